// The workbench's model, driven by the real-time haptic loop, against closed
// forms: a probe held in a linear material feels k d (eq. 1 at rest, eq. 4
// without sliding); probes are devices (mouse probes fed by the host, a
// scripted device replaying a file), a device that cannot start changes
// nothing; depth limits, material changes and reset behave as the window
// relies on. The loop runs on its own threads, so the tests wait for
// conditions with a timeout (never for wall-time figures).

#include "app/gui/workbench.h"

#include "common/test_support.h"
#include "mesh/generate.h"

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

}  // namespace
}  // namespace palpa::app
