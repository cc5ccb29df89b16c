// One haptic tick against closed forms: a linear material on a sphere with
// radial normals gives F = k depth along the outward normal.

#include "haptics/loop_core.h"
#include "haptics/probe_tick.h"
#include "common/test_support.h"
#include "mesh/generate.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <random>
#include <vector>

// Counts heap allocations made by this test program, so a test can check
// that the haptic path allocates nothing.
namespace {
std::atomic<long> g_allocations{0};
}  // namespace

// The replacements pair malloc with free on purpose; GCC cannot see that
// every new here comes from this malloc.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop

namespace palpa::haptics {
namespace {

constexpr double kRadius = 0.05;  // m

// A sphere whose vertex normals are exactly radial: the virtual vertex under
// a probe P is then exactly on the ray through P and its normal is P/|P|;
// the depth is R - |P| minus at most the sagitta of an edge.
struct SphereScene {
  std::shared_ptr<mesh::SurfaceMesh> mesh;
  double sagitta = 0;  // m, h^2 / 8R for the longest edge h
  std::unique_ptr<deform::DeformableSurface> surface;
  std::unique_ptr<collision::VertexTree> tree;

  explicit SphereScene(const deform::Material& material, std::size_t vertices = 20000) {
    mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_sphere(vertices, kRadius));
    for (std::size_t i = 0; i < mesh->vertex_count(); ++i) mesh->normals[i] = mesh->positions[i].normalized();
    double h = 0;
    for (const auto& t : mesh->triangles)
      for (int k = 0; k < 3; ++k) h = std::max(h, (mesh->positions[t[k]] - mesh->positions[t[(k + 1) % 3]]).norm());
    sagitta = h * h / (8 * kRadius);
    surface = std::make_unique<deform::DeformableSurface>(
        mesh, deform::MaterialArrays::uniform(mesh->vertex_count(), material));
    tree = std::make_unique<collision::VertexTree>(mesh->positions);
  }

  ProbeOutput tick(const ProbeInput& in, const ForceParams& params = {}) const {
    ProbeMemory memory;
    ProbeOutput out;
    haptic_tick(*surface, *tree, std::span(&in, 1), std::span(&memory, 1), std::span(&out, 1), params,
                deform::ShapeFunction{});
    return out;
  }
};

deform::Material linear(double k, double b = 0) {
  deform::Material m;
  m.model = deform::LocalModelKind::Linear;
  m.stiffness = k;
  m.damping = b;
  return m;
}

Vec3 direction(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return Vec3(g(rng), g(rng), g(rng)).normalized();
}

TEST(HapticTick, LinearSphereForceIsStiffnessTimesDepth) {
  const double k = 400;  // N/m
  const SphereScene scene(linear(k));
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> depth(0.0005, 0.004);
  for (int i = 0; i < 200; ++i) {
    const Vec3 dir = direction(rng);
    const double d = depth(rng);
    const ProbeOutput out = scene.tick({dir * (kRadius - d), Vec3::Zero()});
    ASSERT_TRUE(out.in_contact) << "probe " << i;
    // |F| = k depth with depth in [d - sagitta, d]; direction outward radial.
    EXPECT_LE(out.force.norm(), k * d * (1 + 1e-12));
    EXPECT_GE(out.force.norm(), k * (d - scene.sagitta) * (1 - 1e-12));
    EXPECT_LE((out.force.normalized() - dir).norm(), 1e-12);
    EXPECT_NEAR(out.normal_reaction, k * out.height.depth, 1e-12);
    // The contact handed to the surface.
    EXPECT_LE((out.contact.point - out.contact.point.norm() * dir).norm(), 1e-12);
    EXPECT_LE((out.contact.normal - dir).norm(), 1e-12);
    EXPECT_EQ(out.contact.depth, out.height.depth);
    EXPECT_EQ(out.contact.vertex, collision::nearest_brute_force(scene.mesh->positions, dir * (kRadius - d)).vertex);
    EXPECT_EQ(out.nearest_vertex, out.contact.vertex);
  }
}

TEST(HapticTick, OutsideGivesNoForce) {
  const SphereScene scene(linear(400));
  std::mt19937 rng(12);
  for (int i = 0; i < 50; ++i) {
    const Vec3 dir = direction(rng);
    for (double r : {kRadius + 1e-3, kRadius + 0.02, 3 * kRadius}) {
      const ProbeOutput out = scene.tick({dir * r, Vec3(0.1, 0, 0)});
      EXPECT_FALSE(out.in_contact);
      EXPECT_EQ(out.force, Vec3::Zero());
      EXPECT_EQ(out.normal_reaction, 0.0);
    }
  }
}

TEST(HapticTick, SeveralProbesAreIndependent) {
  const double k = 250;
  const SphereScene scene(linear(k));
  // Three probes: two inside at different depths on different sides, one outside.
  const std::vector<ProbeInput> probes = {{Vec3(0, 0, kRadius - 0.002), Vec3::Zero()},
                                          {Vec3(kRadius - 0.001, 0, 0), Vec3::Zero()},
                                          {Vec3(0, -kRadius - 0.003, 0), Vec3::Zero()}};
  std::vector<ProbeMemory> memory(3);
  std::vector<ProbeOutput> out(3);
  haptic_tick(*scene.surface, *scene.tree, probes, memory, out, ForceParams{}, deform::ShapeFunction{});
  const double depths[] = {0.002, 0.001};
  const Vec3 dirs[] = {Vec3::UnitZ(), Vec3::UnitX()};
  for (int i = 0; i < 2; ++i) {
    EXPECT_TRUE(out[i].in_contact);
    EXPECT_LE((out[i].force - k * depths[i] * dirs[i]).norm(), k * scene.sagitta + 1e-12) << "probe " << i;
    // The same probe alone gives the same answer.
    EXPECT_EQ(scene.tick(probes[i]).force, out[i].force);
  }
  EXPECT_FALSE(out[2].in_contact);
  EXPECT_EQ(out[2].force, Vec3::Zero());
}

TEST(HapticTick, DampingAndFriction) {
  // Linear model: Fn = k depth - b (v . N); moving in at 2 cm/s adds b * 0.02.
  const double k = 300, b = 5;
  const SphereScene scene(linear(k, b));
  ForceParams params;
  params.friction = 0.4;
  params.max_force = 100;
  const Vec3 p(0, 0, kRadius - 0.002);
  const ProbeOutput rest = scene.tick({p, Vec3::Zero()}, params);
  const double fn0 = rest.normal_reaction;
  EXPECT_NEAR(fn0, k * 0.002, k * scene.sagitta);
  const ProbeOutput pressing = scene.tick({p, Vec3(0, 0, -0.02)}, params);
  EXPECT_NEAR(pressing.normal_reaction, fn0 + b * 0.02, 1e-12);
  EXPECT_LE((pressing.force - Vec3(0, 0, fn0 + b * 0.02)).norm(), 1e-12);
  // Withdrawing fast: the reaction would be negative, so it is zero (no pull).
  const ProbeOutput pulling = scene.tick({p, Vec3(0, 0, 1.0)}, params);
  EXPECT_TRUE(pulling.in_contact);
  EXPECT_EQ(pulling.normal_reaction, 0.0);
  EXPECT_EQ(pulling.force, Vec3::Zero());
  // Sliding along +x at 5 cm/s: friction K Fn along -x, normal part unchanged.
  const ProbeOutput sliding = scene.tick({p, Vec3(0.05, 0, 0)}, params);
  EXPECT_NEAR(sliding.normal_reaction, fn0, 1e-12);
  EXPECT_LE((sliding.force - Vec3(-0.4 * fn0, 0, fn0)).norm(), 1e-12);
}

TEST(HapticTick, ForceIsClampedToTheDeviceLimit) {
  const SphereScene scene(linear(1e5));  // 1e5 N/m * 3 mm = 300 N
  ForceParams params;
  params.max_force = 8;
  const ProbeOutput out = scene.tick({Vec3(0, kRadius - 0.003, 0), Vec3::Zero()}, params);
  EXPECT_TRUE(out.in_contact);
  EXPECT_GT(out.normal_reaction, 290.0);
  EXPECT_NEAR(out.force.norm(), 8.0, 1e-12);
  EXPECT_LE((out.force.normalized() - Vec3::UnitY()).norm(), 1e-12);
}

TEST(HapticTick, DeformedSurfaceBelowTheProbeIsNoContact) {
  // Every vertex pushed in by 4 mm: a probe 2 mm deep is above the deformed
  // surface (offset -2 mm > h = -4 mm), so it touches nothing; 5 mm deep it does.
  const SphereScene scene(linear(400));
  deform::SurfaceState s = scene.surface->state();
  for (auto& v : s.vertices) v.h = -0.004;
  scene.surface->set_state(s);
  const ProbeOutput shallow = scene.tick({Vec3(0, 0, kRadius - 0.002), Vec3::Zero()});
  EXPECT_FALSE(shallow.in_contact);
  EXPECT_EQ(shallow.force, Vec3::Zero());
  EXPECT_NEAR(shallow.height.surface_height, -0.004, 1e-15);
  const ProbeOutput deep = scene.tick({Vec3(0, 0, kRadius - 0.005), Vec3::Zero()});
  EXPECT_TRUE(deep.in_contact);
  // The local model reacts to the probe's own height: k * 5 mm.
  EXPECT_NEAR(deep.normal_reaction, 400 * 0.005, 400 * scene.sagitta);
}

TEST(HapticTick, ViscoelasticAtRestReactsWithBothSprings) {
  // Zener model with relaxed dashpot state q = 0: Fn = k d + k2 d.
  deform::Material m;
  m.model = deform::LocalModelKind::Viscoelastic;
  m.stiffness = 300;
  m.k2 = 200;
  m.damping = 0;
  const SphereScene scene(m);
  const ProbeOutput out = scene.tick({Vec3(kRadius - 0.002, 0, 0), Vec3::Zero()});
  EXPECT_TRUE(out.in_contact);
  EXPECT_NEAR(out.normal_reaction, 500 * 0.002, 500 * scene.sagitta);
  EXPECT_NEAR(out.normal_reaction, 500 * out.height.depth, 1e-12);
}

TEST(HapticTick, StiffnessIsInterpolatedAtTheVirtualVertex) {
  // On a flat grid (normals +z) a stiffness linear in position, k = 1000 +
  // 1e4 x + 5e3 y (N/m), is reproduced exactly by barycentric interpolation:
  // the probe at (x, y, -d) feels (1000 + 1e4 x + 5e3 y) d.
  auto plane = std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(21, 21, 0.005));
  deform::MaterialArrays mats = deform::MaterialArrays::uniform(plane->vertex_count(), linear(1000));
  for (Index i = 0; i < plane->vertex_count(); ++i)
    mats.stiffness[i] = 1000 + 1e4 * plane->positions[i].x() + 5e3 * plane->positions[i].y();
  const deform::DeformableSurface surface(plane, mats);
  const collision::VertexTree tree(plane->positions);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.045, 0.045);
  for (int i = 0; i < 100; ++i) {
    const double x = u(rng), y = u(rng), d = 0.003;
    const ProbeInput in{Vec3(x, y, -d), Vec3::Zero()};
    ProbeMemory memory;
    ProbeOutput out;
    haptic_tick(surface, tree, std::span(&in, 1), std::span(&memory, 1), std::span(&out, 1), ForceParams{},
                deform::ShapeFunction{});
    ASSERT_TRUE(out.in_contact);
    const double fn = (1000 + 1e4 * x + 5e3 * y) * d;
    EXPECT_NEAR(out.normal_reaction, fn, 1e-12);
    EXPECT_LE((out.force - Vec3(0, 0, fn)).norm(), 1e-12);
  }
}

TEST(HapticTick, SlidingProbeWalksAndMatchesAFreshTick) {
  // A probe sliding 2 mm deep along a circle with memory carried over: after
  // the first tick (tree) the in-contact walk answers, and every tick gives
  // the same virtual vertex and force as a tick without history (tree +
  // locate), the closed form k depth, and a nearest vertex that is the
  // exact one (tree) or the contact triangle's nearest (walk).
  const double k = 400;
  const SphereScene scene(linear(k));
  ProbeMemory memory;
  int walked = 0;
  for (int i = 0; i < 400; ++i) {
    const double th = i * 1e-3;
    const Vec3 dir(std::cos(th), std::sin(th), 0);
    const ProbeInput in{dir * (kRadius - 0.002), Vec3(-std::sin(th), std::cos(th), 0) * 0.05};
    ProbeOutput out;
    haptic_tick(*scene.surface, *scene.tree, std::span(&in, 1), std::span(&memory, 1), std::span(&out, 1),
                ForceParams{}, deform::ShapeFunction{});
    ASSERT_TRUE(out.in_contact);
    EXPECT_TRUE(memory.in_contact);
    EXPECT_EQ(out.path, i == 0 ? collision::ContactPath::Tree : collision::ContactPath::Walk) << "tick " << i;
    walked += out.path == collision::ContactPath::Walk;
    const ProbeOutput fresh = scene.tick(in);
    EXPECT_EQ(fresh.path, collision::ContactPath::Tree);
    EXPECT_LE((out.surface.point - fresh.surface.point).norm(), 1e-15) << "tick " << i;
    EXPECT_NEAR(out.height.depth, fresh.height.depth, 1e-15) << "tick " << i;
    EXPECT_LE((out.force - fresh.force).norm(), 1e-12) << "tick " << i;
    EXPECT_NEAR(out.force.dot(dir), k * 0.002, k * scene.sagitta);
    const auto& tri = scene.mesh->triangles[out.surface.triangle];
    const double d2 = (scene.mesh->positions[out.nearest_vertex] - in.position).squaredNorm();
    if (out.path == collision::ContactPath::Tree) {
      EXPECT_EQ(collision::nearest_brute_force(scene.mesh->positions, in.position).distance_sq, d2);
    } else {
      for (Index v : tri) EXPECT_LE(d2, (scene.mesh->positions[v] - in.position).squaredNorm());
    }
  }
  EXPECT_EQ(walked, 399);
}

TEST(HapticTick, TheWarmUpRehearsesACrossingPastTheNearestCorner) {
  // A probe 1 mm deep in contact (a walk's answer): the rehearsal point is
  // the closed form corner + (corner - contact) / 4 + (probe - contact), and
  // a query there on a copy of the cursor, as LoopCore::warm_caches runs
  // it, walks (no jump to the tree) into another triangle round that corner
  // (past it: a convex triangle holds no point beyond its corner on the ray
  // from inside). Most land on a triangle that shares no edge with the
  // probe's own: the crossing past a corner the rehearsal is for.
  const SphereScene scene(linear(400));
  std::mt19937 rng(11);
  int past_corner = 0;
  constexpr int kProbes = 60;
  for (int k = 0; k < kProbes; ++k) {
    const Vec3 dir = direction(rng);
    ProbeMemory memory;
    ProbeOutput out;
    for (int i = 0; i < 2; ++i) {  // tree, then walk
      const ProbeInput in{dir * (kRadius - 0.001) + 1e-6 * i * dir.unitOrthogonal(), Vec3::Zero()};
      haptic_tick(*scene.surface, *scene.tree, std::span(&in, 1), std::span(&memory, 1), std::span(&out, 1),
                  ForceParams{}, deform::ShapeFunction{});
    }
    ASSERT_EQ(out.path, collision::ContactPath::Walk) << k;
    const mesh::SurfaceMesh& m = *scene.mesh;
    const Index start = memory.cursor.triangle;
    const auto& tri = m.triangles[start];
    const Vec3& b = memory.cursor.barycentric;
    const int nearest = b[0] >= b[1] && b[0] >= b[2] ? 0 : (b[1] >= b[2] ? 1 : 2);
    const Vec3 contact = b[0] * m.positions[tri[0]] + b[1] * m.positions[tri[1]] + b[2] * m.positions[tri[2]];
    const Vec3& corner = m.positions[tri[nearest]];
    Vec3 past = Vec3::Zero();
    ASSERT_TRUE(corner_rehearsal_point(m, memory, past));
    EXPECT_LE((past - (corner + 0.25 * (corner - contact) + (memory.cursor.probe - contact))).norm(), 1e-15);
    collision::ContactCursor copy = memory.cursor;
    const collision::ContactAnswer a = collision::track_contact(m, *scene.tree, past, copy, true);
    EXPECT_EQ(a.path, collision::ContactPath::Walk) << k;
    ASSERT_NE(a.surface.triangle, kNoIndex);
    EXPECT_NE(a.surface.triangle, start) << k;
    const auto& landed = m.triangles[a.surface.triangle];
    EXPECT_TRUE(landed[0] == tri[nearest] || landed[1] == tri[nearest] || landed[2] == tri[nearest]) << k;
    const auto& across = m.triangle_neighbors[start];
    past_corner += std::find(across.begin(), across.end(), a.surface.triangle) == across.end();
    EXPECT_EQ(memory.cursor.triangle, start);  // the copy walked, not the memory
  }
  EXPECT_GT(past_corner, kProbes / 2);
  // No contact triangle, no rehearsal.
  Vec3 unchanged(1, 2, 3);
  EXPECT_FALSE(corner_rehearsal_point(*scene.mesh, ProbeMemory{}, unchanged));
  EXPECT_EQ(unchanged, Vec3(1, 2, 3));
}

TEST(HapticTick, ContactHoldsWhileAnUnderdampedSurfaceOvershoots) {
  // A lightly damped linear material (zeta = 0.035) held 2 mm in by a fixed
  // probe overshoots past it: the interpolated height goes below the probe.
  // The hysteretic height check keeps the contact (and its force) on every
  // tick; a fresh check (no history) would drop it on those ticks.
  deform::Material mat = linear(500, 0.05);
  const SphereScene scene(mat);
  deform::ShapeFunction shape;
  shape.kind = deform::ShapeKind::Wendland;
  shape.radius = 0.01;
  const ProbeInput in{Vec3(0, 0, kRadius - 0.002), Vec3::Zero()};
  ProbeMemory memory;
  int overshoot_ticks = 0;
  for (int i = 0; i < 300; ++i) {
    ProbeOutput out;
    haptic_tick(*scene.surface, *scene.tree, std::span(&in, 1), std::span(&memory, 1), std::span(&out, 1),
                ForceParams{}, shape);
    ASSERT_TRUE(out.in_contact) << "tick " << i;
    EXPECT_TRUE(memory.in_contact);
    EXPECT_GT(out.force.z(), 0.0);
    if (out.height.surface_height < -out.height.depth) {
      // The surface is below the probe: only the hysteresis holds the contact.
      ++overshoot_ticks;
      EXPECT_FALSE(collision::height_check(out.surface, Vec3::Constant(out.height.surface_height)).in_contact);
    }
    const deform::Contact c = out.contact;
    scene.surface->set_contacts(std::span(&c, 1));
    scene.surface->step(1e-3);
  }
  EXPECT_GT(overshoot_ticks, 20);
  // Withdrawn above the surface, the contact ends and memory forgets it.
  const ProbeInput out_in{Vec3(0, 0, kRadius + 0.001), Vec3::Zero()};
  ProbeOutput out;
  haptic_tick(*scene.surface, *scene.tree, std::span(&out_in, 1), std::span(&memory, 1), std::span(&out, 1),
              ForceParams{}, shape);
  EXPECT_FALSE(out.in_contact);
  EXPECT_FALSE(memory.in_contact);
  EXPECT_EQ(out.force, Vec3::Zero());
  // Back in, with the surface still below the probe: a new contact needs the
  // probe at or below the deformed surface, so none until it goes deeper.
  ProbeOutput again;
  haptic_tick(*scene.surface, *scene.tree, std::span(&in, 1), std::span(&memory, 1), std::span(&again, 1),
              ForceParams{}, shape);
  EXPECT_EQ(again.in_contact, -again.height.depth <= again.height.surface_height);
}

// ---------------------------------------------------------------------------
// A hovering probe skips the search (collision::ContactPath::Clear): the same
// ticks on two copies of a scene, one whose tree is built from the positions
// alone and so knows no clearance: there every probe out of contact asks
// the tree.

struct TwinScene {
  std::shared_ptr<mesh::SurfaceMesh> mesh;
  std::unique_ptr<deform::DeformableSurface> surface;
  std::unique_ptr<collision::VertexTree> tree;
  std::vector<ProbeMemory> memory;

  TwinScene(const mesh::SurfaceMesh& m, const deform::Material& material, std::size_t probes, bool clearance)
      : mesh(std::make_shared<mesh::SurfaceMesh>(m)), memory(probes) {
    surface = std::make_unique<deform::DeformableSurface>(
        mesh, deform::MaterialArrays::uniform(mesh->vertex_count(), material));
    tree = clearance ? std::make_unique<collision::VertexTree>(*mesh)
                     : std::make_unique<collision::VertexTree>(std::span<const Vec3>(mesh->positions));
  }

  void tick(std::span<const ProbeInput> in, std::span<ProbeOutput> out, const deform::ShapeFunction& shape) {
    haptic_tick(*surface, *tree, in, memory, out, ForceParams{}, shape);
    std::vector<deform::Contact> contacts;
    for (const ProbeOutput& o : out)
      if (o.in_contact) contacts.push_back(o.contact);
    surface->set_contacts(contacts);
    surface->step(1e-3);
  }
};

// Three probes circling the surface of a star-shaped body (the ray from
// `centre` along a turning direction, `radius_along` giving where it meets
// the surface) at 0.06 to 0.16 mm a tick, each rising to 5 mm above it and
// pressing 3 mm into it along the ray, at its own period; probe 0 jumps a
// quarter turn at tick 3000. Checks, tick by tick, that the forces, verdicts
// and surface states are the bits of the scene that always searches, and
// the answers too where this one searched; sets `share` to the share of the
// out of contact probe-ticks that skipped the search.
template <class RadiusAlong>
void compare_hovering(const mesh::SurfaceMesh& m, const Vec3& centre, RadiusAlong radius_along, const char* what,
                      double& share) {
  share = 0;
  const deform::Material material = linear(300, 0.3);
  deform::ShapeFunction shape;
  shape.kind = deform::ShapeKind::Wendland;
  shape.radius = 0.012;
  constexpr int kProbes = 3, kTicks = 6000;
  TwinScene fast(m, material, kProbes, true), full(m, material, kProbes, false);
  std::array<ProbeInput, kProbes> in{};
  std::array<ProbeOutput, kProbes> a{}, b{};
  std::array<Vec3, kProbes> last{};
  const Vec3 axes[kProbes][2] = {{Vec3(1, 0, 0), Vec3(0, 0.6, 0.8)},
                                 {Vec3(0, 1, 0), Vec3(0.8, 0, -0.6)},
                                 {Vec3(0.6, 0, 0.8), Vec3(0, -1, 0)}};
  long skipped = 0, out_of_contact = 0, contact_ticks = 0;
  for (int t = 0; t < kTicks; ++t) {
    for (int p = 0; p < kProbes; ++p) {
      const double turn = (0.0012 + 0.0007 * p) * t + (p == 0 && t >= 3000 ? M_PI / 2 : 0.0);
      const Vec3 d = (std::cos(turn) * axes[p][0] + std::sin(turn) * axes[p][1] +
                      0.2 * std::sin(3.1 * turn) * axes[p][0].cross(axes[p][1]))
                         .normalized();
      const double height = 0.001 + 0.004 * std::sin(2 * M_PI * t / (900.0 + 250 * p));
      const Vec3 pos = centre + (radius_along(d) + height) * d;
      in[p] = {pos, t == 0 ? Vec3::Zero() : Vec3((pos - last[p]) / 1e-3)};
      last[p] = pos;
    }
    fast.tick(in, a, shape);
    full.tick(in, b, shape);
    for (int p = 0; p < kProbes; ++p) {
      const ProbeOutput &x = a[p], &y = b[p];
      ASSERT_EQ(x.in_contact, y.in_contact) << what << ", tick " << t << ", probe " << p;
      ASSERT_EQ(x.force, y.force) << what << ", tick " << t << ", probe " << p;
      ASSERT_EQ(x.normal_reaction, y.normal_reaction) << what << ", tick " << t;
      contact_ticks += y.in_contact;
      out_of_contact += !y.in_contact;
      if (x.path == collision::ContactPath::Clear) {
        ++skipped;
        // The probe is above the surface, as the full query says.
        ASSERT_EQ(y.path, collision::ContactPath::Tree) << what << ", tick " << t;
        ASSERT_GT(y.surface.offset, 0.0) << what << ", tick " << t;
        EXPECT_EQ(x.height.depth, -x.surface.offset);
        EXPECT_EQ(x.height.surface_height, 0.0);
        continue;
      }
      ASSERT_EQ(x.path, y.path) << what << ", tick " << t << ", probe " << p;
      ASSERT_EQ(x.nearest_vertex, y.nearest_vertex) << what << ", tick " << t;
      ASSERT_EQ(x.surface.triangle, y.surface.triangle) << what << ", tick " << t;
      ASSERT_EQ(x.surface.point, y.surface.point) << what << ", tick " << t;
      ASSERT_EQ(x.height.depth, y.height.depth) << what << ", tick " << t;
    }
  }
  for (std::size_t i = 0; i < m.vertex_count(); ++i)
    ASSERT_EQ(fast.surface->state().vertices[i].h, full.surface->state().vertices[i].h) << what << ", vertex " << i;
  std::printf("%s: %ld probe-ticks in contact, %ld out of it, %ld of those skipped the search\n", what,
              contact_ticks, out_of_contact, skipped);
  EXPECT_GT(contact_ticks, kProbes * kTicks / 5) << what;
  share = out_of_contact > 0 ? double(skipped) / double(out_of_contact) : 0.0;
}

TEST(HapticTick, AHoveringProbeSkipsTheSearchWithTheForcesOfTheFullQuery) {
  // A sphere with radial normals, and the default organ (concave in places:
  // its groove, notch and hollow back border) with its own normals.
  const SphereScene sphere(linear(300));
  double share = 0;
  compare_hovering(*sphere.mesh, Vec3::Zero(), [](const Vec3&) { return kRadius; }, "sphere", share);
  EXPECT_GT(share, 0.5);
  const auto organ = mesh::make_organ(20000);
  // Where the ray meets the organ's implicit surface, by bisection.
  auto organ_radius = [](const Vec3& d) {
    double lo = 0, hi = 0.3;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (mesh::organ_implicit(mesh::organ_center() + mid * d) < 0 ? lo : hi) = mid;
    }
    return lo;
  };
  compare_hovering(organ, mesh::organ_center(), organ_radius, "organ", share);
  EXPECT_GT(share, 0.5);
}

TEST(HapticTick, TheRingOfTheNearestCornerIsFetchedOneStageATick) {
  // A probe held in contact near vertex v: from the tick after its first
  // contact the tick fetches v's ring ahead, one stage a tick (offsets,
  // rows, triangles, vertices), then stops; near another vertex it starts
  // over there. The forces are those of a probe with no history (N).
  const SphereScene scene(linear(400));
  const mesh::SurfaceMesh& m = *scene.mesh;
  const Index v = static_cast<Index>(m.vertex_count() / 3);
  const Index w = m.vertex_neighbors.row(v)[0];
  ASSERT_NE(w, v);
  auto below = [&](Index u) { return ProbeInput{m.positions[u] * (1 - 0.001 / kRadius), Vec3::Zero()}; };
  ProbeMemory memory;
  ProbeOutput out;
  auto tick = [&](const ProbeInput& in) {
    haptic_tick(*scene.surface, *scene.tree, std::span(&in, 1), std::span(&memory, 1), std::span(&out, 1),
                ForceParams{}, deform::ShapeFunction{});
    ASSERT_TRUE(out.in_contact);
    // At a vertex several triangles hold the contact point: the walk keeps
    // its own, a fresh tick may pick another, equal up to round-off.
    ASSERT_LE((out.force - scene.tick(in).force).norm(), 1e-12);
  };
  tick(below(v));  // first contact: nothing to fetch yet
  EXPECT_EQ(memory.ring_vertex, kNoIndex);
  for (int stage = 0; stage <= 3; ++stage) {
    tick(below(v));
    EXPECT_EQ(memory.ring_vertex, v) << stage;
    EXPECT_EQ(memory.ring_stage, stage) << stage;
  }
  tick(below(v));
  EXPECT_EQ(memory.ring_stage, 3);  // fetched: it stays there
  tick(below(w));                    // the tick reads last tick's contact, still at v
  EXPECT_EQ(memory.ring_vertex, v);
  tick(below(w));
  EXPECT_EQ(memory.ring_vertex, w);
  EXPECT_EQ(memory.ring_stage, 0);
  // A memory whose fetch state is out of range (another mesh's vertex, a
  // stage past the last) starts over or stays idle; it never reads outside.
  memory.ring_vertex = static_cast<Index>(m.vertex_count() + 7);
  tick(below(w));
  EXPECT_EQ(memory.ring_vertex, w);
  EXPECT_EQ(memory.ring_stage, 0);
  memory.ring_stage = 200;
  tick(below(w));
  EXPECT_EQ(memory.ring_stage, 200);
}

TEST(HapticTick, DoesNotAllocate) {
  // Several probes in and out of contact, over many ticks: no heap allocation.
  const SphereScene scene(linear(400));
  std::vector<ProbeInput> probes = {{Vec3(0, 0, kRadius - 0.002), Vec3(0.01, 0, -0.01)},
                                    {Vec3(kRadius + 0.001, 0, 0), Vec3::Zero()},
                                    {Vec3(0, kRadius - 0.001, 0), Vec3(0, 0, 0.02)}};
  std::vector<ProbeMemory> memory(probes.size());
  std::vector<ProbeOutput> out(probes.size());
  const long before = g_allocations.load();
  for (int i = 0; i < 100; ++i) {
    probes[0].position.x() += 1e-4;
    haptic_tick(*scene.surface, *scene.tree, probes, memory, out, ForceParams{}, deform::ShapeFunction{});
  }
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_TRUE(out[0].in_contact);
  EXPECT_FALSE(out[1].in_contact);

  // A deep press past the focal distance, sliding, then out: the proxy path
  // (and the tree's answer when the probe comes out) allocate nothing.
  ProbeMemory deep;
  ProbeOutput deep_out;
  int proxy_ticks = 0;
  const long before_deep = g_allocations.load();
  for (int i = 0; i <= 400; ++i) {
    const double d = i < 300 ? 0.8 * kRadius * i / 300 : 0.8 * kRadius - 0.85 * kRadius * (i - 300) / 100;
    const ProbeInput in{Vec3(1e-5 * i, 0, kRadius - d), Vec3::Zero()};
    haptic_tick(*scene.surface, *scene.tree, std::span(&in, 1), std::span(&deep, 1), std::span(&deep_out, 1),
                ForceParams{}, deform::ShapeFunction{});
    proxy_ticks += deep_out.path == collision::ContactPath::Proxy;
  }
  EXPECT_EQ(g_allocations.load() - before_deep, 0);
  EXPECT_GT(proxy_ticks, 50);
  EXPECT_FALSE(deep_out.in_contact);
}

TEST(HapticTick, ASetTissueCommandAndTheTicksAfterItDoNotAllocate) {
  // The haptic thread's side of SetTissue: LoopCore::apply swaps the field
  // at a tick boundary and the ticks read the new one (lesions, a pulse, a
  // dynamic region with guarding, breathing), with no heap allocation.
  const SphereScene scene(linear(400), 4000);
  tissue::Lesion l;
  l.centre = Vec3(0, 0, kRadius - 0.006);
  l.semi_axes = Vec3::Constant(0.004);
  tissue::Pulse p;
  p.path = {Vec3(-0.06, 0, kRadius), Vec3(0.06, 0, kRadius)};
  p.radius = 0.01;
  tissue::Breathing b;
  b.enabled = true;
  tissue::DynamicRegion d;
  d.region = "all";
  d.keyframes = {{0.0, 1.2, 0.1}};
  d.guarding.enabled = true;
  d.guarding.threshold = 0.1;
  auto first = std::make_shared<TissueModel>();
  first->field = std::make_shared<tissue::TissueField>(
      tissue::make_field(*scene.mesh, 0.008, {l}, {p}, b, {d}, {std::vector<float>(scene.mesh->vertex_count(), 1.0f)}));
  auto second = std::make_shared<TissueModel>();  // no field at all
  validate_tissue(*first, scene.mesh->vertex_count());
  ProbeSetup setup;
  setup.name = "probe";
  setup.spec.position_dof = 3;
  LoopCore core(*scene.tree, *scene.mesh, CoreConfig{}, {setup});
  std::array<ProbeTickInput, 1> in{};
  std::array<ProbeTickResult, 1> out{};
  ContactSet contacts;
  LoopCommand set = LoopCommand::of(LoopCommandKind::SetTissue);
  double felt_with = 0, felt_without = 0;
  const long before = g_allocations.load();
  for (std::uint64_t i = 0; i < 300; ++i) {
    const double t = 1.0 + static_cast<double>(i) * 1e-3;
    if (i == 100 || i == 200) {
      set.tissue = i == 100 ? first.get() : second.get();
      core.apply(set, t);
    }
    in[0].sample = position_sample(Vec3(0, 0, kRadius - 0.002), i + 1, t);
    core.tick(i, t, *scene.surface, t, in, out, contacts);
    if (i == 199) felt_with = out[0].normal_reaction;
    if (i == 299) felt_without = out[0].normal_reaction;
  }
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_EQ(core.field(), nullptr);
  EXPECT_GT(felt_with, 1.2 * felt_without) << "the first tissue's lesion and keyframe were felt";
  EXPECT_GT(felt_without, 0.0);
}

TEST(HapticTick, NonFiniteProbeGivesNoForce) {
  const SphereScene scene(linear(400), 2000);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const Vec3& p : {Vec3(nan, 0, 0), Vec3(0, inf, 0), Vec3(0, 0, -inf)}) {
    const ProbeOutput out = scene.tick({p, Vec3::Zero()});
    EXPECT_FALSE(out.in_contact);
    EXPECT_EQ(out.force, Vec3::Zero());
  }
  // A non-finite velocity: treated as rest, force still finite (k depth).
  const ProbeOutput out = scene.tick({Vec3(0, 0, kRadius - 0.002), Vec3(nan, 0, 0)});
  EXPECT_TRUE(out.in_contact);
  EXPECT_TRUE(out.force.allFinite());
  EXPECT_NEAR(out.force.z(), 400 * 0.002, 400 * scene.sagitta);
}

}  // namespace
}  // namespace palpa::haptics

#include "haptics/session.h"
#include "tissue/field.h"
#include "tissue/tissue.h"

namespace palpa::haptics {
namespace {

TEST(HapticTick, TheTissueFieldAllocatesNothingOnTheTickOrTheStep) {
  // Lesions, a pulse, breathing and a guarding region: after a warm-up,
  // neither the tick nor the deformation step allocates.
  auto mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(61, 61, 0.001));
  tissue::Lesion les;
  les.centre = Vec3(0, 0, -0.01);
  tissue::Pulse pulse;
  pulse.name = "vessel";
  pulse.path = {Vec3(-0.03, 0, -0.004), Vec3(0.03, 0, -0.004)};
  tissue::Breathing breathing;
  breathing.enabled = true;
  breathing.translation = Vec3(0, 0, 0.002);
  tissue::DynamicRegion guard;
  guard.region = "all";
  guard.guarding.enabled = true;
  guard.guarding.threshold = 0.01;
  guard.keyframes = {{0.1, 1.5, 0.1}};
  auto field = std::make_shared<tissue::TissueField>(tissue::make_field(
      *mesh, 0.008, {les}, {pulse}, breathing, {guard}, {std::vector<float>(mesh->vertex_count(), 1.0f)}));
  CoreConfig config;
  config.deform_rate_hz = 500;
  tissue::Tissue t;
  t.name = "soft";
  const deform::Material m = tissue::hertz_material(t, 0.008);
  const auto model = SessionModel::make(mesh, {}, config, field);
  ProbeSetup probe;
  probe.name = "p";
  probe.spec.position_dof = 3;
  probe.safety.max_jump = 1e9;
  Session s(model, deform::MaterialArrays::uniform(mesh->vertex_count(), m), {probe, probe});
  std::vector<ProbeTickInput> in(2);
  std::vector<ProbeTickResult> out(2);
  auto run = [&](int from, int to) {
    for (int k = from; k < to; ++k) {
      const double t = k * 1e-3;
      for (int j = 0; j < 2; ++j) {
        auto& smp = in[j].sample;
        smp.orientation[0] = 1;
        smp.position[0] = 0.005 * std::sin(t + j);
        smp.position[1] = 0.004 * j;
        smp.position[2] = -0.003;
        smp.status = PALPA_STATUS_VALID;
        smp.sequence = k + 1;
        smp.time = t;
      }
      s.step(t, in, out);
    }
  };
  run(0, 500);
  ASSERT_TRUE(out[0].in_contact);
  const long before = g_allocations.load();
  run(500, 1500);
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_TRUE(out[0].in_contact);
}

}  // namespace
}  // namespace palpa::haptics
