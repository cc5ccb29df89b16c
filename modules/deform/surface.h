#pragma once
// The deformable surface (sections III.A, III.B, IV): per-vertex local models
// driven by contact force fields, an active set so a step costs in proportion
// to the deformed region, and the (nx, ny, nz, h) float32 stream with dirty
// ranges for partial GPU upload.

#include "deform/local_model.h"
#include "deform/shape_function.h"
#include "mesh/surface_mesh.h"

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <unordered_map>
#include <vector>

namespace palpa::deform {

/// One contact acting on the surface, as found by collision detection.
struct Contact {
  Vec3 point = Vec3::Zero();   ///< contact point on the undeformed surface, m
  Vec3 normal = Vec3::UnitZ(); ///< unit undeformed surface normal at the point
  Index vertex = kNoIndex;     ///< nearest vertex (BFS seed)
  double depth = 0;            ///< indentation below the undeformed surface, m (> 0 pushes in)
  ShapeFunction shape;
};

/// How a contact's force field reaches vertices (section III.B).
enum class Propagation : unsigned char {
  /// Breadth-first visit over mesh neighbours from the contact vertex,
  /// stopping at vertices farther than the support radius (CPU way).
  Topological = 0,
  /// Every vertex tests its distance to the contact point and its normal
  /// against the contact normal (GPU way; data-parallel, O(V) per contact).
  DistanceNormal = 1,
};

struct SurfaceOptions {
  Propagation propagation = Propagation::Topological;
  /// Vertices whose undeformed normal has n . n_contact below this are not
  /// affected (keeps fields off the far side of thin parts); with
  /// Topological propagation the visit does not go on through them either.
  double min_normal_cosine = 0.0;
  /// Limit the drawn displacement (the stream's h, deformed_position) of
  /// each vertex to drawn_limit(i) (see drawn_displacement_limits), so the
  /// drawn surface does not pass through its opposite side or fold past a
  /// centre of curvature. Each contact's field is also shaped with its depth
  /// cut to the limit at its vertex, so the drawn dent stays smooth and its
  /// normal corrections match it. The contacts' depths, and so the haptic
  /// force, are not limited.
  bool limit_drawn_displacement = true;
  /// Fraction of the inward thickness (mesh::inward_thickness) a vertex may
  /// be drawn in or out: below 1/2, so two sides pressed towards each other
  /// do not meet.
  double thickness_fraction = 0.4;
  /// Fraction of the convex radius of curvature (mesh::convex_radius) a
  /// vertex may be drawn in or out: below 1, so neighbours do not cross.
  /// The radius bounds two neighbours moved by the same h; on a dent's wall h
  /// varies, which turns triangles over sooner: 0.4 still showed back faces
  /// on a 42 mm organ's thin rim, 0.3 none (tests/render DeepPressImage).
  double curvature_fraction = 0.3;
  /// Limits (m per vertex) computed beforehand with
  /// drawn_displacement_limits for this mesh and these fractions; null: taken
  /// from another live surface of the same mesh object with the same
  /// fractions, else computed at construction (a ray cast per vertex, about
  /// a second per million vertices).
  std::shared_ptr<const std::vector<double>> drawn_limits;
  /// A vertex outside every field leaves the active set once |h|, |v| dt and
  /// |q| are all at or below this (m); its state is then set exactly to rest.
  double rest_threshold = 1e-9;
};

/// Per vertex, the largest drawn displacement (m): min(thickness_fraction *
/// mesh::inward_thickness, curvature_fraction * mesh::convex_radius);
/// +infinity where neither bounds it (an open flat patch).
std::vector<double> drawn_displacement_limits(const mesh::SurfaceMesh& mesh, double thickness_fraction = 0.4,
                                              double curvature_fraction = 0.3);

/// A tissue map as plain data: vertex i has scaled(tissues[tissue_of[i]], scale[i])
/// (scale empty: all 1). What DeformableSurface::set_tissue_map takes.
struct MaterialMap {
  std::vector<Material> tissues;
  std::vector<std::uint16_t> tissue_of;  ///< per vertex, index into tissues
  std::vector<float> scale;              ///< per vertex modulus multiplier (> 0), or empty
};

/// Per-tick state of the whole surface: plain data the recorder can snapshot.
struct SurfaceState {
  std::vector<VertexState> vertices;
  double time = 0;  ///< s, advanced by every step
};

class DeformableSurface {
 public:
  /// All vertices start at rest with no contact. Throws std::invalid_argument
  /// when the mesh is null or not finalized (normals and adjacency per vertex),
  /// when the materials do not fit it (MaterialArrays::validate) or when an
  /// option is out of range, e.g. "SurfaceOptions: rest_threshold must be
  /// non-negative and finite, got -1 m".
  DeformableSurface(std::shared_ptr<const mesh::SurfaceMesh> mesh, MaterialArrays materials,
                    SurfaceOptions options = {});

  const mesh::SurfaceMesh& mesh() const { return *mesh_; }
  /// The per-vertex materials, rebuilt from the table of distinct materials
  /// (O(vertices); for the GUI, tests and records, not for the haptic tick).
  MaterialArrays materials() const;
  /// True when every vertex has the same material.
  bool uniform() const;
  /// The largest small-strain stiffness any vertex can show, N/m (the
  /// Maxwell arm's k2 added for Viscoelastic), from the table of distinct
  /// materials (cheap).
  double max_stiffness() const;
  /// The material of vertex i: the same values as materials().at(i), read
  /// from one small table of distinct materials (one index per vertex), so
  /// the haptic tick touches one array instead of seven. i < vertex count.
  const Material& material(Index i) const { return integrators_[integrator_of_[i]].material; }
  /// Modulus multiplier of vertex i (1 unless a tissue map set one), dimensionless.
  double modulus_scale(Index i) const { return scale_.empty() ? 1.0 : static_cast<double>(scale_[i]); }
  /// The material vertex i actually has: material(i) scaled by modulus_scale(i)
  /// (deform::scaled). i < vertex count.
  Material vertex_material(Index i) const {
    return scale_.empty() ? material(i) : scaled(material(i), static_cast<double>(scale_[i]), scale_root_[i]);
  }
  /// Hints the processor to fetch what deformed_normal(i), material(i) and
  /// state() read for vertex i into cache (no effect on results; lets the
  /// haptic tick overlap the memory latency of several probes). i < vertex count.
  void prefetch_vertex(Index i) const {
    __builtin_prefetch(state_.vertices.data() + i);
    __builtin_prefetch(correction_.data() + i);
    __builtin_prefetch(mesh_->normals.data() + i);
    __builtin_prefetch(integrator_of_.data() + i);
    if (!scale_.empty()) __builtin_prefetch(scale_.data() + i);
  }
  /// Replace the material of vertex i (takes effect at the next step).
  /// Throws std::invalid_argument for an out-of-range vertex or a bad material.
  void set_material(Index i, const Material& m);
  /// Replace the whole material map (O(vertices)); throws as MaterialArrays::validate.
  void set_materials(const MaterialArrays& materials);
  /// Give every vertex material m (takes effect at the next step). O(1) when
  /// the surface is already uniform (one table entry is replaced), one pass
  /// over the vertices otherwise. Throws std::invalid_argument for a bad material.
  void set_uniform_material(const Material& m);
  /// A tissue map in one pass, without looking materials up one by one
  /// (what a 1M-vertex heterogeneous map needs): vertex i gets
  /// scaled(tissues[tissue_of[i]], scale[i]). `scale` may be empty (all 1).
  /// Throws std::invalid_argument for a bad tissue material, a tissue index
  /// out of range, a scale that is not positive and finite, or sizes that do
  /// not match the mesh ("set_tissue_map: scale of vertex 7 must be positive
  /// and finite, got 0").
  void set_tissue_map(std::vector<Material> tissues, std::span<const std::uint16_t> tissue_of,
                      std::span<const float> scale);
  void set_tissue_map(const MaterialMap& map) { set_tissue_map(map.tissues, map.tissue_of, map.scale); }

  /// Drives that move the surface's rest shape with time (pulsing vessels):
  /// drive p lifts vertex vertices[j] by weights[j][p] * value_p (m), value_p
  /// set per step with set_drive_values. The lift is an outward force that
  /// holds a free vertex at that height (equilibrium_force); under a contact
  /// it adds to the contact's field. Drive vertices stay in the active set.
  /// Throws std::invalid_argument for an index out of range or a weight
  /// that is not finite; sizes must match.
  void set_drives(std::vector<Index> vertices, std::vector<std::array<float, 4>> weights);
  /// The drives' values for the following steps, m (no allocation).
  void set_drive_values(const std::array<double, 4>& values) {
    if (values != drive_values_) fields_current_ = false;
    drive_values_ = values;
  }

  const SurfaceOptions& options() const { return options_; }

  /// The contacts whose force fields act during the following steps
  /// (several superpose by summing forces and corrections). Copied; an empty
  /// span releases all contacts. Contacts with a zero or non-finite depth, a
  /// non-finite point or a radius <= 0 shape nothing. With Topological
  /// propagation a contact whose vertex is not a mesh vertex falls back to the
  /// DistanceNormal test. The same contacts again, bit for bit, with no
  /// material, tissue-map or drive edit since, keep the fields already
  /// built: the next step does not visit them again (same results).
  void set_contacts(std::span<const Contact> contacts);
  std::span<const Contact> contacts() const { return contacts_; }

  /// Advances the active set by dt seconds. Deterministic: the result depends
  /// only on the previous state, the contacts, the materials and dt. Each
  /// contact j drives vertex i (undeformed distance r from the contact point)
  /// with the force that holds it at height -depth_j S_j(r). A dt that is not
  /// positive and finite does nothing. Allocates nothing once its buffers
  /// have grown to the largest field seen. Runs with subnormal values taken
  /// as zero (core/subnormals.h), as step_full() does; the caller's
  /// floating-point mode is restored.
  void step(double dt);
  /// Advances every vertex (reference and benchmark path). Same physics and
  /// same results as step(): vertices outside the active set are at rest.
  void step_full(double dt);

  /// Force field (N, along the outward normal) currently applied to vertex i.
  double field_force(Index i) const;
  /// Normal correction of eq. (3) for vertex i (sum over contacts, not normalised).
  Vec3 normal_correction(Index i) const;
  /// Deformed position P0 + h N0 (eq. 2) as drawn: h = drawn_height(i), m.
  Vec3 deformed_position(Index i) const;
  /// The height the stream draws for vertex i: state().vertices[i].h clamped
  /// to [-drawn_limit(i), drawn_limit(i)], m.
  double drawn_height(Index i) const;
  /// Largest drawn displacement of vertex i, m (+infinity when unlimited).
  double drawn_limit(Index i) const { return drawn_limit_[i]; }
  /// All of them (m per vertex), shareable with SurfaceOptions::drawn_limits.
  const std::shared_ptr<const std::vector<double>>& drawn_limits() const { return drawn_limits_; }
  /// Deformed unit normal normalize(N0 + sum Ni) (eq. 3).
  Vec3 deformed_normal(Index i) const;

  const SurfaceState& state() const { return state_; }
  /// Restores a snapshot taken with state() (same mesh); marks everything dirty.
  /// Throws std::invalid_argument when its vertex count differs from the mesh
  /// ("set_state: the snapshot has 3 vertices but the mesh has 4") or a value
  /// is not finite.
  void set_state(const SurfaceState& s);
  /// Restores a snapshot taken as state() and contacts() after a step: the
  /// contacts' fields are rebuilt first, so the surface (fields, active set,
  /// stream) is exactly the one the snapshot was taken from and the next
  /// step gives the same bits. Throws as set_state.
  void restore(const SurfaceState& s, std::span<const Contact> contacts);
  /// Returns every vertex to rest, releases contacts and sets time to 0.
  void reset();

  /// Vertices integrated by step() now.
  std::size_t active_count() const { return active_size_; }

  /// Replicas (the live loop's two copies of one surface). Every vertex whose
  /// state, field, flags or stream entry a step, reset, set_state or restore
  /// may have changed is remembered (each once) until the next level_with
  /// that reads this surface or clear_changes().
  ///
  /// Makes this surface equal to `source` by copying only what `source`
  /// changed since it was last level with this one: the remembered vertices'
  /// states, fields and stream entries, and the small lists (active set,
  /// field vertices, contacts, time, drive values); then forgets source's
  /// changes. The whole arrays are copied when source changed everything
  /// (set_state, restore) or most vertices. The caller guarantees that the
  /// two were level before source changed and that both got the same
  /// material edits (materials are not copied). Stream entries that change
  /// here are marked dirty in this surface. Afterwards every query on this
  /// surface gives the bits `source` gives. Throws std::invalid_argument when
  /// source has another mesh object. Allocates nothing once its lists have
  /// grown to source's.
  void level_with(DeformableSurface& source);
  /// Forgets the changes remembered so far (both replicas are known level).
  void clear_changes();
  /// Vertices remembered as changed (all of them after set_state or restore).
  std::size_t changed_count() const { return all_changed_ ? mesh_->vertex_count() : changed_size_; }

  /// The (nx, ny, nz, h) float32 stream of section IV, 4 floats per vertex:
  /// normal correction and height (m).
  std::span<const float> stream() const { return stream_; }
  /// Index ranges covering exactly the vertices whose stream entries changed
  /// since the last call (sorted, disjoint, merged only where contiguous), so
  /// an upload of them moves 16 bytes per changed vertex; clears them. The
  /// first call after construction or set_state returns the whole mesh.
  std::vector<IndexRange> take_dirty_ranges();

 private:
  // One distinct material with its integrator, cached for the step dt_ it was built for.
  struct Integrator {
    Material material;
    LinearStep linear;  // valid for Linear when coefficients_dt_ is the step's dt
  };

  // Bit pattern of a Material's fields: the key that finds its Integrator.
  using MaterialKey = std::array<std::uint64_t, 9>;
  struct MaterialKeyHash {
    std::size_t operator()(const MaterialKey& k) const;
  };

  template <bool kPlain>
  struct Sweep;  // the per-vertex update shared by step() and step_full()
  // step() and step_full() after prepare_step, kPlain when plain_linear().
  template <bool kPlain>
  void sweep_active(double dt);
  template <bool kPlain>
  void sweep_full(double dt);
  // The surface's only material when it is Linear and no modulus scale is
  // set (every vertex then has f = stiffness h and the same step); null
  // otherwise.
  const Integrator* plain_linear() const;

  void prepare_step(double dt);
  void apply_fields();
  struct FieldConstants;  // what every vertex of one contact's field shares
  void add_field(Index i, const Contact& c, double depth, const Vec3& d, double r, const Vec3& n0,
                 const FieldConstants& k);
  void field_by_bfs(const Contact& c, double depth, const Vec3* n);
  template <bool kLight>
  void visit_field(const Contact& c, double depth, const Vec3* n, const FieldConstants& fc);
  void field_by_scan(const Contact& c, double depth, const Vec3& n);
  double field_depth(const Contact& c) const;
  // The first field of a build to reach vertex i clears what the last build
  // left there and lists it in forced_ (flag bit 5 until the build ends).
  void touch_field(Index i);
  // Asks for huge pages for this surface's per-vertex arrays and its mesh's
  // (core/huge_pages.h); the constructor's last act.
  void advise_huge_pages() const;
  // Vertex i is in no field any more: no force or correction, not forced,
  // and its stream entry rewritten.
  void leave_fields(Index i);
  void write_stream(Index i);
  void mark_dirty(Index i);
  void note_changed(Index i) {
    if (flags_[i] & kChangedFlag) return;
    flags_[i] |= kChangedFlag;
    changed_[changed_size_++] = i;
  }
  static constexpr std::uint8_t kChangedFlag = 1u << 4;
  static MaterialKey key_of(const Material& m);
  Index intern_material(const Material& m);
  void build_integrators(const MaterialArrays& materials);
  void compact_integrators();

  std::shared_ptr<const mesh::SurfaceMesh> mesh_;
  SurfaceOptions options_;
  SurfaceState state_;
  std::vector<Contact> contacts_;

  std::vector<Integrator> integrators_;  // distinct materials
  std::vector<Index> integrator_of_;     // per vertex: index into integrators_
  std::unordered_map<MaterialKey, Index, MaterialKeyHash> integrator_lookup_;
  double coefficients_dt_ = 0;           // s; dt the Linear coefficients were made for (0: none)
  std::vector<float> scale_;             // per vertex modulus multiplier (empty: all 1)
  // sqrt of each scale_ entry (as a double; empty with scale_): the factor of
  // a scaled vertex's damping, kept so the step takes no square root per
  // vertex (on a mapped 1M surface it made the steady step 1.17x a uniform one's).
  std::vector<double> scale_root_;
  std::vector<Index> drive_vertices_;    // set_drives
  std::vector<std::array<float, 4>> drive_weights_;
  std::array<double, 4> drive_values_{};  // m

  std::vector<double> force_;         // N, per vertex
  std::vector<Vec3> correction_;      // eq. (3) sum, per vertex
  std::vector<Index> forced_;         // vertices inside a contact's field this step
  std::vector<Index> prev_forced_;    // forced_ of the previous step
  // force_, correction_, the forced flags and forced_ are what apply_fields
  // would build from contacts_, the materials and the drives as they are now
  // (bit for bit: it depends on nothing else), so a step with the same
  // contacts skips the visit. Cleared by every edit of those.
  bool fields_current_ = false;
  std::vector<Index> active_;         // active set: first active_size_ entries (storage for every vertex)
  std::size_t active_size_ = 0;
  std::vector<std::uint8_t> flags_;   // bit 0: active, 1: forced, 2: visited, 3: dirty, 4: changed, 5: fresh
  std::vector<Index> bfs_queue_;
  std::vector<float> stream_;
  std::shared_ptr<const std::vector<double>> drawn_limits_;  // per vertex, m (all +inf when unlimited)
  const double* drawn_limit_ = nullptr;                      // drawn_limits_->data()
  // Vertices changed since take_dirty_ranges carry flag bit 3; bit b of word
  // w here says that one of the vertices 64 (64 w + b) .. + 63 may.
  std::vector<std::uint64_t> dirty_blocks_;
  bool all_dirty_ = true;             // every vertex changed (new surface or set_state)
  std::vector<Index> changed_;        // for level_with (flag bit 4): first changed_size_ entries
  std::size_t changed_size_ = 0;
  bool all_changed_ = false;          // set_state or restore: level_with copies everything
};

}  // namespace palpa::deform
