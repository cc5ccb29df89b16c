// Resolving a scenario's lesions on its organ: surface points and depths to
// centres, seeded random lesions to lesions (deterministic on every platform).

#include "scenario/scenario.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace palpa::scenario {

namespace {

// SplitMix64 (Steele, Lea, Flood 2014): a fixed sequence for a seed, unlike
// std:: distributions, whose results differ between standard libraries.
struct SplitMix64 {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1): the top 53 bits.
  double unit() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * unit(); }
  // Uniform index in [0, n) by rejection (no modulo bias).
  std::size_t index(std::size_t n) {
    const std::uint64_t limit = std::numeric_limits<std::uint64_t>::max() - std::numeric_limits<std::uint64_t>::max() % n;
    std::uint64_t x;
    do x = next();
    while (x >= limit);
    return static_cast<std::size_t>(x % n);
  }
};

Index nearest_vertex(const mesh::SurfaceMesh& organ, const Vec3& p) {
  Index best = 0;
  double best_d = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < organ.positions.size(); ++i) {
    const double d = (organ.positions[i] - p).squaredNorm();
    if (d < best_d) best_d = d, best = static_cast<Index>(i);
  }
  return best;
}

}  // namespace

std::vector<tissue::Lesion> resolve_lesions(const Scenario& s, const mesh::SurfaceMesh& organ,
                                            const std::vector<float>& region_weight) {
  const std::string file = s.file.string();
  if (organ.positions.empty() || organ.normals.size() != organ.positions.size())
    throw ScenarioError(file, "/organ", "the organ has no vertices (or no normals) to place lesions on");
  std::vector<tissue::Lesion> out;
  // Lesions as written: a centre, or a depth below the nearest vertex.
  for (const LesionSpec& spec : s.lesions) {
    tissue::Lesion l = spec.lesion;
    if (spec.from_surface) {
      const Index v = nearest_vertex(organ, spec.surface_point);
      l.centre = organ.positions[v] - spec.depth * organ.normals[v];
    }
    out.push_back(l);
  }
  // Random lesions: vertices in the region, sizes, depths and ratios from the seed.
  const RandomLesions& r = s.random_lesions;
  if (r.count == 0) return out;
  std::vector<Index> candidates;
  if (r.region.empty()) {
    candidates.resize(organ.positions.size());
    for (std::size_t i = 0; i < candidates.size(); ++i) candidates[i] = static_cast<Index>(i);
  } else {
    if (region_weight.size() != organ.positions.size())
      throw std::invalid_argument("resolve_lesions: region_weight has " + std::to_string(region_weight.size()) +
                                  " values for " + std::to_string(organ.positions.size()) + " vertices");
    for (std::size_t i = 0; i < region_weight.size(); ++i)
      if (region_weight[i] >= 0.5f) candidates.push_back(static_cast<Index>(i));
    if (candidates.empty())
      throw ScenarioError(file, "/random_lesions/region", "no vertex of the organ lies in region \"" + r.region + "\"");
  }
  SplitMix64 rng{r.seed};
  for (std::uint32_t k = 0; k < r.count; ++k) {
    const Index v = candidates[rng.index(candidates.size())];
    const double radius = rng.uniform(r.radius_min, r.radius_max);
    const double depth = rng.uniform(r.depth_min, r.depth_max);
    tissue::Lesion l;
    l.name = "random " + std::to_string(k + 1);
    l.centre = organ.positions[v] - depth * organ.normals[v];
    l.semi_axes = Vec3::Constant(radius);
    l.modulus_ratio = rng.uniform(r.ratio_min, r.ratio_max);
    l.visibility = r.visibility;
    out.push_back(l);
  }
  return out;
}

}  // namespace palpa::scenario
