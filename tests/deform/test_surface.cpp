// The deformable surface (sections III.A, III.B, IV) against physics and brute
// force: equilibrium shapes, volume, normals, superposition, the active set,
// propagation, determinism and the dirty ranges of the stream.

#include "deform/surface.h"

#include "allocation_counter.h"
#include "common/huge_pages_support.h"
#include "mesh/generate.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__x86_64__)
#include <xmmintrin.h>
#endif

namespace palpa::deform {
namespace {

using mesh::SurfaceMesh;
using MeshPtr = std::shared_ptr<const SurfaceMesh>;

MeshPtr sphere(std::size_t vertices, double radius) {
  return std::make_shared<const SurfaceMesh>(mesh::make_sphere(vertices, radius));
}

MeshPtr plane(int n, double spacing) { return std::make_shared<const SurfaceMesh>(mesh::make_plane(n, n, spacing)); }

Material linear() { return Material{}; }  // 1 g, 1 N s/m, 500 N/m

// The vertex nearest to p (brute force).
Index nearest_vertex(const SurfaceMesh& m, const Vec3& p) {
  Index best = 0;
  for (Index i = 1; i < m.vertex_count(); ++i) {
    if ((m.positions[i] - p).squaredNorm() < (m.positions[best] - p).squaredNorm()) best = i;
  }
  return best;
}

// A contact at p on the undeformed surface, seeded at the nearest vertex.
Contact contact_near(const SurfaceMesh& m, const Vec3& p, double depth, ShapeKind kind, double radius) {
  Contact c;
  c.vertex = nearest_vertex(m, p);
  c.point = p;
  c.normal = m.normals[c.vertex];
  c.depth = depth;
  c.shape = ShapeFunction{kind, radius};
  return c;
}

// A contact on a sphere centred at the origin, in direction dir.
Contact sphere_contact(const SurfaceMesh& m, double sphere_radius, Vec3 dir, double depth, ShapeKind kind,
                       double radius) {
  dir.normalize();
  Contact c = contact_near(m, sphere_radius * dir, depth, kind, radius);
  c.normal = dir;
  return c;
}

void run(DeformableSurface& s, int steps, double dt) {
  for (int n = 0; n < steps; ++n) s.step(dt);
}

// Area-weighted vertex normals recomputed from the deformed positions (eq. 2).
std::vector<Vec3> geometric_normals(const DeformableSurface& s) {
  const SurfaceMesh& m = s.mesh();
  std::vector<Vec3> n(m.vertex_count(), Vec3::Zero());
  for (const auto& t : m.triangles) {
    const Vec3 a = s.deformed_position(t[0]), b = s.deformed_position(t[1]), c = s.deformed_position(t[2]);
    const Vec3 w = (b - a).cross(c - a);
    for (Index v : t) n[v] += w;
  }
  for (Vec3& v : n) v.normalize();
  return n;
}

double angle(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }

bool same_bits(const SurfaceState& a, const SurfaceState& b) {
  return a.vertices.size() == b.vertices.size() && a.time == b.time &&
         std::memcmp(a.vertices.data(), b.vertices.data(), a.vertices.size() * sizeof(VertexState)) == 0;
}

bool same_bits(std::span<const float> a, std::span<const float> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// ---------------------------------------------------------------------------
// Equilibrium shape (section III.B): a single contact's shape is the shape function.

TEST(Surface, EquilibriumShapeIsTheShapeFunctionForEveryModel) {
  const double spacing = 1e-3, radius = 0.02, depth = 0.003;
  const MeshPtr m = plane(81, spacing);
  Material exponential;
  exponential.model = LocalModelKind::Exponential;
  Material viscoelastic;
  viscoelastic.model = LocalModelKind::Viscoelastic;
  viscoelastic.tau = 0.05;
  for (const Material& mat : {linear(), exponential, viscoelastic}) {
    for (ShapeKind kind : {ShapeKind::Gaussian, ShapeKind::Wendland, ShapeKind::VolumeConserving}) {
      SCOPED_TRACE("model " + std::to_string(int(mat.model)) + " shape " + std::to_string(int(kind)));
      DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), mat));
      const Contact c = contact_near(*m, Vec3(2e-4, -3e-4, 0), depth, kind, radius);
      s.set_contacts({&c, 1});
      run(s, 600, 0.01);
      for (Index i = 0; i < m->vertex_count(); ++i) {
        const double r = (m->positions[i] - c.point).norm();
        const double expected = r < radius ? -depth * c.shape.value(r) : 0.0;
        ASSERT_NEAR(s.state().vertices[i].h, expected, 1e-9 * depth) << "vertex " << i;
      }
    }
  }
}

TEST(Surface, VolumeConservingShapeKeepsTheVolumeOfAPlane) {
  // Displaced volume sum(h_i * cell area) after settling: zero relative to the
  // pushed-in volume, which itself matches pi R^2 depth 256/3125.
  const double spacing = 5e-4, radius = 0.025, depth = 0.004;
  const MeshPtr m = plane(201, spacing);
  auto volumes = [&](ShapeKind kind) {
    DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), linear()));
    const Contact c = contact_near(*m, Vec3(1.3e-4, -2.1e-4, 0), depth, kind, radius);
    s.set_contacts({&c, 1});
    run(s, 400, 0.01);
    double net = 0, pushed = 0;
    for (const VertexState& v : s.state().vertices) {
      net += v.h * spacing * spacing;
      if (v.h < 0) pushed -= v.h * spacing * spacing;
    }
    return std::pair{net, pushed};
  };
  const auto [net, pushed] = volumes(ShapeKind::VolumeConserving);
  EXPECT_NEAR(pushed, M_PI * radius * radius * depth * 256.0 / 3125.0, 1e-2 * pushed);
  EXPECT_LT(std::abs(net), 1e-3 * pushed);
  // A shape that only pushes in does change the volume (the check can fail).
  const auto [net_w, pushed_w] = volumes(ShapeKind::Wendland);
  EXPECT_GT(std::abs(net_w), 0.5 * pushed_w);
}

// ---------------------------------------------------------------------------
// Normal correction (eq. 3).

TEST(Surface, NormalCorrectionIsTheExactNormalOnAPlane) {
  // On a plane the deformed surface is z = -depth S(r): its unit normal,
  // from central differences of that height, must match eq. (3), and the
  // normals recomputed from the deformed mesh must agree closely.
  const double spacing = 5e-4, radius = 0.02, depth = 0.002;
  const MeshPtr m = plane(121, spacing);
  for (ShapeKind kind : {ShapeKind::Gaussian, ShapeKind::Wendland, ShapeKind::VolumeConserving}) {
    SCOPED_TRACE(int(kind));
    DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), linear()));
    const Contact c = contact_near(*m, Vec3(1e-4, 2e-4, 0), depth, kind, radius);
    s.set_contacts({&c, 1});
    run(s, 300, 0.01);
    const std::vector<Vec3> geo = geometric_normals(s);
    auto z = [&](double x, double y) { return -depth * c.shape.value((Vec3(x, y, 0) - c.point).norm()); };
    double worst_fd = 0, worst_geo = 0, max_tilt = 0;
    const double e = 1e-7;
    for (Index i = 0; i < m->vertex_count(); ++i) {
      const Vec3& p = m->positions[i];
      const double r = (p - c.point).norm();
      if (r > 0.95 * radius || r < 1e-9) continue;  // the Gaussian's cut at R has no derivative
      const Vec3 exact = Vec3(-(z(p.x() + e, p.y()) - z(p.x() - e, p.y())) / (2 * e),
                              -(z(p.x(), p.y() + e) - z(p.x(), p.y() - e)) / (2 * e), 1.0)
                             .normalized();
      worst_fd = std::max(worst_fd, angle(s.deformed_normal(i), exact));
      worst_geo = std::max(worst_geo, angle(s.deformed_normal(i), geo[i]));
      max_tilt = std::max(max_tilt, angle(exact, Vec3::UnitZ()));
    }
    EXPECT_LT(worst_fd, 1e-7);
    EXPECT_GT(max_tilt, 0.05);
    EXPECT_LT(worst_geo, 0.02 * max_tilt);
  }
}

TEST(Surface, NormalCorrectionMatchesRecomputedNormalsOnASphere) {
  // Small deformation of a curved surface: eq. (3) stays close to the normals
  // recomputed geometrically from the deformed positions, and much closer than
  // the undeformed normals are.
  const double R = 0.1, radius = 0.03, depth = 0.001;
  const MeshPtr m = sphere(40000, R);
  for (ShapeKind kind : {ShapeKind::Wendland, ShapeKind::VolumeConserving}) {
    SCOPED_TRACE(int(kind));
    DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), linear()));
    const Contact c = sphere_contact(*m, R, Vec3(0.3, 0.2, 0.93), depth, kind, radius);
    s.set_contacts({&c, 1});
    run(s, 300, 0.01);
    const std::vector<Vec3> geo = geometric_normals(s);
    double worst = 0, worst_uncorrected = 0, sum = 0, sum_uncorrected = 0;
    int count = 0;
    for (Index i = 0; i < m->vertex_count(); ++i) {
      const double r = (m->positions[i] - c.point).norm();
      if (r >= radius) continue;
      const double err = angle(s.deformed_normal(i), geo[i]);
      const double err0 = angle(m->normals[i], geo[i]);
      worst = std::max(worst, err);
      worst_uncorrected = std::max(worst_uncorrected, err0);
      sum += err;
      sum_uncorrected += err0;
      ++count;
    }
    // The shapes tilt normals by up to ~2.1 depth / radius = 0.07 rad. What
    // eq. (3) leaves out is of relative order |h| / R_sphere (the displaced
    // surface is scaled by 1 + h/R) and (r / 2R_sphere)^2 (chord against arc),
    // a few percent here, plus the mesh's own discretisation.
    EXPECT_GT(worst_uncorrected, 0.04);
    EXPECT_LT(worst, 0.1 * worst_uncorrected);
    EXPECT_LT(sum, 0.08 * sum_uncorrected);
  }
}

// ---------------------------------------------------------------------------
// Superposition of contacts.

TEST(Surface, LinearContactsSuperpose) {
  const double R = 0.1, radius = 0.025;
  const MeshPtr m = sphere(10000, R);
  const Contact a = sphere_contact(*m, R, Vec3(0, 0, 1), 0.002, ShapeKind::Wendland, radius);
  const Contact far = sphere_contact(*m, R, Vec3(1, 0, 0.2), 0.003, ShapeKind::VolumeConserving, radius);
  const Contact overlapping = sphere_contact(*m, R, Vec3(0.12, 0.05, 1), 0.0015, ShapeKind::Gaussian, radius);
  ASSERT_GT((a.point - far.point).norm(), 2 * radius);
  ASSERT_LT((a.point - overlapping.point).norm(), 0.6 * radius);

  auto settle = [&](std::vector<Contact> contacts) {
    auto s = std::make_unique<DeformableSurface>(m, MaterialArrays::uniform(m->vertex_count(), linear()));
    s->set_contacts(contacts);
    run(*s, 300, 0.01);
    return s;
  };
  const auto sa = settle({a});
  for (const Contact& b : {far, overlapping}) {
    const auto sb = settle({b});
    const auto both = settle({a, b});
    for (Index i = 0; i < m->vertex_count(); ++i) {
      ASSERT_NEAR(both->state().vertices[i].h, sa->state().vertices[i].h + sb->state().vertices[i].h, 1e-15);
      ASSERT_LT((both->normal_correction(i) - sa->normal_correction(i) - sb->normal_correction(i)).norm(), 1e-15);
    }
  }
}

// ---------------------------------------------------------------------------
// Active set (section III.A): same results as the full step, cost bounded by the field.

// A script of contacts over time: press, slide, two fingers, release.
std::vector<std::vector<Contact>> script(const SurfaceMesh& m, double R) {
  std::vector<std::vector<Contact>> frames;
  for (int n = 0; n < 40; ++n) {
    frames.push_back({sphere_contact(m, R, Vec3(0.1 * n / 40.0, 0, 1), 0.004 * std::min(1.0, n / 10.0),
                                     ShapeKind::Wendland, 0.03)});
  }
  for (int n = 0; n < 25; ++n) {
    frames.push_back({sphere_contact(m, R, Vec3(0.1, 0, 1), 0.004, ShapeKind::VolumeConserving, 0.03),
                      sphere_contact(m, R, Vec3(0, 1, 0.3), 0.002, ShapeKind::Gaussian, 0.02)});
  }
  for (int n = 0; n < 400; ++n) frames.push_back({});
  return frames;
}

// Linear everywhere, with patches of the other two models.
MaterialArrays mixed_materials(const SurfaceMesh& m) {
  MaterialArrays mats = MaterialArrays::uniform(m.vertex_count(), linear());
  for (Index i = 0; i < m.vertex_count(); ++i) {
    const Vec3& p = m.positions[i];
    Material mat = linear();
    if (p.x() > 0.02) mat.model = LocalModelKind::Exponential;
    if (p.y() > 0.05) mat.model = LocalModelKind::Viscoelastic;
    mat.stiffness = 300 + 4000 * std::abs(p.z());  // a smooth stiffness map
    mats.set(i, mat);
  }
  return mats;
}

TEST(Surface, ActiveSetStepEqualsFullStep) {
  const double R = 0.1;
  const MeshPtr m = sphere(6000, R);
  DeformableSurface active(m, mixed_materials(*m));
  DeformableSurface full(m, mixed_materials(*m));
  const auto frames = script(*m, R);
  for (std::size_t n = 0; n < frames.size(); ++n) {
    const double dt = n % 3 == 0 ? 2e-3 : 1e-3;  // changing dt exercises the coefficient cache
    active.set_contacts(frames[n]);
    full.set_contacts(frames[n]);
    active.step(dt);
    full.step_full(dt);
    ASSERT_TRUE(same_bits(active.state(), full.state())) << "frame " << n;
    ASSERT_TRUE(same_bits(active.stream(), full.stream())) << "frame " << n;
    ASSERT_EQ(active.active_count(), full.active_count()) << "frame " << n;
  }
}

// A seeded random sequence of contact sets on a sphere of radius R: 0 to 3
// contacts of every shape kind, random points, depths (some negative) and
// radii, held for a few steps each, with empty stretches so vertices come to
// rest and leave the active set.
std::vector<std::vector<Contact>> random_frames(const SurfaceMesh& m, double R, unsigned seed, int count) {
  std::uint64_t x = seed * 0x9e3779b97f4a7c15ull + 1;
  auto uniform = [&x] {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    return static_cast<double>(x >> 11) * 0x1.0p-53;
  };
  std::vector<std::vector<Contact>> frames;
  while (static_cast<int>(frames.size()) < count) {
    std::vector<Contact> set;
    const int n = uniform() < 0.25 ? 0 : 1 + static_cast<int>(uniform() * 3);
    for (int k = 0; k < n; ++k) {
      const Vec3 dir(2 * uniform() - 1, 2 * uniform() - 1, 2 * uniform() - 1);
      const auto kind = static_cast<ShapeKind>(static_cast<int>(uniform() * 3) % 3);
      const double depth = (uniform() < 0.1 ? -1 : 1) * 0.006 * uniform();
      set.push_back(sphere_contact(m, R, dir.norm() > 1e-3 ? dir : Vec3::UnitZ(), depth, kind, 0.01 + 0.03 * uniform()));
    }
    const int hold = 1 + static_cast<int>(uniform() * (n == 0 ? 30 : 6));
    for (int h = 0; h < hold; ++h) frames.push_back(set);
  }
  return frames;
}

// Every query the haptic tick and the view make gives the same bits on both.
void expect_level(const DeformableSurface& a, const DeformableSurface& b, const std::string& where) {
  ASSERT_TRUE(same_bits(a.state(), b.state())) << where;
  ASSERT_TRUE(same_bits(a.stream(), b.stream())) << where;
  ASSERT_EQ(a.active_count(), b.active_count()) << where;
  ASSERT_EQ(a.contacts().size(), b.contacts().size()) << where;
  for (Index i = 0; i < a.mesh().vertex_count(); ++i) {
    const double fa = a.field_force(i), fb = b.field_force(i);
    ASSERT_EQ(std::memcmp(&fa, &fb, sizeof fa), 0) << where << ", force of vertex " << i;
    const Vec3 ca = a.normal_correction(i), cb = b.normal_correction(i);
    ASSERT_EQ(std::memcmp(ca.data(), cb.data(), sizeof(double) * 3), 0) << where << ", correction of vertex " << i;
  }
}

// Mixed materials, and one plain Linear material (the sweeps' own path,
// with its coefficients held for the whole sweep). The mesh's vertex count is
// not a multiple of step_full's blocks of eight, so its last vertices go by
// themselves.
TEST(Surface, ActiveSetStepEqualsFullStepOnRandomContactSequences) {
  const double R = 0.1;
  const MeshPtr m = sphere(3000, R);
  ASSERT_NE(m->vertex_count() % 8, 0u);
  for (const bool mixed : {true, false}) {
    const MaterialArrays mats = mixed ? mixed_materials(*m) : MaterialArrays::uniform(m->vertex_count(), linear());
    for (unsigned seed : {1u, 2u, 3u}) {
      DeformableSurface active(m, mats);
      DeformableSurface full(m, mats);
      const auto frames = random_frames(*m, R, seed, 300);
      for (std::size_t n = 0; n < frames.size(); ++n) {
        const double dt = n % 7 == 0 ? 2e-3 : 1e-3;
        active.set_contacts(frames[n]);
        full.set_contacts(frames[n]);
        active.step(dt);
        full.step_full(dt);
        expect_level(active, full,
                     std::string(mixed ? "mixed" : "plain") + ", seed " + std::to_string(seed) + ", frame " +
                         std::to_string(n));
        ASSERT_FALSE(HasFatalFailure());
      }
    }
  }
}

// What the two steps leave for the renderer and for the other replica is
// the same too: the dirty ranges (taken every third frame, so that marks
// pile up between uploads), the number of vertices remembered as changed,
// and a replica brought level from each (every fourth frame), which must
// then agree with each other bit for bit and in their own dirty ranges.
// Fails when step_full marks a stream entry dirty, or a vertex changed,
// where step() does not, or misses one.
TEST(Surface, FullStepLeavesTheSameDirtyRangesAndChangesAsTheActiveStep) {
  const double R = 0.1;
  const MeshPtr m = sphere(3000, R);
  for (const bool mixed : {false, true}) {
    const MaterialArrays mats = mixed ? mixed_materials(*m) : MaterialArrays::uniform(m->vertex_count(), linear());
    for (unsigned seed : {11u, 12u}) {
      DeformableSurface active(m, mats), full(m, mats);
      DeformableSurface active_copy(m, mats), full_copy(m, mats);
      const auto frames = random_frames(*m, R, seed, 240);
      std::size_t dirty_frames = 0;
      for (std::size_t n = 0; n < frames.size(); ++n) {
        const std::string where = std::string(mixed ? "mixed" : "plain") + ", seed " + std::to_string(seed) +
                                  ", frame " + std::to_string(n);
        active.set_contacts(frames[n]);
        full.set_contacts(frames[n]);
        active.step(1e-3);
        full.step_full(1e-3);
        ASSERT_EQ(active.changed_count(), full.changed_count()) << where;
        if (n % 3 == 2) {
          const std::vector<IndexRange> a = active.take_dirty_ranges(), f = full.take_dirty_ranges();
          ASSERT_EQ(a, f) << where;
          if (!a.empty()) ++dirty_frames;
        }
        if (n % 4 == 3) {
          active_copy.level_with(active);
          full_copy.level_with(full);
          expect_level(active_copy, full_copy, where + ", levelled copies");
          ASSERT_FALSE(HasFatalFailure());
          ASSERT_EQ(active_copy.take_dirty_ranges(), full_copy.take_dirty_ranges()) << where;
        }
      }
      EXPECT_GT(dirty_frames, 20u) << "the sequence should move the surface between most uploads";
    }
  }
}

// A step's fields (force and normal correction of every vertex) come from
// its contacts alone: a surface that went through a long random sequence of
// contact sets has, after each step, the fields of a new surface given only
// that step's contacts. Fails when a field left by an earlier step, or part
// of one, survives into a later one.
TEST(Surface, FieldsComeFromTheCurrentContactsAlone) {
  const double R = 0.1;
  const MeshPtr m = sphere(3000, R);
  for (const bool mixed : {false, true}) {
    const MaterialArrays mats = mixed ? mixed_materials(*m) : MaterialArrays::uniform(m->vertex_count(), Material{});
    DeformableSurface walked(m, mats);
    const auto frames = random_frames(*m, R, 7u, 240);
    for (std::size_t n = 0; n < frames.size(); ++n) {
      walked.set_contacts(frames[n]);
      walked.step(1e-3);
      if (n % 6 != 5) continue;
      DeformableSurface fresh(m, mats);
      fresh.set_contacts(frames[n]);
      fresh.step(1e-3);
      const std::string where = std::string(mixed ? "mixed" : "uniform") + " materials, frame " + std::to_string(n);
      for (Index i = 0; i < m->vertex_count(); ++i) {
        const double fa = walked.field_force(i), fb = fresh.field_force(i);
        ASSERT_EQ(std::memcmp(&fa, &fb, sizeof fa), 0) << where << ", force of vertex " << i << ": " << fa << " N, "
                                                       << fb << " N from the contacts alone";
        const Vec3 ca = walked.normal_correction(i), cb = fresh.normal_correction(i);
        ASSERT_EQ(std::memcmp(ca.data(), cb.data(), sizeof(double) * 3), 0)
            << where << ", correction of vertex " << i;
      }
    }
  }
}

// The live loop's two replicas: one steps, the other is brought level by
// copying what changed (roles alternating); both must equal a surface that
// made every step itself, after every step, through resets, material edits
// applied to both, edits-only requests and a restored snapshot.
TEST(Surface, LevelWithLeavesBothReplicasEqualToOneThatStepped) {
  const double R = 0.1;
  const MeshPtr m = sphere(3000, R);
  for (unsigned seed : {4u, 5u}) {
    DeformableSurface ref(m, mixed_materials(*m));
    DeformableSurface r0(m, mixed_materials(*m)), r1(m, mixed_materials(*m));
    DeformableSurface* replicas[2] = {&r0, &r1};
    const auto frames = random_frames(*m, R, seed, 400);
    std::size_t most_changed = 0;
    SurfaceState snapshot;
    std::vector<Contact> snapshot_contacts;
    for (std::size_t n = 0; n < frames.size(); ++n) {
      DeformableSurface& src = *replicas[n % 2];
      DeformableSurface& dst = *replicas[1 - n % 2];
      // Edits reach every surface; the source makes the step.
      const bool reset = n % 97 == 50;
      const bool soften = n % 61 == 30;
      Material soft = linear();
      soft.stiffness = 200 + static_cast<double>(n);
      for (DeformableSurface* s : {&ref, &src, &dst}) {
        if (reset) s->reset();
        if (soften) s->set_uniform_material(soft);
      }
      if (n == 120) {
        snapshot = ref.state();
        snapshot_contacts.assign(ref.contacts().begin(), ref.contacts().end());
      }
      if (n == 200) {  // a restored snapshot: the next copy is the whole mesh
        ref.restore(snapshot, snapshot_contacts);
        src.restore(snapshot, snapshot_contacts);
      }
      const double dt = n % 11 == 0 ? 0.0 : (n % 5 == 0 ? 2e-3 : 1e-3);  // 0: an edits-only request
      for (DeformableSurface* s : {&ref, &src}) {
        s->set_contacts(frames[n]);
        if (dt > 0) s->step(dt);
      }
      if (n != 200) most_changed = std::max(most_changed, src.changed_count());
      dst.level_with(src);
      EXPECT_EQ(src.changed_count(), 0u);
      expect_level(ref, src, "seed " + std::to_string(seed) + ", source after frame " + std::to_string(n));
      expect_level(ref, dst, "seed " + std::to_string(seed) + ", copy after frame " + std::to_string(n));
      ASSERT_FALSE(HasFatalFailure());
      // The copy's dirty ranges cover exactly the stream entries that changed
      // in it; the source's are the step's own.
      src.take_dirty_ranges();
    }
    // Only what changed was copied: the fields cover a small part of the sphere.
    EXPECT_LT(most_changed, m->vertex_count() / 2);
    EXPECT_GT(most_changed, 0u);
  }
}

// A step whose contacts are the last step's, bit for bit, reuses the fields
// it built (a probe held still); every edit the fields depend on must make
// the next step build them again. Checked against a surface made afresh
// before every step (so it has no fields to reuse): the same materials,
// tissue map and drives, restored to the state before the step with the
// step's contacts. The stepping surfaces are a pair of replicas, roles
// alternating as in the live loop, with every edit reaching both.
TEST(Surface, HeldContactsStepAsIfTheirFieldsWereRebuilt) {
  const double R = 0.1;
  const MeshPtr m = sphere(3000, R);
  const Index n_vertices = static_cast<Index>(m->vertex_count());
  // Drives on the vertices of one cap, so some lie inside the contacts' fields.
  std::vector<Index> drive_vertices;
  std::vector<std::array<float, 4>> drive_weights;
  for (Index i = 0; i < n_vertices; ++i) {
    if (m->positions[i].z() > 0.07) {
      drive_vertices.push_back(i);
      drive_weights.push_back({0.5f, 0.25f, 0.0f, 0.0f});
    }
  }
  std::vector<std::uint16_t> tissue_of(m->vertex_count());
  std::vector<float> scale(m->vertex_count());
  for (Index i = 0; i < n_vertices; ++i) {
    tissue_of[i] = m->positions[i].x() > 0 ? 1 : 0;
    scale[i] = 1.0f + 0.5f * static_cast<float>(std::abs(m->positions[i].y()) / R);
  }
  Material hertz = linear();
  hertz.model = LocalModelKind::Hertz;
  hertz.hertz = 2e4;
  const std::vector<Material> tissues = {linear(), hertz};

  DeformableSurface r0(m, mixed_materials(*m)), r1(m, mixed_materials(*m));
  DeformableSurface* replicas[2] = {&r0, &r1};
  // Held sets, so most steps reuse their fields.
  const auto frames = random_frames(*m, R, 7u, 400);
  bool map = false, driven = false;
  std::array<double, 4> drive{};
  std::size_t held = 0;
  for (std::size_t n = 0; n < frames.size(); ++n) {
    DeformableSurface& src = *replicas[n % 2];
    DeformableSurface& dst = *replicas[1 - n % 2];
    held += n > 0 && frames[n].size() == frames[n - 1].size() &&
            std::equal(frames[n].begin(), frames[n].end(), frames[n - 1].begin(),
                       [](const Contact& a, const Contact& b) { return a.point == b.point && a.depth == b.depth; });
    // The edits, each on a frame whose contacts are held from the last one.
    for (DeformableSurface* s : {&src, &dst}) {
      if (n % 53 == 20) {
        Material soft = linear();
        soft.stiffness = 250 + static_cast<double>(n);
        s->set_uniform_material(soft);
        map = false;
      }
      if (n % 53 == 30 && !frames[n].empty()) s->set_material(frames[n].front().vertex, hertz);
      if (n % 53 == 40) {
        s->set_tissue_map(tissues, tissue_of, scale);
        map = true;
      }
      if (n == 100) {
        s->set_drives(drive_vertices, drive_weights);
        driven = true;
      }
      if (n % 13 == 5) drive = {0.001 * static_cast<double>(n % 4), -0.0005, 0, 0};
      s->set_drive_values(drive);
      if (n % 97 == 60) s->reset();
    }
    // The reference: a new surface with the same materials and drives, at
    // the state before the step, with the step's contacts.
    DeformableSurface fresh(m, src.materials());
    if (map) fresh.set_tissue_map(tissues, tissue_of, scale);
    if (driven) fresh.set_drives(drive_vertices, drive_weights);
    fresh.set_drive_values(drive);
    fresh.restore(src.state(), frames[n]);
    const double dt = n % 5 == 0 ? 2e-3 : 1e-3;
    fresh.step(dt);
    src.set_contacts(frames[n]);
    src.step(dt);
    dst.level_with(src);
    expect_level(fresh, src, "source after frame " + std::to_string(n));
    expect_level(fresh, dst, "copy after frame " + std::to_string(n));
    ASSERT_FALSE(HasFatalFailure());
  }
  EXPECT_GT(held, 200u) << "the frames hold their contacts";
}

// Under held contacts a vertex's velocity decays geometrically towards its
// rest value. The step takes subnormal values as zero (they cost a microcode
// assist per operation on x86), so no state ever holds one: the velocity
// reaches zero instead of passing through the subnormal range, which it did
// about 340 steps of 2 ms (0.7 s) after the contacts were held still,
// before the step flushed them. The caller's floating-point mode is left
// as it was.
TEST(Surface, HeldContactsNeverLeaveASubnormalInTheState) {
  const double R = 0.1;
  const MeshPtr m = sphere(2000, R);
  const std::vector<Contact> held = {sphere_contact(*m, R, Vec3(0, 0, 1), 0.004, ShapeKind::Wendland, 0.03),
                                     sphere_contact(*m, R, Vec3(1, 0, 0.2), 0.002, ShapeKind::Wendland, 0.02)};
  for (const bool mixed : {false, true}) {
    const std::string which = mixed ? "mixed materials" : "one Linear material";
    DeformableSurface active = mixed ? DeformableSurface(m, mixed_materials(*m))
                                     : DeformableSurface(m, MaterialArrays::uniform(m->vertex_count(), linear()));
    DeformableSurface full = mixed ? DeformableSurface(m, mixed_materials(*m))
                                   : DeformableSurface(m, MaterialArrays::uniform(m->vertex_count(), linear()));
    active.set_contacts(held);
    full.set_contacts(held);
#if defined(__x86_64__)
    const unsigned mode = _mm_getcsr();
#endif
    std::size_t stopped = 0;
    for (int n = 0; n < 1500; ++n) {
      active.step(0.002);
      full.step_full(0.002);
#if defined(__x86_64__)
      ASSERT_EQ(_mm_getcsr(), mode) << which << ": the step left the caller's floating-point mode changed";
#endif
      for (Index i = 0; i < m->vertex_count(); ++i) {
        const VertexState& st = active.state().vertices[i];
        for (const double x : {st.h, st.v, st.q}) {
          ASSERT_NE(std::fpclassify(x), FP_SUBNORMAL) << which << ": vertex " << i << " after step " << n + 1;
        }
      }
      ASSERT_TRUE(same_bits(active.state(), full.state())) << which << ": step " << n + 1;
    }
    for (Index i = 0; i < m->vertex_count(); ++i) {
      stopped += active.field_force(i) != 0 && active.state().vertices[i].v == 0.0;
    }
    EXPECT_GT(stopped, 10u) << which << ": vertices held in a field should have come to an exact stop";
  }
}

TEST(Surface, LevelWithMarksExactlyTheCopiedStreamChangesDirty) {
  const double R = 0.1;
  const MeshPtr m = sphere(3000, R);
  DeformableSurface a(m, mixed_materials(*m)), b(m, mixed_materials(*m));
  a.take_dirty_ranges();
  b.take_dirty_ranges();
  const auto frames = random_frames(*m, R, 9, 120);
  for (std::size_t n = 0; n < frames.size(); ++n) {
    const std::vector<float> before(b.stream().begin(), b.stream().end());
    a.set_contacts(frames[n]);
    a.step(1e-3);
    b.level_with(a);
    a.take_dirty_ranges();
    std::vector<char> dirty(m->vertex_count(), 0);
    for (const IndexRange& r : b.take_dirty_ranges())
      for (Index i = r.begin; i < r.end; ++i) dirty[i] = 1;
    for (Index i = 0; i < m->vertex_count(); ++i) {
      const bool changed = std::memcmp(&before[4 * i], &b.stream()[4 * i], 4 * sizeof(float)) != 0;
      ASSERT_EQ(static_cast<bool>(dirty[i]), changed) << "frame " << n << ", vertex " << i;
    }
  }
}

TEST(Surface, LevelWithRejectsAnotherMesh) {
  const MeshPtr m = sphere(500, 0.1), other = sphere(500, 0.1);
  DeformableSurface a(m, mixed_materials(*m)), b(other, mixed_materials(*other));
  try {
    b.level_with(a);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "level_with: the source surface has another mesh object");
  }
}

TEST(Surface, WarmLevelWithAllocatesNothing) {
  const double R = 0.1;
  const MeshPtr m = sphere(4000, R);
  DeformableSurface r0(m, mixed_materials(*m)), r1(m, mixed_materials(*m));
  DeformableSurface* replicas[2] = {&r0, &r1};
  const auto frames = script(*m, R);
  for (int pass = 0; pass < 2; ++pass) {
    long allocations = 0;
    for (std::size_t n = 0; n < frames.size(); ++n) {
      DeformableSurface& src = *replicas[n % 2];
      DeformableSurface& dst = *replicas[1 - n % 2];
      src.set_contacts(frames[n]);
      src.step(1e-3);
      test::start_counting_allocations();
      dst.level_with(src);
      allocations += test::stop_counting_allocations();
    }
    if (pass == 1) {
      EXPECT_EQ(allocations, 0);
    }
  }
}

TEST(Surface, ActiveCountIsBoundedByTheFieldSupport) {
  const double R = 0.1, radius = 0.02;
  const MeshPtr m = sphere(20000, R);
  DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), linear()));
  EXPECT_EQ(s.active_count(), 0u);
  const Contact c = sphere_contact(*m, R, Vec3(0.2, -0.4, 0.9), 0.003, ShapeKind::Wendland, radius);
  std::size_t support = 0;
  for (const Vec3& p : m->positions) support += (p - c.point).norm() < radius;
  ASSERT_GT(support, 50u);
  ASSERT_LT(support, m->vertex_count() / 20);

  s.set_contacts({&c, 1});
  for (int n = 0; n < 50; ++n) {
    s.step(1e-3);
    EXPECT_EQ(s.active_count(), support);
  }
  // Released: the field's vertices ring down, come to rest exactly and leave.
  s.set_contacts({});
  int steps = 0;
  while (s.active_count() > 0 && steps < 100000) {
    s.step(1e-3);
    EXPECT_LE(s.active_count(), support);
    ++steps;
  }
  EXPECT_EQ(s.active_count(), 0u);
  for (const VertexState& v : s.state().vertices) {
    ASSERT_EQ(v.h, 0.0);
    ASSERT_EQ(v.v, 0.0);
    ASSERT_EQ(v.q, 0.0);
  }
  for (float f : s.stream()) ASSERT_EQ(f, 0.0f);
}

// ---------------------------------------------------------------------------
// Propagation (section III.B).

TEST(Surface, TopologicalAndDistanceNormalAgreeOnASphere) {
  // On a sphere each field's support is one patch around its contact vertex,
  // so the breadth-first visit must reach every vertex the scan of all
  // vertices finds, and no other, whichever way it queues them: the mixed
  // materials call each vertex's model, one Linear material takes the
  // visit's inline path.
  const double R = 0.1;
  const MeshPtr m = sphere(8000, R);
  for (const bool mixed : {true, false}) {
    SCOPED_TRACE(mixed ? "mixed materials" : "one Linear material");
    const MaterialArrays mats = mixed ? mixed_materials(*m) : MaterialArrays::uniform(m->vertex_count(), linear());
    SurfaceOptions bfs_options;
    bfs_options.propagation = Propagation::Topological;
    SurfaceOptions scan_options;
    scan_options.propagation = Propagation::DistanceNormal;
    DeformableSurface bfs(m, mats, bfs_options);
    DeformableSurface scan(m, mats, scan_options);
    const auto frames = script(*m, R);
    std::size_t in_field = 0;
    for (std::size_t n = 0; n < 120; ++n) {
      bfs.set_contacts(frames[n]);
      scan.set_contacts(frames[n]);
      bfs.step(1e-3);
      scan.step(1e-3);
      for (Index i = 0; i < m->vertex_count(); ++i) {
        ASSERT_EQ(bfs.field_force(i), scan.field_force(i)) << "frame " << n << ", vertex " << i;
        ASSERT_EQ(bfs.normal_correction(i), scan.normal_correction(i)) << "frame " << n << ", vertex " << i;
        in_field += scan.field_force(i) != 0.0;
      }
      ASSERT_TRUE(same_bits(bfs.state(), scan.state())) << "frame " << n;
    }
    EXPECT_GT(in_field, 1000u);  // the fields were not empty
  }
}

TEST(Surface, DistanceNormalSkipsVerticesFacingAway) {
  // A field wider than the whole sphere: by distance every vertex is inside,
  // the normal test keeps only those with N0 . n >= min_normal_cosine.
  const double R = 0.05;
  const MeshPtr m = sphere(3000, R);
  const Contact c = sphere_contact(*m, R, Vec3(0, 0, 1), 0.001, ShapeKind::Wendland, 0.12);
  for (double min_cos : {-1.0, 0.0, 0.5}) {
    SurfaceOptions o;
    o.propagation = Propagation::DistanceNormal;
    o.min_normal_cosine = min_cos;
    DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), linear()), o);
    s.set_contacts({&c, 1});
    s.step(1e-3);
    std::size_t affected = 0;
    for (Index i = 0; i < m->vertex_count(); ++i) {
      const bool expected = m->normals[i].dot(c.normal) >= min_cos;
      ASSERT_EQ(s.field_force(i) != 0.0, expected) << "vertex " << i << " min_cos " << min_cos;
      affected += expected;
    }
    EXPECT_EQ(s.active_count(), affected);
  }
}

TEST(Surface, TopologicalContactWithoutSeedFallsBackToTheScan) {
  const double R = 0.1;
  const MeshPtr m = sphere(4000, R);
  Contact c = sphere_contact(*m, R, Vec3(1, 1, 1), 0.002, ShapeKind::Wendland, 0.03);
  DeformableSurface seeded(m, MaterialArrays::uniform(m->vertex_count(), linear()));
  DeformableSurface unseeded(m, MaterialArrays::uniform(m->vertex_count(), linear()));
  seeded.set_contacts({&c, 1});
  c.vertex = kNoIndex;
  unseeded.set_contacts({&c, 1});
  seeded.step(1e-3);
  unseeded.step(1e-3);
  EXPECT_GT(seeded.active_count(), 0u);
  EXPECT_TRUE(same_bits(seeded.state(), unseeded.state()));
}

// ---------------------------------------------------------------------------
// Determinism and snapshots.

TEST(Surface, StepsAreDeterministicAndSnapshotsRoundTrip) {
  const double R = 0.1;
  const MeshPtr m = sphere(5000, R);
  const auto frames = script(*m, R);
  DeformableSurface a(m, mixed_materials(*m));
  DeformableSurface b(m, mixed_materials(*m));
  // Snapshots while two contacts press, and after release while vertices ring down.
  const std::size_t snap_at[] = {50, 70};
  SurfaceState snapshots[2];
  for (std::size_t n = 0; n < frames.size(); ++n) {
    a.set_contacts(frames[n]);
    b.set_contacts(frames[n]);
    a.step(1e-3);
    b.step(1e-3);
    ASSERT_TRUE(same_bits(a.state(), b.state())) << "frame " << n;
    ASSERT_TRUE(same_bits(a.stream(), b.stream())) << "frame " << n;
    for (int k = 0; k < 2; ++k) {
      if (n == snap_at[k]) snapshots[k] = a.state();
    }
  }
  ASSERT_GT(a.state().time, 0.0);
  // A fresh surface restored from a snapshot continues bit-identically.
  for (int k = 0; k < 2; ++k) {
    SCOPED_TRACE(k);
    DeformableSurface c(m, mixed_materials(*m));
    c.set_state(snapshots[k]);
    EXPECT_TRUE(same_bits(c.state(), snapshots[k]));
    EXPECT_GT(c.active_count(), 0u);
    for (std::size_t n = snap_at[k] + 1; n < frames.size(); ++n) {
      c.set_contacts(frames[n]);
      c.step(1e-3);
    }
    EXPECT_TRUE(same_bits(c.state(), a.state()));
    EXPECT_TRUE(same_bits(c.stream(), a.stream()));
    EXPECT_EQ(c.active_count(), a.active_count());
  }
}

TEST(Surface, SetStateRejectsSnapshotsThatDoNotFit) {
  const MeshPtr m = sphere(500, 0.1);
  DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), linear()));
  SurfaceState wrong;
  wrong.vertices.resize(3);
  try {
    s.set_state(wrong);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "set_state: the snapshot has 3 vertices but the mesh has " +
                                         std::to_string(m->vertex_count()));
  }
  SurfaceState bad = s.state();
  bad.vertices[7].v = std::nan("");
  try {
    s.set_state(bad);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "set_state: vertex 7 has a non-finite state");
  }
}

// ---------------------------------------------------------------------------
// The (nx, ny, nz, h) stream of section IV.

TEST(Surface, DirtyRangesCoverExactlyTheChangedVertices) {
  const double R = 0.1;
  const MeshPtr m = sphere(6000, R);
  DeformableSurface s(m, mixed_materials(*m));
  const Index count = static_cast<Index>(m->vertex_count());
  // The first upload covers the whole mesh; then nothing until something moves.
  const auto first = s.take_dirty_ranges();
  ASSERT_EQ(first.size(), 1u);
  EXPECT_EQ(first[0], (IndexRange{0, count}));
  s.step(1e-3);
  EXPECT_TRUE(s.take_dirty_ranges().empty());

  const auto frames = script(*m, R);
  std::vector<float> before(s.stream().begin(), s.stream().end());
  for (std::size_t n = 0; n < frames.size(); ++n) {
    s.set_contacts(frames[n]);
    s.step(1e-3);
    const auto ranges = s.take_dirty_ranges();
    // Sorted, disjoint and merged wherever contiguous.
    for (std::size_t k = 0; k < ranges.size(); ++k) {
      ASSERT_LT(ranges[k].begin, ranges[k].end);
      if (k > 0) {
        ASSERT_GT(ranges[k].begin, ranges[k - 1].end);
      }
    }
    // Exactly the vertices whose four floats changed (compared bit by bit).
    std::vector<bool> covered(count, false);
    for (const IndexRange& r : ranges) {
      for (Index i = r.begin; i < r.end; ++i) covered[i] = true;
    }
    const std::span<const float> now = s.stream();
    for (Index i = 0; i < count; ++i) {
      const bool changed = std::memcmp(&before[4 * i], &now[4 * i], 4 * sizeof(float)) != 0;
      ASSERT_EQ(covered[i], changed) << "frame " << n << " vertex " << i;
    }
    // The stream holds the float32 correction and height of every vertex.
    for (Index i = 0; i < count; ++i) {
      const Vec3 corr = s.normal_correction(i);
      ASSERT_EQ(now[4 * i + 0], static_cast<float>(corr.x()));
      ASSERT_EQ(now[4 * i + 1], static_cast<float>(corr.y()));
      ASSERT_EQ(now[4 * i + 2], static_cast<float>(corr.z()));
      ASSERT_EQ(now[4 * i + 3], static_cast<float>(s.state().vertices[i].h));
    }
    before.assign(now.begin(), now.end());
  }
  // set_state marks everything dirty again.
  SurfaceState rest;
  rest.vertices.assign(count, VertexState{});
  s.set_state(rest);
  const auto all = s.take_dirty_ranges();
  ASSERT_EQ(all.size(), 1u);
  EXPECT_EQ(all[0], (IndexRange{0, count}));

  // A vertex can leave a field without moving (restored to rest under a
  // contact, then released): its correction in the stream must still clear.
  const Contact c = sphere_contact(*m, R, Vec3(0, 0, 1), 0.003, ShapeKind::Wendland, 0.03);
  s.set_contacts({&c, 1});
  s.step(1e-3);
  s.set_state(rest);
  s.take_dirty_ranges();
  std::size_t with_correction = 0;
  for (Index i = 0; i < count; ++i) with_correction += s.normal_correction(i) != Vec3::Zero();
  ASSERT_GT(with_correction, 50u);
  s.set_contacts({});
  s.step(1e-3);
  std::size_t dirty = 0;
  for (const IndexRange& r : s.take_dirty_ranges()) dirty += r.end - r.begin;
  EXPECT_EQ(dirty, with_correction);
  for (float f : s.stream()) ASSERT_EQ(f, 0.0f);
}

TEST(Surface, ResetReturnsEveryVertexToRest) {
  const double R = 0.1;
  const MeshPtr m = sphere(3000, R);
  DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), linear()));
  const Contact c = sphere_contact(*m, R, Vec3(0, 0, 1), 0.003, ShapeKind::Wendland, 0.03);
  s.set_contacts({&c, 1});
  run(s, 20, 1e-3);
  s.take_dirty_ranges();
  ASSERT_GT(s.active_count(), 0u);
  s.reset();
  EXPECT_EQ(s.active_count(), 0u);
  EXPECT_TRUE(s.contacts().empty());
  EXPECT_EQ(s.state().time, 0.0);
  for (Index i = 0; i < m->vertex_count(); ++i) {
    ASSERT_EQ(s.state().vertices[i].h, 0.0);
    ASSERT_EQ(s.state().vertices[i].v, 0.0);
    ASSERT_EQ(s.field_force(i), 0.0);
    ASSERT_EQ(s.normal_correction(i), Vec3::Zero());
  }
  for (float f : s.stream()) ASSERT_EQ(f, 0.0f);
  // Only the vertices of the contact's field were touched.
  std::size_t dirty = 0;
  for (const IndexRange& r : s.take_dirty_ranges()) dirty += r.end - r.begin;
  std::size_t support = 0;
  for (const Vec3& p : m->positions) support += (p - c.point).norm() < 0.03;
  EXPECT_EQ(dirty, support);
}

// ---------------------------------------------------------------------------
// Materials, queries and bad input.

// Height (m) and velocity (m/s) at time t of m h'' + b h' + k h = f from
// rest, underdamped (the closed form; b^2 < 4 k m).
std::pair<double, double> underdamped_from_rest(const Material& mat, double f, double t) {
  const double w0 = std::sqrt(mat.stiffness / mat.mass);
  const double zeta = mat.damping / (2 * std::sqrt(mat.stiffness * mat.mass));
  const double wd = w0 * std::sqrt(1 - zeta * zeta);
  const double decay = std::exp(-zeta * w0 * t);
  const double h = f / mat.stiffness * (1 - decay * (std::cos(wd * t) + zeta * w0 / wd * std::sin(wd * t)));
  const double v = f / mat.stiffness * w0 * w0 / wd * decay * std::sin(wd * t);
  return {h, v};
}

// With two Linear materials on one surface (and with one), every vertex in
// the field moves as its own material's oscillator under its field force.
TEST(Surface, EachVertexStepsWithItsOwnMaterial) {
  const MeshPtr m = plane(41, 1e-3);
  Material heavy = linear();
  heavy.mass = 2e-3;
  heavy.damping = 1.5;
  heavy.stiffness = 2000;
  for (bool mixed : {false, true}) {
    MaterialArrays mats = MaterialArrays::uniform(m->vertex_count(), linear());
    DeformableSurface s(m, mats);
    if (mixed) {
      for (Index i = 0; i < m->vertex_count(); ++i)
        if (m->positions[i].x() > 0) s.set_material(i, heavy);
    }
    const Contact c = contact_near(*m, Vec3::Zero(), 0.002, ShapeKind::Wendland, 0.01);
    s.set_contacts({&c, 1});
    const double dt = 1e-3;
    int checked_heavy = 0, checked_light = 0;
    for (int n = 1; n <= 5; ++n) {
      s.step(dt);
      for (Index i = 0; i < m->vertex_count(); ++i) {
        const double f = s.field_force(i);
        if (f == 0) continue;
        const bool is_heavy = mixed && m->positions[i].x() > 0;
        const auto [h, v] = underdamped_from_rest(is_heavy ? heavy : linear(), f, n * dt);
        ASSERT_NEAR(s.state().vertices[i].h, h, 1e-12 * std::abs(f / 500) + 1e-15) << "vertex " << i << ", step " << n;
        ASSERT_NEAR(s.state().vertices[i].v, v, 1e-9 * std::abs(f / 500) + 1e-15) << "vertex " << i << ", step " << n;
        ++(is_heavy ? checked_heavy : checked_light);
      }
    }
    EXPECT_GT(checked_light, 100);
    if (mixed) {
      EXPECT_GT(checked_heavy, 100);
    }
  }
}

TEST(Surface, MaterialChangesTakeEffectAtTheNextStep) {
  const MeshPtr m = plane(41, 1e-3);
  DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), linear()));
  const Contact c = contact_near(*m, Vec3::Zero(), 0.002, ShapeKind::Wendland, 0.01);
  s.set_contacts({&c, 1});
  s.step(1e-3);
  const Index v = c.vertex;
  EXPECT_NEAR(s.field_force(v), 500.0 * -0.002, 1e-12);  // k t at the centre, S(0) = 1
  Material stiff = linear();
  stiff.stiffness = 2000;
  s.set_material(v, stiff);
  EXPECT_EQ(s.materials().at(v), stiff);
  s.step(1e-3);
  EXPECT_NEAR(s.field_force(v), 2000.0 * -0.002, 1e-12);
  // Deformed position and normal follow eqs. (2) and (3).
  const Vec3 p = s.deformed_position(v);
  EXPECT_NEAR(p.z(), s.state().vertices[v].h, 1e-18);
  EXPECT_NEAR(s.deformed_normal(v).norm(), 1.0, 1e-15);
}

TEST(Surface, BadConstructionIsRejectedWithExactMessages) {
  const MeshPtr m = sphere(500, 0.1);
  const std::size_t n = m->vertex_count();
  auto message = [](auto&& make) -> std::string {
    try {
      make();
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "no exception";
  };
  EXPECT_EQ(message([&] { DeformableSurface(nullptr, MaterialArrays{}); }), "DeformableSurface: the mesh is null");
  auto raw = std::make_shared<SurfaceMesh>();
  raw->positions = {Vec3::Zero(), Vec3::UnitX(), Vec3::UnitY()};
  raw->triangles = {{0, 1, 2}};
  EXPECT_EQ(message([&] { DeformableSurface(raw, MaterialArrays::uniform(3, linear())); }),
            "DeformableSurface: the mesh has 3 vertices but 0 normals (finalize it)");
  EXPECT_EQ(message([&] { DeformableSurface(m, MaterialArrays::uniform(n - 1, linear())); }),
            "materials: array 'model' has " + std::to_string(n - 1) + " entries, expected " + std::to_string(n));
  SurfaceOptions o;
  o.rest_threshold = -1;
  EXPECT_EQ(message([&] { DeformableSurface(m, MaterialArrays::uniform(n, linear()), o); }),
            "SurfaceOptions: rest_threshold must be non-negative and finite, got -1 m");
  o = {};
  o.min_normal_cosine = 2;
  EXPECT_EQ(message([&] { DeformableSurface(m, MaterialArrays::uniform(n, linear()), o); }),
            "SurfaceOptions: min_normal_cosine must be in [-1, 1], got 2");
  DeformableSurface s(m, MaterialArrays::uniform(n, linear()));
  Material bad = linear();
  bad.mass = -1;
  EXPECT_EQ(message([&] { s.set_material(4, bad); }), "material of vertex 4: mass must be positive and finite, got -1 kg");
  EXPECT_EQ(message([&] { s.set_material(Index(n), linear()); }),
            "set_material: vertex " + std::to_string(n) + " is out of range (the mesh has " + std::to_string(n) +
                " vertices)");
}

TEST(Surface, WarmStepsAllocateNothing) {
  const double R = 0.1;
  const MeshPtr m = sphere(4000, R);
  DeformableSurface s(m, mixed_materials(*m));
  const auto frames = script(*m, R);
  // First pass grows the buffers; the second, identical pass must not allocate.
  for (int pass = 0; pass < 2; ++pass) {
    long allocations = 0;
    for (const auto& frame : frames) {
      s.set_contacts(frame);
      test::start_counting_allocations();
      s.step(1e-3);
      allocations += test::stop_counting_allocations();
    }
    if (pass == 1) {
      EXPECT_EQ(allocations, 0);
    }
    s.reset();
  }
}

// The surface asks for huge pages (core/huge_pages.h) for the large arrays
// a tick and a step read at random: its mesh's and its own. Checked where
// the kernel collapses a scratch array of the same size on request.
TEST(DeformableSurface, TheLargeArraysOfTheSurfaceAndItsMeshAreInHugePages) {
  const MeshPtr m = sphere(400000, 0.1);  // positions and normals 9.6 MB, the state 9.6 MB
  const std::vector<double> scratch(m->vertex_count() * 3, 1.0);
  if (core::prefer_huge_pages(scratch).collapsed == 0) {
    GTEST_SKIP() << "the kernel collapsed nothing here (it needs Linux 6.1, free huge pages and a THP setting "
                    "other than 'never'; transparent huge pages are '"
                 << test::thp_setting() << "'), so there is nothing to check";
  }
  const DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), linear()));
  auto check = [](const char* what, const void* data, std::size_t bytes) {
    const std::size_t whole = test::whole_huge_pages(data, bytes);
    ASSERT_GE(whole, 2 * core::kHugePageBytes) << what;
    const std::uintptr_t first = test::first_whole_huge_page(data);
    const long kb = test::huge_kb_of_mapping_holding(first, first + whole);
    EXPECT_GE(kb, 0) << what << ": no one mapping holds its whole huge pages (none advised)";
    EXPECT_GE(static_cast<std::size_t>(std::max(kb, 0L)) * 1024, whole) << what;
  };
  check("the mesh's positions", m->positions.data(), m->positions.size() * sizeof(Vec3));
  check("the mesh's normals", m->normals.data(), m->normals.size() * sizeof(Vec3));
  check("the mesh's triangles", m->triangles.data(), m->triangles.size() * sizeof(mesh::Triangle));
  check("the state", s.state().vertices.data(), s.state().vertices.size() * sizeof(VertexState));
  check("the stream", s.stream().data(), s.stream().size() * sizeof(float));
}

}  // namespace
}  // namespace palpa::deform
