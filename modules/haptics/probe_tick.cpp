// One haptic tick (sections III.C, III.E, V.A): contact query (in-contact
// walk from the last triangle, else nearest vertex by the tree's local
// search and the virtual vertex around it), hysteretic 1-D height check,
// local model at the virtual vertex, eq. (4), clamp.

#include "haptics/probe_tick.h"

#include <algorithm>
#include <cmath>

namespace palpa::haptics {

namespace {

// The material of the virtual vertex: every parameter (modulus scales
// applied) interpolated with the barycentric weights. Tissues all share the
// Hertz law, so the force keeps its form across a region edge; corners of
// different kinds (legacy N/m materials) take the heaviest corner's kind.
deform::Material interpolate_material(const deform::DeformableSurface& surface, const mesh::Triangle& tri,
                                      const Vec3& b) {
  int heaviest = 0;
  if (b[1] > b[heaviest]) heaviest = 1;
  if (b[2] > b[heaviest]) heaviest = 2;
  deform::Material m;
  m.model = surface.material(tri[heaviest]).model;
  m.mass = m.damping = m.stiffness = m.alpha = m.k2 = m.tau = m.hertz = m.relaxation = 0;
  for (int k = 0; k < 3; ++k) {
    const deform::Material mk = surface.vertex_material(tri[k]);
    m.mass += b[k] * mk.mass;
    m.damping += b[k] * mk.damping;
    m.stiffness += b[k] * mk.stiffness;
    m.alpha += b[k] * mk.alpha;
    m.k2 += b[k] * mk.k2;
    m.tau += b[k] * mk.tau;
    m.hertz += b[k] * mk.hertz;
    m.relaxation += b[k] * mk.relaxation;
  }
  return m;
}

// One probe against the surface; `out` starts cleared (no contact, no force).
void tick_one(const deform::DeformableSurface& surface, const collision::VertexTree& tree, const ProbeInput& in,
              ProbeMemory& memory, ProbeOutput& out, const ForceParams& params,
              const deform::ShapeFunction& shape, const TissueTick* tissue) {
  const mesh::SurfaceMesh& mesh = surface.mesh();
  const auto& states = surface.state().vertices;
  // Contact only if proven below; the walk needs last tick's verdict.
  const bool was_in_contact = memory.in_contact;
  memory.in_contact = false;
  if (!in.position.allFinite()) return;
  // A non-finite velocity is treated as rest (no damping, no friction).
  const Vec3 velocity = in.velocity.allFinite() ? in.velocity : Vec3::Zero();

  // Collision: contact query (walk or tree), virtual vertex, height check (section III.C).
  // In contact the proxy stays on the surface (collision::track_contact).
  const collision::ContactAnswer ca = collision::track_contact(mesh, tree, in.position, memory.cursor, was_in_contact);
  if (ca.nearest_vertex == kNoIndex) return;
  out.nearest_vertex = ca.nearest_vertex;
  out.path = ca.path;
  out.surface = ca.surface;
  if (out.surface.triangle == kNoIndex) return;
  // Provably above the surface (collision::track_contact): out of contact,
  // the surface's heights not read (surface_height stays 0).
  if (ca.path == collision::ContactPath::Clear) {
    out.height.depth = -out.surface.offset;
    return;
  }
  const mesh::Triangle& tri = mesh.triangles[out.surface.triangle];
  if (states.size() != mesh.vertex_count()) return;
  const Vec3& b = out.surface.barycentric;
  const Vec3 heights(states[tri[0]].h, states[tri[1]].h, states[tri[2]].h);
  out.height = collision::height_check(out.surface, heights, was_in_contact);
  if (!out.height.in_contact) return;
  memory.in_contact = true;
  memory.corners = tri;

  // Normal reaction of the interpolated local model at the probe's height
  // h = -depth moving at dh/dt = v . N (section III.E).
  deform::Material m = interpolate_material(surface, tri, b);
  const double q = b[0] * states[tri[0]].q + b[1] * states[tri[1]].q + b[2] * states[tri[2]].q;
  double h = -out.height.depth;
  const double dhdt = velocity.dot(out.surface.normal);
  const tissue::TissueField* field = tissue ? tissue->field : nullptr;
  if (field) {
    // The pulse lifts the rest surface under the probe: the indentation is
    // measured from the lifted surface.
    for (std::size_t p = 0; p < field->pulse_count; ++p) {
      const auto& w = field->pulse_weight[p];
      const double wi = b[0] * w[tri[0]] + b[1] * w[tri[1]] + b[2] * w[tri[2]];
      h -= wi * tissue->pulse_value[p];
    }
    // Dynamic regions (keyframes, guarding) scale the modulus where they are.
    double factor = 1.0;
    for (std::size_t r = 0; r < field->dynamic_count; ++r) {
      const auto& w = field->dynamic_weight[r];
      const double wi = b[0] * w[tri[0]] + b[1] * w[tri[1]] + b[2] * w[tri[2]];
      out.region_weight[r] = static_cast<float>(wi);
      factor *= 1.0 + wi * (tissue->dynamic_factor[r] - 1.0);
    }
    if (factor != 1.0 && factor > 0) m = deform::scaled(m, factor);
  }
  const deform::LocalModel& model = deform::local_model(m.model);
  double fn = model.restoring_force(m, h, dhdt, q);
  if (field && field->lesion_count > 0 && h < 0) {
    // Lesions add their contrast times the quasi-static force (lesion.h).
    const double d = -h;
    const Vec3 tip = out.surface.point - d * out.surface.normal;
    double contrast = 0.0;
    for (std::size_t l = 0; l < field->lesion_count; ++l)
      contrast += tissue::lesion_contrast(field->lesions[l], tip, d, field->tip_radius);
    fn += contrast * -model.equilibrium_force(m, h);
  }
  out.normal_reaction = std::isfinite(fn) ? std::max(0.0, fn) : 0.0;

  // The actual normal: the deformed normals (eq. 3) blended at the virtual vertex.
  Vec3 nf = b[0] * surface.deformed_normal(tri[0]) + b[1] * surface.deformed_normal(tri[1]) +
            b[2] * surface.deformed_normal(tri[2]);
  const double len = nf.norm();
  nf = len > 0 && std::isfinite(len) ? Vec3(nf / len) : out.surface.normal;

  // eq. (4), clamped to the device limit.
  out.force = clamp_force(contact_force(out.normal_reaction, nf, velocity, params), params.max_force);
  out.in_contact = true;
  out.contact.point = out.surface.point;
  out.contact.normal = out.surface.normal;
  out.contact.vertex = ca.nearest_vertex;
  out.contact.depth = out.height.depth;
  out.contact.shape = shape;
}

// Asks for what the walk reads of vertex v when it steps into a triangle
// with v as its far corner, and the tick after it: the position (the walk
// prepares the triangle from it) and the surface data. The contact
// triangle's own corners (the walk keeps their geometry) are skipped.
void fetch_step_vertex(const deform::DeformableSurface& surface, const mesh::SurfaceMesh& mesh, Index v,
                       const mesh::Triangle& corners) {
  if (v >= mesh.vertex_count() || v == corners[0] || v == corners[1] || v == corners[2]) return;
  __builtin_prefetch(&mesh.positions[v]);
  surface.prefetch_vertex(v);
}

// One stage of fetching the ring of the vertex the probe is nearest (see
// ProbeMemory::ring_vertex): the walk steps round that vertex when the probe
// passes near it, into triangles beyond the one ahead; without this, each
// such step waited on memory for the triangle, its far corner and its
// neighbours in turn. Each stage reads only lines the stage before asked for
// (a tick earlier), so no stage waits on memory itself. No effect on results.
void fetch_ring_ahead(const deform::DeformableSurface& surface, const mesh::SurfaceMesh& mesh, ProbeMemory& memory) {
  const Vec3& b = memory.cursor.barycentric;
  const Index v = memory.corners[collision::heaviest_corner(b)];
  if (v == memory.ring_vertex && memory.ring_stage >= 3) return;  // fetched: most ticks
  const mesh::Csr& triangles_of = mesh.vertex_triangles;
  const mesh::Csr& ring_of = mesh.vertex_neighbors;
  if (v >= mesh.vertex_count() || triangles_of.rows() != mesh.vertex_count() || ring_of.rows() != mesh.vertex_count() ||
      mesh.triangle_neighbors.size() != mesh.triangle_count())
    return;
  if (v != memory.ring_vertex) {
    memory.ring_vertex = v;
    memory.ring_stage = 0;
    __builtin_prefetch(&triangles_of.offsets[v]);
    __builtin_prefetch(&ring_of.offsets[v]);
    return;
  }
  switch (memory.ring_stage) {
    case 0:
      __builtin_prefetch(triangles_of.items.data() + triangles_of.offsets[v]);
      __builtin_prefetch(ring_of.items.data() + ring_of.offsets[v]);
      break;
    case 1:
      for (Index t : triangles_of.row(v))
        if (t != memory.cursor.triangle && t < mesh.triangle_count()) {
          __builtin_prefetch(&mesh.triangles[t]);
          __builtin_prefetch(&mesh.triangle_neighbors[t]);
        }
      break;
    case 2:
      for (Index w : ring_of.row(v)) fetch_step_vertex(surface, mesh, w, memory.corners);
      break;
    default:
      return;
  }
  ++memory.ring_stage;
}

}  // namespace

bool corner_rehearsal_point(const mesh::SurfaceMesh& mesh, const ProbeMemory& m, Vec3& point) {
  const Index t = m.cursor.triangle;
  if (!m.in_contact || t >= mesh.triangle_count()) return false;
  const mesh::Triangle& tri = mesh.triangles[t];
  const Vec3& b = m.cursor.barycentric;
  if (tri[0] >= mesh.vertex_count() || tri[1] >= mesh.vertex_count() || tri[2] >= mesh.vertex_count() ||
      !b.allFinite() || !m.cursor.probe.allFinite())
    return false;
  const int k = collision::heaviest_corner(b);
  const Vec3 contact = b[0] * mesh.positions[tri[0]] + b[1] * mesh.positions[tri[1]] + b[2] * mesh.positions[tri[2]];
  const Vec3& corner = mesh.positions[tri[k]];
  point = corner + 0.25 * (corner - contact) + (m.cursor.probe - contact);
  return true;
}

void haptic_tick(const deform::DeformableSurface& surface, const collision::VertexTree& tree,
                 std::span<const ProbeInput> probes, std::span<ProbeMemory> memory,
                 std::span<ProbeOutput> outputs, const ForceParams& params,
                 const deform::ShapeFunction& shape, const TissueTick* tissue,
                 std::span<const std::uint8_t> memory_slots) {
  const bool slotted = !memory_slots.empty();
  std::size_t n = std::min({probes.size(), slotted ? memory_slots.size() : memory.size(), outputs.size()});
  // With slots: the common prefix whose slots are in `memory`.
  if (slotted)
    for (std::size_t i = 0; i < n; ++i)
      if (memory_slots[i] >= memory.size()) {
        n = i;
        break;
      }
  auto mem = [&](std::size_t i) -> ProbeMemory& { return slotted ? memory[memory_slots[i]] : memory[i]; };
  // Probes in contact will start from their last triangle: ask for its
  // vertices' data for all probes at once, so their cache misses overlap
  // instead of adding up (no effect on results).
  const mesh::SurfaceMesh& mesh = surface.mesh();
  const bool fits = surface.state().vertices.size() == mesh.vertex_count();
  for (std::size_t i = 0; i < n; ++i) {
    const Index t = mem(i).cursor.triangle;
    if (!mem(i).in_contact || t >= mesh.triangle_count()) continue;
    __builtin_prefetch(&mesh.triangles[t]);
    if (t < mesh.triangle_neighbors.size()) __builtin_prefetch(&mesh.triangle_neighbors[t]);
    // The walk keeps the triangle's geometry in the cursor; the surface
    // state of its corners is read after it.
    for (Index v : mem(i).corners)
      if (fits && v < mesh.vertex_count()) surface.prefetch_vertex(v);
  }
  // The triangle across the nearest edge (the walk fetched it ahead), in case
  // the probe steps across: its far corner's position (the walk prepares the
  // triangle from it) and surface data, and its row of neighbours (read
  // after the step to look ahead again).
  for (std::size_t i = 0; i < n; ++i) {
    const Index a = mem(i).cursor.ahead;
    if (!fits || !mem(i).in_contact || a >= mesh.triangle_count()) continue;
    if (a < mesh.triangle_neighbors.size()) __builtin_prefetch(&mesh.triangle_neighbors[a]);
    for (Index v : mesh.triangles[a]) fetch_step_vertex(surface, mesh, v, mem(i).corners);
  }
  // The ring of the corner each probe in contact is nearest, one stage a tick.
  for (std::size_t i = 0; i < n; ++i)
    if (fits && mem(i).in_contact && mem(i).cursor.triangle < mesh.triangle_count())
      fetch_ring_ahead(surface, mesh, mem(i));
  // Each probe independently; mismatched sizes run the common prefix.
  for (std::size_t i = 0; i < n; ++i) {
    outputs[i] = ProbeOutput{};
    tick_one(surface, tree, probes[i], mem(i), outputs[i], params, shape, tissue);
  }
}

}  // namespace palpa::haptics
