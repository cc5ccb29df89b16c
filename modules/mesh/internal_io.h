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

/// STL (ASCII and binary) through OpenMesh's reader, after our own scan.
RawMesh read_stl(const std::filesystem::path& path, const LoadOptions& options);

/// XML PolyData (.vtp) through VTK's reader.
RawMesh read_vtp(const std::filesystem::path& path, const LoadOptions& options);

// Our own parsers (io_text.cpp, io.cpp), on the file's bytes. Each checks
// every count against its limit and the bytes left before allocating.
/// Wavefront OBJ (mtllib and every other non-geometry line ignored).
RawMesh read_obj(const std::string& bytes, const std::string& source, const LoadOptions& options);
/// ASCII OFF (and COFF, NOFF, STOFF).
RawMesh read_off(const std::string& bytes, const std::string& source, const LoadOptions& options);
/// PLY, ascii or binary either endian.
RawMesh read_ply(const std::string& bytes, const std::string& source, const LoadOptions& options);
/// Legacy VTK POLYDATA, ASCII or BINARY, either cell layout.
RawMesh read_legacy_vtk(const std::string& bytes, const std::string& source, const LoadOptions& options);
/// SOFA's .trian text format.
RawMesh read_trian(const std::string& bytes, const std::string& source, const LoadOptions& options);

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
