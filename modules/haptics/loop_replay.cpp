#include "haptics/loop_replay.h"

#include <deque>
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
    : mesh_(std::move(mesh)) {
  tree_ = std::make_unique<collision::VertexTree>(std::span<const Vec3>(mesh_->positions));
  surface_ = std::make_unique<deform::DeformableSurface>(mesh_, std::move(materials), options);
  core_ = std::make_unique<LoopCore>(*tree_, *mesh_, config, std::move(setups));
}

void LoopReplay::run(const LoopRecording& rec,
                     const std::function<void(const TickRecord&, std::span<const ProbeTickResult>)>& each) {
  if (!rec.ticks.empty() && rec.ticks.front().tick != 0)
    throw std::invalid_argument("replay: the recording starts at tick " + std::to_string(rec.ticks.front().tick) +
                                ", not at tick 0");
  const std::size_t n = core_->probe_count();
  std::array<ProbeTickResult, kMaxProbes> results{};
  std::vector<deform::Contact> scratch;
  // Contacts recomputed by the replayed ticks, until a step has used them.
  std::deque<ContactSet> recent;
  std::size_t next_command = 0, next_deform = 0;

  for (std::size_t k = 0; k < rec.ticks.size(); ++k) {
    const TickRecord& tr = rec.ticks[k];
    if (tr.tick != k)
      throw std::invalid_argument("replay: tick " + std::to_string(k) + " is missing from the recording");
    if (tr.probe_count != n)
      throw std::invalid_argument("replay: tick " + std::to_string(k) + " has " + std::to_string(tr.probe_count) +
                                  " probes, the replay " + std::to_string(n));

    // Bring the model to the generation this tick used.
    while (generation_ < tr.model_generation) {
      if (next_deform >= rec.deforms.size() || rec.deforms[next_deform].generation != generation_ + 1)
        throw std::invalid_argument("replay: deformation step " + std::to_string(generation_ + 1) +
                                    " used by tick " + std::to_string(k) + " is missing from the recording");
      const DeformRecord& d = rec.deforms[next_deform++];
      ContactSet used;
      used.tick = d.contacts_tick;
      if (d.contacts_tick != kNoContactsTick) {
        while (!recent.empty() && recent.front().tick < d.contacts_tick) recent.pop_front();
        if (recent.empty() || recent.front().tick != d.contacts_tick)
          throw std::invalid_argument("replay: contacts of tick " + std::to_string(d.contacts_tick) +
                                      " are not available for deformation step " + std::to_string(d.generation));
        used = recent.front();
      }
      to_contacts(used, scratch);
      surface_->set_contacts(scratch);
      surface_->step(d.dt);
      ++generation_;
    }

    // Commands applied at the start of this tick, then the tick itself.
    while (next_command < rec.commands.size() && rec.commands[next_command].tick <= k) {
      const CommandRecord& c = rec.commands[next_command++];
      if (c.tick == k) core_->apply(c.command, c.time);
    }
    ContactSet contacts;
    core_->tick(k, tr.time, *surface_, tr.model_time, std::span<const ProbeTickInput>(tr.inputs.data(), n),
                std::span<ProbeTickResult>(results.data(), n), contacts);
    // Keep only contacts a later deformation step may still use.
    if (next_deform < rec.deforms.size()) {
      recent.push_back(contacts);
      const std::uint64_t needed = rec.deforms[next_deform].contacts_tick;
      if (needed != kNoContactsTick)
        while (!recent.empty() && recent.front().tick < needed) recent.pop_front();
    }
    if (each) each(tr, std::span<const ProbeTickResult>(results.data(), n));
  }

  // Deformation steps the live loop made after its last tick.
  while (next_deform < rec.deforms.size() && rec.deforms[next_deform].generation == generation_ + 1) {
    const DeformRecord& d = rec.deforms[next_deform++];
    ContactSet used;
    used.tick = d.contacts_tick;
    if (d.contacts_tick != kNoContactsTick) {
      while (!recent.empty() && recent.front().tick < d.contacts_tick) recent.pop_front();
      if (recent.empty() || recent.front().tick != d.contacts_tick) break;
      used = recent.front();
    }
    to_contacts(used, scratch);
    surface_->set_contacts(scratch);
    surface_->step(d.dt);
    ++generation_;
  }
}

}  // namespace palpa::haptics
