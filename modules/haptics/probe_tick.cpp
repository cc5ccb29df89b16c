// One haptic tick (sections III.C and III.E): nearest vertex by local search,
// virtual vertex on the closest triangle, 1-D height check, local model at
// the virtual vertex, eq. (4), clamp.

#include "haptics/probe_tick.h"

#include <algorithm>
#include <cmath>

namespace palpa::haptics {

namespace {

// The material of the virtual vertex: every parameter interpolated with the
// barycentric weights; the model kind of the heaviest vertex.
deform::Material interpolate_material(const deform::MaterialArrays& mats, const mesh::Triangle& tri,
                                      const Vec3& b) {
  int heaviest = 0;
  if (b[1] > b[heaviest]) heaviest = 1;
  if (b[2] > b[heaviest]) heaviest = 2;
  deform::Material m;
  m.model = mats.model[tri[heaviest]];
  m.mass = m.damping = m.stiffness = m.alpha = m.k2 = m.tau = 0;
  for (int k = 0; k < 3; ++k) {
    const deform::Material mk = mats.at(tri[k]);
    m.mass += b[k] * mk.mass;
    m.damping += b[k] * mk.damping;
    m.stiffness += b[k] * mk.stiffness;
    m.alpha += b[k] * mk.alpha;
    m.k2 += b[k] * mk.k2;
    m.tau += b[k] * mk.tau;
  }
  return m;
}

// One probe against the surface; `out` starts cleared (no contact, no force).
void tick_one(const deform::DeformableSurface& surface, const collision::VertexTree& tree, const ProbeInput& in,
              ProbeMemory& memory, ProbeOutput& out, const ForceParams& params,
              const deform::ShapeFunction& shape) {
  const mesh::SurfaceMesh& mesh = surface.mesh();
  const auto& states = surface.state().vertices;
  if (!in.position.allFinite()) return;
  // A non-finite velocity is treated as rest (no damping, no friction).
  const Vec3 velocity = in.velocity.allFinite() ? in.velocity : Vec3::Zero();

  // Collision: nearest vertex, virtual vertex, height check (section III.C).
  const collision::NearestVertex nv = tree.nearest_local(in.position, memory.cursor);
  if (nv.vertex == kNoIndex || nv.vertex >= mesh.vertex_count()) return;
  out.nearest_vertex = nv.vertex;
  out.surface = collision::locate_surface_point(mesh, in.position, nv.vertex);
  if (out.surface.triangle == kNoIndex) return;
  const mesh::Triangle& tri = mesh.triangles[out.surface.triangle];
  if (states.size() != mesh.vertex_count() || surface.materials().size() != mesh.vertex_count()) return;
  const Vec3& b = out.surface.barycentric;
  const Vec3 heights(states[tri[0]].h, states[tri[1]].h, states[tri[2]].h);
  out.height = collision::height_check(out.surface, heights);
  if (!out.height.in_contact) return;

  // Normal reaction of the interpolated local model at the probe's height
  // h = -depth moving at dh/dt = v . N (section III.E).
  const deform::Material m = interpolate_material(surface.materials(), tri, b);
  const double q = b[0] * states[tri[0]].q + b[1] * states[tri[1]].q + b[2] * states[tri[2]].q;
  const double h = -out.height.depth;
  const double dhdt = velocity.dot(out.surface.normal);
  const double fn = deform::local_model(m.model).restoring_force(m, h, dhdt, q);
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
  out.contact.vertex = nv.vertex;
  out.contact.depth = out.height.depth;
  out.contact.shape = shape;
}

}  // namespace

void haptic_tick(const deform::DeformableSurface& surface, const collision::VertexTree& tree,
                 std::span<const ProbeInput> probes, std::span<ProbeMemory> memory,
                 std::span<ProbeOutput> outputs, const ForceParams& params,
                 const deform::ShapeFunction& shape) {
  // Each probe independently; mismatched sizes run the common prefix.
  const std::size_t n = std::min({probes.size(), memory.size(), outputs.size()});
  for (std::size_t i = 0; i < n; ++i) {
    outputs[i] = ProbeOutput{};
    tick_one(surface, tree, probes[i], memory[i], outputs[i], params, shape);
  }
}

}  // namespace palpa::haptics
