// The workbench's replay of a session file (session_player.h).

#include "app/gui/session_player.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace palpa::app {
namespace {

constexpr double kCheckpointInterval = 5.0;      // s of session time between the checkpoints kept while playing
constexpr std::size_t kMaxCheckpoints = 64;      // checkpoints kept at most (a 40k-vertex organ: ~2 MB each)
constexpr std::uint64_t kWindow = 20000;         // ticks read from the file at a time
constexpr std::uint64_t kDeformMargin = 4096;    // ticks back whose deformation steps may still be pending

}  // namespace

SessionPlayer::SessionPlayer(const std::string& file)
    : file_(file), session_(std::make_unique<LoadedSession>(load_session(file))) {
  const record::SessionHeader& h = session_->file.header();
  if (h.ticks == 0) throw std::runtime_error(file + ": holds no ticks");
  first_ = session_->first_tick;
  end_ = first_ + h.ticks;
  rate_ = h.config.rate_hz > 0 ? h.config.rate_hz : 1000.0;
  const record::TickSpan span = session_->file.ticks(first_, first_ + 1);
  if (span.ticks.empty()) throw std::runtime_error(file + ": its first tick " + std::to_string(first_) + " is missing");
  t0_ = span.ticks.front().time;
  if (session_->file.same_layout())
    for (const auto& s : session_->file.snapshots()) snapshots_.push_back(s.tick);
  std::sort(snapshots_.begin(), snapshots_.end());
  seek_tick(first_);
}

SessionPlayer::~SessionPlayer() = default;

double SessionPlayer::duration() const { return static_cast<double>(end_ - first_ - 1) / rate_; }

const deform::DeformableSurface& SessionPlayer::surface() const { return replay_->surface(); }

// A fresh replay at `tick`: tick 0 (the recording's initial state), or one
// of the file's snapshots.
void SessionPlayer::restart_from(std::uint64_t tick) {
  const LoadedSession& s = *session_;
  const record::SessionHeader& h = s.file.header();
  auto replay = std::make_unique<haptics::LoopReplay>(s.model, s.initial, h.setups);
  if (tick > 0) {
    record::DecodedState d = s.file.snapshot(tick, *s.model);
    if (d.pending_map) pending_maps_.push_back(d.pending_map);
    replay->restore({std::move(d.state), std::move(d.pending)});
  }
  replay_ = std::move(replay);
  shown_ = false;
  last_start_ = tick;
}

void SessionPlayer::seek(double seconds) {
  const double ticks = std::round(std::max(0.0, seconds) * rate_);
  seek_tick(ticks >= static_cast<double>(end_ - first_) ? end_ - 1 : first_ + static_cast<std::uint64_t>(ticks));
}

bool SessionPlayer::advance(double seconds) {
  if (at_end()) return false;
  const auto step = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(std::max(0.0, seconds) * rate_)));
  seek_tick(std::min(end_ - 1, tick_ + step));
  return true;
}

void SessionPlayer::seek_tick(std::uint64_t target) {
  target = std::clamp(target, first_, end_ - 1);
  if (replay_ && shown_ && tick_ == target) return;
  // The latest state at or before the target: a snapshot of the file (or
  // the recording's start, tick 0), a checkpoint, or where the replay is.
  std::uint64_t best = first_;
  for (std::uint64_t s : snapshots_)
    if (s <= target) best = std::max(best, s);
  const haptics::ReplayState* checkpoint = nullptr;
  for (const auto& [t, state] : checkpoints_)
    if (t <= target && t > best) {
      best = t;
      checkpoint = &state;
    }
  const std::uint64_t here = replay_ ? replay_->tick() : 0;  // the next tick the replay makes
  if (replay_ && here <= target && here >= best) {
    last_start_ = here;
  } else if (checkpoint) {
    replay_->restore(*checkpoint);
    shown_ = false;
    last_start_ = best;
  } else {
    restart_from(best);
  }
  run_to(target);
}

// Re-runs ticks up to `target` in windows. Each window holds one tick more
// than it runs (when the file has it), and the run stops before that tick:
// the deformation steps asked for but not yet used stay pending, as they
// were live, so the surface is the one the target tick saw.
void SessionPlayer::run_to(std::uint64_t target) {
  const LoadedSession& s = *session_;
  haptics::LoopRecording rec;
  rec.commands = s.commands;
  while (replay_->tick() <= target) {
    const std::uint64_t w = replay_->tick();
    const std::uint64_t e = std::min(target + 1, w + kWindow);  // run [w, e)
    record::TickSpan span = s.file.ticks(w, std::min(e + 1, end_));
    if (span.ticks.empty())
      throw std::runtime_error(file_ + ": tick " + std::to_string(w) + " is missing from the file");
    rec.ticks = std::move(span.ticks);
    // The steps the replay has asked for and not yet made, from the oldest
    // (a snapshot's pending steps may be older than the margin).
    std::uint64_t asked = w > first_ + kDeformMargin ? w - kDeformMargin : first_;
    for (const auto& q : replay_->pending()) asked = std::min(asked, q.tick);
    rec.deforms = s.file.deforms(asked, e + 1);
    replay_->run(
        rec,
        [&](const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> r) {
          ++simulated_;
          tick_ = t.tick;
          time_ = t.time - t0_;
          probe_count_ = std::min(r.size(), results_.size());
          std::copy_n(r.begin(), probe_count_, results_.begin());
          // Checkpoints for seeking back (the state after this tick).
          if (t.tick >= last_checkpoint_ + static_cast<std::uint64_t>(kCheckpointInterval * rate_) &&
              checkpoints_.size() < kMaxCheckpoints &&
              std::none_of(checkpoints_.begin(), checkpoints_.end(), [&](const auto& c) { return c.first == t.tick + 1; })) {
            checkpoints_.emplace_back(t.tick + 1, replay_->snapshot());
            last_checkpoint_ = t.tick;
          }
        },
        e);
    shown_ = true;
    if (replay_->tick() == w) throw std::runtime_error(file_ + ": the replay made no progress at tick " + std::to_string(w));
  }
}

}  // namespace palpa::app
