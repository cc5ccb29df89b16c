#pragma once
// Internal to the mesh module: the raw polygon soup every reader produces, the
// readers themselves and the cleaning pass. Not part of the public API.

#include "mesh/io.h"

#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <string>
#include <vector>

namespace palpa::mesh::internal {

/// A polygon soup exactly as a reader found it (file units, indices unchecked).
struct RawMesh {
  std::vector<Vec3> vertices;              ///< file units
  std::vector<std::int64_t> face_indices;  ///< all polygons' vertex indices, 0-based, unchecked
  std::vector<std::size_t> face_offsets{0};  ///< polygon f is face_indices[offsets[f] .. offsets[f+1])
  /// How the format numbers vertices and faces in error messages (1 for OBJ, else 0).
  int index_base = 0;
  /// Duplicate vertices the reader merged itself (OpenMesh's STL reader does).
  std::size_t premerged_vertices = 0;
  /// Faces with repeated vertices the reader dropped itself (OpenMesh's OBJ and STL readers do).
  std::size_t predropped_degenerate = 0;

  std::size_t face_count() const { return face_offsets.size() - 1; }
  void add_face(std::initializer_list<std::int64_t> ids) {
    face_indices.insert(face_indices.end(), ids);
    face_offsets.push_back(face_indices.size());
  }
};

/// Throws MeshError("<source>: <what>").
[[noreturn]] void fail(const std::string& source, const std::string& what);

/// OBJ, STL, PLY, OFF through OpenMesh's readers (ext lower-case, without dot).
RawMesh read_openmesh(const std::filesystem::path& path, const std::string& ext, const LoadOptions& options);

/// Legacy VTK (.vtk) and XML PolyData (.vtp) through VTK's readers.
RawMesh read_vtk(const std::filesystem::path& path, const std::string& ext, const LoadOptions& options);

/// SOFA's .trian text format (own parser).
RawMesh read_trian(const std::filesystem::path& path, const LoadOptions& options);

/// Checks a soup (limits, finite coordinates, face sizes, index range),
/// fan-triangulates it, cleans it, converts it to metres and finalizes it.
SurfaceMesh build_mesh(RawMesh raw, const LoadOptions& options, const std::string& source,
                       CleanReport* report);

/// The cleaning pass on a triangle soup with checked indices (clean.cpp):
/// weld, drop degenerate and duplicate triangles, keep the largest component,
/// orient outward, remove unused vertices. Positions stay in file units.
void clean_triangles(std::vector<Vec3>& positions, std::vector<Triangle>& triangles,
                     const LoadOptions& options, CleanReport& report);

}  // namespace palpa::mesh::internal
