// Local models of section III.A: the 1-DoF system each vertex follows along
// its undeformed normal. Linear (eq. 1) is integrated exactly; the stiffening
// and viscoelastic models by backward Euler. All are unconditionally stable.

#include "deform/local_model.h"

#include <algorithm>
#include <cmath>

namespace palpa::deform {

// ---------------------------------------------------------------------------
// Linear: exact discretisation of eq. (1).

LinearStep LinearStep::make(const Material& mat, double dt) {
  const double m = mat.mass;
  const double b = mat.damping;
  const double k = mat.stiffness;
  LinearStep c;
  c.inv_k = 1.0 / k;
  if (!(dt > 0)) return c;  // identity

  // exp(A dt) = e^{-a dt} [C I + S (A + a I)] with a = b / 2m, w0^2 = k / m,
  // D = a^2 - w0^2, C = cosh(sqrt(D) dt), S = sinh(sqrt(D) dt) / sqrt(D)
  // (cos / sin for D < 0). Both are power series in x = D dt^2.
  const double a = b / (2.0 * m);
  const double w2 = k / m;
  const double disc = b * b - 4.0 * k * m;  // sign of D; D = disc / (4 m^2)
  const double x = disc / (4.0 * m * m) * dt * dt;

  if (std::abs(x) < 1.0) {
    // Near critical damping: C = sum x^n / (2n)!, S / dt = sum x^n / (2n+1)!,
    // summed by Horner to x^8 (truncation below 1e-16 for |x| < 1).
    static constexpr double kC[9] = {1.0,
                                     1.0 / 2.0,
                                     1.0 / 24.0,
                                     1.0 / 720.0,
                                     1.0 / 40320.0,
                                     1.0 / 3628800.0,
                                     1.0 / 479001600.0,
                                     1.0 / 87178291200.0,
                                     1.0 / 20922789888000.0};
    static constexpr double kS[9] = {1.0,
                                     1.0 / 6.0,
                                     1.0 / 120.0,
                                     1.0 / 5040.0,
                                     1.0 / 362880.0,
                                     1.0 / 39916800.0,
                                     1.0 / 6227020800.0,
                                     1.0 / 1307674368000.0,
                                     1.0 / 355687428096000.0};
    double cs = kC[8];
    double ss = kS[8];
    for (int n = 7; n >= 0; --n) {
      cs = cs * x + kC[n];
      ss = ss * x + kS[n];
    }
    const double e = std::exp(-a * dt);
    const double C = e * cs;
    const double S = e * dt * ss;
    c.p00 = C + a * S;
    c.p01 = S;
    c.p10 = -w2 * S;
    c.p11 = C - a * S;
  } else if (x < 0.0) {
    // Under-damped: damped oscillation at wd = sqrt(-D).
    const double wd = std::sqrt(-disc) / (2.0 * m);
    const double e = std::exp(-a * dt);
    const double C = e * std::cos(wd * dt);
    const double S = e * std::sin(wd * dt) / wd;
    c.p00 = C + a * S;
    c.p01 = S;
    c.p10 = -w2 * S;
    c.p11 = C - a * S;
  } else {
    // Over-damped: two real decay rates l1 = -2k / (b + q) (slow) and
    // l2 = -(b + q) / 2m (fast), q = sqrt(b^2 - 4km); written so neither a
    // tiny mass nor a long step overflows or cancels.
    const double q = std::sqrt(disc);
    const double e1 = std::exp(-2.0 * k / (b + q) * dt);
    const double e2 = std::exp(-(b + q) / (2.0 * m) * dt);
    const double big = (b + q) / (2.0 * q);
    const double small = 2.0 * k * m / (q * (b + q));
    c.p00 = big * e1 - small * e2;
    c.p01 = m * (e1 - e2) / q;
    c.p10 = -k * (e1 - e2) / q;
    c.p11 = -small * e1 + big * e2;
  }
  return c;
}

namespace {

class LinearModel final : public LocalModel {
 public:
  LocalModelKind kind() const override { return LocalModelKind::Linear; }
  void step(const Material& m, VertexState& s, double f, double dt) const override {
    LinearStep::make(m, dt).apply(s, f);
  }
  double equilibrium_force(const Material& m, double h) const override { return m.stiffness * h; }
  double restoring_force(const Material& m, double h, double v, double) const override {
    return -m.stiffness * h - m.damping * v;
  }
};

// ---------------------------------------------------------------------------
// Exponential: stiffening spring, backward Euler solved by monotone Newton.

// ds/dh at height h (N/m), always >= k.
double exponential_slope(const Material& m, double h) {
  if (m.alpha == 0.0) return m.stiffness;
  return m.stiffness * std::exp(std::min(m.alpha * std::abs(h), kExponentialCap));
}

// The height h >= 0 where the spring force is y >= 0 (inverse of s on h >= 0).
double exponential_inverse(const Material& m, double y) {
  if (m.alpha == 0.0) return y / m.stiffness;
  const double z = m.alpha * y / m.stiffness;
  const double zcap = std::expm1(kExponentialCap);
  const double x = z <= zcap ? std::log1p(z) : kExponentialCap + (z - zcap) / std::exp(kExponentialCap);
  return x / m.alpha;
}

class ExponentialModel final : public LocalModel {
 public:
  LocalModelKind kind() const override { return LocalModelKind::Exponential; }

  void step(const Material& m, VertexState& s, double f, double dt) const override {
    if (!(dt > 0)) return;
    // Backward Euler with v1 = (h1 - h0) / dt turns the step into one scalar
    // equation G(h1) = c h1 + dt^2 s(h1) - R = 0 with c = m + b dt and
    // R = c h0 + m dt v0 + dt^2 f. G is strictly increasing and odd-symmetric
    // in (h1, R), so solve for |R| on h1 >= 0, where G is convex.
    const double c = m.mass + m.damping * dt;
    const double dt2 = dt * dt;
    const double r = c * s.h + m.mass * dt * s.v + dt2 * f;
    const double sign = r < 0 ? -1.0 : 1.0;
    const double ra = std::abs(r);

    // Start from the smaller of two upper bounds of the root: the linearised
    // solution (s(h) >= k h) and the spring-only solution (c h >= 0). Newton
    // from the right on a convex increasing function decreases monotonically
    // to the root, so every iterate is a valid bound and it always converges.
    double h = std::min(ra / (c + dt2 * m.stiffness), exponential_inverse(m, ra / dt2));
    for (int it = 0; it < kNewtonIterations; ++it) {
      const double g = c * h + dt2 * exponential_spring(m, h) - ra;
      const double gp = c + dt2 * exponential_slope(m, h);
      const double dh = g / gp;
      h = std::max(h - dh, 0.0);
      if (!(std::abs(dh) > 1e-15 * h)) break;
    }
    const double h1 = sign * h;
    s.v = (h1 - s.h) / dt;
    s.h = h1;
  }

  double equilibrium_force(const Material& m, double h) const override { return exponential_spring(m, h); }
  double restoring_force(const Material& m, double h, double v, double) const override {
    return -exponential_spring(m, h) - m.damping * v;
  }

 private:
  static constexpr int kNewtonIterations = 20;  // 7 suffice over k, m, dt, f spanning 1e-9..1e7
};

// ---------------------------------------------------------------------------
// Viscoelastic: standard linear solid, backward Euler solved exactly.

class ViscoelasticModel final : public LocalModel {
 public:
  LocalModelKind kind() const override { return LocalModelKind::Viscoelastic; }

  void step(const Material& m, VertexState& s, double f, double dt) const override {
    if (!(dt > 0)) return;
    // Unknowns h1, v1, q1 of the implicit system
    //   h1 = h0 + dt v1
    //   m (v1 - v0) = dt (f - b v1 - k h1 - k2 (h1 - q1))
    //   q1 = q0 + dt (h1 - q1) / tau          (dashpot eta = k2 tau)
    // The third gives q1 = (q0 + beta h1) / (1 + beta), beta = dt / tau, so the
    // Maxwell arm acts as a spring k2 / (1 + beta) about q0; substituting
    // leaves one linear equation in h1.
    const double beta = dt / m.tau;
    const double k2e = m.k2 / (1.0 + beta);
    const double dt2 = dt * dt;
    const double num = m.mass * (s.h + dt * s.v) + m.damping * dt * s.h + dt2 * (f + k2e * s.q);
    const double den = m.mass + m.damping * dt + dt2 * (m.stiffness + k2e);
    const double h1 = num / den;
    s.v = (h1 - s.h) / dt;
    s.q = (s.q + beta * h1) / (1.0 + beta);
    s.h = h1;
  }

  double equilibrium_force(const Material& m, double h) const override { return m.stiffness * h; }
  double restoring_force(const Material& m, double h, double v, double q) const override {
    return -m.stiffness * h - m.k2 * (h - q) - m.damping * v;
  }
};

// ---------------------------------------------------------------------------
// Hertz: s(h) = sign(h) S(|h|), S(d) = c ((d + d0)^1.5 - d0^1.5)(1 + alpha d).

// dS/dd at d >= 0, N/m (> 0).
double hertz_slope(const Material& m, double d) {
  const double d0 = kHertzSoftening;
  const double r = std::sqrt(d + d0);
  const double base = (d + d0) * r - d0 * std::sqrt(d0);
  return m.hertz * (1.5 * r * (1.0 + m.alpha * d) + base * m.alpha);
}

class HertzModel final : public LocalModel {
 public:
  LocalModelKind kind() const override { return LocalModelKind::Hertz; }

  void step(const Material& m, VertexState& s, double f, double dt) const override {
    if (!(dt > 0)) return;
    // Backward Euler as for Exponential, with the Maxwell arm's force taken
    // at the relaxed q of the step's start (lagging one step; the arm itself
    // relaxes implicitly): G(h1) = c h1 + dt^2 (1 + g) s(h1) - R = 0,
    // c = m + b dt, R = c h0 + m dt v0 + dt^2 (f + g s(q0)). G is odd,
    // increasing and convex on h1 >= 0: Newton from an upper bound converges
    // monotonically.
    const double g = m.relaxation;
    const double c = m.mass + m.damping * dt;
    const double dt2 = dt * dt;
    const double arm = g > 0 ? g * hertz_spring(m, s.q) : 0.0;
    const double r = c * s.h + m.mass * dt * s.v + dt2 * (f + arm);
    const double sign = r < 0 ? -1.0 : 1.0;
    const double ra = std::abs(r);
    const double w = dt2 * (1.0 + g);
    // Upper bounds: S(h) >= S'(0) h (convex), and S(h) >= c((h+d0)^1.5 - d0^1.5).
    const double d0 = kHertzSoftening;
    const double lin = ra / (c + w * hertz_slope(m, 0.0));
    const double y = ra / (w * m.hertz) + d0 * std::sqrt(d0);
    const double pw = std::cbrt(y * y) - d0;
    double h = std::max(0.0, std::min(lin, pw));
    const double d0r = d0 * std::sqrt(d0);
    for (int it = 0; it < kNewtonIterations; ++it) {
      // hertz_spring(m, h) and hertz_slope(m, h) (h >= 0) sharing one square
      // root, every expression as written there (the same bits).
      const double root = std::sqrt(h + d0);
      const double base = (h + d0) * root - d0r;
      const double gv = c * h + w * (m.hertz * base * (1.0 + m.alpha * h)) - ra;
      const double gp = c + w * (m.hertz * (1.5 * root * (1.0 + m.alpha * h) + base * m.alpha));
      const double dh = gv / gp;
      h = std::max(h - dh, 0.0);
      if (!(std::abs(dh) > 1e-14 * h)) break;
    }
    const double h1 = sign * h;
    s.v = (h1 - s.h) / dt;
    s.h = h1;
    if (g > 0) {
      const double beta = dt / m.tau;
      s.q = (s.q + beta * h1) / (1.0 + beta);
    } else {
      s.q = 0.0;
    }
  }

  double equilibrium_force(const Material& m, double h) const override { return hertz_spring(m, h); }
  double restoring_force(const Material& m, double h, double v, double q) const override {
    const double g = m.relaxation;
    return -(1.0 + g) * hertz_spring(m, h) + (g > 0 ? g * hertz_spring(m, q) : 0.0) - m.damping * v;
  }

 private:
  static constexpr int kNewtonIterations = 40;
};

}  // namespace

double hertz_spring(const Material& m, double h) {
  const double d = std::abs(h);
  const double d0 = kHertzSoftening;
  const double mag = m.hertz * ((d + d0) * std::sqrt(d + d0) - d0 * std::sqrt(d0)) * (1.0 + m.alpha * d);
  return h < 0 ? -mag : mag;
}

double exponential_spring(const Material& m, double h) {
  // k h for alpha = 0; otherwise k expm1(alpha |h|) / alpha, linear past the cap.
  if (m.alpha == 0.0) return m.stiffness * h;
  const double x = m.alpha * std::abs(h);
  const double mag = x <= kExponentialCap
                         ? m.stiffness * std::expm1(x) / m.alpha
                         : m.stiffness / m.alpha *
                               (std::expm1(kExponentialCap) + std::exp(kExponentialCap) * (x - kExponentialCap));
  return h < 0 ? -mag : mag;
}

namespace {
// Constant-initialised: no guard or lock on first use (the haptic thread calls this).
constinit const LinearModel linear;
constinit const ExponentialModel exponential;
constinit const ViscoelasticModel viscoelastic;
constinit const HertzModel hertz_model;
}  // namespace

const LocalModel& local_model(LocalModelKind kind) {
  switch (kind) {
    case LocalModelKind::Exponential:
      return exponential;
    case LocalModelKind::Viscoelastic:
      return viscoelastic;
    case LocalModelKind::Hertz:
      return hertz_model;
    case LocalModelKind::Linear:
      break;
  }
  return linear;
}

}  // namespace palpa::deform
