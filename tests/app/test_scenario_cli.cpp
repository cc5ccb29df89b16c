// palpa-palpate --scenario --indent --depths --json on a flat patch and on a
// curved organ: the force-depth curve against Hertz's formula; and a render
// with and without a hidden lesion: pixel-identical at rest and pressed.

#include "app/render/render_job.h"
#include "common/test_support.h"
#include "mesh/generate.h"
#include "mesh/io.h"
#include "scenario/scenario.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>

namespace palpa::app {
namespace {

scenario::Scenario flat_case(const std::filesystem::path& organ) {
  scenario::Scenario s;
  s.title = "calibration";
  s.organ.path = organ.filename().string();
  s.organ.unit = "m";
  tissue::Tissue t;
  t.name = "gel";
  t.youngs_modulus = 6000;
  t.poisson = 0.45;
  s.tissues = {t};
  s.base_tissue = "gel";
  return s;
}

std::vector<std::pair<double, double>> press(const std::filesystem::path& dir, const scenario::Scenario& s,
                                             const std::string& at, const std::string& depths) {
  const auto file = dir / "case.json";
  scenario::save_scenario(s, file);
  const auto out = dir / "press.json";
  const std::string cmd = std::string(PALPA_PALPATE) + " --scenario " + file.string() + " --indent " + at +
                          " --depths " + depths + " --json " + out.string() + " > " + (dir / "log.txt").string();
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(out);
  const auto j = nlohmann::json::parse(in);
  std::vector<std::pair<double, double>> r;
  for (const auto& rec : j) {
    EXPECT_TRUE(rec.contains("surface_point_m"));
    r.emplace_back(rec.at("depth_m").get<double>(), rec.at("force_n").get<double>());
  }
  return r;
}

double hertz(double e, double nu, double radius, double d) {
  return 4.0 / 3.0 * e / (1 - nu * nu) * std::sqrt(radius) * std::pow(d, 1.5);
}

TEST(IndentCli, AFlatPatchFollowsHertzWithinTenPercent) {
  const auto dir = test::temp_dir("indent_flat");
  mesh::save_mesh(mesh::make_plane(121, 121, 0.001), dir / "patch.ply");
  const auto r = press(dir, flat_case(dir / "patch.ply"), "0,0,0.01", "0.001:0.01:0.001");
  ASSERT_EQ(r.size(), 10u);
  for (const auto& [d, f] : r) EXPECT_NEAR(f / hertz(6000, 0.45, 0.008, d), 1.0, 0.10) << d;
}

TEST(IndentCli, ACurvedOrganFollowsHertzUpToAFifthOfItsThickness) {
  // A 40 mm sphere: 80 mm thick along the inward normal, so up to 16 mm.
  const auto dir = test::temp_dir("indent_curved");
  mesh::save_mesh(mesh::make_sphere(20000, 0.04), dir / "ball.ply");
  const auto r = press(dir, flat_case(dir / "ball.ply"), "0,0,0.1", "0.001:0.016:0.003");
  ASSERT_EQ(r.size(), 6u);
  for (const auto& [d, f] : r) EXPECT_NEAR(f / hertz(6000, 0.45, 0.008, d), 1.0, 0.10) << d;
}

std::string bytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(HiddenLesion, LeavesThePictureUnchangedAtRestAndPressed) {
  const auto dir = test::temp_dir("hidden_lesion");
  scenario::Scenario s;
  s.title = "hidden";
  s.organ.path = "default";
  s.organ.unit = "m";
  tissue::Tissue t;
  t.name = "liver";
  s.tissues = {t};
  s.base_tissue = "liver";
  scenario::Scenario with = s;
  scenario::LesionSpec l;
  l.lesion.name = "nodule";
  l.lesion.semi_axes = Vec3::Constant(0.008);
  l.lesion.modulus_ratio = 6;
  l.from_surface = true;
  l.surface_point = Vec3(0.03, 0, 0.06);
  l.depth = 0.012;
  with.lesions = {l};
  scenario::save_scenario(s, dir / "plain.json");
  scenario::save_scenario(with, dir / "with.json");
  for (double depth : {0.0, 0.008}) {
    std::vector<std::string> paths;
    for (const char* name : {"plain", "with"}) {
      RenderJobOptions o;
      o.scenario = dir / (std::string(name) + ".json");
      o.output = dir / (std::string(name) + std::to_string(depth) + ".png");
      o.width = 320;
      o.height = 240;
      o.settle_time = 0.3;
      o.backend = render::GlBackend::OSMesa;
      o.probes = {{Vec3(0.03, 0, 0.06), depth}};
      std::ostringstream log;
      const RenderJobResult r = run_render_job(o, log);
      EXPECT_EQ(r.lesions_drawn, 0u);
      paths.push_back(o.output.string());
    }
    const std::string a = bytes(paths[0]), b = bytes(paths[1]);
    ASSERT_GT(a.size(), 1000u);
    EXPECT_TRUE(a == b) << "depth " << depth << ": the renders differ";
  }
  // Revealed, the lesion is drawn and the picture changes.
  RenderJobOptions o;
  o.scenario = dir / "with.json";
  o.output = dir / "revealed.png";
  o.width = 320;
  o.height = 240;
  o.settle_time = 0.3;
  o.backend = render::GlBackend::OSMesa;
  o.reveal = true;
  std::ostringstream log;
  EXPECT_EQ(run_render_job(o, log).lesions_drawn, 1u);
}

}  // namespace
}  // namespace palpa::app
