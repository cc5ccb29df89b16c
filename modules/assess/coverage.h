#pragma once
// Pressure levels and surface coverage (docs/ASSESSMENT.md).
//
// A probe in contact at indentation d (m) over a point whose local tissue
// thickness is T (m, mesh::inward_thickness at the contact's nearest
// vertex) presses at level
//   light   d <  kMediumFraction T
//   medium  kMediumFraction T <= d < kDeepFraction T
//   deep    d >= kDeepFraction T.
// A vertex counts as covered at a level when it lay within the Hertz
// contact radius a = sqrt(R d) (R the probe's tip radius) of a contact at
// that level, measured straight (not along the surface) from the contact
// point, on the side the contact normal faces; the contact's nearest
// vertex always counts (a contact radius below the vertex spacing still
// covers the vertex it presses).

#include "collision/vertex_tree.h"
#include "mesh/surface_mesh.h"

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

namespace palpa::assess {

enum class Level : std::uint8_t { None = 0, Light = 1, Medium = 2, Deep = 3 };
inline constexpr std::size_t kLevels = 4;
const char* level_name(Level l);

inline constexpr double kMediumFraction = 0.05;  ///< of the local thickness
inline constexpr double kDeepFraction = 0.15;    ///< of the local thickness

/// The level of a contact at indentation `depth` (m) over tissue `thickness` thick (m).
Level level_of(double depth, double thickness, bool in_contact);

/// Coverage of a mesh, accumulated contact by contact. Not thread-safe.
class Coverage {
 public:
  /// `tip_radius` in m. Takes the mesh's thickness from
  /// mesh::shared_inward_thickness (computed, O(V log V), unless another
  /// user of this mesh object holds it); `tree` may be null (one is built).
  Coverage(std::shared_ptr<const mesh::SurfaceMesh> mesh, double tip_radius,
           std::shared_ptr<const collision::VertexTree> tree = nullptr);

  /// One probe's contact at `point` (organ frame, m) with indentation
  /// `depth` (m) and force `force` (N, |F|). Returns its level. `episode`
  /// numbers contact episodes (a new one each time a probe comes into
  /// contact) for revisits.
  Level add(const Vec3& point, double depth, std::uint32_t episode, double force = 0);

  /// The level of the contact at `point` (organ frame, m) with indentation
  /// `depth` (m), without adding it.
  Level level_at(const Vec3& point, double depth) const;
  /// Nearest vertex of `point` (organ frame, m).
  Index nearest(const Vec3& point) const;

  const mesh::SurfaceMesh& mesh() const { return *mesh_; }
  /// Per vertex: the highest level it was covered at (None: never).
  const std::vector<Level>& highest() const { return highest_; }
  /// Per vertex and level: covered at exactly that level.
  bool covered(Index v, Level l) const { return (mask_[v] >> static_cast<int>(l)) & 1; }
  /// Per vertex: the area (m^2) it stands for (a third of its triangles').
  const std::vector<double>& area() const { return area_; }
  /// Per vertex: distinct contact episodes that covered it (capped at 255).
  const std::vector<std::uint8_t>& episodes() const { return episodes_; }
  /// Per vertex: the inward thickness (m) the levels are fractions of.
  const std::vector<double>& thickness() const { return *thickness_; }
  /// Per vertex: the largest force (N) of a contact that covered it.
  const std::vector<double>& peak_force() const { return peak_force_; }

 private:
  std::shared_ptr<const mesh::SurfaceMesh> mesh_;
  std::shared_ptr<const collision::VertexTree> tree_;
  double tip_radius_;
  std::shared_ptr<const std::vector<double>> thickness_;  // shared with the mesh's other users (m)
  std::vector<double> area_, peak_force_;
  std::vector<Level> highest_;
  std::vector<std::uint8_t> mask_, episodes_;
  std::vector<std::uint32_t> last_episode_;
  std::vector<std::uint32_t> seen_;   // BFS marks
  std::uint32_t stamp_ = 0;
  std::vector<Index> queue_;
};

}  // namespace palpa::assess
