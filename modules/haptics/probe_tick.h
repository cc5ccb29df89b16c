#pragma once
// One haptic tick for several probes: collision (nearest vertex by local
// search, contact interpolation, height check), the local model at the
// virtual vertex and eq. (4). No allocation, no locks, no exceptions.

#include "collision/contact.h"
#include "collision/vertex_tree.h"
#include "deform/surface.h"
#include "haptics/force.h"

#include <span>

namespace palpa::haptics {

/// What a device (or the mouse) says about one probe this tick.
struct ProbeInput {
  Vec3 position = Vec3::Zero();  ///< probe tip, world frame, m
  Vec3 velocity = Vec3::Zero();  ///< m/s
};

/// What the tick computed for one probe.
struct ProbeOutput {
  Vec3 force = Vec3::Zero();          ///< force on the probe, N (clamped, finite)
  double normal_reaction = 0;         ///< Fn of eq. (4) before clamping, N
  bool in_contact = false;
  collision::SurfacePoint surface;    ///< virtual vertex under the probe
  collision::HeightCheck height;      ///< height check result
  Index nearest_vertex = kNoIndex;
  deform::Contact contact;            ///< the contact to feed the surface (valid when in_contact)
};

/// Per-probe persistent data (the local-search cursor and the last position).
struct ProbeMemory {
  collision::SearchCursor cursor;
};

/// Runs one tick for probes.size() probes against the surface's current
/// state. `outputs` and `memory` must have the same size as `probes`.
/// `shape` is the shape function given to each contact.
void haptic_tick(const deform::DeformableSurface& surface, const collision::VertexTree& tree,
                 std::span<const ProbeInput> probes, std::span<ProbeMemory> memory,
                 std::span<ProbeOutput> outputs, const ForceParams& params,
                 const deform::ShapeFunction& shape);

}  // namespace palpa::haptics
