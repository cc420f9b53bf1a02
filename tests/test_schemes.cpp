// The schemes on the standard cases (docs/theory.md §3, §4, §7, §8): invariants over 10⁴ steps,
// observed orders against closed-form references, symmetry, Newton iteration counts and
// the reproduction of the reference table of docs/theory.md §7.
//
// References are the project's independent solutions (closed-form Lagrange top and free
// body, RKF78 in 128-bit for HT2), copied into support/trompo_test.hpp.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "support/show.hpp"
#include "support/trompo_test.hpp"

using namespace trompo;
using trompo_test::Mat3;
using trompo_test::Reference;
using trompo_test::RunStats;
using trompo_test::Vec3;

namespace {

/// The cases of the issue, with the step of the 10⁴-step invariant runs.
struct CaseRun {
  const char* name;
  double h;
  long steps;
};

template <class Scheme, class Case>
RunStats<double> run_case(const Case& c, double h, long steps, Scheme scheme = Scheme{}) {
  Stepper<Scheme, typename Case::SceneT> stepper(scheme, c.scene);
  return trompo_test::run(stepper, c.initial, h, steps);
}

/// Calls f(case, run) for HT0, HT1, HT2 (gravity) and FB1 (free), each with h and a step
/// count of 10⁴: HT0/HT1 h = 1e-3 (t = 10), HT2 h = 2e-4 (t = 2), FB1 h = 1e-2 (t = 100).
template <class F>
void for_each_case(F&& f) {
  f(cases::ht0<double>(), CaseRun{"HT0", 1e-3, 10000});
  f(cases::ht1<double>(), CaseRun{"HT1", 1e-3, 10000});
  f(cases::ht2<double>(), CaseRun{"HT2", 2e-4, 10000});
  f(cases::fb1<double>(), CaseRun{"FB1", 1e-2, 10000});
}

double rotation_error(const State<double>& s, const Reference& ref) {
  return trompo_test::frobenius(s.rotation.matrix() - ref.rotation());
}

}  // namespace

// =====================================================================================
// An independent implementation of the paper forms of docs/theory.md §3–§4, for the
// figures of §4 and §7: written from the equations alone ([T1] with α, κ of Simo-α ½,
// collocation [T2] and Simo-κ (19); [T4]; [T5]), with its own Rodrigues formula and a
// plain Newton on a central-difference Jacobian — no trompo code. It plays the part the
// prototype played (finite-difference Newton) when the figures were first measured: the
// tests below hold trompo's figures to it instead of to pasted numbers.
namespace {
namespace paper {

/// HT0 of docs/theory.md §7, written out: J = diag(5, 5, 1), Mgl = 196.2, E = γ = e3,
/// Λ0 = exp(0.3 ê1), Ω0 = (0, 0, 50).
struct Top {
  Mat3 J = Vec3(5.0, 5.0, 1.0).asDiagonal();
  double Mgl = 20 * 9.81;
  Vec3 E = Vec3::UnitZ(), gamma = Vec3::UnitZ();
  double energy(const Mat3& L, const Vec3& W) const { return 0.5 * W.dot(J * W) + Mgl * gamma.dot(L * E); }
  double mu(const Mat3& L, const Vec3& W) const { return (L * (J * W)).dot(gamma); }
};

Mat3 hat(const Vec3& x) {
  Mat3 m;
  m << 0, -x.z(), x.y(), x.z(), 0, -x.x(), -x.y(), x.x(), 0;
  return m;
}

/// exp(x̂) = I + (sin θ/θ) x̂ + ((1 − cos θ)/θ²) x̂²; every increment here has θ > 0.01.
Mat3 rodrigues(const Vec3& x) {
  const double t = x.norm();
  const Mat3 X = hat(x);
  return Mat3::Identity() + (std::sin(t) / t) * X + ((1 - std::cos(t)) / (t * t)) * X * X;
}

/// Newton with a central-difference Jacobian, to |dx| <= 1e-15 |x|.
template <class F>
Vec3 newton(const F& f, Vec3 x) {
  for (int it = 0; it < 60; ++it) {
    const Vec3 r = f(x);
    Mat3 K;
    const double d = 1e-6 * x.norm();
    for (int j = 0; j < 3; ++j) {
      Vec3 p = x, m = x;
      p(j) += d;
      m(j) -= d;
      K.col(j) = (f(p) - f(m)) / (2 * d);
    }
    const Vec3 dx = K.partialPivLu().solve(-r);
    x += dx;
    if (dx.norm() <= 1e-15 * x.norm()) return x;
  }
  return Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
}

enum class Form { alpha_half, collocation, kappa, gb_t4, gb_t5 };

/// Collocation's α(Θ) of [T2]: the root in [0, 1] nearest ½ of
/// B (cos θ − 1) + C sin θ = θ ρ cos(αθ + φ), solved in closed form (long double: acos is
/// ill-conditioned where the two roots meet).
double collocation_alpha(const Top& top, const Mat3& L, const Vec3& Th) {
  using LD = long double;
  const LD th = LD(Th.norm());
  const Vec3 n = Th / Th.norm(), w = L.transpose() * top.gamma;
  const LD B = LD(top.E.dot(w)) - LD(n.dot(top.E)) * LD(n.dot(w)), C = LD(n.cross(top.E).dot(w));
  const LD rho = std::hypot(B, C), phi = std::atan2(B, C);
  const LD v = std::clamp((B * (std::cos(th) - 1) + C * std::sin(th)) / (th * rho), LD(-1), LD(1));
  const LD a = std::acos(v), two_pi = 2 * std::acos(LD(-1));
  LD best = 0.5L, dist = 2;
  for (int k = -3; k <= 3; ++k)
    for (LD s : {a, -a}) {
      const LD alpha = (s - phi + k * two_pi) / th;
      if (alpha >= 0 && alpha <= 1 && std::abs(alpha - 0.5L) < dist) {
        best = alpha;
        dist = std::abs(alpha - 0.5L);
      }
    }
  return double(best);
}

struct Figures {
  Mat3 L;
  Vec3 W;
  double max_dH = 0, max_dmu = 0;
  long failures = 0;
};

/// `steps` steps of h from HT0's initial state, in the given form.
Figures run(Form form, double h, long steps) {
  const Top top;
  Figures f;
  f.L = rodrigues(Vec3(0.3, 0, 0));
  f.W = Vec3(0, 0, 50);
  const double H0 = top.energy(f.L, f.W), mu0 = top.mu(f.L, f.W);
  for (long k = 0; k < steps; ++k) {
    const Mat3 L = f.L;
    const Vec3 W = f.W, P = top.J * W;
    const Vec3 b = -top.Mgl * (L.transpose() * top.gamma);  // the load in body frame n
    if (form == Form::gb_t4 || form == Form::gb_t5) {
      auto half = [](const Vec3& e) {  // F, the half rotation, (40)
        const double e0 = std::sqrt(1 - e.squaredNorm());
        return Mat3(e0 * Mat3::Identity() + e * e.transpose() / (1 + e0) + hat(e));
      };
      auto R = [&](const Vec3& e) -> Vec3 {
        const Mat3 F = half(e);
        if (form == Form::gb_t4) return F * (top.J * (4 * e / h - W)) - F.transpose() * P - h * top.E.cross(F.transpose() * b);
        return (8 / (h * h)) * (top.J * e) - (4 / h) * P + (8 / (h * h)) * e.cross(top.J * e) - 2 * top.E.cross(F.transpose() * b);
      };
      const Vec3 e = newton(R, Vec3(h * W / 2));
      if (!e.allFinite()) return ++f.failures, f;
      const Mat3 F = half(e);
      f.L = L * F * F;
      f.W = 4 * e / h - W;
    } else {
      auto alpha = [&](const Vec3& Th) { return form == Form::collocation ? collocation_alpha(top, L, Th) : 0.5; };
      auto kappa = [&](const Vec3& Th) { return form == Form::kappa ? std::sin(Th.norm() / 2) / (Th.norm() / 2) : 1.0; };
      auto R = [&](const Vec3& Th) -> Vec3 {  // [T1]
        return rodrigues(Th) * (top.J * (2 * Th / h - W)) - P - h * kappa(Th) * (rodrigues(alpha(Th) * Th) * top.E).cross(b);
      };
      const Vec3 Th = newton(R, Vec3(h * W));
      if (!Th.allFinite()) return ++f.failures, f;
      f.L = L * rodrigues(Th);
      f.W = 2 * Th / h - W;
    }
    f.max_dH = std::max(f.max_dH, std::abs(top.energy(f.L, f.W) - H0) / std::abs(H0));
    f.max_dmu = std::max(f.max_dmu, std::abs(top.mu(f.L, f.W) - mu0) / std::abs(mu0));
  }
  return f;
}

}  // namespace paper
}  // namespace

// =====================================================================================
TEST_CASE("Case definitions: initial H and mu of HT0, HT1, HT2, FB1 match the reference set to 1e-15", "[cases]") {
  // Guards the copied reference data against the case definitions (a mismatch would make
  // every order test below meaningless).
  auto rel = [](double a, double b) { return std::abs(a - b) / std::abs(b); };
  const auto c0 = cases::ht0<double>();
  const auto c1 = cases::ht1<double>();
  const auto c2 = cases::ht2<double>();
  const auto f1 = cases::fb1<double>();
  CHECK(rel(c0.scene.energy(c0.initial), trompo_test::ht0_H) <= 1e-15);
  CHECK(rel(c0.scene.momentum_map(c0.initial), trompo_test::ht0_mu) <= 1e-15);
  CHECK(rel(c1.scene.energy(c1.initial), trompo_test::ht1_H) <= 1e-15);
  CHECK(rel(c1.scene.momentum_map(c1.initial), trompo_test::ht1_mu) <= 1e-15);
  CHECK(rel(c2.scene.energy(c2.initial), trompo_test::ht2_H) <= 1e-15);
  CHECK(rel(c2.scene.momentum_map(c2.initial), trompo_test::ht2_mu) <= 1e-15);
  CHECK(rel(f1.scene.energy(f1.initial), trompo_test::fb1_H) <= 1e-15);
}

TEST_CASE("RK4 reference run: h = 1e-4 reproduces the closed-form HT0 and HT1 at t = 1 to 1e-9 — RK4 order in [3.8, 4.2]",
          "[rk4][reference]") {
  // Cross-checks the copied closed-form values with an independent method (the issue's
  // "fine RK4 run"), and RK4's own order, so that the references below can be trusted.
  const auto c0 = cases::ht0<double>();
  const auto c1 = cases::ht1<double>();
  Stepper<RK4, cases::Top<double>> rk0(RK4{}, c0.scene), rk1(RK4{}, c1.scene);
  const double e0 = rotation_error(trompo_test::advance(rk0, c0.initial, 1e-4, 10000), trompo_test::ht0_t1);
  const double e1 = rotation_error(trompo_test::advance(rk1, c1.initial, 1e-4, 10000), trompo_test::ht1_t1);
  INFO("RK4 h = 1e-4 at t = 1: |Lambda - closed form|_F = " << e0 << " (HT0), " << e1 << " (HT1)");
  CHECK(e0 <= 1e-9);
  CHECK(e1 <= 1e-9);
  std::vector<double> err;
  for (long n : {100L, 200L, 400L}) err.push_back(rotation_error(trompo_test::advance(rk1, c1.initial, 1.0 / double(n), n), trompo_test::ht1_t1));
  const double p1 = trompo_test::observed_order(err[0], err[1]), p2 = trompo_test::observed_order(err[1], err[2]);
  INFO("RK4 on HT1 to t = 1, h = 0.01/0.005/0.0025: errors " << err[0] << ", " << err[1] << ", " << err[2] << "; orders " << p1
                                                              << ", " << p2);
  CHECK(p2 >= 3.8);
  CHECK(p2 <= 4.2);
}

// =====================================================================================
TEMPLATE_TEST_CASE("Exact schemes, 1e4 steps: max |dH/H| and |dmu/mu| (FB1 |d pi|/|pi|) <= 1e-12 on HT0, HT1, HT2, FB1 — Newton its/step <= 3 (collocation 3.001)",
                   "[invariants]", SimoCollocation, SimoKappa, GeradinBauchau) {
  for_each_case([](const auto& c, const CaseRun& r) {
    const RunStats<double> st = run_case<TestType>(c, r.h, r.steps);
    INFO(TestType::name << " on " << r.name << ", h = " << r.h << ", " << st.steps << " steps: max|dH/H| = " << st.max_dH
                        << ", max|dmu/mu| = " << st.max_dmu << ", max|dpi|/|pi| = " << st.max_dpi << ", orthonormality "
                        << st.max_orth << ", Newton its/step " << st.mean_iterations());
    SHOW(TestType::name << " " << r.name << ": dH " << st.max_dH << ", dmu " << st.max_dmu << ", dpi " << st.max_dpi
                        << ", its/step " << st.mean_iterations() << " (max " << st.max_iterations << ")");
    REQUIRE(st.failures == 0);
    CHECK(st.steps == r.steps);
    // Newton: the issue asks for ≤ 3 iterations per step on average (HT1, h = 0.001);
    // held on every case here (corrections, chord steps included), with no step above 6.
    // Collocation on HT0 is the exception, at 3.0004: where f″(½) changes sign its α
    // jumps between two roots, R is not smooth there, and those few steps take a fourth
    // correction (4 in 10⁴ steps).
    const bool collocation = std::is_same_v<TestType, SimoCollocation>;
    CHECK(st.mean_iterations() <= (collocation ? 3.001 : 3.0));
    CHECK(st.mean_iterations() >= 1.0);
    CHECK(st.max_iterations <= 6);
    CHECK(st.max_dH <= 1e-12);
    if (std::string(r.name) == "FB1") {
      // Free body: the whole π is the invariant. (μ = π3 = 0.03 is small against |π| = 4,
      // so |Δμ/μ| magnifies round-off 130×; |Δπ|/|π| is the meaningful figure.)
      CHECK(st.max_dpi <= 1e-12);
    } else {
      CHECK(st.max_dmu <= 1e-12);
    }
    CHECK(st.max_orth <= 1e-14);
  });
}

TEST_CASE("Simo-alpha 1/2 over 1e4 steps: mu exact (<= 1e-12) on HT0-HT2, H and the whole pi exact (<= 1e-12) on FB1 — Newton its/step <= 3", "[invariants][alpha]") {
  for_each_case([](const auto& c, const CaseRun& r) {
    const RunStats<double> st = run_case<SimoAlpha>(c, r.h, r.steps, SimoAlpha(0.5));
    const bool free = std::string(r.name) == "FB1";
    INFO("simo-alpha 1/2 on " << r.name << ", h = " << r.h << ": max|dH/H| = " << st.max_dH << ", max|dmu/mu| = " << st.max_dmu
                              << ", max|dpi|/|pi| = " << st.max_dpi << ", Newton its/step " << st.mean_iterations());
    SHOW("simo-alpha " << r.name << ": dH " << st.max_dH << ", dmu " << st.max_dmu << ", dpi " << st.max_dpi << ", its/step "
                       << st.mean_iterations() << " (max " << st.max_iterations << ")");
    REQUIRE(st.failures == 0);
    CHECK(st.mean_iterations() <= 3.0);
    CHECK(st.max_iterations <= 6);
    if (free) {
      CHECK(st.max_dH <= 1e-12);
      CHECK(st.max_dpi <= 1e-12);
    } else {
      CHECK(st.max_dmu <= 1e-12);
      CHECK(st.max_dH > 1e-11);  // not energy-exact under gravity (O(h²), measured below)
    }
  });
}

TEST_CASE("Simo-alpha 0.3: mu conserved to 1e-12 over 1e4 steps on HT1 (mu exact for any alpha)", "[invariants][alpha]") {
  const auto c = cases::ht1<double>();
  const RunStats<double> st = run_case<SimoAlpha>(c, 1e-3, 10000, SimoAlpha(0.3));
  INFO("simo-alpha 0.3 on HT1: max|dmu/mu| = " << st.max_dmu << ", max|dH/H| = " << st.max_dH);
  REQUIRE(st.failures == 0);
  CHECK(st.max_dmu <= 1e-12);
}

TEST_CASE("Simo-alpha 1/2: max|dH/H| over t in [0,1] shrinks 4x (ratio in [3.6, 4.4]) per halving of h on HT0, HT1, HT2",
          "[invariants][alpha][order]") {
  auto check = [](const auto& c, const char* name, double h0, double t_end) {
    std::vector<double> dH;
    for (int k = 0; k < 4; ++k) {
      const double h = h0 / std::pow(2.0, k);
      const long n = std::lround(t_end / h);
      const RunStats<double> st = run_case<SimoAlpha>(c, h, n, SimoAlpha(0.5));
      REQUIRE(st.failures == 0);
      dH.push_back(st.max_dH);
    }
    for (int k = 0; k + 1 < 4; ++k) {
      const double ratio = dH[k] / dH[k + 1];
      INFO(name << ": max|dH/H| at h = " << h0 / std::pow(2.0, k) << ": " << dH[k] << ", at h/2: " << dH[k + 1] << ", ratio " << ratio);
      CHECK(ratio >= 3.6);
      CHECK(ratio <= 4.4);
    }
    SHOW("simo-alpha " << name << " max|dH/H| by halving h from " << h0 << ": " << dH[0] << ", " << dH[1] << ", " << dH[2] << ", "
                       << dH[3]);
  };
  check(cases::ht0<double>(), "HT0", 0.01, 1.0);
  check(cases::ht1<double>(), "HT1", 0.01, 1.0);
  check(cases::ht2<double>(), "HT2", 0.002, 0.5);
}

// =====================================================================================
TEST_CASE("Geradin-Bauchau paper form [T5]: H exact (<= 1e-12) over 1e4 steps on HT0, HT1, HT2, FB1 — Newton its/step <= 3", "[invariants][gb-paper]") {
  for_each_case([](const auto& c, const CaseRun& r) {
    const RunStats<double> st = run_case<GeradinBauchauPaper>(c, r.h, r.steps);
    INFO("gb-paper on " << r.name << ", h = " << r.h << ": max|dH/H| = " << st.max_dH << ", max|dmu/mu| = " << st.max_dmu
                        << ", max|dpi|/|pi| = " << st.max_dpi << ", Newton its/step " << st.mean_iterations());
    SHOW("gb-paper " << r.name << ": dH " << st.max_dH << ", dmu " << st.max_dmu << ", dpi " << st.max_dpi << ", its/step "
                     << st.mean_iterations() << " (max " << st.max_iterations << ")");
    REQUIRE(st.failures == 0);
    CHECK(st.mean_iterations() <= 3.0);
    CHECK(st.max_iterations <= 6);
    CHECK(st.max_dH <= 1e-12);
  });
}

TEST_CASE("Geradin-Bauchau paper form [T5], HT0: to t = 1 max|dmu/mu| is an independent [T5]'s to 1e-9, of order 2 +- 0.3 (finest two halvings), above 1e-4, H exact",
          "[invariants][gb-paper]") {
  // The prototype's note gave docs/theory.md §4's figures (6.4e-2 … 1.6e-3) as HT1's; they
  // are HT0's (Mgl = 196.2, tilt 0.3). Held here not to those figures but to the same
  // drift computed by the independent implementation above (paper::run), and to the O(h²)
  // that [T5]'s linearised gyroscopic term gives (the coarsest halving is pre-asymptotic:
  // ratio ~2.8, printed).
  const auto c = cases::ht0<double>();
  const double hs[] = {0.01, 0.005, 0.0025, 0.00125};
  std::vector<double> dmu;
  for (double h : hs) {
    const long n = std::lround(1.0 / h);
    const RunStats<double> st = run_case<GeradinBauchauPaper>(c, h, n);
    const paper::Figures ind = paper::run(paper::Form::gb_t5, h, n);
    INFO("gb-paper HT0 h = " << h << ": max|dmu/mu| = " << st.max_dmu << " (independent [T5]: " << ind.max_dmu
                             << "), max|dH/H| = " << st.max_dH << " (independent: " << ind.max_dH << ")");
    SHOW("gb-paper HT0 h = " << h << ": max|dmu/mu| = " << st.max_dmu << ", independent [T5] " << ind.max_dmu);
    REQUIRE(st.failures == 0);
    REQUIRE(ind.failures == 0);
    CHECK(std::abs(st.max_dmu - ind.max_dmu) <= 1e-9 * ind.max_dmu);
    CHECK(st.max_dmu > 1e-4);  // 10¹¹ × round-off: μ really drifts
    CHECK(st.max_dH <= 1e-12);
    CHECK(ind.max_dH <= 1e-12);  // the independent [T5] is a [T5]: it keeps H too
    dmu.push_back(st.max_dmu);
  }
  for (int k = 1; k < 3; ++k) {
    const double p = trompo_test::observed_order(dmu[k], dmu[k + 1]);
    INFO("order of max|dmu/mu| from h = " << hs[k] << " to " << hs[k + 1] << ": " << p);
    CHECK(std::abs(p - 2.0) <= 0.3);
  }
}

TEST_CASE("GB paper [T5], HT1: to t = 1 mu drifts (> 1e-7 at every h) as O(h^2) (finer ratios in [3.6, 4.4]), H exact",
          "[invariants][gb-paper]") {
  const auto c = cases::ht1<double>();
  std::vector<double> dmu;
  for (double h : {0.01, 0.005, 0.0025, 0.00125}) {
    const RunStats<double> st = run_case<GeradinBauchauPaper>(c, h, std::lround(1.0 / h));
    INFO("gb-paper HT1 h = " << h << ": max|dmu/mu| = " << st.max_dmu << ", max|dH/H| = " << st.max_dH);
    REQUIRE(st.failures == 0);
    CHECK(st.max_dH <= 1e-12);
    CHECK(st.max_dmu > 1e-7);  // 10⁸ × round-off: really not conserved
    dmu.push_back(st.max_dmu);
  }
  SHOW("gb-paper HT1 to t = 1: max|dmu/mu| = " << dmu[0] << ", " << dmu[1] << ", " << dmu[2] << ", " << dmu[3]
                                                << " at h = 0.01, 0.005, 0.0025, 0.00125");
  for (int k = 1; k < 3; ++k) {
    INFO("ratio " << dmu[k] / dmu[k + 1]);
    CHECK(dmu[k] / dmu[k + 1] >= 3.6);
    CHECK(dmu[k] / dmu[k + 1] <= 4.4);
  }
}

TEST_CASE("GB paper [T5], free body FB1: H exact, but pi drifts O(h^2) (ratio in [3.6, 4.4] per halving)",
          "[invariants][gb-paper]") {
  // [T5] is [T4] with the gyroscopic part linearised: without load [T4] − e0·[T5]·(4/h)
  // = (4/h)(1 − e0) e × Je ≠ 0, so the spatial momentum is not conserved, only H and |Π|'s
  // energy balance. The "every scheme on FB1 conserves π" cannot hold for [T5];
  // this test pins what does: exact H, an O(h²) drift of π.
  const auto c = cases::fb1<double>();
  std::vector<double> dpi;
  for (double h : {0.04, 0.02, 0.01}) {
    const RunStats<double> st = run_case<GeradinBauchauPaper>(c, h, std::lround(10.0 / h));
    INFO("gb-paper FB1 h = " << h << ": max|dpi|/|pi| = " << st.max_dpi << ", max|dH/H| = " << st.max_dH);
    REQUIRE(st.failures == 0);
    CHECK(st.max_dH <= 1e-12);
    dpi.push_back(st.max_dpi);
  }
  SHOW("gb-paper FB1 to t = 10: max|dpi|/|pi| = " << dpi[0] << ", " << dpi[1] << ", " << dpi[2] << " at h = 0.04, 0.02, 0.01");
  for (int k = 0; k < 2; ++k) {
    INFO("ratio " << dpi[k] / dpi[k + 1]);
    CHECK(dpi[k] > 1e-8);
    CHECK(dpi[k] / dpi[k + 1] >= 3.6);
    CHECK(dpi[k] / dpi[k + 1] <= 4.4);
  }
}

// =====================================================================================
namespace {
/// Observed orders from a sweep of 6 halved steps to the reference time; checks the finest
/// two ratios in [1.9, 2.1] for Λ (Frobenius) and Ω. (The coarsest levels are printed: the
/// Ω error of [T5] on the tops is pre-asymptotic there.)
template <class Scheme, class Case>
void check_order(const Case& c, const char* name, const Reference& ref, double h0) {
  std::vector<double> eL, eW;
  double its = 0;
  const int levels = 6;
  for (int k = 0; k < levels; ++k) {
    const double h = h0 / std::pow(2.0, k);
    const long n = std::lround(ref.t / h);
    const RunStats<double> st = run_case<Scheme>(c, h, n);
    REQUIRE(st.failures == 0);
    REQUIRE(std::abs(st.final.time - ref.t) <= 1e-12);
    eL.push_back(rotation_error(st.final, ref));
    eW.push_back((st.final.omega - ref.angular_velocity()).norm() / ref.angular_velocity().norm());
    its = st.mean_iterations();
  }
  auto orders = [](const std::vector<double>& e) {
    std::string out;
    for (std::size_t k = 0; k + 1 < e.size(); ++k) out += (k ? ", " : "") + std::to_string(trompo_test::observed_order(e[k], e[k + 1]));
    return out;
  };
  auto errors = [](const std::vector<double>& e) {
    std::ostringstream os;
    for (std::size_t k = 0; k < e.size(); ++k) os << (k ? ", " : "") << e[k];
    return os.str();
  };
  const double pL1 = trompo_test::observed_order(eL[levels - 3], eL[levels - 2]);
  const double pL2 = trompo_test::observed_order(eL[levels - 2], eL[levels - 1]);
  const double pW1 = trompo_test::observed_order(eW[levels - 3], eW[levels - 2]);
  const double pW2 = trompo_test::observed_order(eW[levels - 2], eW[levels - 1]);
  INFO(Scheme::name << " on " << name << " to t = " << ref.t << ", h = " << h0 << "/2^k: |Lambda - ref|_F = " << errors(eL)
                    << "; |Omega - ref|/|ref| = " << errors(eW) << "; orders Lambda " << orders(eL) << "; Omega " << orders(eW));
  SHOW(Scheme::name << " " << name << ": order Lambda " << orders(eL) << " | Omega " << orders(eW) << "; finest |dLambda|_F "
                    << eL[levels - 1] << ", its/step " << its);
  // The order asserted is the scheme's trait (scheme.hpp), ± 0.1.
  constexpr double p_expected = Scheme::traits.order;
  for (double p : {pL1, pL2, pW1, pW2}) {
    CHECK(p >= p_expected - 0.1);
    CHECK(p <= p_expected + 0.1);
  }
}
}  // namespace

TEMPLATE_TEST_CASE("Observed order: Lambda and Omega vs closed-form reference in [1.9, 2.1] (h halved 5x, finest two ratios) on HT0, HT1, HT2, FB1",
                   "[order]", SimoAlpha, SimoCollocation, SimoKappa, GeradinBauchau, GeradinBauchauPaper) {
  check_order<TestType>(cases::ht0<double>(), "HT0", trompo_test::ht0_t1, 0.01);
  check_order<TestType>(cases::ht1<double>(), "HT1", trompo_test::ht1_t1, 0.01);
  check_order<TestType>(cases::ht2<double>(), "HT2", trompo_test::ht2_t05, 0.004);
  check_order<TestType>(cases::fb1<double>(), "FB1", trompo_test::fb1_t5, 0.1);
}

// =====================================================================================
// Symmetry (h then −h), reversibility (forward and back), float and long double: the
// generic property suite over the registry (test_properties_*.cpp) checks them for
// every scheme and its compositions; here stays the check that symmetry is a real property.
TEST_CASE("Symmetry is a real check: Simo-alpha 0.3 does not return after h, -h (|dLambda| > 1e-9 on HT1)", "[symmetry]") {
  const auto c = cases::ht1<double>();
  Stepper<SimoAlpha, cases::Top<double>> stepper(SimoAlpha(0.3), c.scene);
  CHECK_FALSE(stepper.symmetric());
  State<double> t = c.initial;
  REQUIRE(stepper.step(t, 0.01).ok());
  REQUIRE(stepper.step(t, -0.01).ok());
  const double back = trompo_test::max_abs(t.rotation.matrix() - c.initial.rotation.matrix()) + (t.omega - c.initial.omega).norm() / 50;
  INFO("simo-alpha 0.3, h = 0.01 then -0.01: departure " << back);
  CHECK(back > 1e-9);
}

// =====================================================================================
// =====================================================================================
TEST_CASE("Reference table of theory section 7, HT0 to t = 1 in 100/200/400 steps: |Lambda - closed form|_F (and Simo-alpha's max dH/H) equal an independent implementation's to 1e-9, of order 2 +- 0.3, GB's 6-8x Simo-alpha's and 8-9.5x Simo-kappa's — exact invariants <= 1e-13",
          "[table]") {
  // Λref: the closed-form HT0 at t = 1 (reference set), ‖·‖ the Frobenius norm. The
  // figures of the table came from a prototype; here each is computed twice, by trompo and
  // by the independent implementation above (paper::run), and the two attitudes must agree
  // to 1e-9 of the error they measure (measured: 1e-12); the errors must fall as h².
  const auto c = cases::ht0<double>();
  const long steps[] = {100, 200, 400};
  double simo_alpha_error[3] = {}, simo_kappa_error[3] = {}, gb_error[3] = {};
  auto table = [&](auto scheme, const char* name, paper::Form form, double* errors) {
    using Scheme = decltype(scheme);
    double fro[3] = {}, dH[3] = {};
    for (int k = 0; k < 3; ++k) {
      const double h = 1.0 / double(steps[k]);
      const RunStats<double> st = run_case<Scheme>(c, h, steps[k], scheme);
      const paper::Figures ind = paper::run(form, h, steps[k]);
      REQUIRE(st.failures == 0);
      REQUIRE(ind.failures == 0);
      const Mat3 D = st.final.rotation.matrix() - trompo_test::ht0_t1.rotation();
      fro[k] = trompo_test::frobenius(D);
      dH[k] = st.max_dH;
      const double fro_ind = trompo_test::frobenius(Mat3(ind.L - trompo_test::ht0_t1.rotation()));
      const double apart = trompo_test::frobenius(Mat3(st.final.rotation.matrix() - ind.L));
      INFO(name << ", h = " << h << ": |Lambda - ref|_F " << fro[k] << " (independent " << fro_ind << ", apart " << apart
                << "), spectral " << trompo_test::spectral(D) << "; max dH/H " << st.max_dH << " (independent " << ind.max_dH
                << "), max dmu/mu " << st.max_dmu << ", Newton its/step " << st.mean_iterations());
      SHOW("table " << name << " h = " << h << ": |dLambda|_F " << fro[k] << " (independent " << fro_ind << ", apart " << apart
                    << "), dH " << st.max_dH << " (independent " << ind.max_dH << "), dmu " << st.max_dmu << ", its "
                    << st.mean_iterations());
      CHECK(apart <= 1e-9 * fro_ind);
      CHECK(fro[k] > 1e-3);  // far above the closed form's 1e-15 and the agreement above
      CHECK(st.max_dmu <= 1e-13);
      if (form == paper::Form::alpha_half) {
        CHECK(std::abs(st.max_dH - ind.max_dH) <= 1e-9 * ind.max_dH);
      } else {
        CHECK(st.max_dH <= 1e-13);
        CHECK(ind.max_dH <= 1e-12);  // the independent forms keep H too: they are the schemes
      }
      errors[k] = fro[k];
    }
    for (int k = 0; k < 2; ++k) {
      const double pL = trompo_test::observed_order(fro[k], fro[k + 1]), pH = trompo_test::observed_order(dH[k], dH[k + 1]);
      INFO(name << ": order of |dLambda|_F from " << steps[k] << " to " << steps[k + 1] << " steps " << pL << ", of max dH/H " << pH);
      CHECK(std::abs(pL - 2.0) <= 0.3);
      if (form == paper::Form::alpha_half) CHECK(std::abs(pH - 2.0) <= 0.3);
    }
  };
  double unused[3];
  table(SimoAlpha(0.5), "simo-alpha 1/2", paper::Form::alpha_half, simo_alpha_error);
  table(SimoCollocation{}, "collocation", paper::Form::collocation, unused);
  table(SimoKappa{}, "simo-kappa", paper::Form::kappa, simo_kappa_error);
  table(GeradinBauchau{}, "geradin-bauchau", paper::Form::gb_t4, gb_error);
  // The agreement discriminates: Simo-κ's attitude (error 0.0059 at 400 steps) is 0.2 of
  // Simo-α's error away from Simo-α's, 10⁸ times the tolerance above.
  const Mat3 kappa_L = paper::run(paper::Form::kappa, 1.0 / 400, 400).L;
  const double other = trompo_test::frobenius(Mat3(kappa_L - paper::run(paper::Form::alpha_half, 1.0 / 400, 400).L));
  INFO("independent Simo-kappa and Simo-alpha 1/2 at 400 steps: apart " << other);
  CHECK(other >= 1e-3 * simo_alpha_error[2]);
  // docs/theory.md §7 and the README: Géradin–Bauchau's error is 6.7–8.7× Simo's on HT0
  // (measured 7.0, 6.8, 6.7 × Simo-α's; 8.7, 8.6, 8.6 × Simo-κ's).
  for (int k = 0; k < 3; ++k) {
    INFO("GB / Simo-alpha attitude error at " << steps[k] << " steps: " << gb_error[k] / simo_alpha_error[k] << ", GB / Simo-kappa "
                                              << gb_error[k] / simo_kappa_error[k]);
    CHECK(gb_error[k] >= 6 * simo_alpha_error[k]);
    CHECK(gb_error[k] <= 8 * simo_alpha_error[k]);
    CHECK(gb_error[k] >= 8 * simo_kappa_error[k]);
    CHECK(gb_error[k] <= 9.5 * simo_kappa_error[k]);
  }
}

// =====================================================================================
TEMPLATE_TEST_CASE("Random heavy tops: no step fails (50 tops, general J, E, gamma — |Omega0| <= 3, h = 0.05, 200 steps each)",
                   "[robustness]", SimoAlpha, SimoCollocation, SimoKappa, GeradinBauchau) {
  // |Θ| ≤ ~0.2 a step: well inside every scheme's comfort zone (docs/theory.md §9 puts the fold at
  // |Θ| ≈ 2.5). A failure here is a solver defect, not a hard case — except for
  // collocation: where f″(½) changes sign along the step (a nutation turn) its α(Θ)
  // must jump between the roots ½ ± ~0.29 of [T2] (no continuous choice exists), and
  // Newton can fail to settle on one side. That step must then be reported, and
  // integrate() must recover it by sub-steps with H exact.
  trompo_test::Rng rng(77);
  int failed_tops = 0;
  long steps = 0, iterations = 0, recovered = 0;
  double max_dH = 0;
  std::string first;
  for (int trial = 0; trial < 50; ++trial) {
    const Mat3 J = trompo_test::random_inertia(rng);
    const double Mgl = rng.uniform(5, 60);
    const Vec3 E = rng.unit(), up = rng.unit();
    HeavyTop<double> scene(RigidBody<double>(J), UniformGravity<double>(Mgl, E, up));
    State<double> s;
    s.rotation = rng.rotation();
    s.omega = rng.vector(0, 3);
    Stepper<TestType, HeavyTop<double>> stepper(TestType{}, scene);
    if constexpr (std::is_same_v<TestType, SimoCollocation>) {
      const double H0 = scene.energy(s);
      const auto sum = integrate(stepper, s, 200 * 0.05, 0.05);
      if (!sum.ok()) ++failed_tops;
      recovered += sum.recovered;
      steps += sum.steps;
      iterations += sum.iterations;
      max_dH = std::max(max_dH, std::abs(scene.energy(s) - H0) / std::max(std::abs(H0), 1.0));
      continue;
    }
    const double H0 = scene.energy(s);
    for (int k = 0; k < 200; ++k) {
      const StepReport<double> rep = stepper.step(s, 0.05);
      iterations += rep.iterations;
      if (!rep.ok()) {
        if (failed_tops++ == 0)
          first = "top " + std::to_string(trial) + " step " + std::to_string(k) + ": " + rep.reason() + ", residual " + std::to_string(rep.residual);
        break;
      }
      ++steps;
      max_dH = std::max(max_dH, std::abs(scene.energy(s) - H0) / std::max(std::abs(H0), 1.0));
    }
  }
  INFO(TestType::name << ": " << failed_tops << " of 50 random tops had a failed step (first: " << first << "); Newton its/step "
                      << double(iterations) / double(steps) << "; intervals recovered by sub-steps " << recovered
                      << "; max |dH|/max(|H0|,1) " << max_dH);
  SHOW(TestType::name << " random tops h = 0.05: " << failed_tops << " of 50 failed; its/step " << double(iterations) / double(steps)
                      << "; recovered intervals " << recovered);
  CHECK(failed_tops == 0);
  // max_dH is measured for every scheme, after every step; it is bounded where the scheme's
  // traits say it keeps H on the heavy top (collocation, Simo-κ, GB), and only shown for
  // Simo-α, whose H error is O(h²) (docs/theory.md §7).
  CHECK(steps > 0);
  if constexpr (scheme_keeps_v<TestType, HeavyTop<double>>.energy) CHECK(max_dH <= 1e-12);
  else CHECK(max_dH > 1e-12);  // measured: Simo-α's error is visible, so the measurement is live
  // Only collocation goes through integrate() (the others' steps are plain and counted as
  // failed_tops above): its recovered intervals are the rare α jumps.
  if constexpr (std::is_same_v<TestType, SimoCollocation>) CHECK(recovered <= 5);  // rare: 1 interval in 10⁴ measured
}
