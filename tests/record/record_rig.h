#pragma once
// A scripted session on a flat patch for the record tests: two probes
// (one sliding and pressing, one pressing still), commands at fixed ticks
// (enable, clutch, material, shape, a material map, two new tissues: a
// lesion under the still probe with a vessel and a tissue map, then only
// another vessel), every input a pure function of the tick so a test knows
// what any tick must hold.

#include "common/test_support.h"
#include "haptics/loop_replay.h"
#include "haptics/session.h"
#include "mesh/generate.h"
#include "record/recorder.h"
#include "record/session_file.h"
#include "tissue/field.h"

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>

namespace palpa::record::test {

/// One folder of this test process for all the record tests' files, made
/// fresh on the first call and kept across calls (palpa::test::temp_dir,
/// which removes it when the process exits normally; a forked child that is
/// killed or calls _exit leaves it to its parent).
inline std::filesystem::path temp_dir() {
  static const std::filesystem::path dir = palpa::test::temp_dir("record");
  std::filesystem::create_directories(dir);
  return dir;
}

inline haptics::Triple probe_position(std::size_t slot, std::uint64_t tick) {
  const double t = static_cast<double>(tick) * 1e-3;
  if (slot == 0) {
    const double s = std::sin(4.0 * t);
    return {0.012 * std::sin(2.0 * t), 0.006 * std::cos(3.0 * t), -0.001 - 0.002 * s * s};
  }
  return {-0.015, -0.015, -0.0015};
}

inline haptics::ProbeTickInput input(std::size_t slot, std::uint64_t tick) {
  haptics::ProbeTickInput in;
  in.sample.orientation[0] = 1;
  const auto p = probe_position(slot, tick);
  for (int k = 0; k < 3; ++k) in.sample.position[k] = p[k];
  in.sample.status = PALPA_STATUS_VALID;
  in.sample.sequence = tick + 1;
  in.sample.time = static_cast<double>(tick) * 1e-3;
  return in;
}

inline deform::Material material(double k) {
  deform::Material m;
  m.stiffness = k;
  m.damping = 0.8;
  return m;
}

struct Rig {
  std::shared_ptr<const haptics::SessionModel> model;
  std::vector<haptics::ProbeSetup> setups;
  deform::MaterialArrays initial;
  /// The tissues the script sets at kLesionTick and kVesselTick (SetTissue).
  std::shared_ptr<const haptics::TissueModel> lesion_tissue, vessel_tissue;
  static constexpr std::uint64_t kLesionTick = 1000, kVesselTick = 1100;

  Rig() {
    auto mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(41, 41, 1e-3));
    haptics::CoreConfig c;
    c.rate_hz = 1000;
    c.deform_rate_hz = 300;  // steps every 3 or 4 ticks
    c.shape.radius = 0.006;
    model = haptics::SessionModel::make(mesh, {}, c);
    for (int j = 0; j < 2; ++j) {
      haptics::ProbeSetup s;
      s.name = "probe " + std::to_string(j);
      s.spec.position_dof = 3;
      s.spec.force_dof = 3;
      s.spec.max_force = 5.0;
      s.spec.max_stiffness = 1e5;
      s.spec.nominal_rate = 1000;
      s.safety.ramp_time = 0.05;
      s.safety.max_force_rate = 500;
      setups.push_back(s);
    }
    initial = deform::MaterialArrays::uniform(mesh->vertex_count(), material(400));

    // A stiff lesion under the still probe, a vessel along y at x = 10 mm,
    // and a map: twice as stiff where y > 0.
    tissue::Lesion l;
    l.name = "lump";
    l.centre = Vec3(-0.015, -0.015, -0.004);
    l.semi_axes = Vec3::Constant(0.003);
    l.modulus_ratio = 5;
    tissue::Pulse p;
    p.name = "vessel";
    p.path = {Vec3(0.01, -0.02, 0), Vec3(0.01, 0.02, 0)};
    p.radius = 0.004;
    p.amplitude = 0.0008;
    auto a = std::make_shared<haptics::TissueModel>();
    a->field = std::make_shared<tissue::TissueField>(tissue::make_field(*mesh, 0.008, {l}, {p}, {}, {}, {}));
    auto map = std::make_shared<deform::MaterialMap>();
    map->tissues = {material(400), material(800)};
    for (const Vec3& x : mesh->positions) map->tissue_of.push_back(x.y() > 0 ? 1 : 0);
    map->scale.assign(mesh->vertex_count(), 1.0f);
    map->scale[0] = 1.5f;
    a->map = map;
    lesion_tissue = a;
    p.rate_bpm = 100;
    p.path = {Vec3(-0.005, -0.02, 0), Vec3(-0.005, 0.02, 0)};
    auto b = std::make_shared<haptics::TissueModel>();
    b->field = std::make_shared<tissue::TissueField>(tissue::make_field(*mesh, 0.008, {}, {p}, {}, {}, {}));
    vessel_tissue = b;
  }

  std::unique_ptr<haptics::Session> session() const {
    return std::make_unique<haptics::Session>(model, initial, setups);
  }

  // The commands of the script at `tick` (before it is stepped).
  void commands(Recorder& r, haptics::Session& s, std::uint64_t tick, const deform::MaterialArrays& map) const {
    const double t = static_cast<double>(tick) * 1e-3;
    using K = haptics::LoopCommandKind;
    if (tick == 0) {
      record_apply(r, s, haptics::LoopCommand::of(K::Enable, 0), t);
      record_apply(r, s, haptics::LoopCommand::of(K::Enable, 1), t);
    }
    if (tick == 200) record_apply(r, s, haptics::LoopCommand::of(K::ClutchOn, 0), t);
    if (tick == 260) record_apply(r, s, haptics::LoopCommand::of(K::ClutchOff, 0), t);
    if (tick == 400) {
      auto c = haptics::LoopCommand::of(K::SetMaterial);
      c.material = material(700);
      record_apply(r, s, c, t);
    }
    if (tick == 700) {
      auto c = haptics::LoopCommand::of(K::SetShape);
      c.shape.radius = 0.004;
      record_apply(r, s, c, t);
    }
    if (tick == 900) {
      auto c = haptics::LoopCommand::of(K::SetMaterialMap);
      c.materials = &map;
      record_apply(r, s, c, t);
    }
    if (tick == kLesionTick || tick == kVesselTick) {
      auto c = haptics::LoopCommand::of(K::SetTissue);
      c.tissue = tick == kLesionTick ? lesion_tissue.get() : vessel_tissue.get();
      record_apply(r, s, c, t);
    }
  }

  deform::MaterialArrays stiffness_map() const {
    auto a = deform::MaterialArrays::uniform(model->mesh->vertex_count(), material(700));
    for (std::size_t i = 0; i < a.size(); ++i) a.stiffness[i] = 500 + 10000 * (model->mesh->positions[i][0] + 0.03);
    return a;
  }

  static SessionInfo info(const std::string& trainee = "test") {
    SessionInfo i;
    i.trainee = trainee;
    i.organ = "plane";
    return i;
  }

  /// Records `ticks` ticks (or until *stop) into `file`; `on_tick` after each.
  template <class F>
  void record(const std::filesystem::path& file, std::uint64_t ticks, RecorderOptions options, F&& on_tick) const {
    auto s = session();
    const auto map = stiffness_map();
    Recorder r(file, *model, initial, setups, info(), options);
    std::array<haptics::ProbeTickInput, 2> in;
    std::array<haptics::ProbeTickResult, 2> out;
    for (std::uint64_t n = 0; n < ticks; ++n) {
      commands(r, *s, n, map);
      for (std::size_t j = 0; j < 2; ++j) in[j] = input(j, n);
      record_step(r, *s, static_cast<double>(n) * 1e-3, in, out);
      on_tick(r, n, out);
    }
    r.finish();
  }
};

}  // namespace palpa::record::test
