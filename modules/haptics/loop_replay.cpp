#include "haptics/loop_replay.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace palpa::haptics {

std::size_t LoopRecording::drain(HapticLoop& loop) {
  std::size_t n = 0;
  if (auto* q = loop.tick_records()) {
    TickRecord r;
    while (q->pop(r)) {
      ticks.push_back(r);
      ++n;
    }
  }
  if (auto* q = loop.command_records()) {
    CommandRecord r;
    while (q->pop(r)) {
      commands.push_back(r);
      ++n;
    }
  }
  if (auto* q = loop.deform_records()) {
    DeformRecord r;
    while (q->pop(r)) {
      deforms.push_back(r);
      ++n;
    }
  }
  return n;
}

LoopReplay::LoopReplay(std::shared_ptr<const mesh::SurfaceMesh> mesh, deform::MaterialArrays materials,
                       deform::SurfaceOptions options, const CoreConfig& config, std::vector<ProbeSetup> setups)
    : session_(std::make_unique<Session>(std::move(mesh), std::move(materials), options, config, std::move(setups))) {}

LoopReplay::LoopReplay(std::shared_ptr<const SessionModel> model, deform::MaterialArrays materials,
                       std::vector<ProbeSetup> setups)
    : session_(std::make_unique<Session>(std::move(model), std::move(materials), std::move(setups))) {}

// The live loop's record of `generation`, or null when it folded that step
// into a later one (it does so only when it fell behind).
const DeformRecord* LoopReplay::made_live(const LoopRecording& rec, std::uint64_t generation) {
  const auto it = std::lower_bound(rec.deforms.begin(), rec.deforms.end(), generation,
                                   [](const DeformRecord& d, std::uint64_t g) { return d.generation < g; });
  return it != rec.deforms.end() && it->generation == generation ? &*it : nullptr;
}

// Makes the pending steps up to `generation`, skipping those the live loop dropped.
void LoopReplay::catch_up(const LoopRecording& rec, std::uint64_t generation, std::uint64_t tick, bool strict) {
  while (session_->generation() < generation) {
    if (pending_.empty()) {
      if (!strict) return;
      throw std::invalid_argument("replay: deformation step " + std::to_string(session_->generation() + 1) +
                                  " used by tick " + std::to_string(tick) + " is missing from the recording");
    }
    DeformRequest r = pending_.front();
    pending_.pop_front();
    // A folded step: only its edits (the next made step covers its time);
    // a made one: the step the live loop took (dt summed over folded ones).
    const DeformRecord* d = made_live(rec, r.generation);
    r.dt = d ? d->dt : 0.0;
    session_->deform(r);
  }
}

void LoopReplay::run(const LoopRecording& rec,
                     const std::function<void(const TickRecord&, std::span<const ProbeTickResult>)>& each,
                     std::uint64_t until) {
  const std::uint64_t start = session_->tick_count();
  if (rec.ticks.empty()) return;
  if (rec.ticks.front().tick > start)
    throw std::invalid_argument("replay: the recording starts at tick " + std::to_string(rec.ticks.front().tick) +
                                ", not at tick " + std::to_string(start));
  std::size_t k = static_cast<std::size_t>(start - rec.ticks.front().tick);
  std::array<ProbeTickResult, kMaxProbes> results{};
  std::size_t next_command = static_cast<std::size_t>(
      std::lower_bound(rec.commands.begin(), rec.commands.end(), start,
                       [](const CommandRecord& c, std::uint64_t t) { return c.tick < t; }) -
      rec.commands.begin());

  for (; k < rec.ticks.size(); ++k) {
    const TickRecord& tr = rec.ticks[k];
    const std::uint64_t tick = session_->tick_count();
    if (tick >= until) return;
    if (tr.tick != tick)
      throw std::invalid_argument("replay: tick " + std::to_string(tick) + " is missing from the recording");

    // Bring the model to the generation this tick used.
    catch_up(rec, tr.model_generation, tick, true);

    // Commands applied at the start of this tick, then the tick itself.
    while (next_command < rec.commands.size() && rec.commands[next_command].tick <= tick) {
      const CommandRecord& c = rec.commands[next_command++];
      if (c.tick != tick) continue;
      session_->apply(c.command, c.time);
      if (c.immediate) session_->apply_edits_now();
    }
    const std::size_t n = session_->core().probe_count();
    if (tr.probe_count != n)
      throw std::invalid_argument("replay: tick " + std::to_string(tick) + " has " + std::to_string(tr.probe_count) +
                                  " probes, the replay " + std::to_string(n));
    if (session_->tick(tr.time, std::span<const ProbeTickInput>(tr.inputs.data(), n),
                       std::span<ProbeTickResult>(results.data(), n), tr.model_time))
      pending_.push_back(session_->core().request());
    if (each) each(tr, std::span<const ProbeTickResult>(results.data(), n));
  }

  // Deformation steps the live loop made after its last tick.
  const std::uint64_t last = rec.deforms.empty() ? 0 : rec.deforms.back().generation;
  catch_up(rec, last, session_->tick_count(), false);
}

}  // namespace palpa::haptics
