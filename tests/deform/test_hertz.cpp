// The Hertz local model, tissue maps set in one pass, and pulse drives,
// against closed forms.

#include "deform/local_model.h"
#include "deform/surface.h"
#include "mesh/generate.h"

#include <gtest/gtest.h>

#include <cmath>

namespace palpa::deform {
namespace {

Material hertz(double c = 600, double relaxation = 0, double tau = 0.3) {
  Material m;
  m.model = LocalModelKind::Hertz;
  m.mass = 1e-3;
  m.hertz = c;
  m.alpha = 0;  // no stiffening
  m.stiffness = 1.5 * c * std::sqrt(0.005);
  m.damping = 2 * std::sqrt(m.stiffness * m.mass);
  m.relaxation = relaxation;
  m.tau = tau;
  return m;
}

// The height h < 0 where the spring holds force f < 0, by bisection (independent of the model's Newton).
double height_for(const Material& m, double f) {
  double lo = -1.0, hi = 0.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (hertz_spring(m, mid) < f ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

TEST(HertzModel, TheSpringIsTheHertzLawWithASoftenedStart) {
  const Material m = hertz(600);
  for (double d : {0.001, 0.003, 0.01, 0.03}) {
    const double closed = 600 * std::pow(d, 1.5);
    EXPECT_NEAR(-hertz_spring(m, -d) / closed, 1.0, 0.015) << d;
    EXPECT_EQ(hertz_spring(m, d), -hertz_spring(m, -d));
  }
  EXPECT_EQ(hertz_spring(m, 0.0), 0.0);
  // The slope at rest is 1.5 c sqrt(d0), so a vertex returns to rest.
  const double e = 1e-9;
  EXPECT_NEAR(hertz_spring(m, e) / e, 1.5 * 600 * std::sqrt(kHertzSoftening), 1e-3);
}

TEST(HertzModel, StepsSettleAtTheSpringsEquilibriumForAnyStep) {
  const Material m = hertz();
  const LocalModel& model = local_model(LocalModelKind::Hertz);
  for (double dt : {1e-4, 1e-3, 1e-2, 1.0}) {
    for (double f : {-0.01, -0.5, -5.0}) {
      VertexState s;
      for (int k = 0; k < 20000 && std::abs(s.v) + std::abs(s.h - height_for(m, f)) > 1e-13; ++k) {
        model.step(m, s, f, dt);
        ASSERT_TRUE(std::isfinite(s.h) && std::isfinite(s.v));
      }
      EXPECT_NEAR(s.h, height_for(m, f), 1e-9) << "dt " << dt << " f " << f;
      EXPECT_NEAR(model.equilibrium_force(m, s.h), f, 1e-9 * std::abs(f) + 1e-12);
    }
  }
}

TEST(HertzModel, AHeldPressRelaxesFromOnePlusGToOneAsBackwardEulerSays) {
  const double g = 0.6, tau = 0.25, dt = 1e-3, h = -0.004;
  const Material m = hertz(600, g, tau);
  const LocalModel& model = local_model(LocalModelKind::Hertz);
  VertexState s;
  s.h = h;
  const double relaxed = -hertz_spring(m, h);
  EXPECT_NEAR(model.restoring_force(m, h, 0, 0), (1 + g) * relaxed, 1e-12);
  const double beta = dt / tau;
  for (int n = 1; n <= 1000; ++n) {
    // The force that holds the vertex at h this step: (1 + g) s(h) - g s(q).
    const double hold = (1 + g) * hertz_spring(m, h) - g * hertz_spring(m, s.q);
    model.step(m, s, hold, dt);
    ASSERT_NEAR(s.h, h, 1e-12) << n;
    const double q = h * (1 - std::pow(1 + beta, -n));
    ASSERT_NEAR(s.q, q, 1e-11) << n;
  }
  EXPECT_NEAR(model.restoring_force(m, h, 0, s.q) / relaxed, 1.0, 0.02);
}

TEST(HertzModel, ValidationNamesTheCoefficient) {
  Material m = hertz();
  m.hertz = 0;
  try {
    validate_material(m, "tissue 0");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "tissue 0: hertz must be positive and finite, got 0 N/m^1.5");
  }
}

std::shared_ptr<const mesh::SurfaceMesh> plane() {
  return std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(11, 11, 0.002));
}

TEST(TissueMap, SetsEveryVertexInOnePassWithItsScale) {
  auto m = plane();
  DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), hertz()));
  const std::size_t n = m->vertex_count();
  std::vector<std::uint16_t> of(n);
  std::vector<float> scale(n);
  for (std::size_t i = 0; i < n; ++i) {
    of[i] = static_cast<std::uint16_t>(i % 2);
    scale[i] = 1.0f + 0.01f * static_cast<float>(i);
  }
  s.set_tissue_map({hertz(600), hertz(900, 0.5)}, of, scale);
  EXPECT_FALSE(s.uniform());
  for (Index i = 0; i < n; ++i) {
    const Material v = s.vertex_material(i);
    EXPECT_DOUBLE_EQ(v.hertz, (i % 2 ? 900 : 600) * static_cast<double>(scale[i]));
    EXPECT_DOUBLE_EQ(v.damping, hertz(i % 2 ? 900 : 600).damping * std::sqrt(static_cast<double>(scale[i])));
    EXPECT_EQ(s.materials().at(i), v);
  }
  // A uniform material clears the map again.
  s.set_uniform_material(hertz());
  EXPECT_TRUE(s.uniform());
  EXPECT_EQ(s.modulus_scale(3), 1.0);
}

TEST(TissueMap, AMappedSurfaceStepsAsTheScaledMaterialsSetVertexByVertex) {
  // The step of a mapped vertex against a surface given each vertex's
  // scaled material outright (deform::scaled, which takes its own square
  // root): the map's kept roots must be those of its scales, and a vertex
  // painted afterwards must lose its scale. Three tissues (two Hertz, one
  // Linear), scales from 0.5 to 3.3, a press that slides and lets go.
  auto m = plane();
  const std::size_t n = m->vertex_count();
  Material linear;
  linear.stiffness = 400;
  linear.damping = 1.5;
  const std::vector<Material> tissues = {hertz(600), hertz(900, 0.5), linear};
  std::vector<std::uint16_t> of(n);
  std::vector<float> scale(n);
  MaterialArrays outright = MaterialArrays::uniform(n, hertz());
  for (std::size_t i = 0; i < n; ++i) {
    of[i] = static_cast<std::uint16_t>(i % 3);
    scale[i] = 0.5f + 0.07f * static_cast<float>(i % 41);
    outright.set(static_cast<Index>(i), scaled(tissues[of[i]], static_cast<double>(scale[i])));
  }
  DeformableSurface mapped(m, MaterialArrays::uniform(n, hertz()));
  mapped.set_tissue_map(tissues, of, scale);
  DeformableSurface reference(m, outright);
  const Index centre = 60;
  double largest = 0;
  for (int k = 0; k < 400; ++k) {
    if (k == 150) {
      // Painting a vertex gives it the material as it is, scale 1.
      for (DeformableSurface* s : {&mapped, &reference}) s->set_material(centre + 1, hertz(700));
      EXPECT_EQ(mapped.vertex_material(centre + 1), hertz(700));
      EXPECT_EQ(mapped.vertex_material(centre + 2), reference.vertex_material(centre + 2));
    }
    Contact c;
    c.vertex = centre;
    c.point = m->positions[centre] + Vec3(1e-5 * k, 0, 0);
    c.normal = Vec3::UnitZ();
    c.depth = k < 300 ? 1e-3 : 0.0;
    c.shape.radius = 0.008;
    for (DeformableSurface* s : {&mapped, &reference}) {
      s->set_contacts(std::vector<Contact>{c});
      s->step(1e-3);
    }
    for (std::size_t i = 0; i < n; ++i) {
      const VertexState& a = mapped.state().vertices[i];
      const VertexState& b = reference.state().vertices[i];
      largest = std::max(largest, std::abs(b.h));
      // The field's force is the unscaled law times the scale on one side and
      // the scaled law on the other: equal up to round-off, not bit for bit.
      ASSERT_NEAR(a.h, b.h, 1e-12) << "vertex " << i << " step " << k;
      ASSERT_NEAR(a.v, b.v, 1e-9) << "vertex " << i << " step " << k;
      ASSERT_NEAR(a.q, b.q, 1e-12) << "vertex " << i << " step " << k;
    }
  }
  EXPECT_GT(largest, 5e-4);  // the press moved the surface (m)
}

TEST(TissueMap, RefusesWhatDoesNotFitWithExactMessages) {
  auto m = plane();
  DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), hertz()));
  const std::size_t n = m->vertex_count();
  std::vector<std::uint16_t> of(n, 0);
  std::vector<float> scale(n, 1.0f);
  auto message = [&](auto f) {
    try {
      f();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  of[7] = 2;
  EXPECT_EQ(message([&] { s.set_tissue_map({hertz(), hertz()}, of, scale); }),
            "set_tissue_map: tissue of vertex 7 is 2, but there are 2 tissues");
  of[7] = 0;
  scale[5] = 0;
  EXPECT_EQ(message([&] { s.set_tissue_map({hertz()}, of, scale); }),
            "set_tissue_map: scale of vertex 5 must be positive and finite, got 0");
  EXPECT_EQ(message([&] { s.set_tissue_map({hertz()}, std::vector<std::uint16_t>(3, 0), {}); }),
            "set_tissue_map: 3 tissue indices for 121 vertices");
  // Nothing changed by the refused maps.
  EXPECT_TRUE(s.uniform());
}

TEST(Drives, AFreeVertexRestsAtItsLiftAndOthersStayAtRest) {
  auto m = plane();
  DeformableSurface s(m, MaterialArrays::uniform(m->vertex_count(), hertz()));
  s.set_drives({60}, {{0.5f, 0, 0, 0}});
  s.set_drive_values({0.002, 0, 0, 0});
  for (int k = 0; k < 3000; ++k) s.step(1e-3);
  EXPECT_NEAR(s.state().vertices[60].h, 0.001, 1e-9);
  for (Index i = 0; i < m->vertex_count(); ++i)
    if (i != 60) {
      EXPECT_EQ(s.state().vertices[i].h, 0.0);
    }
  s.set_drive_values({0, 0, 0, 0});
  for (int k = 0; k < 3000; ++k) s.step(1e-3);
  EXPECT_NEAR(s.state().vertices[60].h, 0.0, 1e-7);
}

}  // namespace
}  // namespace palpa::deform
