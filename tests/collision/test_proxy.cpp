// The god-object proxy of track_contact and the surface slide under it,
// against closed forms: on a plane the slide is the tangential motion, it
// stops at a border, and on a sphere with radial normals it stays on the
// surface; a press past the focal distance keeps its contact point (depth =
// press distance), a press through a small sphere never moves the contact to
// its other side (where query_contact alone lets go), and the
// walk takes over again once the probe is back within its range, also after
// the proxy was left behind by a deep press that slid; without motion the
// slide keeps the virtual vertex it starts from, and a proxy held in its
// cone answers as that slide does, bit for bit; a cursor in contact asked on
// a mesh without its normals gives no triangle (and reads none).

#include "collision/contact.h"
#include "common/test_support.h"
#include "mesh/generate.h"
#include "radial_sphere.h"

#include <Eigen/Geometry>

#include <cmath>
#include <cstring>
#include <random>

namespace palpa::collision {
namespace {

Vec3 point_of(const mesh::SurfaceMesh& m, const SurfacePoint& sp) {
  const auto& t = m.triangles[sp.triangle];
  return sp.barycentric[0] * m.positions[t[0]] + sp.barycentric[1] * m.positions[t[1]] +
         sp.barycentric[2] * m.positions[t[2]];
}

// The triangle of the plane containing the point p (z = 0), and its weights.
SurfacePoint on_plane(const mesh::SurfaceMesh& m, const Vec3& p) {
  for (Index t = 0; t < m.triangle_count(); ++t) {
    Vec3 b;
    const auto& tri = m.triangles[t];
    const Vec3 a = m.positions[tri[0]], e1 = m.positions[tri[1]] - a, e2 = m.positions[tri[2]] - a;
    const double det = e1.x() * e2.y() - e1.y() * e2.x();
    const Vec3 d = p - a;
    const double u = (d.x() * e2.y() - d.y() * e2.x()) / det, v = (e1.x() * d.y() - e1.y() * d.x()) / det;
    if (u >= 0 && v >= 0 && u + v <= 1) {
      SurfacePoint sp;
      sp.triangle = t;
      sp.barycentric = Vec3(1 - u - v, u, v);
      return sp;
    }
  }
  return {};
}

TEST(Slide, OnAPlaneIsTheTangentialMotionAndStopsAtTheBorder) {
  const auto m = mesh::make_plane(21, 21, 0.001);  // 20 mm square, 1 mm cells, z = 0
  const SurfacePoint start = on_plane(m, Vec3(0.0013, -0.0021, 0));
  ASSERT_NE(start.triangle, kNoIndex);
  // 4 mm across, 3 mm along the normal (ignored): crosses several edges.
  const Vec3 probe(0.0053, -0.0021, -0.003);
  SurfacePoint sp = slide_surface_point(m, start.triangle, start.barycentric, Vec3(0.004, 0, -0.003), probe);
  ASSERT_NE(sp.triangle, kNoIndex);
  EXPECT_TRUE(sp.inside);
  EXPECT_LE((sp.point - Vec3(0.0053, -0.0021, 0)).norm(), 1e-15);
  EXPECT_LE((point_of(m, sp) - sp.point).norm(), 1e-18);
  EXPECT_NEAR(sp.offset, -0.003, 1e-15);
  EXPECT_NEAR(sp.barycentric.sum(), 1.0, 1e-15);
  // Diagonal motion past the border x = 10 mm stops on the border edge.
  sp = slide_surface_point(m, start.triangle, start.barycentric, Vec3(0.02, 0.004, 0), probe);
  ASSERT_NE(sp.triangle, kNoIndex);
  EXPECT_NEAR(sp.point.x(), 0.01, 1e-15);
  EXPECT_LE(sp.point.y(), 0.01);
  // Bad input.
  EXPECT_EQ(slide_surface_point(m, kNoIndex, start.barycentric, Vec3::Zero(), probe).triangle, kNoIndex);
  EXPECT_EQ(slide_surface_point(m, start.triangle, start.barycentric, Vec3(NAN, 0, 0), probe).triangle, kNoIndex);
  // Weights that are not weights are taken as the centroid.
  sp = slide_surface_point(m, start.triangle, Vec3(2, -1, 0), Vec3::Zero(), probe);
  EXPECT_LE((sp.barycentric - Vec3::Constant(1.0 / 3)).norm(), 1e-15);
}

TEST(Slide, AtASharpCreaseStopsOnTheEdgeOnTheSideItCameFrom) {
  // A valley: the quad P0 P1 P2 P3 rising at slope 2 towards -x (split into
  // A = P0 P1 P2 and A0 = P0 P2 P3 along its diagonal) and the triangle
  // B = P1 P0 Q rising at slope 2 towards +x, meeting A along the edge
  // x = 0, z = 0 (53 degrees between the planes). Motion down the slope carries
  // the point from A0 across the diagonal into A and down to the edge; in
  // B's plane what is left of it points back down to the edge (the slopes
  // exceed 1), and in A's again: the point cannot move on, so it stays on
  // the edge, on A's side. (Without the stop it crossed back and forth until
  // kMaxSlideSteps, and the 64th crossing left it on B's side.)
  mesh::SurfaceMesh m;
  m.positions = {Vec3(0, -1, 0), Vec3(0, 1, 0), Vec3(-1, 1, 2), Vec3(-1, -1, 2), Vec3(1, 0, 2)};
  m.triangles = {{0, 1, 2}, {0, 2, 3}, {1, 0, 4}};  // A, A0, B
  mesh::finalize(m);
  ASSERT_EQ(m.triangle_neighbors.size(), 3u);
  // The point of A0 at (-0.8, -0.5, 1.6).
  const Vec3 b(0.2, 0.25, 0.55);
  const Vec3 start = 0.2 * m.positions[0] + 0.25 * m.positions[2] + 0.55 * m.positions[3];
  ASSERT_LE((start - Vec3(-0.8, -0.5, 1.6)).norm(), 1e-15);
  // Down A0's slope, 1 along x (the point's normal is tilted a little
  // towards B by the normal shared at P0, so the motion is slightly shorter).
  const SurfacePoint sp = slide_surface_point(m, 1, b, Vec3(1, 0, -2), start);
  ASSERT_EQ(sp.triangle, 0u);
  EXPECT_EQ(sp.barycentric[2], 0.0);  // A's corner P2, off the edge
  EXPECT_NEAR(sp.point.x(), 0.0, 1e-15);
  EXPECT_NEAR(sp.point.z(), 0.0, 1e-15);
  EXPECT_GT(sp.point.y(), -1.0);
  EXPECT_LT(sp.point.y(), 1.0);
  EXPECT_NEAR(sp.barycentric.sum(), 1.0, 1e-15);
}

TEST(Slide, OnASphereStaysOnTheSurfaceAndIgnoresNormalMotion) {
  const double r = 0.05;
  auto m = test::radial_sphere(20000, r);
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  for (int k = 0; k < 200; ++k) {
    const Index t = static_cast<Index>(rng() % m.triangle_count());
    const Vec3 b(0.2, 0.3, 0.5);
    const auto& tri = m.triangles[t];
    const Vec3 p = b[0] * m.positions[tri[0]] + b[1] * m.positions[tri[1]] + b[2] * m.positions[tri[2]];
    const Vec3 n = (b[0] * m.normals[tri[0]] + b[1] * m.normals[tri[1]] + b[2] * m.normals[tri[2]]).normalized();
    // Along the interpolated normal only: the point does not move.
    SurfacePoint sp = slide_surface_point(m, t, b, -0.03 * n, p - 0.03 * n);
    EXPECT_EQ(sp.triangle, t);
    EXPECT_LE((sp.point - p).norm(), 1e-15);
    EXPECT_NEAR(sp.offset, -0.03, 1e-15);
    // Any motion: the point stays on a triangle of the sphere (within its sagitta) and moved
    // about as far as the motion's tangential part (the facets bend it).
    const Vec3 d = 0.01 * Vec3(g(rng), g(rng), g(rng));
    sp = slide_surface_point(m, t, b, d, p);
    ASSERT_NE(sp.triangle, kNoIndex);
    EXPECT_LE((point_of(m, sp) - sp.point).norm(), 1e-15);
    EXPECT_LE(sp.point.norm(), r * (1 + 1e-12));
    EXPECT_GE(sp.point.norm(), r * 0.999);
    const double tangential = (d - d.dot(n) * n).norm();
    EXPECT_NEAR((sp.point - p).norm(), tangential, 0.05 * tangential + 1e-4);
  }
}

TEST(Slide, WithoutMotionIsTheVirtualVertexItStartsFrom) {
  // No displacement (either sign of zero): the start triangle and weights,
  // the interpolated point, the interpolated unit normal and the probe's
  // offset along it (the proxy's path takes this without the slide's loop).
  const double r = 0.05;
  auto m = test::radial_sphere(20000, r);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.05, 1.0);
  std::normal_distribution<double> g;
  for (int k = 0; k < 200; ++k) {
    const Index t = static_cast<Index>(rng() % m.triangle_count());
    Vec3 b(u(rng), u(rng), u(rng));
    b /= b.sum();
    const auto& tri = m.triangles[t];
    const Vec3 p = b[0] * m.positions[tri[0]] + b[1] * m.positions[tri[1]] + b[2] * m.positions[tri[2]];
    const Vec3 n = (b[0] * m.normals[tri[0]] + b[1] * m.normals[tri[1]] + b[2] * m.normals[tri[2]]).normalized();
    const Vec3 probe = p + 0.01 * Vec3(g(rng), g(rng), g(rng));
    const Vec3 zero = k % 2 ? Vec3(-0.0, 0.0, -0.0) : Vec3::Zero();
    const SurfacePoint sp = slide_surface_point(m, t, b, zero, probe);
    ASSERT_EQ(sp.triangle, t) << k;
    EXPECT_TRUE(sp.inside);
    EXPECT_LE((sp.barycentric - b).norm(), 1e-15) << k;
    EXPECT_LE((sp.point - p).norm(), 1e-16) << k;  // about 14 units in the last place of r
    EXPECT_LE((sp.normal - n).norm(), 1e-15) << k;
    EXPECT_NEAR(sp.offset, (probe - p).dot(n), 1e-15) << k;
  }
}

TEST(Proxy, PressPastTheFocalDistanceKeepsTheContactPoint) {
  // Radial normals: the walk answers down to R/2; deeper the proxy holds,
  // the depth is the press distance all the way to 1.8 R (past the centre),
  // and on the way back the walk answers again at the same point.
  const double r = 0.05;
  auto m = test::radial_sphere(20000, r);
  const VertexTree tree(m.positions);
  const Vec3 dir = Vec3(0.3, -0.5, 0.8).normalized();
  ContactCursor cursor;
  bool in = false;
  SurfacePoint first;
  int walk = 0, proxy = 0, walk_back = 0;
  for (int k = 0; k <= 400; ++k) {
    // 0.1 mm above, down to 1.8 R, back to 0.1 R.
    const double d = k <= 300 ? -1e-4 + 1.8 * r * k / 300 : 1.8 * r - 1.7 * r * (k - 300) / 100;
    const Vec3 probe = (first.triangle == kNoIndex ? r * dir : first.point) - d * (first.triangle == kNoIndex ? dir : first.normal);
    const ContactAnswer a = track_contact(m, tree, probe, cursor, in);
    ASSERT_NE(a.surface.triangle, kNoIndex) << k;
    in = a.surface.offset < 0;
    if (k == 0) {
      first = a.surface;
      EXPECT_FALSE(in);
      continue;
    }
    ASSERT_TRUE(in) << k;
    EXPECT_LE((a.surface.point - first.point).norm(), 1e-12) << k;
    EXPECT_NEAR(-a.surface.offset, d, 1e-12) << k;
    if (k <= 300) {
      walk += a.path == ContactPath::Walk;
      proxy += a.path == ContactPath::Proxy;
      if (k == 1) {
        EXPECT_EQ(a.path, ContactPath::Tree);
      } else if (d < 0.499 * r) {
        EXPECT_EQ(a.path, ContactPath::Walk) << k << " at " << d / r << " R";
      } else if (d > 0.501 * r) {
        EXPECT_EQ(a.path, ContactPath::Proxy) << k << " at " << d / r << " R";
      }
    } else {
      walk_back += a.path == ContactPath::Walk;
    }
  }
  EXPECT_GT(walk, 50);
  EXPECT_GT(proxy, 150);
  EXPECT_GT(walk_back, 10);
}

TEST(Proxy, HeldInItsConeItIsTheSlideWithoutMotion) {
  // Pressed along the normal past half the focal distance, the probe stays in
  // the proxy's cone, so the proxy does not move: its answer is the slide's
  // without motion from the last answer, bit for bit. Where the weights sum
  // to exactly 1, track_contact builds it with the normal it computed itself
  // (the slide's shortcut), and that must give the same bits as the slide.
  const double r = 0.05;
  auto m = test::radial_sphere(20000, r);
  const VertexTree tree(m.positions);
  auto bits = [](const Vec3& a, const Vec3& b) { return std::memcmp(a.data(), b.data(), sizeof(double) * 3) == 0; };
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  int compared = 0, exact_weights = 0;
  for (int k = 0; k < 24; ++k) {
    const Vec3 dir = Vec3(g(rng), g(rng), g(rng)).normalized();
    ContactCursor cursor;
    const ContactAnswer first = track_contact(m, tree, r * dir - 1e-4 * dir, cursor, false);
    ASSERT_LT(first.surface.offset, 0) << k;
    for (int j = 1; j <= 10; ++j) {
      const double d = 0.6 * r + 0.08 * r * j;  // 0.68 R to 1.4 R, past R / 2
      const Vec3 probe = first.surface.point - d * first.surface.normal;
      const Index t = cursor.triangle;
      const Vec3 b = cursor.barycentric;
      const ContactAnswer a = track_contact(m, tree, probe, cursor, true);
      ASSERT_EQ(a.path, ContactPath::Proxy) << k << " " << j;
      const SurfacePoint expected = slide_surface_point(m, t, b, Vec3::Zero(), probe);
      EXPECT_EQ(a.surface.triangle, expected.triangle);
      EXPECT_TRUE(bits(a.surface.barycentric, expected.barycentric)) << k << " " << j;
      EXPECT_TRUE(bits(a.surface.point, expected.point)) << k << " " << j;
      EXPECT_TRUE(bits(a.surface.normal, expected.normal)) << k << " " << j;
      EXPECT_EQ(std::memcmp(&a.surface.offset, &expected.offset, sizeof(double)), 0) << k << " " << j;
      EXPECT_NEAR(-a.surface.offset, d, 1e-12);
      ++compared;
      exact_weights += bits(b / b.sum(), b);
    }
  }
  EXPECT_EQ(compared, 240);
  EXPECT_GT(exact_weights, 0);  // the shortcut was taken
}

TEST(Proxy, LeftBehindByADeepPressItRejoinsTheWalkWithoutAJump) {
  // Radial normals (the walk answers down to R/2). The probe presses 0.7 R
  // deep, slides 50 ticks there (the proxy holds in its cone, so it stays
  // behind), rises to 0.1 R while sliding on, and slides 300 more ticks
  // there, along a great circle at 30 um of surface a tick. Once the walk
  // answers again the proxy chases the foot and the walk takes over: the
  // last 100 ticks are walks, whose point is the foot (on the ray from the
  // centre through the probe, for radial normals). A proxy that stayed at
  // its cone's edge would trail the foot by 0.025 R (1.25 mm) for ever.
  // No tick moves the contact point more than kProxyChase times as far as
  // the probe moved.
  const double r = 0.05;
  auto m = test::radial_sphere(20000, r);
  const VertexTree tree(m.positions);
  const Vec3 e1 = Vec3(0.3, -0.5, 0.8).normalized();
  const Vec3 e2 = e1.unitOrthogonal();
  const double dtheta = 30e-6 / r;  // rad a tick
  ContactCursor cursor;
  bool in = false;
  Vec3 last_probe = Vec3::Zero(), last_point = Vec3::Zero();
  int walks_at_end = 0;
  double off_foot = 0;  // largest angle (rad) between the point and the probe in the last 100 ticks
  constexpr int kPress = 100, kDeep = 50, kRise = 50, kShallow = 300;
  constexpr int kTicks = kPress + kDeep + kRise + kShallow;
  for (int k = 0; k <= kTicks; ++k) {
    double d = 0, theta = 0;
    if (k <= kPress) {
      d = -1e-4 + (0.7 * r + 1e-4) * k / kPress;
    } else if (k <= kPress + kDeep) {
      d = 0.7 * r;
      theta = dtheta * (k - kPress);
    } else {
      const int j = k - kPress - kDeep;  // ticks since the slide at 0.7 R ended
      d = j <= kRise ? 0.7 * r - 0.6 * r * j / kRise : 0.1 * r;
      theta = dtheta * (k - kPress);
    }
    const Vec3 probe = (r - d) * (std::cos(theta) * e1 + std::sin(theta) * e2);
    const ContactAnswer a = track_contact(m, tree, probe, cursor, in);
    ASSERT_NE(a.surface.triangle, kNoIndex) << k;
    in = a.surface.offset < 0;
    if (k > 1) {
      ASSERT_TRUE(in) << k;
      EXPECT_LE((a.surface.point - last_point).norm(), kProxyChase * (probe - last_probe).norm() + 1e-9) << k;
    }
    if (k > kTicks - 100) {
      walks_at_end += a.path == ContactPath::Walk;
      off_foot = std::max(off_foot, (a.surface.point.normalized() - probe.normalized()).norm());
    }
    last_probe = probe;
    last_point = a.surface.point;
  }
  EXPECT_EQ(walks_at_end, 100);
  EXPECT_LT(off_foot, 1e-9) << "the contact point trails the foot by " << off_foot * r * 1e3 << " mm";
}

TEST(Proxy, NeverCrossesToTheOtherSide) {
  // A 5 mm sphere (area-weighted normals) pressed 30 mm down from its top,
  // through it and out below: the contact stays on the top (normal up, depth
  // the press distance) although the tree's nearest vertex is soon on the
  // bottom; query_contact alone loses it there.
  const double r = 0.005;
  const auto m = mesh::make_sphere(5000, r);
  const VertexTree tree(m.positions);
  Index top = 0;
  for (Index i = 0; i < m.vertex_count(); ++i)
    if (m.positions[i].z() > m.positions[top].z()) top = i;
  ContactCursor proxy_cursor, plain_cursor;
  bool proxy_in = false, plain_in = false;
  int plain_lost = 0;
  for (int k = 0; k <= 300; ++k) {
    const double d = -1e-4 + 0.03 * k / 300;
    const Vec3 probe = m.positions[top] - d * m.normals[top];
    const ContactAnswer a = track_contact(m, tree, probe, proxy_cursor, proxy_in);
    const ContactAnswer b = query_contact(m, tree, probe, plain_cursor, plain_in);
    proxy_in = a.surface.triangle != kNoIndex && a.surface.offset < 0;
    const bool was_plain = plain_in;
    plain_in = b.surface.triangle != kNoIndex && b.surface.offset < 0;
    plain_lost += was_plain && !plain_in;
    if (d < 1e-5) continue;
    ASSERT_TRUE(proxy_in) << k;
    EXPECT_GT(a.surface.normal.dot(m.normals[top]), 0.99) << k;
    EXPECT_NEAR(-a.surface.offset, d, 1e-12) << k;
  }
  EXPECT_GT(plain_lost, 0);  // the check can fail: without the proxy the contact goes
}

TEST(Proxy, ThePreparedTrianglesTheCursorKeepsGiveTheAnswersOfFreshOnes) {
  // A small sphere (area-weighted normals, so its focal points spread about
  // the centre) pressed 0.7 R deep and slid along a wandering path there,
  // then raised to 0.1 R and slid on: deep, the proxy's walk visits several
  // triangles every tick. One cursor keeps its prepared triangles
  // (FrameCache) from tick to tick; the other has them dropped before every
  // query, so that each is prepared again from the mesh. Every answer must
  // have the same bits, on the proxy's path and on the walk's.
  const double r = 0.005;
  const auto m = mesh::make_sphere(20000, r);
  const VertexTree tree(m.positions);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> turn(-0.3, 0.3);
  Vec3 dir = Vec3(0.2, 0.4, 0.9).normalized();
  Vec3 heading = dir.unitOrthogonal();
  ContactCursor kept, fresh;
  bool kept_in = false, fresh_in = false;
  int proxies = 0, walks = 0, several = 0;
  constexpr int kPress = 100, kDeep = 400, kRise = 50, kShallow = 200;
  for (int k = 0; k <= kPress + kDeep + kRise + kShallow; ++k) {
    double d = 0;
    if (k <= kPress) {
      d = -1e-5 + (0.7 * r + 1e-5) * k / kPress;
    } else {
      const int j = k - kPress - kDeep;
      d = j <= 0 ? 0.7 * r : (j <= kRise ? 0.7 * r - 0.6 * r * j / kRise : 0.1 * r);
      // 10 um of surface a tick, turning at random.
      heading = Eigen::AngleAxisd(turn(rng), dir) * heading;
      dir = (dir + (10e-6 / r) * heading).normalized();
      heading = (heading - heading.dot(dir) * dir).normalized();
    }
    const Vec3 probe = (r - d) * dir;
    fresh.frames = FrameCache{};
    const ContactAnswer a = track_contact(m, tree, probe, kept, kept_in);
    const ContactAnswer b = track_contact(m, tree, probe, fresh, fresh_in);
    ASSERT_EQ(a.surface.triangle, b.surface.triangle) << k;
    ASSERT_EQ(a.path, b.path) << k;
    ASSERT_EQ(a.nearest_vertex, b.nearest_vertex) << k;
    for (int i = 0; i < 3; ++i) {
      ASSERT_EQ(a.surface.barycentric[i], b.surface.barycentric[i]) << k;
      ASSERT_EQ(a.surface.point[i], b.surface.point[i]) << k;
      ASSERT_EQ(a.surface.normal[i], b.surface.normal[i]) << k;
    }
    ASSERT_EQ(a.surface.offset, b.surface.offset) << k;
    kept_in = a.surface.triangle != kNoIndex && a.surface.offset < 0;
    fresh_in = b.surface.triangle != kNoIndex && b.surface.offset < 0;
    proxies += a.path == ContactPath::Proxy;
    walks += a.path == ContactPath::Walk;
    // Triangles the kept cursor holds prepared after this tick.
    const int held = kept.frames.held();
    several += a.path == ContactPath::Proxy && held >= 2;
  }
  // The check covers both paths, and ticks on which the proxy's walk left
  // more than one triangle prepared for the next.
  EXPECT_GT(proxies, 200);
  EXPECT_GT(walks, 100);
  EXPECT_GT(several, 100);
}

TEST(Proxy, AMeshWithoutItsNormalsGivesNoTriangleInContact) {
  // A cursor held on a proxy (a press past half the focal distance), then
  // asked on a copy of the mesh that has lost its normals (a mesh not fit
  // for the query: its frames are not the cursor's, so the walk declines):
  // the query must read no normal that is not there and give no triangle,
  // on every path, as query_contact does for such a mesh.
  const double r = 0.05;
  const auto m = test::radial_sphere(20000, r);
  const VertexTree tree(m.positions);
  const Vec3 dir = Vec3(0.3, -0.5, 0.8).normalized();
  ContactCursor cursor;
  const ContactAnswer first = track_contact(m, tree, r * dir - 1e-4 * dir, cursor, false);
  ASSERT_LT(first.surface.offset, 0);
  ContactAnswer deep;
  for (int k = 1; k <= 10; ++k) deep = track_contact(m, tree, first.surface.point - 0.07 * r * k * first.surface.normal, cursor, true);
  ASSERT_EQ(deep.path, ContactPath::Proxy);  // 0.7 R deep: past R / 2
  auto bare = m;
  bare.normals.clear();
  bare.normals.shrink_to_fit();
  for (const double d : {0.7 * r, 0.1 * r}) {  // the proxy's depth, and the walk's
    ContactCursor held = cursor;
    const ContactAnswer a = track_contact(bare, tree, first.surface.point - d * first.surface.normal, held, true);
    EXPECT_EQ(a.surface.triangle, kNoIndex) << d / r << " R";
    EXPECT_EQ(query_contact(bare, tree, first.surface.point - d * first.surface.normal, held, false).surface.triangle,
              kNoIndex);
  }
}

}  // namespace
}  // namespace palpa::collision
