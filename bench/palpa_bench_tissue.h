#pragma once
// palpa-bench's tissue-map section: a smooth map giving every vertex of a
// 1M-vertex sphere a different modulus, evaluated (tissue::evaluate_tissue_map)
// and applied (DeformableSurface::set_tissue_map), and the deformation step
// with three contacts on it against the same surface of one uniform Hertz
// material (tissue::hertz_material).

#include <nlohmann/json.hpp>

#include <cstddef>

namespace palpa::bench {

/// Measures and prints the section; appends its records to `records` (a JSON
/// array). `vertices`: the sphere's target vertex count; `rounds`: how many
/// times each measurement is repeated (medians are printed).
void run_tissue_map_bench(std::size_t vertices, int rounds, nlohmann::json& records);

}  // namespace palpa::bench
