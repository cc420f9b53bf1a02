// Control in the loop (docs/control.md, docs/theory.md §16): reaction wheels with held motor
// torques, the sampled driver, torque laws with automatic Jacobians, magnetorquers, the
// built-in controllers, and their failure contracts.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <vector>

#include "support/trompo_test.hpp"

using namespace trompo;
using trompo_test::Mat3;
using trompo_test::rpm;
using trompo_test::Vec3;
using trompo_test::WheelVector;
using trompo_test::Wheels;

namespace {

/// A controller that replays a schedule: u(t) for the wheels.
struct Schedule {
  std::function<WheelVector(double)> u;
  std::vector<double> calls;  // its memory: the sample times it saw
  Command<double> operator()(const Sample<double>& s) {
    calls.push_back(s.time);
    Command<double> c;
    c.wheel_torques = u(s.time);
    return c;
  }
};

/// Three wheels on the body axes and one skew wheel, on an asymmetric spacecraft.
Wheels four_wheels(double umax = 0.5) {
  Wheels rw;
  rw.add_wheel({.axis = Vec3::UnitX(), .inertia = 0.08, .speed0 = 100 * rpm, .max_torque = umax});
  rw.add_wheel({.axis = Vec3::UnitY(), .inertia = 0.08, .speed0 = -200 * rpm, .max_torque = umax});
  rw.add_wheel({.axis = Vec3::UnitZ(), .inertia = 0.08, .speed0 = 300 * rpm, .max_torque = umax});
  rw.add_wheel({.axis = Vec3(1, 1, 1), .inertia = 0.05, .speed0 = 50 * rpm, .max_torque = umax});
  return rw;
}

}  // namespace

// Basilisk's closed-form spin-up ("BOE"): hub diag(2, 2, 2) with a wheel on z
// (J = diag(2, 2, 2 + J_s)), u = 0.2 N m from t = 5 s. On this axis the motion is a
// polynomial of degree 1, which every scheme that carries the wheels follows to round-off.
TEMPLATE_TEST_CASE("wheels: Basilisk's closed-form spin-up", "[control]", SimoKappa, SimoAlpha, RK4, Splitting, LGVI) {
  const double Js = 100.0 / (6000.0 * rpm), u = 0.2, w0 = 0.35, W0 = 100 * rpm;
  Wheels rw;
  rw.add_wheel({.axis = Vec3::UnitZ(), .inertia = Js, .speed0 = W0});
  const Mat3 J = Vec3(2, 2, 2 + Js).asDiagonal();
  Scene<double, Wheels> sc(rw.hub_body(J), rw);
  CHECK(sc.body().inertia().isApprox(Mat3(Vec3(2, 2, 2).asDiagonal()), 1e-15));
  Stepper<TestType, Scene<double, Wheels>> stepper(TestType{}, sc);
  State<double> s;
  s.omega = Vec3(0, 0, w0);
  stepper.scene().template effect<Wheels>().start(0.0, s.omega);
  Schedule ctrl{[&](double t) { return WheelVector::Constant(1, t >= 5.0 - 1e-12 ? u : 0.0); }, {}};
  const SampledSummary<double> sum = integrate_sampled(stepper, s, 10.0, 0.5, ctrl, FixedSteps<double>{0.01});
  REQUIRE(sum.ok());
  CHECK(sum.samples == 20);
  const double t = s.time;
  REQUIRE(t == 10.0);
  const double wz = w0 - u * (t - 5) / 2;
  const double Wt = W0 + (2 + Js) * u * (t - 5) / (2 * Js);
  CHECK(std::abs(s.omega.z() - wz) <= 1e-13);
  CHECK(s.omega.head<2>().norm() <= 1e-15);
  const WheelVector speeds = stepper.scene().template effect<Wheels>().speeds(t, s.omega);
  CHECK(std::abs(speeds(0) - Wt) <= 1e-12 * Wt);
}

// Total momentum π = Λ(J_hubΩ + Σ h_i g_i) under random held commands: exact to round-off in
// the energy-momentum schemes (no external torque) [W4], and the energy balance
// H_{n+1} − H_n = h Σ u_i Ω_i,m exact step by step [W3].
TEMPLATE_TEST_CASE("wheels: total momentum and the energy balance under random commands", "[control]", SimoKappa,
                   SimoCollocation, SimoAlpha, LGVI) {
  Wheels rw = four_wheels();
  const Mat3 J = (Mat3() << 900, 20, -10, 20, 800, 15, -10, 15, 600).finished();
  using Sc = Scene<double, Wheels>;
  // Simo-κ, collocation and the LGVI with the compensated state (docs/theory.md §18); Simo-α
  // has no memory to carry it in. The LGVI keeps π but has no discrete energy balance [V13].
  TestType scheme;
  constexpr bool compensated = requires { scheme.compensated; };
  if constexpr (compensated) scheme.compensated = true;
  Stepper<TestType, Sc> stepper(scheme, Sc(rw.hub_body(J), rw));
  State<double> s;
  s.rotation = SO3d::exp(Vec3(0.3, -0.2, 0.5));
  s.omega = Vec3(0.05, -0.1, 0.2);
  stepper.scene().template effect<Wheels>().start(0.0, s.omega);
  trompo_test::Rng rng(33);
  Schedule ctrl{[&](double) {
                  WheelVector u(4);
                  for (int i = 0; i < 4; ++i) u(i) = rng.uniform(-0.6, 0.6);  // some beyond u_max: clipped
                  return u;
                },
                {}};
  const Vec3 pi0 = stepper.scene().spatial_momentum(s);
  const double h = 0.02;
  double max_pi = 0, max_balance = 0;
  // TROMPO_CONTROL_STEPS=1000000 runs the 10⁶ steps (docs/control.md, "Targets").
  const char* steps_env = std::getenv("TROMPO_CONTROL_STEPS");
  const int n = steps_env ? std::atoi(steps_env) : 100000;
  REQUIRE(n > 0);
  // At each row: its time, H, the command held from it on, and the wheels' speeds.
  struct Row {
    double t, H;
    WheelVector u, speeds;
  };
  Row prev{-1, 0, {}, {}};
  auto observer = [&](const State<double>& x) {
    const Sc& scene = stepper.scene();
    const auto& w = scene.template effect<Wheels>();
    max_pi = std::max(max_pi, (scene.spatial_momentum(x) - pi0).norm() / pi0.norm());
    const Row row{x.time, scene.energy(x), w.torques(), w.speeds(x.time, x.omega)};
    if (prev.t >= 0) {
      // ΔH = h Σ u_i Ω_i,m: the motors' work over the step [W3], Ω_i,m the mean of the end speeds.
      const double work = (row.t - prev.t) * prev.u.dot((prev.speeds + row.speeds) / 2);
      max_balance = std::max(max_balance, std::abs(row.H - prev.H - work) / std::abs(row.H));
    }
    prev = row;
  };
  const auto sum = integrate_sampled(stepper, s, n * h, 0.1, ctrl, FixedSteps<double>{h}, observer);
  INFO(sum.reason() << " at t = " << sum.time);
  REQUIRE(sum.ok());
  CHECK(sum.steps == n);
  INFO("max |pi - pi0|/|pi0| = " << max_pi << ", max energy-balance residual = " << max_balance);
  // Round-off only. Plain state: a walk of ~√N·ε (measured 1.4e-14 after 10^5 steps; √N·ε =
  // 7e-14). Compensated: what is left is the increments' own rounding, O(ε·hΩ) a step
  // (measured 5.8e-16 after 10^5 steps).
  if constexpr (compensated) CHECK(max_pi <= 4e-15);
  else CHECK(max_pi <= 3 * std::sqrt(double(n)) * 2.22e-16);
  if constexpr (!std::is_same_v<TestType, LGVI>) CHECK(max_balance <= 1e-14);
  // The commands did something: the wheels' speeds moved far from their start.
  CHECK((stepper.scene().template effect<Wheels>().speeds(s.time, s.omega) - four_wheels().speeds(0, Vec3::Zero())).norm() > 1);
}

TEST_CASE("wheels: RK4 and compositions carry them, RK4 with a momentum error falling as h^4", "[control]") {
  Wheels rw = four_wheels();
  const Mat3 J = Vec3(900, 800, 600).asDiagonal();
  using Sc = Scene<double, Wheels>;
  auto run = [&](auto stepper, double h) {
    State<double> s;
    s.omega = Vec3(0.05, -0.1, 0.2);
    stepper.scene().template effect<Wheels>().start(0.0, s.omega);
    const Vec3 pi0 = stepper.scene().spatial_momentum(s);
    auto ctrl = [](const Sample<double>& x) {
      Command<double> c;
      c.wheel_torques = WheelVector::Constant(4, 0.3 * std::sin(x.time));
      return c;
    };
    REQUIRE(integrate_sampled(stepper, s, 20.0, 0.5, ctrl, FixedSteps<double>{h}).ok());
    return std::make_pair(s, (stepper.scene().spatial_momentum(s) - pi0).norm() / pi0.norm());
  };
  const auto [s4, e4] = run(ComposedStepper<SimoKappa, Sc>(SimoKappa{}, Sc(rw.hub_body(J), rw), 4), 0.5);
  const auto [s4f, e4f] = run(ComposedStepper<SimoKappa, Sc>(SimoKappa{}, Sc(rw.hub_body(J), rw), 4), 0.25);
  CHECK(e4 <= 1e-14);
  CHECK(e4f <= 1e-14);
  const auto [r1, q1] = run(Stepper<RK4, Sc>(RK4{}, Sc(rw.hub_body(J), rw)), 0.1);
  const auto [r2, q2] = run(Stepper<RK4, Sc>(RK4{}, Sc(rw.hub_body(J), rw)), 0.05);
  // RK4 keeps nothing: its momentum error is O(h^4) (ratio 16 for a halved h, within 30 %).
  INFO("RK4 momentum error " << q1 << " -> " << q2);
  CHECK(q1 > 1e-13);
  CHECK(q1 / q2 > 11);
  // Order 4 composition and RK4 agree with each other on the attitude (both accurate).
  CHECK((s4f.rotation.matrix() - r2.rotation.matrix()).norm() <= 1e-6);
}

namespace {
/// A 60 rpm spacecraft, J = diag(120, 100, 150), with three wheels on its axes: the scene, and
/// its state at t0 with the stepper's wheels started there (the clock tests below).
struct FastSpinner {
  using Sc = Scene<double, Wheels>;
  Wheels rw = [] {
    Wheels w;
    for (int i = 0; i < 3; ++i)
      w.add_wheel({.axis = Vec3::Unit(i), .inertia = 0.05, .speed0 = 10.0 * (i + 1), .max_torque = 0.5});
    return w;
  }();
  Sc scene() const { return Sc(rw.hub_body(Vec3(120, 100, 150).asDiagonal()), rw); }
  template <class StepperT>
  static State<double> start(StepperT& stepper, double t0) {
    State<double> s;
    s.time = t0;
    s.omega = Vec3(0.6, 0.0, 60 * rpm);
    stepper.scene().template effect<Wheels>().start(s.time, s.omega);
    return s;
  }
};
}  // namespace

// A composed step with wheels covers its interval exactly, wherever it lies in time: with no
// motor command the wheels' momenta are constant and the run does not depend on its start
// time t0, so the same run from t0 = 0 and from t0 = 1e5 (where ulp(t) = 1.5e-11 s) must
// agree to round-off. Before the sub-steps were laid on times rounded once each ([W4]), the
// last sub-step took what the rounded sum of the others left, the dynamics ran ahead of the
// clock by ~ulp(t) a step, and the two runs differed by 6e-8 (order 4) and 2e-7 (order 6)
// after 1000 steps (measured); now by 3e-14.
TEST_CASE("wheels: a composed step covers its interval exactly, far from t = 0", "[control]") {
  const FastSpinner spinner;
  using Sc = FastSpinner::Sc;
  for (const int order : {4, 6}) {
    auto run = [&](double t0) {
      ComposedStepper<SimoKappa, Sc> stepper(SimoKappa{}, spinner.scene(), order);
      State<double> s = FastSpinner::start(stepper, t0);
      REQUIRE(integrate(stepper, s, t0 + 1.0, 1e-3).ok());
      return s;
    };
    const State<double> near = run(0.0), far = run(1e5);
    INFO("order " << order);
    CHECK((near.rotation.matrix() - far.rotation.matrix()).norm() <= 1e-11);
    CHECK((near.omega - far.omega).norm() <= 1e-11);
  }
  // The processed composition: its kernel ends each step on integrate()'s grid (it ran on a
  // running sum of the primed h, and the two runs differed by 3.4e-8; now by 5e-15), with the
  // output deferred (no observer) and at every step (an observer).
  for (const bool observed : {false, true}) {
    auto run = [&](double t0) {
      ProcessedStepper<SimoKappa, Sc> stepper(SimoKappa{}, spinner.scene());
      State<double> s = FastSpinner::start(stepper, t0);
      int rows = 0;
      const bool ok = observed ? integrate(stepper, s, t0 + 1.0, 1e-3, [&](const State<double>&) { ++rows; }).ok()
                               : integrate(stepper, s, t0 + 1.0, 1e-3).ok();
      REQUIRE(ok);
      CHECK(rows == (observed ? 1001 : 0));  // t0 and each step
      return s;
    };
    const State<double> near = run(0.0), far = run(1e5);
    INFO("processed, observed " << observed);
    CHECK((near.rotation.matrix() - far.rotation.matrix()).norm() <= 1e-11);
    CHECK((near.omega - far.omega).norm() <= 1e-11);
  }
}

// Richardson's estimate steps each attempt as m inner steps; with wheels they lie on times
// rounded once each and span their differences ([W4]), so π stays at round-off wherever the
// run is in time. Measured at t0 = 1e8 (ulp(t) = 1.5e-8 s), 54,018 steps under held commands:
// 9.8e-15 (8.1e-10 when the inner steps ran on a sum of h/m and the attempt's end was set
// after them).
TEST_CASE("wheels: Richardson's inner steps keep pi far from t = 0", "[control][adaptive]") {
  Stepper<SimoKappa, FastSpinner::Sc> stepper(SimoKappa{}, FastSpinner{}.scene());
  const double t0 = 1e8;
  State<double> s = FastSpinner::start(stepper, t0);
  const Vec3 pi0 = stepper.scene().spatial_momentum(s);
  int k = 0;
  auto ctrl = [&k](const Sample<double>&) {
    Command<double> c;
    c.wheel_torques = WheelVector(3);
    c.wheel_torques << 0.3 * std::sin(k), -0.2 * std::cos(1.3 * k), 0.1;
    ++k;
    return c;
  };
  AdaptiveOptions<double> opt;
  opt.rtol = opt.atol = 1e-6;
  opt.estimate = ErrorEstimate::richardson;
  opt.substeps = 3;
  const SampledSummary<double> sum = integrate_sampled(stepper, s, t0 + 100.0, 0.5, ctrl, AdaptiveSteps<double>{opt});
  REQUIRE(sum.ok());
  const double err = (stepper.scene().spatial_momentum(s) - pi0).norm() / pi0.norm();
  const double bound = 3 * std::sqrt(static_cast<double>(sum.steps)) * std::numeric_limits<double>::epsilon();
  INFO(sum.steps << " steps: |dpi|/|pi| = " << err << ", bound " << bound);
  CHECK(sum.steps > 10000);
  CHECK(err <= bound);
}

// The splitting carries wheels by a rotor flow about w(t) = −J⁻¹h_w(t) read at the split
// clock [W14]: π exact (every sub-flow keeps ΛΠ), the closed-form spin-up followed, orders 2
// and 4 measured from a Δt sweep against a converged run.
// (Three wheels on the body axes and a diagonal J, so that the hub is diagonal: on a
// non-diagonal inertia the splitting's conversion to its principal working frame and back
// at every step biases π by ~4e-16 a step, with or without wheels, docs/control.md.)
TEST_CASE("wheels: the splitting carries them", "[control]") {
  Wheels rw;
  rw.add_wheel({.axis = Vec3::UnitX(), .inertia = 0.08, .speed0 = 100 * rpm});
  rw.add_wheel({.axis = Vec3::UnitY(), .inertia = 0.08, .speed0 = -200 * rpm});
  rw.add_wheel({.axis = Vec3::UnitZ(), .inertia = 0.08, .speed0 = 300 * rpm});
  const Mat3 J = Vec3(900, 800, 600).asDiagonal();
  using Sc = Scene<double, Wheels>;
  auto run = [&](SplittingMethod m, double h, double* pi_err = nullptr) {
    Stepper<Splitting, Sc> stepper(Splitting(m), Sc(rw.hub_body(J), rw));
    State<double> s;
    s.rotation = SO3d::exp(Vec3(0.3, -0.2, 0.5));
    s.omega = Vec3(0.5, -1.0, 2.0);
    stepper.scene().effect<Wheels>().start(0.0, s.omega);
    const Vec3 pi0 = stepper.scene().spatial_momentum(s);
    double worst = 0;
    auto ctrl = [](const Sample<double>& x) {
      Command<double> c;
      c.wheel_torques = WheelVector(3);
      c.wheel_torques << 0.3 * std::sin(x.time), -0.2, 0.4 * std::cos(2 * x.time);
      return c;
    };
    auto obs = [&](const State<double>& x) {
      worst = std::max(worst, (stepper.scene().spatial_momentum(x) - pi0).norm() / pi0.norm());
    };
    REQUIRE(integrate_sampled(stepper, s, 8.0, 0.5, ctrl, FixedSteps<double>{h}, obs).ok());
    if (pi_err) *pi_err = worst;
    return s;
  };
  const State<double> ref = run(SplittingMethod::kahan_li_9, 0.5 / 64);
  for (const auto& [m, p] : {std::pair{SplittingMethod::strang, 2}, std::pair{SplittingMethod::suzuki_5, 4}}) {
    double pi_err = 0;
    const double e1 = (run(m, 0.5 / 4, &pi_err).rotation.matrix() - ref.rotation.matrix()).norm();
    const double e2 = (run(m, 0.5 / 8).rotation.matrix() - ref.rotation.matrix()).norm();
    const double order = std::log2(e1 / e2);
    INFO(to_string(m) << ": errors " << e1 << " -> " << e2 << ", order " << order << ", pi " << pi_err);
    CHECK(std::abs(order - p) <= 0.3);
    CHECK(pi_err <= 1e-14);
  }
  CHECK_THROWS_WITH(Splitting(SplittingMethod::chin_4a).check(Sc(rw.hub_body(J), rw)), Catch::Contains("wheels"));
}

// The near-integrable compositions with wheels [W18]: A the hub's exact free flow, B the
// wheels' rotor flow (with the loads' flows around it), so the error is O(εh^{2n} + ε²h²), ε
// the size of B, where Strang's is O(εh²). Both are order 2 in h; what tells them apart is how the
// error follows ε: linear for Strang, quadratic for SABA2 (a fast asymmetric spinner whose
// wheels carry ~1e-4 of its momentum; the wheels' speeds and held torques scale with ε).
TEST_CASE("wheels: the near-integrable splittings", "[control]") {
  using Sc = Scene<double, Wheels>;
  const double T = 0.1;
  auto run = [&](SplittingMethod m, double eps, double h, double* pi_err = nullptr) {
    Wheels rw;
    for (int i = 0; i < 3; ++i) rw.add_wheel({.axis = Vec3::Unit(i), .inertia = 0.05, .speed0 = eps * 2000 * (i - 1)});
    Stepper<Splitting, Sc> stepper(Splitting(m), Sc(rw.hub_body(Vec3(120, 100, 150).asDiagonal()), rw));
    State<double> s;
    s.rotation = SO3d::exp(Vec3(0.1, -0.3, 0.2));
    s.omega = Vec3(0.6, 0.0, 6.3);
    stepper.scene().effect<Wheels>().start(0.0, s.omega);
    const Vec3 pi0 = stepper.scene().spatial_momentum(s);
    double worst = 0;
    auto ctrl = [eps](const Sample<double>& x) {
      Command<double> c;
      c.wheel_torques = WheelVector(3);
      c.wheel_torques << eps * 50 * std::sin(x.time), -eps * 30, eps * 40 * std::cos(2 * x.time);
      return c;
    };
    auto obs = [&](const State<double>& x) {
      worst = std::max(worst, (stepper.scene().spatial_momentum(x) - pi0).norm() / pi0.norm());
    };
    REQUIRE(integrate_sampled(stepper, s, 4.0, T, ctrl, FixedSteps<double>{h}, obs).ok());
    if (pi_err) *pi_err = worst;
    return s;
  };
  for (const auto& [m, eps_power] : {std::pair{SplittingMethod::strang, 1}, std::pair{SplittingMethod::saba2c, 2}}) {
    double e[2][2] = {};  // [ε, ε/2][h, h/2]; ε/2 at h alone
    for (int i = 0; i < 2; ++i) {
      const double eps = 1e-3 / (1 << i);
      const State<double> ref = run(SplittingMethod::kahan_li_9, eps, T / 32);
      for (int j = 0; j < 2 - i; ++j) {
        double pi_err = 0;
        e[i][j] = (run(m, eps, T / (1 << j), &pi_err).rotation.matrix() - ref.rotation.matrix()).norm();
        CHECK(pi_err <= 1e-14);
      }
    }
    const double order_h = std::log2(e[0][0] / e[0][1]), order_eps = std::log2(e[0][0] / e[1][0]);
    INFO(to_string(m) << ": errors " << e[0][0] << ", " << e[0][1] << " (h/2), " << e[1][0] << " (eps/2): order "
                      << order_h << " in h, " << order_eps << " in eps");
    CHECK(std::abs(order_h - 2) <= 0.3);
    CHECK(std::abs(order_eps - eps_power) <= 0.3);
  }
  // At equal h the other near-integrable methods are as far below Strang (ε = 1e-3: ~1e-9
  // against 2e-6), and keep π.
  const State<double> ref = run(SplittingMethod::kahan_li_9, 1e-3, T / 32);
  const double strang = (run(SplittingMethod::strang, 1e-3, T).rotation.matrix() - ref.rotation.matrix()).norm();
  for (SplittingMethod m : {SplittingMethod::saba3c, SplittingMethod::saba4c, SplittingMethod::sbab2c, SplittingMethod::sbab3c}) {
    double pi_err = 0;
    const double err = (run(m, 1e-3, T, &pi_err).rotation.matrix() - ref.rotation.matrix()).norm();
    INFO(to_string(m) << ": " << err << " against Strang's " << strang);
    CHECK(err <= strang / 300);
    CHECK(pi_err <= 1e-14);
  }
  // The order the drivers see (Richardson's estimate): 2 with wheels, 4 without.
  Wheels rw;
  rw.add_wheel({.axis = Vec3::UnitZ(), .inertia = 0.05});
  const Sc scene(rw.hub_body(Vec3(120, 100, 150).asDiagonal()), rw);
  CHECK(Stepper<Splitting, Sc>(Splitting(SplittingMethod::saba2c), scene).order() == 2);
  CHECK(Stepper<Splitting, Scene<double>>(Splitting(SplittingMethod::saba2c), Scene<double>(RigidBody<double>(Vec3(1, 2, 3)))).order() == 4);
  // Beside loads B is damping, kick, the rotor flow, kick, damping: still far below Strang, on
  // an asymmetric hub (A the exact flow [F1]–[F7]) and on a symmetric one (A the flow [S2]).
  using Loaded = Scene<double, Wheels, UniformGravity<double>, ViscousDamping<double>>;
  auto loaded_run = [&](SplittingMethod m, double h, const Vec3& J) {
    Wheels w = rw;
    w.add_wheel({.axis = Vec3::UnitX(), .inertia = 0.05, .speed0 = 2.0});
    Stepper<Splitting, Loaded> stepper(Splitting(m), Loaded(w.hub_body(J.asDiagonal()), w,
                                                            UniformGravity<double>(0.5, Vec3(0.1, 0.2, 1.0), Vec3::UnitZ()),
                                                            ViscousDamping<double>(0.01)));
    State<double> s;
    s.omega = Vec3(0.6, 0.0, 6.3);
    stepper.scene().effect<Wheels>().start(0.0, s.omega);
    auto ctrl = [](const Sample<double>& x) {
      Command<double> c;
      c.wheel_torques = WheelVector(2);
      c.wheel_torques << 0.02 * std::cos(x.time), 0.03;
      return c;
    };
    REQUIRE(integrate_sampled(stepper, s, 4.0, T, ctrl, FixedSteps<double>{h}).ok());
    return s;
  };
  for (const Vec3& J : {Vec3(120, 100, 150), Vec3(120, 120, 150)}) {
    const State<double> loaded_ref = loaded_run(SplittingMethod::kahan_li_9, T / 32, J);
    const double loaded_strang = (loaded_run(SplittingMethod::strang, T, J).rotation.matrix() - loaded_ref.rotation.matrix()).norm();
    const double loaded_saba = (loaded_run(SplittingMethod::saba2c, T, J).rotation.matrix() - loaded_ref.rotation.matrix()).norm();
    INFO("J = " << J.transpose() << ", with loads: saba2c " << loaded_saba << ", strang " << loaded_strang);
    CHECK(loaded_saba <= loaded_strang / 100);
  }
  CHECK_NOTHROW(Splitting(SplittingMethod::saba2c).check(scene));
}

// The LGVI carries wheels by its gyrostat term with the wheels' momentum at the step's mid
// time [V13]: π exact under any command (the test above), order 2 and, being
// symmetric (a step back undoes a step), order 4 by Suzuki-5, from a Δt sweep against a
// converged Simo-κ run. Four wheels (one skew) on a non-diagonal inertia.
TEST_CASE("wheels: the LGVI carries them", "[control][fourth]") {
  Wheels rw = four_wheels();
  const Mat3 J = (Mat3() << 900, 20, -10, 20, 800, 15, -10, 15, 600).finished();
  using Sc = Scene<double, Wheels>;
  auto ctrl = [](const Sample<double>& x) {
    Command<double> c;
    c.wheel_torques = WheelVector(4);
    c.wheel_torques << 0.3 * std::sin(x.time), -0.2, 0.4 * std::cos(2 * x.time), 0.1;
    return c;
  };
  auto run = [&](auto stepper, double h, double* pi_err = nullptr) {
    State<double> s;
    s.rotation = SO3d::exp(Vec3(0.3, -0.2, 0.5));
    s.omega = Vec3(0.5, -1.0, 2.0);
    stepper.scene().template effect<Wheels>().start(0.0, s.omega);
    const Vec3 pi0 = stepper.scene().spatial_momentum(s);
    double worst = 0;
    auto obs = [&](const State<double>& x) {
      worst = std::max(worst, (stepper.scene().spatial_momentum(x) - pi0).norm() / pi0.norm());
    };
    REQUIRE(integrate_sampled(stepper, s, 8.0, 0.5, ctrl, FixedSteps<double>{h}, obs).ok());
    if (pi_err) *pi_err = worst;
    return s;
  };
  const Sc scene(rw.hub_body(J), rw);
  const State<double> ref = run(ComposedStepper<SimoKappa, Sc>(SimoKappa{}, scene, 6), 0.5 / 64);
  for (const int p : {2, 4}) {
    auto stepper_at = [&] { return ComposedStepper<LGVI, Sc>(LGVI{}, scene, p); };
    double pi_err = 0;
    const double e1 = (run(stepper_at(), 0.5 / 8, &pi_err).rotation.matrix() - ref.rotation.matrix()).norm();
    const double e2 = (run(stepper_at(), 0.5 / 16).rotation.matrix() - ref.rotation.matrix()).norm();
    const double order = std::log2(e1 / e2);
    INFO("LGVI, order " << p << ": errors " << e1 << " -> " << e2 << ", measured order " << order << ", pi " << pi_err);
    CHECK(std::abs(order - p) <= 0.3);
    CHECK(pi_err <= 1e-13);  // round-off's walk over 64–256 steps
  }
  // Symmetric with wheels: a step of h and one of −h from its end return to the start (the
  // wheels' hold is a linear law of t, read at each step's own mid time).
  {
    Stepper<LGVI, Sc> stepper(LGVI{}, scene);
    State<double> s0;
    s0.rotation = SO3d::exp(Vec3(0.3, -0.2, 0.5));
    s0.omega = Vec3(0.5, -1.0, 2.0);
    auto& w = stepper.scene().template effect<Wheels>();
    w.start(0.0, s0.omega);
    WheelVector u(4);
    u << 0.3, -0.2, 0.4, 0.1;
    w.hold(0.0, u);
    State<double> s1 = s0, s2;
    REQUIRE(stepper.step(s1, 0.05).ok());
    s2 = s1;
    REQUIRE(stepper.step(s2, -0.05).ok());
    const double back = (s2.rotation.matrix() - s0.rotation.matrix()).norm() + (s2.omega - s0.omega).norm();
    INFO("LGVI with wheels, h then -h: " << back);
    CHECK(back <= 1e-14);
    CHECK((s1.omega - s0.omega).norm() > 1e-3);  // the step did move
  }
  // π to a few ε over 10⁵ steps under random held commands: "wheels: total momentum …" above.
}

TEST_CASE("wheels: saturation clips u and stops a wheel at its speed limit", "[control]") {
  Wheels rw;
  rw.add_wheel({.axis = Vec3::UnitX(), .inertia = 0.1, .speed0 = 0, .max_torque = 0.2, .max_speed = 100});
  rw.add_wheel({.axis = Vec3::UnitY(), .inertia = 0.1, .speed0 = 0, .max_torque = 0.2, .max_speed = 100});
  WheelVector u(2), w(2);
  u << 0.5, -0.1;
  w << 0, 0;
  CHECK(rw.saturate(u, w)(0) == 0.2);
  CHECK(rw.saturate(u, w)(1) == -0.1);
  w << 100, -150;  // both at or past their limit
  u << 0.1, 0.1;
  CHECK(rw.saturate(u, w)(0) == 0.0);   // would speed it up: cut
  CHECK(rw.saturate(u, w)(1) == 0.1);   // slows it down: allowed
  u << -0.1, -0.1;
  CHECK(rw.saturate(u, w)(0) == -0.1);
  CHECK(rw.saturate(u, w)(1) == 0.0);
}

TEST_CASE("wheels: bad input is refused naming the field", "[control]") {
  Wheels rw;
  CHECK_THROWS_WITH(rw.add_wheel({.axis = Vec3::Zero()}), Catch::Contains("axis"));
  CHECK_THROWS_WITH(rw.add_wheel({.axis = Vec3(NAN, 0, 1)}), Catch::Contains("axis"));
  CHECK_THROWS_WITH(rw.add_wheel({.inertia = 0}), Catch::Contains("Js"));
  CHECK_THROWS_WITH(rw.add_wheel({.inertia = -1}), Catch::Contains("Js"));
  CHECK_THROWS_WITH(rw.add_wheel({.speed0 = INFINITY}), Catch::Contains("speed0"));
  CHECK_THROWS_WITH(rw.add_wheel({.max_torque = 0}), Catch::Contains("max_torque"));
  CHECK(rw.size() == 0);
  rw.add_wheel({.axis = Vec3::UnitZ(), .inertia = 5});
  CHECK_THROWS_WITH(rw.hub_body(Mat3(Vec3(10, 10, 4).asDiagonal())), Catch::Contains("positive definite"));
}

// Zero-order hold: the controller is called exactly at t_k = t_0 + kT (k = 0 … N−1), and the
// command it returns at t_k is the one the wheels hold over [t_k, t_{k+1}).
TEST_CASE("sampled: the controller is called at the samples and its command held", "[control]") {
  Wheels rw = four_wheels(10.0);
  using Sc = Scene<double, Wheels>;
  Stepper<SimoKappa, Sc> stepper(SimoKappa{}, Sc(rw.hub_body(Vec3(900, 800, 600).asDiagonal()), rw));
  State<double> s;
  s.time = 1.0;
  s.omega = Vec3(0.01, 0.02, 0.03);
  stepper.scene().effect<Wheels>().start(s.time, s.omega);
  Schedule ctrl{[](double t) { return WheelVector::Constant(4, std::floor(t * 10 + 0.5) / 100); }, {}};
  std::vector<std::pair<double, double>> held;  // (t, u_0 held from t)
  auto obs = [&](const State<double>& x) { held.emplace_back(x.time, stepper.scene().effect<Wheels>().torques()(0)); };
  const auto sum = integrate_sampled(stepper, s, 3.05, 0.25, ctrl, FixedSteps<double>{0.05}, obs);
  REQUIRE(sum.ok());
  REQUIRE(ctrl.calls.size() == 9);  // t_k = 1, 1.25, …, 3 (3.05 ends inside the last hold)
  for (std::size_t k = 0; k < ctrl.calls.size(); ++k) CHECK(ctrl.calls[k] == 1.0 + 0.25 * static_cast<double>(k));
  CHECK(s.time == 3.05);
  // Every grid point once, in order; the command at a row is the one held from it on.
  REQUIRE(held.size() == 42);
  for (std::size_t i = 1; i < held.size(); ++i) CHECK(held[i].first > held[i - 1].first);
  for (const auto& [t, u0] : held) {
    const double t_k = 1.0 + 0.25 * std::floor((t - 1.0) / 0.25 + 1e-9);
    CHECK(u0 == Approx(std::floor(t_k * 10 + 0.5) / 100).margin(1e-15));
  }
}

// A command that cannot be held stops the run at its sample, naming it and t_k, with the
// state, the wheels and the controller's memory as they were.
TEST_CASE("sampled: bad commands and bad options", "[control]") {
  Wheels rw = four_wheels();
  using Sc = Scene<double, Wheels>;
  Stepper<SimoKappa, Sc> stepper(SimoKappa{}, Sc(rw.hub_body(Vec3(900, 800, 600).asDiagonal()), rw));
  State<double> s;
  s.omega = Vec3(0.01, 0.02, 0.03);
  stepper.scene().effect<Wheels>().start(0, s.omega);
  Schedule ctrl{[](double t) { return WheelVector::Constant(4, t < 0.95 ? 0.1 : NAN); }, {}};
  const auto sum = integrate_sampled(stepper, s, 3.0, 0.5, ctrl, FixedSteps<double>{0.1});
  CHECK_FALSE(sum.ok());
  CHECK_THAT(sum.reason(), Catch::Contains("non-finite command wheel_torques") && Catch::Contains("t = 1"));
  CHECK(s.time == 1.0);
  CHECK(sum.samples == 2);
  CHECK(ctrl.calls.size() == 2);  // the refused call's copy was dropped: its memory is as before
  CHECK(stepper.scene().effect<Wheels>().hold_time() == 0.5);
  CHECK(stepper.scene().effect<Wheels>().torques()(0) == 0.1);

  auto wrong_count = [](const Sample<double>&) {
    Command<double> c;
    c.wheel_torques = WheelVector::Zero(3);
    return c;
  };
  CHECK_THAT(integrate_sampled(stepper, s, 3.0, 0.5, wrong_count, FixedSteps<double>{0.1}).reason(),
             Catch::Contains("3 entries for 4 wheels"));
  auto torque_cmd = [](const Sample<double>&) {
    Command<double> c;
    c.body_torque = Vec3(1, 0, 0);
    return c;
  };
  CHECK_THAT(integrate_sampled(stepper, s, 3.0, 0.5, torque_cmd, FixedSteps<double>{0.1}).reason(),
             Catch::Contains("no held body torque"));
  CHECK_THROWS_WITH(integrate_sampled(stepper, s, 3.0, 0.0, torque_cmd, FixedSteps<double>{0.1}),
                    Catch::Contains("control period"));
  CHECK_THROWS_WITH(integrate_sampled(stepper, s, 3.0, NAN, torque_cmd, FixedSteps<double>{0.1}),
                    Catch::Contains("control period"));
  CHECK(s.time == 1.0);
}

// A failed step stops the run at the last accepted state; the wheels' hold still gives h_i
// at that time, and the controller's memory is that of the last sample.
TEST_CASE("sampled: a failed step keeps state, wheels and controller memory", "[control]") {
  Wheels rw = four_wheels();
  using Sc = Scene<double, Wheels>;
  Stepper<SimoKappa, Sc> stepper(SimoKappa{}, Sc(rw.hub_body(Vec3(9, 8, 6).asDiagonal()), rw));
  stepper.options().max_iterations = 2;  // a fast spin at a long step: Newton cannot settle
  State<double> s;
  s.omega = Vec3(3, -4, 5);
  stepper.scene().effect<Wheels>().start(0, s.omega);
  Schedule ctrl{[](double) { return WheelVector::Constant(4, 0.2); }, {}};
  const State<double> before = s;
  const Vec3 pi0 = stepper.scene().spatial_momentum(s);
  IntegrateOptions no_recovery;
  no_recovery.max_halvings = 0;
  const auto sum = integrate_sampled(stepper, s, 10.0, 1.0, ctrl, FixedSteps<double>{1.0, no_recovery});
  REQUIRE_FALSE(sum.ok());
  CHECK(sum.status != StepStatus::ok);
  CHECK(s.time == before.time);
  CHECK(s.omega == before.omega);
  CHECK(s.rotation.unit_quaternion().coeffs() == before.rotation.unit_quaternion().coeffs());
  CHECK(ctrl.calls.size() == 1);
  CHECK(stepper.scene().effect<Wheels>().hold_time() == 0.0);
  CHECK((stepper.scene().spatial_momentum(s) - pi0).norm() == 0.0);
}

// The spacecraft of the adaptive-hold cases: four wheels on a diag(900, 800, 600) body,
// Simo-kappa composed to order 4; start() gives Omega0 = (0.05, -0.1, 0.2) at t = 0 and
// starts the wheels' hold there.
struct AdaptiveHoldCase {
  using Sc = Scene<double, Wheels>;
  Wheels rw = four_wheels();
  ComposedStepper<SimoKappa, Sc> stepper{SimoKappa{}, Sc(rw.hub_body(Vec3(900, 800, 600).asDiagonal()), rw), 4};
  State<double> start() {
    State<double> s;
    s.omega = Vec3(0.05, -0.1, 0.2);
    stepper.scene().effect<Wheels>().start(0, s.omega);
    return s;
  }
};

// Adaptive steps between samples land on every sample; π stays exact.
TEST_CASE("sampled: adaptive steps between the samples", "[control]") {
  AdaptiveHoldCase run;
  auto& stepper = run.stepper;
  State<double> s = run.start();
  const Vec3 pi0 = stepper.scene().spatial_momentum(s);
  std::vector<double> sample_times;
  auto ctrl = [&](const Sample<double>& x) {
    sample_times.push_back(x.time);
    Command<double> c;
    c.wheel_torques = WheelVector::Constant(4, 0.2 * std::cos(x.time));
    return c;
  };
  AdaptiveOptions<double> opt;
  opt.rtol = 1e-10;
  opt.atol = 1e-10;
  const auto sum = integrate_sampled(stepper, s, 10.0, 0.5, ctrl, AdaptiveSteps<double>{opt});
  REQUIRE(sum.ok());
  CHECK(s.time == 10.0);
  CHECK(sample_times.size() == 20);
  CHECK((stepper.scene().spatial_momentum(s) - pi0).norm() / pi0.norm() <= 1e-14);
  // The same run at fixed small steps agrees to the tolerance's scale.
  AdaptiveHoldCase fixed;
  State<double> f = fixed.start();
  REQUIRE(integrate_sampled(fixed.stepper, f, 10.0, 0.5, ctrl, FixedSteps<double>{0.01}).ok());
  CHECK((f.rotation.matrix() - s.rotation.matrix()).norm() <= 1e-8);
}

// An adaptive hold stopped by max_steps (its run failed with no step failure) stops the sampled
// run and says so: found by the fuzzer, which saw ok() at t = 1e-6 of t_end = 8.1.
// A hold whose step falls below the time resolution (t0 = 1e15: ulp(t) = 0.125 s) stops the
// run there with SciPy's message, not "Too many steps." (which it read before).
TEST_CASE("sampled: an adaptive hold whose step falls below the time resolution says so", "[control]") {
  AdaptiveHoldCase run;
  auto& stepper = run.stepper;
  State<double> s = run.start();
  s.time = 1e15;
  stepper.scene().effect<Wheels>().start(s.time, s.omega);
  auto ctrl = [](const Sample<double>&) {
    Command<double> c;
    c.wheel_torques = WheelVector::Constant(4, 0.2);
    return c;
  };
  AdaptiveOptions<double> opt;
  opt.rtol = opt.atol = 1e-10;
  const auto sum = integrate_sampled(stepper, s, 1e15 + 100.0, 10.0, ctrl, AdaptiveSteps<double>{opt});
  INFO("t = " << s.time << ", steps " << sum.steps << ", reason " << sum.reason());
  CHECK_FALSE(sum.ok());
  CHECK(sum.step_too_small);
  CHECK_FALSE(sum.too_many_steps);
  CHECK(sum.status == StepStatus::ok);  // no step failed
  CHECK(sum.reason() == "Required step size is less than spacing between numbers.");
  CHECK(s.time == 1e15);
}

TEST_CASE("sampled: an adaptive hold stopped by max_steps is not ok (Too many steps., time short of t_end)", "[control]") {
  AdaptiveHoldCase run;
  auto& stepper = run.stepper;
  State<double> s = run.start();
  int calls = 0;
  auto ctrl = [&](const Sample<double>&) {
    ++calls;
    Command<double> c;
    c.wheel_torques = WheelVector::Constant(4, 0.2);
    return c;
  };
  AdaptiveOptions<double> opt;
  opt.rtol = 1e-10;
  opt.atol = 1e-10;
  opt.max_steps = 2;  // a hold of 0.5 at 1e-10 takes more (the test above: ~10 a hold)
  const auto sum = integrate_sampled(stepper, s, 10.0, 0.5, ctrl, AdaptiveSteps<double>{opt});
  INFO("t = " << s.time << ", steps " << sum.steps << ", reason " << sum.reason());
  CHECK_FALSE(sum.ok());
  CHECK(sum.too_many_steps);
  CHECK(sum.status == StepStatus::ok);  // no step failed
  CHECK(sum.reason() == "Too many steps.");
  CHECK(s.time > 0.0);
  CHECK(s.time < 0.5);  // stopped inside the first hold
  CHECK(sum.time == s.time);
  CHECK(calls == 1);
  // The same run with room for its steps reaches t_end.
  State<double> r = run.start();
  opt.max_steps = 10000;
  const auto whole = integrate_sampled(stepper, r, 10.0, 0.5, ctrl, AdaptiveSteps<double>{opt});
  CHECK(whole.ok());
  CHECK_FALSE(whole.too_many_steps);
  CHECK(r.time == 10.0);
}

// ---- torque laws --------------------------------------------------------------------

namespace {
/// A law of everything: attitude, rate and time, in body axes.
struct MixedLaw {
  template <class Lam, class Om>
  auto operator()(double t, const Lam& Lambda, const Om& omega) const {
    using T = typename Om::Scalar;
    const Eigen::Matrix<T, 3, 1> up = Lambda.transpose() * Eigen::Matrix<T, 3, 1>(T(0), T(0), T(1));
    Eigen::Matrix<T, 3, 1> tau = -0.3 * omega + up.cross(Eigen::Matrix<T, 3, 1>(T(1), T(0.5), T(-2))) * (1 + 0.1 * t);
    tau(0) += omega(1) * omega(2) * 0.2 + up(0) * up(2);
    return tau;
  }
};
/// The same law with its Jacobians by hand (body axes: D_w for Λ exp(ŵ), D_Ω).
struct MixedLawByHand : MixedLaw {
  void jacobians(double t, const Mat3& Lambda, const Vec3& omega, Mat3& Dw, Mat3& Dv) const {
    const Vec3 up = Lambda.transpose() * Vec3::UnitZ();
    const Vec3 a(1, 0.5, -2);
    // up(w) = exp(−ŵ) up ≈ up + up × w: ∂up/∂w = ûp
    const Mat3 dup = SO3d::hat(up);
    Dw = -SO3d::hat(a) * dup * (1 + 0.1 * t);
    Dw.row(0) += (up(2) * dup.row(0) + up(0) * dup.row(2));
    Dv = -0.3 * Mat3::Identity();
    Dv(0, 1) += omega(2) * 0.2;
    Dv(0, 2) += omega(1) * 0.2;
  }
};
}  // namespace

namespace {
/// A law's frame-n Jacobians at a mid configuration R and rate w against central differences
/// of its torque: ∂/∂w along Λ_n R exp(ŵ), and ∂/∂Ω_m [W8].
template <class Law, class Cache>
void check_jacobians(const Law& law, const Cache& c) {
  const Mat3 R = SO3d::exp(Vec3(-0.2, 0.3, 0.1)).matrix();
  const Vec3 w(0.3, -1.2, 2.0);
  const Mat3 D_rot = law.torque_jacobian_rotation(c, R, w);
  const Mat3 D_om = law.torque_jacobian_omega(c, R, w);
  const double d = 1e-6;
  Mat3 fd_rot, fd_om;
  for (int k = 0; k < 3; ++k) {
    const Vec3 e = d * Vec3::Unit(k);
    fd_rot.col(k) = (law.torque(c, R * SO3d::exp(e).matrix(), w) - law.torque(c, R * SO3d::exp(-e).matrix(), w)) / (2 * d);
    fd_om.col(k) = (law.torque(c, R, w + e) - law.torque(c, R, w - e)) / (2 * d);
  }
  INFO("rotation: " << (D_rot - fd_rot).norm() << " of " << D_rot.norm() << ", omega: " << (D_om - fd_om).norm()
                    << " of " << D_om.norm());
  CHECK((D_rot - fd_rot).norm() <= 1e-8 * D_rot.norm());
  CHECK((D_om - fd_om).norm() <= 1e-8 * D_om.norm());
}
}  // namespace

TEMPLATE_TEST_CASE("torque law: automatic Jacobians against central differences", "[control]",
                   (TorqueLaw<double, MixedLaw, Axes::body>), (TorqueLaw<double, MixedLaw, Axes::space>),
                   (TorqueLaw<double, MixedLawByHand, Axes::body>)) {
  const TestType law{typename std::decay_t<decltype(std::declval<TestType>().function())>{}};
  const Mat3 Lambda_n = SO3d::exp(Vec3(0.4, -0.7, 1.1)).matrix();
  const auto c = law.cache(Lambda_n, 0.7);
  check_jacobians(law, c);
}

// With a torque law, Simo-κ's discrete power balance H_{n+1} − H_n = h Ω_m·τ_m is exact
// [W7], and Newton converges quadratically with the automatic tangent (few iterations).
TEST_CASE("torque law: exact power balance in Simo-kappa under gravity", "[control]") {
  auto law = torque_law<double>(MixedLaw{});
  using Sc = Scene<double, UniformGravity<double>, decltype(law)>;
  Sc scene(RigidBody<double>(Vec3(5, 4, 2)), UniformGravity<double>(20.0, Vec3::UnitZ(), Vec3::UnitZ()), law);
  Stepper<SimoKappa, Sc> stepper(SimoKappa{}, scene);
  State<double> s;
  s.rotation = SO3d::exp(Vec3(0.3, 0.1, 0));
  s.omega = Vec3(1, -2, 8);
  double worst = 0;
  const double h = 0.005;
  std::int64_t iterations = 0;
  for (int k = 0; k < 2000; ++k) {
    const State<double> a = s;
    const auto rep = stepper.step(s, h);
    REQUIRE(rep.ok());
    iterations += rep.iterations;
    // τ_m in the body frame of the mid configuration: Θ = h Ω_m, Λ_{n+½} = Λ_n exp(Θ̂/2).
    const Vec3 omega_m = (a.omega + s.omega) / 2;
    const Mat3 L_mid = a.rotation.matrix() * SO3d::exp(h * omega_m / 2).matrix();
    const Vec3 tau = MixedLaw{}(a.time + h / 2, L_mid, omega_m);
    const double dH = scene.energy(s) - scene.energy(a) - h * omega_m.dot(tau);
    worst = std::max(worst, std::abs(dH) / std::abs(scene.energy(s)));
  }
  INFO("worst |dH - h W|/H = " << worst << ", iterations " << iterations);
  CHECK(worst <= 1e-14);
  CHECK(iterations <= 2000 * 4);
}

namespace {
/// Continuous momentum unloading from the wheels' speeds (a law of their state [W15]): a body
/// torque −k Σ J_s,i Ω_i g_i that bleeds the wheels' momentum relative to the body, plus a
/// little of the attitude and rate so that both Jacobians have something to find.
struct Unloading {
  Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, 8> G;
  Wheels::WheelVector Js;
  double k = 0.05;
  template <class Lam, class Om, class Sp>
  auto operator()(double, const Lam& Lambda, const Om& omega, const Sp& speeds) const {
    using T = typename Om::Scalar;
    Eigen::Matrix<T, 3, 1> tau = 0.01 * omega.cross(Lambda.transpose().col(2));
    for (int i = 0; i < speeds.size(); ++i) tau -= (k * Js(i)) * speeds(i) * G.col(i).template cast<T>();
    return tau;
  }
};
/// The same law written by hand as a law of (t, Λ, Ω), from the wheels' hold: h_i(t) known.
struct UnloadingByHand {
  Unloading law;
  Wheels hold;  // a copy of the scene's wheels with the same hold
  template <class Lam, class Om>
  auto operator()(double t, const Lam& Lambda, const Om& omega) const {
    using T = typename Om::Scalar;
    return law(t, Lambda, omega, hold.speeds(t, Eigen::Matrix<T, 3, 1>(omega)));
  }
};
}  // namespace

// A torque law of the wheels' state [W15]: its AutoDiff Jacobians (∂/∂Ω through the speeds'
// −g_i·Ω) against central differences, and a run that equals the same law written by hand
// from the hold's h_i(t), on Simo-κ and RK4.
TEST_CASE("torque law of the wheels' state: Jacobians, and the same run as the law by hand", "[control]") {
  Wheels rw = four_wheels();
  const Mat3 J = (Mat3() << 900, 20, -10, 20, 800, 15, -10, 15, 600).finished();
  const Vec3 omega0(0.05, -0.1, 0.2);
  rw.start(0.0, omega0);
  WheelVector u(4);
  u << 0.2, -0.1, 0.3, 0.05;
  rw.hold(0.0, u);  // one hold over the whole run: h_i(t) = h_i(0) + u_i t
  const Unloading unload{rw.axes(), rw.inertias()};
  auto law = wheel_torque_law<double>(unload);
  using Sc = Scene<double, Wheels, decltype(law)>;
  const Sc scene(rw.hub_body(J), rw, law);
  // Jacobians at a mid configuration and rate, the cache as the scene builds it.
  const Mat3 Lambda_n = SO3d::exp(Vec3(0.4, -0.7, 1.1)).matrix();
  const auto caches = scene.caches(Lambda_n, 0.7);
  const auto& c = std::get<1>(caches);
  const auto& l = scene.effect<decltype(law)>();
  check_jacobians(l, c);
  // Runs: the law of the wheels' state and the same law by hand, 2,000 steps of h = 0.01.
  auto by_hand = torque_law<double>(UnloadingByHand{unload, rw});
  using ScH = Scene<double, Wheels, decltype(by_hand)>;
  const ScH scene_h(rw.hub_body(J), rw, by_hand);
  State<double> s0;
  s0.rotation = SO3d::exp(Vec3(0.3, -0.2, 0.5));
  s0.omega = omega0;
  auto run = [&](auto stepper) {
    State<double> s = s0;
    for (int k = 0; k < 2000; ++k) REQUIRE(stepper.step(s, 0.01).ok());
    return s;
  };
  const State<double> a = run(Stepper<SimoKappa, Sc>(SimoKappa{}, scene)), b = run(Stepper<SimoKappa, ScH>(SimoKappa{}, scene_h));
  const State<double> a4 = run(Stepper<RK4, Sc>(RK4{}, scene)), b4 = run(Stepper<RK4, ScH>(RK4{}, scene_h));
  const double e = (a.rotation.matrix() - b.rotation.matrix()).norm() + (a.omega - b.omega).norm();
  const double e4 = (a4.rotation.matrix() - b4.rotation.matrix()).norm() + (a4.omega - b4.omega).norm();
  const double moved = (a.omega - run(Stepper<SimoKappa, Scene<double, Wheels>>(SimoKappa{}, Scene<double, Wheels>(rw.hub_body(J), rw))).omega).norm();
  INFO("Simo-kappa: law of the wheels vs by hand " << e << "; RK4 " << e4 << "; the law moved Omega by " << moved);
  CHECK(e <= 1e-12);
  CHECK(e4 <= 1e-12);
  CHECK(moved > 1e-3);  // the law acts: the comparison could fail
}

// ---- magnetorquers and the built-in controllers ----------------------------------------

TEST_CASE("magnetorquer: the dipole field and the torque m x B", "[control]") {
  const double pi = 3.14159265358979323846;
  CircularOrbit<double> orbit(6771e3, 51.6 * pi / 180, 0.3, 0.2);
  DipoleField<double> field(orbit);
  // |B| at 400 km lies between the dipole's equatorial and polar values B0 (R/r)^3 (1 .. 2).
  const double B0 = 1e-9 * Vec3(-1450.9, 4652.5, -29404.8).norm() * std::pow(6371.2e3 / 6771e3, 3);
  for (double t = 0; t < 6000; t += 97) {
    const double b = field.inertial(t).norm();
    CHECK(b >= B0 * 0.999);
    CHECK(b <= 2 * B0 * 1.001);
  }
  CHECK(orbit.normal().dot(orbit.radial(123.0)) == Approx(0).margin(1e-15));
  Magnetorquer<double> mtq(field, Vec3(0.2, 0.2, 0.2));
  mtq.dipole = Vec3(0.1, -0.05, 0.2);
  const Mat3 L = SO3d::exp(Vec3(0.2, 0.5, -0.3)).matrix();
  const auto c = mtq.cache(L, 50.0);
  const Mat3 R = SO3d::exp(Vec3(0.01, -0.02, 0.03)).matrix();
  // In frame n: R (m × (LR)ᵀB).
  const Vec3 direct = R * mtq.dipole.cross((L * R).transpose() * field.inertial(50.0));
  CHECK((mtq.torque(c, R, Vec3::Zero()) - direct).norm() <= 1e-15 * direct.norm() * 10);
  Mat3 fd;
  for (int k = 0; k < 3; ++k) {
    const Vec3 e = 1e-6 * Vec3::Unit(k);
    fd.col(k) = (mtq.torque(c, R * SO3d::exp(e).matrix(), Vec3::Zero()) -
                 mtq.torque(c, R * SO3d::exp(-e).matrix(), Vec3::Zero())) / 2e-6;
  }
  const Mat3 D = mtq.torque_jacobian_rotation(c, R, Vec3::Zero());
  CHECK((D - fd).norm() <= 1e-8 * D.norm());
  CHECK(mtq.saturate(Vec3(1, -1, 0.1)) == Vec3(0.2, -0.2, 0.1));
}

// [W16] B inside a hold from its Taylor expansion about the hold's start: the same field to
// round-off as four trigonometric calls, at the degree chosen by the span and out to the
// expansion's reach; beyond the reach (or without an expansion) B is evaluated afresh.
TEST_CASE("magnetorquer: the field from the hold's Taylor expansion", "[control]") {
  const double pi = 3.14159265358979323846;
  using Field = DipoleField<double>;
  const CircularOrbit<double> orbit(6771e3, 51.6 * pi / 180, 0.4, 0.1);
  const Field field(orbit, -29404.8, -1450.9, 4652.5, 0.7);
  using LD = long double;
  const DipoleField<LD> truth(CircularOrbit<LD>(6771e3L, LD(51.6) * LD(pi) / 180, LD(0.4), LD(0.1)), LD(-29404.8),
                              LD(-1450.9), LD(4652.5), LD(0.7));
  // The reach table: the first term left out, 2x^{D+1}/(D+1)!, is below 2^-56 at x_D, and
  // not far below (the table is rounded down by less than 1 %).
  LD factorial = 1;
  for (int D = 1; D <= Field::max_degree; ++D) {
    factorial *= D + 1;
    const LD term = 2 * std::pow(LD(Field::degree_reach[D]), D + 1) / factorial;
    INFO("degree " << D << ": first term left out " << static_cast<double>(term) << " of 2^-56");
    CHECK(term <= std::ldexp(LD(1), -56));
    CHECK(term >= LD(0.9) * std::ldexp(LD(1), -56));
  }
  const double w_max = 2 * orbit.rate() + Field::earth_rate;
  // The lowest degree that serves the span: a 4 Hz sample in low orbit needs degree 4.
  CHECK(field.expansion(0.0, 0.25).degree == 4);
  CHECK(field.expansion(0.0, -0.25).degree == 4);
  CHECK(field.expansion(0.0, 5.0).degree == 6);
  CHECK(field.expansion(0.0).degree == Field::max_degree);
  CHECK(field.expansion(0.0, 1e6).degree == Field::max_degree);
  double worst = 0, worst_direct = 0;
  int afresh = 0;
  for (const double t0 : {0.0, 1234.5, 55451.25, -800.0}) {
    for (const double span : {0.25, -0.25, 1.0, 5.0, 12.0, 0.0}) {
      const Field::Expansion e = field.expansion(t0, span);
      CHECK(e.reach >= std::abs(span));
      CHECK(e.reach == Approx(Field::degree_reach[e.degree] / w_max).epsilon(1e-15));
      if (e.degree > 1 && span != 0.0) CHECK(std::abs(span) * w_max > Field::degree_reach[e.degree - 1]);  // lowest
      for (const double frac : {1e-9, 0.01, 0.3, 0.7, 0.99, 1.0}) {
        for (const double sign : {1.0, -1.0}) {
          const double t = t0 + sign * frac * e.reach;
          const Vec3 exact = truth.inertial(LD(t)).cast<double>();
          // Both evaluations round the angles' arguments: ε(1 + |u| + |θ|) relative is their floor.
          const double floor = 2.2e-16 * (1 + std::abs(orbit.latitude(t)) + std::abs(0.7 + Field::earth_rate * t));
          worst = std::max(worst, (field.inertial(t, e) - exact).norm() / exact.norm() / floor);
          worst_direct = std::max(worst_direct, (field.inertial(t) - exact).norm() / exact.norm() / floor);
        }
      }
      // Beyond the reach: afresh, bit for bit.
      for (const double beyond : {1.001, 1.5, 40.0}) {
        const double t = t0 + beyond * e.reach;
        CHECK(field.inertial(t, e) == field.inertial(t));
        ++afresh;
      }
    }
  }
  INFO("worst error in units of the floor: by the expansion " << worst << ", afresh " << worst_direct);
  CHECK(worst <= 4);
  CHECK(worst_direct <= 4);
  CHECK(afresh == 72);
  // Without an expansion (a dipole set directly, not held) B is evaluated afresh: exactly inertial(t).
  CHECK(field.inertial(321.0, Field::Expansion{}) == field.inertial(321.0));
  // An orbit so fast that n^j/j! overflows (r = 1e-90 m): no polynomial, B afresh.
  const Field fast(CircularOrbit<double>(1e-90));
  const Field::Expansion ef = fast.expansion(0.0, 0.25);
  CHECK(ef.reach < 0);
  CHECK(detail::all_finite(fast.inertial(0.0)));
  CHECK(fast.inertial(0.0, ef) == fast.inertial(0.0));
  // A magnetorquer's hold keeps the expansion about the sample: its cache reads B from it.
  Magnetorquer<double> mtq(field);
  mtq.hold(100.0, Vec3(0.1, 0, 0));
  const Mat3 I = Mat3::Identity();
  CHECK((mtq.cache(I, 100.1).b - field.inertial(100.1)).norm() <= 8e-16 * field.inertial(100.1).norm());
  // The orbit's in-plane basis gives the same r̂ as [W9] written out.
  const double u = orbit.latitude(77.0), i = 51.6 * pi / 180, raan = 0.4;
  const Vec3 r(std::cos(u) * std::cos(raan) - std::sin(u) * std::cos(i) * std::sin(raan),
               std::cos(u) * std::sin(raan) + std::sin(u) * std::cos(i) * std::cos(raan), std::sin(u) * std::sin(i));
  CHECK((orbit.radial(77.0) - r).norm() <= 4e-16);
}

// [W16] Steps that follow the rate: each hold split into max(⌈T/h⌉, ⌈|Ω_k|T/θ⌉) equal steps,
// landing on every sample; a bad max_angle is refused before anything runs.
TEST_CASE("sampled: steps limited by the angle turned at the sample's rate", "[control]") {
  using Sc = FreeScene<double>;
  Stepper<Splitting, Sc> stepper(Splitting(SplittingMethod::strang), Sc(RigidBody<double>(Vec3(3, 2, 1))));
  auto none = [](const Sample<double>&) { return Command<double>{}; };
  const double T = 0.25;
  for (const double w : {0.01, 0.5, 2.0, 9.0}) {
    State<double> s;
    s.omega = Vec3(w, 0, 0);  // a steady spin about the major axis: |Ω| stays w
    const FixedSteps<double> between{T, {}, 0.1};
    const long expected = std::max(1L, static_cast<long>(std::ceil(w * T / 0.1)));
    CHECK(between.step_for(w, T) == Approx(T / static_cast<double>(expected)).epsilon(1e-15));
    std::vector<double> times;
    const auto sum = integrate_sampled(stepper, s, 2.0, T, none, between, [&](const State<double>& x) { times.push_back(x.time); });
    REQUIRE(sum.ok());
    INFO("|Omega| = " << w);
    CHECK(sum.steps == 8 * expected);
    CHECK(s.time == 2.0);
    for (int k = 0; k <= 8; ++k) CHECK(std::count(times.begin(), times.end(), k * T) == 1);  // every sample is a grid point
  }
  // h still bounds the step where the rate allows a longer one; backward runs divide |Δt|.
  CHECK(FixedSteps<double>{0.05, {}, 0.1}.step_for(0.01, 0.25) == Approx(0.05).epsilon(1e-15));
  CHECK(FixedSteps<double>{-0.25, {}, 0.1}.step_for(2.0, -0.25) == Approx(-0.05).epsilon(1e-15));
  CHECK(FixedSteps<double>{0.25, {}, 0.1}.step_for(2.0, -0.25) == 0.25);  // against the run: left to integrate() to refuse
  CHECK(FixedSteps<double>{0.25}.step_for(100.0, 0.25) == 0.25);  // max_angle 0: off
  State<double> s;
  s.omega = Vec3(1, 0, 0);
  CHECK_THROWS_WITH(integrate_sampled(stepper, s, 1.0, T, none, FixedSteps<double>{T, {}, -0.1}), Catch::Contains("max_angle"));
  CHECK_THROWS_WITH(integrate_sampled(stepper, s, 1.0, T, none, FixedSteps<double>{T, {}, NAN}), Catch::Contains("max_angle"));
  CHECK_THROWS_WITH(integrate_sampled(stepper, s, 1.0, T, none, FixedSteps<double>{T, {}, 0.1, -1}), Catch::Contains("max_steps"));
  CHECK(s.time == 0.0);

  // FixedSteps::max_steps: a body spun up by a held torque asks ever more steps a hold; the run
  // stops at the first sample whose hold would ask more than the limit, there, too_many_steps.
  using Torqued = Scene<double, HeldBodyTorque<double>>;
  Stepper<Splitting, Torqued> spun(Splitting(SplittingMethod::strang),
                                   Torqued(RigidBody<double>(Vec3(3, 2, 1)), held_body_torque<double>()));
  auto spin_up = [](const Sample<double>&) {
    Command<double> c;
    c.body_torque = Vec3(3, 0, 0);  // Ω_x grows by 1 rad/s each second
    return c;
  };
  for (const std::int64_t limit : {std::int64_t(0), std::int64_t(12)}) {
    State<double> x;
    x.omega = Vec3(1, 0, 0);
    std::vector<double> samples;
    const auto sum = integrate_sampled(spun, x, 5.0, T, spin_up, FixedSteps<double>{T, {}, 0.1, limit},
                                       [&](const State<double>& y) { samples.push_back(y.time); });
    INFO("max_steps " << limit << ": " << sum.reason() << " at t = " << x.time << ", |Omega| " << x.omega.norm());
    if (limit == 0) {  // no limit: to the end, 1 + 3·20 / 2 … steps a hold as Ω_x grows 1 → 6
      CHECK(sum.ok());
      CHECK(x.time == 5.0);
      CHECK(sum.steps > 12 * 20 / 2);
    } else {
      // |Ω_k| T / 0.1 > 12 from |Ω_k| > 4.8: the hold starting at t = 4.0 (Ω_x = 5) is refused.
      CHECK_FALSE(sum.ok());
      CHECK(sum.too_many_steps);
      CHECK(sum.reason() == "Too many steps.");
      CHECK(x.time == Approx(4.0).epsilon(1e-15));
      CHECK(x.omega.x() == Approx(5.0).epsilon(1e-12));
      CHECK(samples.back() == x.time);  // the sample was observed; nothing after it
    }
  }
}

TEST_CASE("mrp: conventions of Basilisk's mrpFeedback", "[control]") {
  const Vec3 sigma(0.1, 0.2, -0.3);
  const Mat3 Lambda = rotation_of_mrp(sigma);
  CHECK((Lambda.transpose() * Lambda - Mat3::Identity()).norm() <= 1e-15);
  CHECK((mrp_of_relative<double>(Lambda, Mat3::Identity()) - sigma).norm() <= 1e-15);
  // Schaub's [BN] ≈ I − 4σ̂ for small σ: the body turned by −4σ seen from N, i.e. Λ ≈ I + 4σ̂.
  const Vec3 small(1e-5, -2e-5, 3e-5);
  CHECK((rotation_of_mrp(small) - (Mat3::Identity() + 4 * SO3d::hat(small))).norm() <= 1e-7);
  // The first command of the scenario: u = (0.38, 0.40, −0.15) N m before clipping.
  Sample<double> smp;
  smp.state.rotation = SO3d::from_matrix(Lambda);
  smp.state.omega = Vec3(0.001, -0.01, 0.03);
  smp.wheel_axes = Mat3::Identity();
  MrpPd<double> pd{.K = 3.5, .P = 30};
  const Command<double> c = pd(smp);
  CHECK((c.wheel_torques - Vec3(0.38, 0.40, -0.15)).norm() <= 1e-15);
  // The shadow set: a rotation past π is measured the short way, |σ| ≤ 1.
  const Mat3 far = SO3d::exp(Vec3(0, 0, 3.5)).matrix();
  CHECK(mrp_of_relative<double>(far, Mat3::Identity()).norm() <= 1.0);
  CHECK(mrp_of_relative<double>(far, Mat3::Identity()).z() < 0);
}

// B-dot detumbling: the body rate falls by orders of magnitude (a 3U-like body).
TEST_CASE("bdot: detumbles a small satellite", "[control]") {
  const double pi = 3.14159265358979323846;
  CircularOrbit<double> orbit(6771e3, 51.6 * pi / 180);
  Magnetorquer<double> mtq(DipoleField<double>(orbit), Vec3::Constant(0.2));
  using Sc = Scene<double, Magnetorquer<double>>;
  Stepper<SimoKappa, Sc> stepper(SimoKappa{}, Sc(RigidBody<double>(Vec3(0.035, 0.035, 0.01)), mtq));
  State<double> s;
  s.omega = Vec3::Constant(10 * pi / 180);
  const double n = orbit.rate();
  BDot<double> bdot{.k = 2 * n * (1 + std::sin(51.6 * pi / 180)) * 0.01 / 3e-10};
  const double w0 = s.omega.norm();
  const auto sum = integrate_sampled(stepper, s, 3 * 2 * pi / n, 0.25, bdot, FixedSteps<double>{0.25});
  REQUIRE(sum.ok());
  INFO("|Omega| " << w0 << " -> " << s.omega.norm());
  CHECK(s.omega.norm() < 0.1 * w0);
  CHECK(bdot.have_last);
}

// The holds of the sampled driver start far from t = 0: span/h = (16.2 − 16.1)/0.02 is
// 5 + 7e-14, and integrate() must take 5 steps, not 5 and a vanishing sixth (which failed
// as a zero step before the remainder was measured in ulps of the times).
TEST_CASE("integrate: whole steps far from t = 0 end without a vanishing step", "[control]") {
  Stepper<SimoKappa, FreeScene<double>> stepper(SimoKappa{}, FreeScene<double>(RigidBody<double>(Vec3(3, 2, 1))));
  for (const double t0 : {16.1, 1000.3, 123456.7}) {
    State<double> s;
    s.time = t0;
    s.omega = Vec3(0.1, 0.2, 0.3);
    const double t1 = t0 + 0.1;
    const auto sum = integrate(stepper, s, t1, 0.02);
    INFO("t0 = " << t0);
    CHECK(sum.ok());
    CHECK(sum.steps == 5);
    CHECK(s.time == t1);
  }
}
