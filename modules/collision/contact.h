#pragma once
// Contact point interpolation and the 1-D height check (section III.C), and
// the contact query of the haptic tick: the in-contact walk of section V.A
// ("nearest vertex search is performed linearly moving through
// neighbourhoods when probe is in contact with surface") with the vertex
// tree as its exact fallback.

#include "collision/vertex_tree.h"
#include "mesh/surface_mesh.h"

#include <array>

namespace palpa::collision {

/// The virtual vertex under a probe: the point on a triangle of the
/// undeformed surface whose interpolated normal passes through the probe.
struct SurfacePoint {
  Index triangle = kNoIndex;
  Vec3 barycentric = Vec3::Zero();  ///< weights of the triangle's vertices (sum 1)
  Vec3 point = Vec3::Zero();        ///< on the undeformed surface, m
  Vec3 normal = Vec3::UnitZ();      ///< interpolated undeformed normal, unit
  double offset = 0;                ///< (probe - point) . normal, m (negative = below the undeformed surface)
  bool inside = false;              ///< barycentric weights all within the triangle (else clamped to its edge)
};

/// The corner (0, 1 or 2) of a triangle with the largest of the
/// barycentric weights `b` (dimensionless; the first of equal ones): the
/// corner a point at `b` is nearest.
inline int heaviest_corner(const Vec3& b) noexcept {
  return b[0] >= b[1] && b[0] >= b[2] ? 0 : (b[1] >= b[2] ? 1 : 2);
}

/// Finds the surface point for `probe` among the triangles around
/// `nearest_vertex` (its one-ring, widened to the neighbours' rings when no
/// triangle contains the projection). No allocation.
SurfacePoint locate_surface_point(const mesh::SurfaceMesh& mesh, const Vec3& probe, Index nearest_vertex);

/// Most triangles the in-contact walk visits before it gives up.
inline constexpr int kMaxWalkSteps = 6;
/// Where more than kFanValence triangles meet at a vertex (more than an
/// even mesh's six), the walk's steps that turn around it (across
/// consecutive edges sharing it) do not count towards kMaxWalkSteps but
/// towards kMaxFanSteps: a probe sliding near a fan of hundreds of thin
/// triangles crosses many of them in one tick, and without this the walk
/// gave up and the tree's answer searched the whole fan (tens of
/// microseconds). The same holds, on a smaller scale, where slivers double
/// a vertex's triangles (12 around it): a probe swinging round such a vertex
/// crosses six of them, and a walk that gave up there left the contact on
/// track_contact's proxy, which costs about twice a walk per tick.
inline constexpr std::size_t kFanValence = 6;
inline constexpr int kMaxFanSteps = 64;

/// The in-contact walk: solves the interpolated-normal equation on
/// `start_triangle` (the last contact triangle) and, while the solution lies
/// outside the triangle, steps across the edge opposite the most negative
/// barycentric weight (at most kMaxWalkSteps triangles; the neighbour across
/// an edge comes from mesh.triangle_neighbors, or from mesh.vertex_triangles
/// when that table is absent; steps around a high-valence vertex count
/// towards kMaxFanSteps instead). It answers only when it ends
/// inside a triangle (weights within 1e-9 of [0, 1]) with the probe below
/// the undeformed surface (offset < 0) and within half the focal distance
/// there, |offset| * kappa <= 1/2, where kappa (1/m) is the largest rate at
/// which the vertex normals turn along the triangle's edges,
/// |n_a - n_b| / |p_a - p_b| (1/R on a sphere of radius R with radial
/// normals). Otherwise (border or non-manifold edge, degenerate triangle,
/// too many steps, stepping back, probe above or too deep) it returns
/// triangle == kNoIndex. On the triangle it ends on, the answer is
/// bit-identical to locate_surface_point's. It follows the contact
/// continuously: where a fold of the surface is about as thin as the probe
/// is deep, several triangles' normals can pass through the probe, and the
/// walk keeps the one the contact slid in from while locate_surface_point
/// picks by the nearest vertex, so the two may differ there. No allocation.
SurfacePoint walk_surface_point(const mesh::SurfaceMesh& mesh, const Vec3& probe, Index start_triangle);

/// Why an in-contact walk stopped. Every decline of the walk is one of
/// these, so a caller (or a benchmark) can say why a query fell back to the
/// tree.
enum class WalkEnd : unsigned char {
  Answer = 0,       ///< ended inside a triangle, below the surface, within half the focal distance
  BadInput = 1,     ///< bad start triangle, probe or mesh tables: nothing walked
  Jump = 2,         ///< the probe moved farther than the start triangle's longest edge (query_contact's test)
  Unsolved = 3,     ///< the interpolated-normal equation had no usable solution on a triangle (degenerate)
  Above = 4,        ///< inside a triangle, but the probe is above the undeformed surface (offset >= 0)
  TooDeep = 5,      ///< inside a triangle, but deeper than half the focal distance there
  Border = 6,       ///< no triangle across the edge to step over: a border or non-manifold edge
  SteppedBack = 7,  ///< the step went straight back: the solution lies in no triangle here
  OutOfSteps = 8,   ///< kMaxWalkSteps (or kMaxFanSteps round a high-valence vertex) used up
  /// On a triangle too far from the point a walk's answer had to be near to
  /// be taken (track_contact's walk from the slid proxy; see there).
  OutOfReach = 9,
};

/// The triangles an in-contact walk visited, in order, and from which of
/// them a walk started afresh, with the same probe, ends as this one did.
/// Each step of the walk depends only on the triangle it is on and the
/// probe, so a walk started on a later triangle of the trace follows the
/// rest of it and stops where this one stopped (where this one stepped
/// straight back, a walk started on the last triangle steps back once and
/// then stops there too), except where this one ran out of steps: a new
/// walk has more. track_contact uses it to skip a second walk whose answer
/// it knows. (A tick's walk that passes over its start triangle on a guess,
/// see query_contact, records it unsolved; where the guess was wrong the
/// walk comes back and the trace starts again from there.)
struct WalkTrace {
  /// Most triangles a walk can visit: the start, kMaxWalkSteps - 1 steps
  /// and kMaxFanSteps steps around high-valence vertices.
  static constexpr int kCapacity = kMaxWalkSteps + kMaxFanSteps;
  std::array<Index, kCapacity> triangles;  ///< the first `count` are set
  int count = 0;  ///< triangles recorded
  /// True when a walk started on any of triangles[1 .. count - 1], with the
  /// same probe and no jump test, gives the same answer (the same bits, or
  /// no answer); false after a jump test or out of steps.
  bool repeatable = false;
  /// Why the walk stopped (Answer when it answered).
  WalkEnd end = WalkEnd::BadInput;

  /// True when a walk from `t` would repeat this one's answer.
  bool repeats_from(Index t) const {
    if (!repeatable) return false;
    for (int i = 1; i < count; ++i)
      if (triangles[i] == t) return true;
    return false;
  }
};

/// walk_surface_point, also recording the triangles visited in `trace`.
SurfacePoint walk_surface_point(const mesh::SurfaceMesh& mesh, const Vec3& probe, Index start_triangle,
                                WalkTrace& trace);

/// One triangle prepared for the interpolated-normal equation: its corners
/// and per-triangle constants, so a walk that stays on a triangle does not
/// rebuild them every tick. Filled by the walk; valid for the mesh
/// (unchanged) and the triangle its FrameCache lists it under (`owner`,
/// `key`). A frame is made only on a mesh the walk has checked, so a walk
/// that starts on the frame's triangle does not check it again.
struct TriangleFrame {
  mesh::Triangle corners{kNoIndex, kNoIndex, kNoIndex};
  /// Corner positions (m) and unit normals, as in the mesh.
  Vec3 p[3] = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  Vec3 n[3] = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  Vec3 p0 = Vec3::Zero(), e1 = Vec3::Zero(), e2 = Vec3::Zero();  ///< first corner and edges from it, m
  Vec3 n0 = Vec3::Zero(), f1 = Vec3::Zero(), f2 = Vec3::Zero();  ///< first corner's unit normal and normal differences
  Vec3 k0 = Vec3::Zero(), k1 = Vec3::Zero(), k2 = Vec3::Zero();  ///< e1 x e2 (m^2), f1 x e2 + e1 x f2 (m), f1 x f2
  double nk0 = 0, nk1 = 0, nk2 = 0;        ///< n0 . k0, n0 . k1, n0 . k2
  double inv_nk0 = 0;                      ///< 1 / nk0 (1/m^2), 0 when nk0 is 0
  double a11 = 0, a12 = 0, a22 = 0, det = 0;  ///< edge Gram matrix (m^2) and its determinant (m^4)
  double e3_sq = 0;                        ///< |e2 - e1|^2, m^2
  double longest_sq = 0;                   ///< the longest edge squared, m^2
  double root_scale = 0;                   ///< sqrt(a11 + a22), m: the solver's length scale
  double f1_sq = 0, f2_sq = 0, f3_sq = 0;  ///< |f1|^2, |f2|^2, |f2 - f1|^2
  bool flat = false;                       ///< all three normals equal
  bool neighbors = false;                  ///< the mesh has its triangle_neighbors table
};

/// The walk's last triangles, prepared (TriangleFrame). A walk that keeps
/// coming back to the same triangles, as the proxy's does each tick while
/// the probe is held deep, prepares each once. On the cingulate gyrus, where
/// a quarter of the vertices have more than kFanValence triangles, those
/// walks visit up to ten triangles a tick, and four kept triangles were
/// rebuilt every tick (16: 8 KB a probe). Replaced in turn; `last` is the
/// slot of the frame the walk ended on. The frames are of one mesh, `owner`,
/// and their triangles are listed apart (`key`, 64 bytes), so that a
/// lookup reads one or two lines, not one per frame. A cache only: the answers are
/// the same with any content (each frame is made from its mesh and
/// triangle). Value-initialised: empty.
struct FrameCache {
  static constexpr int kSize = 16;
  const mesh::SurfaceMesh* owner = nullptr;  ///< the mesh of the frames held; null: none held
  std::array<Index, kSize> key{};  ///< the triangle in each slot (with owner set; kNoIndex: none)
  TriangleFrame slot[kSize];
  int last = 0;  ///< slot of the walk's last triangle
  int next = 0;  ///< slot to replace next

  /// Forgets every frame.
  void clear() {
    owner = nullptr;
    last = 0;
    next = 0;
  }

  /// The number of frames held.
  int held() const {
    int n = 0;
    if (owner)
      for (Index k : key) n += k != kNoIndex;
    return n;
  }

  /// The slot of the prepared frame of triangle t of `mesh`, or -1.
  int find(const mesh::SurfaceMesh& mesh, Index t) const {
    if (owner != &mesh) return -1;
    if (key[last] == t) return last;
    for (int i = 0; i < kSize; ++i)
      if (key[i] == t) return i;
    return -1;
  }

  /// The slot to prepare triangle t of `mesh` in (the next in turn; a cache
  /// of another mesh is emptied first), listed as t's. The caller fills it.
  int take(const mesh::SurfaceMesh& mesh, Index t) {
    if (owner != &mesh) {
      owner = &mesh;
      key.fill(kNoIndex);
    }
    const int s = next;
    next = (next + 1) % kSize;
    key[s] = t;
    return s;
  }

  /// Asks for the lines a query reads first: the list, the last frame and
  /// the one to be replaced next (a warm-up does, since it runs on a copy
  /// without frames). No effect on results.
  void prefetch() const {
    __builtin_prefetch(&owner);
    __builtin_prefetch(key.data());
    for (const TriangleFrame* f : {&slot[last], &slot[next]}) {
      const char* p = reinterpret_cast<const char*>(f);
      for (std::size_t b = 0; b < sizeof(TriangleFrame); b += 64) __builtin_prefetch(p + b);
    }
  }
};

/// Per-probe memory of query_contact but its prepared triangles: what the
/// next answer depends on. Plain data; value-initialised means "no previous
/// answer". Copied alone (a ContactCursor sliced to it) where the cache
/// need not travel.
struct ContactCursorState {
  SearchCursor tree;          ///< leaf of the last tree answer (local search of section V.A)
  Index triangle = kNoIndex;  ///< triangle of the last answer
  Vec3 probe = Vec3::Zero();  ///< probe position of the last answer, m
  /// Barycentric weights of the last answer on `triangle` (sum 1): with it
  /// the last answer's point is the proxy that track_contact slides.
  Vec3 barycentric = Vec3::Zero();
  /// True when `barycentric` is the foot of the interpolated normal through
  /// the probe at `probe` (a walk's answer, or the tree's inside a
  /// triangle), so that the next walk may guess from it where the foot
  /// went; false after the proxy's answer (the probe deeper than half the
  /// focal distance, not on the normal at the proxy).
  bool at_foot = false;
  /// The triangle across the edge of `triangle` nearest to the last answer
  /// (where a sliding probe goes next); its data is fetched ahead of time.
  Index ahead = kNoIndex;
  /// The last tree answer that found the probe above the undeformed surface
  /// (offset > 0): where the probe was (m), its surface point and nearest
  /// vertex, and its clearance (m), a lower bound on the probe's distance
  /// from the undeformed surface there (VertexTree::clearance, at most
  /// kMaxClearance; 0: no such answer, a probe too close, or a tree that
  /// knows no surface). The ball of that radius holds no point of the
  /// surface, so a probe inside it is on the same side, above, and cannot
  /// have come into contact (track_contact's path Clear).
  Vec3 clear_from = Vec3::Zero();
  double clearance = 0;
  SurfacePoint clear_surface;
  Index clear_vertex = kNoIndex;
};

/// Per-probe memory of query_contact: its state and the walk's prepared
/// triangles. Plain data; value-initialised means "no previous answer".
struct ContactCursor : ContactCursorState {
  FrameCache frames;  ///< the walk's last triangles, prepared (a cache: no effect on answers)
};

/// Which way query_contact found its answer.
enum class ContactPath : unsigned char {
  None = 0,  ///< no answer (bad input or empty mesh)
  Walk = 1,  ///< in-contact walk from the last triangle
  Tree = 2,  ///< nearest vertex by the tree's local search + locate_surface_point
  /// In contact, the walk declined (the probe is deeper than half the focal
  /// distance, or it jumped): the proxy slid along the surface with the
  /// probe's motion (track_contact).
  Proxy = 3,
  /// Out of contact and inside the clearance of the last tree answer that
  /// found the probe above the surface (ContactCursor::clearance): nothing
  /// was searched. The surface point and nearest vertex are that answer's,
  /// with the offset measured again from its point along its normal.
  Clear = 4,
};

/// What query_contact found.
struct ContactAnswer {
  SurfacePoint surface;
  /// The nearest vertex (exact, from the tree) on the Tree path; on the Walk
  /// path the vertex of the contact triangle nearest to the probe; on the
  /// Clear path the last tree answer's.
  Index nearest_vertex = kNoIndex;
  ContactPath path = ContactPath::None;
};

/// The contact query of one haptic tick. When `in_contact` (the caller's
/// verdict on the previous answer: the probe was touching the surface) and
/// the probe moved less than the longest edge of the last triangle since
/// then, the walk runs from that triangle (where the last answer's weights,
/// the cursor's barycentric when at_foot, put its foot near enough to an
/// edge for the probe's motion to have carried it across, the walk first
/// tries the neighbour it guesses the foot is in, and goes on from there
/// when the foot passed a corner of the start; a wrong guess costs time,
/// not a different answer, except where the surface holds more than one
/// foot within the walk's reach); when
/// it declines, or otherwise, the tree's local search finds the exact
/// nearest vertex and
/// locate_surface_point the surface point around it. Updates the cursor. No
/// allocation.
ContactAnswer query_contact(const mesh::SurfaceMesh& mesh, const VertexTree& tree, const Vec3& probe,
                            ContactCursor& cursor, bool in_contact);

/// query_contact out of contact with the tree's search from its root, not
/// from the cursor's leaf: what track_contact asks where a probe comes out
/// above its proxy (a probe leaving contact). The leaf is where the last
/// tree answer was, which a probe that slid in contact may have left far
/// behind; a local search from a far leaf climbs high and searches wide
/// (about 8 us on a 1M-vertex sphere), and the root's path is the one the
/// clearance bound takes too. The same nearest vertex as query_contact
/// (ties aside, as VertexTree::nearest_local). Updates the cursor. No
/// allocation.
ContactAnswer query_contact_from_root(const mesh::SurfaceMesh& mesh, const VertexTree& tree, const Vec3& probe,
                                      ContactCursor& cursor);

/// Largest clearance (m) a tree answer above the surface asks of the tree
/// (ContactCursor::clearance): the bound's search stops there, and a probe
/// farther away is asked again after moving this far.
inline constexpr double kMaxClearance = 0.01;

/// Distance (m) a walk's answer in track_contact may lie from the proxy on
/// top of twice the probe's motion (round-off of a probe at rest).
inline constexpr double kProxyTolerance = 1e-9;

/// Most triangles slide_surface_point crosses in one call.
inline constexpr int kMaxSlideSteps = 64;

/// Moves a point of the undeformed surface along the surface: the point with
/// weights `barycentric` on `triangle` goes by the part of `displacement` (m)
/// tangent to that triangle's plane, crossing edges into the neighbouring
/// triangles (the motion left at an edge is turned into the next triangle's
/// plane, its length kept) until the motion is used up, a border or
/// non-manifold edge stops it (it stays on that edge), the motion turns
/// straight back across the edge it has just crossed (a crease whose planes
/// on both sides turn it towards the edge: it stays on that edge, on the
/// side it came from) or kMaxSlideSteps triangles were crossed. It never
/// leaves the surface, so it never passes through the volume to another
/// sheet. Weights that are not finite, negative
/// or do not sum to 1 are taken as the centroid. Returns the point (inside =
/// true) with its interpolated normal and the offset of `probe` along it;
/// triangle == kNoIndex for a bad triangle, a mesh without normals or
/// adjacency, or a non-finite input. No allocation.
SurfacePoint slide_surface_point(const mesh::SurfaceMesh& mesh, Index triangle, const Vec3& barycentric,
                                 const Vec3& displacement, const Vec3& probe);

/// Where the walk declines (deeper than half the focal distance), the proxy
/// of track_contact holds while the probe's distance from the proxy's normal
/// line is at most kProxyCone times its depth (a cone of half angle
/// atan(0.25), about 14 degrees: a press roughly along the normal does not
/// move the contact point).
inline constexpr double kProxyCone = 0.25;
/// Beyond that cone the proxy moves towards the probe's side at most
/// kProxyChase times as far as the probe moved across the proxy's normal
/// (it catches up with a sliding probe, yet stops when the probe stops);
/// the same limit holds while it chases the walk's answer.
inline constexpr double kProxyChase = 2.0;

/// The contact query with a god-object proxy, for the haptic tick. When not
/// `in_contact` (or without a last triangle) it is query_contact, except
/// that a probe which has moved less than the cursor's clearance from where
/// the last tree answer found it above the surface gets that answer again
/// without a search (path Clear; offset measured again from its point): it
/// is still above the undeformed surface, and a new contact needs it below
/// (height_check). A hovering probe costs a few loads then, not a tree
/// search; the contact verdicts, and so the forces, are the same as
/// without it wherever the mesh's normals point out of the side the probe
/// is on (a probe that comes within the clearance of the surface is asked
/// of the tree again before it can touch). In contact
/// the proxy (the last answer: cursor.triangle, cursor.barycentric) never
/// leaves the surface and the tree is never asked, so the contact cannot jump
/// through the volume to another sheet or fold:
///  1. the in-contact walk from the last triangle as in query_contact (path
///     Walk), taken only when its point is within 2 |probe motion| +
///     kProxyTolerance of the proxy (within half the focal distance the foot
///     of the interpolated normal moves at most twice as far as the probe; a
///     farther answer is another foot: another sheet, a fold, another root);
///  2. otherwise, where the walk answered but farther away (the proxy was
///     left behind the foot, holding in its cone during a deeper press), the
///     proxy slides along the surface (slide_surface_point) towards the
///     walk's point, at most kProxyChase times as far as the probe moved
///     across the proxy's normal since the last answer, so that 1. takes
///     over again without a jump once the foot is within its reach; where
///     the walk did not answer, the proxy stays while the probe lies within
///     the cone of half angle atan(kProxyCone) around the proxy's inward
///     normal, and beyond it slides towards the probe's side by the excess,
///     with the same limit (so it cannot run away where the probe is deeper
///     than the local centre of curvature);
///  3. from a new triangle the walk is tried again without the jump test
///     (Walk, same distance test); otherwise the proxy is the answer (path
///     Proxy; nearest_vertex is its triangle's corner of largest weight);
///  4. when the probe has come out above the proxy (offset >= 0), before the
///     contact is let go the tree's answer (query_contact's) decides: across
///     a convex fold the probe may still be below another part of the
///     surface, and then the contact goes on there (path Tree; its depth is
///     near zero then, as the proxy's is, so the force does not jump).
/// The answer's offset is measured along the proxy's interpolated normal, so
/// the caller's hysteretic height check holds the contact until the probe
/// comes back above the surface at the proxy. Updates the cursor. No
/// allocation.
ContactAnswer track_contact(const mesh::SurfaceMesh& mesh, const VertexTree& tree, const Vec3& probe,
                            ContactCursor& cursor, bool in_contact);

/// Result of the height check: the probe against the current deformed height
/// interpolated at the virtual vertex.
struct HeightCheck {
  double surface_height = 0;  ///< interpolated h at the virtual vertex, m
  double depth = 0;           ///< -offset: penetration below the undeformed surface, m
  /// offset < 0, and offset <= surface_height for a new contact (see height_check).
  bool in_contact = false;
};

/// The 1-D height check: the probe touches the surface when it lies below
/// the undeformed surface (offset < 0) and, for a new contact, not above the
/// current deformed one along the interpolated normal (offset <=
/// surface_height). It is hysteretic: with `was_in_contact` (the probe
/// touched at the previous tick) the contact holds while offset < 0 even
/// when the surface has moved past the probe, so an under-damped surface
/// that overshoots the probe does not make the contact flicker. `heights`
/// holds the current h (m) of the three vertices of sp.triangle, in the
/// triangle's vertex order.
HeightCheck height_check(const SurfacePoint& sp, const Vec3& heights, bool was_in_contact = false);

}  // namespace palpa::collision
