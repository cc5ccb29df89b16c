// The deformable surface (sections III.A, III.B, IV): contact force fields
// shaped by shape functions, per-vertex local models advanced over an active
// set, normal corrections of eq. (3) and the (nx, ny, nz, h) stream.

#include "deform/surface.h"

#include "core/huge_pages.h"
#include "core/shared_by_owner.h"
#include "core/subnormals.h"
#include "deform/forced_sweep.h"
#include "deform/rest_scan.h"
#include "deform/vertex_flags.h"
#include "mesh/thickness.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace palpa::deform {

namespace {

using internal::kActive;
using internal::kChanged;
using internal::kDirty;
using internal::kForced;
using internal::kFresh;
using internal::kVisited;
using internal::mark_block;

bool finite(const Vec3& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

// h == 0.0 && v == 0.0 && q == 0.0, tested on the bits in one comparison:
// with the sign bit shifted out, all three are +0 or -0 (a NaN is not).
bool at_rest(const VertexState& s) {
  static_assert(sizeof(VertexState) == 3 * sizeof(std::uint64_t));
  std::uint64_t h, v, q;
  std::memcpy(&h, &s.h, sizeof h);
  std::memcpy(&v, &s.v, sizeof v);
  std::memcpy(&q, &s.q, sizeof q);
  return ((h | v | q) << 1) == 0;
}

// The widest rest-block skip this processor runs (step_full), chosen once.
const internal::RestScan kRestScan = internal::best_rest_scan();
// Whether step_full's runs of blocks in a field go four or eight vertices
// at a time, and which.
const bool kForcedRuns = internal::forced_run_available();
const internal::ForcedRunWidth kForcedRunWidth = internal::best_forced_run();
// State larger than this (bytes) is prefetched ahead of step_full's skip.
constexpr std::size_t kPrefetchStateBytes = std::size_t{512} << 10;

// The drawn height: h clamped to [-limit, limit] (limit >= 0, maybe +inf),
// before and after its conversion to float.
inline double drawn_double(double h, double limit) { return h < -limit ? -limit : (h > limit ? limit : h); }
inline float drawn(double h, double limit) { return static_cast<float>(drawn_double(h, limit)); }

// A contact that can shape a field: finite, non-zero depth, a positive radius.
bool usable(const Contact& c) {
  return std::isfinite(c.depth) && c.depth != 0.0 && finite(c.point) && c.shape.radius > 0 &&
         std::isfinite(c.shape.radius);
}

}  // namespace

namespace {

std::vector<double> limits_from(const std::vector<double>& thickness, const mesh::SurfaceMesh& mesh,
                                double thickness_fraction, double curvature_fraction) {
  std::vector<double> limit = thickness;
  const std::vector<double> radius = mesh::convex_radius(mesh);
  for (std::size_t i = 0; i < limit.size(); ++i)
    limit[i] = std::min(thickness_fraction * limit[i], curvature_fraction * radius[i]);
  return limit;
}

}  // namespace

std::vector<double> drawn_displacement_limits(const mesh::SurfaceMesh& mesh, double thickness_fraction,
                                              double curvature_fraction) {
  return limits_from(mesh::inward_thickness(mesh), mesh, thickness_fraction, curvature_fraction);
}

namespace {

// The limits of live surfaces, by mesh object and fractions, so that the
// surfaces of one mesh (a loop's replicas) cast the rays once. Entries whose
// mesh or limits are gone are dropped. Construction only: a lock is fine.
std::shared_ptr<const std::vector<double>> shared_drawn_limits(
    const std::shared_ptr<const mesh::SurfaceMesh>& mesh, double thickness_fraction, double curvature_fraction) {
  static SharedByOwner<mesh::SurfaceMesh, std::vector<double>, std::pair<double, double>> cache;
  return cache.get(mesh, {thickness_fraction, curvature_fraction}, [&] {
    // The thickness too is shared by mesh (a coverage of the same mesh may hold it).
    return limits_from(*mesh::shared_inward_thickness(mesh), *mesh, thickness_fraction, curvature_fraction);
  });
}

}  // namespace

// ---------------------------------------------------------------------------
// Construction and materials.

std::size_t DeformableSurface::MaterialKeyHash::operator()(const MaterialKey& k) const {
  // FNV-1a style mix of the seven words.
  std::uint64_t h = 1469598103934665603ull;
  for (std::uint64_t w : k) {
    h ^= w + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
    h *= 1099511628211ull;
  }
  return static_cast<std::size_t>(h);
}

DeformableSurface::DeformableSurface(std::shared_ptr<const mesh::SurfaceMesh> mesh, MaterialArrays materials,
                                     SurfaceOptions options)
    : mesh_(std::move(mesh)), options_(options) {
  // The mesh must be finalized: one normal and one adjacency row per vertex.
  if (!mesh_) throw std::invalid_argument("DeformableSurface: the mesh is null");
  const std::size_t n = mesh_->vertex_count();
  if (n >= kNoIndex) throw std::invalid_argument("DeformableSurface: the mesh has too many vertices");
  if (mesh_->normals.size() != n) {
    throw std::invalid_argument("DeformableSurface: the mesh has " + std::to_string(n) + " vertices but " +
                                std::to_string(mesh_->normals.size()) + " normals (finalize it)");
  }
  if (mesh_->vertex_neighbors.rows() != n) {
    throw std::invalid_argument("DeformableSurface: the mesh has " + std::to_string(n) + " vertices but " +
                                std::to_string(mesh_->vertex_neighbors.rows()) +
                                " adjacency rows (finalize it)");
  }
  // Options within their ranges.
  if (!(options_.rest_threshold >= 0) || !std::isfinite(options_.rest_threshold)) {
    std::ostringstream msg;
    msg << "SurfaceOptions: rest_threshold must be non-negative and finite, got " << options_.rest_threshold
        << " m";
    throw std::invalid_argument(msg.str());
  }
  if (!(options_.min_normal_cosine >= -1.0 && options_.min_normal_cosine <= 1.0)) {
    std::ostringstream msg;
    msg << "SurfaceOptions: min_normal_cosine must be in [-1, 1], got " << options_.min_normal_cosine;
    throw std::invalid_argument(msg.str());
  }
  if (!(options_.thickness_fraction > 0 && options_.thickness_fraction < 0.5)) {
    std::ostringstream msg;
    msg << "SurfaceOptions: thickness_fraction must be in (0, 0.5), got " << options_.thickness_fraction;
    throw std::invalid_argument(msg.str());
  }
  if (!(options_.curvature_fraction > 0 && options_.curvature_fraction < 1)) {
    std::ostringstream msg;
    msg << "SurfaceOptions: curvature_fraction must be in (0, 1), got " << options_.curvature_fraction;
    throw std::invalid_argument(msg.str());
  }
  if (options_.drawn_limits && options_.drawn_limits->size() != n) {
    throw std::invalid_argument("SurfaceOptions: drawn_limits has " + std::to_string(options_.drawn_limits->size()) +
                                " values but the mesh has " + std::to_string(n) + " vertices");
  }
  materials.validate(n);

  // The drawn displacement limits: given, computed, or none (+inf).
  if (!options_.limit_drawn_displacement) {
    drawn_limits_ = std::make_shared<const std::vector<double>>(n, std::numeric_limits<double>::infinity());
  } else if (options_.drawn_limits) {
    drawn_limits_ = options_.drawn_limits;
  } else {
    drawn_limits_ = shared_drawn_limits(mesh_, options_.thickness_fraction, options_.curvature_fraction);
  }
  drawn_limit_ = drawn_limits_->data();

  // Per-vertex arrays, all at rest; the whole stream is due for a first upload.
  state_.vertices.assign(n, VertexState{});
  force_.assign(n, 0.0);
  correction_.assign(n, Vec3::Zero());
  flags_.assign(n, 0);
  stream_.assign(4 * n, 0.0f);
  active_.resize(n);
  dirty_blocks_.assign((n + 4095) / 4096, 0);
  all_dirty_ = true;
  changed_.resize(n);
  static_assert(kChanged == kChangedFlag);
  build_integrators(materials);
  advise_huge_pages();
}

void DeformableSurface::advise_huge_pages() const {
  // The arrays a tick and a step read at random (core/huge_pages.h): the
  // mesh's (shared: a second surface on it asks again, which costs nothing
  // once they are huge) and this surface's.
  const mesh::SurfaceMesh& m = *mesh_;
  using core::prefer_huge_pages;
  prefer_huge_pages(m.positions);
  prefer_huge_pages(m.normals);
  prefer_huge_pages(m.triangles);
  prefer_huge_pages(m.triangle_neighbors);
  prefer_huge_pages(m.vertex_neighbors.offsets);
  prefer_huge_pages(m.vertex_neighbors.items);
  prefer_huge_pages(m.vertex_triangles.offsets);
  prefer_huge_pages(m.vertex_triangles.items);
  prefer_huge_pages(*drawn_limits_);
  prefer_huge_pages(state_.vertices);
  prefer_huge_pages(force_);
  prefer_huge_pages(correction_);
  prefer_huge_pages(flags_);
  prefer_huge_pages(stream_);
  prefer_huge_pages(active_);
  prefer_huge_pages(changed_);
}

DeformableSurface::MaterialKey DeformableSurface::key_of(const Material& m) {
  return {static_cast<std::uint64_t>(m.model), std::bit_cast<std::uint64_t>(m.mass),
          std::bit_cast<std::uint64_t>(m.damping), std::bit_cast<std::uint64_t>(m.stiffness),
          std::bit_cast<std::uint64_t>(m.alpha), std::bit_cast<std::uint64_t>(m.k2),
          std::bit_cast<std::uint64_t>(m.tau), std::bit_cast<std::uint64_t>(m.hertz),
          std::bit_cast<std::uint64_t>(m.relaxation)};
}

Index DeformableSurface::intern_material(const Material& m) {
  // Find the material's integrator by bit pattern, adding it when new.
  const MaterialKey key = key_of(m);
  auto [it, inserted] = integrator_lookup_.try_emplace(key, static_cast<Index>(integrators_.size()));
  if (inserted) {
    Integrator g;
    g.material = m;
    if (coefficients_dt_ > 0) g.linear = LinearStep::make(m, coefficients_dt_);
    integrators_.push_back(g);
  }
  return it->second;
}

void DeformableSurface::build_integrators(const MaterialArrays& materials) {
  // One integrator per distinct material; runs of equal materials skip the lookup.
  fields_current_ = false;
  integrators_.clear();
  integrator_lookup_.clear();
  integrator_of_.assign(materials.size(), 0);
  Material previous;
  Index previous_index = kNoIndex;
  for (std::size_t i = 0; i < materials.size(); ++i) {
    const Material m = materials.at(static_cast<Index>(i));
    if (previous_index == kNoIndex || !(m == previous)) {
      previous = m;
      previous_index = intern_material(m);
    }
    integrator_of_[i] = previous_index;
  }
}

void DeformableSurface::compact_integrators() {
  // Keep only the integrators some vertex still uses, in order of first use.
  std::vector<Index> remap(integrators_.size(), kNoIndex);
  std::vector<Integrator> kept;
  for (Index& g : integrator_of_) {
    if (remap[g] == kNoIndex) {
      remap[g] = static_cast<Index>(kept.size());
      kept.push_back(integrators_[g]);
    }
    g = remap[g];
  }
  integrators_ = std::move(kept);
  integrator_lookup_.clear();
  for (std::size_t j = 0; j < integrators_.size(); ++j)
    integrator_lookup_.emplace(key_of(integrators_[j].material), static_cast<Index>(j));
}

MaterialArrays DeformableSurface::materials() const {
  MaterialArrays out = MaterialArrays::uniform(integrator_of_.size(), Material{});
  for (std::size_t i = 0; i < integrator_of_.size(); ++i) out.set(static_cast<Index>(i), vertex_material(static_cast<Index>(i)));
  return out;
}

bool DeformableSurface::uniform() const {
  if (integrators_.size() != 1) return false;
  for (float v : scale_)
    if (v != scale_.front()) return false;
  return true;
}

double DeformableSurface::max_stiffness() const {
  double k = 0;
  for (const Integrator& g : integrators_) {
    double kg = g.material.stiffness;
    if (g.material.model == LocalModelKind::Viscoelastic) kg += g.material.k2;
    if (g.material.model == LocalModelKind::Hertz) kg *= 1.0 + g.material.relaxation;
    k = std::max(k, kg);
  }
  double smax = 1.0;
  if (!scale_.empty()) smax = *std::max_element(scale_.begin(), scale_.end());
  return k * smax;
}

void DeformableSurface::set_tissue_map(std::vector<Material> tissues, std::span<const std::uint16_t> tissue_of,
                                       std::span<const float> scale) {
  const std::size_t n = mesh_->vertex_count();
  if (tissues.empty()) throw std::invalid_argument("set_tissue_map: no tissues");
  for (std::size_t t = 0; t < tissues.size(); ++t) validate_material(tissues[t], "tissue " + std::to_string(t));
  if (tissue_of.size() != n)
    throw std::invalid_argument("set_tissue_map: " + std::to_string(tissue_of.size()) + " tissue indices for " +
                                std::to_string(n) + " vertices");
  if (!scale.empty() && scale.size() != n)
    throw std::invalid_argument("set_tissue_map: " + std::to_string(scale.size()) + " scales for " +
                                std::to_string(n) + " vertices");
  // Check everything before changing anything.
  std::uint16_t top = 0;
  for (std::uint16_t t : tissue_of) top = std::max(top, t);
  if (top >= tissues.size()) {
    const auto at = std::find(tissue_of.begin(), tissue_of.end(), top) - tissue_of.begin();
    throw std::invalid_argument("set_tissue_map: tissue of vertex " + std::to_string(at) + " is " +
                                std::to_string(top) + ", but there are " + std::to_string(tissues.size()) +
                                " tissues");
  }
  for (std::size_t i = 0; i < scale.size(); ++i) {
    if (!(scale[i] > 0) || !std::isfinite(scale[i])) {
      std::ostringstream msg;
      msg << "set_tissue_map: scale of vertex " << i << " must be positive and finite, got " << scale[i];
      throw std::invalid_argument(msg.str());
    }
  }
  fields_current_ = false;
  integrators_.clear();
  integrator_lookup_.clear();
  for (const Material& m : tissues) {
    Integrator g;
    g.material = m;
    if (coefficients_dt_ > 0) g.linear = LinearStep::make(m, coefficients_dt_);
    integrator_lookup_.try_emplace(key_of(m), static_cast<Index>(integrators_.size()));
    integrators_.push_back(g);
  }
  integrator_of_.assign(tissue_of.begin(), tissue_of.end());
  bool ones = true;
  for (float v : scale) ones = ones && v == 1.0f;
  if (ones) {
    scale_.clear();
    scale_root_.clear();
  } else {
    scale_.assign(scale.begin(), scale.end());
    scale_root_.resize(n);
    for (std::size_t i = 0; i < n; ++i) scale_root_[i] = std::sqrt(static_cast<double>(scale_[i]));
  }
}

void DeformableSurface::set_drives(std::vector<Index> vertices, std::vector<std::array<float, 4>> weights) {
  if (vertices.size() != weights.size())
    throw std::invalid_argument("set_drives: " + std::to_string(vertices.size()) + " vertices but " +
                                std::to_string(weights.size()) + " weights");
  for (std::size_t j = 0; j < vertices.size(); ++j) {
    if (vertices[j] >= mesh_->vertex_count())
      throw std::invalid_argument("set_drives: vertex " + std::to_string(vertices[j]) + " is out of range");
    for (float w : weights[j])
      if (!std::isfinite(w)) throw std::invalid_argument("set_drives: a weight is not finite");
  }
  fields_current_ = false;
  drive_vertices_ = std::move(vertices);
  drive_weights_ = std::move(weights);
}

void DeformableSurface::set_material(Index i, const Material& m) {
  if (i >= integrator_of_.size()) {
    throw std::invalid_argument("set_material: vertex " + std::to_string(i) + " is out of range (the mesh has " +
                                std::to_string(integrator_of_.size()) + " vertices)");
  }
  validate_material(m, "material of vertex " + std::to_string(i));
  fields_current_ = false;
  integrator_of_[i] = intern_material(m);
  if (!scale_.empty()) {
    scale_[i] = 1.0f;
    scale_root_[i] = 1.0;
  }
  // Painting many distinct values leaves unused integrators behind: compact now and then.
  if (integrators_.size() > 2 * integrator_of_.size() + 64) compact_integrators();
}

void DeformableSurface::set_materials(const MaterialArrays& materials) {
  materials.validate(mesh_->vertex_count());
  build_integrators(materials);
  scale_.clear();
  scale_root_.clear();
}

void DeformableSurface::set_uniform_material(const Material& m) {
  validate_material(m, "uniform material");
  fields_current_ = false;
  Integrator g;
  g.material = m;
  if (coefficients_dt_ > 0) g.linear = LinearStep::make(m, coefficients_dt_);
  if (integrators_.size() != 1) {
    // Once per change from a map to one material: every vertex to entry 0.
    std::fill(integrator_of_.begin(), integrator_of_.end(), Index{0});
    integrators_.assign(1, g);
  } else {
    integrators_[0] = g;  // O(1): the table's only entry
  }
  integrator_lookup_.clear();
  integrator_lookup_.emplace(key_of(m), Index{0});
  scale_.clear();
  scale_root_.clear();
}

namespace {

bool same_bits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

bool same_bits(const Vec3& a, const Vec3& b) {
  return same_bits(a.x(), b.x()) && same_bits(a.y(), b.y()) && same_bits(a.z(), b.z());
}

// Every value a contact's field is made from, compared bit for bit.
bool same_contact(const Contact& a, const Contact& b) {
  return same_bits(a.point, b.point) && same_bits(a.normal, b.normal) && a.vertex == b.vertex &&
         same_bits(a.depth, b.depth) && a.shape.kind == b.shape.kind && same_bits(a.shape.radius, b.shape.radius);
}

}  // namespace

void DeformableSurface::set_contacts(std::span<const Contact> contacts) {
  // The same contacts again (a probe held still) keep the fields built.
  if (contacts.size() != contacts_.size() ||
      !std::equal(contacts.begin(), contacts.end(), contacts_.begin(), same_contact))
    fields_current_ = false;
  contacts_.assign(contacts.begin(), contacts.end());
}

// ---------------------------------------------------------------------------
// Force fields (section III.B) and normal corrections (eq. 3).

const DeformableSurface::Integrator* DeformableSurface::plain_linear() const {
  return integrators_.size() == 1 && integrators_[0].material.model == LocalModelKind::Linear && scale_.empty()
             ? &integrators_[0]
             : nullptr;
}

// What every vertex of one contact's field shares, computed once per field
// (the loops' stores could alias the members it is read from, so the
// compiler would read them again for every vertex).
struct DeformableSurface::FieldConstants {
  double inverse_radius;  // 1/m: 1 / c.shape.radius, as ShapeFunction::evaluate computes it
  double tiny;            // m: 1e-12 c.shape.radius; a shorter tangent has no direction
  bool plain;             // one Linear material and no modulus scale: f = stiffness h
  double stiffness;       // N/m: that material's (when plain)
  // The arrays the field adds to (their addresses would otherwise be read
  // again from the surface after every byte store to the flags).
  double* force;
  Vec3* correction;

  FieldConstants(DeformableSurface& s, const Contact& c)
      : inverse_radius(1.0 / c.shape.radius),
        tiny(1e-12 * c.shape.radius),
        plain(s.plain_linear() != nullptr),
        stiffness(plain ? s.plain_linear()->material.stiffness : 0.0),
        force(s.force_.data()),
        correction(s.correction_.data()) {}
};

__attribute__((always_inline)) inline void DeformableSurface::add_field(Index i, const Contact& c, double depth,
                                                                        const Vec3& d, double r, const Vec3& n0,
                                                                        const FieldConstants& k) {
  // d = P0_i - contact point (m), r = |d|, n0 = N0_i. Force that holds
  // vertex i at the shape function's height -depth S(r).
  touch_field(i);
  double shape = 0.0, slope = 0.0;
  c.shape.evaluate(r, k.inverse_radius, shape, slope);
  const double h = -depth * shape;
  if (k.plain) {
    k.force[i] += k.stiffness * h;  // the Linear law k h
  } else {
    const Material& m = integrators_[integrator_of_[i]].material;
    // Every model's equilibrium force is linear in its moduli, so a vertex's
    // modulus scale multiplies it.
    const double f =
        m.model == LocalModelKind::Linear ? m.stiffness * h : local_model(m.model).equilibrium_force(m, h);
    k.force[i] += scale_.empty() ? f : f * static_cast<double>(scale_[i]);
  }

  // eq. (3): depth S'(r) along the tangential direction away from the contact.
  const Vec3 t = d - d.dot(n0) * n0;
  const double len = t.norm();
  if (len > k.tiny) k.correction[i] += (depth * slope / len) * t;
}

void DeformableSurface::field_by_bfs(const Contact& c, double depth, const Vec3* n) {
  const FieldConstants fc(*this, c);
  if (fc.plain) visit_field<true>(c, depth, n, fc);
  else visit_field<false>(c, depth, n, fc);
}

template <bool kLight>
void DeformableSurface::visit_field(const Contact& c, double depth, const Vec3* n, const FieldConstants& fc) {
  // Breadth-first visit from the contact vertex over mesh neighbours; vertices
  // outside the support, or facing away from the contact normal n (when
  // given), are marked visited but not expanded. The visit order is that of
  // the plain breadth-first visit, so the fields are bit for bit the ones it
  // gives, whichever way the queue is kept.
  //
  // A neighbour clearly outside the support is not queued at all (nor
  // marked: another neighbour may meet it again, and it is left out again).
  // The plain visit would queue it and pass it over when it came out,
  // without expanding it, so leaving it out keeps the order of every other
  // vertex; it was about 5% of the visits on a 1M-vertex sphere, and its
  // trip through the queue about 7% of the visit's time (docs/PERFORMANCE.md,
  // Round 38). Where the field's force is the Linear law inline (kLight),
  // what a visit reads is asked for eight places ahead in the queue; where
  // each vertex calls its model (Hertz, scaled moduli), it is asked for when
  // the vertex is queued, which was faster there (Round 4).
  const Vec3* pos = mesh_->positions.data();
  const Vec3* nrm = mesh_->normals.data();
  const double radius = c.shape.radius;
  // Past this squared distance sqrt(r2) >= radius whatever the rounding: the
  // roundings in radius^2 (1 + 1e-9) and in the square root are each about
  // 1e-16 relative, far below the 1e-9 margin. So a neighbour past it is
  // left out of the queue, and every vertex queued but the contact's own is
  // within it (the same expression, the same bits): the visit below needs
  // no such check of its own, the square root's test covers the first.
  const double outside2 = radius * radius * (1.0 + 1e-9);
  const Index* offsets = mesh_->vertex_neighbors.offsets.data();
  const Index* items = mesh_->vertex_neighbors.items.data();
  std::uint8_t* flags = flags_.data();
  // Asks for the lines vertex v's visit reads (no effect on results: on a
  // 1M-vertex mesh these are cache misses).
  auto ask_for = [&](Index v) {
    __builtin_prefetch(pos + v);
    __builtin_prefetch(nrm + v);
    __builtin_prefetch(offsets + v);
    __builtin_prefetch(force_.data() + v, 1);
    __builtin_prefetch(correction_.data() + v, 1);
  };
  if (bfs_queue_.size() < 64) bfs_queue_.resize(64);
  Index* queue = bfs_queue_.data();
  std::size_t capacity = bfs_queue_.size();
  const double min_cosine = options_.min_normal_cosine;
  std::size_t tail = 0;
  queue[tail++] = c.vertex;
  flags[c.vertex] |= kVisited;
  for (std::size_t head = 0; head < tail; ++head) {
    if constexpr (kLight) {
      if (head + 8 < tail) ask_for(queue[head + 8]);
    }
    if (head + 4 < tail) __builtin_prefetch(items + offsets[queue[head + 4]]);
    const Index i = queue[head];
    const Vec3 d = pos[i] - c.point;
    const double r2 = d.squaredNorm();
    const double r = std::sqrt(r2);  // = d.norm(), bit for bit
    if (!(r < radius)) continue;
    if (n && nrm[i].dot(*n) < min_cosine) continue;
    add_field(i, c, depth, d, r, nrm[i], fc);
    const Index begin = offsets[i];
    const Index end = offsets[i + 1];
    if (tail + (end - begin) > capacity) {
      bfs_queue_.resize(std::max(2 * capacity, tail + (end - begin)));
      queue = bfs_queue_.data();
      capacity = bfs_queue_.size();
    }
    for (Index k = begin; k < end; ++k) {
      const Index j = items[k];
      const std::uint8_t f = flags[j];
      if (f & kVisited) continue;
      if ((pos[j] - c.point).squaredNorm() > outside2) continue;  // as r2 above: clearly outside
      flags[j] = static_cast<std::uint8_t>(f | kVisited);
      queue[tail++] = j;
      if constexpr (!kLight) ask_for(j);
    }
  }
  // Clear the visit marks for the next contact.
  for (std::size_t k = 0; k < tail; ++k) flags[queue[k]] &= static_cast<std::uint8_t>(~kVisited);
}

void DeformableSurface::field_by_scan(const Contact& c, double depth, const Vec3& n) {
  // Every vertex tests its distance to the contact and its normal against the
  // contact normal (the data-parallel way of section III.B).
  const auto& pos = mesh_->positions;
  const auto& nrm = mesh_->normals;
  const double radius = c.shape.radius;
  const double reject2 = 2.0 * radius * radius;  // cheap early rejection, safely above radius^2
  const FieldConstants fc(*this, c);
  const Index count = static_cast<Index>(pos.size());
  for (Index i = 0; i < count; ++i) {
    const Vec3 d = pos[i] - c.point;
    if (d.squaredNorm() > reject2) continue;
    const double r = d.norm();
    if (!(r < radius) || nrm[i].dot(n) < options_.min_normal_cosine) continue;
    add_field(i, c, depth, d, r, nrm[i], fc);
  }
}

void DeformableSurface::apply_fields() {
  // Fields built from the same contacts, materials and drives: rebuilding
  // them would give the same bits, the same forced list in the same order,
  // and no vertex leaving a field.
  if (fields_current_) return;
  fields_current_ = true;
  // The previous step's fields stay until each vertex is met: the first
  // field to reach a vertex clears it (touch_field), and the vertices no
  // field reached are cleared after.
  prev_forced_.swap(forced_);
  forced_.clear();

  // Superpose the fields of every usable contact, in contact order.
  const Index count = static_cast<Index>(mesh_->vertex_count());
  for (const Contact& c : contacts_) {
    if (!usable(c)) continue;
    const double depth = field_depth(c);
    const double len = c.normal.norm();
    const bool has_normal = len > 0 && std::isfinite(len);
    const Vec3 n = has_normal ? Vec3(c.normal / len) : Vec3::UnitZ();
    if (options_.propagation == Propagation::Topological && c.vertex < count) {
      field_by_bfs(c, depth, has_normal ? &n : nullptr);
      continue;
    }
    // DistanceNormal, or a contact without a valid seed vertex.
    if (!has_normal) continue;
    field_by_scan(c, depth, n);
  }

  // Drives (pulsing vessels): the force that holds a free vertex at its lift.
  for (std::size_t j = 0; j < drive_vertices_.size(); ++j) {
    const Index i = drive_vertices_[j];
    const auto& w = drive_weights_[j];
    const double lift = w[0] * drive_values_[0] + w[1] * drive_values_[1] + w[2] * drive_values_[2] +
                        w[3] * drive_values_[3];
    const Material& m = integrators_[integrator_of_[i]].material;
    const double f = local_model(m.model).equilibrium_force(m, lift);
    touch_field(i);
    force_[i] += scale_.empty() ? f : f * static_cast<double>(scale_[i]);
  }

  // Vertices no field of this build reached have left every field.
  for (Index i : prev_forced_) {
    if (!(flags_[i] & kFresh)) leave_fields(i);
  }
  // The vertices in a field: forced, and in the active set (those entering
  // a field join it here, in the order the fields met them). Their stream
  // corrections (nx, ny, nz) are written here, once per build: the steps
  // write only the height, so a probe held still costs no conversion of
  // unchanged corrections.
  {
    std::uint8_t* flags = flags_.data();
    Index* active = active_.data();
    float* stream = stream_.data();
    const Vec3* correction = correction_.data();
    std::uint64_t* dirty_blocks = dirty_blocks_.data();
    const bool all_dirty = all_dirty_;
    std::size_t active_size = active_size_;
    for (Index i : forced_) {
      std::uint8_t f = flags[i];
      if (!(f & kActive)) active[active_size++] = i;
      f = static_cast<std::uint8_t>((f & ~kFresh) | kForced | kActive);
      const Vec3& c = correction[i];
      const float nx = static_cast<float>(c.x()), ny = static_cast<float>(c.y()), nz = static_cast<float>(c.z());
      float* p = stream + 4 * static_cast<std::size_t>(i);
      if (p[0] != nx || p[1] != ny || p[2] != nz) {
        p[0] = nx;
        p[1] = ny;
        p[2] = nz;
        if (!all_dirty && !(f & kDirty)) {  // mark_dirty, on the flags in hand
          f |= kDirty;
          mark_block(dirty_blocks, i);
        }
      }
      flags[i] = f;
    }
    active_size_ = active_size;
  }
}

inline void DeformableSurface::touch_field(Index i) {
  // The first field of this build to reach vertex i clears what the previous
  // build left there and lists it.
  const std::uint8_t f = flags_[i];
  if (f & kFresh) return;
  flags_[i] = static_cast<std::uint8_t>(f | kFresh);
  force_[i] = 0.0;
  correction_[i].setZero();
  forced_.push_back(i);
  note_changed(i);
}

void DeformableSurface::leave_fields(Index i) {
  force_[i] = 0.0;
  correction_[i].setZero();
  flags_[i] &= static_cast<std::uint8_t>(~kForced);
  write_stream(i);  // its stream correction is now zero
}

double DeformableSurface::field_depth(const Contact& c) const {
  // The depth the field is shaped with: cut to the drawn limit at the
  // contact vertex (the deepest point of the dent), sign kept.
  if (c.vertex >= mesh_->vertex_count()) return c.depth;
  const double limit = drawn_limit_[c.vertex];
  return std::abs(c.depth) <= limit ? c.depth : std::copysign(limit, c.depth);
}

// ---------------------------------------------------------------------------
// Integration (section III.A) over the active set.

void DeformableSurface::prepare_step(double dt) {
  // Linear exact-discretisation coefficients depend on dt: rebuild per distinct material.
  if (dt != coefficients_dt_) {
    for (Integrator& g : integrators_) g.linear = LinearStep::make(g.material, dt);
    coefficients_dt_ = dt;
  }
  apply_fields();
}

// The per-vertex update of step() and step_full(): everything it touches is
// held in locals, so byte stores to the flags do not force reloads. kPlain:
// the surface's one material is an unscaled Linear one (plain_linear()), whose
// step is copied in here, so that no material is looked up per vertex and its
// coefficients stay in registers.
template <bool kPlain>
struct DeformableSurface::Sweep {
  VertexState* state;
  const double* force;
  const Index* integrator_of;
  const Integrator* integrators;
  LinearStep plain;    // kPlain: the one material's step for dt
  const float* scale;  // null: all 1
  const double* scale_root;  // sqrt of each scale (null with scale)
  std::uint8_t* flags;
  float* stream;
  const double* limit;
  std::uint64_t* dirty_blocks;
  bool all_dirty;
  Index* changed;
  std::size_t changed_size;
  double dt;
  double rest;

  Sweep(DeformableSurface& s, double step_dt)
      : state(s.state_.vertices.data()),
        force(s.force_.data()),
        integrator_of(s.integrator_of_.data()),
        integrators(s.integrators_.data()),
        plain(kPlain ? s.plain_linear()->linear : LinearStep{}),
        scale(s.scale_.empty() ? nullptr : s.scale_.data()),
        scale_root(s.scale_.empty() ? nullptr : s.scale_root_.data()),
        flags(s.flags_.data()),
        stream(s.stream_.data()),
        limit(s.drawn_limit_),
        dirty_blocks(s.dirty_blocks_.data()),
        all_dirty(s.all_dirty_),
        changed(s.changed_.data()),
        changed_size(s.changed_size_),
        dt(step_dt),
        rest(s.options_.rest_threshold) {}

  void finish(DeformableSurface& s) const { s.changed_size_ = changed_size; }

  void mark(Index i, std::uint8_t& f) {
    if (all_dirty || (f & kDirty)) return;
    f |= kDirty;
    mark_block(dirty_blocks, i);
  }

  // Advances vertex i by dt under its field force (zero outside every field),
  // updates its stream entry and flags; returns whether it stays active.
  [[gnu::always_inline]] bool advance(Index i) {
    std::uint8_t f = flags[i];
    VertexState& s = state[i];
    const bool forced = (f & kForced) != 0;
    const double fi = forced ? force[i] : 0.0;
    if constexpr (kPlain) {
      plain.apply(s, fi);
    } else {
      const Integrator& g = integrators[integrator_of[i]];
      const float si = scale ? scale[i] : 1.0f;
      if (si != 1.0f) {
        // A scaled vertex (tissue maps: Hertz, integrated without a cache; a
        // scaled Linear vertex makes its coefficients here, slowly).
        const Material m = scaled(g.material, static_cast<double>(si), scale_root[i]);
        if (m.model == LocalModelKind::Linear) LinearStep::make(m, dt).apply(s, fi);
        else local_model(m.model).step(m, s, fi, dt);
      } else if (g.material.model == LocalModelKind::Linear) {
        g.linear.apply(s, fi);
      } else {
        local_model(g.material.model).step(g.material, s, fi, dt);
      }
    }
    return record(i, f, s, forced);
  }

  // After vertex i's integration: its stream height, flags and place in the
  // changed list; returns whether it stays active. (The stream's
  // correction is written when the fields are built, apply_fields.)
  [[gnu::always_inline]] bool record(Index i, std::uint8_t f, VertexState& s, bool forced) {
    bool stays = true;
    if (!forced && std::abs(s.h) <= rest && std::abs(s.v) * dt <= rest && std::abs(s.q) <= rest) {
      // No field, and (nearly) stopped: set exactly to rest, out of the
      // active set.
      s = VertexState{};
      stays = false;
    }
    float* p = stream + 4 * static_cast<std::size_t>(i) + 3;
    const float h = drawn(s.h, limit[i]);
    if (*p != h) {
      *p = h;
      mark(i, f);
    }
    if (!(f & kChanged)) {
      f |= kChanged;
      changed[changed_size++] = i;
    }
    flags[i] = stays ? static_cast<std::uint8_t>(f | kActive) : static_cast<std::uint8_t>(f & ~kActive);
    return stays;
  }
};

void DeformableSurface::step(double dt) {
  if (!(dt > 0) || !std::isfinite(dt)) return;
  // Subnormal values as zero (core/subnormals.h): a vertex held in a field
  // decays towards its rest velocity and would otherwise pass through the
  // subnormal range for about twenty steps, where the 1M sphere's step with
  // three held contacts took 1.2 to 1.6 ms instead of 0.2.
  const SubnormalsAsZero flush;
  prepare_step(dt);  // the vertices in a field are in the active set from here
  if (plain_linear()) sweep_active<true>(dt);
  else sweep_active<false>(dt);
  state_.time += dt;
}

template <bool kPlain>
void DeformableSurface::sweep_active(double dt) {
  Index* active = active_.data();
  // Advance the active set, dropping the vertices that came to rest. What
  // the vertex kAhead places on reads is asked for now (no effect on
  // results): the active vertices are scattered over arrays larger than the
  // cache, and one vertex's integration is too long for the processor to
  // reach the next one's loads by itself.
  Sweep<kPlain> sweep(*this, dt);
  const std::size_t n = active_size_;
  std::size_t kept = 0;
  constexpr std::size_t kAhead = 6;
  for (std::size_t k = 0; k < n; ++k) {
    if (k + kAhead < n) {
      const Index a = active[k + kAhead];
      __builtin_prefetch(sweep.state + a, 1);
      __builtin_prefetch(sweep.force + a);
      if constexpr (!kPlain) __builtin_prefetch(sweep.integrator_of + a);
      __builtin_prefetch(sweep.stream + 4 * static_cast<std::size_t>(a), 1);
      __builtin_prefetch(sweep.limit + a);
      if (sweep.scale_root) __builtin_prefetch(sweep.scale_root + a);
    }
    const Index i = active[k];
    if (sweep.advance(i)) active[kept++] = i;
  }
  active_size_ = kept;
  sweep.finish(*this);
}

void DeformableSurface::step_full(double dt) {
  if (!(dt > 0) || !std::isfinite(dt)) return;
  const SubnormalsAsZero flush;  // as step(), so that both give the same bits
  prepare_step(dt);
  if (plain_linear()) sweep_full<true>(dt);
  else sweep_full<false>(dt);
  state_.time += dt;
}

template <bool kPlain>
void DeformableSurface::sweep_full(double dt) {
  // Advance every vertex; the active set becomes those not at rest or in a
  // field. A vertex exactly at rest, with no field and not active, would stay
  // exactly at rest under every model, so it is only read: runs of blocks
  // of eight such vertices are passed over by internal::skip_rest_blocks
  // (wide loads of the flags and the state), the other blocks go vertex by
  // vertex in index order (the same order and arithmetic as step()).
  Sweep<kPlain> sweep(*this, dt);
  Index* active = active_.data();
  const VertexState* state = state_.vertices.data();
  const std::uint8_t* flags = flags_.data();
  std::size_t kept = 0;
  const std::size_t count = mesh_->vertex_count();
  auto one = [&](Index i) [[gnu::always_inline]] {
    if (!(flags[i] & (kForced | kActive)) && at_rest(state[i])) return;
    if (sweep.advance(i)) active[kept++] = i;
  };
  // The state is also asked for 256 vertices (6 KB) ahead when it is larger
  // than the caches: the hardware prefetcher alone does not keep the read
  // at memory bandwidth there.
  const bool prefetch = count * sizeof(VertexState) > kPrefetchStateBytes;
  constexpr std::uint64_t kMovingWord = internal::spread8(kForced | kActive);
  const std::size_t whole = count - count % internal::kRestBlock;
  // One plain Linear material: runs of blocks with vertices in a field, the
  // others at rest, go four vertices at a time where the processor can
  // (internal::advance_forced_run, the same bits and marks as vertex by
  // vertex).
  constexpr std::uint64_t kForcedWord = internal::spread8(kForced);
  const bool forced_runs = kPlain && kForcedRuns;
  internal::ForcedRun run{sweep.state,     sweep.force, sweep.limit, sweep.flags,   sweep.stream, sweep.dirty_blocks,
                          sweep.all_dirty, active,      0,           sweep.changed, 0,            sweep.plain};
  std::size_t i = 0;
  while (i < whole) {
    // A block with a vertex in a field or active goes straight to the
    // vertices (most blocks of a field are followed by more of it); the
    // skip is asked only from a block whose flags say it may be at rest.
    std::uint64_t f;
    std::memcpy(&f, flags + i, sizeof f);
    if (!(f & kMovingWord)) {
      i = internal::skip_rest_blocks(kRestScan, flags, kForced | kActive, state, i, whole, prefetch);
      if (i == whole) break;
      std::memcpy(&f, flags + i, sizeof f);
    }
    if (forced_runs && (f & kForcedWord) != 0) {
      run.active_size = kept;
      run.changed_size = sweep.changed_size;
      const std::size_t stop = internal::advance_forced_run(kForcedRunWidth, run, i, whole);
      kept = run.active_size;
      sweep.changed_size = run.changed_size;
      if (stop % internal::kRestBlock != 0) {
        // The run refused the second four of a block: they go one by one.
        for (std::size_t j = stop; j < stop + 4; ++j) one(static_cast<Index>(j));
        i = stop + 4;
        continue;
      }
      if (stop != i) {
        i = stop;
        continue;
      }
      // Refused at once (a vertex of the first four moves outside a field).
    }
    for (std::size_t j = i; j < i + internal::kRestBlock; ++j) one(static_cast<Index>(j));
    i += internal::kRestBlock;
  }
  for (; i < count; ++i) one(static_cast<Index>(i));
  active_size_ = kept;
  sweep.finish(*this);
}

// ---------------------------------------------------------------------------
// Queries: eq. (2) positions and eq. (3) normals.

double DeformableSurface::field_force(Index i) const { return force_[i]; }

Vec3 DeformableSurface::normal_correction(Index i) const { return correction_[i]; }

Vec3 DeformableSurface::deformed_position(Index i) const {
  return mesh_->positions[i] + drawn_height(i) * mesh_->normals[i];
}

double DeformableSurface::drawn_height(Index i) const {
  const double h = state_.vertices[i].h, limit = drawn_limit_[i];
  return h < -limit ? -limit : (h > limit ? limit : h);
}

Vec3 DeformableSurface::deformed_normal(Index i) const {
  return (mesh_->normals[i] + correction_[i]).normalized();
}

// ---------------------------------------------------------------------------
// Snapshots.

void DeformableSurface::set_state(const SurfaceState& s) {
  // The snapshot must fit this mesh and hold finite values.
  const std::size_t n = mesh_->vertex_count();
  if (s.vertices.size() != n) {
    throw std::invalid_argument("set_state: the snapshot has " + std::to_string(s.vertices.size()) +
                                " vertices but the mesh has " + std::to_string(n));
  }
  if (!std::isfinite(s.time)) throw std::invalid_argument("set_state: the snapshot time is not finite");
  for (std::size_t i = 0; i < n; ++i) {
    const VertexState& v = s.vertices[i];
    if (!std::isfinite(v.h) || !std::isfinite(v.v) || !std::isfinite(v.q)) {
      throw std::invalid_argument("set_state: vertex " + std::to_string(i) + " has a non-finite state");
    }
  }
  state_ = s;
  all_changed_ = true;

  // The active set becomes the vertices not at rest or in a field; the whole stream is rewritten.
  all_dirty_ = true;
  active_size_ = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Index vi = static_cast<Index>(i);
    if (!at_rest(state_.vertices[i]) || (flags_[i] & kForced)) {
      flags_[i] |= kActive;
      active_[active_size_++] = vi;
    } else {
      flags_[i] &= static_cast<std::uint8_t>(~kActive);
    }
    write_stream(vi);
  }
}

void DeformableSurface::restore(const SurfaceState& s, std::span<const Contact> contacts) {
  if (s.vertices.size() != mesh_->vertex_count()) set_state(s);  // throws with the sizes
  set_contacts(contacts);
  apply_fields();
  set_state(s);
}

void DeformableSurface::reset() {
  // Release contacts and their fields.
  contacts_.clear();
  fields_current_ = false;
  prev_forced_.swap(forced_);
  forced_.clear();
  for (Index i : prev_forced_) leave_fields(i);
  prev_forced_.clear();
  // Vertices outside the active set are already exactly at rest.
  for (std::size_t k = 0; k < active_size_; ++k) {
    const Index i = active_[k];
    state_.vertices[i] = VertexState{};
    flags_[i] &= static_cast<std::uint8_t>(~kActive);
    write_stream(i);  // remembers i as changed
  }
  active_size_ = 0;
  state_.time = 0.0;
}

// ---------------------------------------------------------------------------
// Replicas: bringing one level with another by copying what changed.

void DeformableSurface::clear_changes() {
  for (std::size_t k = 0; k < changed_size_; ++k) flags_[changed_[k]] &= static_cast<std::uint8_t>(~kChanged);
  changed_size_ = 0;
  all_changed_ = false;
}

void DeformableSurface::level_with(DeformableSurface& src) {
  if (&src == this) return;
  if (src.mesh_ != mesh_) throw std::invalid_argument("level_with: the source surface has another mesh object");
  const std::size_t n = mesh_->vertex_count();
  // Flag bits that describe the vertex (copied) and those that are this
  // surface's own bookkeeping (kept).
  constexpr std::uint8_t kCopied = kActive | kForced;
  constexpr auto kOwn = static_cast<std::uint8_t>(~kCopied);
  VertexState* state = state_.vertices.data();
  const VertexState* src_state = src.state_.vertices.data();
  float* stream = stream_.data();
  const float* src_stream = src.stream_.data();
  // Raw pointers, so the flag byte stores do not make the compiler reload
  // every array's address from the objects.
  double* force = force_.data();
  const double* src_force = src.force_.data();
  Vec3* correction = correction_.data();
  const Vec3* src_correction = src.correction_.data();
  std::uint8_t* flags = flags_.data();
  const std::uint8_t* src_flags = src.flags_.data();
  // One vertex: state, field, flags, stream entry (dirty when its bits change).
  auto copy_one = [&](Index i) {
    state[i] = src_state[i];
    force[i] = src_force[i];
    correction[i] = src_correction[i];
    flags[i] = static_cast<std::uint8_t>((flags[i] & kOwn) | (src_flags[i] & kCopied));
    float* p = stream + 4 * static_cast<std::size_t>(i);
    const float* q = src_stream + 4 * static_cast<std::size_t>(i);
    if (std::memcmp(p, q, 4 * sizeof(float)) != 0) {
      std::memcpy(p, q, 4 * sizeof(float));
      mark_dirty(static_cast<Index>(i));
    }
  };
  if (src.all_changed_ || src.changed_size_ > n / 4) {
    // Everything (or most of it) changed: one pass over the whole arrays, in
    // index order, at copy bandwidth.
    std::memcpy(static_cast<void*>(state), src_state, n * sizeof(VertexState));
    std::copy(src.force_.begin(), src.force_.end(), force_.begin());
    std::copy(src.correction_.begin(), src.correction_.end(), correction_.begin());
    for (std::size_t i = 0; i < n; ++i) {
      flags_[i] = static_cast<std::uint8_t>((flags_[i] & kOwn) | (src.flags_[i] & kCopied));
      float* p = stream + 4 * i;
      const float* q = src_stream + 4 * i;
      if (std::memcmp(p, q, 4 * sizeof(float)) != 0) {
        std::memcpy(p, q, 4 * sizeof(float));
        mark_dirty(static_cast<Index>(i));
      }
    }
  } else {
    // The vertices changed, in the order the step met them: scattered over
    // arrays larger than the cache, so the lines of the vertex eight places
    // on are asked for first (no effect on results).
    const Index* changed = src.changed_.data();
    const std::size_t count = src.changed_size_;
    constexpr std::size_t kAhead = 8;
    for (std::size_t k = 0; k < count; ++k) {
      if (k + kAhead < count) {
        const Index a = changed[k + kAhead];
        __builtin_prefetch(state + a, 1);
        __builtin_prefetch(src_state + a);
        __builtin_prefetch(force + a, 1);
        __builtin_prefetch(src_force + a);
        __builtin_prefetch(correction + a, 1);
        __builtin_prefetch(src_correction + a);
        __builtin_prefetch(stream + 4 * static_cast<std::size_t>(a), 1);
        __builtin_prefetch(src_stream + 4 * static_cast<std::size_t>(a));
      }
      copy_one(changed[k]);
    }
  }
  // The small lists, in their order (the next step visits them in it).
  forced_.assign(src.forced_.begin(), src.forced_.end());
  prev_forced_.assign(src.prev_forced_.begin(), src.prev_forced_.end());
  std::copy(src.active_.begin(), src.active_.begin() + static_cast<std::ptrdiff_t>(src.active_size_), active_.begin());
  active_size_ = src.active_size_;
  contacts_.assign(src.contacts_.begin(), src.contacts_.end());
  state_.time = src.state_.time;
  drive_values_ = src.drive_values_;
  // Our fields are now source's, made from the same contacts and drives, and
  // (as the caller guarantees) the same materials.
  fields_current_ = src.fields_current_;
  src.clear_changes();
}

// ---------------------------------------------------------------------------
// The (nx, ny, nz, h) stream of section IV and its dirty ranges.

void DeformableSurface::write_stream(Index i) {
  // Store the float32 values, marking the vertex dirty only when they change.
  const Vec3& c = correction_[i];
  const float nx = static_cast<float>(c.x());
  const float ny = static_cast<float>(c.y());
  const float nz = static_cast<float>(c.z());
  const float h = drawn(state_.vertices[i].h, drawn_limit_[i]);
  float* p = stream_.data() + 4 * static_cast<std::size_t>(i);
  note_changed(i);
  if (p[0] != nx || p[1] != ny || p[2] != nz || p[3] != h) {
    p[0] = nx;
    p[1] = ny;
    p[2] = nz;
    p[3] = h;
    mark_dirty(i);
  }
}

void DeformableSurface::mark_dirty(Index i) {
  if (all_dirty_ || (flags_[i] & kDirty)) return;
  flags_[i] |= kDirty;
  mark_block(dirty_blocks_.data(), i);
}

std::vector<IndexRange> DeformableSurface::take_dirty_ranges() {
  std::vector<IndexRange> ranges;
  const Index count = static_cast<Index>(mesh_->vertex_count());
  // Everything changed (a new surface, set_state, restore): one range; the
  // marks made before are only cleared.
  const bool whole = all_dirty_;
  all_dirty_ = false;
  std::uint8_t* flags = flags_.data();
  // kDirty in each byte of a word of eight flags (byte k is vertex i + k).
  constexpr std::uint64_t kDirtyBytes = internal::spread8(kDirty);
  static_assert(std::endian::native == std::endian::little, "take_dirty_ranges reads eight flags as one word");
  // Vertices [b, e) join the ranges (they come in index order).
  auto add = [&ranges](Index b, Index e) {
    if (!ranges.empty() && ranges.back().end == b) {
      ranges.back().end = e;
    } else {
      ranges.push_back({b, e});
    }
  };

  // The blocks of 64 vertices holding a mark, in index order (one bit each),
  // then the marks within each: sorted without sorting, in time proportional
  // to the marked blocks (few on a spatially ordered mesh) plus one bit per
  // block of the mesh.
  for (std::size_t w = 0; w < dirty_blocks_.size(); ++w) {
    std::uint64_t bits = dirty_blocks_[w];
    if (!bits) continue;
    dirty_blocks_[w] = 0;
    while (bits) {
      const Index block = static_cast<Index>(w * 64 + static_cast<std::size_t>(std::countr_zero(bits)));
      bits &= bits - 1;
      const Index end = std::min<Index>(count, (block + 1) * 64);
      // The marks eight at a time: one load and one test for eight flags
      // (the step marks most vertices of a block, in runs).
      Index i = block * 64;
      for (; i + 8 <= end; i += 8) {
        std::uint64_t eight;
        std::memcpy(&eight, flags + i, sizeof eight);
        std::uint64_t marks = eight & kDirtyBytes;
        if (!marks) continue;
        eight &= ~kDirtyBytes;
        std::memcpy(flags + i, &eight, sizeof eight);
        if (whole) continue;
        if (marks == kDirtyBytes) {
          add(i, i + 8);
          continue;
        }
        while (marks) {
          const Index j = i + static_cast<Index>(std::countr_zero(marks) >> 3);
          marks &= marks - 1;
          add(j, j + 1);
        }
      }
      for (; i < end; ++i) {
        if (!(flags[i] & kDirty)) continue;
        flags[i] &= static_cast<std::uint8_t>(~kDirty);
        if (!whole) add(i, i + 1);
      }
    }
  }
  if (whole && count > 0) ranges.push_back({0, count});
  return ranges;
}

}  // namespace palpa::deform
