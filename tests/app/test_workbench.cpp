// The workbench's model, driven by the real-time haptic loop, against closed
// forms: a probe held in a linear material feels k d (eq. 1 at rest, eq. 4
// without sliding); probes are devices (mouse probes fed by the host, a
// scripted device replaying a file), a device that cannot start changes
// nothing; depth limits, material changes and reset behave as the window
// relies on. Scenarios: each shipped one runs on a loop whose model holds
// its field and tissue map, a bad one changes nothing and names its file, a
// Hertz material reaches the loop as tissue::hertz_material gives it, a
// mouse probe on a breathing organ is fed tips that move with the phase, and
// a material edit of a scenario is undone. The loop runs on its own threads,
// so the tests wait for conditions with a timeout (never for wall-time figures).

#include "app/gui/workbench.h"
#include "app/replay/session_job.h"

#include "common/test_support.h"
#include "mesh/generate.h"
#include "scenario/scenario.h"

#include <chrono>
#include <fstream>
#include <functional>
#include <thread>

namespace palpa::app {
namespace {

mesh::Organ sphere_organ() {
  mesh::Organ o;
  o.name = "sphere";
  auto m = std::make_shared<mesh::SurfaceMesh>(mesh::make_sphere(8000, 0.05));
  // Exactly radial normals, so the virtual vertex is exactly under the probe.
  for (std::size_t i = 0; i < m->vertex_count(); ++i) m->normals[i] = m->positions[i].normalized();
  o.mesh = m;
  o.facts = mesh::analyse(*m);
  return o;
}

// Calls wb.update() until `done` holds or `timeout_s` passes; returns done().
bool wait_for(Workbench& wb, const std::function<bool()>& done, double timeout_s = 20) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    wb.update();
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  wb.update();
  return done();
}

// Largest |h| of a render stream (4 floats per vertex: Ncorr, h).
double max_h(const std::vector<float>& stream) {
  double m = 0;
  for (std::size_t i = 3; i < stream.size(); i += 4) m = std::max(m, static_cast<double>(std::abs(stream[i])));
  return m;
}

TEST(Workbench, AHeldProbeFeelsStiffnessTimesDepth) {
  Workbench wb;
  MaterialSettings mat;
  mat.law = MaterialLaw::Linear;  // the advanced N/m model
  mat.stiffness = 300;
  wb.set_material(mat);
  wb.set_organ(sphere_organ());
  const int id = wb.add_probe();
  ASSERT_NE(wb.loop(), nullptr);
  wb.place(id, Vec3(0, 0, 0.05), Vec3::UnitZ(), 0.004);
  // At rest the local model under the probe holds h = -d: F = k d along +n.
  const double expected = 300 * 0.004;
  const Probe& p = *wb.probe(id);
  EXPECT_TRUE(wait_for(wb, [&] { return p.output.in_contact && std::abs(p.output.force.z() - expected) < 0.05 * expected; }))
      << "force " << p.output.force.transpose();
  EXPECT_NEAR(p.output.force.z(), expected, 0.05 * expected);
  EXPECT_NEAR(p.output.force.head<2>().norm(), 0.0, 1e-3);
  EXPECT_NEAR(p.output.depth, 0.004, 1e-4);
  EXPECT_GT(wb.time(), 0.0);
  EXPECT_GT(wb.statistics().ticks, 0u);
}

TEST(Workbench, SeveralProbesPressAtOnceAndRemovingOneReleasesIt) {
  Workbench wb;
  wb.set_organ(sphere_organ());
  const int a = wb.add_probe();
  const int b = wb.add_probe();
  EXPECT_EQ(wb.selected_id(), b);
  EXPECT_EQ(wb.loop()->probe_count(), 2u);
  wb.place(a, Vec3(0, 0, 0.05), Vec3::UnitZ(), 0.003);
  wb.place(b, Vec3(0, 0, -0.05), -Vec3::UnitZ(), 0.003);
  EXPECT_TRUE(wait_for(wb, [&] { return wb.contact_count() == 2; }));
  EXPECT_TRUE(wb.probe(a)->output.in_contact);
  EXPECT_TRUE(wb.probe(b)->output.in_contact);
  wb.remove_probe(b);
  EXPECT_EQ(wb.selected_id(), a);
  EXPECT_EQ(wb.loop()->probe_count(), 1u);
  EXPECT_TRUE(wait_for(wb, [&] { return wb.probe(a)->output.in_contact; }));
  EXPECT_EQ(wb.contact_count(), 1u);
}

TEST(Workbench, ALiftedProbeDoesNotTouch) {
  Workbench wb;
  wb.set_organ(sphere_organ());
  const int id = wb.add_probe();
  wb.place(id, Vec3(0, 0, 0.05), Vec3::UnitZ(), 0.0);
  EXPECT_TRUE(wait_for(wb, [&] { return wb.view().tick > 10; }));
  EXPECT_FALSE(wb.probe(id)->output.in_contact);
  EXPECT_EQ(wb.probe(id)->output.force.norm(), 0.0);
}

TEST(Workbench, DepthIsClampedToTheShapeRadiusAndMaterialAppliesAtOnce) {
  Workbench wb;
  wb.set_organ(sphere_organ());
  const int id = wb.add_probe();
  wb.place(id, Vec3(0, 0, 0.05), Vec3::UnitZ(), 1.0);
  EXPECT_EQ(wb.probe(id)->depth, wb.max_depth());
  wb.set_depth(id, -1.0);
  EXPECT_EQ(wb.probe(id)->depth, 0.0);
  MaterialSettings m;
  m.law = MaterialLaw::Linear;  // the advanced N/m model
  m.stiffness = 1234;
  m.model = deform::LocalModelKind::Exponential;
  const haptics::HapticLoop* before = wb.loop();
  wb.set_material(m);
  // The same running loop gets the new material at its next deformation
  // step (an edit, not a rebuild); the probe is kept.
  ASSERT_NE(wb.loop(), nullptr);
  EXPECT_EQ(wb.loop(), before);
  ASSERT_TRUE(wait_for(wb, [&] { return wb.settled(); }));
  EXPECT_EQ(wb.loop()->surface().materials().stiffness.front(), 1234);
  EXPECT_EQ(wb.loop()->surface().materials().stiffness.back(), 1234);
  EXPECT_EQ(wb.loop()->surface().materials().model.front(), deform::LocalModelKind::Exponential);
  EXPECT_EQ(wb.materials().stiffness.front(), 1234);
  ASSERT_EQ(wb.probes().size(), 1u);
  EXPECT_TRUE(wb.probe(id)->placed);
  EXPECT_EQ(wb.loop()->core_state().shape.radius, m.radius);
}

TEST(Workbench, ResetLiftsEveryProbeAndRestsTheSurface) {
  Workbench wb;
  wb.set_organ(sphere_organ());
  const int id = wb.add_probe();
  wb.place(id, Vec3(0, 0, 0.05), Vec3::UnitZ(), 0.004);
  std::vector<float> stream;
  EXPECT_TRUE(wait_for(wb, [&] {
    wb.take_surface_changes(stream);
    return max_h(stream) > 1e-3;
  }));
  const haptics::HapticLoop* before = wb.loop();
  wb.reset();
  EXPECT_EQ(wb.loop(), before);  // a command to the running loop, not a new loop
  EXPECT_EQ(wb.probe(id)->depth, 0.0);
  // The surface comes back to rest exactly (the reset step zeroes every vertex).
  EXPECT_TRUE(wait_for(wb, [&] {
    wb.take_surface_changes(stream);
    return wb.settled() && max_h(stream) == 0.0;
  }));
  EXPECT_EQ(max_h(stream), 0.0);
  EXPECT_TRUE(wait_for(wb, [&] { return wb.view().tick > 10; }));
  EXPECT_EQ(wb.contact_count(), 0u);
}

TEST(Workbench, ANewOrganUnplacesTheProbes) {
  Workbench wb;
  wb.set_organ(sphere_organ());
  const int id = wb.add_probe();
  wb.place(id, Vec3(0, 0, 0.05), Vec3::UnitZ(), 0.004);
  wb.set_organ(sphere_organ());
  EXPECT_FALSE(wb.probe(id)->placed);
  EXPECT_EQ(wb.time(), 0.0);
}

TEST(Workbench, AScriptedDeviceDrivesAContact) {
  const auto dir = palpa::test::temp_dir("workbench_scripted");
  const auto file = dir / "press.csv";
  // From 1 cm above the top of the sphere to 4 mm into it, then held.
  { std::ofstream(file) << "t,x,y,z,buttons\n0,0,0,0.06,0\n0.2,0,0,0.046,0\n1000,0,0,0.046,0\n"; }
  Workbench wb;
  wb.set_organ(sphere_organ());
  wb.add_probe();
  const int id = wb.add_device_probe("scripted", "file=" + file.string(), haptics::DeviceMapping{});
  EXPECT_EQ(wb.selected_id(), id);
  const Probe& p = *wb.probe(id);
  EXPECT_FALSE(p.host_fed);
  EXPECT_TRUE(p.force_output);
  // Held 4 mm deep: in contact, pushed out along +z.
  EXPECT_TRUE(wait_for(wb, [&] {
    return std::abs(p.tip.z() - 0.046) < 1e-9 && p.output.in_contact && p.output.force.z() > 0.1;
  })) << "tip " << p.tip.transpose() << ", force " << p.output.force.transpose();
  EXPECT_NEAR(p.output.depth, 0.004, 1e-4);
  EXPECT_TRUE(p.output.enabled);
  // The force the device gets is the world force (identity mapping), within its limit.
  EXPECT_LE(p.output.force.norm(), 10.0);
}

TEST(Workbench, ADeviceThatCannotStartChangesNothing) {
  Workbench wb;
  wb.set_organ(sphere_organ());
  const int id = wb.add_probe();
  const auto* loop = wb.loop();
  const auto missing = palpa::test::temp_dir("workbench_bad_device") / "missing.csv";
  try {
    wb.add_device_probe("scripted", "file=" + missing.string(), haptics::DeviceMapping{});
    ADD_FAILURE() << "no error";
  } catch (const devices::DeviceError& e) {
    EXPECT_EQ(std::string(e.what()), "scripted: cannot open trajectory file '" + missing.string() + "'");
  }
  EXPECT_THROW(wb.add_device_probe("nosuchdevice", "", haptics::DeviceMapping{}), devices::DeviceError);
  ASSERT_EQ(wb.probes().size(), 1u);
  EXPECT_EQ(wb.selected_id(), id);
  EXPECT_EQ(wb.loop(), loop) << "the loop was not rebuilt";
  EXPECT_TRUE(wb.loop()->running());
}


// ---------------------------------------------------------------------------
// Scenarios.

std::filesystem::path shipped(const std::string& name) { return palpa::test::project_data_dir() / "scenarios" / name; }

// The material of vertex i that a tissue map gives.
deform::Material map_material(const deform::MaterialMap& map, Index i) {
  const deform::Material& m = map.tissues.at(map.tissue_of.at(i));
  return map.scale.empty() ? m : deform::scaled(m, map.scale[i]);
}

TEST(WorkbenchScenario, EachShippedScenarioRunsOnALoopWithItsFieldAndTissueMap) {
  for (const char* name : {"breast_two_nodules.json", "liver_tumour.json", "abdomen_aorta.json"}) {
    SCOPED_TRACE(name);
    Workbench wb;
    wb.add_probe();
    ASSERT_NO_THROW(wb.open_scenario(shipped(name)));
    ASSERT_TRUE(wb.has_scenario());
    const scenario::Resolved& sc = *wb.scenario();
    ASSERT_NE(wb.loop(), nullptr);
    EXPECT_TRUE(wb.loop()->running());
    EXPECT_EQ(wb.organ().mesh, sc.organ.mesh);
    // The loop runs on the scenario's model: its field and its tissue map.
    const haptics::SessionModel* model = wb.loop()->model();
    ASSERT_NE(model, nullptr);
    ASSERT_NE(model->field, nullptr);
    ASSERT_NE(model->tissue_map, nullptr);
    EXPECT_EQ(model->field, sc.field);
    EXPECT_EQ(model->tissue_map, sc.materials);
    EXPECT_EQ(model->mesh, sc.organ.mesh);
    EXPECT_EQ(model->field->lesion_count, sc.lesions.size());
    EXPECT_TRUE(wb.tissue_map_in_force());
    // The probe's shape function and the base tissue in the settings.
    EXPECT_EQ(model->config.shape.kind, sc.scenario.probe.shape.kind);
    EXPECT_EQ(model->config.shape.radius, sc.scenario.probe.shape.radius);
    EXPECT_EQ(wb.material().law, MaterialLaw::Hertz);
    EXPECT_EQ(wb.material().tissue, sc.scenario.tissues[sc.base]);
    EXPECT_EQ(wb.material().tip_radius, sc.scenario.probe.tip_radius);
    EXPECT_EQ(wb.material().radius, sc.scenario.probe.shape.radius);
    // The map is what the vertices have (one vertex per 97 checked).
    const deform::MaterialArrays now = wb.materials();
    for (Index i = 0; i < sc.organ.mesh->vertex_count(); i += 97)
      ASSERT_EQ(now.at(i), map_material(*sc.materials, i)) << "vertex " << i;
    EXPECT_TRUE(wait_for(wb, [&] { return wb.view().tick > 10; }));
  }
}

TEST(WorkbenchScenario, TheShippedScenariosHoldWhatTheyPromise) {
  Workbench wb;
  wb.open_scenario(shipped("breast_two_nodules.json"));
  EXPECT_EQ(wb.field()->lesion_count, 2u);
  for (const auto& l : wb.scenario()->lesions) EXPECT_EQ(l.visibility, tissue::Visibility::Hidden) << l.name;
  EXPECT_FALSE(wb.field()->breathing.enabled);
  wb.open_scenario(shipped("abdomen_aorta.json"));
  EXPECT_TRUE(wb.field()->breathing.enabled);
  EXPECT_EQ(wb.field()->pulse_count, 1u);
}

TEST(WorkbenchScenario, ABadScenarioChangesNothingAndNamesTheFile) {
  const auto dir = palpa::test::temp_dir("workbench_bad_scenario");
  Workbench wb;
  const int id = wb.add_probe();
  wb.open_scenario(shipped("liver_tumour.json"));
  wb.place(id, wb.organ().mesh->positions[0], wb.organ().mesh->normals[0], 0.002);
  const haptics::HapticLoop* loop = wb.loop();
  const auto mesh_before = wb.organ().mesh;
  const scenario::Resolved* sc_before = wb.scenario();
  const MaterialSettings material_before = wb.material();

  // A validation fault: the file and the JSON pointer in the message.
  const auto bad = dir / "bad_radius.json";
  {
    scenario::Scenario s = scenario::load_scenario(shipped("liver_tumour.json"));
    std::string text = scenario::to_json_text(s);
    const auto at = text.find("\"radius_mm\": ");
    ASSERT_NE(at, std::string::npos);
    text.replace(at, std::string("\"radius_mm\": ").size(), "\"radius_mm\": -3, \"x\": ");
    std::ofstream(bad) << text;
  }
  // An organ that does not exist: the scenario is named, not only the organ file.
  const auto no_organ = dir / "no_organ.json";
  {
    scenario::Scenario s = scenario::load_scenario(shipped("liver_tumour.json"));
    s.organ.path = "missing_organ.ply";
    s.organ.sha256.clear();
    std::ofstream(no_organ) << scenario::to_json_text(s);
  }
  // Not JSON at all, and a file that is not there.
  const auto garbage = dir / "garbage.json";
  { std::ofstream(garbage) << "{ this is not json"; }
  const auto missing = dir / "missing.json";

  for (const auto& file : {bad, no_organ, garbage, missing}) {
    SCOPED_TRACE(file.string());
    try {
      wb.open_scenario(file);
      ADD_FAILURE() << "no error";
    } catch (const std::exception& e) {
      EXPECT_EQ(std::string(e.what()).rfind(file.string(), 0), 0u) << e.what();
    }
    // Same loop object, organ, scenario, settings and probe.
    EXPECT_EQ(wb.loop(), loop);
    EXPECT_TRUE(wb.loop()->running());
    EXPECT_EQ(wb.organ().mesh, mesh_before);
    EXPECT_EQ(wb.scenario(), sc_before);
    EXPECT_EQ(wb.material().tissue, material_before.tissue);
    EXPECT_TRUE(wb.probe(id)->placed);
    EXPECT_EQ(wb.probe(id)->depth, 0.002);
  }
  const auto ticks = wb.statistics().ticks;
  EXPECT_TRUE(wait_for(wb, [&] { return wb.statistics().ticks > ticks; }));
}

TEST(WorkbenchScenario, AHertzMaterialReachesTheLoopAsTissueGivesIt) {
  Workbench wb;
  wb.set_organ(sphere_organ());
  MaterialSettings m;
  m.law = MaterialLaw::Hertz;
  m.tissue.youngs_modulus = 12.5e3;
  m.tissue.poisson = 0.45;
  m.tissue.damping_ratio = 0.8;
  m.tissue.relaxation_time = 0.5;
  m.tissue.relaxation_fraction = 0.2;
  m.tissue.stiffening = 20;
  m.tip_radius = 0.006;
  wb.set_material(m);
  ASSERT_TRUE(wait_for(wb, [&] { return wb.settled(); }));
  const deform::Material expected = tissue::hertz_material(m.tissue, 0.006, m.mass);
  EXPECT_EQ(expected.model, deform::LocalModelKind::Hertz);
  EXPECT_EQ(wb.loop()->surface().material(0), expected);
  EXPECT_EQ(wb.loop()->surface().material(Index(wb.organ().mesh->vertex_count() - 1)), expected);
  // A bad tissue is refused and changes nothing.
  MaterialSettings bad = m;
  bad.tissue.poisson = 0.5;
  EXPECT_THROW(wb.set_material(bad), std::invalid_argument);
  EXPECT_EQ(wb.material().tissue, m.tissue);
}

TEST(WorkbenchScenario, AMaterialEditReplacesTheTissueMapAndRestoreUndoesIt) {
  Workbench wb;
  wb.open_scenario(shipped("breast_two_nodules.json"));
  const scenario::Resolved& sc = *wb.scenario();
  const haptics::HapticLoop* loop = wb.loop();
  MaterialSettings m = wb.material();
  m.tissue.youngs_modulus = 30e3;
  wb.set_material(m);
  EXPECT_FALSE(wb.tissue_map_in_force());
  EXPECT_EQ(wb.loop(), loop) << "an edit, not a new loop";
  ASSERT_TRUE(wait_for(wb, [&] { return wb.settled(); }));
  const deform::Material uniform = tissue::hertz_material(m.tissue, m.tip_radius, m.mass);
  EXPECT_EQ(wb.loop()->surface().vertex_material(0), uniform);
  EXPECT_EQ(wb.materials().at(0), uniform);
  // Undo: the scenario's map again, vertex by vertex.
  wb.restore_tissue_map();
  EXPECT_TRUE(wb.tissue_map_in_force());
  EXPECT_EQ(wb.material().tissue, sc.scenario.tissues[sc.base]);
  ASSERT_TRUE(wait_for(wb, [&] { return wb.settled(); }));
  for (Index i = 0; i < sc.organ.mesh->vertex_count(); i += 53)
    ASSERT_EQ(wb.loop()->surface().vertex_material(i), map_material(*sc.materials, i)) << "vertex " << i;
}

TEST(WorkbenchScenario, AMouseProbeOnABreathingOrganIsFedTipsThatMoveWithThePhase) {
  Workbench wb;
  const int id = wb.add_probe();
  wb.open_scenario(shipped("abdomen_aorta.json"));
  const auto field = wb.field();
  ASSERT_TRUE(field && field->breathing.enabled);
  // The vertex whose normal is most nearly +z (the belly), pressed 4 mm.
  const auto& mesh = *wb.organ().mesh;
  Index top = 0;
  for (Index i = 0; i < mesh.vertex_count(); ++i)
    if (mesh.normals[i].z() > mesh.normals[top].z() + 1e-12 ||
        (mesh.normals[i].z() >= mesh.normals[top].z() - 1e-12 && mesh.positions[i].z() > mesh.positions[top].z()))
      top = i;
  const Vec3 anchor = mesh.positions[top], normal = mesh.normals[top].normalized();
  const double depth = 0.004;
  wb.place(id, anchor, normal, depth);
  const Vec3 organ_tip = anchor - depth * normal;
  // Over about 1.5 s of breathing (14 per minute) the tips fed follow the organ.
  double lo_b = 1, hi_b = 0, lo_z = 1e9, hi_z = -1e9, lo_loop = 1e9, hi_loop = -1e9;
  int samples = 0, in_contact = 0;
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(1500);
  while (std::chrono::steady_clock::now() < end) {
    wb.update();
    const Probe& p = *wb.probe(id);
    const double t = wb.loop_time();
    // What is fed is the organ point where breathing has it at the loop's time.
    ASSERT_LT((p.tip - field->to_world(organ_tip, t)).norm(), 1e-12) << "t " << t;
    const double b = field->breathing_value(t);
    lo_b = std::min(lo_b, b), hi_b = std::max(hi_b, b);
    lo_z = std::min(lo_z, p.tip.z()), hi_z = std::max(hi_z, p.tip.z());
    // The loop reads it: its world position of the probe moves too.
    const haptics::LoopView v = wb.view();
    if (p.slot < v.probe_count && v.tick > 0) {
      const double z = haptics::to_vec(v.probes[p.slot].world).z();
      lo_loop = std::min(lo_loop, z), hi_loop = std::max(hi_loop, z);
      in_contact += p.output.in_contact;
    }
    ++samples;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_GT(samples, 10);
  // The breathing translation is along z: the tips moved by b's range times it.
  const double expected = (hi_b - lo_b) * field->breathing.translation.z();
  ASSERT_GT(expected, 1e-3) << "the phase hardly moved in 1.5 s";
  EXPECT_NEAR(hi_z - lo_z, expected, 1e-9);
  EXPECT_GT(hi_loop - lo_loop, 0.8 * expected) << "the loop did not see the probe move with the organ";
  // Carried with the organ, the pressed probe stays in contact.
  EXPECT_GT(in_contact, samples / 2);
}

// The scenario's vertex whose normal is most nearly +z (the top of the organ).
Index top_vertex(const mesh::SurfaceMesh& mesh) {
  Index top = 0;
  for (Index i = 0; i < mesh.vertex_count(); ++i)
    if (mesh.normals[i].z() > mesh.normals[top].z()) top = i;
  return top;
}

TEST(WorkbenchScenario, AnEditAddsALesionToTheRunningLoopAndTheProbeFeelsIt) {
  Workbench wb;
  const int id = wb.add_probe();
  wb.open_scenario(shipped("breast_two_nodules.json"));
  const haptics::HapticLoop* loop = wb.loop();
  const auto& mesh = *wb.organ().mesh;
  const Index top = top_vertex(mesh);
  wb.place(id, mesh.positions[top], mesh.normals[top].normalized(), 0.004);
  const Probe& p = *wb.probe(id);
  // The held probe's force, once it has settled (many ticks after contact).
  ASSERT_TRUE(wait_for(wb, [&] { return p.output.in_contact; }));
  std::uint64_t from = wb.loop()->ticks();
  ASSERT_TRUE(wait_for(wb, [&] { return wb.loop()->ticks() > from + 500; }));
  const double before = p.output.force.norm();
  ASSERT_GT(before, 0.01);
  const std::size_t lesions = wb.scenario()->lesions.size();

  // A stiff lesion under the probe: the tip (4 mm deep) is inside it.
  scenario::Scenario edited = wb.scenario()->scenario;
  scenario::LesionSpec spec;
  spec.lesion.name = "added";
  spec.lesion.semi_axes = Vec3::Constant(0.006);
  spec.lesion.modulus_ratio = 6;
  spec.from_surface = true;
  spec.surface_point = mesh.positions[top];
  spec.depth = 0.008;
  edited.lesions.push_back(spec);
  from = wb.loop()->ticks();
  wb.edit_scenario(edited);
  EXPECT_EQ(wb.loop(), loop) << "an edit, not a new loop";
  ASSERT_EQ(wb.scenario()->lesions.size(), lesions + 1);
  EXPECT_EQ(wb.scenario()->lesions.back().name, "added");
  EXPECT_EQ(wb.scenario()->scenario, edited);
  EXPECT_EQ(wb.field()->lesion_count, lesions + 1);
  EXPECT_TRUE(wb.tissue_map_in_force());
  EXPECT_TRUE(wb.probe(id)->placed);
  // The loop goes on and the probe feels the lesion: contrast
  // (rho - 1) a^2 / (a^2 + R d) = 5 * 36 / 68, about 2.6 times the tissue's force more.
  EXPECT_TRUE(wait_for(wb, [&] { return wb.settled() && p.output.force.norm() > 1.8 * before; }))
      << "before " << before << " N, now " << p.output.force.norm() << " N";
  EXPECT_GT(wb.loop()->ticks(), from);
  EXPECT_TRUE(wb.loop()->running());

  // A bad edit (a lesion of radius 0) is refused and changes nothing.
  const scenario::Resolved* sc = wb.scenario();
  const auto field = wb.field();
  scenario::Scenario bad = edited;
  bad.lesions.back().lesion.semi_axes = Vec3(0.006, 0, 0.006);
  EXPECT_THROW(wb.edit_scenario(bad), scenario::ScenarioError);
  EXPECT_EQ(wb.scenario(), sc);
  EXPECT_EQ(wb.field(), field);
  EXPECT_EQ(wb.loop(), loop);
  EXPECT_TRUE(wb.settled());
  // Another organ is a new scenario, not an edit.
  scenario::Scenario other = edited;
  other.organ.path = "default";
  EXPECT_THROW(wb.edit_scenario(other), std::invalid_argument);
  EXPECT_EQ(wb.scenario(), sc);
  // Removing the lesion again: the force returns to what it was.
  scenario::Scenario removed = wb.scenario()->scenario;
  removed.lesions.pop_back();
  wb.edit_scenario(removed);
  EXPECT_EQ(wb.scenario()->lesions.size(), lesions);
  EXPECT_TRUE(wait_for(wb, [&] { return wb.settled() && std::abs(p.output.force.norm() - before) < 0.1 * before; }))
      << "before " << before << " N, now " << p.output.force.norm() << " N";
  EXPECT_EQ(wb.loop(), loop);
}

TEST(WorkbenchScenario, ARecordingGoesOnThroughAnEditAndReplaysIt) {
  const auto dir = palpa::test::temp_dir("workbench_edit_recording");
  const auto file = dir / "edited.palpa";
  std::filesystem::remove(file);
  Workbench wb;
  const int id = wb.add_probe();
  wb.open_scenario(shipped("breast_two_nodules.json"));
  const auto& mesh = *wb.organ().mesh;
  const Index top = top_vertex(mesh);
  wb.place(id, mesh.positions[top], mesh.normals[top].normalized(), 0.004);
  const Probe& p = *wb.probe(id);
  ASSERT_TRUE(wait_for(wb, [&] { return p.output.in_contact; }));
  wb.start_recording(file, "editor");
  std::uint64_t from = wb.loop()->ticks();
  ASSERT_TRUE(wait_for(wb, [&] { return wb.loop()->ticks() > from + 300; }));
  const double before = p.output.force.norm();
  scenario::Scenario edited = wb.scenario()->scenario;
  scenario::LesionSpec spec;
  spec.lesion.semi_axes = Vec3::Constant(0.006);
  spec.lesion.modulus_ratio = 6;
  spec.from_surface = true;
  spec.surface_point = mesh.positions[top];
  spec.depth = 0.008;
  edited.lesions.push_back(spec);
  wb.edit_scenario(edited);
  EXPECT_TRUE(wb.recording()) << "the recording goes on";
  ASSERT_TRUE(wait_for(wb, [&] { return wb.settled() && p.output.force.norm() > 1.8 * before; }));
  from = wb.loop()->ticks();
  ASSERT_TRUE(wait_for(wb, [&] { return wb.loop()->ticks() > from + 100; }));
  wb.stop_recording();

  // The file holds the SetTissue command and replays it: the probe's force
  // (re-simulated from the file alone) rises at that tick.
  const app::LoadedSession s = app::load_session(file.string());
  std::uint64_t edit_tick = 0;
  for (const auto& c : s.commands)
    if (c.command.kind == haptics::LoopCommandKind::SetTissue) edit_tick = c.tick;
  ASSERT_GT(edit_tick, s.first_tick) << "a SetTissue command in the recording";
  double replayed_before = 0, replayed_after = 0;
  app::ForceCheck check;
  app::replay_session(s, 0, ~std::uint64_t{0},
                      [&](const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> r, const auto&) {
                        if (t.tick + 1 == edit_tick) replayed_before = r[p.slot].normal_reaction;
                        if (t.tick == edit_tick + 50) replayed_after = r[p.slot].normal_reaction;
                      },
                      check);
  EXPECT_EQ(check.ticks, s.file.header().ticks);
  EXPECT_TRUE(check.identical) << app::describe(check);
  EXPECT_GT(replayed_before, 0.01);
  EXPECT_GT(replayed_after, 1.8 * replayed_before);

  // A recording started after the edit names the scenario as it runs (its
  // lesions are what an assessment grades) and starts from the tissue in force.
  const auto later = dir / "after_edit.palpa";
  std::filesystem::remove(later);
  wb.start_recording(later, "editor");
  from = wb.loop()->ticks();
  ASSERT_TRUE(wait_for(wb, [&] { return wb.loop()->ticks() > from + 200; }));
  wb.stop_recording();
  const app::LoadedSession t = app::load_session(later.string());
  EXPECT_EQ(t.lesions.size(), wb.scenario()->lesions.size());
  EXPECT_EQ(t.model->field->lesion_count, wb.scenario()->lesions.size());
  double replayed = 0;
  app::ForceCheck again;
  app::replay_session(t, 0, ~std::uint64_t{0},
                      [&](const haptics::TickRecord&, std::span<const haptics::ProbeTickResult> r, const auto&) {
                        replayed = r[p.slot].normal_reaction;
                      },
                      again);
  EXPECT_TRUE(again.identical) << app::describe(again);
  EXPECT_GT(replayed, 1.8 * replayed_before) << "the lesion is felt in the replay";
}

// A loop warning that comes on while recording is written as an event of the
// session: here the haptic thread was told not to ask for real-time
// priority (PALPA_REALTIME=off), so the loop warns of it from its start.
TEST(WorkbenchScenario, ARecordingKeepsTheLoopsWarningsAsEvents) {
  const auto dir = palpa::test::temp_dir("workbench_warning_events");
  const auto file = dir / "warned.palpa";
  std::filesystem::remove(file);
  setenv("PALPA_REALTIME", "off", 1);
  struct Unset {
    ~Unset() { unsetenv("PALPA_REALTIME"); }
  } unset;
  Workbench wb;
  wb.add_probe();
  wb.open_scenario(shipped("breast_two_nodules.json"));
  ASSERT_TRUE(wait_for(wb, [&] { return (wb.view().warnings & haptics::kWarnNoRealtime) != 0; }))
      << "the loop does not warn that it runs without real-time priority";
  wb.start_recording(file, "trainee");
  const std::uint64_t from = wb.loop()->ticks();
  ASSERT_TRUE(wait_for(wb, [&] { return wb.loop()->ticks() > from + 200; }));
  wb.stop_recording();

  const app::LoadedSession s = app::load_session(file.string());
  // (Other warnings, a missed deadline on a loaded machine, may come too.)
  std::vector<record::EventRecord> warnings;
  for (const auto& e : s.file.events())
    if (e.kind == record::EventKind::Warning && (static_cast<std::uint32_t>(e.value) & haptics::kWarnNoRealtime))
      warnings.push_back(e);
  ASSERT_EQ(warnings.size(), 1u) << "one event: the warning came on once and never went off";
  const record::EventRecord& w = warnings[0];
  EXPECT_NE(std::string(w.text).find("without real-time priority"), std::string::npos) << w.text;
  EXPECT_GE(w.tick, s.first_tick);
  EXPECT_LT(w.tick, s.first_tick + s.file.header().ticks) << "the event lies within the recorded ticks";
}

// The running loop is snapshot only where a recording starts; once it
// stops, a background replay of the file adds a snapshot every interval, and
// a seek from the latest replays the rest of the recording bit-identically.
TEST(WorkbenchScenario, AStoppedRecordingGetsSeekSnapshots) {
  const auto dir = palpa::test::temp_dir("workbench_seek_snapshots");
  const auto file = dir / "seek.palpa";
  std::filesystem::remove(file);
  Workbench wb;
  EXPECT_THROW(wb.set_seek_snapshot_interval(-1), std::invalid_argument);
  wb.set_seek_snapshot_interval(0.3);
  const int id = wb.add_probe();
  wb.open_scenario(shipped("breast_two_nodules.json"));
  const auto& mesh = *wb.organ().mesh;
  const Index top = top_vertex(mesh);
  wb.place(id, mesh.positions[top], mesh.normals[top].normalized(), 0.004);
  ASSERT_TRUE(wait_for(wb, [&] { return wb.probe(id)->output.in_contact; }));
  wb.start_recording(file, "trainee");
  const std::uint64_t from = wb.loop()->ticks();
  ASSERT_TRUE(wait_for(wb, [&] { return wb.loop()->ticks() > from + 1300; }));
  const std::size_t at_start = app::load_session(file.string()).file.snapshots().size();
  wb.stop_recording();
  ASSERT_TRUE(wait_for(wb, [&] { return !wb.adding_seek_snapshots(); }, 60)) << "the pass did not end";

  const app::LoadedSession s = app::load_session(file.string());
  const auto snaps = s.file.snapshots();
  EXPECT_EQ(at_start, 1u) << "a recording of the running loop starts with one snapshot";
  ASSERT_GE(snaps.size(), at_start + 3) << "1.3 s at one per 0.3 s";
  const std::uint64_t end = s.first_tick + s.file.header().ticks;
  const std::uint64_t latest = snaps.back().tick;
  EXPECT_GT(latest, s.first_tick + 900);
  app::ForceCheck check;
  app::replay_session(s, latest, end, nullptr, check);
  EXPECT_EQ(check.ticks, end - latest) << "replayed from the snapshot at tick " << latest;
  EXPECT_TRUE(check.identical) << app::describe(check);
}

TEST(WorkbenchScenario, EditingWithoutAScenarioIsALogicError) {
  Workbench wb;
  EXPECT_THROW(wb.edit_scenario(scenario::Scenario{}), std::logic_error);
  wb.set_organ(sphere_organ());
  EXPECT_THROW(wb.edit_scenario(scenario::Scenario{}), std::logic_error);
}

}  // namespace
}  // namespace palpa::app
