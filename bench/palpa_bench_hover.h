#pragma once
// palpa-bench's hovering section: three probes on the paths of
// palpa-loop-bench (each presses 4 mm into the default organ and rises 4 mm
// above it, circling 3 mm, period 3 s), so that half of the probe queries
// are out of contact, ticked by haptics::haptic_tick with the loop's
// warm-up before each tick and a deformation step every 10 ticks. Once
// with a tree that knows the surface (a hovering probe within its
// clearance is not searched for, collision::ContactPath::Clear) and once
// with a tree built from the positions alone (every probe out of contact
// is searched for, as before the clearance), alternating.

#include <nlohmann/json.hpp>

#include <cstddef>

namespace palpa::bench {

/// Measures and prints the section; appends its records to `records` (a JSON
/// array). `vertices`: the organ's target vertex count; `ticks`: timed
/// ticks per run; `rounds`: runs of each variant (alternating).
void run_hover_bench(std::size_t vertices, std::size_t ticks, int rounds, nlohmann::json& records);

}  // namespace palpa::bench
