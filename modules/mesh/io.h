#pragma once
// Loading and saving organ surfaces. OBJ, STL (ASCII and binary), PLY and OFF
// are read through OpenMesh; legacy VTK (.vtk, ASCII or BINARY) and XML
// PolyData (.vtp) through VTK's readers; SOFA's .trian by our own parser.
// Every loaded mesh is cleaned (welded, degenerate and duplicate triangles
// dropped, oriented outward, optionally reduced to its largest component),
// converted to metres and finalized (normals, adjacency).

#include "mesh/surface_mesh.h"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace palpa::mesh {

/// Bad input: the message always starts with the file name and says what is
/// wrong, e.g. "liver.obj: vertex 12 has a coordinate that is not a finite number".
/// Vertices and faces are numbered the way the format numbers them: from 1 in
/// OBJ, from 0 everywhere else (STL facets and their corners from 0).
class MeshError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// How to read and clean a mesh.
struct LoadOptions {
  /// Length of one file unit in metres: 1.0 for files in metres, 1e-3 for mm.
  double unit_m = 1.0;
  /// Merge vertices closer than weld_tolerance (file units); 0 merges exact duplicates only.
  bool weld = true;
  double weld_tolerance = 0.0;
  /// Flip triangles so that every component is consistently oriented with outward normals.
  bool orient_outward = true;
  /// Keep only the component with the most triangles (drops stray specks).
  bool keep_largest_component = false;
  /// Refuse larger inputs with a MeshError (protects against absurd files).
  /// Every limit is checked before the memory it guards is allocated.
  std::size_t max_vertices = 20'000'000;
  std::size_t max_triangles = 40'000'000;
  /// Largest file read, bytes (2 GiB).
  std::uintmax_t max_file_bytes = std::uintmax_t(2) << 30;
  /// Most vertices one polygon may have (OBJ, OFF, PLY, VTK polygons and strips).
  std::size_t max_face_vertices = 256;
  /// Largest |coordinate| accepted, file units (1e6: a kilometre in mm).
  double max_coordinate = 1e6;
  /// Smallest largest extent accepted, m after the unit (1 micrometre).
  double min_extent_m = 1e-6;
};

/// What cleaning changed.
struct CleanReport {
  std::size_t input_vertices = 0;        ///< as stored (STL: three per facet)
  std::size_t input_triangles = 0;       ///< after fan triangulation, before cleaning
  std::size_t welded_vertices = 0;       ///< vertices merged into others (for STL including
                                         ///< the corners OpenMesh's reader merges itself)
  std::size_t unused_vertices = 0;       ///< vertices referenced by no remaining triangle,
                                         ///< removed (welded ones not counted again)
  std::size_t degenerate_triangles = 0;  ///< zero-area or repeated-index triangles dropped
                                         ///< (including faces OpenMesh's OBJ / STL readers drop)
  std::size_t duplicate_triangles = 0;   ///< triangles with the same vertex set as another, dropped
  std::size_t flipped_triangles = 0;     ///< triangles reversed to orient outward: neighbours
                                         ///< across manifold edges agree; a closed patch gets
                                         ///< positive volume, an open one keeps its majority side
  std::size_t dropped_components = 0;    ///< components removed by keep_largest_component
};

/// Loads a mesh file (format chosen by extension, case-insensitive:
/// .obj .stl .ply .off .vtk .vtp .trian) in file units scaled by
/// options.unit_m to metres. Throws MeshError naming the file when it is
/// missing, not a regular file (a FIFO, a device, a directory) or unreadable,
/// has an unknown extension, holds no triangles, has non-finite coordinates or
/// coordinates beyond LoadOptions::max_coordinate, is smaller than
/// LoadOptions::min_extent_m, has out-of-range indices, faces with fewer than
/// three or more than max_face_vertices vertices, is truncated, or exceeds the
/// size limits (checked before allocating). OBJ, OFF (ASCII), PLY, legacy VTK
/// and .trian are read by our own parsers (an OBJ's mtllib is ignored); STL
/// through OpenMesh (serialised internally: its readers are shared
/// singletons), .vtp through VTK's XML reader. Float files give float32
/// precision.
SurfaceMesh load_mesh(const std::filesystem::path& path, const LoadOptions& options = {},
                      CleanReport* report = nullptr);

/// Builds a clean, finalized mesh from raw vertices (file units) and polygons
/// (0-based vertex indices). Polygons with more than three vertices are
/// fan-triangulated; fewer than three is an error. `source` names the input in
/// error messages. Throws MeshError as load_mesh does.
SurfaceMesh from_polygons(std::vector<Vec3> vertices, const std::vector<std::vector<long long>>& polygons,
                          const LoadOptions& options, const std::string& source,
                          CleanReport* report = nullptr);

/// Writes a mesh (positions in metres) as binary little-endian PLY (float32),
/// OBJ (9 significant digits) or binary STL (float32) by extension. Writes to
/// "<path>.palpa-tmp" first and renames it over `path`, so an existing file is
/// never left half-written. Throws MeshError for another extension, a triangle
/// with an out-of-range index, or when the file cannot be written.
void save_mesh(const SurfaceMesh& mesh, const std::filesystem::path& path);

}  // namespace palpa::mesh
