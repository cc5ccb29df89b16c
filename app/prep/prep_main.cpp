// palpa-prep: prepares an organ mesh for palpation (repair, close, orient,
// remesh to a uniform edge, spatial order) and reports what it did.

#include "mesh/io.h"
#include "mesh/organ.h"
#include "prep/prep.h"
#include "scenario/scenario.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <string_view>

namespace {

using namespace palpa;

constexpr const char* kUsage =
    "usage: palpa-prep IN OUT [--unit U] [--edge-mm L | --probe-radius-mm R] [--lesion-radius-mm A | --scenario S]\n"
    "                  [--report FILE.json]\n"
    "                  [--repaired FILE] [--fit-rounds N] [--feature-angle DEG] [--refine-rounds N]\n"
    "                  [--no-cache] [--cache-dir DIR] [--quiet]\n"
    "  IN                 any mesh Palpa reads (.obj .stl .ply .off .vtk .vtp .trian)\n"
    "  OUT                the prepared mesh, in metres (.ply .obj .stl); load it with unit 1\n"
    "  --unit U           file unit of IN: m, cm, mm, auto (default: guessed from the size) or metres per unit (1e-3)\n"
    "  --edge-mm L        target edge length, mm\n"
    "  --probe-radius-mm R  probe tip radius, mm (default 8); the edge is R/4, at most 1/40 of the organ's diagonal\n"
    "  --lesion-radius-mm A  the smallest lesion to resolve, mm: the edge is also at most A/2 (not with --edge-mm)\n"
    "  --scenario S       take A from scenario S: its smallest lesion semi-axis (or random lesion radius)\n"
    "  --fit-rounds N     while the Hausdorff or volume target is missed, shorten the edge by 3/4 and remesh,\n"
    "                     at most N times (default 3; never past 400000 triangles; 0: keep the edge)\n"
    "  --feature-angle DEG  edges whose faces turn by more than DEG stay sharp creases, their vertices\n"
    "                     pinned to them (default 60; 0: none)\n"
    "  --refine-rounds N  rounds of local refinement where a feature is thinner than the edge (default %d;\n"
    "                     each refines with 0.6 x the previous edge, at the cost of a less uniform edge)\n"
    "  --report FILE      also write the report as JSON\n"
    "  --repaired FILE    also write the repaired surface before remeshing (metres; implies --no-cache)\n"
    "  --no-cache         prepare even when the cache has this input with these parameters\n"
    "  --cache-dir DIR    the cache folder (default $PALPA_PREP_CACHE, $XDG_CACHE_HOME/palpa/prep or ~/.cache/palpa/prep)\n"
    "  --quiet            no progress lines\n";

// A progress line was started ("[k/n] step ...") and not ended yet.
bool g_progress_line_open = false;

int usage_error(const std::string& what) {
  std::fprintf(stderr, "palpa-prep: %s\n", what.c_str());
  std::fprintf(stderr, kUsage, palpa::prep::PrepOptions{}.refine_rounds);
  return 2;
}

// A positive finite number, or false.
bool parse_positive(const std::string& s, double& out) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || *end != '\0' || !(v > 0) || v > 1e300) return false;
  out = v;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> pos;
  prep::PrepOptions opt;
  std::string report_path, cache_dir, repaired_path;
  bool use_cache = true, quiet = false, edge_given = false, radius_given = false, lesion_given = false;
  std::string scenario_path;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](std::string& v) {
      if (i + 1 >= argc) return false;
      v = argv[++i];
      return true;
    };
    std::string v;
    if (a == "--help" || a == "-h") {
      std::printf(kUsage, prep::PrepOptions{}.refine_rounds);
      return 0;
    } else if (a == "--unit") {
      if (!value(v)) return usage_error("--unit needs a unit");
      double u = 0;
      if (parse_positive(v, u)) {
        opt.unit_m = u;
      } else {
        try {
          opt.unit_m = mesh::unit_metres(mesh::parse_mesh_unit(v));
        } catch (const std::exception& e) {
          return usage_error(std::string("--unit: ") + e.what());
        }
      }
    } else if (a == "--edge-mm") {
      if (!value(v) || !parse_positive(v, opt.edge_m)) return usage_error("--edge-mm needs a positive length in mm");
      opt.edge_m *= 1e-3;
      edge_given = true;
    } else if (a == "--probe-radius-mm") {
      if (!value(v) || !parse_positive(v, opt.probe_radius_m))
        return usage_error("--probe-radius-mm needs a positive length in mm");
      opt.probe_radius_m *= 1e-3;
      radius_given = true;
    } else if (a == "--lesion-radius-mm") {
      if (!value(v) || !parse_positive(v, opt.lesion_radius_m) || opt.lesion_radius_m > 100)
        return usage_error("--lesion-radius-mm needs a positive length in mm, at most 100");
      opt.lesion_radius_m *= 1e-3;
      lesion_given = true;
    } else if (a == "--scenario") {
      if (!value(scenario_path)) return usage_error("--scenario needs a scenario file");
    } else if (a == "--feature-angle") {
      if (!value(v) || (v != "0" && !parse_positive(v, opt.feature_angle_deg)) || opt.feature_angle_deg > 180)
        return usage_error("--feature-angle needs an angle in degrees from 0 to 180");
      if (v == "0") opt.feature_angle_deg = 0;
    } else if (a == "--fit-rounds") {
      double n = 0;
      if (!value(v) || (v != "0" && !parse_positive(v, n)) || n > 10 || n != std::floor(n))
        return usage_error("--fit-rounds needs a whole number from 0 to 10");
      opt.fit_rounds = static_cast<int>(n);
    } else if (a == "--refine-rounds") {
      double n = 0;
      if (!value(v) || (v != "0" && !parse_positive(v, n)) || n > 10 || n != std::floor(n))
        return usage_error("--refine-rounds needs a whole number from 0 to 10");
      opt.refine_rounds = static_cast<int>(n);
    } else if (a == "--repaired") {
      if (!value(repaired_path)) return usage_error("--repaired needs a file name");
    } else if (a == "--report") {
      if (!value(report_path)) return usage_error("--report needs a file name");
    } else if (a == "--cache-dir") {
      if (!value(cache_dir)) return usage_error("--cache-dir needs a folder");
    } else if (a == "--no-cache") {
      use_cache = false;
    } else if (a == "--quiet") {
      quiet = true;
    } else if (!a.empty() && a[0] == '-') {
      return usage_error("unknown option " + a);
    } else {
      pos.push_back(a);
    }
  }
  if (pos.size() != 2) return usage_error("needs an input and an output file");
  if (edge_given && radius_given) return usage_error("give --edge-mm or --probe-radius-mm, not both");
  if (lesion_given && !scenario_path.empty()) return usage_error("give --lesion-radius-mm or --scenario, not both");
  if (edge_given && (lesion_given || !scenario_path.empty()))
    return usage_error("--lesion-radius-mm and --scenario choose the edge with the probe radius; --edge-mm gives it");
  if (!scenario_path.empty()) {
    try {
      opt.lesion_radius_m = scenario::smallest_lesion_radius(scenario::load_scenario(scenario_path));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "palpa-prep: %s\n", e.what());
      return 1;
    }
    if (!quiet) {
      if (opt.lesion_radius_m > 0)
        std::printf("%s: smallest lesion radius %.3g mm\n", scenario_path.c_str(), opt.lesion_radius_m * 1e3);
      else
        std::printf("%s: no lesions; the edge follows the probe radius\n", scenario_path.c_str());
    }
  }

  // Progress: one line per step as it starts, its time when it ends.
  if (!quiet)
    opt.progress = [](std::string_view step, int index, int count, double fraction) {
      static std::chrono::steady_clock::time_point t0;
      if (step == "cache hit") {
        std::fprintf(stderr, "cache hit: the prepared mesh is loaded from the cache\n");
      } else if (fraction == 0) {
        t0 = std::chrono::steady_clock::now();
        std::fprintf(stderr, "[%d/%d] %.*s ...", index + 1, count, static_cast<int>(step.size()), step.data());
        g_progress_line_open = true;
      } else {
        std::fprintf(stderr, " %.2f s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        g_progress_line_open = false;
      }
      std::fflush(stderr);
    };

  mesh::SurfaceMesh repaired;
  if (!repaired_path.empty()) {
    opt.repaired = &repaired;
    use_cache = false;
  }
  try {
    prep::PrepReport report;
    const mesh::SurfaceMesh out =
        use_cache ? prep::prepare_cached(pos[0], opt, &report,
                                         cache_dir.empty() ? prep::default_cache_dir() : std::filesystem::path(cache_dir))
                  : prep::prepare_file(pos[0], opt, &report);
    mesh::save_mesh(out, pos[1]);
    if (!repaired_path.empty()) mesh::save_mesh(repaired, repaired_path);
    if (!report_path.empty()) {
      const std::string text = prep::report_json(report);
      const std::string tmp = report_path + ".palpa-tmp";
      std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
      f << text;
      f.close();
      if (!f || std::rename(tmp.c_str(), report_path.c_str()) != 0) {
        std::fprintf(stderr, "palpa-prep: %s: cannot be written\n", report_path.c_str());
        return 1;
      }
    }
    std::fputs(prep::report_text(report).c_str(), stdout);
    std::printf("wrote %s (%zu vertices, %zu triangles, metres)\n", pos[1].c_str(), out.vertex_count(),
                out.triangle_count());
    return 0;
  } catch (const std::exception& e) {
    if (g_progress_line_open) std::fputs(" failed\n", stderr);
    std::fprintf(stderr, "palpa-prep: %s\n", e.what());
    return 1;
  }
}
