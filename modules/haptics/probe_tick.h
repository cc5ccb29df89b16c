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
#include "tissue/field.h"

#include <array>
#include <cstdint>

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
  /// Height check result; on the Clear path only depth (-offset) is set.
  collision::HeightCheck height;
  /// Nearest vertex: exact when path == Tree; on the Walk path the contact
  /// triangle's vertex nearest to the probe; on the Clear path (a hovering
  /// probe, no search) the last tree answer's (see collision::ContactAnswer).
  Index nearest_vertex = kNoIndex;
  collision::ContactPath path = collision::ContactPath::None;  ///< how the contact query answered
  deform::Contact contact;            ///< the contact to feed the surface (valid when in_contact)
  /// Membership weight of the contact point in each dynamic region of the
  /// tissue field (0 without a field or contact).
  std::array<float, tissue::kMaxDynamicRegions> region_weight{};
};

/// What one tick needs of the tissue beyond the surface's materials:
/// lesions, pulse lifts and dynamic-region modulus factors at this tick's
/// time (computed once per tick by the caller).
struct TissueTick {
  const tissue::TissueField* field = nullptr;
  std::array<double, tissue::kMaxPulses> pulse_value{};           ///< m, per pulse
  std::array<double, tissue::kMaxDynamicRegions> dynamic_factor{1, 1, 1, 1};  ///< per dynamic region
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
  /// The corner of cursor.triangle with the largest weight, whose one-ring
  /// the ticks fetch ahead of the walk (a probe passing near a vertex crosses
  /// two or three triangles round it in one tick), and how far that fetch has
  /// got: 0 its rows' offsets asked for, 1 the rows, 2 the ring's triangles,
  /// 3 its vertices' data. One stage per tick, each reading only what the
  /// stage before asked for. Where data is fetched only: no effect on results.
  Index ring_vertex = kNoIndex;
  std::uint8_t ring_stage = 0;
};

/// Copies `from` into `to`, all but the cursor's prepared triangles
/// (collision::FrameCache: kSize frames of about 500 bytes), which `to`
/// keeps: a cache, with which every answer is the same whatever it holds.
inline void copy_state(const ProbeMemory& from, ProbeMemory& to) {
  static_cast<collision::ContactCursorState&>(to.cursor) = from.cursor;
  to.in_contact = from.in_contact;
  to.corners = from.corners;
  to.ring_vertex = from.ring_vertex;
  to.ring_stage = from.ring_stage;
}
static_assert(sizeof(ProbeMemory) == sizeof(collision::ContactCursor) + 24,
              "ProbeMemory changed: copy its new fields in copy_state");

/// No history (made before main, so that forget takes no guard on the
/// haptic thread).
inline const ProbeMemory kNoProbeMemory{};

/// Sets `m` to no history, as ProbeMemory{} does, without writing its
/// prepared triangles again (they are forgotten).
inline void forget(ProbeMemory& m) {
  copy_state(kNoProbeMemory, m);
  m.cursor.frames.clear();
}

/// Sets `w` to the memory a warm-up runs the last tick again with (into
/// scratch, as LoopCore::warm_caches does): `m`, except that a probe the
/// tick answered without a search (hovering within its clearance,
/// collision::ContactPath::Clear) is asked of the tree, so that the tree's
/// path is in the cache on the tick the probe leaves its clearance (tens of
/// microseconds on a 1M-vertex organ otherwise, against about one warm).
/// Without m's prepared triangles (not copied): `w` has none, so the
/// warm-up prepares the triangles it walks, reading their corners; the lines
/// of m's that the next tick reads first are asked for instead.
inline void set_warm_up_memory(const ProbeMemory& m, ProbeMemory& w) {
  m.cursor.frames.prefetch();
  copy_state(m, w);
  w.cursor.frames.clear();
  w.cursor.clearance = 0;
}

/// Where a warm-up rehearses a crossing past a corner (LoopCore::warm_caches):
/// the probe's last position (m) carried past the corner of its contact
/// triangle it is nearest by a quarter of that corner's distance from the
/// contact point, at the same offset from the surface. A probe passing near
/// a corner crosses two or three triangles round it in one tick, reading
/// triangles, corners and code that no other tick reads; a query there on
/// the warm-up's copy of the memory brings them into the cache. The move is
/// at most 1.25 x 2/3 of the triangle's longest edge (the corner's weight is
/// at least 1/3), within the walk's jump test. False without a contact
/// triangle (`point` unchanged).
bool corner_rehearsal_point(const mesh::SurfaceMesh& mesh, const ProbeMemory& m, Vec3& point);

/// Runs one tick for probes.size() probes against the surface's current
/// state. `outputs` and `memory` must have the same size as `probes`; with
/// `memory_slots`, probe i's memory is memory[memory_slots[i]] instead (so
/// that memories in slots with holes need not be gathered and copied back:
/// a FrameCache each).
/// `shape` is the shape function given to each contact. With `tissue`, the
/// normal reaction at indentation d is the local model's at
/// d + (the pulse lift at the contact point), with the modulus multiplied
/// by the dynamic regions' factors there, plus the lesions' contrast
/// (tissue/lesion.h) times its quasi-static part.
void haptic_tick(const deform::DeformableSurface& surface, const collision::VertexTree& tree,
                 std::span<const ProbeInput> probes, std::span<ProbeMemory> memory,
                 std::span<ProbeOutput> outputs, const ForceParams& params,
                 const deform::ShapeFunction& shape, const TissueTick* tissue = nullptr,
                 std::span<const std::uint8_t> memory_slots = {});

}  // namespace palpa::haptics
