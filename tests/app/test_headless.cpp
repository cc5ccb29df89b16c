// `palpa` with no display: it says so and still does its job (palpates the
// default organ, or runs `palpa FILE.json` as `palpa render --scenario`
// would, and writes a PNG; a file that does not open is named). Runs the
// real executable with DISPLAY unset.

#include "common/test_support.h"
#include "render/image.h"

#include <array>
#include <cstdio>
#include <string>

namespace {

// Runs a shell command, returns stdout+stderr and the exit status.
std::string run(const std::string& command, int* status) {
  std::string out;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return "(popen failed)";
  std::array<char, 4096> buf{};
  while (std::fgets(buf.data(), buf.size(), pipe)) out += buf.data();
  const int rc = pclose(pipe);
  *status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  return out;
}

TEST(PalpaHeadless, SaysThereIsNoDisplayAndWritesThePicture) {
  const auto dir = palpa::test::temp_dir("palpa_headless");
  int status = 0;
  const std::string out = run("cd '" + dir.string() + "' && env -u DISPLAY -u WAYLAND_DISPLAY '" PALPA_EXE
                              "' --size 320x240 --settle 0.3",
                              &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("palpa: no display (DISPLAY is not set), so no window; running headless instead"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("wrote palpa-headless.png"), std::string::npos) << out;
  const palpa::render::Image img = palpa::render::read_png(dir / "palpa-headless.png");
  EXPECT_EQ(img.width, 320);
  EXPECT_EQ(img.height, 240);
  long organ = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) organ += img.grey(x, y) > 60;
  EXPECT_GT(organ, img.width * img.height / 8) << "the organ is not in the picture";
}

TEST(PalpaHeadless, AScenarioFileRunsHeadlessAsRenderScenarioWould) {
  const auto dir = palpa::test::temp_dir("palpa_headless_scenario");
  const auto file = palpa::test::project_data_dir() / "scenarios" / "liver_tumour.json";
  int status = 0;
  const std::string out = run("cd '" + dir.string() + "' && env -u DISPLAY -u WAYLAND_DISPLAY '" PALPA_EXE "' '" +
                                  file.string() + "' --size 240x180 --settle 0.2",
                              &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("running headless instead: running the scenario " + file.string()), std::string::npos) << out;
  EXPECT_NE(out.find("as palpa render --scenario " + file.string() + " would"), std::string::npos) << out;
  EXPECT_NE(out.find("wrote palpa-headless.png"), std::string::npos) << out;
  const palpa::render::Image img = palpa::render::read_png(dir / "palpa-headless.png");
  EXPECT_EQ(img.width, 240);
  EXPECT_EQ(img.height, 180);
}

TEST(PalpaHeadless, AFileThatDoesNotOpenIsNamed) {
  const auto dir = palpa::test::temp_dir("palpa_headless_bad_file");
  int status = 0;
  const std::string missing = (dir / "missing.json").string();
  std::string out = run("env -u DISPLAY -u WAYLAND_DISPLAY '" PALPA_EXE "' '" + missing + "'", &status);
  EXPECT_EQ(status, 1) << out;
  EXPECT_NE(out.find("palpa: " + missing + ": "), std::string::npos) << out;
  const std::string mesh = (dir / "missing.ply").string();
  out = run("env -u DISPLAY -u WAYLAND_DISPLAY '" PALPA_EXE "' '" + mesh + "'", &status);
  EXPECT_EQ(status, 1) << out;
  EXPECT_NE(out.find(mesh), std::string::npos) << out;
}

TEST(PalpaHeadless, RefusesOSMesaBecauseItIsNotLinkedFirst) {
  // The Qt workbench keeps libGL's entry points for its window; the error
  // tells the user what to do instead.
  int status = 0;
  const std::string out =
      run("env -u DISPLAY '" PALPA_EXE "' render --gl osmesa --output /nonexistent/x.png", &status);
  EXPECT_EQ(status, 1);
  EXPECT_NE(out.find("palpa: OSMesa backend: libOSMesa is not linked into this executable"), std::string::npos)
      << out;
}

TEST(PalpaHeadless, BadOptionIsNamed) {
  int status = 0;
  const std::string out = run("env -u DISPLAY '" PALPA_EXE "' --size 3", &status);
  EXPECT_EQ(status, 1);
  EXPECT_NE(out.find("palpa: --size: expected WxH with 16..8192 pixels each, got '3'"), std::string::npos) << out;
}

}  // namespace
