#pragma once
// One haptic tick for several probes: collision (contact query: in contact
// a god-object proxy that stays on the surface, collision::track_contact,
// else the tree's local search; contact interpolation, hysteretic height
// check), the local model at the virtual vertex and eq. (4). No allocation,
// no locks, no exceptions.

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
  /// Nearest vertex: exact when path == Tree; on the Walk path the contact
  /// triangle's vertex nearest to the probe (see collision::ContactAnswer).
  Index nearest_vertex = kNoIndex;
  collision::ContactPath path = collision::ContactPath::None;  ///< how the contact query answered
  deform::Contact contact;            ///< the contact to feed the surface (valid when in_contact)
};

/// Per-probe persistent data between ticks. Value-initialised = no history.
struct ProbeMemory {
  /// Last contact triangle and weights (in contact: the proxy), probe
  /// position and tree leaf (collision::track_contact).
  collision::ContactCursor cursor;
  /// The probe was in contact at the last tick: enables the in-contact walk
  /// and makes the height check hysteretic (the contact holds while the probe
  /// is below the undeformed surface, offset < 0, even when the deformed
  /// surface overshoots past it; a new contact needs offset <= h as well).
  bool in_contact = false;
  /// Vertices of cursor.triangle (valid with it), so the next tick can ask
  /// for their data before it reads the triangle.
  mesh::Triangle corners{kNoIndex, kNoIndex, kNoIndex};
};

/// Runs one tick for probes.size() probes against the surface's current
/// state. `outputs` and `memory` must have the same size as `probes`.
/// `shape` is the shape function given to each contact.
void haptic_tick(const deform::DeformableSurface& surface, const collision::VertexTree& tree,
                 std::span<const ProbeInput> probes, std::span<ProbeMemory> memory,
                 std::span<ProbeOutput> outputs, const ForceParams& params,
                 const deform::ShapeFunction& shape);

}  // namespace palpa::haptics
