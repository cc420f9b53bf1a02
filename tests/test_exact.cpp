// Exact reference solutions (trompo::exact::LagrangeTop, FreeBody), docs/theory.md §8:
//   1. agreement with the shared reference figures of HT0, HT1, FB1, FB2 (tests/data);
//   2. agreement with an independent fine integration (odeint Runge–Kutta–Fehlberg 7(8),
//      controlled, on the quaternion + Ω equations written below) on the standard and
//      on degenerate inputs: in double at tolerance 1e-14 (≤ 1e-10 wherever that
//      integration is itself accurate enough) and in long double at 1e-19 (≤ 1e-12);
//   3. invariants of the exact solution (H, γ·ΛJΩ for the top; H, ΛJΩ for the free body)
//      and orthonormality of Λ.
// Each case prints the errors it measured.
#include <catch2/catch.hpp>

#include "support/show.hpp"

#ifdef TROMPO_HAVE_BOOST

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <boost/math/special_functions/ellint_1.hpp>
#include <boost/math/special_functions/jacobi_elliptic.hpp>
// GCC 12 reports -Wmaybe-uninitialized inside odeint's stepper copy constructors (a false
// positive in Boost's code, instantiated here).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "data/reference_cases.hpp"
#include "trompo/exact/free_body.hpp"
#include "trompo/exact/lagrange_top.hpp"

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using trompo::exact::FreeBody;
using trompo::exact::LagrangeTop;

Matrix3d rot(double angle, const Vector3d& axis) { return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix(); }
Matrix3d Rx(double a) { return rot(a, Vector3d::UnitX()); }
Matrix3d Rz(double a) { return rot(a, Vector3d::UnitZ()); }

// ---- independent integration ----------------------------------------------------------
// State x = (q_w, q_x, q_y, q_z, Ω1, Ω2, Ω3):
//   q̇ = ½ q ⊗ (0, Ω)                          (dΛ/dt = ΛΩ̂, Λ = R(q))
//   J Ω̇ = JΩ × Ω − Mgl E × R(q)ᵀγ              (Euler with the gravity torque)
template <class S>
struct RigidBodyOde {
  std::array<S, 3> J, E, gamma;
  S Mgl;
  void operator()(const std::array<S, 7>& x, std::array<S, 7>& dx, S /*t*/) const {
    const S w = x[0], a = x[1], b = x[2], c = x[3];
    const S O1 = x[4], O2 = x[5], O3 = x[6];
    dx[0] = -(a * O1 + b * O2 + c * O3) / 2;
    dx[1] = (w * O1 + b * O3 - c * O2) / 2;
    dx[2] = (w * O2 + c * O1 - a * O3) / 2;
    dx[3] = (w * O3 + a * O2 - b * O1) / 2;
    // g = R(q)ᵀ γ (body components of γ), R(q) of the normalised quaternion
    const S n = w * w + a * a + b * b + c * c;
    const S R[3][3] = {{w * w + a * a - b * b - c * c, 2 * (a * b - w * c), 2 * (a * c + w * b)},
                       {2 * (a * b + w * c), w * w - a * a + b * b - c * c, 2 * (b * c - w * a)},
                       {2 * (a * c - w * b), 2 * (b * c + w * a), w * w - a * a - b * b + c * c}};
    S g[3];
    for (int i = 0; i < 3; ++i) g[i] = (R[0][i] * gamma[0] + R[1][i] * gamma[1] + R[2][i] * gamma[2]) / n;
    // T = −Mgl E × g
    const S T[3] = {-Mgl * (E[1] * g[2] - E[2] * g[1]), -Mgl * (E[2] * g[0] - E[0] * g[2]),
                    -Mgl * (E[0] * g[1] - E[1] * g[0])};
    const S P[3] = {J[0] * O1, J[1] * O2, J[2] * O3};  // Π = JΩ
    // J Ω̇ = Π × Ω + T
    dx[4] = (P[1] * O3 - P[2] * O2 + T[0]) / J[0];
    dx[5] = (P[2] * O1 - P[0] * O3 + T[1]) / J[1];
    dx[6] = (P[0] * O2 - P[1] * O1 + T[2]) / J[2];
  }
};

struct Sample {
  double t;
  Matrix3d L;
  Vector3d W;
};

struct Problem {
  Vector3d J;
  double Mgl;
  Vector3d gamma;  // unit
  Matrix3d L0;
  Vector3d W0;
  Vector3d E = Vector3d::UnitZ();  // the body point (the centre of mass direction)
};

// Integrate with RKF78 (controlled, abs = rel = tol) in scalar S, sampled at `times`.
template <class S>
std::vector<Sample> integrate(const Problem& p, const std::vector<double>& times, double tol) {
  namespace odeint = boost::numeric::odeint;
  using State = std::array<S, 7>;
  RigidBodyOde<S> ode{{S(p.J(0)), S(p.J(1)), S(p.J(2))}, {S(p.E(0)), S(p.E(1)), S(p.E(2))},
                      {S(p.gamma(0)), S(p.gamma(1)), S(p.gamma(2))}, S(p.Mgl)};
  const Eigen::Quaterniond q0(p.L0);
  State x{S(q0.w()), S(q0.x()), S(q0.y()), S(q0.z()), S(p.W0(0)), S(p.W0(1)), S(p.W0(2))};
  std::vector<S> ts(times.begin(), times.end());
  std::vector<Sample> out;
  auto stepper = odeint::make_controlled(S(tol), S(tol), odeint::runge_kutta_fehlberg78<State, S, State, S>());
  odeint::integrate_times(stepper, ode, x, ts.begin(), ts.end(), S(1e-3),
                          [&](const State& s, S t) {
                            // normalise in S, then round
                            const S n = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + s[3] * s[3]);
                            const Eigen::Quaterniond q(static_cast<double>(s[0] / n), static_cast<double>(s[1] / n),
                                                       static_cast<double>(s[2] / n), static_cast<double>(s[3] / n));
                            out.push_back({static_cast<double>(t), q.toRotationMatrix(),
                                           Vector3d(static_cast<double>(s[4]), static_cast<double>(s[5]),
                                                    static_cast<double>(s[6]))});
                          });
  return out;
}

std::vector<double> linspace(double T, int n) {
  std::vector<double> t(static_cast<std::size_t>(n) + 1);
  for (int i = 0; i <= n; ++i) t[static_cast<std::size_t>(i)] = T * i / n;
  return t;
}

using RotFn = std::function<Matrix3d(double)>;
using OmFn = std::function<Vector3d(double)>;

struct Errors {
  double L = 0, W = 0;
};

// max |Λ − Λ_ode| (entries) and max |Ω − Ω_ode| / max|Ω| over the samples.
Errors compare(const RotFn& L, const OmFn& W, const std::vector<Sample>& ref) {
  Errors e;
  double wmax = 0;
  for (const auto& s : ref) wmax = std::max(wmax, s.W.norm());
  if (wmax == 0) wmax = 1;
  for (const auto& s : ref) {
    e.L = std::max(e.L, (L(s.t) - s.L).cwiseAbs().maxCoeff());
    e.W = std::max(e.W, (W(s.t) - s.W).cwiseAbs().maxCoeff() / wmax);
  }
  return e;
}

struct Invariants {
  double H = 0, mu = 0, orth = 0;
};

// Drift of H = ½Ω·JΩ + Mgl γ·ΛE (relative to ½Ω0·JΩ0 + |Mgl|), of the momentum (ΛJΩ for
// the free body, γ·ΛJΩ for the top; relative to max_t |JΩ|), and max |ΛᵀΛ − I|, over n samples.
Invariants invariants(const RotFn& L, const OmFn& W, const Problem& p, double T, int n, bool full_momentum) {
  const Vector3d E = Vector3d::UnitZ();
  auto H = [&](const Matrix3d& Lt, const Vector3d& Wt) {
    return 0.5 * Wt.dot(p.J.cwiseProduct(Wt)) + p.Mgl * p.gamma.dot(Lt * E);
  };
  const Matrix3d L0 = L(0.0);
  const Vector3d W0 = W(0.0);
  const double H0 = H(L0, W0);
  const Vector3d pi0 = L0 * p.J.cwiseProduct(W0);
  const double Hscale = 0.5 * W0.dot(p.J.cwiseProduct(W0)) + std::abs(p.Mgl);
  double Pscale = std::numeric_limits<double>::min();
  for (double t : linspace(T, n)) Pscale = std::max(Pscale, p.J.cwiseProduct(W(t)).norm());
  Invariants r;
  for (double t : linspace(T, n)) {
    const Matrix3d Lt = L(t);
    const Vector3d Wt = W(t);
    const Vector3d pi = Lt * p.J.cwiseProduct(Wt);
    r.H = std::max(r.H, std::abs(H(Lt, Wt) - H0) / Hscale);
    r.mu = std::max(r.mu, full_momentum ? (pi - pi0).norm() / Pscale : std::abs(p.gamma.dot(pi - pi0)) / Pscale);
    r.orth = std::max(r.orth, (Lt.transpose() * Lt - Matrix3d::Identity()).cwiseAbs().maxCoeff());
  }
  return r;
}

Problem top_problem(double A, double C, double Mgl, const Matrix3d& L0, const Vector3d& W0,
                    const Vector3d& gamma = Vector3d::UnitZ()) {
  return {Vector3d(A, A, C), Mgl, gamma.normalized(), L0, W0};
}

// Whether long double carries more digits than double (x87 80-bit, or binary128).
constexpr bool have_extended_long_double = std::numeric_limits<long double>::digits > 60;

// Tolerance reached against the integrations (checked): the double one (RKF78, tol 1e-14)
// agrees to this on every case where its own error allows (double_ode_ok), the long
// double one (RKF78, tol 1e-19) on every case.
constexpr double tol_double_ode = 1e-10;
constexpr double tol_long_double_ode = 1e-12;

// Checks one exact solution against both integrations and its invariants.
// double_ode_ok = false where the double integration itself is not accurate to 1e-10
// (near the separatrix, or with |Ω| ~ 1e-4 against its absolute tolerance); it is
// then only reported.
void check_exact(const char* kind, const char* name, const RotFn& L, const OmFn& W, const Problem& p, double T,
                 bool full_momentum, bool double_ode_ok) {
  const auto times = linspace(T, 40);
  const Errors ed = compare(L, W, integrate<double>(p, times, 1e-14));
  Errors el;
  if (have_extended_long_double) el = compare(L, W, integrate<long double>(p, times, 1e-19));
  const Invariants inv = invariants(L, W, p, T, 400, full_momentum);
  std::printf("[exact] %s %-46s RKF78 double: |dL| %.1e |dW|/|W| %.1e; long double: |dL| %.1e |dW|/|W| %.1e; "
              "drift H %.1e %s %.1e; orth %.1e\n",
              kind, name, ed.L, ed.W, el.L, el.W, inv.H, full_momentum ? "pi" : "mu", inv.mu, inv.orth);
  INFO(kind << " " << name);
  if (double_ode_ok) {
    CHECK(ed.L <= tol_double_ode);
    CHECK(ed.W <= tol_double_ode);
  }
  if (have_extended_long_double) {
    CHECK(el.L <= tol_long_double_ode);
    CHECK(el.W <= tol_long_double_ode);
  } else {
    // Reported to ctest as skipped (SKIP_REGULAR_EXPRESSION), not shown as a pass.
    trompo_test::skip("long double is double here: the extended-precision comparison did not run");
  }
  CHECK(inv.H <= 1e-13);
  CHECK(inv.mu <= 1e-13);
  CHECK(inv.orth <= 1e-14);
}

void check_top(const char* name, const Problem& p, double T, bool double_ode_ok = true) {
  const LagrangeTop top(p.J(0), p.J(2), p.Mgl, p.L0, p.W0, p.gamma);
  check_exact("top ", name, [&](double t) { return top.rotation(t); }, [&](double t) { return top.omega(t); }, p, T,
              false, double_ode_ok);
}

void check_free(const char* name, const Problem& p, double T, bool double_ode_ok = true) {
  const FreeBody body(p.J, p.L0, p.W0);
  check_exact("free", name, [&](double t) { return body.rotation(t); }, [&](double t) { return body.omega(t); }, p, T,
              true, double_ode_ok);
}

// max |Λ − Λref| and max |Ω − Ωref|/|Ωref| over the rows of a reference table.
template <std::size_t N, std::size_t M>
Errors against_table(const RotFn& L, const OmFn& W, const double (&tab)[N][M]) {
  Errors e;
  for (const auto& row : tab) {
    Matrix3d R;
    for (int i = 0; i < 9; ++i) R(i / 3, i % 3) = row[1 + i];
    const Vector3d Wr(row[10], row[11], row[12]);
    e.L = std::max(e.L, (L(row[0]) - R).cwiseAbs().maxCoeff());
    e.W = std::max(e.W, (W(row[0]) - Wr).cwiseAbs().maxCoeff() / Wr.norm());
  }
  return e;
}

// The standard cases (docs/theory.md §8).
Problem ht0() { return top_problem(5, 1, 196.2, Rx(0.3), Vector3d(0, 0, 50)); }
Problem ht1() { return top_problem(5, 1, 20, Rx(0.05), Vector3d(0, 0, 50)); }
Problem fb1() { return {Vector3d(1, 2, 3), 0.0, Vector3d::UnitZ(), Matrix3d::Identity(), Vector3d(0.01, 2, 0.01)}; }
Problem fb2() {
  const Vector3d J(2, 1, 2.0 / 3.0);
  return {J, 0.0, Vector3d::UnitZ(), Matrix3d::Identity(), Vector3d(std::cos(1.1), 0, std::sin(1.1)).cwiseQuotient(J)};
}

}  // namespace

// ---- 1. reference figures ----------------------------------------------------------------

TEST_CASE("exact: LagrangeTop reproduces the HT0 and HT1 reference figures", "[exact][top]") {
  namespace ref = trompo_test::reference;
  struct Case {
    const char* name;
    Problem p;
    const double (*tab)[15];
  };
  for (const auto& c : {Case{"HT0", ht0(), ref::ht0}, Case{"HT1", ht1(), ref::ht1}}) {
    const LagrangeTop top(c.p.J(0), c.p.J(2), c.p.Mgl, c.p.L0, c.p.W0);
    Errors e;
    double dH = 0, dmu = 0;
    for (int i = 0; i < 21; ++i) {
      const double* row = c.tab[i];
      Matrix3d R;
      for (int k = 0; k < 9; ++k) R(k / 3, k % 3) = row[1 + k];
      const Vector3d Wr(row[10], row[11], row[12]);
      const Matrix3d L = top.rotation(row[0]);
      const Vector3d W = top.omega(row[0]);
      e.L = std::max(e.L, (L - R).cwiseAbs().maxCoeff());
      e.W = std::max(e.W, (W - Wr).cwiseAbs().maxCoeff() / Wr.norm());
      const double H = 0.5 * W.dot(c.p.J.cwiseProduct(W)) + c.p.Mgl * L(2, 2);
      dH = std::max(dH, std::abs(H - row[13]) / std::abs(row[13]));
      dmu = std::max(dmu, std::abs((L * c.p.J.cwiseProduct(W))(2) - row[14]) / std::abs(row[14]));
    }
    std::printf("[exact] top  %-44s vs reference: |dL| %.1e |dW|/|W| %.1e; H %.1e mu %.1e\n", c.name, e.L, e.W, dH, dmu);
    INFO(c.name);
    CHECK(e.L <= 5e-13);  // measured ≤ 1e-13 (t up to 100: angles of ~400 rad)
    CHECK(e.W <= 5e-13);
    CHECK(dH <= 1e-13);
    CHECK(dmu <= 1e-13);
  }
}

TEST_CASE("exact: FreeBody reproduces the FB1 and FB2 reference figures", "[exact][free]") {
  namespace ref = trompo_test::reference;
  for (int k = 0; k < 2; ++k) {
    const Problem p = (k == 0) ? fb1() : fb2();
    const auto& tab = (k == 0) ? ref::fb1 : ref::fb2;
    const FreeBody body(p.J, p.L0, p.W0);
    const Errors e = against_table([&](double t) { return body.rotation(t); }, [&](double t) { return body.omega(t); }, tab);
    double dpi = 0;
    for (const auto& row : tab) {
      const Vector3d pi = body.rotation(row[0]) * p.J.cwiseProduct(body.omega(row[0]));
      dpi = std::max(dpi, (pi - Vector3d(row[15], row[16], row[17])).norm() / Vector3d(row[15], row[16], row[17]).norm());
    }
    const char* name = (k == 0) ? "FB1" : "FB2";
    std::printf("[exact] free %-44s vs reference: |dL| %.1e |dW|/|W| %.1e; pi %.1e\n", name, e.L, e.W, dpi);
    INFO(name);
    CHECK(e.L <= 5e-13);  // measured ≤ 1e-13 (t up to 100: angles of ~400 rad)
    CHECK(e.W <= 5e-13);
    CHECK(dpi <= 1e-13);
  }
}

// ---- 2. independent integration and 3. invariants ----------------------------------------

TEST_CASE("exact: standard cases agree with an RKF78 integration", "[exact][ode]") {
  check_top("HT0", ht0(), 10);
  check_top("HT1", ht1(), 10);
  // FB1 runs next to the separatrix (k'² = 5e-5): the double integration drifts to ~5e-10.
  check_free("FB1 (max-inertia side of the separatrix)", fb1(), 100, false);
  check_free("FB2 (min-inertia side)", fb2(), 100);
}

TEST_CASE("exact: HT2's reference rows agree with an independent RKF78 run in long double", "[exact][ode][ht2]") {
  // HT2 has no closed form: its rows in tests/data/reference_cases.hpp are a published
  // RKF7(8) run in 128-bit floats. Here they are checked against odeint's RKF78 in long
  // double at tol 1e-19 (a different integrator's code and arithmetic; the initial Ω3 =
  // −4.61538 rounded to double), at both rows (t = 0.5 and 2): Λ entries and Ω relative to
  // |Ω|. scripts/reference_tables.py --check reproduces them to 25 digits in 50-digit
  // arithmetic (a Taylor-series run; not part of the test command).
  if (!have_extended_long_double) {
    trompo_test::skip("long double is double here: the HT2 reference check did not run");
    return;
  }
  namespace ref = trompo_test::reference;
  Problem p{Vector3d(15.234375, 0.46875, 15.234375), 15 * 9.81, Vector3d::UnitZ(), Matrix3d::Identity(),
            Vector3d(0, 150, -4.61538), Vector3d::UnitY()};
  const std::vector<Sample> run = integrate<long double>(p, {0.0, ref::ht2[0][0], ref::ht2[1][0]}, 1e-19);
  REQUIRE(run.size() == 3);
  double dL = 0, dW = 0;
  for (int i = 0; i < 2; ++i) {
    const double* row = ref::ht2[i];
    const Sample& s = run[static_cast<std::size_t>(i) + 1];
    REQUIRE(s.t == row[0]);
    Matrix3d R;
    for (int k = 0; k < 9; ++k) R(k / 3, k % 3) = row[1 + k];
    const Vector3d Wr(row[10], row[11], row[12]);
    dL = std::max(dL, (s.L - R).cwiseAbs().maxCoeff());
    dW = std::max(dW, (s.W - Wr).cwiseAbs().maxCoeff() / Wr.norm());
    // the rows' own invariants: H and μ as at t = 0 (the case's definition)
    const double H = 0.5 * s.W.dot(p.J.cwiseProduct(s.W)) + p.Mgl * (s.L * p.E)(2);
    CHECK(std::abs(H - row[13]) <= 1e-13 * row[13]);
    CHECK(std::abs((s.L * p.J.cwiseProduct(s.W))(2) - row[14]) <= 1e-13 * p.J.cwiseProduct(p.W0).norm());
  }
  std::printf("[exact] HT2 reference rows vs RKF78 long double: |dL| %.1e |dW|/|W| %.1e\n", dL, dW);
  // Measured (g++ 12, x86-64, 80-bit long double): |dL| 3.4e-14, |dW|/|W| 1.5e-15; the
  // bound, 3e-13, fails a row wrong in its 13th digit.
  CHECK(dL <= 3e-13);
  CHECK(dW <= 3e-13);
}

TEST_CASE("exact: LagrangeTop on degenerate and other inputs", "[exact][top][ode]") {
  SECTION("steady precession (k -> 0)") {
    const double A = 5, C = 1, Mgl = 20, th = 0.5, W3 = 50;
    // Mgl = φ̇ (C Ω3 − A φ̇ cos θ): slow root φ̇ = 2 Mgl / (C Ω3 + √(C²Ω3² − 4 A Mgl cos θ))
    const double phid = 2 * Mgl / (C * W3 + std::sqrt(C * C * W3 * W3 - 4 * A * Mgl * std::cos(th)));
    const Problem p = top_problem(A, C, Mgl, Rx(th), Vector3d(0, phid * std::sin(th), W3));
    check_top("steady precession", p, 10);
    const LagrangeTop top(A, C, Mgl, p.L0, p.W0);
    double du = 0;
    for (double t : linspace(10, 200)) du = std::max(du, std::abs(top.rotation(t)(2, 2) - std::cos(th)));
    std::printf("[exact] top  steady precession: max |cos θ(t) − cos θ0| = %.1e\n", du);
    CHECK(du <= 1e-13);
  }
  SECTION("near vertical, fast (stable sleeping), tilt 1e-6") {
    check_top("near vertical, stable, tilt 1e-6", top_problem(5, 1, 20, Rx(1e-6), Vector3d(0, 0, 50)), 10);
  }
  SECTION("near vertical, slow (falls), tilt 1e-6") {
    // Unstable upright (C²Ω3² < 4 A Mgl, k'² ≈ 1e-12): the top falls, nutates down to
    // cos θ = 0.31 and climbs back to a tilt of 1e-6 near t = 8. Integration errors grow like
    // e^{3.8 t} near the upright: the double integration is off by ~1e-8, and past the second
    // approach (t > 7) even the long double one is not converged, so the span is [0, 7].
    check_top("near vertical, falls, tilt 1e-6, t <= 7", top_problem(5, 1, 196.2, Rx(1e-6), Vector3d(0, 0, 50)), 7,
              false);
  }
  SECTION("sleeping top (tilt 0)") {
    const Problem p = top_problem(5, 1, 196.2, Rz(0.7), Vector3d(0, 0, 50));
    check_top("sleeping top, tilt 0", p, 10);
    const LagrangeTop top(5, 1, 196.2, p.L0, p.W0);
    double e = 0;
    for (double t : linspace(10, 50)) e = std::max(e, (top.rotation(t) - Rz(0.7 + 50 * t)).cwiseAbs().maxCoeff());
    CHECK(e <= 1e-13);
  }
  SECTION("starts exactly upright with a transverse velocity") {
    check_top("upright start, Omega0 = (0.3, 0.1, 5)", top_problem(5, 1, 20, Matrix3d::Identity(), Vector3d(0.3, 0.1, 5)), 10);
  }
  SECTION("hanging top (Mgl < 0)") {
    check_top("hanging top, Mgl = -50", top_problem(5, 1, -50, Rx(0.4), Vector3d(1, -2, 10)), 10);
    // |Ω| ~ 1e-4: the absolute tolerance 1e-14 of the double integration limits |dΩ|/|Ω| to ~1e-10
    check_top("hanging top, Mgl = -20, near rest", top_problem(5, 1, -20, Rx(1e-5), Vector3d(1e-4, 0, 0)), 10, false);
  }
  SECTION("slow, non-spinning, pendulum-like tops") {
    check_top("plane pendulum through the bottom (Omega0 = 0)", top_problem(5, 1, 20, Rx(1.0), Vector3d::Zero()), 10);
    check_top("spherical pendulum near the bottom", top_problem(5, 1, 20, Rx(2.9), Vector3d(0.05, 0.02, 0)), 10);
    check_top("looping pendulum through both verticals", top_problem(5, 1, 20, Matrix3d::Identity(), Vector3d(6, 0, 0)),
              10);
    // planar motions have D₋ = D₊ = 0 exactly: u = ±1 are roots of f whether or not they are reached
    check_top("plane pendulum swinging, u3 = 1", top_problem(5, 1, 20, Rx(1.0), Vector3d(1, 0, 0)), 10);
    check_top("plane pendulum looping from a tilt", top_problem(5, 1, 20, Rx(1.0), Vector3d(3, 0, 0)), 10);
    const Matrix3d down = Vector3d(1, -1, -1).asDiagonal();  // exactly hanging: Λ0 E = −γ
    check_top("plane pendulum launched from the bottom", top_problem(5, 1, 20, down, Vector3d(1, 0, 0)), 10);
    check_top("plane pendulum looping from the bottom", top_problem(5, 1, 20, down, Vector3d(5, 0, 0)), 10);
    check_top("exactly hanging start, Omega0 = (0.5, 0.2, 3)", top_problem(5, 1, 20, down, Vector3d(0.5, 0.2, 3)), 10);
    // ½Aω² = 2Mgl exactly: the pendulum creeps up to the upright (k = 1, no period)
    check_top("plane pendulum on its separatrix (k = 1)", top_problem(4, 1, 1, down, Vector3d(1, 0, 0)), 10);
    const LagrangeTop sep(4, 1, 1, down, Vector3d(1, 0, 0));
    for (double t : {100.0, 1000.0, -1000.0}) {
      CHECK(sep.rotation(t).allFinite());
      CHECK(sep.omega(t).allFinite());
      CHECK(sep.rotation(t)(2, 2) >= 1.0 - 1e-14);  // at the upright
    }
  }
  SECTION("gamma not along e3") {
    const Vector3d g = Vector3d(1, 2, -0.5).normalized();
    check_top("gamma = (1, 2, -0.5)/|.|",
              top_problem(5, 1, 20, rot(0.9, Vector3d(0.3, -1, 0.2)), Vector3d(0.5, -1, 30), g), 10);
    check_top("gamma = -e3 (upside down)", top_problem(5, 1, 20, Rx(0.3), Vector3d(0.2, 0, 20), -Vector3d::UnitZ()), 10);
  }
  SECTION("oblate top (C > A)") {
    check_top("oblate, A = 1, C = 1.8", top_problem(1, 1.8, 5, Rx(0.8), Vector3d(0.3, -0.2, 12)), 10);
  }
  SECTION("Mgl = 0: a free symmetric body, also against FreeBody") {
    const Problem p = top_problem(5, 1, 0, rot(0.7, Vector3d(1, 0.4, -0.3)), Vector3d(1, 0.5, 20));
    check_top("Mgl = 0", p, 10);
    const LagrangeTop top(5, 1, 0, p.L0, p.W0);
    const FreeBody body(p.J, p.L0, p.W0);
    Errors e;
    for (double t : linspace(10, 50)) {
      e.L = std::max(e.L, (top.rotation(t) - body.rotation(t)).cwiseAbs().maxCoeff());
      e.W = std::max(e.W, (top.omega(t) - body.omega(t)).cwiseAbs().maxCoeff() / p.W0.norm());
    }
    CHECK(e.L <= 1e-12);
    CHECK(e.W <= 1e-12);
  }
  SECTION("at rest") {
    for (double Mgl : {20.0, -20.0}) {
      const LagrangeTop top(5, 1, Mgl, Matrix3d::Identity(), Vector3d::Zero());
      for (double t : {0.0, 1.0, 100.0}) {
        CHECK((top.rotation(t) - Matrix3d::Identity()).cwiseAbs().maxCoeff() <= 1e-15);
        CHECK(top.omega(t).cwiseAbs().maxCoeff() == 0.0);
      }
    }
    check_top("at rest, upright (unstable equilibrium)", top_problem(5, 1, 20, Matrix3d::Identity(), Vector3d::Zero()), 10);
  }
  SECTION("negative time") {
    const Problem p = ht1();
    const LagrangeTop top(p.J(0), p.J(2), p.Mgl, p.L0, p.W0);
    // started from the state at t = −3, the solution returns to the initial state at t = 0
    const LagrangeTop back(p.J(0), p.J(2), p.Mgl, top.rotation(-3.0), top.omega(-3.0));
    CHECK((back.rotation(3.0) - p.L0).cwiseAbs().maxCoeff() <= 1e-12);
    CHECK((back.omega(3.0) - p.W0).cwiseAbs().maxCoeff() <= 1e-12 * p.W0.norm());
  }
}

TEST_CASE("exact: FreeBody on degenerate and other inputs", "[exact][free][ode]") {
  const Matrix3d L0 = rot(1.3, Vector3d(0.2, -0.5, 1));
  SECTION("symmetric bodies (two equal moments)") {
    check_free("J = (2, 2, 1)", {Vector3d(2, 2, 1), 0, Vector3d::UnitZ(), L0, Vector3d(0.3, -0.4, 1.1)}, 100);
    check_free("J = (1, 3, 3)", {Vector3d(1, 3, 3), 0, Vector3d::UnitZ(), L0, Vector3d(0.8, 0.1, -0.5)}, 100);
  }
  SECTION("rotation about a principal axis") {
    for (const Vector3d& W0 : {Vector3d(0, 2, 0), Vector3d(0, 0, 1.5), Vector3d(-0.7, 0, 0), Vector3d(0, 0, 0)}) {
      const FreeBody body(Vector3d(1, 2, 3), L0, W0);
      double e = 0;
      for (double t : linspace(100, 50)) {
        const Matrix3d expected = L0 * Eigen::AngleAxisd(t * W0.norm(), W0.norm() > 0 ? Vector3d(W0.normalized()) : Vector3d::UnitX()).toRotationMatrix();
        e = std::max(e, (body.rotation(t) - expected).cwiseAbs().maxCoeff());
        CHECK((body.omega(t) - W0).norm() == 0.0);
      }
      CHECK(e <= 1e-13);
    }
    check_free("principal axis, max inertia", {Vector3d(1, 2, 3), 0, Vector3d::UnitZ(), L0, Vector3d(0, 0, 1.5)}, 100);
    check_free("spherical body J = (2, 2, 2)", {Vector3d(2, 2, 2), 0, Vector3d::UnitZ(), L0, Vector3d(0.3, -1, 0.4)}, 100);
  }
  SECTION("either side of the separatrix") {
    check_free("near separatrix, min-inertia side", {Vector3d(1, 2, 3), 0, Vector3d::UnitZ(), L0, Vector3d(0.03, 2, 0.01)},
               100);
    check_free("near separatrix, max-inertia side", {Vector3d(1, 2, 3), 0, Vector3d::UnitZ(), L0, Vector3d(0.01, 2, 0.03)},
               100);
    check_free("generic, unsorted J = (3, 1, 2)", {Vector3d(3, 1, 2), 0, Vector3d::UnitZ(), L0, Vector3d(0.4, -1.2, 0.7)}, 100);
    check_free("generic, negative components", {Vector3d(1, 2, 3), 0, Vector3d::UnitZ(), L0, Vector3d(-0.5, -0.4, -0.9)}, 100);
  }
  SECTION("close to degenerate") {
    check_free("nearly principal (1e-7 off the max axis)", {Vector3d(1, 2, 3), 0, Vector3d::UnitZ(), L0, Vector3d(1e-7, 0, 1.5)},
               100);
    check_free("nearly symmetric J = (1, 1 + 1e-9, 2)",
               {Vector3d(1, 1 + 1e-9, 2), 0, Vector3d::UnitZ(), L0, Vector3d(0.3, 0.2, 1)}, 100);
    check_free("extreme ratio J = (1e-3, 1, 1.001)", {Vector3d(1e-3, 1, 1.001), 0, Vector3d::UnitZ(), L0, Vector3d(0.5, 0.2, 0.3)},
               10);
  }
  SECTION("backward in time") {
    const Problem p = fb2();
    const FreeBody body(p.J, p.L0, p.W0);
    const FreeBody back(p.J, body.rotation(-30.0), body.omega(-30.0));
    CHECK((back.rotation(30.0) - p.L0).cwiseAbs().maxCoeff() <= 1e-12);
    CHECK((back.omega(30.0) - p.W0).cwiseAbs().maxCoeff() <= 1e-12 * p.W0.norm());
  }
  SECTION("exactly on the separatrix: k = 1, no NaN") {
    // J = (3, 4, 6), Π0 = (1, 1, 1) (exact in floating point): G² − 2T J_mid = Π1²(3 − 4)/3 + Π3²(6 − 4)/6 = 0.
    const Vector3d J(3, 4, 6);
    const Vector3d W0(1.0 / 3.0, 0.25, 1.0 / 6.0);
    REQUIRE(J.cwiseProduct(W0) == Vector3d(1, 1, 1));
    const FreeBody body(J, Matrix3d::Identity(), W0);
    // No period: an evaluation at large |t| runs the flow over all of t (in pieces); the
    // spatial momentum π = Λ J Ω stays π0 there, which a stale or non-finite Λ would not.
    const Vector3d pi0 = J.cwiseProduct(W0);  // Λ0 = I
    for (double t : {-1e6, -1000.0, -10.0, 0.0, 1.0, 10.0, 100.0, 1000.0, 1e6}) {
      CHECK(body.rotation(t).allFinite());
      CHECK(body.omega(t).allFinite());
      CHECK((body.rotation(t) * J.cwiseProduct(body.omega(t)) - pi0).norm() <= 1e-12 * pi0.norm());
    }
    CHECK(std::abs(J(1) * body.omega(1e6)(1) - std::sqrt(3.0)) <= 1e-14);
    // Past |λt| = 80 the body spins steadily about the middle axis: the same attitude as the
    // flow run in one call (which holds to |λt| ≈ 150 before round-off leaves the axis).
    trompo::EulerPoinsot<double> flow(J);
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    Vector3d P = J.cwiseProduct(W0);
    flow.advance(q, P, 1000.0);  // |λ| = 0.144: |λt| = 144
    CHECK((body.rotation(1000.0) - q.toRotationMatrix()).norm() <= 1e-12);
    // Π tends to ±G e_mid as t → ±∞ (the unstable axis, reached asymptotically; no period)
    CHECK(std::abs(J(1) * body.omega(1000.0)(1) - std::sqrt(3.0)) <= 1e-14);
    CHECK(std::abs(J(1) * body.omega(-1000.0)(1) + std::sqrt(3.0)) <= 1e-14);
    check_free("exactly on the separatrix", {J, 0, Vector3d::UnitZ(), Matrix3d::Identity(), W0}, 40);
  }
}

// ---- input checks and the elliptic helpers ----------------------------------------------

TEST_CASE("exact: invalid inputs throw trompo::invalid_input naming the field and the value", "[exact]") {
  using Catch::Matchers::Contains;
  const Matrix3d I = Matrix3d::Identity();
  const Vector3d W(0, 0, 1);
  // The same exception as the rest of the library (errors.hpp), still a std::invalid_argument.
  CHECK_THROWS_AS(LagrangeTop(0, 1, 1, I, W), trompo::invalid_input);
  CHECK_THROWS_AS(FreeBody(Vector3d(1, 0, 2), I, W), std::invalid_argument);
  CHECK_THROWS_WITH(LagrangeTop(0, 1, 1, I, W), Contains("LagrangeTop: A") && Contains("got 0"));
  CHECK_THROWS_WITH(LagrangeTop(1, -1, 1, I, W), Contains("LagrangeTop: C") && Contains("got -1"));
  CHECK_THROWS_WITH(LagrangeTop(1, 1, std::nan(""), I, W), Contains("Mgl") && Contains("nan"));
  CHECK_THROWS_WITH(LagrangeTop(1, 1, 1, I, W, Vector3d::Zero()), Contains("gamma") && Contains("(0, 0, 0)"));
  CHECK_THROWS_WITH(LagrangeTop(1, 1, 1, 2.0 * I, W), Contains("Lambda0 is not a rotation") && Contains("= 3"));
  CHECK_THROWS_WITH(LagrangeTop(1, 1, 1, -I, W), Contains("Lambda0 is not a rotation, determinant -1"));
  CHECK_THROWS_WITH(LagrangeTop(1, 1, 1, I, Vector3d(0, std::nan(""), 1)), Contains("Omega0") && Contains("nan"));
  CHECK_THROWS_WITH(FreeBody(Vector3d(1, 0, 2), I, W), Contains("FreeBody: the moments of inertia J") &&
                                                          Contains("(1, 0, 2)"));
  CHECK_THROWS_WITH(FreeBody(Vector3d(1, -2, 2), I, W), Contains("(1, -2, 2)"));
  CHECK_THROWS_WITH(FreeBody(Vector3d(1, 2, 3), I, Vector3d(0, std::numeric_limits<double>::infinity(), 0)),
                    Contains("FreeBody: Omega0") && Contains("inf"));
  CHECK_THROWS_AS(FreeBody(Vector3d(1, 2, 3), I * std::nan(""), W), trompo::invalid_input);
}

TEST_CASE("exact: FreeBody (Euler-Poinsot flow) agrees with the published closed form", "[exact][free]") {
  // FreeBody evaluates by the exact flow over t mod the period of Π plus the whole periods'
  // precession; FreeBodyClosedForm is the published solution (Jacobi functions and Carlson R_J).
  std::mt19937_64 rng(20261125);
  std::uniform_real_distribution<double> U(-1.0, 1.0), M(1.0, 3.0), T(0.0, 1000.0);
  double worst = 0;
  for (int k = 0; k < 12; ++k) {
    const Vector3d J = k == 0 ? Vector3d(1, 2, 3) : Vector3d(M(rng), M(rng), M(rng));
    const Vector3d W0 = k == 0 ? Vector3d(0.01, 2, 0.01) : Vector3d(U(rng), U(rng), U(rng));
    const Matrix3d L0 = Eigen::AngleAxisd(2 * U(rng), Vector3d(U(rng), U(rng), U(rng)).normalized()).toRotationMatrix();
    const trompo::exact::FreeBody fast(J, L0, W0);
    const trompo::exact::FreeBodyClosedForm closed(J, L0, W0);
    for (int i = 0; i < 20; ++i) {
      const double t = i == 0 ? 100.0 : T(rng);
      const double e = (fast.rotation(t) - closed.rotation(t)).norm() + (fast.omega(t) - closed.omega(t)).norm();
      INFO("J = " << J.transpose() << " W0 = " << W0.transpose() << " t = " << t << ": " << e);
      // the closed form itself is good to ~1e-13 (FB1 7.8e-14); t up to 1000 (~50 periods)
      CHECK(e <= 2e-11);
      worst = std::max(worst, e);
    }
  }
  std::printf("FreeBody (flow) vs FreeBodyClosedForm, 12 bodies x 20 times in [0, 1000]: worst %.2e\n", worst);
}

TEST_CASE("exact: Jacobi elliptic functions with the complementary parameter", "[exact]") {
  using trompo::exact::detail::Elliptic;
  using trompo::exact::detail::jacobi_sncndn;
  for (double k : {0.0, 0.1, 0.5, 0.9, 0.99, 0.999}) {
    const double m = k * k, mc = (1 - k) * (1 + k);
    const Elliptic e(m, mc);
    CHECK(std::abs(e.K() - boost::math::ellint_1(k)) <= 1e-14 * e.K());
    for (double u : {-3.7, -1.0, 0.0, 0.4, 1.3, 2.9, 6.0}) {
      double sn, cn, dn;
      jacobi_sncndn(u, m, mc, sn, cn, dn);
      double bcn, bdn;
      const double bsn = boost::math::jacobi_elliptic(k, u, &bcn, &bdn);
      CHECK(std::abs(sn - bsn) <= 1e-14);
      CHECK(std::abs(cn - bcn) <= 1e-14);
      CHECK(std::abs(dn - bdn) <= 1e-14);
    }
  }
  // k' → 0 with k' given exactly: the phase is reduced across periods, and cn keeps its
  // relative accuracy next to its zero when the phase is given as n K + offset:
  // cn(K − x) = k' sn x / dn x ≈ k' x.
  const Elliptic e(1 - 1e-12, 1e-12);
  const auto p = e.phase(5 * e.K() - 1e-3);
  CHECK(p.j == 2);
  CHECK(std::abs(p.sn - 1.0) <= 1e-14);
  for (double x : {1e-3, 1e-8, 1e-14}) {
    double cx, dx;
    const double sx = boost::math::jacobi_elliptic(std::sqrt(1 - 1e-12), x, &cx, &dx);  // small x: k barely matters
    const double cn_expected = 1e-6 * sx / dx, dn_expected = 1e-6 / dx;
    const auto q = e.phase(-x, 1);  // τ = K − x
    CHECK(q.j == 0);
    CHECK(std::abs(q.cn - cn_expected) <= 1e-14 * cn_expected);
    CHECK(std::abs(q.dn - dn_expected) <= 1e-14 * dn_expected);
    const auto r = e.phase(x, -3);  // τ = −3K + x, |cn τ| = cn(K − x)
    CHECK(std::abs(std::abs(r.sign() * r.cn) - cn_expected) <= 1e-14 * cn_expected);
  }
  // the amplitude ↔ phase round trip near the quarter period
  double off = 0;
  long n = 0;
  e.phase_of_amplitude(std::cos(1e-9), std::sin(1e-9), off, n);  // φ = π/2 − 1e-9
  CHECK(n == 1);
  const auto back = e.phase(off, n);
  CHECK(std::abs(back.cn - std::sin(1e-9)) <= 1e-14 * 1e-9);
}

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

#else
TEST_CASE("exact: Boost not available", "[exact]") { trompo_test::skip("trompo/exact needs Boost.Math"); }
#endif
