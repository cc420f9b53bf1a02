// Input validation, the failure contract of a step, and integrate's recovery rule
// (docs/robustness.md).
//
//  - invalid input throws trompo::invalid_input naming the field and the value;
//  - a failed step returns its status and leaves the state bit-for-bit unchanged;
//  - integrate() lands exactly on t_end, recovers failed intervals by halving, and
//    reports what it could not recover with the state at the last accepted step.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "support/same_bits.hpp"
#include "support/show.hpp"
#include "trompo/trompo.hpp"

using namespace trompo;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

namespace {

constexpr double nan_ = std::numeric_limits<double>::quiet_NaN();
constexpr double inf_ = std::numeric_limits<double>::infinity();

/// The message of the invalid_input thrown by f (fails the test if none is thrown).
template <class F>
std::string message_of(F&& f) {
  try {
    f();
  } catch (const invalid_input& e) {
    return e.what();
  }
  FAIL("no trompo::invalid_input thrown");
  return {};
}

using trompo_test::same_bits;

template <class Scene>
double rel_energy_error(const Scene& scene, const State<double>& s, double H0) {
  return std::abs(scene.energy(s) - H0) / std::abs(H0);
}

}  // namespace

// ---- 1. input validation ------------------------------------------------------------------

TEST_CASE("invalid inertia is rejected with the field and its value", "[robustness][validation]") {
  using Body = RigidBody<double>;
  CHECK_THAT(message_of([] { Body(Vec3(1, 2, nan_)); }), Catch::Contains("inertia") && Catch::Contains("nan"));
  CHECK_THAT(message_of([] { Body(Vec3(1, inf_, 2)); }), Catch::Contains("inertia") && Catch::Contains("inf"));
  Mat3 nonsym = Vec3(2, 2, 2).asDiagonal();
  nonsym(0, 1) = 0.5;
  CHECK_THAT(message_of([&] { Body{nonsym}; }), Catch::Contains("inertia") && Catch::Contains("symmetric") &&
                                                    Catch::Contains("0.5"));
  CHECK_THAT(message_of([] { Body(Vec3(1, 2, -1)); }),
             Catch::Contains("inertia") && Catch::Contains("positive definite") && Catch::Contains("-1"));
  CHECK_THAT(message_of([] { Body(Vec3(0, 1, 1)); }), Catch::Contains("positive definite"));
  CHECK_THAT(message_of([] { Body(Vec3(1, 1, 2.5)); }),
             Catch::Contains("inertia") && Catch::Contains("triangle") && Catch::Contains("2.5"));
  // The disk limit J1 + J2 = J3 is a rigid body (a lamina), and is accepted.
  CHECK_NOTHROW(Body(Vec3(1, 2, 3)));
  CHECK_NOTHROW(Body(Vec3(1, 1, 2)));
  // Extreme but valid ratios.
  CHECK_NOTHROW(Body(Vec3(1, 1, 1e-3)));
  CHECK_NOTHROW(Body(Vec3(1, 1e3, 1e3)));
}

TEST_CASE("invalid gravity is rejected with the field and its value", "[robustness][validation]") {
  using Gravity = UniformGravity<double>;
  CHECK_THAT(message_of([] { Gravity(20, Vec3::Zero()); }), Catch::Contains("E") && Catch::Contains("(0, 0, 0)"));
  CHECK_THAT(message_of([] { Gravity(20, Vec3(0, nan_, 1)); }), Catch::Contains("E") && Catch::Contains("nan"));
  CHECK_THAT(message_of([] { Gravity(20, Vec3::UnitZ(), Vec3::Zero()); }), Catch::Contains("up"));
  CHECK_THAT(message_of([] { Gravity(20, Vec3::UnitZ(), Vec3(inf_, 0, 0)); }), Catch::Contains("up"));
  CHECK_THAT(message_of([] { Gravity(nan_, Vec3::UnitZ()); }), Catch::Contains("Mgl") && Catch::Contains("nan"));
  CHECK_THAT(message_of([] { Gravity(-inf_, Vec3::UnitZ()); }), Catch::Contains("Mgl") && Catch::Contains("inf"));
}

TEST_CASE("a non-rotation attitude and a non-finite state are rejected", "[robustness][validation]") {
  Mat3 scaled = 1.001 * Mat3::Identity();
  CHECK_THAT(message_of([&] { SO3d::from_matrix(scaled); }), Catch::Contains("rotation") && Catch::Contains("orthonormal"));
  Mat3 reflection = Mat3::Identity();
  reflection(2, 2) = -1;
  CHECK_THAT(message_of([&] { SO3d::from_matrix(reflection); }), Catch::Contains("determinant"));
  Mat3 with_nan = Mat3::Identity();
  with_nan(1, 2) = nan_;
  CHECK_THAT(message_of([&] { SO3d::from_matrix(with_nan); }), Catch::Contains("non-finite"));
  CHECK_THAT(message_of([] { SO3d::from_quaternion(Eigen::Quaterniond(2, 0, 0, 0)); }), Catch::Contains("quaternion norm"));
  CHECK_THAT(message_of([] { SO3d::renormalized(Eigen::Quaterniond(0, 0, 0, 0)); }), Catch::Contains("quaternion"));

  State<double> s;
  s.omega = Vec3(0, nan_, 1);
  CHECK_THAT(message_of([&] { s.validate(); }), Catch::Contains("omega") && Catch::Contains("nan"));
  s.omega = Vec3(0, 0, -inf_);
  CHECK_THAT(message_of([&] { s.validate(); }), Catch::Contains("omega") && Catch::Contains("inf"));
  s.omega = Vec3::Zero();
  s.time = nan_;
  CHECK_THAT(message_of([&] { s.validate(); }), Catch::Contains("time"));
  CHECK_THAT(message_of([] { SimoAlpha(1.5); }), Catch::Contains("alpha") && Catch::Contains("1.5"));
  CHECK_THAT(message_of([] { SimoAlpha{nan_}; }), Catch::Contains("alpha"));
}

TEST_CASE("a step of h = 0, NaN or ±inf is refused and changes nothing", "[robustness][validation]") {
  const auto c = cases::ht1<double>();
  const Stepper<SimoKappa, cases::Top<double>> kappa(SimoKappa{}, c.scene);
  const Stepper<GeradinBauchau, cases::Top<double>> gb(GeradinBauchau{}, c.scene);
  const Stepper<RK4, cases::Top<double>> rk4(RK4{}, c.scene);
  for (const double h : {0.0, -0.0, nan_, inf_, -inf_}) {
    CAPTURE(h);
    State<double> s = c.initial;
    const State<double> before = s;
    CHECK(kappa.step(s, h).status == StepStatus::invalid_step);
    CHECK(gb.step(s, h).status == StepStatus::invalid_step);
    CHECK(rk4.step(s, h).status == StepStatus::invalid_step);
    CHECK(same_bits(s, before));
  }
}

TEST_CASE("integrate validates h, t_end and the state before any step", "[robustness][validation][integrate]") {
  const auto c = cases::ht1<double>();
  const Stepper<SimoKappa, cases::Top<double>> st(SimoKappa{}, c.scene);
  State<double> s = c.initial;
  const State<double> before = s;
  CHECK_THAT(message_of([&] { integrate(st, s, 1.0, 0.0); }), Catch::Contains("time step h") && Catch::Contains("0"));
  CHECK_THAT(message_of([&] { integrate(st, s, 1.0, nan_); }), Catch::Contains("time step h") && Catch::Contains("nan"));
  CHECK_THAT(message_of([&] { integrate(st, s, 1.0, inf_); }), Catch::Contains("time step h") && Catch::Contains("inf"));
  CHECK_THAT(message_of([&] { integrate(st, s, 1.0, -inf_); }), Catch::Contains("time step h") && Catch::Contains("-inf"));
  CHECK_THAT(message_of([&] { integrate(st, s, nan_, 0.01); }), Catch::Contains("t_end") && Catch::Contains("nan"));
  CHECK_THAT(message_of([&] { integrate(st, s, inf_, 0.01); }), Catch::Contains("t_end") && Catch::Contains("inf"));
  CHECK_THAT(message_of([&] { integrate(st, s, -1.0, 0.01); }),
             Catch::Contains("t_end = -1") && Catch::Contains("behind the start"));
  CHECK_THAT(message_of([&] { integrate(st, s, 1.0, -0.01); }),
             Catch::Contains("t_end = 1") && Catch::Contains("behind the start"));
  State<double> far = s;
  far.time = 1e9;
  CHECK_THAT(message_of([&] { integrate(st, far, 1e9 + 1, 1e-9); }), Catch::Contains("time resolution"));
  State<double> bad = s;
  bad.omega.x() = nan_;
  CHECK_THAT(message_of([&] { integrate(st, bad, 1.0, 0.01); }), Catch::Contains("omega"));
  CHECK_THAT(message_of([&] { integrate(st, s, 1.0, 0.01, NoObserver{}, IntegrateOptions{-1}); }),
             Catch::Contains("max_halvings"));
  CHECK(same_bits(s, before));
}

// ---- 2. failures that lose nothing -------------------------------------------------------

namespace {

/// Steps `st` from `s` with h until `want` is returned (at most `tries` steps); checks
/// that the failed step left the state bit-for-bit unchanged.
/// `also` is a second acceptable status (StepStatus::ok: none).
template <class St>
void expect_failure_leaves_state(const St& st, State<double> s, double h, StepStatus want, int tries = 400,
                                 StepStatus also = StepStatus::ok) {
  for (int i = 0; i < tries; ++i) {
    const State<double> before = s;
    const StepReport<double> rep = st.step(s, h);
    if (rep.ok()) {
      REQUIRE(s.omega.allFinite());
      continue;
    }
    INFO("status: " << rep.reason());
    CHECK((rep.status == want || (also != StepStatus::ok && rep.status == also)));
    CHECK(same_bits(s, before));
    return;
  }
  FAIL("no " << to_string(want) << " within " << tries << " steps");
}

}  // namespace

TEST_CASE("each failure status leaves the state bit-for-bit unchanged", "[robustness][failure]") {
  const auto ht0 = cases::ht0<double>();
  const auto ht1 = cases::ht1<double>();
  using Top = cases::Top<double>;
  SECTION("GB: an increment at or beyond pi is out of the domain") {
    // HT1 at h = 0.05: |hΩ| ≈ 2.5 rad; the predictor e⁰ (capped at |e| = 0.99) is valid,
    // but the Newton iterates leave the domain |e| < 1.
    expect_failure_leaves_state(Stepper<GeradinBauchau, Top>(GeradinBauchau{}, ht1.scene), ht1.initial, 0.05,
                                StepStatus::out_of_domain);
    expect_failure_leaves_state(Stepper<GeradinBauchauPaper, Top>(GeradinBauchauPaper{}, ht1.scene), ht1.initial,
                                0.05, StepStatus::out_of_domain);
  }
  SECTION("Simo: an increment near or past pi is a wrong branch") {
    // HT0 at h = 0.1: |hΩ| = 5 rad.
    expect_failure_leaves_state(Stepper<SimoKappa, Top>(SimoKappa{}, ht0.scene), ht0.initial, 0.1,
                                StepStatus::wrong_branch);
    expect_failure_leaves_state(Stepper<SimoAlpha, Top>(SimoAlpha{}, ht0.scene), ht0.initial, 0.1,
                                StepStatus::wrong_branch);
    expect_failure_leaves_state(Stepper<SimoCollocation, Top>(SimoCollocation{}, ht0.scene), ht0.initial, 0.1,
                                StepStatus::wrong_branch);
  }
  SECTION("Simo: past the fold of the implicit equation Newton fails") {
    // HT0 at h = 0.05 (|Θ| ≈ 2.5 rad): 2J/h no longer dominates the gyroscopic term.
    // With plain Newton the iterates wander until the tangent is singular; with the
    // simplified Newton (the default) they may instead exhaust the iteration cap,
    // depending on round-off (the wandering is chaotic). Either is a reported failure.
    NewtonOptions<double> plain;
    plain.reuse_tangent = 0;
    expect_failure_leaves_state(Stepper<SimoKappa, Top>(SimoKappa{}, ht0.scene, plain), ht0.initial, 0.05,
                                StepStatus::singular_tangent);
    expect_failure_leaves_state(Stepper<SimoAlpha, Top>(SimoAlpha{}, ht0.scene, plain), ht0.initial, 0.05,
                                StepStatus::singular_tangent);
    expect_failure_leaves_state(Stepper<SimoKappa, Top>(SimoKappa{}, ht0.scene), ht0.initial, 0.05,
                                StepStatus::singular_tangent, 400, StepStatus::not_converged);
    expect_failure_leaves_state(Stepper<SimoAlpha, Top>(SimoAlpha{}, ht0.scene), ht0.initial, 0.05,
                                StepStatus::singular_tangent, 400, StepStatus::not_converged);
  }
  SECTION("an iteration cap that is too small: not converged") {
    NewtonOptions<double> opt;
    opt.max_iterations = 1;
    expect_failure_leaves_state(Stepper<SimoKappa, Top>(SimoKappa{}, ht1.scene, opt), ht1.initial, 0.01,
                                StepStatus::not_converged, 1);
    expect_failure_leaves_state(Stepper<SimoCollocation, Top>(SimoCollocation{}, ht1.scene, opt), ht1.initial,
                                0.01, StepStatus::not_converged, 1);
    expect_failure_leaves_state(Stepper<GeradinBauchau, Top>(GeradinBauchau{}, ht1.scene, opt), ht1.initial, 0.01,
                                StepStatus::not_converged, 1);
  }
  SECTION("overflow inside the step: non-finite, never a NaN behind ok") {
    State<double> s = ht1.initial;
    s.omega = Vec3(1e300, -1e300, 1e300);
    for (const double h : {1e-3, 1.0}) {
      const State<double> before = s;
      State<double> a = s, b = s, c = s, d = s;
      const auto r1 = Stepper<SimoKappa, Top>(SimoKappa{}, ht1.scene).step(a, h);
      const auto r2 = Stepper<GeradinBauchau, Top>(GeradinBauchau{}, ht1.scene).step(b, h);
      const auto r3 = Stepper<RK4, Top>(RK4{}, ht1.scene).step(c, h);
      const auto r4 = Stepper<SimoCollocation, Top>(SimoCollocation{}, ht1.scene).step(d, h);
      CHECK_FALSE(r1.ok());
      CHECK_FALSE(r2.ok());
      CHECK(r3.status == StepStatus::non_finite);
      CHECK_FALSE(r4.ok());
      CHECK(same_bits(a, before));
      CHECK(same_bits(b, before));
      CHECK(same_bits(c, before));
      CHECK(same_bits(d, before));
    }
  }
}

TEST_CASE("RK4 blowing up never returns ok with a zero quaternion (a fuzzer find)", "[robustness][failure]") {
  // Found by fuzz/fuzz_step.cpp: after a few wild steps q1 was finite but |q1|² overflowed,
  // and normalising by an infinite norm returned the zero quaternion with status ok.
  const cases::Free<double> scene{RigidBody<double>(Vec3(1, 1, 1.5))};
  const Stepper<RK4, cases::Free<double>> st(RK4{}, scene);
  State<double> s;
  s.rotation = SO3d::from_quaternion(Eigen::Quaterniond(0, 0, -1, 0));
  s.omega = Vec3(-1e-300, 9999.7734629232327, -9986.6577378320872);
  for (int i = 0; i < 10; ++i) {
    const State<double> before = s;
    const auto rep = st.step(s, 2.9312730450652444);
    if (!rep.ok()) {
      CHECK(rep.status == StepStatus::non_finite);
      CHECK(same_bits(s, before));
      break;
    }
    CHECK(std::abs(s.rotation.unit_quaternion().norm() - 1) <= 1e-15);
    REQUIRE(s.omega.allFinite());
  }
}

TEST_CASE("the fold rule: an accepted large step has det(K J^-1) h > 0", "[robustness][branch]") {
  // A few accepted large steps; and the rule also holds backward in time (h < 0).
  const auto c = cases::ht2<double>();
  using Top = cases::Top<double>;
  // For each accepted step the tangent K of [T3] is evaluated at the step's own root
  // y = Θ − hΩ_n = h(Ω_{n+1} − Ω_n)/2, and det(K J⁻¹)·h computed outright; it must be > 0
  // and agree in sign with the library's SimoProblem::orientation (det(K)·h).
  const Eigen::Matrix3d J_inv = c.scene.body().inertia().inverse();
  const auto fold_rule = [&](const State<double>& before, const State<double>& after, double h) {
    const detail::StepData<Top> d(c.scene, before, h);
    const Vec3 y = h * (after.omega - before.omega) / 2;
    Vec3 R;
    Eigen::Matrix3d K;
    double scale = 0;
    REQUIRE(SimoKappa{}.residual(d)(y, R, K, scale));
    const detail::SimoProblem<detail::SimoVariant::kappa, Top> problem(0.5, d, before);
    return std::pair{(K * J_inv).determinant() * h, problem.orientation(K)};
  };
  for (const double h : {0.015, -0.015}) {
    const Stepper<SimoKappa, Top> st(SimoKappa{}, c.scene);
    State<double> s = c.initial;
    s.time = h > 0 ? 0.0 : 2.0;
    int ok = 0;
    double min_det = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 40; ++i) {
      const State<double> before = s;
      const auto rep = st.step(s, h);
      if (rep.ok()) {
        ++ok;
        const auto [det_h, orientation] = fold_rule(before, s, h);
        INFO("step " << i << ", h = " << h << ": det(K J^-1) h = " << det_h << ", orientation " << orientation);
        CHECK(det_h > 0);
        CHECK(orientation > 0);
        min_det = std::min(min_det, det_h);
      } else {
        CHECK(same_bits(s, before));
        for (int k = 0; k < 4; ++k) REQUIRE(st.step(s, h / 4).ok());
      }
    }
    CHECK(ok > 10);
    SHOW("h = " << h << ": " << ok << " accepted steps, min det(K J^-1) h = " << min_det);
  }
  // The check can fail: the same step's tangent with h's sign flipped (the root of the
  // step backward, read as a forward one) is on the wrong side of the rule.
  State<double> s = c.initial;
  const State<double> before = s;
  REQUIRE(Stepper<SimoKappa, Top>(SimoKappa{}, c.scene).step(s, 0.015).ok());
  const detail::StepData<Top> d(c.scene, before, -0.015);
  Vec3 R;
  Eigen::Matrix3d K;
  double scale = 0;
  REQUIRE(SimoKappa{}.residual(d)(Vec3(0.015 * (s.omega - before.omega) / 2), R, K, scale));
  CHECK_FALSE((K * J_inv).determinant() * 0.015 > 0);
}

// ---- 3. integrate ---------------------------------------------------------------------------

TEST_CASE("integrate lands exactly on t_end and matches plain stepping bit for bit", "[robustness][integrate]") {
  // FB1 (|Ω| ≈ 2): steps up to 0.3 are well inside every scheme's range.
  const auto c = cases::fb1<double>();
  const Stepper<SimoKappa, cases::Free<double>> st(SimoKappa{}, c.scene);

  SECTION("whole steps of exactly h, then the remainder") {
    State<double> a = c.initial;
    const auto sum = integrate(st, a, 1.0, 0.3);  // 0.3, 0.6, 0.9, then 0.1
    CHECK(sum.ok());
    CHECK(sum.steps == 4);
    CHECK(sum.substeps == 0);
    CHECK(sum.failures == 0);
    CHECK(a.time == 1.0);
    CHECK(sum.time == 1.0);
    State<double> b = c.initial;
    for (int i = 0; i < 3; ++i) REQUIRE(st.step(b, 0.3).ok());
    REQUIRE(st.step(b, 1.0 - 3 * 0.3).ok());  // the grid time t0 + 3h is 0.9 (0.3*3 = 0.8999999999999999)
    CHECK((a.omega - b.omega).norm() <= 1e-12);
  }
  SECTION("a span that is a whole number of steps up to round-off takes no sliver step") {
    State<double> a = c.initial;
    const auto sum = integrate(st, a, 1.0, 0.1);  // 1.0/0.1 = 10 up to round-off
    CHECK(sum.steps == 10);
    CHECK(a.time == 1.0);
    State<double> b = c.initial;
    const auto sum2 = integrate(st, b, 0.7, 0.1);  // 0.7/0.1 = 6.999999999999999
    CHECK(sum2.steps == 7);
    CHECK(b.time == 0.7);
  }
  SECTION("the steps are exactly h: same bits as a loop of step(s, h)") {
    // Trajectories on both sides: integrate() would step a plain State along a trajectory
    // of its own (the scheme's history predictor), a loop of step(State&, h) memoryless.
    auto a = st.start(c.initial), b = st.start(c.initial);
    const double h = 1.0 / 64;
    REQUIRE(integrate(st, a, 1.0, h).ok());
    for (int i = 0; i < 64; ++i) REQUIRE(st.step(b, h).ok());
    CHECK(same_bits(a.state(), b.state()));
    CHECK(a.time == 1.0);
  }
  SECTION("t_end == t0: nothing to do") {
    State<double> a = c.initial;
    const State<double> before = a;
    int calls = 0;
    const auto sum = integrate(st, a, 0.0, 0.01, [&](const State<double>&) { ++calls; });
    CHECK(sum.ok());
    CHECK(sum.steps == 0);
    CHECK(calls == 1);
    CHECK(same_bits(a, before));
  }
  SECTION("backward in time") {
    State<double> a = c.initial;
    REQUIRE(integrate(st, a, 5.0, 0.01).ok());
    const auto sum = integrate(st, a, 0.0, -0.01);
    CHECK(sum.ok());
    CHECK(sum.steps == 500);
    CHECK(a.time == 0.0);
    CHECK((a.omega - c.initial.omega).norm() <= 1e-10 * c.initial.omega.norm());
    CHECK((a.rotation.inverse() * c.initial.rotation).log().norm() <= 1e-11);
  }
  SECTION("starting from a non-zero time") {
    State<double> a = c.initial;
    a.time = 10.0;
    const auto sum = integrate(st, a, 10.25, 0.1);
    CHECK(sum.steps == 3);
    CHECK(a.time == 10.25);
  }
}

TEST_CASE("the observer sees the start and every grid time — none costs nothing", "[robustness][integrate]") {
  static_assert(std::is_empty_v<NoObserver>);
  const auto c = cases::fb1<double>();
  const Stepper<GeradinBauchau, cases::Free<double>> st(GeradinBauchau{}, c.scene);
  State<double> a = c.initial, b = c.initial;
  std::vector<double> times;
  const auto sum = integrate(st, a, 1.0, 0.125, [&](const State<double>& s) { times.push_back(s.time); });
  REQUIRE(sum.ok());
  REQUIRE(times.size() == 9);
  for (std::size_t k = 0; k < times.size(); ++k) CHECK(times[k] == 0.125 * static_cast<double>(k));
  REQUIRE(integrate(st, b, 1.0, 0.125).ok());
  CHECK(same_bits(a, b));
}

TEST_CASE("integrate recovers failed intervals by halving and keeps the invariants", "[robustness][integrate][recovery]") {
  const auto c = cases::ht0<double>();
  using Top = cases::Top<double>;
  const double H0 = c.scene.energy(c.initial);
  const double mu0 = c.scene.momentum_map(c.initial);

  SECTION("Simo-kappa at h = 0.1 (|h Omega| = 5 rad): every interval is recovered") {
    const Stepper<SimoKappa, Top> st(SimoKappa{}, c.scene);
    State<double> s = c.initial;
    double max_dH = 0, max_dmu = 0;
    const auto sum = integrate(st, s, 2.0, 0.1, [&](const State<double>& x) {
      max_dH = std::max(max_dH, rel_energy_error(c.scene, x, H0));
      max_dmu = std::max(max_dmu, std::abs(c.scene.momentum_map(x) - mu0) / std::abs(mu0));
    });
    CHECK(sum.ok());
    CHECK(s.time == 2.0);
    CHECK(sum.recovered == 20);
    CHECK(sum.steps == 0);
    CHECK(sum.substeps > 40);
    CHECK(sum.failures >= 20);
    CHECK(sum.max_depth >= 1);
    CHECK(sum.max_depth <= 3);
    CHECK(sum.last_failure != StepStatus::ok);
    CHECK(max_dH <= 1e-13);
    CHECK(max_dmu <= 1e-13);
  }
  SECTION("GB at h = 0.05: every whole step leaves the domain, halves do not") {
    const Stepper<GeradinBauchau, Top> st(GeradinBauchau{}, c.scene);
    State<double> s = c.initial;
    const auto sum = integrate(st, s, 1.0, 0.05);
    CHECK(sum.ok());
    CHECK(sum.recovered == 20);
    CHECK(sum.substeps == 40);
    CHECK(sum.last_failure == StepStatus::out_of_domain);
    CHECK(rel_energy_error(c.scene, s, H0) <= 1e-13);
    CHECK(std::abs(c.scene.momentum_map(s) - mu0) <= 1e-13 * std::abs(mu0));
  }
  SECTION("recovery off: the first failure stops, the state is the last accepted one") {
    const Stepper<GeradinBauchau, Top> st(GeradinBauchau{}, c.scene);
    State<double> s = c.initial;
    const State<double> before = s;
    const auto sum = integrate(st, s, 1.0, 0.05, NoObserver{}, IntegrateOptions{0});
    CHECK_FALSE(sum.ok());
    CHECK(sum.status == StepStatus::out_of_domain);
    CHECK(sum.steps == 0);
    CHECK(sum.time == 0.0);
    CHECK(same_bits(s, before));
  }
  SECTION("an unrecoverable blow-up is reported with a bounded number of attempts") {
    // RK4 at h = 0.1 on HT0 is unstable: it overflows after a few steps, and no halving
    // of the offending interval can bring a state of 1e150 back.
    const Stepper<RK4, Top> st(RK4{}, c.scene);
    State<double> s = c.initial;
    const auto sum = integrate(st, s, 10.0, 0.1, NoObserver{}, IntegrateOptions{4});
    CHECK_FALSE(sum.ok());
    CHECK(sum.status == StepStatus::non_finite);
    CHECK(sum.time < 10.0);
    CHECK(s.time == sum.time);
    CHECK(s.omega.allFinite());
    CHECK(sum.max_depth == 4);
    CHECK(sum.failures <= 2 * 4 + 1);
  }
}

TEST_CASE("integrate works for float and long double", "[robustness][integrate]") {
  {
    const auto c = cases::ht1<float>();
    const Stepper<SimoKappa, cases::Top<float>> st(SimoKappa{}, c.scene);
    State<float> s = c.initial;
    const auto sum = integrate(st, s, 1.0f, 0.01f);
    CHECK(sum.ok());
    CHECK(s.time == 1.0f);
  }
  {
    const auto c = cases::ht1<long double>();
    const Stepper<GeradinBauchau, cases::Top<long double>> st(GeradinBauchau{}, c.scene);
    State<long double> s = c.initial;
    const auto sum = integrate(st, s, 1.0L, 0.01L);
    CHECK(sum.ok());
    CHECK(s.time == 1.0L);
  }
}
