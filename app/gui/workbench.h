#pragma once
// The workbench's model, without Qt: the organ, its deformable surface, the
// collision tree, the virtual probes the mouse drives and the material the
// panel edits. The window calls tick() at the haptic rate and draws the result.

#include "collision/vertex_tree.h"
#include "deform/surface.h"
#include "haptics/probe_tick.h"
#include "render/organ.h"

#include <memory>
#include <vector>

namespace palpa::app {

/// What the material panel edits; applied to the whole organ. SI units.
struct MaterialSettings {
  deform::LocalModelKind model = deform::LocalModelKind::Linear;
  double stiffness = 200.0;  ///< N/m
  double damping = 2.0;      ///< N s/m
  double mass = 1e-3;        ///< kg
  deform::ShapeKind shape = deform::ShapeKind::Wendland;
  double radius = 0.025;     ///< shape-function support, m
  double friction = 0.2;     ///< K of eq. (4)
  double max_force = 8.0;    ///< N
};

/// One virtual probe: pressed `depth` into the organ at an undeformed
/// surface point, along the inward normal there.
struct Probe {
  int id = 0;
  bool placed = false;           ///< has a surface point
  Vec3 anchor = Vec3::Zero();    ///< undeformed surface point, m
  Vec3 normal = Vec3::UnitZ();   ///< outward undeformed normal there, unit
  double depth = 0;              ///< m below the undeformed surface (0: touching, not pressing)
  Vec3 tip = Vec3::Zero();       ///< anchor - depth * normal, m
  Vec3 velocity = Vec3::Zero();  ///< m/s
  haptics::ProbeMemory memory;
  haptics::ProbeOutput output;   ///< last tick's force and contact
};

class Workbench {
 public:
  /// Replaces the organ: new surface and tree; probes stay but are lifted
  /// and unplaced. Strong guarantee: if building throws, nothing changes.
  void set_organ(render::Organ organ);
  bool has_organ() const { return surface_ != nullptr; }
  const render::Organ& organ() const { return organ_; }
  deform::DeformableSurface& surface() { return *surface_; }
  const deform::DeformableSurface& surface() const { return *surface_; }

  /// Applies the material to every vertex, the shape and force parameters to every contact (next tick).
  void set_material(const MaterialSettings& m);
  const MaterialSettings& material() const { return material_; }

  /// Adds a probe and selects it; returns its id.
  int add_probe();
  /// Removes a probe (its contact is released at the next tick).
  void remove_probe(int id);
  void select_probe(int id);
  int selected_id() const { return selected_; }
  Probe* probe(int id);
  Probe* selected_probe() { return probe(selected_); }
  const std::vector<Probe>& probes() const { return probes_; }

  /// Puts probe `id` at an undeformed surface point with an indentation depth (m, clamped to 0..max_depth()).
  void place(int id, const Vec3& anchor, const Vec3& normal, double depth);
  void set_depth(int id, double depth);
  /// Deepest indentation allowed, m (the shape function's support radius).
  double max_depth() const { return material_.radius; }

  /// One haptic tick (collision, eq. 4 force) for every placed probe, then
  /// a deformation step, both of dt seconds.
  void tick(double dt);
  /// Surface to rest, every probe lifted (depth 0).
  void reset();
  /// Simulated time since the organ was set, s.
  double time() const { return time_; }
  std::uint64_t ticks() const { return ticks_; }

 private:
  render::Organ organ_;
  std::unique_ptr<deform::DeformableSurface> surface_;
  std::unique_ptr<collision::VertexTree> tree_;
  MaterialSettings material_;
  std::vector<Probe> probes_;
  int selected_ = 0;
  int next_id_ = 1;
  double time_ = 0;
  std::uint64_t ticks_ = 0;
  // Scratch for tick() (kept to avoid reallocating every millisecond).
  std::vector<haptics::ProbeInput> inputs_;
  std::vector<haptics::ProbeMemory> memory_;
  std::vector<haptics::ProbeOutput> outputs_;
  std::vector<std::size_t> which_;
  std::vector<deform::Contact> contacts_;
};

/// The core's material from the panel's settings.
deform::Material to_material(const MaterialSettings& m);

}  // namespace palpa::app
