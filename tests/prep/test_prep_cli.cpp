// palpa-prep on the command line: exit status, messages, the files it writes.

#include "common/test_support.h"
#include "mesh/generate.h"
#include "mesh/io.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <sys/wait.h>

namespace palpa::prep {
namespace {

struct ToolRun {
  int status = -1;
  std::string output;  // stdout and stderr
};

ToolRun run(const std::string& args) {
  ToolRun r;
  const std::string cmd = std::string(PALPA_PREP_BIN) + " " + args + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) r.output.append(buf, n);
  const int st = ::pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

TEST(PrepCli, PreparesWritesAndReports) {
  const auto dir = test::temp_dir("prep_cli");
  const auto in = dir / "sphere.ply", out = dir / "out.obj", report = dir / "report.json";
  mesh::save_mesh(mesh::make_sphere(600, 0.03), in);
  const ToolRun r = run(in.string() + " " + out.string() + " --unit m --edge-mm 4 --fit-rounds 0 --no-cache --report " +
                    report.string());
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("[1/11] repair soup ..."), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("targets (closed, manifold, outward, CV <= 0.2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("all met"), std::string::npos) << r.output;
  const mesh::SurfaceMesh m = mesh::load_mesh(out);
  EXPECT_TRUE(mesh::analyse(m).closed());
  std::ifstream f(report);
  const std::string json{std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
  EXPECT_NE(json.find("\"format\": \"palpa.prep-report\""), std::string::npos);
}

// --scenario takes the smallest lesion radius from a scenario (the shipped
// breast's nodules have radii 6 and 4 mm): with a 16 mm probe the probe's
// rule alone gives 4 mm, the smaller nodule 2 mm.
TEST(PrepCli, TheScenariosSmallestLesionChoosesTheEdge) {
  const auto dir = test::temp_dir("prep_cli_lesion");
  const auto in = dir / "sphere.ply", out = dir / "out.ply";
  mesh::save_mesh(mesh::make_sphere(600, 0.03), in);
  const auto scenario = test::project_data_dir() / "scenarios" / "breast_two_nodules.json";
  const ToolRun r = run(in.string() + " " + out.string() + " --unit m --probe-radius-mm 16 --scenario " +
                        scenario.string() + " --fit-rounds 0 --no-cache");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find(scenario.string() + ": smallest lesion radius 4 mm"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("edge target   2 mm (half the smallest lesion's radius 4 mm, shorter than a quarter of the "
                          "probe radius 16 mm)"),
            std::string::npos)
      << r.output;
  const ToolRun bad = run(in.string() + " " + out.string() + " --unit m --scenario " + (dir / "none.json").string());
  EXPECT_EQ(bad.status, 1);
  EXPECT_NE(bad.output.find("none.json"), std::string::npos) << bad.output;
}

TEST(PrepCli, RefusesAnOpenSheetNamingTheFile) {
  const auto dir = test::temp_dir("prep_cli_sheet");
  const auto in = dir / "sheet.ply";
  mesh::save_mesh(mesh::make_plane(5, 5, 0.01), in);
  const ToolRun r = run(in.string() + " " + (dir / "out.ply").string() + " --unit m --no-cache --quiet");
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.output, "palpa-prep: " + in.string() +
                          ": cannot make a closed surface: hole 1 of 1 (16 boundary edges, perimeter 160 mm) would "
                          "be 50% of the surface (the limit is 20%); the input is an open sheet, not a closed organ "
                          "with holes\n");
  EXPECT_FALSE(std::filesystem::exists(dir / "out.ply"));
}

TEST(PrepCli, BadArgumentsSayWhy) {
  ToolRun r = run("a.ply b.ply --edge-mm 2 --probe-radius-mm 8");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.output.substr(0, r.output.find('\n')), "palpa-prep: give --edge-mm or --probe-radius-mm, not both");
  r = run("a.ply");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.output.substr(0, r.output.find('\n')), "palpa-prep: needs an input and an output file");
  r = run("a.ply b.ply --edge-mm 2 --lesion-radius-mm 3");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.output.substr(0, r.output.find('\n')),
            "palpa-prep: --lesion-radius-mm and --scenario choose the edge with the probe radius; --edge-mm gives it");
  r = run("a.ply b.ply --lesion-radius-mm 3 --scenario s.json");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.output.substr(0, r.output.find('\n')), "palpa-prep: give --lesion-radius-mm or --scenario, not both");
  r = run("a.ply b.ply --unit furlong");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.output.substr(0, r.output.find('\n')),
            "palpa-prep: --unit: unknown mesh unit 'furlong' (expected auto, m, cm or mm)");
}

}  // namespace
}  // namespace palpa::prep
