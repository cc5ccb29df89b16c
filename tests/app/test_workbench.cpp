// The workbench's model against closed forms: a probe held in a linear
// material feels k d (eq. 1 at rest, eq. 4 without sliding); probes, depth
// limits, material changes and reset behave as the window relies on.

#include "app/gui/workbench.h"

#include "common/test_support.h"
#include "mesh/generate.h"

namespace palpa::app {
namespace {

render::Organ sphere_organ() {
  render::Organ o;
  o.name = "sphere";
  auto m = std::make_shared<mesh::SurfaceMesh>(mesh::make_sphere(8000, 0.05));
  // Exactly radial normals, so the virtual vertex is exactly under the probe.
  for (std::size_t i = 0; i < m->vertex_count(); ++i) m->normals[i] = m->positions[i].normalized();
  o.mesh = m;
  o.facts = mesh::analyse(*m);
  return o;
}

TEST(Workbench, AHeldProbeFeelsStiffnessTimesDepth) {
  Workbench wb;
  MaterialSettings mat;
  mat.stiffness = 300;
  wb.set_material(mat);
  wb.set_organ(sphere_organ());
  const int id = wb.add_probe();
  wb.place(id, Vec3(0, 0, 0.05), Vec3::UnitZ(), 0.004);
  for (int i = 0; i < 1000; ++i) wb.tick(1e-3);
  const Probe& p = *wb.probe(id);
  ASSERT_TRUE(p.output.in_contact);
  // At rest the local model under the probe holds h = -d: F = k d along +n.
  EXPECT_NEAR(p.output.force.z(), 300 * 0.004, 0.05 * 300 * 0.004);
  EXPECT_NEAR(p.output.force.head<2>().norm(), 0.0, 1e-3);
  EXPECT_NEAR(wb.time(), 1.0, 1e-9);
}

TEST(Workbench, SeveralProbesPressAtOnceAndRemovingOneReleasesIt) {
  Workbench wb;
  wb.set_organ(sphere_organ());
  const int a = wb.add_probe();
  const int b = wb.add_probe();
  EXPECT_EQ(wb.selected_id(), b);
  wb.place(a, Vec3(0, 0, 0.05), Vec3::UnitZ(), 0.003);
  wb.place(b, Vec3(0, 0, -0.05), -Vec3::UnitZ(), 0.003);
  for (int i = 0; i < 200; ++i) wb.tick(1e-3);
  EXPECT_TRUE(wb.probe(a)->output.in_contact);
  EXPECT_TRUE(wb.probe(b)->output.in_contact);
  EXPECT_EQ(wb.surface().contacts().size(), 2u);
  wb.remove_probe(b);
  EXPECT_EQ(wb.selected_id(), a);
  wb.tick(1e-3);
  EXPECT_EQ(wb.surface().contacts().size(), 1u);
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
  wb.set_material(m);
  EXPECT_EQ(wb.surface().materials().stiffness.front(), 1234);
  EXPECT_EQ(wb.surface().materials().stiffness.back(), 1234);
  EXPECT_EQ(wb.surface().materials().model.front(), deform::LocalModelKind::Exponential);
}

TEST(Workbench, ResetLiftsEveryProbeAndRestsTheSurface) {
  Workbench wb;
  wb.set_organ(sphere_organ());
  const int id = wb.add_probe();
  wb.place(id, Vec3(0, 0, 0.05), Vec3::UnitZ(), 0.004);
  for (int i = 0; i < 100; ++i) wb.tick(1e-3);
  ASSERT_GT(wb.surface().active_count(), 0u);
  wb.reset();
  EXPECT_EQ(wb.probe(id)->depth, 0.0);
  for (const auto& v : wb.surface().state().vertices) ASSERT_EQ(v.h, 0.0);
  wb.tick(1e-3);
  EXPECT_TRUE(wb.surface().contacts().empty());
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

}  // namespace
}  // namespace palpa::app
