// The scenario job of palpa-palpate (scenario_job.h).

#include "app/cli/scenario_job.h"

#include "app/cli/record_job.h"

#include "haptics/indent.h"
#include "haptics/session.h"
#include "scenario/resolve.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>

namespace palpa::app {

namespace {

struct Usage : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct ScenarioOptions {
  std::string scenario;
  bool indent = false;
  Vec3 near = Vec3::Zero();
  double from = 0.001, to = 0.01, step = 0.001;  // m
  std::string json;
  double seconds = 5.0;
  double rate_hz = 1000.0;
  int probes = 1;
  std::string record;  // session file (empty: none)
};

const char* kUsage =
    "usage: palpa-palpate --scenario FILE [--seconds S] [--rate HZ] [--probes N] [--record SESSION]\n"
    "       palpa-palpate --scenario FILE --indent X,Y,Z --depths FROM:TO:STEP [--json OUT]\n"
    "  --scenario FILE        the scenario (docs/SCENARIO.md)\n"
    "  --seconds S            simulated time of the scripted run, s, in (0, 3600] (default 5)\n"
    "  --rate HZ              haptic rate, Hz, in [100, 10000] (default 1000)\n"
    "  --probes N             scripted probes, integer in [1, 8] (default 1)\n"
    "  --record SESSION       record the scripted run into a new session file\n"
    "  --indent X,Y,Z         press at the surface point nearest to X,Y,Z (m, world frame at t = 0;\n"
    "                         |X|, |Y|, |Z| <= 10)\n"
    "  --depths FROM:TO:STEP  indentation depths, m (0 <= FROM <= TO <= 0.1, STEP > 0, at most 10000 depths)\n"
    "  --json OUT             write one record per depth: depth_m, force_n, surface_point_m\n";

double number(const std::string& option, const std::string& text) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(v)) throw Usage(option + ": expected a number, got '" + text + "'");
  return v;
}

std::vector<double> numbers(const std::string& option, const std::string& text, char sep, std::size_t count,
                            const char* what) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, sep)) out.push_back(number(option, item));
  if (out.size() != count) throw Usage(option + ": expected " + what + ", got '" + text + "'");
  return out;
}

ScenarioOptions parse(const std::vector<std::string>& args) {
  ScenarioOptions o;
  bool have_depths = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&]() -> const std::string& {
      if (i + 1 >= args.size()) throw Usage(a + " needs a value");
      return args[++i];
    };
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    } else if (a == "--scenario") {
      o.scenario = value();
    } else if (a == "--indent") {
      const auto v = numbers(a, value(), ',', 3, "X,Y,Z in metres");
      for (double c : v)
        if (!(std::abs(c) <= 10)) throw Usage("--indent: expected X,Y,Z in metres with |X|, |Y|, |Z| <= 10, got '" + args[i] + "'");
      o.near = Vec3(v[0], v[1], v[2]);
      o.indent = true;
    } else if (a == "--depths") {
      const auto v = numbers(a, value(), ':', 3, "FROM:TO:STEP in metres");
      o.from = v[0];
      o.to = v[1];
      o.step = v[2];
      if (!(o.from >= 0 && o.to >= o.from && o.to <= 0.1 && o.step > 0))
        throw Usage("--depths: expected 0 <= FROM <= TO <= 0.1 m and STEP > 0, got '" + args[i] + "'");
      if ((o.to - o.from) / o.step > 10000) throw Usage("--depths: at most 10000 depths, got '" + args[i] + "'");
      have_depths = true;
    } else if (a == "--record") {
      o.record = value();
    } else if (a == "--json") {
      o.json = value();
    } else if (a == "--seconds") {
      o.seconds = number(a, value());
      if (!(o.seconds > 0 && o.seconds <= 3600)) throw Usage("--seconds: expected a time in (0, 3600] s, got " + args[i]);
    } else if (a == "--rate") {
      o.rate_hz = number(a, value());
      if (!(o.rate_hz >= 100 && o.rate_hz <= 10000)) throw Usage("--rate: expected a rate in [100, 10000] Hz, got " + args[i]);
    } else if (a == "--probes") {
      const double p = number(a, value());
      if (!(p >= 1 && p <= 8 && p == std::floor(p))) throw Usage("--probes: expected an integer in [1, 8], got " + args[i]);
      o.probes = static_cast<int>(p);
    } else {
      throw Usage("unknown option '" + a + "' with --scenario");
    }
  }
  if (o.scenario.empty()) throw Usage("--scenario needs a file");
  if (!o.indent && std::lround(o.seconds * o.rate_hz) < 1)
  {
    std::ostringstream m;
    m << "--seconds " << o.seconds << " at --rate " << o.rate_hz << " makes no tick";
    throw Usage(m.str());
  }
  if (o.indent != have_depths) throw Usage("--indent and --depths go together");
  if (!o.json.empty() && !o.indent) throw Usage("--json goes with --indent");
  if (!o.record.empty() && o.indent) throw Usage("--record goes with the scripted run, not --indent");
  return o;
}

int run_indent(const ScenarioOptions& o, const scenario::Resolved& r) {
  const auto model = scenario::session_model(r, scenario::core_config(r, o.rate_hz, o.rate_hz / 2));
  const Vec3 near = model->field ? model->field->to_organ(o.near, 0.0) : o.near;
  const haptics::IndentSite site = haptics::indent_site(*model, near);
  std::vector<double> depths;
  const auto count = static_cast<long>(std::floor((o.to - o.from) / o.step + 1e-9));
  for (long k = 0; k <= count; ++k) depths.push_back(o.from + static_cast<double>(k) * o.step);
  haptics::IndentOptions io;
  if (model->field)
    for (const auto& t : r.scenario.tissues) io.settle = std::max(io.settle, 5.0 * t.relaxation_time);
  const auto samples = haptics::indent(model, r.tissues[r.base], site, depths, io);
  std::printf("press at vertex %u (%.2f, %.2f, %.2f) mm, normal (%.3f, %.3f, %.3f), thickness %.1f mm\n",
              static_cast<unsigned>(site.vertex), 1e3 * site.point.x(), 1e3 * site.point.y(), 1e3 * site.point.z(),
              site.normal.x(), site.normal.y(), site.normal.z(), 1e3 * site.thickness);
  std::printf("%12s %12s\n", "depth [mm]", "force [N]");
  for (const auto& s : samples) std::printf("%12.3f %12.5f%s\n", 1e3 * s.depth, s.force, s.in_contact ? "" : "  (no contact)");
  if (!o.json.empty()) {
    std::ostringstream j;
    j.precision(17);
    j << "[\n";
    for (std::size_t k = 0; k < samples.size(); ++k) {
      const auto& s = samples[k];
      j << "  {\"depth_m\": " << s.depth << ", \"force_n\": " << s.force << ", \"surface_point_m\": ["
        << s.surface_point.x() << ", " << s.surface_point.y() << ", " << s.surface_point.z()
        << "], \"in_contact\": " << (s.in_contact ? "true" : "false") << ", \"thickness_m\": ";
      if (std::isfinite(site.thickness)) j << site.thickness;
      else j << "null";  // an open patch: no opposite side
      j << "}" << (k + 1 < samples.size() ? "," : "") << "\n";
    }
    j << "]\n";
    std::ofstream f(o.json, std::ios::binary | std::ios::trunc);
    f << j.str();
    f.close();
    if (!f) {
      std::fprintf(stderr, "palpa-palpate: %s: cannot write\n", o.json.c_str());
      return 1;
    }
    std::printf("wrote %zu records to %s\n", samples.size(), o.json.c_str());
  }
  return 0;
}

// Scripted probes sweep the organ's upper surface in a raster, pressing
// 6 mm (the depth a clinician uses to search), and the job reports what
// they felt.
int run_scripted(const ScenarioOptions& o, const scenario::Resolved& r) {
  const auto config = scenario::core_config(r, o.rate_hz, o.rate_hz / 2);
  const auto model = scenario::session_model(r, config);
  const mesh::SurfaceMesh& m = *model->mesh;
  std::vector<haptics::ProbeSetup> setups(o.probes);
  for (int j = 0; j < o.probes; ++j) {
    setups[j].name = "scripted probe " + std::to_string(j + 1);
    setups[j].spec.position_dof = 3;
    setups[j].safety.max_jump = 1e9;
  }
  const auto initial = deform::MaterialArrays::uniform(m.vertex_count(), r.tissues[r.base]);
  haptics::Session session(model, initial, setups);
  std::unique_ptr<record::Recorder> recorder;
  if (!o.record.empty())
    recorder = open_recording(o.record, *model, initial, setups,
                              session_info(r.organ.name, o.scenario, r.scenario.task.force_limit));
  Vec3 lo = m.positions[0], hi = lo;
  for (const Vec3& p : m.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double dt = 1.0 / o.rate_hz;
  const auto ticks = static_cast<long>(std::lround(o.seconds * o.rate_hz));
  std::vector<haptics::ProbeTickInput> in(o.probes);
  std::vector<haptics::ProbeTickResult> out(o.probes);
  double peak = 0;
  long over = 0, contact_ticks = 0;
  std::printf("%s: %zu tissues, %zu regions, %zu lesions, %zu pulses, breathing %s\n", r.scenario.title.c_str(),
              r.scenario.tissues.size(), r.scenario.regions.size(), r.lesions.size(), r.scenario.pulses.size(),
              r.scenario.breathing.enabled ? "on" : "off");
  std::printf("%8s", "t [s]");
  for (int j = 0; j < o.probes; ++j) std::printf("  probe%d |F| [N]", j + 1);
  std::printf("\n");
  const collision::VertexTree& tree = *model->tree;
  for (long n = 0; n < ticks; ++n) {
    const double t = static_cast<double>(n) * dt;
    for (int j = 0; j < o.probes; ++j) {
      // A raster over the top: x sweeps back and forth, y advances.
      const double u = std::fmod(0.25 * t + 0.3 * j, 2.0);
      const double fx = u < 1 ? u : 2 - u;
      const double fy = (j + 0.5) / o.probes;
      const Vec3 above(lo.x() + (0.15 + 0.7 * fx) * (hi.x() - lo.x()), lo.y() + (0.2 + 0.6 * fy) * (hi.y() - lo.y()),
                       hi.z());
      const Index v = tree.nearest(above).vertex;
      const double press = std::min(1.0, t / 0.5) * 0.006;
      Vec3 p = m.positions[v] - press * m.normals[v].normalized();
      if (model->field) p = model->field->to_world(p, t);
      in[j].sample = haptics::position_sample(p, static_cast<std::uint64_t>(n) + 1, t);
    }
    if (recorder)
      record::record_step(*recorder, session, t, in, out);
    else
      session.step(t, in, out);
    for (const auto& po : out) {
      const double f = haptics::to_vec(po.force_world).norm();
      peak = std::max(peak, f);
      over += f > r.scenario.task.force_limit ? 1 : 0;
      contact_ticks += po.in_contact ? 1 : 0;
    }
    if (n % std::max<long>(1, ticks / 10) == 0 || n == ticks - 1) {
      std::printf("%8.3f", t);
      for (const auto& po : out) std::printf("  %14.3f", haptics::to_vec(po.force_world).norm());
      std::printf("\n");
    }
  }
  std::printf("peak force %.3f N (task limit %.1f N, exceeded in %ld probe-ticks); in contact %.0f%% of probe-ticks\n",
              peak, r.scenario.task.force_limit, over,
              100.0 * static_cast<double>(contact_ticks) / static_cast<double>(std::max<long>(1, ticks * o.probes)));
  if (recorder) close_recording(*recorder, stdout);
  return 0;
}

}  // namespace

int scenario_main(const std::vector<std::string>& args) {
  ScenarioOptions o;
  try {
    o = parse(args);
  } catch (const Usage& e) {
    std::fprintf(stderr, "palpa-palpate: %s\n%s", e.what(), kUsage);
    return 2;
  }
  try {
    const scenario::Scenario s = scenario::load_scenario(o.scenario);
    const scenario::Resolved r = scenario::resolve(s);
    std::printf("scenario %s: organ %s, %zu vertices\n", o.scenario.c_str(), r.organ.name.c_str(),
                r.organ.mesh->vertex_count());
    return o.indent ? run_indent(o, r) : run_scripted(o, r);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palpa-palpate: %s\n", e.what());
    return 1;
  }
}

}  // namespace palpa::app
