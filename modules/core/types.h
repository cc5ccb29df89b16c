#pragma once
// Basic types shared by every core module. All quantities are SI: metres,
// newtons, seconds, kilograms.

#include <Eigen/Core>
#include <cstdint>

namespace palpa {

/// A point or vector in 3-D, metres (or a unit vector, dimensionless).
using Vec3 = Eigen::Vector3d;

/// Index of a mesh vertex or triangle.
using Index = std::uint32_t;

/// Marks "no vertex / no triangle".
inline constexpr Index kNoIndex = 0xffffffffu;

/// A half-open range [begin, end) of vertex indices.
struct IndexRange {
  Index begin = 0;
  Index end = 0;
  friend bool operator==(const IndexRange&, const IndexRange&) = default;
};

}  // namespace palpa
