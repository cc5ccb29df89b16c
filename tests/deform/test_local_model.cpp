// Local models (section III.A) against closed forms: the linear model's step
// and impulse responses, stability for stiff and light vertices, the
// stiffening spring's equilibrium and the standard linear solid's relaxation.

#include "deform/local_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace palpa::deform {
namespace {

using Real = long double;

Material linear_material(double m, double b, double k) {
  Material mat;
  mat.model = LocalModelKind::Linear;
  mat.mass = m;
  mat.damping = b;
  mat.stiffness = k;
  return mat;
}

// Closed-form response of eq. (1) from h(0) = 0, v(0) = v0 under a constant
// force f (N): returns h(t). Written per damping regime, in long double.
Real closed_form_height(const Material& mat, Real f, Real v0, Real t) {
  const Real m = mat.mass, b = mat.damping, k = mat.stiffness;
  const Real a = b / (2 * m);
  const Real w2 = k / m;
  const Real d = a * a - w2;
  const Real hf = f / k;
  // h = hf + e^{-at} (A cos + B sin) etc. with h(0) = 0, h'(0) = v0.
  if (d < 0) {
    const Real wd = std::sqrt(-d);
    const Real A = -hf;
    const Real B = (v0 + a * A) / wd;
    return hf + std::exp(-a * t) * (A * std::cos(wd * t) + B * std::sin(wd * t));
  }
  if (d == 0) {
    const Real A = -hf;
    const Real B = v0 + a * A;
    return hf + std::exp(-a * t) * (A + B * t);
  }
  const Real g = std::sqrt(d);
  const Real l1 = -a + g, l2 = -a - g;
  // h = hf + c1 e^{l1 t} + c2 e^{l2 t}, c1 + c2 = -hf, l1 c1 + l2 c2 = v0.
  const Real c1 = (v0 + l2 * hf) / (l1 - l2);
  const Real c2 = -hf - c1;
  return hf + c1 * std::exp(l1 * t) + c2 * std::exp(l2 * t);
}

struct Regime {
  const char* name;
  double m, b, k;
};

// m = 1 g, k = 500 N/m: critical damping is b = 2 sqrt(k m) = 1.41421... N s/m.
const Regime kRegimes[] = {
    {"under-damped", 1e-3, 0.05, 500.0},
    {"critically damped", 1e-3, 2.0 * std::sqrt(500.0 * 1e-3), 500.0},
    {"over-damped", 1e-3, 20.0, 500.0},
    {"just under critical", 1e-3, 2.0 * std::sqrt(500.0 * 1e-3) * (1 - 1e-3), 500.0},
    {"just over critical", 1e-3, 2.0 * std::sqrt(500.0 * 1e-3) * (1 + 1e-3), 500.0},
};

TEST(LinearModel, StepResponseMatchesClosedForm) {
  const LocalModel& model = local_model(LocalModelKind::Linear);
  const double f = -2.0;  // N, pushes in
  for (const Regime& r : kRegimes) {
    for (double dt : {1e-3, 1e-4}) {
      SCOPED_TRACE(std::string(r.name) + " dt " + std::to_string(dt));
      const Material mat = linear_material(r.m, r.b, r.k);
      VertexState s;
      const double scale = std::abs(f) / r.k;
      for (int n = 1; n <= 400; ++n) {
        model.step(mat, s, f, dt);
        const double expected = static_cast<double>(closed_form_height(mat, f, 0, static_cast<Real>(n) * dt));
        ASSERT_NEAR(s.h, expected, 1e-9 * scale) << "step " << n;
      }
    }
  }
}

TEST(LinearModel, ImpulseResponseMatchesClosedForm) {
  // An impulse J at t = 0 leaves the vertex at h = 0 with v = J / m.
  const LocalModel& model = local_model(LocalModelKind::Linear);
  const double impulse = 1e-3;  // N s
  for (const Regime& r : kRegimes) {
    SCOPED_TRACE(r.name);
    const Material mat = linear_material(r.m, r.b, r.k);
    const double v0 = impulse / r.m;
    VertexState s{0.0, v0, 0.0};
    const double dt = 2e-4;
    const double scale = v0 / std::sqrt(r.k / r.m);  // amplitude of the undamped oscillation
    for (int n = 1; n <= 300; ++n) {
      model.step(mat, s, 0.0, dt);
      const double expected = static_cast<double>(closed_form_height(mat, 0, v0, static_cast<Real>(n) * dt));
      ASSERT_NEAR(s.h, expected, 1e-9 * scale) << "step " << n;
    }
  }
}

TEST(LinearModel, CoefficientsAreContinuousAcrossCriticalDamping) {
  // Damping a hair either side of critical, and at the switches between the
  // series and the closed forms (x = D dt^2 = +-1), gives transition
  // matrices that agree (p01 in s, p10 in 1/s, compared relative to dt).
  const double m = 1e-3, k = 500;
  auto near = [](const LinearStep& a, const LinearStep& b, double dt, double tol) {
    return std::abs(a.p00 - b.p00) < tol && std::abs(a.p01 - b.p01) < tol * dt &&
           std::abs(a.p10 - b.p10) * dt < tol && std::abs(a.p11 - b.p11) < tol;
  };
  const double bc = 2 * std::sqrt(k * m);
  for (double dt : {1e-4, 1e-3, 1e-2}) {
    const LinearStep crit = LinearStep::make(linear_material(m, bc, k), dt);
    for (double eps : {1e-12, 1e-9, 1e-6}) {
      EXPECT_TRUE(near(crit, LinearStep::make(linear_material(m, bc * (1 + eps), k), dt), dt, 1e2 * eps + 1e-13));
      EXPECT_TRUE(near(crit, LinearStep::make(linear_material(m, bc * (1 - eps), k), dt), dt, 1e2 * eps + 1e-13));
    }
  }
  // b such that (b^2 - 4km) dt^2 / (4 m^2) = +-1 exactly, then a hair around it.
  const double dt = 3e-3;
  for (double side : {1.0, -1.0}) {
    const double b_switch = std::sqrt(4 * k * m + side * 4 * m * m / (dt * dt));
    const LinearStep lo = LinearStep::make(linear_material(m, b_switch * (1 - 1e-12), k), dt);
    const LinearStep hi = LinearStep::make(linear_material(m, b_switch * (1 + 1e-12), k), dt);
    EXPECT_TRUE(near(lo, hi, dt, 1e-12)) << "side " << side;
  }
}

TEST(LinearModel, StableAndConvergentForStiffAndLightVertices) {
  // The energy about the equilibrium never grows and the vertex settles at
  // f / k, for stiffness up to 1e5 N/m, tiny masses and 1 ms / 0.1 ms steps
  // (explicit Euler would diverge for all of these).
  const LocalModel& model = local_model(LocalModelKind::Linear);
  const double f = -1.0;
  for (double k : {1e3, 1e4, 1e5}) {
    for (double m : {1e-3, 1e-6, 1e-9}) {
      for (double b : {0.01, 1.0, 50.0}) {
        for (double dt : {1e-3, 1e-4}) {
          SCOPED_TRACE("k " + std::to_string(k) + " m " + std::to_string(m) + " b " + std::to_string(b) + " dt " +
                       std::to_string(dt));
          const Material mat = linear_material(m, b, k);
          const double hf = f / k;
          auto energy = [&](const VertexState& s) {
            return 0.5 * m * s.v * s.v + 0.5 * k * (s.h - hf) * (s.h - hf);
          };
          // Slowest decay rate of the closed form: b/2m (under-damped) or 2k/(b + sqrt(b^2 - 4km)).
          const double disc = b * b - 4 * k * m;
          const double rate = disc < 0 ? b / (2 * m) : 2 * k / (b + std::sqrt(disc));
          const int steps = static_cast<int>(std::min(60.0 / (rate * dt), 2e5)) + 10;
          VertexState s;
          double e = energy(s);
          const double e_floor = 1e-16 * e;  // below it h - hf is dominated by the rounding of h
          for (int n = 0; n < steps; ++n) {
            model.step(mat, s, f, dt);
            const double e1 = energy(s);
            ASSERT_TRUE(std::isfinite(s.h) && std::isfinite(s.v));
            if (e > e_floor) {
              ASSERT_LE(e1, e * (1 + 1e-12)) << "step " << n;
            }
            e = e1;
          }
          if (60.0 / (rate * dt) < 2e5) {
            EXPECT_NEAR(s.h, hf, 1e-9 * std::abs(hf));
          }
        }
      }
    }
  }
}

TEST(LinearModel, EquilibriumIsAnExactFixedPoint) {
  const Material mat = linear_material(1e-3, 1.0, 500.0);
  VertexState s{0.25 / 500.0, 0.0, 0.0};
  local_model(LocalModelKind::Linear).step(mat, s, 0.25, 1e-3);
  EXPECT_EQ(s.h, 0.25 / 500.0);
  EXPECT_EQ(s.v, 0.0);
}

TEST(LinearModel, ForcesFollowEquationOne) {
  const Material mat = linear_material(1e-3, 2.0, 400.0);
  const LocalModel& model = local_model(LocalModelKind::Linear);
  EXPECT_DOUBLE_EQ(model.equilibrium_force(mat, -0.01), -4.0);
  // Pushed in (h < 0) and moving in (v < 0): the restoring force is outward.
  EXPECT_DOUBLE_EQ(model.restoring_force(mat, -0.01, -0.5, 0.0), 4.0 + 1.0);
}

// --- Exponential (stiffening) model ---------------------------------------

Material exponential_material(double k, double alpha, double m = 1e-3, double b = 1.0) {
  Material mat;
  mat.model = LocalModelKind::Exponential;
  mat.mass = m;
  mat.damping = b;
  mat.stiffness = k;
  mat.alpha = alpha;
  return mat;
}

TEST(ExponentialModel, SpringIsTheDocumentedStiffeningLaw) {
  const Material mat = exponential_material(500, 200);
  const LocalModel& model = local_model(LocalModelKind::Exponential);
  for (double h : {-0.02, -0.005, -1e-4, 1e-4, 0.003, 0.01}) {
    const double expected = (h < 0 ? -1 : 1) * 500 * (std::exp(200 * std::abs(h)) - 1) / 200;
    EXPECT_NEAR(model.equilibrium_force(mat, h), expected, 1e-12 * std::abs(expected));
  }
  // Small strain: stiffness k. Stiffening: force / displacement grows with |h|.
  EXPECT_NEAR(model.equilibrium_force(mat, -1e-8) / -1e-8, 500.0, 1e-3);
  double previous = 0;
  for (int i = 1; i <= 20; ++i) {
    const double h = -1e-3 * i;
    const double secant = model.equilibrium_force(mat, h) / h;
    EXPECT_GT(secant, previous);
    previous = secant;
  }
  // alpha = 0 is the linear spring.
  EXPECT_DOUBLE_EQ(model.equilibrium_force(exponential_material(500, 0), -0.01), -5.0);
}

TEST(ExponentialModel, SettlesAtTheHeightItsEquilibriumForceNames) {
  const LocalModel& model = local_model(LocalModelKind::Exponential);
  const Material mat = exponential_material(500, 200);
  for (double target : {-0.004, -0.012, 0.006}) {
    VertexState s;
    const double f = model.equilibrium_force(mat, target);
    for (int n = 0; n < 5000; ++n) model.step(mat, s, f, 1e-3);
    EXPECT_NEAR(s.h, target, 1e-10) << target;
    // A force twice as large moves it less than twice as far (stiffening).
    VertexState s2;
    for (int n = 0; n < 5000; ++n) model.step(mat, s2, 2 * f, 1e-3);
    EXPECT_LT(std::abs(s2.h), 2 * std::abs(target));
    EXPECT_GT(std::abs(s2.h), std::abs(target));
  }
}

TEST(ExponentialModel, BackwardEulerEquationHoldsEvenForHugeSteps) {
  // Each step must solve m (v1 - v0) = dt (f - b v1 - s(h1)), h1 = h0 + dt v1,
  // to round-off, whatever the parameters (the Newton iteration converges).
  const LocalModel& model = local_model(LocalModelKind::Exponential);
  for (double k : {10.0, 500.0, 1e5}) {
    for (double alpha : {0.0, 50.0, 1000.0}) {
      for (double m : {1e-9, 1e-3, 1.0}) {
        for (double dt : {1e-4, 1e-2, 1.0}) {
          for (double f : {-1e3, -1.0, 3.0}) {
            const Material mat = exponential_material(k, alpha, m, 0.5);
            VertexState s{-0.002, 0.3, 0.0};
            const VertexState s0 = s;
            model.step(mat, s, f, dt);
            const double lhs = m * (s.v - s0.v);
            const double rhs = dt * (f - mat.damping * s.v - model.equilibrium_force(mat, s.h));
            const double scale = std::abs(m * s0.v) + dt * (std::abs(f) + std::abs(model.equilibrium_force(mat, s.h)) +
                                                             mat.damping * std::abs(s.v)) + m * std::abs(s.v);
            EXPECT_NEAR(lhs, rhs, 1e-10 * scale) << "k " << k << " alpha " << alpha << " m " << m << " dt " << dt
                                                 << " f " << f;
            EXPECT_NEAR(s.h, s0.h + dt * s.v, 1e-12 * (std::abs(s.h) + std::abs(s0.h)));
          }
        }
      }
    }
  }
}

TEST(ExponentialModel, EnergyNeverGrowsAtLargeSteps) {
  // Backward Euler on a convex potential dissipates
  // E = m v^2 / 2 + P(h) - f h, P(h) = k (expm1(alpha |h|) - alpha |h|) / alpha^2.
  const LocalModel& model = local_model(LocalModelKind::Exponential);
  const double k = 1e5, alpha = 300, m = 1e-6, f = -20;
  const Material mat = exponential_material(k, alpha, m, 1e-3);
  auto energy = [&](const VertexState& s) {
    const double x = alpha * std::abs(s.h);
    return 0.5 * m * s.v * s.v + k * (std::expm1(x) - x) / (alpha * alpha) - f * s.h;
  };
  for (double dt : {1e-3, 0.1}) {
    VertexState s{0.01, -2.0, 0.0};
    double e = energy(s);
    for (int n = 0; n < 2000; ++n) {
      model.step(mat, s, f, dt);
      const double e1 = energy(s);
      ASSERT_TRUE(std::isfinite(e1));
      ASSERT_LE(e1, e + 1e-12 * std::abs(e) + 1e-15) << "dt " << dt << " step " << n;
      e = e1;
    }
    EXPECT_NEAR(model.equilibrium_force(mat, s.h), f, 1e-6 * std::abs(f));
  }
}

// --- Viscoelastic (standard linear solid) model ---------------------------

Material sls_material(double k, double k2, double tau, double m = 1e-3, double b = 1.0) {
  Material mat;
  mat.model = LocalModelKind::Viscoelastic;
  mat.mass = m;
  mat.damping = b;
  mat.stiffness = k;
  mat.k2 = k2;
  mat.tau = tau;
  return mat;
}

TEST(ViscoelasticModel, ForceRelaxesUnderHeldIndentation) {
  // Hold the vertex at h = -d (a very heavy vertex barely moves in a step and
  // is put back each step). The restoring force must relax from (k + k2) d
  // to k d as k d + k2 d exp(-t / tau).
  const double k = 400, k2 = 600, tau = 0.3, d = 0.005, dt = 2e-4;
  const Material mat = sls_material(k, k2, tau, 1e4, 0.0);
  const LocalModel& model = local_model(LocalModelKind::Viscoelastic);
  VertexState s{-d, 0.0, 0.0};
  EXPECT_NEAR(model.restoring_force(mat, s.h, 0.0, s.q), (k + k2) * d, 1e-12);
  const int steps = static_cast<int>(5 * tau / dt);
  for (int n = 1; n <= steps; ++n) {
    model.step(mat, s, 0.0, dt);
    s.h = -d;
    s.v = 0.0;
    const double t = n * dt;
    const double expected = k * d + k2 * d * std::exp(-t / tau);
    ASSERT_NEAR(model.restoring_force(mat, s.h, 0.0, s.q), expected, 2e-3 * k2 * d) << "t " << t;
  }
  // Fit the time constant from the force at t = tau: exp(-1) of the excess.
  VertexState r{-d, 0.0, 0.0};
  const long n_tau = std::lround(tau / dt);
  for (long n = 0; n < n_tau; ++n) {
    model.step(mat, r, 0.0, dt);
    r.h = -d;
    r.v = 0.0;
  }
  const double excess = model.restoring_force(mat, -d, 0.0, r.q) - k * d;
  EXPECT_NEAR(-(n_tau * dt) / std::log(excess / (k2 * d)), tau, 1e-3 * tau);
}

TEST(ViscoelasticModel, CreepsToTheRelaxedEquilibriumAsTheClosedForm) {
  // Under a constant force f a light vertex follows the quasi-static creep of
  // the standard linear solid: q -> f/k with tau_c = tau (k + k2) / k and
  // h = (f + k2 q) / (k + k2): from f / (k + k2) at once to f / k in the end.
  const double k = 400, k2 = 600, tau = 0.2, dt = 1e-4;
  const Material mat = sls_material(k, k2, tau, 1e-6, 0.05);
  const LocalModel& model = local_model(LocalModelKind::Viscoelastic);
  const double target = -0.004;
  const double f = model.equilibrium_force(mat, target);
  EXPECT_DOUBLE_EQ(f, k * target);
  const double tau_c = tau * (k + k2) / k;
  VertexState s;
  const int steps = static_cast<int>(6 * tau_c / dt);
  for (int n = 1; n <= steps; ++n) {
    model.step(mat, s, f, dt);
    const double t = n * dt;
    if (t < 0.01) continue;  // the fast transient (damping) is over after a few ms
    const double q = f / k * (1 - std::exp(-t / tau_c));
    const double h = (f + k2 * q) / (k + k2);
    ASSERT_NEAR(s.h, h, 2e-3 * std::abs(target)) << "t " << t;
  }
  for (int n = 0; n < 20000; ++n) model.step(mat, s, f, 1e-3);
  EXPECT_NEAR(s.h, target, 1e-9);
  EXPECT_NEAR(s.q, target, 1e-9);
}

TEST(ViscoelasticModel, EnergyNeverGrowsAtLargeSteps) {
  // E = m v^2/2 + k h^2/2 + k2 (h - q)^2/2 - f h is dissipated by backward Euler.
  const double k = 1e5, k2 = 5e4, m = 1e-7, f = 3.0;
  const Material mat = sls_material(k, k2, 0.01, m, 1e-3);
  const LocalModel& model = local_model(LocalModelKind::Viscoelastic);
  auto energy = [&](const VertexState& s) {
    return 0.5 * m * s.v * s.v + 0.5 * k * s.h * s.h + 0.5 * k2 * (s.h - s.q) * (s.h - s.q) - f * s.h;
  };
  for (double dt : {1e-4, 1e-3, 0.5}) {
    VertexState s{-0.01, 5.0, 0.002};
    double e = energy(s);
    for (int n = 0; n < 3000; ++n) {
      model.step(mat, s, f, dt);
      const double e1 = energy(s);
      ASSERT_LE(e1, e + 1e-12 * std::abs(e) + 1e-18) << "dt " << dt << " step " << n;
      e = e1;
    }
    EXPECT_NEAR(s.h, f / k, 1e-9);
  }
}

TEST(LocalModel, SharedInstancesReportTheirKind) {
  for (LocalModelKind k : {LocalModelKind::Linear, LocalModelKind::Exponential, LocalModelKind::Viscoelastic}) {
    EXPECT_EQ(local_model(k).kind(), k);
  }
}

}  // namespace
}  // namespace palpa::deform
