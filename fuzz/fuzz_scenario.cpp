// libFuzzer target: the scenario file (docs/SCENARIO.md) through
// load_scenario, then what a session does with an accepted one. The input is
// written as "input.json" beside a small sphere organ "organ.ply" (50 mm
// across) that seeds may name, so the organ, region files and lesion placement
// all run. ScenarioError and mesh::MeshError are the expected answers to bad
// input; anything else (a crash, a sanitizer report, another exception, a
// hang, unbounded memory) is a finding, and so is an accepted scenario that
// does not survive a save and reload unchanged (the file format's promise).

#include "mesh/generate.h"
#include "mesh/io.h"
#include "scenario/resolve.h"
#include "scenario/scenario.h"

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace {

// A private folder for this process's files (in memory when /dev/shm exists).
const std::filesystem::path& folder() {
  static const std::filesystem::path dir = [] {
    std::string base = std::filesystem::exists("/dev/shm") ? "/dev/shm" : "/tmp";
    std::string tmpl = base + "/palpa-fuzz-scenario-XXXXXX";
    if (!::mkdtemp(tmpl.data())) std::abort();
    return std::filesystem::path(tmpl);
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // 642 vertices, radius 25 (file units: the seeds say "unit": "mm").
  palpa::mesh::save_mesh(palpa::mesh::make_sphere(642, 25.0), folder() / "organ.ply");
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path path = folder() / "input.json";
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  palpa::scenario::Scenario s;
  try {
    s = palpa::scenario::load_scenario(path);
  } catch (const palpa::scenario::ScenarioError&) {
    return 0;
  } catch (const palpa::mesh::MeshError&) {
    return 0;
  }
  // Accepted: its text must load again to the same text (load-save-load is byte-identical).
  const std::string text = palpa::scenario::to_json_text(s);
  try {
    const auto again = palpa::scenario::parse_scenario(text, path);
    if (palpa::scenario::to_json_text(again) != text) {
      std::fprintf(stderr, "fuzz_scenario: the saved text of an accepted scenario changes on reload\n");
      std::abort();
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_scenario: the saved text of an accepted scenario does not load: %s\n", e.what());
    std::abort();
  }
  // The bundled organ is large; resolve only scenarios on the fuzz organ.
  // An organ to prepare (organ.prep) takes seconds and writes prep's cache:
  // its parsing and round trip are fuzzed above, its preparation is not.
  if (s.organ.path == "default" || s.organ.prep) return 0;
  try {
    const auto r = palpa::scenario::resolve(s);
    (void)palpa::scenario::session_model(r, palpa::scenario::core_config(r));
  } catch (const palpa::scenario::ScenarioError&) {
  } catch (const palpa::mesh::MeshError&) {
  }
  return 0;
}
