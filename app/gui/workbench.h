#pragma once
// The workbench's model, without Qt: the organ, the probes and the material
// the panel edits, all driven by the real-time haptic loop
// (haptics::HapticLoop, its own threads at 1 kHz). Every probe is a device
// plugin: the virtual probes the mouse drives are `mouse` devices the window
// feeds (Device::feed) with the picked tip; other probes are bound to any
// plugin (scripted, spacemouse, falcon, igtl). The window calls update() once
// per frame to read the loop's latest state and take_surface_changes() to
// move the render stream.
//
// One loop runs per organ. Adding or removing a probe, changing the
// material, shape function or force parameters, and reset() are commands
// to the running loop (applied at a tick boundary, recorded with the
// session): the dent and the other probes stay where they are. Only a new
// organ builds a new loop.

#include "devices/loader.h"
#include "haptics/loop.h"
#include "mesh/organ.h"

#include <cstdint>
#include <functional>
#include <span>
#include <memory>
#include <string>
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

/// The loop's latest state of one probe (from HapticLoop::view()).
struct ProbeReadout {
  Vec3 force = Vec3::Zero();  ///< force on the probe after safety, world frame, N
  bool in_contact = false;
  double depth = 0;           ///< penetration below the undeformed surface, m
  std::uint32_t flags = 0;    ///< haptics::SafetyFlag bits
  haptics::SafetyFault fault = haptics::SafetyFault::None;
  bool enabled = false;       ///< force output enabled (devices with force output)
};

/// One probe. Mouse probes (host_fed) are pressed `depth` into the organ at
/// an undeformed surface point along the inward normal there; other probes
/// follow their device.
struct Probe {
  int id = 0;
  std::string device = "mouse";  ///< plugin name
  std::string options;           ///< plugin options it was created with
  bool host_fed = true;          ///< the window feeds its positions (mouse)
  bool force_output = false;     ///< the device renders forces
  bool wants_output = true;      ///< enabled by the user; cleared when a fault latches
  std::string fault_text;        ///< the latched fault, until re-enabled (empty: none)
  haptics::DeviceMapping mapping;  ///< device to world (identity for mouse probes)
  bool placed = false;           ///< mouse: has a surface point; others: has a reading
  Vec3 anchor = Vec3::Zero();    ///< mouse: undeformed surface point, m
  Vec3 normal = Vec3::UnitZ();   ///< mouse: outward undeformed normal there, unit
  double depth = 0;              ///< mouse: m below the undeformed surface (0: lifted off)
  Vec3 tip = Vec3::Zero();       ///< probe position (mouse: what is fed; others: the loop's), m
  ProbeReadout output;           ///< the loop's latest state (update())
  std::shared_ptr<devices::Device> dev;  ///< started; outlives every loop that uses it
  std::size_t slot = 0;          ///< the loop's probe slot
};

class Workbench {
 public:
  /// Loads plugins through `loader` (default search path when omitted).
  Workbench();
  explicit Workbench(devices::PluginLoader loader);
  ~Workbench();
  Workbench(const Workbench&) = delete;
  Workbench& operator=(const Workbench&) = delete;

  /// Replaces the organ: a new loop on it; probes stay, mouse probes are
  /// unplaced. Strong guarantee: if building throws, nothing changes.
  void set_organ(mesh::Organ organ);
  bool has_organ() const { return organ_.mesh != nullptr; }
  const mesh::Organ& organ() const { return organ_; }

  /// New material for every vertex and new force/shape parameters, sent to
  /// the running loop as edits (probes and dent kept). Strong guarantee:
  /// a bad value throws std::invalid_argument and changes nothing.
  void set_material(const MaterialSettings& m);
  const MaterialSettings& material() const { return material_; }
  /// The per-vertex materials the running model uses (once settled()).
  deform::MaterialArrays materials() const;
  /// True once the latest edit has reached the running model.
  bool settled() const;

  /// Adds a mouse probe and selects it; returns its id. Throws (nothing
  /// changed) when the mouse plugin cannot be loaded or the loop is full.
  int add_probe();
  /// Adds a probe bound to plugin `plugin` created with `options`, started,
  /// mapped with `mapping`, force output enabled; selects it and returns its
  /// id. Throws devices::DeviceError (or std::invalid_argument from the
  /// loop) with the plugin's message; nothing changes then.
  int add_device_probe(const std::string& plugin, const std::string& options, const haptics::DeviceMapping& mapping);
  /// Removes a probe (its device stops once the loop no longer uses it).
  void remove_probe(int id);
  void select_probe(int id);
  int selected_id() const { return selected_; }
  Probe* probe(int id);
  Probe* selected_probe() { return probe(selected_); }
  const std::vector<Probe>& probes() const { return probes_; }

  /// Puts mouse probe `id` at an undeformed surface point with an
  /// indentation depth (m, clamped to 0..max_depth()) and feeds its device.
  void place(int id, const Vec3& anchor, const Vec3& normal, double depth);
  void set_depth(int id, double depth);
  /// Deepest indentation allowed, m (the shape function's support radius).
  double max_depth() const { return material_.radius; }
  /// How far above the surface a lifted mouse probe (depth 0) is held, m.
  static constexpr double kLiftClearance = 1e-3;

  /// Re-enables force output of probe `id` (clears a latched fault).
  void reenable(int id);

  /// Reads the loop's latest state into every probe's output and tip;
  /// latches fault texts. Call once per frame.
  void update();
  /// The stream entries (4 floats per vertex) changed since the last call,
  /// from the loop (everything after a rebuild); empty without a loop.
  std::vector<IndexRange> take_surface_changes(std::vector<float>& stream);
  /// Hands `sink` the loop's surface mailbox (the whole stream, 4 floats per
  /// vertex) and the ranges changed since the last call, for the view to
  /// copy straight from (no intermediate copy); `everything`: every vertex
  /// is handed over this time. Returns false without a loop.
  bool pull_surface(const std::function<void(std::span<const float>, std::span<const IndexRange>)>& sink,
                    bool everything = false);

  /// Surface to rest (a command; the loop keeps running), every mouse probe lifted.
  void reset();

  /// The running loop, or null (no organ or no probe).
  const haptics::HapticLoop* loop() const { return loop_.get(); }
  haptics::LoopView view() const;
  haptics::LoopStatistics statistics() const;
  /// Probes in contact at the latest update().
  std::size_t contact_count() const;
  /// s since the organ was set (CLOCK_MONOTONIC of the loop's latest tick).
  double time() const { return time_; }

 private:
  haptics::LoopConfig loop_config() const;
  std::unique_ptr<haptics::HapticLoop> build_loop(const mesh::Organ& organ, const deform::MaterialArrays& materials,
                                                  const haptics::LoopConfig& config,
                                                  const std::vector<Probe>& probes) const;
  // Stops the current loop and starts `next` (may be null) with `probes`.
  void install(std::unique_ptr<haptics::HapticLoop> next, std::vector<Probe>& probes);
  void feed(const Probe& p) const;
  int add(Probe p);
  static haptics::ForceParams force_params(const MaterialSettings& m);
  static haptics::ProbeBinding binding(const Probe& p);

  devices::PluginLoader loader_;
  mesh::Organ organ_;
  MaterialSettings material_;
  std::vector<Probe> probes_;
  std::vector<std::shared_ptr<devices::Device>> retired_;  // removed, maybe still read by the loop
  haptics::CommandTicket last_ticket_ = 0;
  std::unique_ptr<haptics::HapticLoop> loop_;
  int selected_ = 0;
  int next_id_ = 1;
  double epoch_ = 0;  // s, CLOCK_MONOTONIC when the organ was set
  double time_ = 0;
};

/// The core's material from the panel's settings.
deform::Material to_material(const MaterialSettings& m);

}  // namespace palpa::app
