// palpa-bench: the core benchmark of Palpa. On generated spheres and on the
// shared organs, with 1 and 3 probes sliding over the surface along a seeded
// trajectory at 1 kHz, it measures
//   - the haptic tick (haptics::haptic_tick) latency,
//   - our contact query as the tick runs it (collision::query_contact: the
//     in-contact walk from the last triangle, the tree's local search when not
//     in contact) against the tree's local search alone, a full query of our
//     tree, CGAL's AABB tree (with and without hint) and brute force, each
//     followed by the contact interpolation,
//   - one deformation step (active set and full mesh) against memcpy bandwidth,
//   - a 1M-vertex tissue map: evaluated, applied, and stepped against a
//     uniform material (palpa_bench_tissue.cpp),
// prints tables with the targets next to the figures and optionally writes the
// records as JSON. It is a benchmark, not a test: it never fails on a figure.

#include "collision/contact.h"
#include "collision/vertex_tree.h"
#include "deform/surface.h"
#include "haptics/cpu_plan.h"
#include "haptics/probe_tick.h"
#include "haptics/session.h"
#include "mesh/generate.h"
#include "mesh/spatial_order.h"
#include "mesh/io.h"
#include "palpa_bench_cgal.h"
#include "palpa_bench_meshes.h"
#include "palpa_bench_path.h"
#include "palpa_bench_replica.h"
#include "palpa_bench_fallback.h"
#include "palpa_bench_hover.h"
#include "palpa_bench_query_loop.h"
#include "palpa_bench_tissue.h"
#include "palpa_bench_util.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace {

using namespace palpa;
using bench::Clock;
using bench::elapsed_ns;
using bench::Latency;
using nlohmann::json;
namespace fs = std::filesystem;

// ---------------------------------------------------------------------------
// Fixed scenario (SI units).
constexpr double kSphereRadius = 0.1;     // m: an organ-sized test sphere
constexpr double kTickPeriod = 1e-3;      // s: 1 kHz haptic ticks
constexpr double kProbeSpeed = 0.03;      // m/s sliding speed
constexpr double kProbeDepth = 1e-3;      // m below the undeformed surface
constexpr double kShapeRadius = 0.015;    // m: Wendland support radius of each contact
constexpr int kMaxProbes = 3;
constexpr std::size_t kDeformEvery = 2;   // ticks per DeformableSurface::step: 500 Hz, the loop's default deform rate
constexpr double kDeformPeriod = kDeformEvery * kTickPeriod;  // s
constexpr std::size_t kDirtyEvery = 16;   // ticks between take_dirty_ranges (a ~60 Hz renderer)

// Targets of the issue, printed next to the figures.
constexpr double kTargetTickP99Us = 3.0;       // at 1M vertices, 3 probes
constexpr double kTargetGrowth = 1.5;          // tick p99 from 10k to 1M vertices
constexpr double kTargetFlatness = 2.0;        // tick p99 of the fan and sliver spheres over the even one
constexpr double kTargetQuerySpeedup = 3.0;    // cgal_hint / local at p50 and p99
constexpr double kTargetCopyFraction = 0.5;    // step_full vs memcpy
constexpr int kHeldSteps = 600;                // active steps with the contacts held still (1.2 s at 2 ms)
constexpr std::size_t kHeldFrom = 500;         // ticks of the paths before the probes are held still
constexpr std::size_t kHeldTicks = 3500;       // ticks with the probes held still (3.5 s)
constexpr std::size_t kHeldEarly = 1500;       // the held ticks' first window starts here (1.5 s) ...
constexpr std::size_t kHeldWindow = 500;       // ... and each window, the last ending at kHeldTicks, is this long
static_assert(kHeldEarly + kHeldWindow <= kHeldTicks - kHeldWindow, "the two windows of held ticks overlap");

// ---------------------------------------------------------------------------
// Command line.
struct Options {
  bool quick = false;
  std::string json_path;
  fs::path shared_dir = PALPA_BENCH_SHARED_ORGANS_DIR;
  std::size_t ticks = 0;  // timed ticks per run; 0 = mode default
  std::uint64_t seed = 20240601;
  double organ_unit_m = 0;  // > 0: every organ file is in this unit (e.g. 1 for palpa-prep's output)
  bool spheres = true;
  bool tissue_map_only = false;
  bool hover_only = false;  // only the hovering section
  bool threaded = true;  // also the tick with the step on another thread (3 probes)
  bool threaded_both = false;  // ... with both replicas stepped (before issue 8)
  bool threaded_warm = true;   // ... warming during the spin before each tick, as HapticLoop
  bool threaded_hold = true;   // ... and reading the replica held from the warm-up at the deadline
  double threaded_spin_us = -1;  // ... spinning this long before each tick (-1: the workbench's plan)
  bool threaded_place = true;    // ... on a CPU of its own, the step on the others, as the workbench
  bool spatial_order = true;   // mesh::reorder_spatially, as load_organ numbers every organ
  std::string only;      // only meshes whose name contains this
  int repeat = 1;        // contact queries: runs of each method's path, least time per query kept
  int query_loop = 0;    // > 0: only track_contact along the paths, this many passes (--query-loop)
  int same_phase_blocks = 0;  // > 0: only targets 3 and 4 interleaved, the meshes in turn in blocks (--same-phase)
};

void print_usage() {
  std::printf(
      "usage: palpa-bench [--quick] [--json FILE] [--shared-data DIR] [--organ-unit U] [--no-spheres]\n"
      "                   [--ticks N] [--seed N] [--repeat N] [--tissue-map] [--hover] [--query-loop N]\n"
      "                   [--same-phase N] [--only TEXT] [--no-threaded] (further options below)\n"
      "  --quick            reduced set (spheres 10k, 100k, 1M; fewer ticks; no brute force above 100k)\n"
      "  --json FILE        also write the records as a JSON array to FILE\n"
      "  --shared-data DIR  folder of shared organ meshes (default %s)\n"
      "  --organ-unit U     metres per file unit of every organ (e.g. 1 for meshes palpa-prep wrote);\n"
      "                     default: the SOURCES.md units (cm for sofa_liver-smooth.obj, else mm)\n"
      "  --no-spheres       organs only\n"
      "  --ticks N          timed ticks per run (default 50000, quick 3000)\n"
      "  --seed N           trajectory seed (default 20240601)\n"
      "  --repeat N         contact queries only: run each method's path N times from the same start\n"
      "                     and keep each query's least time (takes the machine's interruptions out of\n"
      "                     both sides of a comparison; default 1: every query timed once)\n"
      "  --tissue-map       only the 1M-vertex tissue-map section (evaluate, apply, step vs uniform)\n"
      "  --hover            only the hovering section (1M-vertex organ, palpa-loop-bench's paths, a tree\n"
      "                     that knows the surface against one built from positions alone)\n"
      "  --threaded-both    the threaded run steps both replicas (as before issue 8) instead of level_with\n"
      "  --no-threaded      skip the paced run with the deformation step on another thread\n"
      "  --no-warm          in that run, spin before each tick without the loop's warm-up\n"
      "                     (LoopConfig::warm_before_tick)\n"
      "  --no-hold          in that run, no held warm-up at the spin's deadline: the tick takes the\n"
      "                     current replica itself (the warm-up as before the hold, for comparison)\n"
      "  --spin-us US       in that run, spin US microseconds before each tick (at most 85%% of the\n"
      "                     period) instead of the workbench's plan for a kept CPU (haptics::plan_haptic_spin)\n"
      "  --no-placement     in that run, no CPU kept for the ticking thread (the workbench keeps one,\n"
      "                     haptics::reserve_haptic_cpu): both threads where the scheduler puts them\n"
      "  --as-built-order   keep each mesh's vertex order as generated or read (before issue 8's\n"
      "                     spatial order; load_organ numbers organs along a Hilbert curve)\n"
      "  --only TEXT        only the meshes whose name contains TEXT (=NAME: only the mesh NAME)\n"
      "  --query-loop N     only the tick's contact query (track_contact) along each mesh's paths, 1 and 3\n"
      "                     probes, N passes with nothing else in the loop: its time per query and a hash\n"
      "                     of the answers' bits (for profilers, e.g. callgrind collecting only in\n"
      "                     'palpa::collision::track_contact*', and to check that a change keeps the answers)\n"
      "  --same-phase N     only targets 3 and 4 on the interleaved run (the ticks' first command's paths\n"
      "                     and steps): the 10k and 1M spheres and the 1M fan and sliver spheres, each\n"
      "                     run cut into N blocks run in turn, so that all meet the same phases of the\n"
      "                     machine; the first tenth of each block (at most 100 ticks) runs untimed\n",
      PALPA_BENCH_SHARED_ORGANS_DIR);
}

// Parses argv; returns an error message or nothing.
std::optional<std::string> parse_options(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](std::string& out) -> bool {
      if (i + 1 >= argc) return false;
      out = argv[++i];
      return true;
    };
    auto number = [&](const std::string& name, std::uint64_t& out) -> std::optional<std::string> {
      std::string v;
      if (!value(v)) return name + " needs a value";
      char* end = nullptr;
      out = std::strtoull(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0') return name + ": '" + v + "' is not a non-negative integer";
      return std::nullopt;
    };
    if (a == "--quick") {
      o.quick = true;
    } else if (a == "--json") {
      if (!value(o.json_path)) return std::string("--json needs a file name");
    } else if (a == "--shared-data") {
      std::string d;
      if (!value(d)) return std::string("--shared-data needs a folder");
      o.shared_dir = d;
    } else if (a == "--organ-unit") {
      std::string v;
      if (!value(v)) return std::string("--organ-unit needs metres per file unit");
      char* end = nullptr;
      o.organ_unit_m = std::strtod(v.c_str(), &end);
      if (v.empty() || *end != '\0' || !(o.organ_unit_m > 0)) return "--organ-unit: '" + v + "' is not a positive number";
    } else if (a == "--no-spheres") {
      o.spheres = false;
    } else if (a == "--ticks") {
      std::uint64_t n = 0;
      if (auto e = number("--ticks", n)) return e;
      if (n < 100) return std::string("--ticks: at least 100 ticks are needed for percentiles");
      o.ticks = n;
    } else if (a == "--threaded-both") {
      o.threaded_both = true;
    } else if (a == "--no-threaded") {
      o.threaded = false;
    } else if (a == "--no-warm") {
      o.threaded_warm = false;
    } else if (a == "--no-hold") {
      o.threaded_hold = false;
    } else if (a == "--no-placement") {
      o.threaded_place = false;
    } else if (a == "--spin-us") {
      std::uint64_t n = 0;
      if (auto e = number("--spin-us", n)) return e;
      // The spin leaves the thread asleep for haptics::kHapticMinSleepShare
      // of the period, as plan_haptic_spin caps it.
      const auto most = static_cast<std::uint64_t>((1 - haptics::kHapticMinSleepShare) * kTickPeriod * 1e6 + 0.5);
      if (n > most)
        return "--spin-us: " + std::to_string(n) + " us is more than " + std::to_string(most) + " us, " +
               std::to_string(static_cast<int>((1 - haptics::kHapticMinSleepShare) * 100 + 0.5)) + "% of the " +
               std::to_string(static_cast<int>(kTickPeriod * 1e6 + 0.5)) + " us period";
      o.threaded_spin_us = static_cast<double>(n);
    } else if (a == "--as-built-order") {
      o.spatial_order = false;
    } else if (a == "--only") {
      if (!value(o.only)) return std::string("--only needs part of a mesh name");
    } else if (a == "--tissue-map") {
      o.tissue_map_only = true;
    } else if (a == "--hover") {
      o.hover_only = true;
    } else if (a == "--seed") {
      if (auto e = number("--seed", o.seed)) return e;
    } else if (a == "--repeat") {
      std::uint64_t n = 0;
      if (auto e = number("--repeat", n)) return e;
      if (n < 1 || n > 100) return "--repeat: " + std::to_string(n) + " runs is outside 1 to 100";
      o.repeat = static_cast<int>(n);
    } else if (a == "--query-loop") {
      std::uint64_t n = 0;
      if (auto e = number("--query-loop", n)) return e;
      if (n < 1 || n > 1000) return "--query-loop: " + std::to_string(n) + " passes is outside 1 to 1000";
      o.query_loop = static_cast<int>(n);
    } else if (a == "--same-phase") {
      std::uint64_t n = 0;
      if (auto e = number("--same-phase", n)) return e;
      if (n < 1 || n > 1000) return "--same-phase: " + std::to_string(n) + " blocks is outside 1 to 1000";
      o.same_phase_blocks = static_cast<int>(n);
    } else if (a == "--help" || a == "-h") {
      print_usage();
      std::exit(0);
    } else {
      return "unknown option '" + a + "'";
    }
  }
  if (o.tissue_map_only + o.hover_only + (o.query_loop > 0) + (o.same_phase_blocks > 0) > 1)
    return "--tissue-map, --hover, --query-loop and --same-phase each run only their own section: give one";
  return std::nullopt;
}

// What one run measures, derived from the mode.
struct Plan {
  std::vector<std::size_t> spheres;
  std::size_t ticks = 0;          // timed ticks per (mesh, probes)
  std::size_t warmup = 0;         // untimed ticks before them
  std::size_t brute_max_vertices = 0;  // brute force skipped above this
  double brute_budget = 0;        // vertex visits allowed per (mesh, probes): limits samples
  int full_step_reps = 0;         // step_full / memcpy repetitions (at least)
  double full_step_seconds = 0;   // and about this long
};

Plan make_plan(const Options& o) {
  Plan p;
  if (o.quick) {
    p.spheres = {10'000, 100'000, 1'000'000};
    p.ticks = 3000;
    p.warmup = 300;
    p.brute_max_vertices = 100'000;
    p.brute_budget = 3e8;
    p.full_step_reps = 3;
    p.full_step_seconds = 0.05;
  } else {
    p.spheres = {10'000, 100'000, 1'000'000, 2'000'000};
    p.ticks = 50000;
    p.warmup = 2000;
    p.brute_max_vertices = ~std::size_t{0};
    p.brute_budget = 2e9;
    p.full_step_reps = 5;
    p.full_step_seconds = 0.3;
  }
  if (o.ticks) p.ticks = o.ticks;
  return p;
}

// ---------------------------------------------------------------------------
// Meshes: generated spheres and the shared organs.
struct MeshCase {
  std::string name;
  std::string source;            // "make_sphere" or the file name
  std::size_t sphere_target = 0; // > 0: generated sphere
  std::string generator;         // "fan" or "sliver": the sphere made hard on the contact query
  fs::path file;                 // organ file
  double unit_m = 1.0;           // organ file unit, m
};

// Length unit of a shared organ file, from SOURCES.md: the SOFA smooth liver
// is in centimetres; the others are in millimetres (stated or mm-like extents).
double organ_unit_m(const fs::path& file) {
  return file.filename() == "sofa_liver-smooth.obj" ? 1e-2 : 1e-3;
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Lists the organ meshes of the shared folder (sorted), saying what is skipped.
std::vector<MeshCase> organ_cases(const fs::path& dir, double unit_override_m) {
  std::vector<MeshCase> cases;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    std::printf("shared organs: %s not found -- organs skipped, running spheres only\n", dir.string().c_str());
    return cases;
  }
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.is_regular_file()) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  // Every format the loader reads; a mesh stored twice (the same stem in two
  // formats, like sofa_coeur1.off and .trian) is measured once.
  const auto readable = [](const std::string& ext) {
    return ext == ".obj" || ext == ".stl" || ext == ".ply" || ext == ".off" || ext == ".vtk" || ext == ".vtp" ||
           ext == ".trian";
  };
  for (const auto& f : files) {
    const std::string ext = lower(f.extension().string());
    if (readable(ext)) {
      const auto same = std::find_if(cases.begin(), cases.end(),
                                     [&](const MeshCase& c) { return c.name == f.stem().string(); });
      if (same != cases.end()) {
        std::printf("shared organs: %s skipped (the same mesh as %s)\n", f.filename().string().c_str(),
                    same->source.c_str());
        continue;
      }
      MeshCase c;
      c.name = f.stem().string();
      c.source = f.filename().string();
      c.file = f;
      c.unit_m = unit_override_m > 0 ? unit_override_m : organ_unit_m(f);
      cases.push_back(c);
    } else if (ext != ".md" && ext != ".mtl" && ext != ".txt") {
      std::printf("shared organs: %s skipped (not a mesh format the loader reads)\n", f.filename().string().c_str());
    }
  }
  std::printf("shared organs: %zu meshes in %s\n", cases.size(), dir.string().c_str());
  return cases;
}

std::string sphere_name(std::size_t n) {
  return "sphere-" + (n >= 1'000'000 ? std::to_string(n / 1'000'000) + "M" : std::to_string(n / 1000) + "k");
}

// A generated sphere of about n vertices: even (generator empty), or made
// hard on the contact query with high-valence fans ("fan") or slivers
// ("sliver"), as many vertices as the even one.
MeshCase generated_case(std::size_t n, const std::string& generator) {
  MeshCase c;
  c.name = generator.empty() ? sphere_name(n) : generator + "-" + sphere_name(n);
  c.source = "make_" + (generator.empty() ? std::string() : generator + "_") + "sphere";
  c.sphere_target = n;
  c.generator = generator;
  return c;
}

// ---------------------------------------------------------------------------
// Records and table rows.
struct TickRow {
  std::string mesh;
  std::size_t vertices = 0;
  int probes = 0;
  Latency tick;
  double contact_fraction = 0;
  double walk_fraction = 0;  // probe ticks answered by the in-contact walk
};

struct QueryRow {
  std::string mesh;
  std::size_t vertices = 0;
  int probes = 0;
  std::string method;
  Latency lat;          // per probe query
  std::string note;     // sampling / agreement
};

struct StepRow {
  std::string mesh;
  std::size_t vertices = 0;
  int probes = 0;
  std::string method;
  double vertices_per_step = 0;
  double vertices_per_s = 0;
  double bytes_per_step = 0;  // counted as described at kStateBytes
  double bytes_per_s = 0;
  double copy_bytes_per_s = 0;
  double fraction = 0;
};

struct ReplicaRow {
  std::string mesh;
  std::size_t vertices = 0;
  bench::ReplicaStepFigures f;
};

struct ThreadRow {
  std::string mesh;
  std::size_t vertices = 0;
  bench::ThreadedFigures f;
};

struct Results {
  std::vector<ReplicaRow> replicas;
  std::vector<ThreadRow> threaded;
  std::vector<TickRow> ticks;
  std::vector<QueryRow> queries;
  std::vector<StepRow> steps;
  json records = json::array();
};

json latency_json(const Latency& l) {
  return {{"p50_us", l.p50_us}, {"p99_us", l.p99_us}, {"p999_us", l.p999_us},
          {"max_us", l.max_us}, {"mean_us", l.mean_us}, {"samples", l.samples}};
}

// The non-zero counts of a bench::WalkEndCounts, by the end's printed name.
json walk_end_counts_json(const bench::WalkEndCounts& counts) {
  json d = json::object();
  for (std::size_t e = 0; e < counts.size(); ++e)
    if (counts[e]) d[bench::walk_end_name(e)] = counts[e];
  return d;
}

// ---------------------------------------------------------------------------
// Bytes counted for the copy-bandwidth figure, from the public state only
// (SurfaceState::vertices, sizeof(VertexState) = 24 B: h, v, q):
//   full pass:   24 B read for every vertex (a full pass must look at each
//                vertex's state) + 24 B written for each vertex left moving
//                (active_count() after the step);
//   active step: 24 B read + 24 B written per active vertex.
// Nothing else is counted (flags, material index, force, correction, the
// stream, vertices that came to rest this step), so the step's figure is a
// lower bound. The copy figure: memcpy of an array of 24 B per mesh vertex
// into another, which moves 48 B per vertex (24 read + 24 written); its
// bandwidth counts read + written bytes. fraction = step B/s / copy B/s.
constexpr int kStateBytes = static_cast<int>(sizeof(deform::VertexState));

// ---------------------------------------------------------------------------
// Timing harness for queries: the same points, the same order, one timed call
// per probe per tick. Ticks [warm_begin, timed_begin) run untimed first
// (carrying cursors and hints on); then ticks timed_begin, timed_begin +
// stride, ... are timed (stride > 1 only for brute force).
struct Answer {
  Index vertex = kNoIndex;    // nearest vertex (ours, brute); kNoIndex for CGAL
  double distance_sq = 0;     // squared distance to it, m^2 (ours, brute)
  Vec3 point = Vec3::Zero();  // our contact point or CGAL's closest point, m
};

template <class Query>
std::vector<double> time_queries(const bench::ProbePaths& paths, int probes, std::size_t warm_begin,
                                 std::size_t timed_begin, std::size_t stride, Query&& query,
                                 std::vector<Answer>& answers) {
  for (std::size_t k = warm_begin; k < timed_begin; ++k) {
    for (int p = 0; p < probes; ++p) answers.push_back(query(p, paths.at(k, p)));
  }
  answers.clear();
  std::vector<double> ns;
  ns.reserve((paths.ticks - timed_begin) / stride * probes + probes);
  for (std::size_t k = timed_begin; k < paths.ticks; k += stride) {
    for (int p = 0; p < probes; ++p) {
      const Vec3& q = paths.at(k, p);
      const auto t0 = Clock::now();
      const Answer a = query(p, q);
      const auto t1 = Clock::now();
      ns.push_back(elapsed_ns(t0, t1));
      answers.push_back(a);
    }
  }
  return ns;
}

// time_queries run `repeat` times, each after `reset` (which puts the
// method's cursors, hints and counters back to their start), keeping each
// query's least time: the same queries in the same states every run, so the
// least is the query's cost without the machine's interruptions. The
// answers are the last run's (every run gives the same).
template <class Reset, class Query>
std::vector<double> time_queries_least(int repeat, Reset&& reset, const bench::ProbePaths& paths, int probes,
                                       std::size_t warm_begin, std::size_t timed_begin, std::size_t stride,
                                       Query&& query, std::vector<Answer>& answers) {
  std::vector<double> least;
  for (int r = 0; r < repeat; ++r) {
    reset();
    std::vector<double> ns = time_queries(paths, probes, warm_begin, timed_begin, stride, query, answers);
    if (r == 0) {
      least = std::move(ns);
    } else {
      for (std::size_t i = 0; i < least.size() && i < ns.size(); ++i) least[i] = std::min(least[i], ns[i]);
    }
  }
  return least;
}

// A case's mesh, generated or read, in spatial order unless the options
// say otherwise.
std::shared_ptr<mesh::SurfaceMesh> build_mesh(const MeshCase& mc, const Options& opt) {
  std::shared_ptr<mesh::SurfaceMesh> m;
  if (mc.generator == "fan") {
    // 40 fans of hundreds of thin triangles each (15 mm disks; about 22% of the sphere).
    m = std::make_shared<mesh::SurfaceMesh>(bench::make_fan_sphere(mc.sphere_target, kSphereRadius, 40, 0.015));
  } else if (mc.generator == "sliver") {
    m = std::make_shared<mesh::SurfaceMesh>(bench::make_sliver_sphere(mc.sphere_target, kSphereRadius));
  } else if (mc.sphere_target) {
    m = std::make_shared<mesh::SurfaceMesh>(mesh::make_sphere(mc.sphere_target, kSphereRadius));
  } else {
    mesh::LoadOptions lo;
    lo.unit_m = mc.unit_m;
    lo.keep_largest_component = true;  // sofa_liver.vtk carries three tiny specks
    m = std::make_shared<mesh::SurfaceMesh>(mesh::load_mesh(mc.file, lo));
  }
  if (opt.spatial_order) mesh::reorder_spatially(*m);
  return m;
}

// The probes' paths of every run: kMaxProbes probes (the 1-probe runs
// use probe 0's) for the plan's warm-up and timed ticks, sliding at
// kProbeSpeed kProbeDepth below the surface, from the run's seed.
bench::PathOptions path_options(const Plan& plan, const Options& opt) {
  bench::PathOptions po;
  po.probes = kMaxProbes;
  po.ticks = plan.warmup + plan.ticks;
  po.dt = kTickPeriod;
  po.speed = kProbeSpeed;
  po.depth = kProbeDepth;
  po.seed = opt.seed;
  return po;
}

// The session model of the interleaved run: this mesh and tree, 1 kHz
// ticks, a deformation step every kDeformEvery ticks, Wendland contacts of
// radius kShapeRadius, the default force parameters.
std::shared_ptr<haptics::SessionModel> bench_model(const std::shared_ptr<mesh::SurfaceMesh>& m,
                                                   const std::shared_ptr<const collision::VertexTree>& tree) {
  auto model = std::make_shared<haptics::SessionModel>();
  model->mesh = m;
  model->tree = tree;
  model->config.rate_hz = 1.0 / kTickPeriod;
  model->config.deform_rate_hz = 1.0 / kDeformPeriod;
  model->config.shape.kind = deform::ShapeKind::Wendland;
  model->config.shape.radius = kShapeRadius;
  model->config.force = haptics::ForceParams{};
  model->config.velocity_cutoff_hz = 1e4;  // the paths are smooth: velocity by plain finite difference
  return model;
}

// ---------------------------------------------------------------------------
// The interleaved run: a session of `probes` probes on a model, its ticks
// timed on this thread with a deformation step every kDeformEvery ticks
// after them (Session::deform, also on this thread, timed apart), the ticks
// split by what happened in them. run() may be called for consecutive
// ranges of ticks: the session goes on where the last range stopped.
class InterleavedTicks {
 public:
  InterleavedTicks(const std::shared_ptr<haptics::SessionModel>& model, std::size_t vertices, int probes,
                   bool keep_requests)
      : session(model, deform::MaterialArrays::uniform(vertices, deform::Material{}), setups_for(probes)),
        probes_(probes),
        keep_requests_(keep_requests) {}

  // Ticks k of paths in [from, to), timed (and their steps) where k >= timed_from.
  void run(const bench::ProbePaths& paths, std::size_t from, std::size_t to, std::size_t timed_from) {
    deform::DeformableSurface& surface = session.surface();
    const int probes = probes_;
    for (std::size_t k = from; k < to && k < paths.ticks; ++k) {
      const double t = static_cast<double>(k) * kTickPeriod;
      for (int p = 0; p < probes; ++p) {
        inputs_[p].sample = haptics::position_sample(paths.at(k, p), k + 1, t);
      }
      std::array<Index, kMaxProbes> triangle_before{}, ring_vertex_before{};
      std::array<int, kMaxProbes> ring_stage_before{};
      for (int p = 0; p < probes; ++p) {
        const haptics::ProbeMemory& pm = session.core().state().memory[p];
        triangle_before[p] = pm.cursor.triangle;
        ring_vertex_before[p] = pm.ring_vertex;
        ring_stage_before[p] = pm.ring_stage;
      }
      const auto a = Clock::now();
      const bool due = session.tick(t, std::span<const haptics::ProbeTickInput>(inputs_.data(), probes),
                                    std::span<haptics::ProbeTickResult>(results_.data(), probes));
      const auto b = Clock::now();
      const bool after_step = stepped_;
      stepped_ = due;
      if (k >= timed_from) {
        const double ns = elapsed_ns(a, b);
        tick_ns.push_back(ns);
        (after_step ? tick_after_step_ns : tick_other_ns).push_back(ns);
        int slowest = 0;  // 0 walk, 1 proxy, 2 tree
        for (int p = 0; p < probes; ++p) {
          const auto path = static_cast<collision::ContactPath>(results_[p].path);
          contact_ticks += results_[p].in_contact;
          walk_ticks += path == collision::ContactPath::Walk;
          if (path == collision::ContactPath::Tree) {
            slowest = 2;
          } else if (path == collision::ContactPath::Proxy) {
            slowest = std::max(slowest, 1);
          }
        }
        tick_by_path[slowest].push_back(ns);
        bool crossed = false, cornered = false, ring = false;
        for (int p = 0; p < probes; ++p) {
          const haptics::ProbeMemory& pm = session.core().state().memory[p];
          ring |= pm.ring_vertex != ring_vertex_before[p] || pm.ring_stage != ring_stage_before[p];
          const Index now = pm.cursor.triangle, before = triangle_before[p];
          if (now == before) continue;
          crossed = true;
          // Past a corner: into a triangle that shares no edge with the last.
          const mesh::SurfaceMesh& m = surface.mesh();
          if (before < m.triangle_neighbors.size() && now != kNoIndex) {
            const auto& across = m.triangle_neighbors[before];
            cornered |= std::find(across.begin(), across.end(), now) == across.end();
          }
        }
        (crossed ? tick_cross_ns : tick_stay_ns).push_back(ns);
        if (cornered) tick_corner_ns.push_back(ns);
        if (!crossed) (ring ? tick_ring_ns : tick_quiet_ns).push_back(ns);
        if (!crossed && !ring) (after_step ? tick_quiet_after_step_ns : tick_quiet_later_ns).push_back(ns);
      }
      if (due) {
        if (keep_requests_) requests.push_back(session.core().request());
        const auto c = Clock::now();
        session.deform(session.core().request());
        const auto d = Clock::now();
        if (k >= timed_from) {
          step_ns.push_back(elapsed_ns(c, d));
          active_sum += static_cast<double>(surface.active_count());
        }
      }
      if (k % kDirtyEvery == 0) (void)surface.take_dirty_ranges();
    }
  }

  // After ticks [0, at) of paths (run()), the probes held still at their
  // points of tick at - 1 for `ticks` more ticks, with the steps between
  // them as in run(); returns each tick's duration (ns). The device reads
  // the same position every tick, so the filtered velocity decays
  // geometrically towards zero.
  std::vector<double> hold(const bench::ProbePaths& paths, std::size_t at, std::size_t ticks) {
    std::vector<double> ns;
    ns.reserve(ticks);
    const std::size_t last = at - 1;
    for (std::size_t j = 0; j < ticks; ++j) {
      const std::size_t k = at + j;
      const double t = static_cast<double>(k) * kTickPeriod;
      for (int p = 0; p < probes_; ++p) inputs_[p].sample = haptics::position_sample(paths.at(last, p), k + 1, t);
      const auto a = Clock::now();
      const bool due = session.tick(t, std::span<const haptics::ProbeTickInput>(inputs_.data(), probes_),
                                    std::span<haptics::ProbeTickResult>(results_.data(), probes_));
      ns.push_back(elapsed_ns(a, Clock::now()));
      stepped_ = due;
      if (due) session.deform(session.core().request());
      if (k % kDirtyEvery == 0) (void)session.surface().take_dirty_ranges();
    }
    return ns;
  }

  haptics::Session session;
  // Ticks, and ticks split by whether a step ran just before them on this thread.
  std::vector<double> tick_ns, step_ns, tick_after_step_ns, tick_other_ns;
  // Ticks split by whether a probe's contact triangle changed in them (a
  // crossing: the walk prepares a new triangle, so the tick's cost grows
  // with how many triangles a probe crosses per second, that is with the
  // mesh's density along the path).
  std::vector<double> tick_cross_ns, tick_stay_ns;
  // Of those, the ticks where a probe passed a corner of its triangle
  // (the walk steps at least twice).
  std::vector<double> tick_corner_ns;
  // The ticks without a crossing, split by whether a probe's fetch of the
  // ring round its nearest corner (ProbeMemory::ring_vertex) moved on in
  // them: a new corner, or one more stage. Their share grows with the
  // mesh's density along the path, as the crossings' does.
  std::vector<double> tick_ring_ns, tick_quiet_ns;
  // The quiet ones again, split by whether a step ran just before them.
  std::vector<double> tick_quiet_after_step_ns, tick_quiet_later_ns;
  // Ticks split by the slowest contact path any probe took (walk < proxy < tree).
  std::array<std::vector<double>, 3> tick_by_path;
  double active_sum = 0;                          // active vertices summed over the timed steps
  std::size_t contact_ticks = 0, walk_ticks = 0;  // probe-ticks in contact, answered by the walk
  std::vector<haptics::DeformRequest> requests;   // each step's request (keep_requests)

 private:
  static std::vector<haptics::ProbeSetup> setups_for(int probes) {
    std::vector<haptics::ProbeSetup> setups(static_cast<std::size_t>(probes));
    for (auto& su : setups) {
      su.name = "bench probe";
      su.spec.position_dof = 3;  // no force output: the model's force, no safety ramp
      su.safety.max_jump = 1e3;
    }
    return setups;
  }
  int probes_;
  bool keep_requests_;
  bool stepped_ = false;
  std::array<haptics::ProbeTickInput, kMaxProbes> inputs_{};
  std::array<haptics::ProbeTickResult, kMaxProbes> results_{};
};

// ---------------------------------------------------------------------------
// --same-phase: targets 3 and 4 on the interleaved run, with the meshes'
// runs cut into blocks run in turn (the 10k sphere, the 1M sphere, its fan
// and sliver twins), so that every mesh's ticks meet the same phases of
// the machine: on a shared VM the same run's p99 moves by 2x from minute
// to minute, and the full bench runs these meshes a minute or more apart.
// Each block's first tenth (at most 100 ticks) runs untimed: the mesh
// before it has just used the caches. The figures are each mesh's pooled
// timed ticks, and each round of blocks' ratios.
void run_same_phase(const Plan& plan, const Options& opt, Results& res) {
  struct Case {
    std::string name;
    std::shared_ptr<mesh::SurfaceMesh> mesh;
    std::shared_ptr<haptics::SessionModel> model;
    std::optional<bench::ProbePaths> paths;
  };
  const std::array<MeshCase, 4> made = {generated_case(10'000, ""), generated_case(1'000'000, ""),
                                        generated_case(1'000'000, "fan"), generated_case(1'000'000, "sliver")};
  std::array<Case, 4> cases;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    Case& c = cases[i];
    c.name = made[i].name;
    c.mesh = build_mesh(made[i], opt);
    const auto tree = std::make_shared<const collision::VertexTree>(*c.mesh);
    const bench::CgalClosestPoint cgal(*c.mesh);
    c.paths.emplace(make_probe_paths(*c.mesh, cgal, path_options(plan, opt)));
    c.model = bench_model(c.mesh, tree);
  }
  const std::size_t blocks = static_cast<std::size_t>(opt.same_phase_blocks);
  const std::size_t block = std::max<std::size_t>(1, plan.ticks / blocks);
  const std::size_t untimed = std::min<std::size_t>(100, block / 10);
  std::printf("same phase: %zu blocks of %zu ticks per mesh (the first %zu of each untimed), the meshes in turn "
              "(%s, %s, %s, %s); the interleaved run's paths and steps\n",
              blocks, block, untimed, cases[0].name.c_str(), cases[1].name.c_str(), cases[2].name.c_str(),
              cases[3].name.c_str());
  // Ratios of case `num` to case `den`: of the pooled p99s, and each round's.
  struct Ratio {
    const char* what;
    std::size_t num, den;
    double limit;
  };
  const std::array<Ratio, 3> ratios_of = {Ratio{"target 3, p99 growth 10k -> 1M", 1, 0, kTargetGrowth},
                                          Ratio{"target 4, fans over the even sphere", 2, 1, kTargetFlatness},
                                          Ratio{"target 4, slivers over the even sphere", 3, 1, kTargetFlatness}};
  for (int probes : {1, kMaxProbes}) {
    std::array<std::unique_ptr<InterleavedTicks>, 4> runs;
    for (std::size_t i = 0; i < cases.size(); ++i) {
      runs[i] = std::make_unique<InterleavedTicks>(cases[i].model, cases[i].mesh->vertex_count(), probes, false);
      runs[i]->run(*cases[i].paths, 0, plan.warmup, plan.warmup);
    }
    std::array<std::vector<double>, 3> rounds;
    const std::size_t never = ~std::size_t{0};
    for (std::size_t b = 0; b < blocks; ++b) {
      const std::size_t from = plan.warmup + b * block, to = from + block;
      std::array<double, 4> p99{};
      for (std::size_t i = 0; i < cases.size(); ++i) {
        InterleavedTicks& r = *runs[i];
        r.run(*cases[i].paths, from, from + untimed, never);
        const std::size_t before = r.tick_ns.size();
        r.run(*cases[i].paths, from + untimed, to, 0);
        std::vector<double> these(r.tick_ns.begin() + static_cast<std::ptrdiff_t>(before), r.tick_ns.end());
        p99[i] = bench::latency_of(these).p99_us;
      }
      for (std::size_t k = 0; k < ratios_of.size(); ++k)
        if (p99[ratios_of[k].den] > 0) rounds[k].push_back(p99[ratios_of[k].num] / p99[ratios_of[k].den]);
    }
    std::printf("[same phase] %d probe%s, the four sessions made: %s\n", probes, probes == 1 ? "" : "s",
                bench::huge_page_report().c_str());
    json r = {{"section", "same_phase"}, {"probes", probes}, {"blocks", blocks}, {"block_ticks", block},
              {"untimed_per_block", untimed}};
    std::array<Latency, 4> pooled;
    for (std::size_t i = 0; i < cases.size(); ++i) {
      InterleavedTicks& t = *runs[i];
      pooled[i] = bench::latency_of(t.tick_ns);
      const double n = static_cast<double>(std::max<std::size_t>(1, t.tick_ns.size()));
      const Latency cross = bench::latency_of(t.tick_cross_ns), ring = bench::latency_of(t.tick_ring_ns),
                    quiet = bench::latency_of(t.tick_quiet_ns),
                    quiet_after = bench::latency_of(t.tick_quiet_after_step_ns),
                    quiet_later = bench::latency_of(t.tick_quiet_later_ns);
      std::printf("[same phase] %d probe%s, %-16s tick p50 %.3f p99 %.3f p99.9 %.3f us (%zu ticks); with a crossing "
                  "%.1f%% p99 %.3f, moving a ring fetch on %.1f%% p99 %.3f, quiet %.1f%% p99 %.3f us (right after a "
                  "step %.3f, a tick later %.3f)\n",
                  probes, probes == 1 ? "" : "s", cases[i].name.c_str(), pooled[i].p50_us, pooled[i].p99_us,
                  pooled[i].p999_us, pooled[i].samples, 100.0 * static_cast<double>(cross.samples) / n, cross.p99_us,
                  100.0 * static_cast<double>(ring.samples) / n, ring.p99_us,
                  100.0 * static_cast<double>(quiet.samples) / n, quiet.p99_us, quiet_after.p99_us,
                  quiet_later.p99_us);
      r[cases[i].name] = latency_json(pooled[i]);
    }
    for (std::size_t k = 0; k < ratios_of.size(); ++k) {
      const Ratio& q = ratios_of[k];
      const double pooled_ratio = pooled[q.den].p99_us > 0 ? pooled[q.num].p99_us / pooled[q.den].p99_us : 0;
      std::vector<double>& v = rounds[k];
      std::sort(v.begin(), v.end());
      const double median = v.empty() ? 0 : v[v.size() / 2];
      std::printf("[same phase] %d probe%s, %s: p99 %.2fx <= %.1fx %s; round by round: median %.2fx, %.2f to %.2fx "
                  "over %zu rounds\n",
                  probes, probes == 1 ? "" : "s", q.what, pooled_ratio, q.limit, pooled_ratio <= q.limit ? "PASS" : "FAIL",
                  median, v.empty() ? 0 : v.front(), v.empty() ? 0 : v.back(), v.size());
      r[q.what] = {{"p99_ratio", pooled_ratio}, {"round_median", median}, {"rounds", v}};
    }
    std::fflush(stdout);
    res.records.push_back(r);
  }
}

// ---------------------------------------------------------------------------
// Everything measured on one mesh.
void run_mesh(const MeshCase& mc, const Plan& plan, const Options& opt, Results& res) {
  // Build the mesh, our tree, CGAL's tree and the deformable surface.
  auto t0 = Clock::now();
  const std::shared_ptr<mesh::SurfaceMesh> m = build_mesh(mc, opt);
  const double t_mesh = elapsed_ns(t0, Clock::now()) * 1e-9;
  const std::size_t V = m->vertex_count();
  t0 = Clock::now();
  const auto tree_ptr = std::make_shared<const collision::VertexTree>(*m);
  const collision::VertexTree& tree = *tree_ptr;
  const double t_tree = elapsed_ns(t0, Clock::now()) * 1e-9;
  t0 = Clock::now();
  const bench::CgalClosestPoint cgal(*m);
  const double t_cgal = elapsed_ns(t0, Clock::now()) * 1e-9;

  // One seeded trajectory of three probes; the 1-probe runs use probe 0's.
  t0 = Clock::now();
  const bench::ProbePaths paths = make_probe_paths(*m, cgal, path_options(plan, opt));
  const double t_path = elapsed_ns(t0, Clock::now()) * 1e-9;
  std::printf("[%s] %zu vertices, %zu triangles (%s): mesh %.2f s, our tree %.2f s, CGAL tree %.2f s, paths %.2f s\n",
              mc.name.c_str(), V, m->triangle_count(), mc.source.c_str(), t_mesh, t_tree, t_cgal, t_path);
  std::fflush(stdout);

  if (opt.query_loop > 0) {
    for (int probes : {1, kMaxProbes}) {
      const bench::QueryLoopResult q = bench::run_query_loop(*m, tree, paths, probes, opt.query_loop);
      std::printf("[%s] %d probe%s: track_contact %zu queries x %d passes, best pass %.1f ns/query, median %.1f; "
                  "answers: walk %zu, proxy %zu, tree %zu, clear %zu; answer hash %016llx\n",
                  mc.name.c_str(), probes, probes == 1 ? "" : "s", q.queries, q.passes, q.best_ns_per_query,
                  q.median_ns_per_query, q.walk, q.proxy, q.tree, q.clear,
                  static_cast<unsigned long long>(q.answer_hash));
      char hex[17];
      std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(q.answer_hash));
      json r = {{"mesh", mc.name}, {"mesh_source", mc.source}, {"vertices", V}, {"triangles", m->triangle_count()},
                {"section", "query_loop"}, {"method", "track"}, {"probes", probes}, {"queries_per_pass", q.queries},
                {"passes", q.passes}, {"best_ns_per_query", q.best_ns_per_query},
                {"median_ns_per_query", q.median_ns_per_query}, {"answer_hash", hex},
                {"walk", q.walk}, {"proxy", q.proxy}, {"tree", q.tree}, {"clear", q.clear}};
      res.records.push_back(r);
    }
    std::fflush(stdout);
    return;
  }

  const auto model = bench_model(m, tree_ptr);
  const json base = {{"mesh", mc.name}, {"mesh_source", mc.source}, {"vertices", V},
                     {"triangles", m->triangle_count()}, {"quick", opt.quick}};

  for (int probes : {1, kMaxProbes}) {
    // ---- Session steps: the haptic tick of every probe (timed: LoopCore::tick,
    // i.e. mapping, input checks, collision, eq. 4) and, every kDeformEvery
    // ticks on this thread, the deformation step (timed for the active-set figure).
    InterleavedTicks run(model, V, probes, probes == kMaxProbes);
    for (auto& v : {&run.tick_ns, &run.step_ns}) v->reserve(plan.ticks);
    run.run(paths, 0, paths.ticks, plan.warmup);
    if (probes == 1) std::printf("[%s] %s\n", mc.name.c_str(), bench::huge_page_report().c_str());
    deform::DeformableSurface& surface = run.session.surface();
    auto& tick_ns = run.tick_ns;
    auto& step_ns = run.step_ns;
    auto& tick_after_step_ns = run.tick_after_step_ns;
    auto& tick_other_ns = run.tick_other_ns;
    auto& tick_cross_ns = run.tick_cross_ns;
    auto& tick_stay_ns = run.tick_stay_ns;
    auto& tick_corner_ns = run.tick_corner_ns;
    auto& tick_ring_ns = run.tick_ring_ns;
    auto& tick_quiet_ns = run.tick_quiet_ns;
    auto& tick_by_path = run.tick_by_path;
    const double active_sum = run.active_sum;
    const std::size_t contact_ticks = run.contact_ticks, walk_ticks = run.walk_ticks;
    const auto& requests = run.requests;
    const bench::Latency after_step = bench::latency_of(tick_after_step_ns);
    const bench::Latency other = bench::latency_of(tick_other_ns);
    const bench::Latency crossing = bench::latency_of(tick_cross_ns);
    const bench::Latency staying = bench::latency_of(tick_stay_ns);
    const bench::Latency cornering = bench::latency_of(tick_corner_ns);
    const bench::Latency ringing = bench::latency_of(tick_ring_ns);
    const bench::Latency quiet = bench::latency_of(tick_quiet_ns);
    auto share = [&](const std::vector<double>& v) {
      return tick_ns.empty() ? 0.0 : 100.0 * static_cast<double>(v.size()) / static_cast<double>(tick_ns.size());
    };
    std::printf("[%s] %d probe%s: ticks where a probe changed triangle (%.1f%%) p50 %.3f p99 %.3f us, the others p50 "
                "%.3f p99 %.3f us; of the first, past a corner of the last triangle (%.2f%%) p50 %.3f p99 %.3f us\n",
                mc.name.c_str(), probes, probes == 1 ? "" : "s", share(tick_cross_ns), crossing.p50_us,
                crossing.p99_us, staying.p50_us, staying.p99_us, share(tick_corner_ns), cornering.p50_us,
                cornering.p99_us);
    std::printf("[%s] %d probe%s: of the others, ticks that moved a probe's ring fetch on (%.1f%%) p50 %.3f p99 %.3f "
                "us, the rest (%.1f%%) p50 %.3f p99 %.3f us\n",
                mc.name.c_str(), probes, probes == 1 ? "" : "s", share(tick_ring_ns), ringing.p50_us, ringing.p99_us,
                share(tick_quiet_ns), quiet.p50_us, quiet.p99_us);
    std::printf("[%s] %d probe%s: ticks right after a step p50 %.3f p99 %.3f us, the others p50 %.3f p99 %.3f us\n",
                mc.name.c_str(), probes, probes == 1 ? "" : "s", after_step.p50_us, after_step.p99_us, other.p50_us,
                other.p99_us);
    const std::array<bench::Latency, 3> by_path = {bench::latency_of(tick_by_path[0]),
                                                   bench::latency_of(tick_by_path[1]),
                                                   bench::latency_of(tick_by_path[2])};
    std::printf("[%s] %d probe%s by path (the slowest any probe took): walk %zu ticks p50 %.3f p99 %.3f us; "
                "proxy %zu p50 %.3f p99 %.3f us; tree %zu p50 %.3f p99 %.3f us\n",
                mc.name.c_str(), probes, probes == 1 ? "" : "s", by_path[0].samples, by_path[0].p50_us,
                by_path[0].p99_us, by_path[1].samples, by_path[1].p50_us, by_path[1].p99_us, by_path[2].samples,
                by_path[2].p50_us, by_path[2].p99_us);
    TickRow tr{mc.name, V, probes, bench::latency_of(tick_ns),
               static_cast<double>(contact_ticks) / (static_cast<double>(plan.ticks) * probes),
               static_cast<double>(walk_ticks) / (static_cast<double>(plan.ticks) * probes)};
    res.ticks.push_back(tr);
    {
      json r = base;
      r.update(latency_json(tr.tick));
      r["suite"] = "tick";
      r["method"] = "local";
      r["probes"] = probes;
      r["contact_fraction"] = tr.contact_fraction;
      r["walk_fraction"] = tr.walk_fraction;
      r["after_step"] = latency_json(after_step);
      r["not_after_step"] = latency_json(other);
      r["triangle_changed"] = latency_json(crossing);
      r["triangle_kept"] = latency_json(staying);
      r["triangle_kept_ring_fetched"] = latency_json(ringing);
      r["triangle_kept_quiet"] = latency_json(quiet);
      r["by_path"] = {{"walk", latency_json(by_path[0])}, {"proxy", latency_json(by_path[1])},
                      {"tree", latency_json(by_path[2])}};
      res.records.push_back(r);
    }

    // ---- The live loop's two replicas (issue 8): both stepped vs one step and a copy.
    if (probes == kMaxProbes) {
      ReplicaRow rr{mc.name, V, bench::measure_replica_steps(*model, requests, 100)};
      std::printf("[%s] replica step, 3 probes: both stepped p50 %.3f p99 %.3f ms; step + level_with p50 %.3f p99 %.3f "
                  "ms (step p50 %.3f, copy p50 %.3f; %.0f changed, %.0f active); replicas equal: %s\n",
                  mc.name.c_str(), rr.f.both.p50_us * 1e-3, rr.f.both.p99_us * 1e-3, rr.f.level.p50_us * 1e-3,
                  rr.f.level.p99_us * 1e-3, rr.f.level_step.p50_us * 1e-3, rr.f.level_copy.p50_us * 1e-3,
                  rr.f.changed_mean, rr.f.active_mean, rr.f.equal ? "yes" : "NO");
      json r = base;
      r["suite"] = "replica_step";
      r["probes"] = probes;
      r["both"] = latency_json(rr.f.both);
      r["level"] = latency_json(rr.f.level);
      r["level_step"] = latency_json(rr.f.level_step);
      r["level_copy"] = latency_json(rr.f.level_copy);
      r["changed_mean"] = rr.f.changed_mean;
      r["active_mean"] = rr.f.active_mean;
      r["equal"] = rr.f.equal;
      res.records.push_back(r);
      res.replicas.push_back(rr);
      if (opt.threaded) {
        // The haptic thread's wait as in the workbench with a CPU kept for it:
        // a spin of haptics::plan_haptic_spin's default (or --spin-us), with the warm-up.
        bench::ThreadedPacing pacing;
        pacing.level = !opt.threaded_both;
        pacing.spin_us = opt.threaded_spin_us >= 0 ? opt.threaded_spin_us
                                                   : haptics::plan_haptic_spin(1 / kTickPeriod, 0, "").spin_us;
        pacing.warm = opt.threaded_warm;
        pacing.hold = opt.threaded_hold;
        pacing.place = opt.threaded_place;
        ThreadRow th{mc.name, V, bench::measure_threaded(model, paths, probes, plan.warmup, plan.ticks, pacing)};
        const double warm_per_tick =
            static_cast<double>(th.f.warm_ups) / static_cast<double>(std::max<std::size_t>(1, plan.warmup + plan.ticks));
        char placed[96] = "threads not placed";
        if (th.f.haptic_cpu >= 0)
          std::snprintf(placed, sizeof placed, "ticks on CPU %d at %s, the step on the others", th.f.haptic_cpu,
                        th.f.realtime ? "SCHED_FIFO" : "normal priority");
        std::printf("[%s] threaded (step on another thread, paced at 1 kHz, spin %.0f us, %.2f warm-ups per tick, %s), "
                    "3 probes: tick p50 %.3f p99 %.3f p99.9 %.3f us; step p50 %.3f p99 %.3f ms (%zu steps, %zu merged); "
                    "%zu tick slots skipped (the thread held up past them)\n",
                    mc.name.c_str(), pacing.spin_us, warm_per_tick, placed, th.f.tick.p50_us, th.f.tick.p99_us,
                    th.f.tick.p999_us, th.f.step.p50_us * 1e-3, th.f.step.p99_us * 1e-3, th.f.steps, th.f.merged,
                    th.f.skipped);
        std::printf("[%s] threaded, 3 probes: ticks on the replica held from the last warm-up %zu p50 %.3f p99 %.3f us "
                    "(%zu with another published during the hold), without a held warm-up %zu p50 %.3f p99 %.3f us; "
                    "a warm-up p50 %.3f p99 %.3f us\n",
                    mc.name.c_str(), th.f.tick_held.samples, th.f.tick_held.p50_us, th.f.tick_held.p99_us,
                    th.f.held_behind, th.f.tick_taken.samples, th.f.tick_taken.p50_us, th.f.tick_taken.p99_us,
                    th.f.warm.p50_us, th.f.warm.p99_us);
        json t = base;
        t.update(latency_json(th.f.tick));
        t["suite"] = "tick_threaded";
        t["probes"] = probes;
        t["step"] = latency_json(th.f.step);
        t["steps"] = th.f.steps;
        t["merged"] = th.f.merged;
        t["spin_us"] = pacing.spin_us;
        t["haptic_cpu"] = th.f.haptic_cpu;
        t["realtime"] = th.f.realtime;
        t["warm_ups_per_tick"] = warm_per_tick;
        t["on_held_replica"] = latency_json(th.f.tick_held);
        t["held_behind"] = th.f.held_behind;
        t["skipped_slots"] = th.f.skipped;
        t["without_held_warm_up"] = latency_json(th.f.tick_taken);
        t["warm_up"] = latency_json(th.f.warm);
        res.records.push_back(t);
        res.threaded.push_back(th);
      }
      std::fflush(stdout);
    }

    // ---- Steps: active set (timed inside the tick loop above) and full mesh,
    // with the last contacts held (their fields built once, as for a probe
    // held still) and with contacts that change every step (fields built
    // every step: the same contacts, their depths alternately one ulp
    // deeper, so the visit is the same work).
    double step_total_s = 0;
    for (double x : step_ns) step_total_s += x * 1e-9;
    const double active_mean = step_ns.empty() ? 0 : active_sum / static_cast<double>(step_ns.size());
    const std::vector<deform::Contact> held(surface.contacts().begin(), surface.contacts().end());
    std::vector<deform::Contact> nudged = held;
    for (auto& c : nudged) c.depth = std::nextafter(c.depth, std::numeric_limits<double>::infinity());
    // The active step with the last contacts held still for kHeldSteps steps,
    // from the state the tick run left (restored afterwards): the vertices in
    // the fields settle, and their velocities decay towards zero through
    // the range where, without the step's flush of subnormal values, every
    // operation on them took a microcode assist (about 0.7 s in).
    {
      const deform::SurfaceState before = surface.state();
      std::vector<double> held_ns;
      held_ns.reserve(kHeldSteps);
      for (int n = 0; n < kHeldSteps; ++n) {
        const auto a = Clock::now();
        surface.step(kDeformPeriod);
        held_ns.push_back(elapsed_ns(a, Clock::now()));
        surface.clear_changes();
      }
      const Latency held_lat = bench::latency_of(held_ns);
      std::printf("[%s] %d probe%s: the active step with the contacts held still, %d steps of %.0f ms: p50 %.1f "
                  "p99 %.1f max %.1f us\n",
                  mc.name.c_str(), probes, probes == 1 ? "" : "s", kHeldSteps, kDeformPeriod * 1e3,
                  held_lat.p50_us, held_lat.p99_us, held_lat.max_us);
      json r = base;
      r.update(latency_json(held_lat));
      r["suite"] = "step_held";
      r["probes"] = probes;
      r["steps"] = kHeldSteps;
      r["dt_s"] = kDeformPeriod;
      res.records.push_back(r);
      surface.restore(before, held);
    }
    auto time_full = [&](bool new_contacts) {
      std::vector<double> seconds;
      double total = 0;
      while ((static_cast<int>(seconds.size()) < plan.full_step_reps || total < plan.full_step_seconds) &&
             seconds.size() < 1000) {
        if (new_contacts) surface.set_contacts(seconds.size() % 2 ? held : nudged);
        const auto a = Clock::now();
        surface.step_full(kDeformPeriod);
        seconds.push_back(elapsed_ns(a, Clock::now()) * 1e-9);
        total += seconds.back();
      }
      surface.set_contacts(held);
      return seconds;
    };
    std::vector<double> full_new_s = time_full(true);
    std::vector<double> full_s = time_full(false);
    const double t_full = bench::median(full_s);
    const double t_full_new = bench::median(full_new_s);
    const double moving_after_full = static_cast<double>(surface.active_count());
    const double dV = static_cast<double>(V);
    const double t_copy = bench::median_memcpy_seconds(static_cast<std::size_t>(kStateBytes) * V,
                                                       plan.full_step_reps, plan.full_step_seconds);
    const double copy_bw = 2.0 * kStateBytes * dV / t_copy;
    const double active_vps = step_total_s > 0 ? active_sum / step_total_s : 0;
    const double active_bytes_per_step = 2.0 * kStateBytes * active_mean;
    const double full_bytes_per_step = kStateBytes * (dV + moving_after_full);
    const double full_vps = dV / t_full;
    const double active_bw = step_total_s > 0 ? 2.0 * kStateBytes * active_sum / step_total_s : 0;
    const double full_bw = full_bytes_per_step / t_full;
    const double full_new_bw = full_bytes_per_step / t_full_new;
    const std::array<StepRow, 3> srows = {{
        {mc.name, V, probes, "active", active_mean, active_vps, active_bytes_per_step, active_bw, copy_bw,
         active_bw / copy_bw},
        {mc.name, V, probes, "full", dV, full_vps, full_bytes_per_step, full_bw, copy_bw, full_bw / copy_bw},
        {mc.name, V, probes, "full_new", dV, dV / t_full_new, full_bytes_per_step, full_new_bw, copy_bw,
         full_new_bw / copy_bw},
    }};
    for (const auto& s : srows) {
      res.steps.push_back(s);
      json r = base;
      r["suite"] = "step";
      r["method"] = s.method;
      r["probes"] = probes;
      r["vertices_per_step"] = s.vertices_per_step;
      r["vertices_per_s"] = s.vertices_per_s;
      r["bytes_per_step"] = s.bytes_per_step;
      r["step_bytes_per_s"] = s.bytes_per_s;
      r["copy_bytes"] = 2.0 * kStateBytes * dV;
      r["copy_bytes_per_s"] = s.copy_bytes_per_s;
      r["fraction_of_copy_bandwidth"] = s.fraction;
      r["steps"] = s.method == "full" ? full_s.size() : (s.method == "full_new" ? full_new_s.size() : step_ns.size());
      r["dt_s"] = kDeformPeriod;
      res.records.push_back(r);
    }

    // ---- Contact queries: every method on the same points in the same order.
    // local: query_contact, the contact query ("in contact" = the last
    // answer lay below the undeformed surface, as the tick's height check
    // says on a surface at rest); track: track_contact with the same verdict,
    // what the haptic tick calls (query_contact out of contact; in contact
    // the walk, or the proxy where the walk declines); tree_local: the
    // tree's local search alone.
    std::array<collision::ContactCursor, kMaxProbes> contact_cursors{};
    std::array<bool, kMaxProbes> touching{};
    std::array<collision::SearchCursor, kMaxProbes> cursors{};
    std::array<Vec3, kMaxProbes> hints{};  // CGAL's hints: each probe's first closest point (reset_hints)
    const auto& mesh_ref = *m;
    std::size_t local_walks = 0;
    auto local = [&](int p, const Vec3& q) {
      const auto ca = collision::query_contact(mesh_ref, tree, q, contact_cursors[p], touching[p]);
      touching[p] = ca.surface.triangle != kNoIndex && ca.surface.offset < 0;
      local_walks += ca.path == collision::ContactPath::Walk;
      return Answer{ca.nearest_vertex, (mesh_ref.positions[ca.nearest_vertex] - q).squaredNorm(), ca.surface.point};
    };
    std::array<collision::ContactCursor, kMaxProbes> track_cursors{};
    std::array<bool, kMaxProbes> track_touching{};
    std::size_t track_walks = 0, track_proxies = 0;
    auto track = [&](int p, const Vec3& q) {
      const auto ca = collision::track_contact(mesh_ref, tree, q, track_cursors[p], track_touching[p]);
      track_touching[p] = ca.surface.triangle != kNoIndex && ca.surface.offset < 0;
      track_walks += ca.path == collision::ContactPath::Walk;
      track_proxies += ca.path == collision::ContactPath::Proxy;
      return Answer{ca.nearest_vertex, (mesh_ref.positions[ca.nearest_vertex] - q).squaredNorm(), ca.surface.point};
    };
    auto tree_local = [&](int p, const Vec3& q) {
      const auto nv = tree.nearest_local(q, cursors[p]);
      const auto sp = collision::locate_surface_point(mesh_ref, q, nv.vertex);
      return Answer{nv.vertex, nv.distance_sq, sp.point};
    };
    auto full = [&](int, const Vec3& q) {
      const auto nv = tree.nearest(q);
      const auto sp = collision::locate_surface_point(mesh_ref, q, nv.vertex);
      return Answer{nv.vertex, nv.distance_sq, sp.point};
    };
    auto cgal_plain = [&](int, const Vec3& q) {
      return Answer{kNoIndex, 0, cgal.closest_point(q)};
    };
    auto cgal_hint = [&](int p, const Vec3& q) {
      const Vec3 c = cgal.closest_point(q, hints[p]);
      hints[p] = c;
      return Answer{kNoIndex, 0, c};
    };
    auto brute = [&](int, const Vec3& q) {
      const auto nv = collision::nearest_brute_force(mesh_ref.positions, q);
      const auto sp = collision::locate_surface_point(mesh_ref, q, nv.vertex);
      return Answer{nv.vertex, nv.distance_sq, sp.point};
    };
    std::vector<Answer> a_local, a_tree_local, a_full, a_cgal, a_hint, a_brute;
    std::map<std::string, std::vector<double>> ns;
    // Each method from its start state (cursors, hints, counters), opt.repeat times.
    const auto none = [] {};
    const int rep = opt.repeat;
    const auto reset_local = [&] {
      contact_cursors = {};
      touching = {};
      local_walks = 0;
    };
    ns["local"] = time_queries_least(rep, reset_local, paths, probes, 0, plan.warmup, 1, local, a_local);
    const double walk_share = static_cast<double>(local_walks) / static_cast<double>(paths.ticks * probes);
    // Why the walk declined on the queries that went to the tree, and what
    // the tree path's parts cost (an untimed replay; the query times are
    // the ones just taken).
    const bench::TreePathSplit split =
        bench::split_tree_path(mesh_ref, tree, paths, probes, 0, plan.warmup, ns["local"]);
    std::vector<Answer> a_track;
    const auto reset_track = [&] {
      track_cursors = {};
      track_touching = {};
      track_walks = 0;
      track_proxies = 0;
    };
    ns["track"] = time_queries_least(rep, reset_track, paths, probes, 0, plan.warmup, 1, track, a_track);
    const bench::TrackPathSplit track_split =
        bench::split_track_paths(mesh_ref, tree, paths, probes, 0, plan.warmup, ns["track"]);
    const double track_walk_share = static_cast<double>(track_walks) / static_cast<double>(paths.ticks * probes);
    const double track_proxy_share = static_cast<double>(track_proxies) / static_cast<double>(paths.ticks * probes);
    const auto reset_tree = [&] { cursors = {}; };
    ns["tree_local"] = time_queries_least(rep, reset_tree, paths, probes, 0, plan.warmup, 1, tree_local, a_tree_local);
    ns["full"] = time_queries_least(rep, none, paths, probes, 0, plan.warmup, 1, full, a_full);
    ns["cgal"] = time_queries_least(rep, none, paths, probes, 0, plan.warmup, 1, cgal_plain, a_cgal);
    const auto reset_hints = [&] {
      for (int p = 0; p < probes; ++p) hints[p] = cgal.closest_point(paths.at(0, p));
    };
    ns["cgal_hint"] = time_queries_least(rep, reset_hints, paths, probes, 0, plan.warmup, 1, cgal_hint, a_hint);
    // Diagnostics: the nearest-vertex part alone (no locate_surface_point), same points.
    std::array<collision::SearchCursor, kMaxProbes> cursors2{};
    std::vector<Answer> a_scratch;
    auto nearest_local_only = [&](int p, const Vec3& q) {
      const auto nv = tree.nearest_local(q, cursors2[p]);
      return Answer{nv.vertex, nv.distance_sq, Vec3::Zero()};
    };
    auto nearest_full_only = [&](int, const Vec3& q) {
      const auto nv = tree.nearest(q);
      return Answer{nv.vertex, nv.distance_sq, Vec3::Zero()};
    };
    const auto reset_tree2 = [&] { cursors2 = {}; };
    auto ns_local_only =
        time_queries_least(rep, reset_tree2, paths, probes, 0, plan.warmup, 1, nearest_local_only, a_scratch);
    auto ns_full_only = time_queries_least(rep, none, paths, probes, 0, plan.warmup, 1, nearest_full_only, a_scratch);
    const Latency lat_local_only = bench::latency_of(ns_local_only);
    const Latency lat_full_only = bench::latency_of(ns_full_only);
    // Brute force: skipped or sampled (every stride-th tick) to bound its cost;
    // warmed up on a few ticks just before the timed ones.
    std::size_t stride = 0;
    std::string brute_note;
    if (V > plan.brute_max_vertices) {
      brute_note = "skipped above " + bench::short_count(static_cast<double>(plan.brute_max_vertices)) +
                   " vertices in quick mode";
    } else {
      const double all = static_cast<double>(plan.ticks) * probes * static_cast<double>(V);
      stride = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(all / plan.brute_budget)));
      ns["brute"] = time_queries(paths, probes, plan.warmup - std::min<std::size_t>(plan.warmup, 5), plan.warmup,
                                 stride, brute, a_brute);
    }

    // Agreement checks: local vs full contact point, tree_local vs full
    // nearest vertex (same distance), brute vs full on its samples, cgal_hint
    // vs cgal, and how far our contact point is from CGAL's exact closest
    // point (ours is where the interpolated normal passes through the probe,
    // so it may be slightly farther).
    auto differ = [](double a, double b) { return std::abs(a - b) > 1e-9 * std::max(b, 1e-12); };
    std::size_t local_differ = 0, tree_local_differ = 0, hint_differ = 0, brute_differ = 0;
    std::vector<double> gap;  // |our contact point - CGAL's closest point|, m
    gap.reserve(a_local.size());
    for (std::size_t i = 0; i < a_local.size(); ++i) {
      const Vec3& q = paths.at(plan.warmup + i / probes, static_cast<int>(i % probes));
      local_differ += (a_local[i].point - a_full[i].point).norm() > 1e-9;
      tree_local_differ += differ(a_tree_local[i].distance_sq, a_full[i].distance_sq);
      hint_differ += differ((a_hint[i].point - q).squaredNorm(), (a_cgal[i].point - q).squaredNorm());
      gap.push_back((a_local[i].point - a_cgal[i].point).norm());
    }
    // Brute answer j is tick warmup + (j / probes) * stride, probe j % probes.
    for (std::size_t j = 0; j < a_brute.size(); ++j) {
      const std::size_t i = (j / probes) * stride * probes + j % probes;
      brute_differ += differ(a_brute[j].distance_sq, a_full[i].distance_sq);
    }

    // Gap statistics: latency_of scales its input by 1e-3, so nanometres in give micrometres out.
    for (double& g : gap) g *= 1e9;
    const Latency gap_um = bench::latency_of(gap);
    std::map<std::string, Latency> lat;
    for (auto& [method, v] : ns) lat[method] = bench::latency_of(v);
    const Latency ours = lat["local"];
    for (const char* method : {"local", "track", "tree_local", "full", "cgal", "cgal_hint", "brute"}) {
      if (!ns.count(method)) {
        QueryRow q{mc.name, V, probes, method, {}, brute_note};
        res.queries.push_back(q);
        json r = base;
        r["suite"] = "query";
        r["method"] = method;
        r["probes"] = probes;
        r["skipped"] = brute_note;
        for (const char* f : {"p50_us", "p99_us", "p999_us", "max_us"}) r[f] = nullptr;  // not measured
        r["samples"] = 0;
        res.records.push_back(r);
        continue;
      }
      QueryRow q{mc.name, V, probes, method, lat[method], ""};
      char note[160] = "";
      if (q.method == "local")
        std::snprintf(note, sizeof note,
                      "walk %.1f%%; %zu points differ from full by > 1 nm; |ours-cgal| p99 %.1f max %.1f um",
                      100 * walk_share, local_differ, gap_um.p99_us, gap_um.max_us);
      else if (q.method == "track")
        std::snprintf(note, sizeof note, "the tick's query: walk %.1f%%, proxy %.1f%%", 100 * track_walk_share,
                      100 * track_proxy_share);
      else if (q.method == "tree_local")
        std::snprintf(note, sizeof note, "%zu differ from full; nearest_local alone p50 %.3f p99 %.3f",
                      tree_local_differ, lat_local_only.p50_us, lat_local_only.p99_us);
      else if (q.method == "full")
        std::snprintf(note, sizeof note, "nearest alone p50 %.3f p99 %.3f", lat_full_only.p50_us,
                      lat_full_only.p99_us);
      else if (q.method == "cgal_hint")
        std::snprintf(note, sizeof note, "%zu differ from cgal", hint_differ);
      else if (q.method == "brute")
        std::snprintf(note, sizeof note, "1 in %zu ticks; %zu of %zu differ from full", stride, brute_differ,
                      a_brute.size());
      q.note = note;
      res.queries.push_back(q);
      json r = base;
      r.update(latency_json(q.lat));
      r["suite"] = "query";
      r["method"] = method;
      r["probes"] = probes;
      r["runs_per_query"] = method == std::string("brute") ? 1 : opt.repeat;  // least time kept (--repeat)
      r["p50_ratio_to_local"] = q.lat.p50_us / ours.p50_us;
      r["p99_ratio_to_local"] = q.lat.p99_us / ours.p99_us;
      r["check"] = q.note;
      if (q.method == "brute") r["sample_every_ticks"] = stride;
      if (q.method == "local") {
        r["points_differ_from_full"] = local_differ;
        r["walk_fraction"] = walk_share;
        r["distance_to_cgal_point_p99_um"] = gap_um.p99_us;
        r["distance_to_cgal_point_max_um"] = gap_um.max_us;
      }
      if (q.method == "track") {
        r["walk_fraction"] = track_walk_share;
        r["proxy_fraction"] = track_proxy_share;
      }
      if (q.method == "tree_local") {
        r["differ_from_full"] = tree_local_differ;
        r["nearest_only"] = latency_json(lat_local_only);
      }
      if (q.method == "full") r["nearest_only"] = latency_json(lat_full_only);
      if (q.method == "cgal_hint") r["differ_from_cgal"] = hint_differ;
      if (q.method == "brute") r["differ_from_full"] = brute_differ;
      res.records.push_back(r);
    }
    std::printf("[%s] %d probe%s: tick p99 %.2f us, local query p50 %.3f us, cgal_hint p50 %.3f us, step_full %s vertices/s\n",
                mc.name.c_str(), probes, probes > 1 ? "s" : "", tr.tick.p99_us, ours.p50_us,
                lat["cgal_hint"].p50_us,
                bench::short_count(full_vps).c_str());
    {
      // The local query's tree path (target 3's p99 against CGAL): where
      // it is over 1% of the queries, the query's p99 falls among them.
      const std::string why = bench::walk_end_counts_text(split.declines);
      std::printf("[%s] %d probe%s: local query by path: walk %zu p50 %.3f p99 %.3f us; tree %zu (%.1f%%) p50 %.3f p99 %.3f us, "
                  "%zu of them after the walk declined (%s); the tree path again, warm: nearest_local p50 %.3f p99 %.3f, "
                  "locate_surface_point in the one ring %zu p50 %.3f p99 %.3f, widened %zu p50 %.3f p99 %.3f us\n",
                  mc.name.c_str(), probes, probes > 1 ? "s" : "", split.walk, split.walk_query.p50_us,
                  split.walk_query.p99_us, split.tree,
                  split.queries ? 100.0 * static_cast<double>(split.tree) / static_cast<double>(split.queries) : 0.0,
                  split.tree_query.p50_us, split.tree_query.p99_us, split.tree_in_contact,
                  why.c_str(), split.nearest.p50_us, split.nearest.p99_us,
                  split.locate_ring.samples, split.locate_ring.p50_us, split.locate_ring.p99_us,
                  split.locate_wide.samples, split.locate_wide.p50_us, split.locate_wide.p99_us);
      json r = base;
      r["suite"] = "query_tree_path";
      r["probes"] = probes;
      r["queries"] = split.queries;
      r["walk"] = split.walk;
      r["tree"] = split.tree;
      r["tree_after_declined_walk"] = split.tree_in_contact;
      r["walk_declined"] = walk_end_counts_json(split.declines);
      r["walk_query"] = latency_json(split.walk_query);
      r["tree_query"] = latency_json(split.tree_query);
      r["tree_nearest_warm"] = latency_json(split.nearest);
      r["tree_locate_ring_warm"] = latency_json(split.locate_ring);
      r["tree_locate_widened_warm"] = latency_json(split.locate_wide);
      res.records.push_back(r);
    }
    {
      // The tick's query (track_contact) by path: which of its paths sets
      // its p99 against CGAL's.
      const bench::TrackPathSplit& t = track_split;
      auto part = [](const char* name, const Latency& l) {
        char b[128];
        std::snprintf(b, sizeof b, "%s %zu p50 %.3f p99 %.3f", name, l.samples, l.p50_us, l.p99_us);
        return std::string(b);
      };
      std::printf("[%s] %d probe%s: track query by path (us): %s; %s; %s; %s; %s; the proxy's first walk ended: %s; "
                  "triangles it visited: %.2f on average, %.2f on the slowest tenth of the proxy's queries\n",
                  mc.name.c_str(), probes, probes > 1 ? "s" : "", part("walk", t.walk).c_str(),
                  part("proxy", t.proxy).c_str(), part("proxy let go", t.proxy_released).c_str(),
                  part("tree in contact", t.tree_in_contact).c_str(), part("out of contact", t.out_of_contact).c_str(),
                  bench::walk_end_counts_text(t.proxy_walk_ends).c_str(), t.proxy_walk_triangles,
                  t.proxy_walk_triangles_slowest_tenth);
      json r = base;
      r["suite"] = "query_track_path";
      r["probes"] = probes;
      r["queries"] = t.queries;
      r["walk"] = latency_json(t.walk);
      r["proxy"] = latency_json(t.proxy);
      r["proxy_let_go"] = latency_json(t.proxy_released);
      r["tree_in_contact"] = latency_json(t.tree_in_contact);
      r["out_of_contact"] = latency_json(t.out_of_contact);
      r["proxy_first_walk_ended"] = walk_end_counts_json(t.proxy_walk_ends);
      r["proxy_first_walk_triangles_mean"] = t.proxy_walk_triangles;
      r["proxy_first_walk_triangles_slowest_tenth"] = t.proxy_walk_triangles_slowest_tenth;
      res.records.push_back(r);
    }
    {
      // The probes held still after the first kHeldFrom ticks of their
      // paths, in a session of their own with the loop's default velocity
      // filter (the run above filters at 10 kHz, which lets the velocity
      // reach zero at once): the velocity filtered towards zero entered the
      // subnormal range about 2.6 s in and stayed there before the tick
      // took subnormal values as zero. The two windows are before and after
      // that time.
      auto held_model = std::make_shared<haptics::SessionModel>(*model);
      held_model->config.velocity_cutoff_hz = haptics::CoreConfig{}.velocity_cutoff_hz;
      InterleavedTicks still(held_model, V, probes, false);
      still.run(paths, 0, kHeldFrom, kHeldFrom);
      std::vector<double> held = still.hold(paths, kHeldFrom, kHeldTicks);
      const auto from = [&held](std::size_t tick) { return held.begin() + static_cast<std::ptrdiff_t>(tick); };
      std::vector<double> early(from(kHeldEarly), from(kHeldEarly + kHeldWindow));
      std::vector<double> late(from(kHeldTicks - kHeldWindow), held.end());
      const Latency e = bench::latency_of(early), l = bench::latency_of(late);
      std::printf("[%s] %d probe%s: ticks with the probes held still (velocity filter %.0f Hz), %.1f to %.1f s: "
                  "p50 %.3f p99 %.3f us; %.1f to %.1f s: p50 %.3f p99 %.3f us\n",
                  mc.name.c_str(), probes, probes > 1 ? "s" : "", held_model->config.velocity_cutoff_hz,
                  kHeldEarly * kTickPeriod, (kHeldEarly + kHeldWindow) * kTickPeriod, e.p50_us, e.p99_us,
                  (kHeldTicks - kHeldWindow) * kTickPeriod, kHeldTicks * kTickPeriod, l.p50_us, l.p99_us);
      json r = base;
      r["suite"] = "tick_held";
      r["probes"] = probes;
      r["early"] = latency_json(e);
      r["late"] = latency_json(l);
      r["held_ticks"] = kHeldTicks;
      r["velocity_cutoff_hz"] = held_model->config.velocity_cutoff_hz;
      res.records.push_back(r);
    }
    std::fflush(stdout);
  }
}

// ---------------------------------------------------------------------------
// Tables and targets.
const char* verdict(bool ok) { return ok ? "PASS" : "FAIL"; }

void print_tables(const Results& r, const bench::ClockOverhead& clock, const Options& opt) {
  auto tick_of = [&](const std::string& mesh, int probes) -> const TickRow* {
    for (const auto& t : r.ticks)
      if (t.mesh == mesh && t.probes == probes) return &t;
    return nullptr;
  };

  // Haptic ticks, with the tick targets next to the 1M rows.
  std::printf("\n== Haptic tick (haptics::haptic_tick: collision + interpolation + local model + eq. 4), per tick, us\n"
              "   (DeformableSurface::step runs every %zu ticks on the same thread, between timed ticks)\n",
              kDeformEvery);
  std::printf("%-40s %9s %6s %8s %8s %8s %8s %8s %6s  %s\n", "mesh", "vertices", "probes", "p50", "p99", "p99.9",
              "max", "contact", "walk", "target");
  for (const auto& t : r.ticks) {
    std::string target;
    if (t.mesh == "sphere-1M") {
      char buf[160] = "";  // a 1-probe row without the 10k sphere writes nothing into it
      int n = 0;
      if (t.probes == 3)
        n = std::snprintf(buf, sizeof buf, "p99 <= %.0f us %s; ", kTargetTickP99Us,
                          verdict(t.tick.p99_us <= kTargetTickP99Us));
      if (const TickRow* small = tick_of("sphere-10k", t.probes)) {
        const double g = t.tick.p99_us / small->tick.p99_us;
        std::snprintf(buf + n, sizeof buf - n, "p99 growth from 10k %.2fx <= %.1fx %s", g, kTargetGrowth,
                      verdict(g <= kTargetGrowth));
      }
      target = buf;
    }
    if (t.mesh == "fan-sphere-1M" || t.mesh == "sliver-sphere-1M")
      if (const TickRow* even = tick_of("sphere-1M", t.probes)) {
        char buf[120];
        const double x = t.tick.p99_us / even->tick.p99_us;
        std::snprintf(buf, sizeof buf, "p99 %.2fx sphere-1M's <= 2x %s", x, verdict(x <= kTargetFlatness));
        target = buf;
      }
    std::printf("%-40s %9zu %6d %8.3f %8.3f %8.3f %8.2f %7.0f%% %5.0f%%  %s\n", t.mesh.c_str(), t.vertices,
                t.probes, t.tick.p50_us, t.tick.p99_us, t.tick.p999_us, t.tick.max_us, 100 * t.contact_fraction,
                100 * t.walk_fraction, target.c_str());
  }

  // Contact queries, with ratios to ours and the 3x target on the cgal_hint rows.
  std::printf("\n== Contact query, per probe query, us (x = method / local; local = query_contact: in-contact walk "
              "from the last triangle, else nearest_local + locate_surface_point; track = track_contact, what the "
              "haptic tick calls: query_contact out of contact, in contact the walk or, where the walk declines, the "
              "proxy slid along the surface; tree_local = nearest_local + locate_surface_point; full = nearest + "
              "locate_surface_point; brute = nearest_brute_force + locate_surface_point; cgal = "
              "AABB_tree::closest_point)\n");
  if (opt.repeat > 1)
    std::printf("   each query's least time over %d runs of its method's path from the same start (--repeat; brute "
                "force timed once)\n",
                opt.repeat);
  std::printf("%-40s %9s %2s %-10s %7s %8s %8s %8s %8s %6s %6s  %s\n", "mesh", "vertices", "p", "method", "samples",
              "p50", "p99", "p99.9", "max", "x p50", "x p99", "check / target");
  const QueryRow* local = nullptr;
  const QueryRow* track = nullptr;
  for (const auto& q : r.queries) {
    if (q.method == "local") local = &q;
    if (q.method == "track") track = &q;
    if (q.lat.samples == 0) {
      std::printf("%-40s %9zu %2d %-10s %s\n", q.mesh.c_str(), q.vertices, q.probes, q.method.c_str(),
                  q.note.c_str());
      continue;
    }
    const double x50 = local ? q.lat.p50_us / local->lat.p50_us : 0;
    const double x99 = local ? q.lat.p99_us / local->lat.p99_us : 0;
    std::string note = q.note;
    if (q.method == "cgal_hint") {
      note += std::string(note.empty() ? "" : "; ") + "target x >= 3 at p50 and p99: " +
              verdict(x50 >= kTargetQuerySpeedup && x99 >= kTargetQuerySpeedup);
      if (track && track->mesh == q.mesh && track->probes == q.probes && track->lat.samples > 0) {
        char t[96];
        std::snprintf(t, sizeof t, "; against track x %.2f at p50, %.2f at p99", q.lat.p50_us / track->lat.p50_us,
                      q.lat.p99_us / track->lat.p99_us);
        note += t;
      }
    }
    std::printf("%-40s %9zu %2d %-10s %7zu %8.3f %8.3f %8.3f %8.2f %6.2f %6.2f  %s\n", q.mesh.c_str(), q.vertices,
                q.probes, q.method.c_str(), q.lat.samples, q.lat.p50_us, q.lat.p99_us, q.lat.p999_us, q.lat.max_us,
                x50, x99, note.c_str());
  }

  // Deformation steps, with the 50 % target on the full rows.
  std::printf("\n== Deformation step (DeformableSurface::step = active, step_full = full), dt = %.0f ms; active: "
              "the steps of the tick runs; full: repeated after them with the last contacts held (their fields "
              "built once, as for a probe held still); full_new: the same with contacts that change every step "
              "(fields built every step; not the pass the target is about, shown for what the fields cost)\n",
              kDeformPeriod * 1e3);
  std::printf("%-40s %9s %6s %-8s %12s %10s %10s %10s %8s  %s\n", "mesh", "vertices", "probes", "method",
              "vertices/step", "vertices/s", "step GB/s", "copy GB/s", "of copy", "target");
  for (const auto& s : r.steps) {
    std::string target;
    if (s.method == "full")
      target = std::string(">= 50% ") + verdict(s.fraction >= kTargetCopyFraction);
    std::printf("%-40s %9zu %6d %-8s %12.0f %10s %10.2f %10.2f %7.1f%%  %s\n", s.mesh.c_str(), s.vertices, s.probes,
                s.method.c_str(), s.vertices_per_step, bench::short_count(s.vertices_per_s).c_str(),
                s.bytes_per_s * 1e-9, s.copy_bytes_per_s * 1e-9, 100 * s.fraction, target.c_str());
  }
  std::printf("Bytes counted (public state only, SurfaceState::vertices = %d B per vertex): full = %d B read for "
              "every vertex + %d B written for each vertex still moving after the step (active_count()); active = "
              "%d B read + %d B written per active vertex. Not counted: flags, material index, force, correction, "
              "stream, vertices that came to rest -- so step GB/s is a lower bound. Copy figure, same run: memcpy "
              "of a %d B-per-vertex array (same size as the state) into another, median of repeats; copy GB/s "
              "counts %d B read + %d B written per vertex. of copy = step GB/s / copy GB/s.\n\n",
              kStateBytes, kStateBytes, kStateBytes, kStateBytes, kStateBytes, kStateBytes, kStateBytes,
              kStateBytes);

  // Replica steps and the threaded tick (issue 8).
  std::printf("\n== Live loop's replicas, per deformation request, ms (3 probes; both = each replica steps, as "
              "HapticLoop did before issue 8; level = one steps, the other copies what changed)\n");
  std::printf("%-40s %9s %9s %9s %9s %9s %9s %9s %9s %6s  %s\n", "mesh", "vertices", "both p50", "both p99",
              "level p50", "level p99", "step p50", "copy p50", "changed", "equal", "target");
  for (const auto& x : r.replicas) {
    std::string target;
    if (x.mesh == "sphere-1M")
      target = std::string("level <= 1 ms at p50 and p99: ") +
               verdict(x.f.level.p50_us <= 1e3 && x.f.level.p99_us <= 1e3);
    std::printf("%-40s %9zu %9.3f %9.3f %9.3f %9.3f %9.3f %9.3f %9.0f %6s  %s\n", x.mesh.c_str(), x.vertices,
                x.f.both.p50_us * 1e-3, x.f.both.p99_us * 1e-3, x.f.level.p50_us * 1e-3, x.f.level.p99_us * 1e-3,
                x.f.level_step.p50_us * 1e-3, x.f.level_copy.p50_us * 1e-3, x.f.changed_mean,
                x.f.equal ? "yes" : "NO", target.c_str());
  }
  if (!r.threaded.empty()) {
    std::printf("\n== Haptic tick with the deformation step on another thread (LoopCore::tick paced at 1 kHz after "
                "a spin, %s; the other thread steps one replica and levels the other, as HapticLoop), 3 probes, us\n",
                !opt.threaded_warm  ? "without the warm-up (--no-warm)"
                : opt.threaded_hold ? "warming the tick's data during it and reading the replica held from the "
                                      "last warm-up, as HapticLoop"
                                    : "warming the tick's data during it, without the held warm-up (--no-hold)");
    std::printf("%-40s %9s %8s %8s %8s %8s %10s %10s %7s  %s\n", "mesh", "vertices", "p50", "p99", "p99.9", "max",
                "step p50", "step p99", "merged", "target");
    const ThreadRow* small = nullptr;
    for (const auto& x : r.threaded)
      if (x.mesh == "sphere-10k") small = &x;
    for (const auto& x : r.threaded) {
      char target[160] = "";
      if (x.mesh == "sphere-1M") {
        const int n = std::snprintf(target, sizeof target, "p99 <= %.0f us %s; ", kTargetTickP99Us,
                                    verdict(x.f.tick.p99_us <= kTargetTickP99Us));
        if (small) {
          const double g = x.f.tick.p99_us / small->f.tick.p99_us;
          std::snprintf(target + n, sizeof target - n, "growth from 10k %.2fx %s", g, verdict(g <= kTargetGrowth));
        } else {
          std::snprintf(target + n, sizeof target - n, "growth from 10k not measured (no sphere-10k in this run)");
        }
      }
      const ThreadRow* even = nullptr;
      for (const auto& y : r.threaded)
        if (y.mesh == "sphere-1M") even = &y;
      if ((x.mesh == "fan-sphere-1M" || x.mesh == "sliver-sphere-1M") && even)
        std::snprintf(target, sizeof target, "p99 %.2fx sphere-1M's <= 2x %s", x.f.tick.p99_us / even->f.tick.p99_us,
                      verdict(x.f.tick.p99_us <= kTargetFlatness * even->f.tick.p99_us));
      std::printf("%-40s %9zu %8.3f %8.3f %8.3f %8.2f %10.3f %10.3f %7zu  %s\n", x.mesh.c_str(), x.vertices,
                  x.f.tick.p50_us, x.f.tick.p99_us, x.f.tick.p999_us, x.f.tick.max_us, x.f.step.p50_us * 1e-3,
                  x.f.step.p99_us * 1e-3, x.f.merged, target);
    }
  }

  // Targets.
  std::printf("\n== Targets\n");
  const TickRow* t1m = tick_of("sphere-1M", 3);
  const TickRow* t10k = tick_of("sphere-10k", 3);
  if (t1m)
    std::printf("haptic tick p99 <= %.1f us at 1M vertices, 3 probes: %.3f us  %s\n", kTargetTickP99Us,
                t1m->tick.p99_us, verdict(t1m->tick.p99_us <= kTargetTickP99Us));
  else
    std::printf("haptic tick p99 <= %.1f us at 1M vertices, 3 probes: not measured in this run\n", kTargetTickP99Us);
  for (int probes : {1, 3}) {
    const TickRow* a = tick_of("sphere-10k", probes);
    const TickRow* b = tick_of("sphere-1M", probes);
    if (a && b)
      std::printf("growth <= %.1fx from 10k to 1M vertices (tick p99, %d probe%s): %.2fx  %s   (p50: %.2fx)\n",
                  kTargetGrowth, probes, probes > 1 ? "s" : "", b->tick.p99_us / a->tick.p99_us,
                  verdict(b->tick.p99_us / a->tick.p99_us <= kTargetGrowth), b->tick.p50_us / a->tick.p50_us);
  }
  if (!t10k || !t1m) std::printf("growth 10k -> 1M: not measured in this run\n");
  std::printf("our contact query >= %.0fx faster than CGAL's hinted query (cgal_hint / local at p50 and p99):\n",
              kTargetQuerySpeedup);
  for (std::size_t i = 0; i < r.queries.size(); ++i) {
    const auto& l = r.queries[i];
    if (l.method != "local") continue;
    for (std::size_t j = i; j < r.queries.size() && r.queries[j].mesh == l.mesh && r.queries[j].probes == l.probes;
         ++j) {
      const auto& h = r.queries[j];
      if (h.method != "cgal_hint") continue;
      const double x50 = h.lat.p50_us / l.lat.p50_us, x99 = h.lat.p99_us / l.lat.p99_us;
      std::printf("  %-40s %d probe%s: p50 %.2fx  p99 %.2fx  %s", l.mesh.c_str(), l.probes, l.probes > 1 ? "s" : " ",
                  x50, x99, verdict(x50 >= kTargetQuerySpeedup && x99 >= kTargetQuerySpeedup));
      for (std::size_t k = i; k < j; ++k) {
        const auto& t = r.queries[k];
        if (t.method != "track" || t.lat.samples == 0) continue;
        const double t50 = h.lat.p50_us / t.lat.p50_us, t99 = h.lat.p99_us / t.lat.p99_us;
        std::printf("   (the tick's track_contact: p50 %.2fx  p99 %.2fx  %s)", t50, t99,
                    verdict(t50 >= kTargetQuerySpeedup && t99 >= kTargetQuerySpeedup));
      }
      std::printf("\n");
    }
  }
  std::printf("full-mesh pass >= %.0f%% of measured copy bandwidth:\n", 100 * kTargetCopyFraction);
  for (const auto& s : r.steps) {
    if (s.method != "full") continue;
    std::printf("  %-40s %d probe%s: %.1f%%  %s", s.mesh.c_str(), s.probes, s.probes > 1 ? "s" : " ",
                100 * s.fraction, verdict(s.fraction >= kTargetCopyFraction));
    for (const auto& n : r.steps)
      if (n.method == "full_new" && n.mesh == s.mesh && n.probes == s.probes)
        std::printf("   (with new contacts every step, fields built each time: %.1f%%)", 100 * n.fraction);
    std::printf("\n");
  }
  std::printf("\nTiming: steady_clock::now() around each tick/query/step, nothing subtracted; clock overhead in "
              "this run (two back-to-back reads): min %.0f ns, p50 %.0f ns, p99 %.0f ns. Threads not pinned, except in "
              "the threaded run (%s).\n",
              clock.min_ns, clock.p50_ns, clock.p99_ns,
              opt.threaded_place ? "the ticking thread on a CPU of its own, as the workbench" : "--no-placement: not pinned");
  std::printf("For scale (from the issue): CGAL alone on a 2M-triangle sphere along a sliding path, p50 1.1 us "
              "without hint, 0.55 us with one, on a 2-core VM.\n");
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (auto err = parse_options(argc, argv, opt)) {
    std::fprintf(stderr, "palpa-bench: %s\n", err->c_str());
    print_usage();
    return 2;
  }
  const Plan plan = make_plan(opt);
  if (opt.same_phase_blocks > 0 && static_cast<std::size_t>(opt.same_phase_blocks) > plan.ticks) {
    std::fprintf(stderr, "palpa-bench: --same-phase: %d blocks is more than the %zu timed ticks (--ticks)\n",
                 opt.same_phase_blocks, plan.ticks);
    return 2;
  }
  const auto start = Clock::now();

  // Open the JSON file first, so an unwritable path fails before minutes of measuring.
  std::ofstream json_out;
  if (!opt.json_path.empty()) {
    json_out.open(opt.json_path);
    if (!json_out) {
      std::fprintf(stderr, "palpa-bench: %s: cannot open for writing\n", opt.json_path.c_str());
      return 1;
    }
  }

  // Scenario summary.
  std::printf("palpa-bench%s: %zu timed ticks (+%zu warm-up) per run at %.0f Hz; probes slide at %.0f mm/s, %.1f mm "
              "below the surface, seed %llu; Wendland contacts of radius %.0f mm; default material; spheres of "
              "radius %.0f mm\n",
              opt.quick ? " --quick" : "", plan.ticks, plan.warmup, 1 / kTickPeriod, kProbeSpeed * 1e3,
              kProbeDepth * 1e3, static_cast<unsigned long long>(opt.seed), kShapeRadius * 1e3, kSphereRadius * 1e3);
  const bench::ClockOverhead clock = bench::measure_clock_overhead();
  std::printf("clock overhead (steady_clock, two back-to-back reads): min %.0f ns, p50 %.0f ns, p99 %.0f ns\n",
              clock.min_ns, clock.p50_ns, clock.p99_ns);
  if (opt.quick)
    std::printf("quick mode: no 2M sphere, brute force skipped above %s vertices\n",
                bench::short_count(static_cast<double>(plan.brute_max_vertices)).c_str());
  std::printf("brute force (nearest_brute_force + locate_surface_point) is sampled on every n-th tick so that it "
              "visits at most %s vertices per run\n",
              bench::short_count(plan.brute_budget).c_str());

  // The meshes: spheres first, then the shared organs (none with --tissue-map).
  std::vector<MeshCase> cases;
  if (!opt.tissue_map_only && !opt.hover_only && opt.same_phase_blocks == 0) {
    for (std::size_t n : opt.spheres ? plan.spheres : std::vector<std::size_t>{}) cases.push_back(generated_case(n, ""));
    // Issue 8: as many vertices as the 1M sphere, with high-valence fans or slivers.
    for (const char* g : {"fan", "sliver"})
      if (opt.spheres) cases.push_back(generated_case(1'000'000, g));
    for (auto& c : organ_cases(opt.shared_dir, opt.organ_unit_m)) cases.push_back(c);
    if (!opt.only.empty())
      std::erase_if(cases, [&](const MeshCase& c) {
        return opt.only[0] == '=' ? c.name != opt.only.substr(1) : c.name.find(opt.only) == std::string::npos;
      });
  }

  // Measure each mesh in turn (one mesh in memory at a time).
  Results results;
  if (opt.same_phase_blocks > 0) run_same_phase(plan, opt, results);
  for (const auto& c : cases) {
    try {
      run_mesh(c, plan, opt, results);
    } catch (const std::exception& e) {
      std::printf("[%s] skipped: %s\n", c.name.c_str(), e.what());
    }
  }

  if (opt.query_loop > 0) {
    std::printf("query loop: collect in 'palpa::collision::track_contact*' (callgrind --toggle-collect) and divide "
                "by queries x passes for instructions per query; equal answer hashes mean equal bits\n");
  } else {
    if (!opt.tissue_map_only && !opt.hover_only && opt.same_phase_blocks == 0) print_tables(results, clock, opt);
  }
  if (!opt.hover_only && opt.query_loop == 0 && opt.same_phase_blocks == 0) {
    try {
      bench::run_tissue_map_bench(1'000'000, opt.quick ? 3 : 5, results.records);
    } catch (const std::exception& e) {
      std::printf("[tissue map] skipped: %s\n", e.what());
    }
  }
  if (!opt.tissue_map_only && opt.query_loop == 0 && opt.same_phase_blocks == 0) {
    try {
      bench::run_hover_bench(1'000'000, opt.quick ? 10000 : 30000, 2, results.records);
    } catch (const std::exception& e) {
      std::printf("[hover] skipped: %s\n", e.what());
    }
  }
  for (auto& rec : results.records) rec["clock_overhead_ns"] = clock.p50_ns;
  std::printf("total run time %.1f s\n", elapsed_ns(start, Clock::now()) * 1e-9);

  // JSON records (the file was opened before measuring).
  if (json_out.is_open()) {
    json_out << results.records.dump(2) << '\n';
    json_out.close();
    if (!json_out) {
      std::fprintf(stderr, "palpa-bench: %s: write failed\n", opt.json_path.c_str());
      return 1;
    }
    std::printf("wrote %zu records to %s\n", results.records.size(), opt.json_path.c_str());
  }
  return 0;
}
