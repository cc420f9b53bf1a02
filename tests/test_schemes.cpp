// The schemes on the standard cases (docs/theory.md §3, §4, §7, §8): invariants over 10⁴ steps,
// observed orders against closed-form references, symmetry, Newton iteration counts and
// the reproduction of the reference table of docs/theory.md §7.
//
// References are the project's independent solutions (closed-form Lagrange top and free
// body, RKF78 in 128-bit for HT2), copied into support/trompo_test.hpp.
#include <catch2/catch.hpp>
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

TEST_CASE("Geradin-Bauchau paper form [T5]: max|dmu/mu| to t = 1 within 30% of the reference 6.4e-2, 2.3e-2, 6.2e-3, 1.6e-3 (reproduced on HT0)",
          "[invariants][gb-paper]") {
  // The prototype's note gave these figures as HT1's; they are HT0's (Mgl = 196.2, tilt
  // 0.3), as docs/theory.md §4 now says. On HT1 (Mgl = 20, tilt 0.05) [T5] drifts ~3000×
  // less (next test); an independent [T5] with finite-difference Newton gives the same
  // numbers as trompo on both cases, so the old label was what was wrong.
  const auto c = cases::ht0<double>();
  const double hs[] = {0.01, 0.005, 0.0025, 0.00125};
  const double expected[] = {6.4e-2, 2.3e-2, 6.2e-3, 1.6e-3};  // docs/theory.md §4, measured by the prototype
  for (int k = 0; k < 4; ++k) {
    const RunStats<double> st = run_case<GeradinBauchauPaper>(c, hs[k], std::lround(1.0 / hs[k]));
    INFO("gb-paper HT0 h = " << hs[k] << ": max|dmu/mu| = " << st.max_dmu << " (reference " << expected[k] << "), max|dH/H| = " << st.max_dH);
    SHOW("gb-paper HT0 h = " << hs[k] << ": max|dmu/mu| = " << st.max_dmu << " vs reference " << expected[k]);
    REQUIRE(st.failures == 0);
    CHECK(st.max_dmu >= 0.7 * expected[k]);
    CHECK(st.max_dmu <= 1.3 * expected[k]);
    CHECK(st.max_dH <= 1e-12);
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
TEST_CASE("Reference table of theory section 7, HT0: max dH/H of Simo-alpha and |Lambda - Lambda_ref|_F within 10% (t = 1 — 100/200/400 steps)",
          "[table]") {
  // Λref: the closed-form HT0 at t = 1 (reference set). The prototype's ‖Λ − Λref‖ is
  // matched by the Frobenius norm (the spectral norm is 1/√2 of it for a small rotation
  // error: ~30% lower, outside the tolerance; both are printed).
  const auto c = cases::ht0<double>();
  const long steps[] = {100, 200, 400};
  struct Row {
    const char* name;
    double lambda[3];
  };
  const double alpha_dH[] = {1.2e-3, 2.8e-4, 6.8e-5};
  auto table = [&](auto scheme, const Row& row, bool energy_row) {
    using Scheme = decltype(scheme);
    for (int k = 0; k < 3; ++k) {
      const double h = 1.0 / double(steps[k]);
      const RunStats<double> st = run_case<Scheme>(c, h, steps[k], scheme);
      REQUIRE(st.failures == 0);
      const Mat3 D = st.final.rotation.matrix() - trompo_test::ht0_t1.rotation();
      const double fro = trompo_test::frobenius(D), spec = trompo_test::spectral(D), mx = trompo_test::max_abs(D);
      INFO(row.name << ", h = " << h << ": |Lambda - ref| Frobenius " << fro << ", spectral " << spec << ", max-abs " << mx
                    << " (reference " << row.lambda[k] << "); max dH/H " << st.max_dH << ", max dmu/mu " << st.max_dmu
                    << ", Newton its/step " << st.mean_iterations());
      SHOW("table " << row.name << " h = " << h << ": |dLambda|_F " << fro << " (reference " << row.lambda[k] << "), spectral "
                    << spec << ", dH " << st.max_dH << ", dmu " << st.max_dmu << ", its " << st.mean_iterations());
      CHECK(std::abs(fro - row.lambda[k]) <= 0.1 * row.lambda[k]);
      CHECK(st.max_dmu <= 1e-13);
      if (energy_row) {
        CHECK(std::abs(st.max_dH - alpha_dH[k]) <= 0.1 * alpha_dH[k]);
      } else {
        CHECK(st.max_dH <= 1e-13);
      }
    }
  };
  table(SimoAlpha(0.5), Row{"simo-alpha 1/2", {0.116, 0.030, 0.0076}}, true);
  table(SimoCollocation{}, Row{"collocation", {0.099, 0.026, 0.0065}}, false);
  table(SimoKappa{}, Row{"simo-kappa", {0.094, 0.024, 0.0059}}, false);
  table(GeradinBauchau{}, Row{"geradin-bauchau", {0.82, 0.20, 0.051}}, false);
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
