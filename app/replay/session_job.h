#pragma once
// What palpa-replay and palpa-assess share: a session file opened with its
// session model rebuilt (the recorded mesh; for a scenario session the
// tissue field and tissue map resolved again from the recorded scenario
// text, its organ checked against the recorded mesh), and a replay of the
// recorded ticks in windows (bounded memory) that checks every force
// against the recorded one.

#include "assess/assess.h"
#include "haptics/loop_replay.h"
#include "haptics/session.h"
#include "record/session_file.h"
#include "tissue/lesion.h"

#include <atomic>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace palpa::app {

/// A session file and everything needed to re-run it.
struct LoadedSession {
  explicit LoadedSession(record::SessionFile f) : file(std::move(f)) {}
  record::SessionFile file;
  std::shared_ptr<const haptics::SessionModel> model;
  deform::MaterialArrays initial;
  std::vector<haptics::CommandRecord> commands;
  std::vector<std::shared_ptr<const deform::MaterialArrays>> kept;  ///< what the commands point to (SetMaterialMap maps, SetTissue tissues)
  std::vector<tissue::Lesion> lesions;  ///< the scenario's, placed (empty: none)
  std::string scenario_title;
  double tip_radius = 0.008;            ///< m (the scenario's probe; 8 mm without one)
  double force_limit = 0;               ///< N (0: none)
  bool has_roi = false;                 ///< the scenario has a region named "roi"
  std::vector<float> roi;               ///< its weights per vertex (when has_roi)
  assess::Task task;                    ///< the scenario's task and scoring (defaults without one)
  /// The first tick the file holds: 0, or for a session recorded from a
  /// loop already running (the workbench's Record) the tick of the snapshot
  /// it starts from. Its ticks are [first_tick, first_tick + header.ticks).
  std::uint64_t first_tick = 0;
};

/// Opens `file` and rebuilds its model. Throws record::RecordError, or
/// std::runtime_error naming the scenario when it no longer resolves or its
/// organ is not the recorded mesh.
LoadedSession load_session(const std::string& file);

/// The assessment of a loaded session: its stored results, or a replay of
/// it when the file has none (a recording of the live loop). `each` (may be
/// empty) is called with every tick too; a throw from it ends the
/// assessment (a caller's cancel). Throws what replay_session and the file
/// throw.
assess::Report assess_session(const LoadedSession& s,
                              const std::function<void(const haptics::TickRecord&,
                                                       std::span<const haptics::ProbeTickResult>)>& each = {});

/// How the replayed forces compare with the recorded ones.
struct ForceCheck {
  std::uint64_t ticks = 0;            ///< ticks compared
  bool identical = true;              ///< every force the same bits
  std::uint64_t first_tick = 0;       ///< the first tick that differs
  double first_time = 0;              ///< s, its time
  double first_difference = 0;        ///< N, its largest component difference
  double max_difference = 0;          ///< N, over every tick compared
  std::uint32_t first_probe = 0;
};

/// A session's assessment with everything its report page shows.
struct AssessedSession {
  assess::Report report;
  /// (s since the first tick, the largest |F| of any probe over each 50 ms, N)
  std::vector<std::pair<double, double>> force_curve;
  std::optional<assess::Coverage> coverage;  ///< per vertex: levels, peak force (N)
  std::vector<std::uint8_t> coverage_png;    ///< the coverage map on the organ, 480 px square
  double force_limit = 0;                    ///< N, the scenario's (0: none)
  std::string title;                         ///< "Palpa assessment: SCENARIO (TRAINEE)"
  std::string html;                          ///< the self-contained report page (assess::to_html)
  bool replayed = false;                     ///< no results stored: the ticks were replayed
  ForceCheck check;                          ///< when replayed, how its forces compared
};

/// assess_session, and the report page palpa-assess --html writes (the
/// same bytes): the coverage map rendered on the organ, the force plot and
/// the tables. `name` heads the page when the session has no scenario
/// title (palpa-assess passes the file as given).
AssessedSession assess_session_report(const LoadedSession& s, const std::string& name,
                                      const std::function<void(const haptics::TickRecord&,
                                                               std::span<const haptics::ProbeTickResult>)>& each = {});

/// Re-runs the session from tick `from` (from the latest snapshot at or
/// before it, else from tick 0; ticks before `from` are replayed but not
/// passed on; a session starting at a later first_tick starts from its
/// snapshot there, with `from` and `to` clipped to its ticks) to `to` (exclusive), calling `each` with the recorded tick,
/// the replayed results and the replayed surface. Compares forces
/// (force_device always, force_world where stored) into `check`. Reads the
/// file in windows of `window` ticks.
/// `inspect` (may be empty) is called after `each` with the replay itself
/// (from the first tick replayed, `from` or not).
void replay_session(const LoadedSession& s, std::uint64_t from, std::uint64_t to,
                    const std::function<void(const haptics::TickRecord&, std::span<const haptics::ProbeTickResult>,
                                             const deform::DeformableSurface&)>& each,
                    ForceCheck& check, std::uint64_t window = 20000,
                    const std::function<void(const haptics::TickRecord&, const haptics::LoopReplay&)>& inspect = {});

/// Replays the session file `file` once from its start and adds to it a
/// snapshot every `interval_s` (s, > 0) of session time, each at the first
/// tick past its time, stored with the deformation steps the replay had asked
/// for and not yet made (so that a seek restores it exactly; a tick whose
/// pending steps carry a material map or tissue edit, or more than
/// record::kMaxPendingSteps steps, waits for the next); ticks that already
/// have one are skipped. Only while the replay is bit-identical to the
/// recording: at the first difference it stops and throws
/// std::runtime_error naming the file, the tick and how many it added (those
/// are kept). `cancel` (may be null) set true stops it after loading or
/// between ticks, the snapshots added so far kept. Returns how many it
/// added. Throws record::RecordError naming the file, or
/// std::invalid_argument for an interval that is not > 0.
std::size_t add_seek_snapshots(const std::string& file, double interval_s, const std::atomic<bool>* cancel = nullptr);

/// One line about a force check, e.g. "forces bit-identical to the recording
/// over 5000 ticks" or "forces differ from tick 1234 (t = 1.234 s, probe 1) by
/// 3.1e-09 N; at most 4.2e-06 N over 5000 ticks".
std::string describe(const ForceCheck& c);

}  // namespace palpa::app
