#pragma once
// Finding and loading the organ a session shows: the bundled default organ
// and user files whose unit (m, cm, mm) is often unstated.

#include "mesh/io.h"
#include "mesh/surface_mesh.h"

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace palpa::mesh {

/// Length unit of a mesh file.
enum class MeshUnit : unsigned char {
  Auto = 0,        ///< the one of m, cm, mm that makes the largest extent closest to 0.15 m
  Metre = 1,
  Centimetre = 2,
  Millimetre = 3,
};

/// "auto", "m", "cm" or "mm"; throws std::invalid_argument
/// "unknown mesh unit 'X' (expected auto, m, cm or mm)".
MeshUnit parse_mesh_unit(std::string_view name);
/// Metres per file unit (Auto is not a unit: 0).
double unit_metres(MeshUnit unit);
/// For MeshUnit::Auto: the unit (m per file unit) that makes `largest_extent`
/// (file units) closest, in ratio, to an organ's 0.15 m.
double auto_unit_metres(double largest_extent);

/// A loaded organ and what is known about it.
struct Organ {
  std::shared_ptr<const SurfaceMesh> mesh;
  std::string name;        ///< file name, or "default organ"
  double unit_m = 1.0;     ///< metres per file unit used
  bool unit_guessed = false;
  std::string note;        ///< anything the user should know (generated instead of loaded...)
  MeshFacts facts;
};

/// Folder of the bundled data: $PALPA_DATA_DIR if set, else the source tree's data/.
std::filesystem::path data_dir();
/// data_dir() / "default_organ.ply".
std::filesystem::path default_organ_path();

/// Smallest and largest organ, m (largest extent of the bounding box after the unit).
inline constexpr double kMinOrganSize = 5e-3;
inline constexpr double kMaxOrganSize = 1.0;

/// Loads, cleans (largest component only), scales and numbers in spatial
/// order (reorder_spatially: nearby vertices adjacent in memory) a mesh file. Throws
/// MeshError naming the file, and when the organ is not kMinOrganSize ..
/// kMaxOrganSize across: "<file>: the organ is 138 m across with the unit m;
/// an organ is 5 mm to 1 m across: with the unit mm it is 13.8 cm" (or ", and
/// no unit (m, cm or mm) makes it so"). Open boundaries and non-manifold
/// edges are named in Organ::note ("not a closed surface: 1 open boundary
/// (12 boundary edges, the first at (x, y, z) mm)...").
Organ load_organ(const std::filesystem::path& path, MeshUnit unit = MeshUnit::Auto);
/// The bundled default organ (metres); generated with make_organ()
/// when the file is missing (said in Organ::note).
Organ load_default_organ();

}  // namespace palpa::mesh
