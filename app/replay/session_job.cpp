// Opening a session with its model, and replaying it in windows (session_job.h).

#include "app/replay/session_job.h"

#include "app/replay/overlay.h"
#include "mesh/spatial_order.h"
#include "scenario/resolve.h"
#include "scenario/scenario.h"
#include "tissue/regions.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <set>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

namespace palpa::app {

LoadedSession load_session(const std::string& file) {
  LoadedSession s(record::SessionFile::open(file));
  const auto& h = s.file.header();
  auto mesh = s.file.mesh();
  s.force_limit = h.info.force_limit;
  if (!h.info.scenario_json.empty()) {
    // The recorded scenario text, resolved again: its organ must be the recorded mesh.
    const scenario::Scenario sc = scenario::parse_scenario(h.info.scenario_json, h.info.scenario_file);
    scenario::Resolved r = scenario::resolve(sc);
    if (r.organ.mesh->positions != mesh->positions || r.organ.mesh->triangles != mesh->triangles) {
      if (!mesh::same_mesh_up_to_spatial_order(*mesh, *r.organ.mesh))
        throw std::runtime_error(file + ": the organ of its scenario (" + sc.organ.path +
                                 ") is not the recorded mesh; the organ file changed since the session");
      // Recorded before organs were numbered in spatial order: the same
      // organ in the file's numbering. The model is resolved on the recorded
      // numbering, which the ticks and snapshots refer to.
      mesh::Organ organ = r.organ;
      organ.mesh = mesh;
      r = scenario::resolve_on(sc, std::move(organ));
    }
    s.model = haptics::SessionModel::make(mesh, h.options, h.config, r.field, r.materials);
    s.lesions = r.lesions;
    s.scenario_title = sc.title;
    s.tip_radius = sc.probe.tip_radius;
    s.force_limit = sc.task.force_limit;
    const scenario::Scoring& sg = sc.task.scoring;
    s.task.time_limit = sc.task.time_limit;
    s.task.position_tolerance = sg.position_tolerance;
    s.task.size_tolerance = sg.size_tolerance;
    s.task.pass_score = sg.pass_score;
    s.task.weight_found = sg.weight_found;
    s.task.weight_size = sg.weight_size;
    s.task.weight_consistency = sg.weight_consistency;
    s.task.weight_force = sg.weight_force;
    s.task.weight_coverage = sg.weight_coverage;
    for (const auto& region : sc.regions)
      if (region.name == "roi") {
        s.has_roi = true;
        s.roi = tissue::region_weights(*mesh, region);
      }
  } else {
    s.model = haptics::SessionModel::make(mesh, h.options, h.config);
  }
  s.task.force_limit = s.force_limit;
  s.initial = s.file.initial_materials();
  s.commands = s.file.commands(s.kept);
  // A recording of a loop already running starts at its snapshot's tick.
  if (h.ticks > 0 && s.file.ticks(0, 1).ticks.empty()) {
    const auto snaps = s.file.snapshots();
    if (snaps.empty())
      throw std::runtime_error(file + ": its ticks do not start at tick 0 and it holds no snapshot to start from");
    s.first_tick = snaps.front().tick;
    for (const auto& snap : snaps) s.first_tick = std::min(s.first_tick, snap.tick);
    if (s.file.ticks(s.first_tick, s.first_tick + 1).ticks.empty())
      throw std::runtime_error(file + ": its first snapshot (tick " + std::to_string(s.first_tick) +
                               ") is not where its ticks start");
  }
  return s;
}

namespace {

// Largest component difference (N), and whether the bits differ.
bool differs(const haptics::Triple& a, const haptics::Triple& b, double& d) {
  d = 0;
  for (int k = 0; k < 3; ++k) d = std::max(d, std::abs(a[k] - b[k]));
  return std::memcmp(&a, &b, sizeof a) != 0;
}

}  // namespace

void replay_session(const LoadedSession& s, std::uint64_t from, std::uint64_t to,
                    const std::function<void(const haptics::TickRecord&, std::span<const haptics::ProbeTickResult>,
                                             const deform::DeformableSurface&)>& each,
                    ForceCheck& check, std::uint64_t window,
                    const std::function<void(const haptics::TickRecord&, const haptics::LoopReplay&)>& inspect) {
  const auto& h = s.file.header();
  to = std::min<std::uint64_t>(to, s.first_tick + h.ticks);
  from = std::max(from, s.first_tick);
  haptics::LoopReplay replay(s.model, s.initial, h.setups);
  // Seek: the latest snapshot at or before `from`.
  std::shared_ptr<const deform::MaterialArrays> pending;
  std::uint64_t start = 0;
  std::uint64_t asked_from = 0;  // the first window's deformation steps: from the oldest one still pending
  if (from > 0 && s.file.same_layout()) {
    for (const auto& snap : s.file.snapshots())
      if (snap.tick <= from && snap.tick > start) start = snap.tick;
    if (start > 0) {
      record::DecodedState d = s.file.snapshot(start, *s.model);
      pending = d.pending_map;
      asked_from = start;
      for (const auto& q : d.pending) asked_from = std::min(asked_from, q.tick);
      replay.restore({std::move(d.state), std::move(d.pending)});
    }
  }
  haptics::LoopRecording rec;
  rec.commands = s.commands;
  for (std::uint64_t w = start; w < to; w += window) {
    const std::uint64_t end = std::min(to, w + window);
    record::TickSpan span = s.file.ticks(w, end);
    if (span.ticks.empty()) break;
    rec.ticks = std::move(span.ticks);
    rec.deforms = s.file.deforms(w == start ? asked_from : w, end);
    const auto& stored = span.results;
    replay.run(rec, [&](const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> r) {
      ++check.ticks;
      for (std::size_t j = 0; j < r.size(); ++j) {
        double d1 = 0, d2 = 0;
        bool bad = differs(r[j].force_device, t.force_device[j], d1);
        if (!stored.empty()) bad = differs(r[j].force_world, stored[t.tick - w][j].force_world, d2) || bad;
        const double d = std::max(d1, d2);
        if (bad && check.identical) {
          check.identical = false;
          check.first_tick = t.tick;
          check.first_time = t.time;
          check.first_difference = d;
          check.first_probe = static_cast<std::uint32_t>(j);
        }
        check.max_difference = std::max(check.max_difference, d);
      }
      if (t.tick >= from && each) each(t, r, replay.surface());
      if (inspect) inspect(t, replay);
    });
  }
}

std::size_t add_seek_snapshots(const std::string& file, double interval_s, const std::atomic<bool>* cancel) {
  if (!(interval_s > 0) || !std::isfinite(interval_s))
    throw std::invalid_argument("add_seek_snapshots: the interval must be a time > 0 s, got " + std::to_string(interval_s));
  const auto cancelled = [cancel] { return cancel && cancel->load(std::memory_order_relaxed); };
  const LoadedSession s = load_session(file);
  const record::SessionHeader& h = s.file.header();
  if (h.ticks == 0 || cancelled()) return 0;
  record::SnapshotAppender out(file);
  std::set<std::uint64_t> have;
  for (const auto& snap : s.file.snapshots()) have.insert(snap.tick);
  const std::uint64_t end = s.first_tick + h.ticks;
  const double t0 = s.file.ticks(s.first_tick, s.first_tick + 1).ticks.front().time;
  double next = interval_s;
  std::size_t added = 0;
  struct Stop {};
  ForceCheck check;
  try {
    replay_session(s, s.first_tick, end, nullptr, check, 20000,
                   [&](const haptics::TickRecord& t, const haptics::LoopReplay& replay) {
                     if (cancelled() || !check.identical) throw Stop{};
                     // replay.tick(): the next tick, where a seek from this state goes on.
                     if (t.time - t0 < next || !record::storable(replay.pending()) || replay.tick() >= end) return;
                     next = (std::floor((t.time - t0) / interval_s) + 1) * interval_s;
                     if (have.count(replay.tick())) return;
                     const haptics::ReplayState state = replay.snapshot();
                     out.add(state.session, state.pending);
                     ++added;
                   });
  } catch (const Stop&) {
  }
  // A replay that no longer gives the recorded forces cannot stand for the
  // recording's state: the snapshots stop there, and the caller hears why.
  if (!check.identical && !cancelled())
    throw std::runtime_error(file + ": seek snapshots stop at tick " + std::to_string(check.first_tick) + " (" +
                             std::to_string(added) + " added): its replay " + describe(check));
  return added;
}

namespace {

// Feeds the assessor every tick: the stored results, or a replay of the
// session when the file has none (a recording of the live loop).
void assess_ticks(const LoadedSession& s, assess::Assessor& a,
                  const std::function<void(const haptics::TickRecord&, std::span<const haptics::ProbeTickResult>)>& each,
                  bool& replayed, ForceCheck& check) {
  const auto& h = s.file.header();
  auto add = [&](const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> r) {
    a.add(t, r);
    if (each) each(t, r);
  };
  const std::uint64_t first = s.first_tick, end = s.first_tick + h.ticks;
  const bool stored = h.ticks > 0 && !s.file.ticks(first, first + 1).results.empty();
  replayed = false;
  if (stored) {
    for (std::uint64_t w = first; w < end; w += 20000) {
      const auto span = s.file.ticks(w, w + 20000);
      if (span.ticks.empty() || span.results.size() != span.ticks.size()) break;
      for (std::size_t k = 0; k < span.ticks.size(); ++k)
        add(span.ticks[k], std::span<const haptics::ProbeTickResult>(span.results[k].data(), span.ticks[k].probe_count));
    }
  } else if (h.ticks > 0) {
    replayed = true;
    replay_session(s, first, end, [&](const auto& t, auto r, const auto&) { add(t, r); }, check);
  }
}

assess::Options assess_options(const LoadedSession& s) {
  assess::Options opt;
  opt.tip_radius = s.tip_radius;
  opt.roi = s.roi;
  return opt;
}

}  // namespace

assess::Report assess_session(const LoadedSession& s,
                              const std::function<void(const haptics::TickRecord&,
                                                       std::span<const haptics::ProbeTickResult>)>& each) {
  assess::Assessor a(s.model->mesh, s.lesions, s.task, assess_options(s));
  bool replayed = false;
  ForceCheck check;
  assess_ticks(s, a, each, replayed, check);
  assess::Report r = a.finish(s.file.events());
  r.session_status = std::string(record::status_name(s.file.header().status));
  return r;
}

AssessedSession assess_session_report(const LoadedSession& s, const std::string& name,
                                      const std::function<void(const haptics::TickRecord&,
                                                               std::span<const haptics::ProbeTickResult>)>& each) {
  const auto& h = s.file.header();
  AssessedSession out;
  assess::Assessor a(s.model->mesh, s.lesions, s.task, assess_options(s));
  double t0 = 0;
  bool first = true;
  auto& curve = out.force_curve;
  assess_ticks(
      s, a,
      [&](const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> r) {
        if (first) {
          t0 = t.time;
          first = false;
        }
        double f = 0;
        for (const auto& p : r) f = std::max(f, haptics::to_vec(p.force_world).norm());
        const double bucket = std::floor((t.time - t0) / 0.05) * 0.05;
        if (curve.empty() || curve.back().first < bucket)
          curve.emplace_back(bucket, f);
        else
          curve.back().second = std::max(curve.back().second, f);
        if (each) each(t, r);
      },
      out.replayed, out.check);
  out.report = a.finish(s.file.events());
  out.report.session_status = std::string(record::status_name(h.status));
  out.coverage.emplace(a.coverage());
  cv::imencode(".png", coverage_map(a.coverage(), Vec3(0, -std::sin(0.61), std::cos(0.61)), Vec3::UnitZ(), 480),
               out.coverage_png);
  out.title = "Palpa assessment: " + (s.scenario_title.empty() ? name : s.scenario_title) +
              (h.info.trainee.empty() ? "" : " (" + h.info.trainee + ")");
  out.force_limit = s.force_limit;
  out.html = assess::to_html(out.report, out.title, out.coverage_png, out.force_curve, out.force_limit);
  return out;
}

std::string describe(const ForceCheck& c) {
  char b[256];
  if (c.identical)
    std::snprintf(b, sizeof b, "forces bit-identical to the recording over %llu ticks",
                  static_cast<unsigned long long>(c.ticks));
  else
    std::snprintf(b, sizeof b, "forces differ from tick %llu (t = %.6f s, probe %u) by %.3g N; at most %.3g N over %llu ticks",
                  static_cast<unsigned long long>(c.first_tick), c.first_time, c.first_probe + 1, c.first_difference,
                  c.max_difference, static_cast<unsigned long long>(c.ticks));
  return b;
}

}  // namespace palpa::app
