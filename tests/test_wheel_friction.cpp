// Viscous wheel friction (docs/theory.md [W17], docs/control.md): the exact flow of friction
// alone, split around each fixed step of the sampled driver. Closed forms on one axis, the
// energy sink on three, an independent reference for the order, π exact, the failure
// contract and the refusals.
#include <catch2/catch.hpp>

#include <cmath>
#include <tuple>
#include <vector>

#include "support/trompo_test.hpp"

using namespace trompo;
using trompo_test::Mat3;
using trompo_test::rpm;
using trompo_test::Vec3;
using trompo_test::WheelVector;
using trompo_test::Wheels;

namespace {

/// A controller that holds u = `u_of(t)` on every wheel (one value per wheel).
struct HoldEach {
  WheelVector (*u_of)(double);
  Command<double> operator()(const Sample<double>& s) const {
    Command<double> c;
    c.wheel_torques = u_of(s.time);
    return c;
  }
};

/// Three wheels on the body axes and a skew one, each with its own friction.
Wheels four_wheels_with_friction() {
  Wheels rw;
  rw.add_wheel({.axis = Vec3::UnitX(), .inertia = 0.08, .speed0 = 100 * rpm, .max_torque = 0.5, .friction = 0.02});
  rw.add_wheel({.axis = Vec3::UnitY(), .inertia = 0.08, .speed0 = -200 * rpm, .max_torque = 0.5, .friction = 0.01});
  rw.add_wheel({.axis = Vec3::UnitZ(), .inertia = 0.08, .speed0 = 300 * rpm, .max_torque = 0.5});
  rw.add_wheel({.axis = Vec3(1, 1, 1), .inertia = 0.05, .speed0 = 50 * rpm, .max_torque = 0.5, .friction = 0.03});
  return rw;
}

WheelVector four_commands(double t) {
  WheelVector u(4);
  u << 0.2 * std::sin(t), -0.1 * std::cos(0.7 * t), 0.15, 0.1 * std::sin(1.3 * t + 1);
  return u;
}

/// Simo-κ on four_wheels_with_friction()'s hub of a skew spacecraft, `s` set to its start,
/// the wheels started there with four_commands(0) held from t = 0 and their friction's flow
/// prepared: one hold of the adaptive driver, stepped by hand or by friction_split_hold.
using FrictionScene = Scene<double, Wheels>;
Stepper<SimoKappa, FrictionScene> held_four_wheels(State<double>& s) {
  const Mat3 J = (Mat3() << 9, 0.2, -0.1, 0.2, 8, 0.15, -0.1, 0.15, 6).finished();
  Stepper<SimoKappa, FrictionScene> stepper(SimoKappa{},
                                            FrictionScene(four_wheels_with_friction().hub_body(J), four_wheels_with_friction()));
  Wheels& rw = stepper.scene().effect<Wheels>();
  s.rotation = SO3d::exp(Vec3(0.1, -0.3, 0.2));
  s.omega = Vec3(0.3, -0.2, 0.5);
  rw.start(0.0, s.omega);
  rw.hold(0.0, four_commands(0.0));
  rw.prepare_friction(stepper.scene().body().inertia_inverse());
  return stepper;
}

// One axis: a hub diag(2, 2, Jh) spinning about z with a wheel on z. Π_z = Jh ω + h is
// constant (Ω × Π = 0), and ḣ = u − c(h/J_s − ω) with ω = (Π − h)/Jh is linear:
// h(t) = h∞ + (h0 − h∞) e^{−k(t − t_k)}, k = c(1/J_s + 1/Jh), h∞ = (u + cΠ/Jh)/k.
struct OneAxis {
  double Js = 0.1, Jh = 3.0, c = 0.05, w0 = 0.4, W0 = 50.0, T = 0.5, t_end = 10.0;
  static WheelVector u_of(double t) { return WheelVector::Constant(1, std::fmod(t + 1e-9, 1.0) < 0.5 ? 0.3 : -0.2); }
  static WheelVector zero(double) { return WheelVector::Zero(1); }

  Wheels wheels() const {
    Wheels rw;
    rw.add_wheel({.axis = Vec3::UnitZ(), .inertia = Js, .speed0 = W0, .friction = c});
    return rw;
  }
  /// The closed form at t_end: ω_z and the wheel's absolute momentum h.
  std::pair<double, double> exact(bool driven) const {
    double h = Js * (W0 + w0);
    const double Pi = Jh * w0 + h, k = c * (1 / Js + 1 / Jh);
    for (double t = 0; t < t_end - 1e-9; t += T) {
      const double u = driven ? u_of(t)(0) : 0.0;
      const double hinf = (u + c * Pi / Jh) / k;
      h = hinf + (h - hinf) * std::exp(-k * T);
    }
    return {(Pi - h) / Jh, h};
  }
  template <class Scheme>
  std::pair<double, double> run(double dt, bool driven) const {
    const Wheels rw = wheels();
    using Sc = Scene<double, Wheels>;
    Stepper<Scheme, Sc> stepper(Scheme{}, Sc(rw.hub_body(Vec3(2 + Js, 2 + Js, Jh + Js).asDiagonal()), rw));
    State<double> s;
    s.omega = Vec3(0, 0, w0);
    stepper.scene().template effect<Wheels>().start(0.0, s.omega);
    HoldEach ctrl{driven ? &u_of : &zero};
    const SampledSummary<double> sum = integrate_sampled(stepper, s, t_end, T, ctrl, FixedSteps<double>{dt});
    REQUIRE(sum.ok());
    REQUIRE(s.time == t_end);
    CHECK(s.omega.head<2>().norm() <= 1e-14);
    return {s.omega.z(), stepper.scene().template effect<Wheels>().momenta(s.time)(0)};
  }
};

}  // namespace

// Without a motor torque the friction flow and the body's spin about the same axis commute:
// the split run is the closed form to round-off, at any step. With held motor torques the
// split is Strang's, whose error falls as Δt² (measured from a sweep).
TEMPLATE_TEST_CASE("friction: the closed form on one axis, exact undriven and of order 2 driven", "[control][friction]",
                   SimoKappa, RK4, Splitting, LGVI) {
  const OneAxis c;
  const auto [w_exact, h_exact] = c.exact(false);
  const auto [w, h] = c.template run<TestType>(0.1, false);
  INFO("undriven: omega_z " << w << " vs " << w_exact << ", h " << h << " vs " << h_exact);
  CHECK(std::abs(w - w_exact) <= 1e-14);
  CHECK(std::abs(h - h_exact) <= 1e-13 * std::abs(h_exact));
  // The wheel slowed relative to the hub: friction acted (h moved by a few units).
  CHECK(std::abs(h - c.Js * (c.W0 + c.w0)) > 0.1);

  const auto [wd_exact, hd_exact] = c.exact(true);
  std::vector<double> err;
  for (const double dt : {0.1, 0.05, 0.025}) {
    const auto [wd, hd] = c.template run<TestType>(dt, true);
    err.push_back(std::abs(hd - hd_exact));
    CHECK(std::abs(c.Jh * wd + hd - (c.Jh * wd_exact + hd_exact)) <= 1e-13);  // Π_z kept
  }
  const double p1 = std::log2(err[0] / err[1]), p2 = std::log2(err[1] / err[2]);
  INFO("driven: |h - h_exact| = " << err[0] << ", " << err[1] << ", " << err[2] << "; orders " << p1 << ", " << p2);
  CHECK(err[0] > 1e-9);  // the split's error is real at this step, and falls as:
  CHECK(std::abs(p1 - 2) <= 0.05);
  CHECK(std::abs(p2 - 2) <= 0.05);
}

// friction_flow alone: Λ and Π stay, the kinetic energy [W3] falls by exactly the dissipation
// it returns, and its backward flow undoes it.
TEST_CASE("friction: the flow keeps Pi and dissipates what it says", "[control][friction]") {
  Wheels rw = four_wheels_with_friction();
  const Mat3 J = (Mat3() << 9, 0.2, -0.1, 0.2, 8, 0.15, -0.1, 0.15, 6).finished();
  using Sc = Scene<double, Wheels>;
  Sc sc(rw.hub_body(J), rw);
  Wheels& w = sc.effect<Wheels>();
  State<double> s;
  s.time = 3.0;
  s.omega = Vec3(0.3, -0.2, 0.5);
  w.start(0.0, Vec3(0.3, -0.2, 0.5));
  w.hold(1.0, four_commands(1.0));
  REQUIRE_THROWS_WITH(w.friction_flow(s.time, 0.1, s.omega), Catch::Contains("prepare_friction"));
  w.prepare_friction(sc.body().inertia_inverse());
  const Wheels fresh = w;  // the hold before any flow
  const Vec3 Pi0 = sc.momentum(s.omega, s.time);
  const double T0 = sc.energy(s);
  const double P0 = w.friction_power(s.time, s.omega);
  const State<double> before = s;
  // A short flow dissipates P0·τ to first order.
  const double tiny = w.friction_flow(s.time, 1e-6, s.omega);
  CHECK(std::abs(tiny - P0 * 1e-6) <= 1e-4 * P0 * 1e-6);
  s = before;
  w = fresh;
  const double dissipated = w.friction_flow(s.time, 2.0, s.omega);
  CHECK(dissipated > 0);
  CHECK(w.hold_time() == s.time);
  CHECK((sc.momentum(s.omega, s.time) - Pi0).norm() <= 4e-16 * Pi0.norm() * 4);
  INFO("T0 = " << T0 << ", dissipated = " << dissipated << ", T1 = " << sc.energy(s));
  CHECK(std::abs(sc.energy(s) - (T0 - dissipated)) <= 4e-15 * T0);
  // The speeds of the wheel without friction's neighbours moved; its own h did not.
  CHECK(w.momenta(s.time)(2) == fresh.momenta(s.time)(2));
  // Backward by the same time: back to the start, to round-off.
  const double regained = w.friction_flow(s.time, -2.0, s.omega);
  CHECK(std::abs(regained + dissipated) <= 1e-13 * dissipated);
  CHECK((s.omega - before.omega).norm() <= 1e-14 * before.omega.norm());
  CHECK((w.momenta(s.time) - fresh.momenta(s.time)).norm() <= 1e-13 * fresh.momenta(s.time).norm());
}

// The split step's energy balance: over F(Δ/2) ∘ Φ_Δ ∘ F(Δ/2) with Simo-κ as Φ, H changes by
// Φ's motor work hΣu_iΩ_{i,m} [W4] less the two flows' exact dissipation, to round-off.
TEST_CASE("friction: the split step's energy balance is exact", "[control][friction]") {
  Wheels rw = four_wheels_with_friction();
  const Mat3 J = (Mat3() << 9, 0.2, -0.1, 0.2, 8, 0.15, -0.1, 0.15, 6).finished();
  using Sc = Scene<double, Wheels>;
  Stepper<SimoKappa, Sc> stepper(SimoKappa{}, Sc(rw.hub_body(J), rw));
  Wheels& w = stepper.scene().effect<Wheels>();
  State<double> s;
  s.omega = Vec3(0.3, -0.2, 0.5);
  w.start(0.0, s.omega);
  w.prepare_friction(stepper.scene().body().inertia_inverse());
  const double dt = 0.05;
  double worst = 0, dissipated = 0;
  for (int n = 0; n < 400; ++n) {
    if (n % 10 == 0) w.hold(s.time, four_commands(s.time));
    const double H0 = stepper.scene().energy(s);
    const double d1 = w.friction_flow(s.time, dt / 2, s.omega);
    const WheelVector xa = w.speeds(s.time, s.omega);
    REQUIRE(stepper.step(s, dt).ok());
    const WheelVector xb = w.speeds(s.time, s.omega);
    const double work = dt * w.torques().dot((xa + xb) / 2);
    const double d2 = w.friction_flow(s.time, dt / 2, s.omega);
    const double H1 = stepper.scene().energy(s);
    worst = std::max(worst, std::abs(H1 - (H0 - d1 + work - d2)) / H1);
    dissipated += d1 + d2;
  }
  INFO("worst balance residual " << worst << ", dissipated " << dissipated << " of H = " << stepper.scene().energy(s));
  CHECK(dissipated > 1e-3 * stepper.scene().energy(s));
  CHECK(worst <= 1e-14);
}

// A spacecraft with lossy wheels and no motor torque is an energy sink: it ends spinning as a
// rigid body about its major axis (the whole spacecraft's, wheels locked), T = |π|²/(2J_max),
// with π kept exactly all the way.
TEMPLATE_TEST_CASE("friction: the energy sink ends in a major-axis spin, pi exact", "[control][friction]", SimoKappa,
                   SimoAlpha) {
  Wheels rw;
  rw.add_wheel({.axis = Vec3::UnitX(), .inertia = 0.05, .speed0 = 20, .friction = 0.005});
  rw.add_wheel({.axis = Vec3::UnitY(), .inertia = 0.05, .speed0 = -10, .friction = 0.005});
  rw.add_wheel({.axis = Vec3(0, 1, 1), .inertia = 0.05, .speed0 = 5, .friction = 0.005});
  const Mat3 J = (Mat3() << 6, 0.3, 0, 0.3, 8, -0.2, 0, -0.2, 9).finished();
  using Sc = Scene<double, Wheels>;
  Stepper<TestType, Sc> stepper(TestType{}, Sc(rw.hub_body(J), rw));
  State<double> s;
  s.rotation = SO3d::exp(Vec3(0.2, 0.4, -0.1));
  s.omega = Vec3(0.4, 0.3, -0.2);
  stepper.scene().template effect<Wheels>().start(0.0, s.omega);
  const Vec3 pi0 = stepper.scene().spatial_momentum(s);
  const double T0 = stepper.scene().energy(s);
  double max_pi = 0, rise = 0, last = T0;
  int steps = 0;
  auto observer = [&](const State<double>& x) {
    max_pi = std::max(max_pi, (stepper.scene().spatial_momentum(x) - pi0).norm() / pi0.norm());
    const double T = stepper.scene().energy(x);
    rise = std::max(rise, (T - last) / T0);  // never up by more than round-off
    last = T;
    ++steps;
  };
  auto none = [](const Sample<double>&) { return Command<double>{}; };
  const SampledSummary<double> sum = integrate_sampled(stepper, s, 6000.0, 1.0, none, FixedSteps<double>{0.05}, observer);
  REQUIRE(sum.ok());
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(J);
  const double J_max = eig.eigenvalues()(2);
  const double T_end = stepper.scene().energy(s), T_sink = pi0.squaredNorm() / (2 * J_max);
  const WheelVector x = stepper.scene().template effect<Wheels>().speeds(s.time, s.omega);
  INFO("T0 = " << T0 << ", T_end = " << T_end << ", |pi|^2/(2 J_max) = " << T_sink << ", wheel speeds " << x.transpose()
               << ", max |pi - pi0|/|pi0| = " << max_pi << ", largest rise " << rise << " over " << steps << " rows");
  CHECK(T0 > 1.5 * T_sink);  // far from the end state at the start
  CHECK(std::abs(T_end - T_sink) <= 1e-9 * T_sink);
  CHECK(x.norm() <= 1e-6);  // the wheels locked to the hub
  // The body's rate along the major axis, in the direction of π.
  const Vec3 axis = eig.eigenvectors().col(2);
  CHECK(std::abs(std::abs(s.omega.normalized().dot(axis)) - 1) <= 1e-9);
  CHECK(max_pi <= 3 * std::sqrt(double(steps)) * 2.22e-16);
  CHECK(rise <= 1e-15);
}

// Three axes, held commands, four wheels (one without friction): the split run against an
// independent reference, RK4 on (q, Π, h_i) with the friction in the vector field, at a step
// 50 times smaller. Simo-κ in the split is of order 2, its triple jump of order 4, π kept to
// round-off.
TEST_CASE("friction: three axes against an independent reference, orders 2 and 4", "[control][friction]") {
  const Wheels rw0 = four_wheels_with_friction();
  const Mat3 J = (Mat3() << 9, 0.2, -0.1, 0.2, 8, 0.15, -0.1, 0.15, 6).finished();
  using Sc = Scene<double, Wheels>;
  const RigidBody<double> hub = rw0.hub_body(J);
  const double T = 0.5, t_end = 10.0;
  const Vec3 omega0(0.3, -0.2, 0.5), theta0(0.1, -0.3, 0.2);

  // The reference: y = (q, Π, h), Π̇ = Π × Ω, ḣ_i = u_i − c_i(h_i/J_s,i − g_i·Ω),
  // Ω = J_hub⁻¹(Π − Σ h_i g_i), q̇ = ½ q ⊗ (0, Ω); u held over each sample.
  const Mat3 Jinv = hub.inertia_inverse();
  const int n = rw0.size();
  Eigen::Quaterniond q(SO3d::exp(theta0).matrix());
  WheelVector h(n);
  for (int i = 0; i < n; ++i) h(i) = rw0.inertias()(i) * (rw0.speeds(0, Vec3::Zero())(i) + rw0.axis(i).dot(omega0));
  Vec3 Pi = hub.inertia() * omega0 + rw0.axes() * h;
  struct D {
    Eigen::Vector4d q;
    Vec3 Pi;
    WheelVector h;
  };
  auto rate = [&](const D& y, const WheelVector& u) {
    const Vec3 w = Jinv * (y.Pi - rw0.axes() * y.h);
    D d;
    const Eigen::Quaterniond qq(y.q(3), y.q(0), y.q(1), y.q(2));
    const Eigen::Quaterniond dq = qq * Eigen::Quaterniond(0, w.x(), w.y(), w.z());
    d.q = 0.5 * dq.coeffs();
    d.Pi = y.Pi.cross(w);
    d.h.resize(n);
    for (int i = 0; i < n; ++i)
      d.h(i) = u(i) - rw0.frictions()(i) * (y.h(i) / rw0.inertias()(i) - rw0.axis(i).dot(w));
    return d;
  };
  auto add = [n](const D& y, const D& d, double a) {
    D r{y.q + a * d.q, y.Pi + a * d.Pi, WheelVector(n)};
    r.h = y.h + a * d.h;
    return r;
  };
  D y{q.coeffs(), Pi, h};
  const int per_sample = 2000;
  const double dt_ref = T / per_sample;
  for (int k = 0; k * T < t_end - 1e-9; ++k) {
    const WheelVector u = four_commands(k * T);
    for (int j = 0; j < per_sample; ++j) {
      const D k1 = rate(y, u), k2 = rate(add(y, k1, dt_ref / 2), u), k3 = rate(add(y, k2, dt_ref / 2), u),
              k4 = rate(add(y, k3, dt_ref), u);
      y.q += dt_ref / 6 * (k1.q + 2 * k2.q + 2 * k3.q + k4.q);
      y.Pi += dt_ref / 6 * (k1.Pi + 2 * k2.Pi + 2 * k3.Pi + k4.Pi);
      y.h += dt_ref / 6 * (k1.h + 2 * k2.h + 2 * k3.h + k4.h);
    }
  }
  const Mat3 R_ref = Eigen::Quaterniond(y.q(3), y.q(0), y.q(1), y.q(2)).normalized().toRotationMatrix();
  const Vec3 omega_ref = Jinv * (y.Pi - rw0.axes() * y.h);

  // A run's start (the stepper's wheels started there, π₀) and its end's distance to the reference.
  auto started = [&](auto stepper) {
    State<double> s;
    s.rotation = SO3d::exp(theta0);
    s.omega = omega0;
    stepper.scene().template effect<Wheels>().start(0.0, s.omega);
    const Vec3 pi0 = stepper.scene().spatial_momentum(s);
    return std::tuple{std::move(stepper), s, pi0};
  };
  auto error_of = [&](const auto& stepper, const State<double>& s) {
    return (s.rotation.matrix() - R_ref).norm() + (s.omega - omega_ref).norm() / omega_ref.norm() +
           (stepper.scene().template effect<Wheels>().momenta(s.time) - y.h).norm() / y.h.norm();
  };
  auto errors = [&](auto make_stepper) {
    std::vector<double> err;
    for (const double dt : {0.1, 0.05, 0.025}) {
      auto [stepper, s, pi0] = started(make_stepper());
      HoldEach ctrl{&four_commands};
      REQUIRE(integrate_sampled(stepper, s, t_end, T, ctrl, FixedSteps<double>{dt}).ok());
      CHECK((stepper.scene().spatial_momentum(s) - pi0).norm() <= 1e-14 * pi0.norm());
      err.push_back(error_of(stepper, s));
    }
    return err;
  };
  const std::vector<double> e2 = errors([&] { return Stepper<SimoKappa, Sc>(SimoKappa{}, Sc(hub, rw0)); });
  // A composed stepper's sub-steps each sit between two flows: the composition of the
  // symmetric split steps, of the composition's order.
  const std::vector<double> e4 = errors([&] { return ComposedStepper<SimoKappa, Sc>(SimoKappa{}, Sc(hub, rw0), 4); });
  const double p1 = std::log2(e2[0] / e2[1]), p2 = std::log2(e2[1] / e2[2]);
  const double q1 = std::log2(e4[0] / e4[1]), q2 = std::log2(e4[1] / e4[2]);
  INFO("order 2: errors " << e2[0] << ", " << e2[1] << ", " << e2[2] << "; orders " << p1 << ", " << p2);
  INFO("order 4: errors " << e4[0] << ", " << e4[1] << ", " << e4[2] << "; orders " << q1 << ", " << q2);
  CHECK(e2[2] <= 1e-3);
  CHECK(std::abs(p1 - 2) <= 0.1);
  CHECK(std::abs(p2 - 2) <= 0.1);
  CHECK(e4[0] < e2[0] / 100);
  CHECK(std::abs(q1 - 4) <= 0.3);
  CHECK(std::abs(q2 - 4) <= 0.3);

  // Adaptive holds (AdaptiveSteps) on the split step: Richardson's estimate of S_Δ sees the
  // friction, a refused attempt puts the wheels back with the state, and the error follows the
  // tolerance. The first step of each hold is the whole hold, which the tighter tolerances
  // refuse: the wheels' line is put back at every sample (else the friction of each refused
  // attempt would stay in the wheels, an error of c·Δt ≈ 1e-2 whatever the tolerance).
  auto adaptive = [&](auto make_stepper, double rtol) {
    auto run = started(make_stepper());  // (named references: the observer below captures them)
    auto& stepper = std::get<0>(run);
    State<double>& s = std::get<1>(run);
    const Vec3 pi0 = std::get<2>(run);
    HoldEach ctrl{&four_commands};
    AdaptiveOptions<double> opt;
    opt.rtol = rtol;
    opt.atol = rtol;
    opt.first_step = T;
    // π at every accepted step as an observer sees it: the wheels at that step's own line
    // (Richardson's inner steps are reported after the attempt's last step moved them on).
    double dpi = 0;
    int nodes = 0;
    auto watch = [&](const State<double>& x) {
      dpi = std::max(dpi, (stepper.scene().spatial_momentum(x) - pi0).norm());
      ++nodes;
    };
    const SampledSummary<double> sum = integrate_sampled(stepper, s, t_end, T, ctrl, AdaptiveSteps<double>{opt}, watch);
    REQUIRE(sum.ok());
    CHECK(s.time == t_end);
    CHECK(nodes == sum.steps + 1);
    CHECK(dpi <= 1e-14 * pi0.norm());
    CHECK((stepper.scene().spatial_momentum(s) - pi0).norm() <= 1e-14 * pi0.norm());
    return std::tuple{error_of(stepper, s), sum.steps, sum.rejected};
  };
  for (const bool composed : {false, true}) {
    std::vector<double> ea;
    std::vector<std::int64_t> steps, rejected;
    for (const double rtol : {1e-5, 1e-7, 1e-9}) {
      const auto [e, n_steps, n_rejected] = composed
                              ? adaptive([&] { return ComposedStepper<SimoKappa, Sc>(SimoKappa{}, Sc(hub, rw0), 4); }, rtol)
                              : adaptive([&] { return Stepper<SimoKappa, Sc>(SimoKappa{}, Sc(hub, rw0)); }, rtol);
      ea.push_back(e);
      steps.push_back(n_steps);
      rejected.push_back(n_rejected);
      INFO((composed ? "order 4" : "order 2") << ", rtol " << rtol << ": error " << e << " in " << n_steps << " steps");
      CHECK(e <= 60 * rtol);  // 20 holds, each a run held to the tolerance by itself
    }
    INFO((composed ? "order 4" : "order 2") << ": errors " << ea[0] << ", " << ea[1] << ", " << ea[2] << "; steps "
                                           << steps[0] << ", " << steps[1] << ", " << steps[2]);
    CHECK(ea[2] < ea[0] / 100);  // the error follows the tolerance
    CHECK(rejected[2] >= 20);    // the whole hold refused at least once a hold at the tightest
    CHECK(steps[2] > steps[1]);
    CHECK(steps[1] > steps[0]);
  }

  // A hold the adaptive driver gives up (max_steps) stops the run at its last accepted step
  // with the wheels at that step's line, not at a refused attempt's: π of the state reached,
  // read with the wheels, is π₀ (a refused attempt's friction, ~1e-3 of the wheels' momenta,
  // would show). And FixedSteps::max_steps stops the run at the sample before the hold.
  {
    auto [stepper, s, pi0] = started(Stepper<SimoKappa, Sc>(SimoKappa{}, Sc(hub, rw0)));
    HoldEach ctrl{&four_commands};
    AdaptiveOptions<double> opt;
    opt.rtol = opt.atol = 1e-10;
    opt.first_step = T;
    opt.max_steps = 3;  // attempts a hold: the whole hold and its halves are refused first
    const SampledSummary<double> sum = integrate_sampled(stepper, s, t_end, T, ctrl, AdaptiveSteps<double>{opt});
    INFO(sum.reason() << " at t = " << s.time << ", " << sum.steps << " steps, " << sum.rejected << " refused");
    CHECK(sum.too_many_steps);
    CHECK(sum.rejected >= 2);
    CHECK(s.time < T);
    CHECK((stepper.scene().spatial_momentum(s) - pi0).norm() <= 1e-14 * pi0.norm());

    auto [fixed, x, pi_fixed] = started(Stepper<SimoKappa, Sc>(SimoKappa{}, Sc(hub, rw0)));
    (void)pi_fixed;
    // 5 steps a hold at h = 0.1; a limit of 4 refuses the first hold before any step
    const SampledSummary<double> none = integrate_sampled(fixed, x, t_end, T, ctrl, FixedSteps<double>{0.1, {}, 0, 4});
    CHECK(none.too_many_steps);
    CHECK(none.steps == 0);
    CHECK(x.time == 0.0);
    CHECK(x.omega == omega0);
    const SampledSummary<double> all = integrate_sampled(fixed, x, t_end, T, ctrl, FixedSteps<double>{0.1, {}, 0, 5});
    CHECK(all.ok());
    CHECK(all.steps == 100);
  }
}

// (W17.a)-(W17.b): a node of the dense output on a scene whose wheels have friction has the
// motion's rates. Checked against the model written here on its own, y = (Π, h) in body
// axes, Π̇ = Π × Ω, ḣ_i = u_i − c_i(h_i/J_s,i − g_i·Ω), Ω = J_hub⁻¹(Π − Σ h_i g_i): Ω̇ from
// it to round-off, and Ω̈ against the central difference of its Ω̇ along RK4 steps of ±δ
// (error O(δ²) ≈ 1e-9 relative). The friction's share of each rate is far above the bound,
// so a node that left it out (the scene's rates before (W17.a)) fails.
TEST_CASE("friction: the dense output's nodes have the motion's rates (W17.a-b)", "[control][friction]") {
  const Mat3 J = (Mat3() << 9, 0.2, -0.1, 0.2, 8, 0.15, -0.1, 0.15, 6).finished();
  using Sc = Scene<double, Wheels>;
  Sc scene(four_wheels_with_friction().hub_body(J), four_wheels_with_friction());
  Wheels& rw = scene.effect<Wheels>();
  State<double> s;
  s.time = 1.5;
  s.rotation = SO3d::exp(Vec3(0.1, -0.3, 0.2));
  s.omega = Vec3(0.3, -0.2, 0.5);
  rw.start(s.time, s.omega);
  const WheelVector u = four_commands(s.time);
  rw.hold(s.time, u);
  const DenseNode<double> node = dense_node(scene, s);

  const Mat3 Jinv = scene.body().inertia_inverse();
  const int n = rw.size();
  struct Y {
    Vec3 Pi;
    WheelVector h;
  };
  auto omega_of = [&](const Y& y) { return Vec3(Jinv * (y.Pi - rw.axes() * y.h)); };
  auto rate = [&](const Y& y, double c_scale) {  // c_scale 0: the same model without friction
    const Vec3 w = omega_of(y);
    Y d{y.Pi.cross(w), WheelVector(n)};
    for (int i = 0; i < n; ++i)
      d.h(i) = u(i) - c_scale * rw.frictions()(i) * (y.h(i) / rw.inertias()(i) - rw.axis(i).dot(w));
    return d;
  };
  auto omega_dot = [&](const Y& y, double c_scale) {
    const Y d = rate(y, c_scale);
    return Vec3(Jinv * (d.Pi - rw.axes() * d.h));
  };
  auto rk4 = [&](Y y, double dt, double c_scale) {
    auto add = [](const Y& a, const Y& b, double x) { return Y{a.Pi + x * b.Pi, a.h + x * b.h}; };
    const Y k1 = rate(y, c_scale), k2 = rate(add(y, k1, dt / 2), c_scale), k3 = rate(add(y, k2, dt / 2), c_scale),
            k4 = rate(add(y, k3, dt), c_scale);
    y.Pi += dt / 6 * (k1.Pi + 2 * k2.Pi + 2 * k3.Pi + k4.Pi);
    y.h += dt / 6 * (k1.h + 2 * k2.h + 2 * k3.h + k4.h);
    return y;
  };
  const WheelVector h0 = rw.momenta(s.time);
  const Y y0{scene.body().inertia() * s.omega + rw.axes() * h0, h0};
  REQUIRE((omega_of(y0) - s.omega).norm() <= 1e-15);
  const double delta = 1e-4;
  auto omega_ddot = [&](double c_scale) {
    return Vec3((omega_dot(rk4(y0, delta, c_scale), c_scale) - omega_dot(rk4(y0, -delta, c_scale), c_scale)) / (2 * delta));
  };
  const Vec3 wd = omega_dot(y0, 1), wd_free = omega_dot(y0, 0);
  const Vec3 wdd = omega_ddot(1), wdd_free = omega_ddot(0);
  INFO("Omega_dot " << node.omega_dot.transpose() << " model " << wd.transpose() << " without friction "
                    << wd_free.transpose());
  INFO("Omega_ddot " << node.omega_ddot.transpose() << " model " << wdd.transpose() << " without friction "
                     << wdd_free.transpose());
  CHECK((node.omega_dot - wd).norm() <= 1e-14 * wd.norm());
  CHECK((node.omega_ddot - wdd).norm() <= 1e-8 * wdd.norm());
  // the friction's share, far above both bounds
  CHECK((wd - wd_free).norm() >= 1e-2 * wd.norm());
  CHECK((wdd - wdd_free).norm() >= 1e-4 * wdd.norm());
}

// [W17] Between two nodes of an adaptive hold the wheels lie on the cubic Hermite of their
// momenta with ḣ_i = u_i − c_i Ω_i at both ends (FrictionSplitStepper::wheels_at, which the
// CLI's rows at --t-eval and its events call): the total momentum of the interpolated state
// with them is π₀ to the interpolants' error, while the wheels' line at the step's end moved
// by u alone (the friction left out) puts it far off.
TEST_CASE("friction: the wheels between two nodes lie on their Hermite interpolant", "[control][friction]") {
  // Doubling (m = 2), and Richardson's m = 8 from a first step of the whole hold, which the
  // driver refuses: the refused attempts' steps are in the stepper's memory of recent steps
  // when the accepted ones are reported, and the times checked include their inner ends
  // (t0 + k·0.5/8), where a refused step's line must not be taken.
  const double T = 0.5;  // one hold
  for (const int m : {2, 8}) {
    State<double> s;
    auto stepper = held_four_wheels(s);
    Wheels& rw = stepper.scene().effect<Wheels>();
    const Vec3 pi0 = stepper.scene().spatial_momentum(s);
    AdaptiveOptions<double> opt;
    opt.rtol = opt.atol = 1e-9;
    if (m == 8) {
      opt.estimate = ErrorEstimate::richardson;
      opt.substeps = 8;
      opt.first_step = T;
    }
    double worst = 0, worst_unmoved = 0;
    int rows = 0;
    auto observe = [&](const DenseNode<double>& a, const DenseNode<double>& b, const auto& wheels_at) {
      std::vector<double> times{(a.state.time + b.state.time) / 2};
      for (int k = 1; k < 8; ++k)
        if ((k * T / 8 - a.state.time) * (b.state.time - k * T / 8) > 0) times.push_back(k * T / 8);
      for (const double t : times) {
        const State<double> x = LieHermite<double>(a, b, true).state(t);
        wheels_at(b.state.time);
        const double unmoved = (stepper.scene().spatial_momentum(x) - pi0).norm();  // the wheels at b's line
        wheels_at(t);
        const double moved = (stepper.scene().spatial_momentum(x) - pi0).norm();
        worst = std::max(worst, moved);
        worst_unmoved = std::max(worst_unmoved, unmoved);
        ++rows;
      }
    };
    const AdaptiveSummary<double> sum = detail::friction_split_hold(stepper, rw, s, T, opt, observe);
    REQUIRE(sum.ok());
    INFO("m = " << m << ", " << sum.accepted << " steps, " << sum.rejected << " refused, " << rows
                << " times: |pi - pi0|/|pi0| " << worst / pi0.norm() << ", with the wheels at the end's line "
                << worst_unmoved / pi0.norm());
    CHECK(rows >= 10);
    if (m == 8) CHECK(sum.rejected >= 1);
    CHECK(worst <= 1e-12 * pi0.norm());
    CHECK(worst_unmoved >= 1e-6 * pi0.norm());
    CHECK(s.time == T);
    CHECK((stepper.scene().spatial_momentum(s) - pi0).norm() <= 1e-14 * pi0.norm());
  }
}

// The split stepper's memory of its last steps, read by wheels_at as the adaptive driver
// leaves it: an accepted step, a refused attempt (its coarse step and m inner steps), then
// the accepted attempt. A time inside an accepted inner step takes the Hermite of that step's
// own two ends: in its first inner step after a refused attempt of m = 16 that pushed the
// step before out of memory, and at a refused inner step's end that lies inside an accepted
// step (both once gave the wrong line: unchanged, and the refused one).
TEST_CASE("friction: wheels_at reads the accepted steps, not a refused attempt's", "[control][friction]") {
  using St = Stepper<SimoKappa, FrictionScene>;
  State<double> s;
  St stepper = held_four_wheels(s);
  Wheels& rw = stepper.scene().effect<Wheels>();
  const detail::FrictionSplitStepper<St, State<double>> split(stepper, rw);
  using Traj = detail::FrictionSplitStepper<St, State<double>>::Trajectory;
  // The Hermite of the wheels' momenta inside a step from a to b, written here.
  auto hermite = [&](const Traj& a, const Traj& b, double t) {
    rw.set_hold_line(a.line);
    const WheelVector ra = rw.momentum_rates(a.time, a.omega);
    rw.set_hold_line(b.line);
    const WheelVector rb = rw.momentum_rates(b.time, b.omega);
    const double d = b.time - a.time, x = (t - a.time) / d;
    return WheelVector((2 * x * x * x - 3 * x * x + 1) * a.line.momenta + (x * x * x - 2 * x * x + x) * d * ra +
                       (3 * x * x - 2 * x * x * x) * b.line.momenta + (x * x * x - x * x) * d * rb);
  };
  auto wheels_at = [&](double t) {
    split.wheels_at(t);
    return WheelVector(rw.hold_line().momenta);
  };
  for (const int m : {16, 4}) {
    Traj t = split.start(s);
    REQUIRE(split.step(t, 0.01).ok());  // accepted
    const Traj ta = t;
    const double h_refused = m == 16 ? 0.16 : 0.04, h_inner = 0.016;  // m = 4: its inner ends 0.02, 0.03, ...
    {  // a refused attempt from ta: its coarse step, then m inner steps (the driver drops them)
      Traj coarse = ta, fine = ta;
      REQUIRE(split.step(coarse, h_refused).ok());
      for (int k = 0; k < m; ++k) REQUIRE(split.step(fine, h_refused / m).ok());
    }
    // the accepted attempt from ta: its coarse step, then m inner steps of h_inner / m
    Traj coarse = ta, fine = ta;
    REQUIRE(split.step(coarse, h_inner).ok());
    std::vector<Traj> ends{ta};
    for (int k = 0; k < m; ++k) {
      REQUIRE(split.step(fine, h_inner / m).ok());
      ends.push_back(fine);
    }
    const double tol = 1e-14 * rw.hold_line().momenta.norm();
    // inside the first inner step
    const double t1 = (ends[0].time + ends[1].time) / 2;
    INFO("m = " << m);
    CHECK((wheels_at(t1) - hermite(ends[0], ends[1], t1)).norm() <= tol);
    // at each accepted inner end: its own line
    for (std::size_t k = 1; k < ends.size(); ++k) CHECK((wheels_at(ends[k].time) - ends[k].line.momenta).norm() == 0);
    // at a refused inner end inside an accepted step (m = 4: 0.02 inside [0.018, 0.022])
    if (m == 4) {
      const double tr = 0.01 + h_refused / m;
      std::size_t k = 1;
      while (ends[k].time < tr) ++k;
      REQUIRE(ends[k - 1].time < tr);
      REQUIRE(tr < ends[k].time);
      CHECK((wheels_at(tr) - hermite(ends[k - 1], ends[k], tr)).norm() <= tol);
    }
  }
}

// A symmetric scheme in a symmetric split is time-reversible: forward then backward under the
// same held command returns to the start.
TEST_CASE("friction: forward then backward returns to the start", "[control][friction]") {
  Wheels rw = four_wheels_with_friction();
  using Sc = Scene<double, Wheels>;
  Stepper<SimoKappa, Sc> stepper(SimoKappa{}, Sc(rw.hub_body(Vec3(9, 8, 6).asDiagonal()), rw));
  State<double> s;
  s.omega = Vec3(0.3, -0.2, 0.5);
  stepper.scene().effect<Wheels>().start(0, s.omega);
  const State<double> start = s;
  const WheelVector h0 = stepper.scene().effect<Wheels>().momenta(0);
  auto constant = [](const Sample<double>&) {
    Command<double> c;
    c.wheel_torques = four_commands(0.3);
    return c;
  };
  REQUIRE(integrate_sampled(stepper, s, 5.0, 0.5, constant, FixedSteps<double>{0.05}).ok());
  CHECK((s.omega - start.omega).norm() > 0.01);
  REQUIRE(integrate_sampled(stepper, s, 0.0, 0.5, constant, FixedSteps<double>{-0.05}).ok());
  CHECK(s.time == 0.0);
  CHECK((s.omega - start.omega).norm() <= 1e-12);
  CHECK((s.rotation.matrix() - start.rotation.matrix()).norm() <= 1e-12);
  CHECK((stepper.scene().effect<Wheels>().momenta(0) - h0).norm() <= 1e-12 * h0.norm());
}

TEST_CASE("friction: a failed step keeps state and wheels", "[control][friction]") {
  Wheels rw = four_wheels_with_friction();
  using Sc = Scene<double, Wheels>;
  Stepper<SimoKappa, Sc> stepper(SimoKappa{}, Sc(rw.hub_body(Vec3(9, 8, 6).asDiagonal()), rw));
  stepper.options().max_iterations = 2;  // a fast spin at a long step: Newton cannot settle
  State<double> s;
  s.omega = Vec3(3, -4, 5);
  stepper.scene().effect<Wheels>().start(0, s.omega);
  const State<double> before = s;
  const WheelVector h0 = stepper.scene().effect<Wheels>().momenta(0);
  const Vec3 pi0 = stepper.scene().spatial_momentum(s);
  IntegrateOptions no_recovery;
  no_recovery.max_halvings = 0;
  auto constant = [](const Sample<double>&) {
    Command<double> c;
    c.wheel_torques = WheelVector::Constant(4, 0.2);
    return c;
  };
  const auto sum = integrate_sampled(stepper, s, 10.0, 1.0, constant, FixedSteps<double>{1.0, no_recovery});
  REQUIRE_FALSE(sum.ok());
  CHECK(sum.status != StepStatus::ok);
  CHECK(s.time == before.time);
  CHECK(s.omega == before.omega);
  CHECK(s.rotation.unit_quaternion().coeffs() == before.rotation.unit_quaternion().coeffs());
  const Wheels& w = stepper.scene().effect<Wheels>();
  CHECK(w.momenta(0) == h0);
  CHECK(w.torques() == WheelVector::Constant(4, 0.2));
  CHECK((stepper.scene().spatial_momentum(s) - pi0).norm() == 0.0);

  // A stiff friction stays finite: with c_1 = 10^3 or 10^6 (c/J_s·Δt/2 = 600 or 6·10^5) wheel 1
  // locks to the hub within each half flow, up to the slip its slower neighbours force on it,
  // x_1 ≈ −Σ_a S_1a c_a x_a/(S_11 c_1), which falls as 1/c_1. One whose matrix overflows
  // (c/J_s > max) fails as non-finite, and keeps the state and the wheels too.
  double slip[2] = {0, 0};
  for (const double c : {1e3, 1e6, 1e308}) {
    Stepper<SimoKappa, Sc> stiff(SimoKappa{}, Sc(rw.hub_body(Vec3(9, 8, 6).asDiagonal()), rw));
    stiff.scene().effect<Wheels>().set_friction(0, c);
    State<double> x;
    x.omega = Vec3(0.3, -0.2, 0.1);
    stiff.scene().effect<Wheels>().start(0, x.omega);
    const State<double> x0 = x;
    const WheelVector hx = stiff.scene().effect<Wheels>().momenta(0);
    const auto r = integrate_sampled(stiff, x, 1.0, 0.5, constant, FixedSteps<double>{0.1});
    INFO("c = " << c << ": " << r.reason() << " at t = " << x.time);
    if (c < 1e308) {
      REQUIRE(r.ok());
      slip[c < 1e4 ? 0 : 1] = std::abs(stiff.scene().effect<Wheels>().speeds(x.time, x.omega)(0));
    } else {
      CHECK(r.status == StepStatus::non_finite);
      CHECK(x.time == 0.0);
      CHECK(x.omega == x0.omega);
      CHECK(stiff.scene().effect<Wheels>().momenta(0) == hx);
    }
  }
  INFO("wheel 1's slip at c = 1e3 and 1e6: " << slip[0] << ", " << slip[1]);
  CHECK(slip[0] < 1e-5);
  CHECK(slip[0] / slip[1] > 500);
  CHECK(slip[0] / slip[1] < 2000);
}

TEST_CASE("friction: bad input and the drivers that cannot apply it are refused", "[control][friction]") {
  Wheels rw;
  REQUIRE_THROWS_WITH(rw.add_wheel({.axis = Vec3::UnitX(), .inertia = 0.1, .friction = -1e-3}),
                      Catch::Contains("wheel 1") && Catch::Contains("friction"));
  REQUIRE_THROWS_WITH(rw.add_wheel({.axis = Vec3::UnitX(), .inertia = 0.1, .friction = std::nan("")}),
                      Catch::Contains("friction"));
  REQUIRE(rw.size() == 0);
  REQUIRE_THROWS_WITH(rw.set_friction(0, 1.0), Catch::Contains("wheel 1: no such wheel"));
  rw.add_wheel({.axis = Vec3::UnitX(), .inertia = 0.1, .friction = 0.0});
  CHECK_FALSE(rw.has_friction());
  rw.add_wheel({.axis = Vec3::UnitY(), .inertia = 0.1, .friction = 1e-3});
  CHECK(rw.has_friction());
  REQUIRE_THROWS_WITH(rw.set_friction(1, -2.0), Catch::Contains("wheel 2: friction must be finite and >= 0"));
  REQUIRE_THROWS_WITH(rw.set_friction(1, INFINITY), Catch::Contains("wheel 2: friction"));
  CHECK(rw.frictions()(1) == 1e-3);

  using Sc = Scene<double, Wheels>;
  Stepper<SimoKappa, Sc> stepper(SimoKappa{}, Sc(rw.hub_body(Vec3(3, 4, 5).asDiagonal()), rw));
  State<double> s;
  s.omega = Vec3(0.1, 0.2, 0.3);
  stepper.scene().effect<Wheels>().start(0, s.omega);
  CHECK(stepper.scene().wheel_friction());
  const State<double> before = s;
  REQUIRE_THROWS_WITH(integrate(stepper, s, 1.0, 0.1), Catch::Contains("integrate: the wheels have viscous friction"));
  AdaptiveOptions<double> opt;
  opt.rtol = 1e-8;
  REQUIRE_THROWS_WITH(integrate_adaptive(stepper, s, 1.0, opt), Catch::Contains("viscous friction"));
  auto none = [](const Sample<double>&) { return Command<double>{}; };
  // Adaptive holds estimate the split step by Richardson's rule; the defect estimate and the
  // reversible control, built for a scheme's own step, are refused.
  AdaptiveOptions<double> defect = opt, reversible = opt;
  defect.estimate = ErrorEstimate::defect;
  reversible.control = StepControl::reversible;
  REQUIRE_THROWS_WITH(integrate_sampled(stepper, s, 1.0, 0.1, none, AdaptiveSteps<double>{defect}),
                      Catch::Contains("sampled: the wheels have viscous friction") && Catch::Contains("estimate = defect"));
  REQUIRE_THROWS_WITH(integrate_sampled(stepper, s, 1.0, 0.1, none, AdaptiveSteps<double>{reversible}),
                      Catch::Contains("sampled: the wheels have viscous friction") && Catch::Contains("control = reversible"));
  // A driver of one's own between the samples would leave the flow out.
  struct OwnBetween {
    bool operator()(const Stepper<SimoKappa, Sc>&, State<double>& x, double t_next, const NoObserver&,
                    SampledSummary<double>&) const {
      x.time = t_next;
      return true;
    }
  };
  REQUIRE_THROWS_WITH(integrate_sampled(stepper, s, 1.0, 0.1, none, OwnBetween{}),
                      Catch::Contains("sampled: the wheels have viscous friction") && Catch::Contains("of one's own"));
  // The processed composition steps a kernel, not the output the flow would act on.
  ProcessedStepper<SimoKappa, Sc> processed(SimoKappa{}, stepper.scene());
  REQUIRE_THROWS_WITH(integrate_sampled(processed, s, 1.0, 0.1, none, FixedSteps<double>{0.1}),
                      Catch::Contains("sampled: the wheels have viscous friction") && Catch::Contains("ComposedStepper"));
  CHECK(s.omega == before.omega);
  CHECK(s.time == before.time);
  // FixedSteps and AdaptiveSteps apply it.
  REQUIRE(integrate_sampled(stepper, s, 1.0, 0.1, none, FixedSteps<double>{0.1}).ok());
  CHECK(s.time == 1.0);
  REQUIRE(integrate_sampled(stepper, s, 2.0, 0.1, none, AdaptiveSteps<double>{opt}).ok());
  CHECK(s.time == 2.0);
}

// Closed-loop ensembles copy the stepper per member: each member with friction is its own
// single run, bit for bit.
TEST_CASE("friction: ensemble members are their single runs", "[control][friction]") {
  Wheels rw = four_wheels_with_friction();
  using Sc = Scene<double, Wheels>;
  const Stepper<SimoKappa, Sc> stepper(SimoKappa{}, Sc(rw.hub_body(Vec3(9, 8, 6).asDiagonal()), rw));
  std::vector<State<double>> initials(3);
  for (int i = 0; i < 3; ++i) initials[i].omega = Vec3(0.1 * (i + 1), -0.2, 0.3);
  HoldEach ctrl{&four_commands};
  EnsembleOptions two;
  two.threads = 2;
  const auto members = integrate_sampled_ensemble(stepper, initials, 3.0, 0.5, ctrl, FixedSteps<double>{0.05}, two);
  for (int i = 0; i < 3; ++i) {
    auto own = stepper;
    State<double> s = initials[i];
    own.scene().effect<Wheels>().start(s.time, s.omega);
    HoldEach c = ctrl;
    REQUIRE(integrate_sampled(own, s, 3.0, 0.5, c, FixedSteps<double>{0.05}).ok());
    CHECK(members[i].state.omega == s.omega);
    CHECK(members[i].state.rotation.unit_quaternion().coeffs() == s.rotation.unit_quaternion().coeffs());
    CHECK(members[i].wheel_speeds == own.scene().effect<Wheels>().speeds(s.time, s.omega));
  }
}
