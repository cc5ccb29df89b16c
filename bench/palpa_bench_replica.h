#pragma once
// palpa-bench, issue 8: the deformation step of the live loop's two replicas
// (stepped twice, as before, against one step and a copy of what changed),
// and the haptic tick with the deformation step on another thread, as
// HapticLoop runs them (palpa_bench_replica.cpp).

#include "haptics/session.h"
#include "palpa_bench_path.h"
#include "palpa_bench_util.h"

#include <cstddef>
#include <vector>

namespace palpa::bench {

/// The requests a session made, applied to two fresh replicas in two ways:
/// `both` steps each replica (HapticLoop before issue 8), `level` steps one
/// and brings the other level with DeformableSurface::level_with (roles
/// alternating, as HapticLoop does now). Per request, us; `equal`: both
/// ways end with bit-identical replicas.
struct ReplicaStepFigures {
  Latency both, level, level_step, level_copy;
  double changed_mean = 0;  ///< vertices copied per request
  double active_mean = 0;   ///< active set after the step
  bool equal = false;
};
ReplicaStepFigures measure_replica_steps(const haptics::SessionModel& model,
                                         const std::vector<haptics::DeformRequest>& requests, std::size_t skip);

/// The haptic tick (LoopCore::tick on the replica the deformation thread is
/// not writing) paced at the model's rate on this thread while another
/// thread makes the deformation steps on the other replica and brings the
/// first level, exactly as HapticLoop::process (level false: steps both
/// replicas, as HapticLoop did before issue 8). This thread waits for each
/// tick as the haptic thread of the workbench does: it sleeps, then spins
/// the last `spin_us` (us), and with `warm` runs the warm-up of
/// LoopConfig::warm_before_tick during the spin (haptics::warm_during_spin),
/// and the held replica's warm-up once more just before the tick
/// (haptics::touch_before_tick).
/// With `place`, the threads run where the workbench runs them: this thread
/// on one CPU of its own (chosen as haptics::reserve_haptic_cpu chooses it),
/// at SCHED_FIFO where the process may, and the deformation thread on the
/// others; this thread's CPUs and policy are restored afterwards.
/// Per tick and per step, us.
struct ThreadedFigures {
  Latency tick, step;
  std::size_t steps = 0, merged = 0;
  std::size_t warm_ups = 0;  ///< warm-ups run before the timed ticks and between them
  /// The timed ticks split by the replica they read: the one held from the
  /// warm-up at the spin's deadline, or (no held warm-up: a late wake, or a
  /// warm-up that overran) the current one, taken by the tick itself.
  Latency tick_held, tick_taken;
  /// Held ticks whose replica was no longer the current one when the tick
  /// began (the deformation thread published another during the hold).
  std::size_t held_behind = 0;
  /// Tick slots skipped among the timed ones because the haptic thread was
  /// held up past them (HapticLoop skips them the same way).
  std::size_t skipped = 0;
  Latency warm;  ///< each warm-up between timed ticks (at most 4 per tick kept)
  int haptic_cpu = -1;    ///< the CPU the ticking thread had to itself (-1: not placed)
  bool realtime = false;  ///< the ticking thread ran at SCHED_FIFO
};
struct ThreadedPacing {
  bool level = true;
  double spin_us = 850;  ///< the workbench's spin at 1 kHz with a CPU kept for the haptic thread
  bool warm = true;
  /// With `warm`: the held warm-up at the spin's deadline, whose replica the
  /// tick reads (false: none there, the tick takes the current replica, as
  /// before the hold).
  bool hold = true;
  /// Threads placed as in the workbench (see measure_threaded); false: where
  /// the scheduler puts them.
  bool place = true;
};
ThreadedFigures measure_threaded(const std::shared_ptr<const haptics::SessionModel>& model, const ProbePaths& paths,
                                 int probes, std::size_t warmup, std::size_t ticks, const ThreadedPacing& pacing);

}  // namespace palpa::bench
