// The history predictor of the energy-exact schemes (detail/history.hpp, docs/predictor.md):
// what it costs (evaluations per step, asserted as counts), that it changes nothing but
// the starting point (invariants and results as the memoryless step's, to round-off), and
// its fallbacks (fresh memory, a change of h, a history that misleads).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <type_traits>

#include "support/same_bits.hpp"
#include "support/trompo_test.hpp"
#include "trompo/model/cases.hpp"
#include "trompo/drivers/integrate.hpp"

using namespace trompo;
using trompo_test::Mat3;
using trompo_test::Vec3;

namespace {

/// Evaluation counts: full (residual and tangent) and residual-only.
struct Counts {
  long full = 0, residual_only = 0, steps = 0;
};

/// Steps `c` n times with h along a trajectory of `scheme` (history predictor on), and
/// re-solves each step's equation with a counting wrapper of the scheme's residual from
/// the same start (the memory's extrapolation and carried tangent). The replica must land
/// on the increment the library recorded, bit for bit, so the counts are the library's.
/// The first `skip` steps (the history filling) are not counted.
template <class Scheme, class SceneT>
Counts count_with_history(const Scheme& scheme, const cases::Case<SceneT>& c, double h, int n, int skip) {
  const Stepper<Scheme, SceneT> stepper(scheme, c.scene);
  auto traj = stepper.start(c.initial);
  Counts k;
  constexpr bool gb = std::is_same_v<Scheme, GeradinBauchau>;
  for (int i = 0; i < n; ++i) {
    const auto& m = traj.memory;
    if (i >= skip) {
      REQUIRE(m.trusted(h));
      const detail::StepData<SceneT> d(c.scene, traj, h);
      const auto residual = scheme.residual(d);
      auto counted = [&](const Vec3& x, Vec3& R, Mat3* K, double& scale) {
        ++(K ? k.full : k.residual_only);
        return residual(x, R, K, scale);
      };
      const Vec3 x0 = m.extrapolate();
      const Vec3 base = gb ? Vec3(h / 2 * traj.omega) : Vec3(h * traj.omega);
      Vec3 y = x0 - base;
      Mat3 K, K_inv = m.tangent_inverse;
      REQUIRE(detail::newton(counted, y, stepper.options(),
                                    NewtonSolve<double>{
                                        .x_scale = x0.norm(), .tangent = &K, .carried = &K_inv, .start_from_carried = true})
                  .ok());
      const Vec3 x = base + y;
      REQUIRE(stepper.step(traj, h).ok());
      if constexpr (!gb) CHECK(std::memcmp(x.data(), traj.memory.increment[0].data(), sizeof(double) * 3) == 0);
      else CHECK((x - traj.memory.increment[0]).norm() <= 1e-15);
      ++k.steps;
    } else {
      REQUIRE(stepper.step(traj, h).ok());
    }
  }
  return k;
}

/// Max |ΔH/H| and |Δμ/μ| over n steps of h, along a trajectory or as plain State steps.
template <class Scheme, class SceneT>
std::pair<double, double> drift(const Scheme& scheme, const cases::Case<SceneT>& c, double h, long n, bool trajectory) {
  const Stepper<Scheme, SceneT> stepper(scheme, c.scene);
  const auto st = trajectory ? trompo_test::run(stepper, stepper.start(c.initial), h, n)
                             : trompo_test::run(stepper, c.initial, h, n);
  REQUIRE(st.failures == 0);
  return {st.max_dH, st.max_dmu};
}

}  // namespace

TEST_CASE("history predictor: two residual-only evaluations and no tangent per step (HT1, h = 1e-3)",
          "[predictor][newton]") {
  // Memoryless, the same steps cost one full and one residual-only evaluation (Simo-κ) or
  // one full and two residual-only (GB): tests/test_newton.cpp.
  const auto ht1 = cases::ht1<double>();
  SECTION("Simo-kappa") {
    const Counts k = count_with_history(SimoKappa{}, ht1, 1e-3, 2000, 8);
    CHECK(k.full == 0);
    CHECK(k.residual_only == 2 * k.steps);
  }
  SECTION("Simo collocation") {
    const Counts k = count_with_history(SimoCollocation{}, ht1, 1e-3, 2000, 8);
    CHECK(k.full == 0);
    CHECK(k.residual_only <= 2 * k.steps + k.steps / 50);  // measured 2.00
  }
  SECTION("Geradin-Bauchau") {
    const Counts k = count_with_history(GeradinBauchau{}, ht1, 1e-3, 2000, 8);
    CHECK(k.full == 0);
    CHECK(k.residual_only == 2 * k.steps);
  }
}

TEST_CASE("history predictor: the memory fills, and restarts on a change of h", "[predictor]") {
  const auto ht1 = cases::ht1<double>();
  const Stepper<SimoKappa, cases::Top<double>> stepper(SimoKappa{}, ht1.scene);
  auto traj = stepper.start(ht1.initial);
  CHECK(traj.memory.count == 0);
  for (int i = 1; i <= 8; ++i) {
    REQUIRE(stepper.step(traj, 1e-3).ok());
    CHECK(traj.memory.count == std::min(i, IncrementHistory<double>::depth));
  }
  CHECK(traj.memory.ready(1e-3));
  CHECK(traj.memory.trusted(1e-3));  // HT1 at 1e-3: the extrapolation hit the last step to < 1e-6
  CHECK(traj.memory.miss < 1e-6);
  CHECK_FALSE(traj.memory.ready(2e-3));
  REQUIRE(stepper.step(traj, 2e-3).ok());
  CHECK(traj.memory.count == 1);
  CHECK(traj.memory.h == 2e-3);
  CHECK_FALSE(traj.memory.trusted(2e-3));
  traj.reset();
  CHECK(traj.memory.count == 0);
}

TEST_CASE("history predictor: steps that differ by the rounding of t keep the history (the adaptive driver's steps)",
          "[predictor]") {
  // t_{n+1} − t_n at a held h differs from h by ulp(t): an adaptive run held at one h takes
  // such steps. They count as one h (IncrementHistory::same_step, relative 1e-9).
  const auto ht1 = cases::ht1<double>();
  const Stepper<SimoKappa, cases::Top<double>> stepper(SimoKappa{}, ht1.scene);
  auto traj = stepper.start(ht1.initial);
  traj.time = 100.0;  // ulp(100) = 1.4e-14: the steps below differ by up to 1e-11 relative
  for (int i = 0; i < 40; ++i) {
    const double t_next = traj.time + 1e-3;
    REQUIRE(stepper.step(traj, t_next - traj.time).ok());
    traj.time = t_next;
  }
  CHECK(traj.memory.count == IncrementHistory<double>::depth);
  CHECK(traj.memory.trusted(1e-3));
  CHECK(traj.memory.miss < 1e-6);
  CHECK(IncrementHistory<double>::same_step(1e-3 * (1 + 5e-10), 1e-3));
  CHECK_FALSE(IncrementHistory<double>::same_step(1e-3 * (1 + 5e-9), 1e-3));
}

TEST_CASE("history predictor: a step from fresh memory is the memoryless step, bit for bit", "[predictor]") {
  const auto ht1 = cases::ht1<double>();
  const auto check = [&](auto scheme) {
    using Scheme = decltype(scheme);
    const Stepper<Scheme, cases::Top<double>> stepper(scheme, ht1.scene);
    auto traj = stepper.start(ht1.initial);
    State<double> s = ht1.initial;
    for (int i = 0; i < 20; ++i) REQUIRE(stepper.step(traj, 1e-3).ok());
    s = traj.state();
    traj.reset();  // as after an edit by hand
    REQUIRE(stepper.step(traj, 1e-3).ok());
    REQUIRE(stepper.step(s, 1e-3).ok());
    CHECK(trompo_test::same_bits(traj.state(), s));
  };
  check(SimoKappa{});
  check(SimoCollocation{});
  check(GeradinBauchau{});
}

TEST_CASE("history predictor: switched off, a trajectory is stepped as plain states, bit for bit", "[predictor]") {
  const auto ht1 = cases::ht1<double>();
  SimoKappa off;
  off.history_predictor = false;
  const Stepper<SimoKappa, cases::Top<double>> stepper(off, ht1.scene);
  auto traj = stepper.start(ht1.initial);
  State<double> s = ht1.initial;
  for (int i = 0; i < 200; ++i) {
    REQUIRE(stepper.step(traj, 1e-3).ok());
    REQUIRE(stepper.step(s, 1e-3).ok());
  }
  CHECK(traj.memory.count == 0);
  CHECK(trompo_test::same_bits(traj.state(), s));
}

TEST_CASE("history predictor: a misleading history falls back to the memoryless start", "[predictor]") {
  // A memory that claims the right h but holds increments of another motion (and a wrong
  // tangent): the step must still be the correct one, to Newton's tolerance.
  const auto ht1 = cases::ht1<double>();
  const auto check = [&](auto scheme) {
    using Scheme = decltype(scheme);
    const Stepper<Scheme, cases::Top<double>> stepper(scheme, ht1.scene);
    auto traj = stepper.start(ht1.initial);
    for (int i = 0; i < 6; ++i) traj.memory.record(Vec3(0.9, -0.4, 0.2) * double(i % 2 == 0 ? 1 : -1), 1e-2, Mat3::Identity() * 7.0);
    traj.memory.miss = 0;  // claims to have predicted the last step exactly
    REQUIRE(traj.memory.trusted(1e-2));
    State<double> s = ht1.initial;
    REQUIRE(stepper.step(traj, 1e-2).ok());
    REQUIRE(stepper.step(s, 1e-2).ok());
    const double w = s.omega.norm();
    CHECK((traj.omega - s.omega).norm() / w < 1e-13);
    CHECK((traj.rotation.matrix() - s.rotation.matrix()).norm() < 1e-13);
    CHECK(std::abs(ht1.scene.energy(traj) - ht1.scene.energy(ht1.initial)) <= 1e-14 * std::abs(ht1.scene.energy(ht1.initial)));
  };
  check(SimoKappa{});
  check(SimoCollocation{});
  check(GeradinBauchau{});
}

TEST_CASE("history predictor: H and mu as exact as memoryless steps (HT1, 2e5 steps of 1e-3, 5e4 under the sanitizers)",
          "[predictor][invariants]") {
  const auto ht1 = cases::ht1<double>();
#ifdef TROMPO_SANITIZED
  const long n = 50000;  // ASan/UBSan at -O1 (the test command's only build of this file): the same checks, fewer steps
#else
  const long n = 200000;
#endif
  const auto check = [&](auto scheme) {
    using Scheme = decltype(scheme);
    const auto with = drift(scheme, ht1, 1e-3, n, true);
    const auto without = drift(scheme, ht1, 1e-3, n, false);
    INFO(Scheme::name << ": with history max|dH/H| " << with.first << ", max|dmu/mu| " << with.second
                      << "; memoryless " << without.first << ", " << without.second);
    // The bench_long_run bound over 1e6 steps, and no worse than 3x the memoryless run.
    CHECK(with.first <= 1e-13);
    CHECK(with.second <= 1e-13);
    CHECK(with.first <= 3 * without.first + 1e-15);
    CHECK(with.second <= 3 * without.second + 1e-15);
  };
  check(SimoKappa{});
  check(GeradinBauchau{});
}

TEST_CASE("history predictor: integrate() with sub-stepped intervals keeps H exact", "[predictor][integrate]") {
  // A tight iteration cap (3) makes many steps fail at h = 0.01, so that integrate()
  // recovers intervals by sub-steps, changing h and restarting the history (measured: 61
  // of the 100 intervals recovered): the run must still end ok with H and μ exact.
  const auto ht1 = cases::ht1<double>();
  NewtonOptions<double> opt;
  opt.max_iterations = 3;
  const Stepper<SimoKappa, cases::Top<double>> stepper(SimoKappa{}, ht1.scene, opt);
  auto traj = stepper.start(ht1.initial);
  const auto sum = integrate(stepper, traj, 1.0, 0.01);
  REQUIRE(sum.ok());
  CHECK(sum.recovered > 0);
  CHECK(sum.recovered < 100);
  const double H0 = ht1.scene.energy(ht1.initial), mu0 = ht1.scene.momentum_map(ht1.initial);
  CHECK(std::abs(ht1.scene.energy(traj) - H0) <= 1e-14 * std::abs(H0));
  CHECK(std::abs(ht1.scene.momentum_map(traj) - mu0) <= 1e-14 * std::abs(mu0));
}

TEST_CASE("history predictor: H and mu on an anisotropic top, along a trajectory (2e4 steps)",
          "[predictor][invariants]") {
  // The top on which a careless acceptance drifted H (trompo_test::anisotropic_top).
  const auto top = trompo_test::anisotropic_top();
  const int n = 20000;
  // Collocation's α(Θ) jumps where B′ of [T2] changes sign (simo_step.hpp,
  // collocation_alpha), and a step whose root lies on the jump cannot converge: a Newton
  // 2-cycle, measured here once in 2e4 steps at h = 0.01 after a round-off change (step 8453,
  // residual 6e-5 relative, both halves converging in 2 iterations). Such a step is retaken
  // as two halves, as integrate() does, and counted; Simo-κ and GB have no such jump.
  const auto check_run = [&](auto scheme, double h) {
    using Scheme = decltype(scheme);
    constexpr bool jumps = std::is_same_v<Scheme, SimoCollocation>;
    const Stepper<Scheme, HeavyTop<double>> stepper(scheme, top.scene);
    const auto st = trompo_test::run(stepper, stepper.start(top.initial), h, n, jumps);  // the history along the run
    INFO(Scheme::name << " h = " << h << ": max dH/H " << st.max_dH << ", max dmu/mu " << st.max_dmu
                      << ", steps retaken as halves " << st.recovered);
    REQUIRE(st.failures == 0);
    CHECK(st.recovered <= (jumps ? 2 : 0));  // the documented rate: ~1 step in 10⁴
    CHECK(st.max_dH < 3 * std::sqrt(double(n)) * 2.2e-16);
    CHECK(st.max_dmu < 3 * std::sqrt(double(n)) * 2.2e-16);
  };
  for (double h : {0.01, 0.001}) {
    check_run(SimoKappa{}, h);
    check_run(SimoCollocation{}, h);
    check_run(GeradinBauchau{}, h);
  }
}

TEST_CASE("history predictor: a failed step leaves state and memory bit-identical", "[predictor][robustness]") {
  // The history is filled by a normal stepper; a stepper allowed one correction per solve
  // then fails the next step both from the history (two needed) and from the memoryless
  // start, and must leave the trajectory exactly as it was.
  const auto ht1 = cases::ht1<double>();
  NewtonOptions<double> one;
  one.max_iterations = 1;
  const Stepper<SimoKappa, cases::Top<double>> normal(SimoKappa{}, ht1.scene), starved(SimoKappa{}, ht1.scene, one);
  auto traj = normal.start(ht1.initial);
  for (int i = 0; i < 10; ++i) REQUIRE(normal.step(traj, 1e-3).ok());
  REQUIRE(traj.memory.trusted(1e-3));
  const auto before = traj;
  const StepReport<double> rep = starved.step(traj, 1e-3);
  CHECK_FALSE(rep.ok());
  CHECK(rep.status == StepStatus::not_converged);
  const auto& m = traj.memory;
  const auto& b = before.memory;
  for (std::size_t i = 0; i < m.increment.size(); ++i)
    CHECK(std::memcmp(m.increment[i].data(), b.increment[i].data(), sizeof(double) * 3) == 0);
  CHECK(std::memcmp(m.tangent_inverse.data(), b.tangent_inverse.data(), sizeof(double) * 9) == 0);
  CHECK(std::memcmp(&m.h, &b.h, sizeof(double)) == 0);
  CHECK(std::memcmp(&m.miss, &b.miss, sizeof(double)) == 0);
  CHECK(m.count == b.count);
  CHECK(trompo_test::same_bits(traj.state(), before.state()));
}

TEST_CASE("history predictor: a composed step failing in a later sub-step leaves every sub-step's memory bit-identical",
          "[predictor][robustness][composition]") {
  // ComposedStepper steps each sub-step's memory in place and puts back the entries of
  // the sub-steps already taken when a later one fails. The triple jump's long backward
  // middle sub-step (−1.70 h) fails the branch rule (|Θ| ≥ 0.999π) at an h where the
  // first (1.35 h) still succeeds, so entry 0 has been recorded when the step fails.
  const auto ht1 = cases::ht1<double>();
  const ComposedStepper<SimoKappa, cases::Top<double>> composed(SimoKappa{}, ht1.scene, Composition::triple_jump);
  auto traj = composed.start(ht1.initial);
  for (int i = 0; i < 10; ++i) REQUIRE(composed.step(traj, 1e-3).ok());
  const double h = 2.1 / ht1.initial.omega.norm();  // |Θ| ≈ 2.8 (first), 3.6 (middle)
  // Precondition: the first sub-step alone succeeds (so the failure is a later one's).
  {
    const Stepper<SimoKappa, cases::Top<double>> base(SimoKappa{}, ht1.scene);
    auto probe = traj.memory[0];
    State<double> s = traj.state();
    REQUIRE(base.step(s, probe, composed.coefficients().gamma[0] * h).ok());
  }
  const auto before = traj;
  const StepReport<double> rep = composed.step(traj, h);
  REQUIRE_FALSE(rep.ok());
  CHECK(std::memcmp(traj.omega.data(), before.omega.data(), sizeof(double) * 3) == 0);
  CHECK(std::memcmp(traj.rotation.unit_quaternion().coeffs().data(), before.rotation.unit_quaternion().coeffs().data(),
                    sizeof(double) * 4) == 0);
  CHECK(traj.time == before.time);
  for (std::size_t i = 0; i < traj.memory.size(); ++i) {
    const auto& m = traj.memory[i];
    const auto& b = before.memory[i];
    CAPTURE(i);
    for (std::size_t j = 0; j < m.increment.size(); ++j)
      CHECK(std::memcmp(m.increment[j].data(), b.increment[j].data(), sizeof(double) * 3) == 0);
    CHECK(std::memcmp(m.tangent_inverse.data(), b.tangent_inverse.data(), sizeof(double) * 9) == 0);
    CHECK(std::memcmp(&m.h, &b.h, sizeof(double)) == 0);
    CHECK(std::memcmp(&m.miss, &b.miss, sizeof(double)) == 0);
    CHECK(m.count == b.count);
  }
}
