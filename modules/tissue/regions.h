#pragma once
// Heterogeneous tissue: regions and maps painted onto the organ's vertices.
// Layers combine in the order given (docs/TISSUE.md): the base tissue first,
// then each region in turn; a region's weight w in [0, 1] at a vertex
// (1 inside, 0 outside, a smoothstep across `feather` metres centred on the
// boundary) either blends the vertex towards the region's tissue (effective
// modulus E/(1-nu^2) blended linearly by w) or multiplies its modulus by
// 1 + w (scale - 1); image and value maps multiply it by their sampled scale.

#include "deform/material.h"
#include "mesh/surface_mesh.h"
#include "tissue/tissue.h"

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace palpa::tissue {

enum class RegionKind : std::uint8_t {
  Sphere = 0,          ///< centre, radius
  Ellipsoid = 1,       ///< centre, semi_axes (organ frame axes)
  Box = 2,             ///< box_min, box_max (organ frame axes)
  HalfSpace = 3,       ///< inside where (x - point) . normal <= 0
  GeodesicDisk = 4,    ///< surface within `radius` (along the surface) of the vertex nearest `centre`
  VertexArray = 5,     ///< per-vertex labels or values read from a VTP or PLY file
  PlanarImage = 6,     ///< 8- or 16-bit PNG projected along the plane's normal
  CylindricalImage = 7,///< 8- or 16-bit PNG wrapped around an axis
};

/// One layer of the tissue map. Lengths in m, organ frame.
struct Region {
  std::string name;
  RegionKind kind = RegionKind::Sphere;

  // Geometry.
  Vec3 centre = Vec3::Zero();          ///< Sphere, Ellipsoid, GeodesicDisk
  double radius = 0.01;                ///< Sphere, GeodesicDisk (geodesic), m
  Vec3 semi_axes = Vec3::Constant(0.01);  ///< Ellipsoid, m
  Vec3 box_min = Vec3::Constant(-0.01), box_max = Vec3::Constant(0.01);  ///< Box, m
  Vec3 point = Vec3::Zero(), normal = Vec3::UnitZ();  ///< HalfSpace (unit normal, outward of the inside)

  // Files (VertexArray, images): resolved to an absolute path by the scenario reader.
  std::filesystem::path file;
  /// VertexArray: the point-data array's name. Each organ vertex takes the
  /// value of the file's nearest point (so a file of the same organ in
  /// another vertex order, or welded, still maps).
  std::string array;
  /// VertexArray: labels (the array holds integers) map to tissues by
  /// name; a label not listed keeps what the layers below gave.
  std::map<int, std::string> label_tissues;

  // Image projection. Planar: pixel (0, 0) at `origin`, the image's width
  // along `u_axis` (a vector whose length is the width, m) and its height
  // along `v_axis`; vertices project along u x v. Cylindrical: around the
  // line through `origin` along unit `axis`; the image's width spans the
  // angle 0 .. 2 pi from unit `reference` (perpendicular to the axis), its
  // height spans `height` metres along the axis from `origin`. Vertices
  // outside the image are not affected.
  Vec3 origin = Vec3::Zero();
  Vec3 u_axis = Vec3(0.1, 0, 0), v_axis = Vec3(0, 0.1, 0);
  Vec3 axis = Vec3::UnitZ(), reference = Vec3::UnitX();
  double height = 0.1;
  /// Images and VertexArray values: a sample v in [0, 1] (pixel / 255 or
  /// / 65535; a value array is used as is) scales the modulus by
  /// scale_min + (scale_max - scale_min) v.
  double scale_min = 1.0, scale_max = 1.0;

  double feather = 0.0;  ///< boundary width, m (>= 0)

  // Effect (geometric regions): either a tissue, or a modulus scale.
  std::string tissue;    ///< non-empty: the region holds this tissue (by name)
  double scale = 1.0;    ///< else: modulus multiplier inside (> 0)

  friend bool operator==(const Region&, const Region&) = default;
};

/// What the layers give every vertex: a tissue (index into the tissue
/// list) and a modulus multiplier relative to that tissue's modulus.
struct TissueMap {
  std::vector<std::uint16_t> tissue_of;  ///< per vertex
  std::vector<float> scale;              ///< per vertex, dimensionless (> 0)
};

/// Membership weight of every vertex in one region, in [0, 1]. Throws
/// std::runtime_error naming the region and the fault (a file that cannot
/// be read, an array missing, a bad image).
std::vector<float> region_weights(const mesh::SurfaceMesh& mesh, const Region& region);

/// The tissue map of the layers over the base tissue. `tissues` are named
/// (Tissue::name); `base` indexes them. Throws std::runtime_error naming the
/// region and the fault (unknown tissue name, unreadable file).
TissueMap evaluate_tissue_map(const mesh::SurfaceMesh& mesh, const std::vector<Tissue>& tissues, std::size_t base,
                              const std::vector<Region>& regions);

}  // namespace palpa::tissue
