// The drawn displacement limit: a press far deeper than a thin part is
// thick draws a dent no deeper than the limit, so the surface never passes
// through its other side, while the contact keeps its depth (the force on
// the probe is not limited). Closed forms on a flattened sphere (an
// ellipsoid with semi-axes R, R, c).

#include "deform/surface.h"

#include "mesh/generate.h"
#include "mesh/thickness.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

namespace palpa::deform {
namespace {

constexpr double kR = 0.05, kC = 0.005;  // m: a 10 mm thick disc-like organ 100 mm across

std::shared_ptr<const mesh::SurfaceMesh> flat_ellipsoid() {
  mesh::SurfaceMesh m = mesh::make_sphere(20000, kR);
  for (Vec3& p : m.positions) p.z() *= kC / kR;
  mesh::finalize(m);
  return std::make_shared<const mesh::SurfaceMesh>(std::move(m));
}

Index top_vertex(const mesh::SurfaceMesh& m) {
  Index top = 0;
  for (Index i = 0; i < m.vertex_count(); ++i)
    if (m.positions[i].z() > m.positions[top].z()) top = i;
  return top;
}

Material linear(double k = 200) {
  Material m;
  m.model = LocalModelKind::Linear;
  m.stiffness = k;
  m.damping = 2;
  m.mass = 1e-3;
  return m;
}

// A press `depth` (m) at the top pole with the workbench's 25 mm Wendland
// shape, stepped to rest (0.5 s at 1 kHz).
Contact top_press(const mesh::SurfaceMesh& m, double depth) {
  Contact c;
  c.vertex = top_vertex(m);
  c.point = m.positions[c.vertex];
  c.normal = m.normals[c.vertex];
  c.depth = depth;
  c.shape = ShapeFunction{ShapeKind::Wendland, 0.025};
  return c;
}

void settle(DeformableSurface& s, int steps = 500) {
  for (int k = 0; k < steps; ++k) s.step(1e-3);
}

TEST(DrawnLimit, IsTheThicknessAndCurvatureBound) {
  const auto m = flat_ellipsoid();
  const auto limits = drawn_displacement_limits(*m, 0.4, 0.8);
  const auto t = mesh::inward_thickness(*m);
  const auto r = mesh::convex_radius(*m);
  for (std::size_t i = 0; i < limits.size(); ++i) EXPECT_EQ(limits[i], std::min(0.4 * t[i], 0.8 * r[i]));
  // At the pole: 0.4 of the 2c thickness (the curvature radius there, R^2/c, is far larger).
  EXPECT_NEAR(limits[top_vertex(*m)], 0.4 * 2 * kC, 0.01 * kC);
  // An open flat patch is not limited.
  for (double l : drawn_displacement_limits(mesh::make_plane(5, 5, 0.01))) EXPECT_TRUE(std::isinf(l));
}

TEST(DrawnLimit, DeepPressOnAThinPartDoesNotDrawThroughItsOtherSide) {
  // 30 mm into a 10 mm thick part. Every vertex of the top side must stay
  // above the bottom side (z = -z0 below a top vertex at z0, by symmetry).
  const auto m = flat_ellipsoid();
  DeformableSurface limited(m, MaterialArrays::uniform(m->vertex_count(), linear()));
  SurfaceOptions off;
  off.limit_drawn_displacement = false;
  DeformableSurface unlimited(m, MaterialArrays::uniform(m->vertex_count(), linear()), off);
  const Contact c = top_press(*m, 0.03);
  limited.set_contacts(std::span(&c, 1));
  unlimited.set_contacts(std::span(&c, 1));
  settle(limited);
  settle(unlimited);

  int through_limited = 0, through_unlimited = 0;
  const auto stream = limited.stream();
  for (Index i = 0; i < m->vertex_count(); ++i) {
    const Vec3& p = m->positions[i];
    if (p.z() <= 0) continue;
    through_limited += limited.deformed_position(i).z() <= -p.z();
    through_unlimited += unlimited.deformed_position(i).z() <= -p.z();
    // The stream draws the limited height; the state keeps the physics.
    EXPECT_LE(std::abs(limited.drawn_height(i)), limited.drawn_limit(i));
    EXPECT_EQ(stream[4 * i + 3], static_cast<float>(limited.drawn_height(i)));
  }
  EXPECT_EQ(through_limited, 0);
  EXPECT_GT(through_unlimited, 10);  // the check can fail: without the limit the dent goes through
  // The dent reaches the limit at the pole; the contact keeps its full depth.
  const Index top = top_vertex(*m);
  EXPECT_NEAR(limited.drawn_height(top), -limited.drawn_limit(top), 1e-3 * kC);
  EXPECT_EQ(limited.contacts()[0].depth, 0.03);
  EXPECT_NEAR(unlimited.drawn_height(top), -0.03, 1e-4);
}

TEST(DrawnLimit, NoDrawnTriangleTurnsOver) {
  // A press 3 times deeper than the curvature radius of a small sphere: no
  // drawn triangle may face the other way (a back face, a black hole in the
  // picture). Without the limit some do.
  const double radius = 0.012;
  const auto m = std::make_shared<const mesh::SurfaceMesh>(mesh::make_sphere(6000, radius));
  auto flipped = [&](const DeformableSurface& s) {
    int n = 0;
    for (const auto& t : m->triangles) {
      const Vec3 a = s.deformed_position(t[0]), b = s.deformed_position(t[1]), c = s.deformed_position(t[2]);
      const Vec3 a0 = m->positions[t[0]], b0 = m->positions[t[1]], c0 = m->positions[t[2]];
      n += (b - a).cross(c - a).dot((b0 - a0).cross(c0 - a0)) <= 0;
    }
    return n;
  };
  SurfaceOptions off;
  off.limit_drawn_displacement = false;
  for (bool limit : {true, false}) {
    DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), linear()), limit ? SurfaceOptions{} : off);
    const Contact c = top_press(*m, 3 * radius);
    s.set_contacts(std::span(&c, 1));
    settle(s);
    if (limit)
      EXPECT_EQ(flipped(s), 0);
    else
      EXPECT_GT(flipped(s), 0);
  }
}

TEST(DrawnLimit, ActiveStepEqualsFullStepWhereTheLimitBinds) {
  const auto m = flat_ellipsoid();
  DeformableSurface a(m, MaterialArrays::uniform(m->vertex_count(), linear(500)));
  DeformableSurface b(m, MaterialArrays::uniform(m->vertex_count(), linear(500)));
  for (int n = 0; n < 300; ++n) {
    // Pressing in to 30 mm and out again.
    const Contact c = top_press(*m, 0.03 * std::sin(M_PI * n / 200.0));
    a.set_contacts(std::span(&c, n < 200 ? 1 : 0));
    b.set_contacts(std::span(&c, n < 200 ? 1 : 0));
    a.step(1e-3);
    b.step_full(1e-3);
    ASSERT_EQ(std::memcmp(a.stream().data(), b.stream().data(), a.stream().size_bytes()), 0) << n;
    ASSERT_EQ(std::memcmp(a.state().vertices.data(), b.state().vertices.data(),
                          a.state().vertices.size() * sizeof(VertexState)),
              0)
        << n;
  }
}

TEST(DrawnLimit, SharedLimitsAreUsedAndChecked) {
  const auto m = flat_ellipsoid();
  {
    // Two surfaces of one mesh object cast the rays once; other fractions
    // or another mesh object get their own.
    DeformableSurface a(m, MaterialArrays::uniform(m->vertex_count(), linear()));
    DeformableSurface b(m, MaterialArrays::uniform(m->vertex_count(), linear()));
    EXPECT_EQ(a.drawn_limits(), b.drawn_limits());
    SurfaceOptions other;
    other.curvature_fraction = 0.2;
    DeformableSurface c(m, MaterialArrays::uniform(m->vertex_count(), linear()), other);
    EXPECT_NE(c.drawn_limits(), a.drawn_limits());
    const auto copy = std::make_shared<const mesh::SurfaceMesh>(*m);
    DeformableSurface d(copy, MaterialArrays::uniform(m->vertex_count(), linear()));
    EXPECT_NE(d.drawn_limits(), a.drawn_limits());
    EXPECT_EQ(*d.drawn_limits(), *a.drawn_limits());
  }
  SurfaceOptions o;
  o.drawn_limits = std::make_shared<const std::vector<double>>(m->vertex_count(), 0.001);
  DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), linear()), o);
  EXPECT_EQ(s.drawn_limit(0), 0.001);
  o.drawn_limits = std::make_shared<const std::vector<double>>(3, 0.001);
  EXPECT_THROW(DeformableSurface(m, MaterialArrays::uniform(m->vertex_count(), linear()), o),
               std::invalid_argument);
  SurfaceOptions bad;
  bad.thickness_fraction = 0.5;
  EXPECT_THROW(DeformableSurface(m, MaterialArrays::uniform(m->vertex_count(), linear()), bad),
               std::invalid_argument);
}

TEST(DrawnLimit, FieldsStayOffTheFarSideOfAThinPart) {
  // The 25 mm support reaches around the 5 mm rim of the thin part to its
  // bottom side; vertices facing away from the contact normal get no field.
  const auto m = flat_ellipsoid();
  DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), linear()));
  Contact c = top_press(*m, 0.002);
  c.shape.radius = 0.012;
  // At the rim, x = R - 1 mm, on the top side.
  Index rim = 0;
  for (Index i = 0; i < m->vertex_count(); ++i) {
    const Vec3& p = m->positions[i];
    if (p.z() > 0 && std::abs(p.y()) < 0.002 &&
        std::abs(p.x() - (kR - 0.001)) < std::abs(m->positions[rim].x() - (kR - 0.001)))
      rim = i;
  }
  c.vertex = rim;
  c.point = m->positions[rim];
  c.normal = m->normals[rim];
  auto count = [&](DeformableSurface& s, int& far_side, int& near_side) {
    s.set_contacts(std::span(&c, 1));
    s.step(1e-3);
    far_side = near_side = 0;
    for (Index i = 0; i < m->vertex_count(); ++i) {
      if (s.field_force(i) == 0) continue;
      (m->normals[i].dot(c.normal) < 0 ? far_side : near_side)++;
    }
  };
  int far_side = 0, near_side = 0;
  count(s, far_side, near_side);
  EXPECT_EQ(far_side, 0);
  EXPECT_GT(near_side, 10);
  // With the normal test off (cosine -1) the field does reach the far side.
  SurfaceOptions all;
  all.min_normal_cosine = -1;
  DeformableSurface t(m, MaterialArrays::uniform(m->vertex_count(), linear()), all);
  count(t, far_side, near_side);
  EXPECT_GT(far_side, 10);
}

}  // namespace
}  // namespace palpa::deform
