// Deep scripted presses through the haptic tick and the deformation step, in
// one thread (haptic tick at 1 kHz, deformation step every tick or every
// second tick), with the workbench's material: while the probe is inside,
// the contact holds (the god-object proxy of collision::track_contact), the
// depth is the press distance along the normal and the force grows
// monotonically with it up to the device clamp, at three times the clamp
// depth and through thin organs.

#include "haptics/probe_tick.h"
#include "common/test_support.h"
#include "mesh/io.h"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace palpa::haptics {
namespace {

// The workbench defaults (app/gui/workbench.h MaterialSettings).
constexpr double kStiffness = 200.0;  // N/m
constexpr double kDamping = 2.0;      // N s/m
constexpr double kMass = 1e-3;        // kg
constexpr double kRadius = 0.025;     // Wendland support, m
constexpr double kFriction = 0.2;
constexpr double kMaxForce = 8.0;     // N
constexpr double kTick = 1e-3;        // s (1 kHz)

struct Scene {
  std::shared_ptr<const mesh::SurfaceMesh> mesh;
  std::unique_ptr<deform::DeformableSurface> surface;
  std::unique_ptr<collision::VertexTree> tree;
  double stiffness = kStiffness;
};

// Loads an organ the way the application does (cleaned, largest component,
// scaled to metres) with a uniform linear material of the given stiffness.
Scene load(const std::filesystem::path& path, double unit_m, double stiffness = kStiffness) {
  mesh::LoadOptions opt;
  opt.unit_m = unit_m;
  opt.keep_largest_component = true;
  Scene s;
  s.mesh = std::make_shared<const mesh::SurfaceMesh>(mesh::load_mesh(path, opt));
  deform::Material m;
  m.model = deform::LocalModelKind::Linear;
  m.stiffness = stiffness;
  m.damping = kDamping;
  m.mass = kMass;
  s.stiffness = stiffness;
  s.surface = std::make_unique<deform::DeformableSurface>(
      s.mesh, deform::MaterialArrays::uniform(s.mesh->vertex_count(), m));
  s.tree = std::make_unique<collision::VertexTree>(s.mesh->positions);
  return s;
}

Scene default_organ(double stiffness = kStiffness) {
  return load(test::project_data_dir() / "default_organ.ply", 1.0, stiffness);
}

ForceParams force_params() {
  ForceParams fp;
  fp.friction = kFriction;
  fp.max_force = kMaxForce;
  return fp;
}

deform::ShapeFunction wendland() {
  deform::ShapeFunction shape;
  shape.kind = deform::ShapeKind::Wendland;
  shape.radius = kRadius;
  return shape;
}

// One tick of the single-threaded session: the haptic tick, the contact
// handed to the surface, and the deformation step every `step_every` ticks.
struct Session {
  Scene& scene;
  int step_every = 1;
  long tick_count = 0;
  ProbeMemory memory;

  ProbeOutput tick(const ProbeInput& in) {
    ProbeOutput out;
    haptic_tick(*scene.surface, *scene.tree, std::span(&in, 1), std::span(&memory, 1), std::span(&out, 1),
                force_params(), wendland());
    if (out.in_contact)
      scene.surface->set_contacts(std::span(&out.contact, 1));
    else
      scene.surface->set_contacts({});
    if (++tick_count % step_every == 0) scene.surface->step(step_every * kTick);
    return out;
  }
};

// A press along the inward normal of vertex v, from 2 mm above the surface
// to depth_max (m) at constant speed over `ticks` ticks.
struct Sample {
  double press = 0;  // m below the undeformed surface along the vertex normal
  ProbeOutput out;
};

std::vector<Sample> press_along_normal(Scene& s, Index v, double depth_max, int ticks, int step_every) {
  s.surface->reset();
  Session session{s, step_every, 0, {}};
  const Vec3 p = s.mesh->positions[v], n = s.mesh->normals[v];
  const double start = -0.002;
  const double speed = (depth_max - start) / (ticks * kTick);  // m/s
  std::vector<Sample> samples;
  samples.reserve(ticks + 1);
  for (int k = 0; k <= ticks; ++k) {
    const double d = start + (depth_max - start) * k / ticks;
    const ProbeInput in{p - d * n, -speed * n};
    samples.push_back({d, session.tick(in)});
  }
  return samples;
}

// The checks of a normal press: in contact on every tick once the probe is
// 0.1 mm below the surface, depth equal to the press distance, the normal
// reaction of the linear model k depth + b speed, |F| > 0 and non-decreasing
// until it reaches the clamp, then at the clamp. Returns the failures seen.
int check_press(const Scene& s, const std::vector<Sample>& samples, double speed, const std::string& what) {
  int failures = 0;
  double last_force = 0, last_fn = 0;
  bool started = false;
  for (const Sample& smp : samples) {
    const ProbeOutput& o = smp.out;
    if (smp.press < 1e-4) continue;
    const double f = o.force.norm();
    const bool ok_contact = o.in_contact && f > 0;
    // The proxy stays where the press began: depth = press distance.
    const bool ok_depth = std::abs(o.height.depth - smp.press) <= 1e-9;
    const bool ok_fn = std::abs(o.normal_reaction - (s.stiffness * smp.press + kDamping * speed)) <= 1e-6;
    // Monotone up to the clamp (round-off of the clamp aside).
    const bool ok_mono = !started || (f >= last_force - 1e-12 && o.normal_reaction >= last_fn);
    const bool ok_clamp = f <= kMaxForce * (1 + 1e-12);
    if (!(ok_contact && ok_depth && ok_fn && ok_mono && ok_clamp)) {
      if (++failures <= 3)
        ADD_FAILURE() << what << ": at " << 1e3 * smp.press << " mm: in_contact " << o.in_contact << ", depth "
                      << 1e3 * o.height.depth << " mm, Fn " << o.normal_reaction << " N, |F| " << f
                      << " N (last " << last_force << " N), path " << int(o.path);
    }
    started = true;
    last_force = f;
    last_fn = o.normal_reaction;
  }
  // Three times the clamp depth reaches the clamp.
  EXPECT_NEAR(samples.back().out.force.norm(), kMaxForce, 1e-9) << what;
  return failures;
}

// Presses at `count` vertices spread over the mesh, to three times the clamp depth.
void press_everywhere(Scene& s, int count, int step_every, const std::string& what) {
  const double clamp_depth = kMaxForce / s.stiffness;  // m
  const double depth_max = 3 * clamp_depth;
  const int ticks = 2000;
  const double speed = (depth_max + 0.002) / (ticks * kTick);
  int failed_presses = 0;
  const std::size_t n = s.mesh->vertex_count();
  for (int i = 0; i < count; ++i) {
    const Index v = static_cast<Index>((2 * i + 1) * n / (2 * count));
    const auto samples = press_along_normal(s, v, depth_max, ticks, step_every);
    failed_presses += check_press(s, samples, speed, what + " vertex " + std::to_string(v)) > 0;
  }
  EXPECT_EQ(failed_presses, 0) << what;
}

TEST(DeepPress, DefaultOrganForceGrowsWithDepthToThreeTimesTheClampDepth) {
  // 200 N/m: clamp depth 40 mm, pressed to 120 mm (through most of the organ).
  Scene s = default_organ();
  press_everywhere(s, 24, 1, "default organ, 200 N/m, step every tick");
  press_everywhere(s, 12, 2, "default organ, 200 N/m, step every 2 ticks");
}

TEST(DeepPress, DefaultOrganAtTheIssuesStiffness) {
  // 800 N/m: clamp depth 10 mm, pressed to 30 mm.
  Scene s = default_organ(800.0);
  press_everywhere(s, 24, 1, "default organ, 800 N/m");
}

TEST(DeepPress, ThinOrganForceGrowsWithDepthToThreeTimesTheClampDepth) {
  // The cingulate gyrus is a thin folded sheet (a few mm): a 120 mm press
  // goes through it; the proxy stays on the side pressed, the force grows.
  PALPA_REQUIRE_SHARED_ORGANS();
  Scene s = load(test::shared_organs_dir() / "bp3d_FMA72717_right_cingulate_gyrus.obj", 1e-3);
  press_everywhere(s, 30, 1, "cingulate gyrus, 200 N/m");
  Scene stiff = load(test::shared_organs_dir() / "bp3d_FMA72717_right_cingulate_gyrus.obj", 1e-3, 800.0);
  press_everywhere(stiff, 16, 2, "cingulate gyrus, 800 N/m, step every 2 ticks");
}

TEST(DeepPress, ForceGrowsPastTheDrawnLimit) {
  // The drawn dent stops at the surface's drawn-displacement limit (a
  // fraction of the local thickness); the force on the probe does not.
  PALPA_REQUIRE_SHARED_ORGANS();
  Scene s = load(test::shared_organs_dir() / "bp3d_FMA72717_right_cingulate_gyrus.obj", 1e-3);
  const Index v = static_cast<Index>(s.mesh->vertex_count() / 2);
  const double depth_max = 3 * kMaxForce / kStiffness;
  const int ticks = 2000;
  const auto samples = press_along_normal(s, v, depth_max, ticks, 1);
  const double speed = (depth_max + 0.002) / (ticks * kTick);
  const ProbeOutput& last = samples.back().out;
  const Index cv = last.contact.vertex;
  ASSERT_LT(cv, s.mesh->vertex_count());
  // The limit is far below the press and binds at the contact vertex.
  EXPECT_LT(s.surface->drawn_limit(cv), 0.1 * depth_max);
  EXPECT_NEAR(s.surface->drawn_height(cv), -s.surface->drawn_limit(cv), 1e-3 * s.surface->drawn_limit(cv));
  // The force: the linear model at the full depth, clamped.
  EXPECT_NEAR(last.normal_reaction, kStiffness * depth_max + kDamping * speed, 1e-6);
  EXPECT_NEAR(last.force.norm(), kMaxForce, 1e-9);
  EXPECT_EQ(last.contact.depth, last.height.depth);
}

TEST(DeepPress, SmallHeartForceGrowsWithDepth) {
  // coeur1 (27 x 39 x 29 mm): smaller than the shape function's support.
  PALPA_REQUIRE_SHARED_ORGANS();
  Scene s = load(test::shared_organs_dir() / "sofa_coeur1.off", 1e-3);
  press_everywhere(s, 8, 1, "coeur1, 200 N/m");
}

TEST(DeepPress, IssuesVerticalPressOnTheDefaultOrganNeverLetsGo) {
  // The press of the issue: z from 0.10 to 0.035 m over 2 s at the top of
  // the default organ, 800 N/m. Once in contact it holds to the end, and
  // the force never decreases (a vertical line at a tilted point: the
  // depth is measured along the contact normal, the force still monotone).
  Scene s = default_organ(800.0);
  const mesh::MeshFacts facts = mesh::analyse(*s.mesh);
  const double cx = 0.5 * (facts.bbox_min.x() + facts.bbox_max.x());
  const double cy = 0.5 * (facts.bbox_min.y() + facts.bbox_max.y());
  Session session{s, 1, 0, {}};
  const int ticks = 2000;
  bool touched = false;
  double last = 0;
  int drops = 0, decreases = 0;
  std::printf("  depth [mm]   |F| [N]   (vertical press at the top centre, 800 N/m)\n");
  for (int k = 0; k <= ticks; ++k) {
    const double z = 0.10 - 0.065 * k / ticks;
    const ProbeOutput o = session.tick({Vec3(cx, cy, z), Vec3(0, 0, -0.065 / (ticks * kTick))});
    const double f = o.force.norm();
    if (touched && !(o.in_contact && f > 0)) ++drops;
    if (touched && f < last - 1e-12) ++decreases;
    if (o.in_contact) touched = true;
    if (o.in_contact && k % 25 == 0) std::printf("  %9.2f   %7.3f\n", 1e3 * o.height.depth, f);
    last = f;
  }
  EXPECT_TRUE(touched);
  EXPECT_EQ(drops, 0);
  EXPECT_EQ(decreases, 0);
  EXPECT_NEAR(last, kMaxForce, 1e-9);
}

// Brute force: is p inside the closed mesh (an odd number of crossings of a
// ray from p)?
bool inside(const mesh::SurfaceMesh& m, const Vec3& p) {
  const Vec3 dir = Vec3(0.0123, 0.0071, 1).normalized();
  int crossings = 0;
  for (const auto& t : m.triangles) {
    const Vec3 a = m.positions[t[0]], e1 = m.positions[t[1]] - a, e2 = m.positions[t[2]] - a;
    const Vec3 q = dir.cross(e2);
    const double det = e1.dot(q);
    if (std::abs(det) < 1e-30) continue;
    const Vec3 s = p - a;
    const double u = s.dot(q) / det;
    if (u < 0 || u > 1) continue;
    const Vec3 r = s.cross(e1);
    const double v = dir.dot(r) / det;
    if (v < 0 || u + v > 1) continue;
    if (e2.dot(r) / det > 0) ++crossings;
  }
  return crossings % 2 == 1;
}

// A path `depth` below the surface: the surface point moves `step` (m) per
// tick along a heading that turns by up to 0.05 rad, re-placed on the
// surface each tick by the tree's nearest vertex and the interpolated-normal
// point around it (a point on the surface, no sheet ambiguity).
std::vector<Vec3> sliding_path(const Scene& s, std::mt19937& rng, Index v0, int ticks, double step,
                               double depth) {
  std::uniform_real_distribution<double> turn(-0.05, 0.05);
  Vec3 point = s.mesh->positions[v0], normal = s.mesh->normals[v0];
  auto tangent = [](const Vec3& d, const Vec3& n) {
    const Vec3 t = d - d.dot(n) * n;
    return t.norm() > 1e-9 ? Vec3(t.normalized()) : Vec3(n.unitOrthogonal());
  };
  Vec3 heading = tangent(normal.unitOrthogonal(), normal);
  std::vector<Vec3> path;
  for (int k = 0; k < ticks; ++k) {
    path.push_back(point - depth * normal);
    const double a = turn(rng);
    heading = std::cos(a) * heading + std::sin(a) * normal.cross(heading);
    const Vec3 next = point + step * heading;
    const collision::SurfacePoint sp = collision::locate_surface_point(*s.mesh, next, s.tree->nearest(next).vertex);
    if (sp.triangle == kNoIndex) break;
    point = sp.point;
    normal = sp.normal;
    heading = tangent(heading, normal);
  }
  return path;
}

TEST(DeepPress, SlidingDeepPressesAcrossFoldsKeepContact) {
  // On the cingulate gyrus: press 3 or 6 mm in along the normal (deeper than
  // the sheet is thick in places), then slide 40 mm across its folds. The
  // contact holds and pushes on every tick.
  PALPA_REQUIRE_SHARED_ORGANS();
  Scene s = load(test::shared_organs_dir() / "bp3d_FMA72717_right_cingulate_gyrus.obj", 1e-3);
  std::mt19937 rng(5);
  std::uniform_int_distribution<Index> vertex(0, static_cast<Index>(s.mesh->vertex_count() - 1));
  int failed = 0, proxy_ticks = 0, total = 0, released_total = 0;
  for (double depth : {0.003, 0.006}) {
    for (int path_no = 0; path_no < 8; ++path_no) {
      const Index v0 = vertex(rng);
      const std::vector<Vec3> slide = sliding_path(s, rng, v0, 1000, 4e-5, depth);
      s.surface->reset();
      Session session{s, 1, 0, {}};
      // Press in along the normal over 0.5 s.
      const Vec3 p = s.mesh->positions[v0], n = s.mesh->normals[v0];
      for (int k = 0; k <= 500; ++k) {
        const double d = -0.001 + (depth + 0.001) * k / 500;
        session.tick({p - d * n, -(depth + 0.001) / 0.5 * n});
      }
      ASSERT_TRUE(session.memory.in_contact) << "press at vertex " << v0;
      // Slide (velocity by finite differences).
      int lost = 0, released = 0, bad_force = 0;
      bool was_touching = true;
      for (std::size_t k = 0; k < slide.size(); ++k) {
        const Vec3 vel = k > 0 ? Vec3((slide[k] - slide[k - 1]) / kTick) : Vec3::Zero();
        const ProbeOutput o = session.tick({slide[k], vel});
        ++total;
        proxy_ticks += o.path == collision::ContactPath::Proxy;
        // A contact lets go only once the probe has come out (past a thin
        // sheet or a fold the probe may come out above the proxy); it may
        // start again later as a new contact.
        if (was_touching && !o.in_contact) {
          ++released;
          lost += inside(*s.mesh, slide[k]);
        }
        was_touching = o.in_contact;
        // In contact the reaction is the linear model's, k depth - b dh/dt
        // (zero only while the probe is withdrawn fast enough for the
        // damping to cancel the spring).
        if (o.in_contact) {
          const double fn = s.stiffness * o.height.depth - kDamping * vel.dot(o.surface.normal);
          if (!(std::abs(o.normal_reaction - std::max(0.0, fn)) <= 1e-9 && (fn <= 0 || o.force.norm() > 0))) ++bad_force;
        }
      }
      released_total += released;
      EXPECT_EQ(bad_force, 0) << "slide from vertex " << v0;
      if (lost > 0) {
        ++failed;
        ADD_FAILURE() << "slide from vertex " << v0 << " at " << 1e3 * depth << " mm let go " << lost
                      << " times with the probe inside the organ";
      }
    }
  }
  EXPECT_EQ(failed, 0);
  std::printf("  %d of %d sliding ticks in contact through the proxy; let go %d times, the probe outside\n",
              proxy_ticks, total, released_total);
  // The slides did go deep enough for the proxy to matter.
  EXPECT_GT(proxy_ticks, total / 20);
}

TEST(DeepPress, ProbeMemoryIsASnapshot) {
  // ProbeMemory is all a probe's history: a second session run to the same
  // tick, handed a copy of the first one's memory, goes on bit-identically
  // through a deep, sliding press (walk, proxy and back).
  Scene a = default_organ(), b = default_organ();
  const Index v = static_cast<Index>(a.mesh->vertex_count() / 3);
  const Vec3 p = a.mesh->positions[v], n = a.mesh->normals[v];
  auto input = [&](int k) {
    const double d = -0.002 + 0.1 * std::sin(0.0015 * k);
    const Vec3 side = 0.01 * std::sin(0.003 * k) * n.unitOrthogonal();
    return ProbeInput{p - d * n + side, -0.05 * n};
  };
  Session sa{a, 1, 0, {}}, sb{b, 1, 0, {}};
  for (int k = 0; k < 1200; ++k) {
    sa.tick(input(k));
    sb.tick(input(k));
  }
  sb.memory = sa.memory;
  int proxy = 0;
  for (int k = 1200; k < 2400; ++k) {
    const ProbeOutput oa = sa.tick(input(k));
    const ProbeOutput ob = sb.tick(input(k));
    proxy += oa.path == collision::ContactPath::Proxy;
    ASSERT_EQ(oa.in_contact, ob.in_contact) << k;
    ASSERT_EQ(oa.force, ob.force) << k;
    ASSERT_EQ(oa.surface.point, ob.surface.point) << k;
  }
  EXPECT_GT(proxy, 100);
}

}  // namespace
}  // namespace palpa::haptics
