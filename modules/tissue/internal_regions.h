#pragma once
// Internal to the tissue module (and its tests): what one region gives each
// vertex before the layer rules of evaluate_tissue_map use it.

#include "tissue/regions.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace palpa::tissue::internal {

/// One region sampled at every vertex.
struct RegionSample {
  /// Membership in [0, 1]: the feathered weight of a geometric region; for
  /// maps (images, vertex arrays) 1 where the map covers the vertex, else 0.
  std::vector<float> weight;
  /// Maps only: the sampled value where weight > 0 (an image's v in [0, 1],
  /// a value array's value as is, a label array's integer label), else 0.
  /// Empty for geometric regions.
  std::vector<float> value;
};

/// Samples one region (region_weights returns its `weight`). Throws
/// std::runtime_error "region '<name>': ..." on bad geometry or a bad file.
RegionSample sample_region(const mesh::SurfaceMesh& mesh, const Region& region);

/// smoothstep(t) = t^2 (3 - 2 t) on [0, 1], clamped outside.
inline double smoothstep01(double t) {
  if (t <= 0) return 0;
  if (t >= 1) return 1;
  return t * t * (3 - 2 * t);
}

/// Weight from a signed distance d (m, negative inside) and a feather width
/// (m): smoothstep(-d / feather + 1/2); with feather 0: 1 for d <= 0, else 0.
inline double feathered_weight(double d, double feather) {
  if (feather > 0) return smoothstep01(-d / feather + 0.5);
  return d <= 0 ? 1.0 : 0.0;
}

/// The approximate signed distance (m) of p to the ellipsoid with centre c
/// and semi-axes a (see docs/TISSUE.md, Region maps): k0 (k0 - 1) / k1 with
/// k0 = |q / a|, k1 = |q / a^2|, q = p - c. Exact on a sphere and on the
/// surface (0); first order in the distance near it.
double ellipsoid_signed_distance(const Vec3& p, const Vec3& c, const Vec3& a);

/// Geodesic distance (m) from vertex `source` along the surface to every
/// vertex, by fast marching over the triangles (a vertex is updated from the
/// unfolded planar wavefront through an edge of two accepted corners, else
/// along an edge). Stops once the accepted distance exceeds `max_distance`;
/// vertices not reached are +infinity.
std::vector<double> geodesic_distances(const mesh::SurfaceMesh& mesh, Index source, double max_distance);

/// Point data of a VTP or PLY file: positions (file units) and one scalar
/// array by name. Throws std::runtime_error "region '<name>': ...".
struct PointArray {
  std::vector<Vec3> points;
  std::vector<double> values;
};
PointArray read_point_array(const std::filesystem::path& file, const std::string& array, const std::string& what);

}  // namespace palpa::tissue::internal
