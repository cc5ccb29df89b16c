// palpa-palpate: palpates an organ along a scripted path with one or more
// virtual probes at a fixed haptic rate, printing forces and timings. It needs
// no display and no device; it is the headless main job of Palpa.

#include "app/cli/record_job.h"
#include "app/cli/scenario_job.h"
#include "collision/vertex_tree.h"
#include "deform/surface.h"
#include "haptics/session.h"
#include "mesh/generate.h"
#include "mesh/io.h"
#include "mesh/spatial_order.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

namespace {

using palpa::Vec3;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string mesh = std::string(PALPA_DATA_DIR) + "/default_organ.ply";
  double unit_m = 1.0;         // file unit, m
  std::size_t organ_vertices = 0;  // >0: generate the default organ at this size instead
  int probes = 3;
  double seconds = 2.0;        // simulated time, s
  double rate_hz = 1000.0;     // haptic rate, Hz
  double depth = 0.008;        // maximum indentation, m
  double stiffness = 200.0;    // N/m
  double damping = 2.0;        // N s/m
  double mass = 1e-3;          // kg
  double radius = 0.025;       // shape-function support, m
  double friction = 0.2;       // K of eq. (4)
  double max_force = 8.0;      // N
  std::string record;          // session file to record into (empty: none)
};

void usage() {
  std::puts(
      "usage: palpa-palpate [options]\n"
      "  --mesh FILE          organ mesh (default: the bundled default organ)\n"
      "  --unit METRES        length of one file unit in metres, 1e-06 .. 1 (1e-3 for mm; default 1)\n"
      "  --organ-vertices N   generate the default organ with about N vertices instead, 100 .. 5000000\n"
      "  --probes N           probes palpating at once, 1 .. 8 (default 3)\n"
      "  --seconds S          simulated time, 0.001 .. 3600 s (default 2)\n"
      "  --rate HZ            haptic rate, 100 .. 10000 Hz (default 1000); seconds x rate is\n"
      "                       1 .. 10000000 ticks\n"
      "  --depth M            maximum indentation, 0.0001 .. 0.05 m (default 0.008)\n"
      "  --stiffness N_PER_M  vertex stiffness, 0.001 .. 1e+06 N/m (default 200)\n"
      "  --friction K         friction coefficient of eq. (4), 0 .. 2 (default 0.2)\n"
      "  --record SESSION     record the session into a new session file (palpa-replay, palpa-assess)\n"
      "  --scenario FILE ...  run a scenario instead (palpa-palpate --scenario FILE --help for its options)\n"
      "Every number outside its range is refused (never clamped).");
}

// The most ticks one run may simulate (two timing records of 8 bytes each per tick).
constexpr long kMaxTicks = 10'000'000;

[[noreturn]] void refuse(const std::string& what) {
  std::fprintf(stderr, "palpa-palpate: %s\n", what.c_str());
  std::exit(2);
}

std::string shortest(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto next = [&](const char* what) -> const char* {
      if (i + 1 >= argc) refuse(std::string(what) + " needs a value");
      return argv[++i];
    };
    // A finite number in [lo, hi] (unit for the message), else exit 2 naming the range.
    auto number = [&](const char* what, double lo, double hi, const char* unit) {
      const char* s = next(what);
      char* end = nullptr;
      errno = 0;
      const double v = std::strtod(s, &end);
      if (end == s || *end != '\0' || !std::isfinite(v) || !(v >= lo && v <= hi))
        refuse(std::string(what) + ": expected a number in " + shortest(lo) + " .. " + shortest(hi) + unit +
               ", got '" + s + "'");
      return v;
    };
    // A whole number in [lo, hi] (decimal digits only: "2.5" and "1e3" are refused).
    auto integer = [&](const char* what, long long lo, long long hi) {
      const char* s = next(what);
      char* end = nullptr;
      errno = 0;
      const long long v = std::strtoll(s, &end, 10);
      if (end == s || *end != '\0' || errno == ERANGE || v < lo || v > hi)
        refuse(std::string(what) + ": expected an integer in " + std::to_string(lo) + " .. " + std::to_string(hi) +
               ", got '" + s + "'");
      return v;
    };
    if (a == "--help" || a == "-h") { usage(); std::exit(0); }
    else if (a == "--mesh") o.mesh = next("--mesh");
    else if (a == "--unit") o.unit_m = number("--unit", 1e-6, 1.0, " m");
    else if (a == "--organ-vertices") o.organ_vertices = static_cast<std::size_t>(integer("--organ-vertices", 100, 5'000'000));
    else if (a == "--probes") o.probes = static_cast<int>(integer("--probes", 1, 8));
    else if (a == "--seconds") o.seconds = number("--seconds", 1e-3, 3600.0, " s");
    else if (a == "--rate") o.rate_hz = number("--rate", 100.0, 10000.0, " Hz");
    else if (a == "--depth") o.depth = number("--depth", 1e-4, 0.05, " m");
    else if (a == "--stiffness") o.stiffness = number("--stiffness", 1e-3, 1e6, " N/m");
    else if (a == "--friction") o.friction = number("--friction", 0.0, 2.0, "");
    else if (a == "--record") o.record = next("--record");
    else { std::fprintf(stderr, "palpa-palpate: unknown option '%s'\n", a.c_str()); usage(); return false; }
  }
  // The run's length in ticks, before anything is allocated for it.
  const double ticks = std::round(o.seconds * o.rate_hz);
  if (!(ticks >= 1 && ticks <= kMaxTicks))
    refuse("--seconds " + shortest(o.seconds) + " at --rate " + shortest(o.rate_hz) + " makes " + std::to_string(static_cast<long long>(ticks)) +
           " ticks; it must make 1 .. " + std::to_string(kMaxTicks));
  return true;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(p * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// Scripted probe path: probe j circles over a patch of the organ's upper
// surface, pressing in and out with a raised-cosine depth profile. The path is
// defined relative to the surface: each tick the probe sits `depth(t)` below
// the surface point above which it hovers (found by a ray from above).
struct ScriptedProbe {
  Vec3 center;      // point on the undeformed surface, m
  Vec3 normal;      // outward normal there
  Vec3 u, v;        // tangent frame
  double circle_r;  // m
  double phase;     // rad
};

}  // namespace

int main(int argc, char** argv) {
  // A scenario run has its own options (app/cli/scenario_job.h).
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], "--scenario") == 0) return palpa::app::scenario_main({argv + 1, argv + argc});
  Options o;
  if (!parse(argc, argv, o)) return 2;

  // Load (or generate) the organ.
  auto t0 = Clock::now();
  auto mesh = std::make_shared<palpa::mesh::SurfaceMesh>();
  try {
    if (o.organ_vertices > 0) {
      *mesh = palpa::mesh::make_organ(o.organ_vertices);
      o.mesh = "generated organ";
    } else {
      palpa::mesh::LoadOptions lo;
      lo.unit_m = o.unit_m;
      *mesh = palpa::mesh::load_mesh(o.mesh, lo);
    }
    palpa::mesh::reorder_spatially(*mesh);  // as load_organ numbers every organ
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palpa-palpate: %s\n", e.what());
    return 1;
  }
  const auto facts = palpa::mesh::analyse(*mesh);
  const double load_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  std::printf("organ: %s\n  %zu vertices, %zu triangles, %.1f x %.1f x %.1f mm, %s, loaded in %.0f ms\n",
              o.mesh.c_str(), facts.vertices, facts.triangles, 1e3 * (facts.bbox_max.x() - facts.bbox_min.x()),
              1e3 * (facts.bbox_max.y() - facts.bbox_min.y()), 1e3 * (facts.bbox_max.z() - facts.bbox_min.z()),
              facts.closed() ? "closed" : "open", load_ms);

  // Build the collision tree and the deformable surface.
  t0 = Clock::now();
  palpa::haptics::CoreConfig config;
  config.rate_hz = o.rate_hz;
  config.deform_rate_hz = o.rate_hz;  // one deformation step per tick
  config.force.friction = o.friction;
  config.force.max_force = o.max_force;
  config.shape.kind = palpa::deform::ShapeKind::Wendland;
  config.shape.radius = o.radius;
  const auto model = palpa::haptics::SessionModel::make(mesh, {}, config);
  const palpa::collision::VertexTree& tree = *model->tree;
  palpa::deform::Material mat;
  mat.model = palpa::deform::LocalModelKind::Linear;
  mat.stiffness = o.stiffness;
  mat.damping = o.damping;
  mat.mass = o.mass;
  // Scripted probes have no force output: the session reports the model's force.
  std::vector<palpa::haptics::ProbeSetup> setups(o.probes);
  for (int j = 0; j < o.probes; ++j) {
    setups[j].name = "scripted probe " + std::to_string(j);
    setups[j].spec.position_dof = 3;
    setups[j].safety.max_jump = 1e9;
  }
  palpa::haptics::Session session(model, palpa::deform::MaterialArrays::uniform(mesh->vertex_count(), mat), setups);
  const palpa::deform::DeformableSurface& surface = session.surface();
  std::printf("  tree of %zu nodes (depth %d) built in %.0f ms\n", tree.node_count(), tree.depth(),
              std::chrono::duration<double, std::milli>(Clock::now() - t0).count());

  // Place the probes on the upper surface: vertices with the highest z spread
  // along x, each with a tangent frame.
  const Vec3 lo = facts.bbox_min, hi = facts.bbox_max;
  const double size = (hi - lo).norm();
  std::vector<ScriptedProbe> script;
  for (int j = 0; j < o.probes; ++j) {
    const double fx = (j + 1.0) / (o.probes + 1.0);
    Vec3 above(lo.x() + fx * (hi.x() - lo.x()), 0.5 * (lo.y() + hi.y()), hi.z() + 0.5 * size);
    // The surface point under `above`: the nearest vertex to a point just above the top.
    Vec3 target = above;
    palpa::Index best = palpa::kNoIndex;
    double best_z = -1e300;
    for (palpa::Index i = 0; i < mesh->vertex_count(); ++i) {
      const Vec3& p = mesh->positions[i];
      const double dxy = std::hypot(p.x() - target.x(), p.y() - target.y());
      if (dxy < 0.02 * size && p.z() > best_z && mesh->normals[i].z() > 0.3) { best_z = p.z(); best = i; }
    }
    if (best == palpa::kNoIndex) best = tree.nearest(target).vertex;
    ScriptedProbe sp;
    sp.center = mesh->positions[best];
    sp.normal = mesh->normals[best];
    sp.u = sp.normal.unitOrthogonal();
    sp.v = sp.normal.cross(sp.u);
    sp.circle_r = 0.01 * size;
    sp.phase = 2.0 * M_PI * j / o.probes;
    script.push_back(sp);
  }

  // --record: every tick, step and a snapshot every few seconds into a session file.
  std::unique_ptr<palpa::record::Recorder> recorder;
  if (!o.record.empty()) {
    try {
      recorder = palpa::app::open_recording(o.record, *model, palpa::deform::MaterialArrays::uniform(mesh->vertex_count(), mat),
                                            setups, palpa::app::session_info(o.mesh));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "palpa-palpate: %s\n", e.what());
      return 1;
    }
  }

  std::vector<palpa::haptics::ProbeTickInput> in(o.probes);
  std::vector<palpa::haptics::ProbeTickResult> out(o.probes);

  const double dt = 1.0 / o.rate_hz;
  const long ticks = std::lround(o.seconds * o.rate_hz);
  std::vector<double> tick_us, step_us;
  tick_us.reserve(ticks);
  step_us.reserve(ticks);
  double peak_force = 0;
  std::size_t peak_active = 0;

  std::printf("palpating with %d probe(s) at %.0f Hz for %.2f s (depth up to %.1f mm, k = %.0f N/m)\n", o.probes,
              o.rate_hz, o.seconds, 1e3 * o.depth, o.stiffness);
  std::printf("%8s", "t [s]");
  for (int j = 0; j < o.probes; ++j) std::printf("   probe%d depth [mm]  |F| [N]", j);
  std::printf("   active vertices\n");

  // The haptic loop, simulated at a fixed rate (no real-time pacing needed here).
  for (long n = 0; n < ticks; ++n) {
    const double t = n * dt;
    // Scripted probe positions and velocities (analytic derivative).
    for (int j = 0; j < o.probes; ++j) {
      const auto& s = script[j];
      const double w = 2.0 * M_PI * 0.5;  // rad/s, one circle every 2 s
      const double press = 0.5 * (1.0 - std::cos(2.0 * M_PI * t / o.seconds));  // 0 -> 1 -> 0
      const double a = s.phase + w * t;
      const double dpress = M_PI / o.seconds * std::sin(2.0 * M_PI * t / o.seconds);
      const double d = o.depth * press - 0.001;  // starts 1 mm above the surface
      (void)dpress;
      const Vec3 p = s.center + s.circle_r * (std::cos(a) * s.u + std::sin(a) * s.v) - d * s.normal;
      in[j].sample = palpa::haptics::position_sample(p, static_cast<std::uint64_t>(n) + 1, t);
    }
    // One session step: collision and force for every probe (eq. 4), then
    // the deformation step with their contacts.
    auto a0 = Clock::now();
    const bool due = recorder ? false : session.tick(t, in, out);
    if (recorder) palpa::record::record_step(*recorder, session, t, in, out);  // tick and step, timed as the tick
    auto a1 = Clock::now();
    if (due) session.deform(session.core().request());
    auto a2 = Clock::now();
    tick_us.push_back(std::chrono::duration<double, std::micro>(a1 - a0).count());
    step_us.push_back(std::chrono::duration<double, std::micro>(a2 - a1).count());
    for (const auto& po : out) peak_force = std::max(peak_force, palpa::haptics::to_vec(po.force_world).norm());
    peak_active = std::max(peak_active, surface.active_count());

    if (n % std::max<long>(1, ticks / 10) == 0 || n == ticks - 1) {
      std::printf("%8.3f", t);
      for (const auto& po : out) {
        const double f = palpa::haptics::to_vec(po.force_world).norm();
        if (po.in_contact)
          std::printf("   %18.2f  %7.3f", 1e3 * po.depth, f);
        else
          std::printf("   %18s  %7.3f", "no contact", f);
      }
      std::printf("   %zu\n", surface.active_count());
    }
  }

  if (recorder) {
    // record_step makes the tick and the step it asks for in one call: one figure for both.
    std::printf("haptic tick + deformation step + record (%d probes): p50 %.2f us, p99 %.2f us, max %.2f us; "
                "peak %zu active of %zu vertices\n",
                o.probes, percentile(tick_us, 0.5), percentile(tick_us, 0.99),
                *std::max_element(tick_us.begin(), tick_us.end()), peak_active, mesh->vertex_count());
  } else {
    std::printf("haptic tick (collision + interpolation + local model + eq. 4, %d probes): p50 %.2f us, p99 %.2f us, max %.2f us\n",
                o.probes, percentile(tick_us, 0.5), percentile(tick_us, 0.99),
                *std::max_element(tick_us.begin(), tick_us.end()));
    std::printf("deformation step (active set): p50 %.1f us, p99 %.1f us, peak %zu active of %zu vertices\n",
                percentile(step_us, 0.5), percentile(step_us, 0.99), peak_active, mesh->vertex_count());
  }
  std::printf("peak force %.3f N (limit %.1f N)\n", peak_force, o.max_force);
  if (recorder) {
    try {
      palpa::app::close_recording(*recorder, stdout);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "palpa-palpate: %s\n", e.what());
      return 1;
    }
  }
  return 0;
}
