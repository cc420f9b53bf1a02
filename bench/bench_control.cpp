// trompo-bench-control: control in the loop, what accuracy costs in time (docs/control.md).
//
//   control/<case>/<method>/<m|tol>   one closed-loop run of the case to its end time:
//                                     the controller sampled every T, its commands held, and
//                                     between samples m steps of h = T/m (trompo's schemes,
//                                     and odeint's runge_kutta4 "sub-stepping each sample"
//                                     as Basilisk, 42 and S2E do; "angle:θ" instead of "m":
//                                     the fewest steps a sample that turn the body by at most
//                                     θ at the sample's rate, FixedSteps::max_angle), or odeint's dopri5
//                                     restarted at each sample at abs = rel = tol (a SciPy
//                                     user's solve_ivp loop), its first step a guess of T/1000,
//                                     T/10 or T (",first:0.1T", ",first:T"; the controller then
//                                     shrinks or grows it): the first guess decides most of a
//                                     short hold's steps, so each tolerance is timed with all three. CPU time per iteration = the
//                                     run's. Counters: err_rot (‖Λ − Λref‖_F at the end),
//                                     err_pi (max ‖π − π0‖/‖π0‖ over the samples, where no
//                                     external torque acts; else 0), steps.
//
// Cases (every parameter here):
//   rw        Basilisk's scenarioAttitudeFeedbackRW: J = diag(900, 800, 600), three wheels on
//             the body axes (J_s = 50/(6000 rpm), 100/200/300 rpm, 0.2 N m, 6000 rpm),
//             σ(0) = (0.1, 0.2, −0.3), Ω(0) = (0.001, −0.01, 0.03); mrp-pd K = 3.5, P = 30,
//             T = 0.1 s, 600 s.
//   pointing  the same spacecraft in the gravity gradient of a 400 km circular orbit
//             (i = 51.6°), mrp-pd (K = 3.5, P = 30) to an inertial target σ_R = (0.2, −0.1, 0.3),
//             T = 0.5 s, one orbit (5,545 s).
//   bdot      fast loop (a): a 3U-like body J = diag(0.033, 0.034, 0.007) kg m² tumbling at
//             30 °/s per axis, magnetorquers of 0.2 A m² per axis in the IGRF-13 dipole along
//             the same orbit, B-dot m = −k Ḃ with k = 1e4 A m² s/T at 4 Hz, 10 orbits.
//   rw-friction  rw with viscous friction c = 1e-4 N m s/rad on each wheel (Basilisk's
//             cViscous), split around the steps [W17]: what friction costs against the rw rows
//             of the same run. trompo's methods only: odeint's state has no wheel momenta, so
//             it cannot carry friction.
//   spinner   fast loop (b): J = diag(120, 100, 150) spinning at 60 rpm about its major axis
//             with a nutation of 0.6 rad/s, three wheels on the body axes (J_s = 0.05,
//             u_max = 0.5 N m, at rest relative to the body at t = 0); the transverse wheels
//             damp the nutation and are brought back to rest, u_i = P Ω_i − K h_i (i = 1, 2,
//             h_i the wheel's momentum, P = 1 N m s, K = 0.2 /s; the first samples saturate)
//             at 20 Hz, 300 s: the nutation falls from 0.6 to 2e-5 rad/s. (Without the K term
//             the damper spun its wheels up without bound once the nutation was gone, to
//             2,800 rad/s and a spin axis tilted by 60° at 300 s, see docs/control.md.)
// References: the splitting (Kahan–Li-9) at 64 steps a sample (bdot: 16), cross-checked against
// Simo-κ composed to order 6 at 32 steps a sample (bdot: 8): their distance is the counter
// ref_check, the floor of every err_rot. rw-friction: the other way round (reference()).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "odeint_baseline.hpp"
#include "trompo/trompo.hpp"

namespace {

using namespace trompo;
using V = Eigen::Vector3d;
using M = Eigen::Matrix3d;
using Wheels = ReactionWheels<double>;
constexpr double pi = 3.14159265358979323846;
constexpr double rpm = 2 * pi / 60;

/// The spinner's wheels' axial inertia (kg m²), which its damper reads too.
constexpr double spinner_Js = 0.05;

/// The spinner's nutation damper on the two transverse wheels: u_i = P Ω_i − K h_i, the body
/// torque −u_i opposing the transverse rate, and −K h_i bringing the wheel back to rest as the
/// nutation dies (h_i = J_s(Ω_i + Ω_w,i), the wheel's momentum on its body axis i).
struct NutationDamper {
  double P = 1, K = 0.2, J_s = spinner_Js;
  Command<double> operator()(const Sample<double>& s) const {
    Command<double> c;
    c.wheel_torques = Wheels::WheelVector::Zero(s.wheel_speeds.size());
    for (int i = 0; i < 2; ++i) c.wheel_torques(i) = P * s.state.omega(i) - K * J_s * (s.state.omega(i) + s.wheel_speeds(i));
    return c;
  }
};

Wheels hr16_wheels() {
  Wheels rw;
  for (int i = 0; i < 3; ++i)
    rw.add_wheel({.axis = V::Unit(i), .inertia = 50.0 / (6000 * rpm), .speed0 = 100.0 * (i + 1) * rpm, .max_torque = 0.2,
                  .max_speed = 6000 * rpm});
  return rw;
}
const M J_sc = V(900, 800, 600).asDiagonal();
const CircularOrbit<double> leo(6771e3, 51.6 * pi / 180, 0.4, 0.1);

struct RwCase {
  static constexpr const char* name = "rw";
  static constexpr double period = 0.1, t_end = 600;
  static constexpr bool momentum_exact = true;
  static constexpr bool with_odeint = true;
  static constexpr bool friction = false;
  static constexpr bool near_integrable = true;  ///< wheels and no load: the SABA/SBAB rows [W18]
  using Sc = Scene<double, Wheels>;
  static Sc scene() { return Sc(hr16_wheels().hub_body(J_sc), hr16_wheels()); }
  static State<double> initial() {
    State<double> s;
    s.rotation = SO3d::from_matrix(rotation_of_mrp(V(0.1, 0.2, -0.3)));
    s.omega = V(0.001, -0.01, 0.03);
    return s;
  }
  static MrpPd<double> controller() { return MrpPd<double>{.K = 3.5, .P = 30}; }
};

struct RwFrictionCase : RwCase {
  static constexpr const char* name = "rw-friction";
  static constexpr bool with_odeint = false;
  static constexpr bool friction = true;
  static constexpr bool near_integrable = false;
  static Wheels wheels() {
    Wheels rw = hr16_wheels();
    for (int i = 0; i < 3; ++i) rw.set_friction(i, 1e-4);
    return rw;
  }
  static Sc scene() { return Sc(wheels().hub_body(J_sc), wheels()); }
};

struct PointingCase {
  static constexpr const char* name = "pointing";
  static constexpr double period = 0.5;
  static inline const double t_end = 2 * pi / leo.rate();
  static constexpr bool momentum_exact = false;
  static constexpr bool with_odeint = true;
  static constexpr bool friction = false;
  static constexpr bool near_integrable = false;
  using Sc = Scene<double, Wheels, GravityGradient<double>>;
  static Sc scene() {
    return Sc(hr16_wheels().hub_body(J_sc), hr16_wheels(), GravityGradient<double>(J_sc, leo.rate(), leo.normal(), leo.radial0()));
  }
  static State<double> initial() { return RwCase::initial(); }
  static MrpPd<double> controller() {
    return MrpPd<double>{.K = 3.5, .P = 30, .target = rotation_of_mrp(V(0.2, -0.1, 0.3))};
  }
};

struct BdotCase {
  static constexpr const char* name = "bdot";
  static constexpr double period = 0.25;
  static inline const double t_end = 10 * 2 * pi / leo.rate();
  static constexpr bool momentum_exact = false;
  static constexpr bool with_odeint = true;
  static constexpr bool friction = false;
  static constexpr bool near_integrable = false;
  using Sc = Scene<double, Magnetorquer<double>>;
  static Sc scene() {
    return Sc(RigidBody<double>(V(0.033, 0.034, 0.007), allow_unphysical_inertia),
              Magnetorquer<double>(DipoleField<double>(leo), V::Constant(0.2)));
  }
  static State<double> initial() {
    State<double> s;
    s.rotation = SO3d::exp(V(0.3, -0.5, 0.2));
    s.omega = V::Constant(30 * pi / 180);
    return s;
  }
  static BDot<double> controller() { return BDot<double>{.k = 1e4}; }
};

struct SpinnerCase {
  static constexpr const char* name = "spinner";
  static constexpr double period = 0.05, t_end = 300;
  static constexpr bool momentum_exact = true;
  static constexpr bool with_odeint = true;
  static constexpr bool friction = false;
  static constexpr bool near_integrable = true;
  using Sc = Scene<double, Wheels>;
  static Wheels wheels() {
    Wheels rw;
    for (int i = 0; i < 3; ++i) rw.add_wheel({.axis = V::Unit(i), .inertia = spinner_Js, .speed0 = 0, .max_torque = 0.5});
    return rw;
  }
  static Sc scene() { return Sc(wheels().hub_body(V(120, 100, 150).asDiagonal()), wheels()); }
  static State<double> initial() {
    State<double> s;
    s.omega = V(0.6, 0.0, 60 * rpm);
    return s;
  }
  static NutationDamper controller() { return {}; }
};

/// Between samples: odeint's runge_kutta4, m steps a sample, on the stepper's scene (the
/// held commands are in it).
struct OdeintRK4 {
  int m;
  template <class StepperT, class Traj, class Obs>
  bool operator()(const StepperT& st, Traj& s, double t_next, Obs&&, SampledSummary<double>& sum) const {
    bench::QuaternionOde<typename StepperT::Scene> ode{&st.scene()};
    bench::OdeState x = bench::to_ode(s);
    const double h = (t_next - s.time) / m;
    bench::odeint_rk4(ode, x, s.time, h, m, [](const bench::OdeState&, double) {});
    s.rotation = bench::from_ode(x, t_next).rotation;
    s.omega = V(x[4], x[5], x[6]);
    s.time = t_next;
    sum.steps += m;
    return std::isfinite(x[4]);
  }
};

/// Between samples: odeint's dopri5 from t_k to t_{k+1}, restarted at each sample.
struct OdeintDopri5 {
  double tol;
  double first = 1e-3;  ///< the first step's guess, as a fraction of the hold
  template <class StepperT, class Traj, class Obs>
  bool operator()(const StepperT& st, Traj& s, double t_next, Obs&&, SampledSummary<double>& sum) const {
    bench::QuaternionOde<typename StepperT::Scene> ode{&st.scene()};
    bench::OdeState x = bench::to_ode(s);
    sum.steps += bench::odeint_dopri5(ode, x, s.time, t_next, tol, [](const bench::OdeState&, double) {}, first);
    s.rotation = bench::from_ode(x, t_next).rotation;
    s.omega = V(x[4], x[5], x[6]);
    s.time = t_next;
    return std::isfinite(x[4]);
  }
};

struct Outcome {
  State<double> s;
  double err_pi = 0;
  long steps = 0;
  bool ok = false;
};

/// One closed-loop run of the case with `stepper` (its scene holds the commands) and `between`.
template <class Case, class StepperT, class Between>
Outcome run(StepperT stepper, const Between& between, bool watch_momentum) {
  Outcome o;
  o.s = Case::initial();
  if constexpr (Case::Sc::has_wheels) stepper.scene().template effect<Wheels>().start(o.s.time, o.s.omega);
  auto ctrl = Case::controller();
  const V pi0 = stepper.scene().spatial_momentum(o.s);
  auto watch = [&](const State<double>& x) {
    o.err_pi = std::max(o.err_pi, (stepper.scene().spatial_momentum(x) - pi0).norm() / pi0.norm());
  };
  SampledSummary<double> sum;
  if (watch_momentum && Case::momentum_exact)
    sum = integrate_sampled(stepper, o.s, Case::t_end, Case::period, ctrl, between, watch);
  else
    sum = integrate_sampled(stepper, o.s, Case::t_end, Case::period, ctrl, between);
  o.steps = sum.steps;
  o.ok = sum.ok();
  return o;
}

template <class Case>
Outcome splitting_run(SplittingMethod method, int m, bool watch, double max_angle = 0) {
  return run<Case>(Stepper<Splitting, typename Case::Sc>(Splitting(method), Case::scene()),
                   FixedSteps<double>{Case::period / m, {}, max_angle}, watch);
}
template <class Case>
Outcome simo_run(int order, int m, bool watch) {
  using Sc = typename Case::Sc;
  if (order == 2) return run<Case>(Stepper<SimoKappa, Sc>(SimoKappa{}, Case::scene()), FixedSteps<double>{Case::period / m}, watch);
  return run<Case>(ComposedStepper<SimoKappa, Sc>(SimoKappa{}, Case::scene(), order == 4 ? Composition::suzuki5 : Composition::kahan_li9),
                   FixedSteps<double>{Case::period / m}, watch);
}
template <class Case>
Outcome rk4_run(int m, bool watch) {
  return run<Case>(Stepper<RK4, typename Case::Sc>(RK4{}, Case::scene()), OdeintRK4{m}, watch);
}
template <class Case>
Outcome dopri5_run(double tol, bool watch, double first = 1e-3) {
  return run<Case>(Stepper<RK4, typename Case::Sc>(RK4{}, Case::scene()), OdeintDopri5{tol, first}, watch);
}

/// The case's reference (computed on first use) and its distance to an independent run. With
/// friction the two swap: the friction flow is split around a splitting step (Strang, order 2
/// [W17]) but between the sub-steps of a composition (order 6).
template <class Case>
const std::pair<State<double>, double>& reference() {
  static const std::pair<State<double>, double> r = [] {
    const bool long_case = Case::t_end / Case::period > 1e5;
    State<double> ref = splitting_run<Case>(SplittingMethod::kahan_li_9, long_case ? 16 : 64, false).s;
    State<double> other = simo_run<Case>(6, long_case ? 8 : 32, false).s;
    if constexpr (Case::friction) std::swap(ref, other);
    return std::pair{ref, (other.rotation.matrix() - ref.rotation.matrix()).norm()};
  }();
  return r;
}

template <class Case>
void register_case() {
  constexpr int repetitions = 3;
  auto add = [](const std::string& method, const std::string& param, std::function<Outcome(bool)> f) {
    const std::string name = std::string("control/") + Case::name + "/" + method + "/" + param;
    benchmark::RegisterBenchmark(name.c_str(), [f, method, param](benchmark::State& st) {
      Outcome o;
      for (auto _ : st) o = f(false);
      const Outcome w = Case::momentum_exact ? f(true) : o;  // the momentum watched in a run of its own
      if (!o.ok || !w.ok) {
        st.SkipWithError("the run failed");
        return;
      }
      const auto& [ref, check] = reference<Case>();
      st.counters["err_rot"] = (o.s.rotation.matrix() - ref.rotation.matrix()).norm();
      st.counters["ref_check"] = check;
      st.counters["err_pi"] = w.err_pi;
      st.counters["steps"] = static_cast<double>(o.steps);
      st.SetLabel("case=" + std::string(Case::name) + ";method=" + method + ";param=" + param);
    })->Iterations(1)->Repetitions(Case::t_end / Case::period > 1e5 ? 1 : repetitions)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
  };
  // The grids: every method from one step a sample up to where it has passed the bound or
  // costs far more than the cheapest; the 10-orbit B-dot loop is long, so its grids are
  // sparser and each configuration runs once.
  const bool long_case = Case::t_end / Case::period > 1e5;
  const std::vector<int> m2 = long_case ? std::vector<int>{1, 4, 16} : std::vector<int>{1, 2, 4, 8, 16, 32};
  const std::vector<int> m4 = long_case ? std::vector<int>{1, 2, 4, 8} : std::vector<int>{1, 2, 4, 8, 16};
  const std::vector<int> m6 = long_case ? std::vector<int>{1, 2, 4} : std::vector<int>{1, 2, 4, 8};
  // RK4's grid is finer where the cases cross their bounds (m = 24 … 96): its error goes as m⁻⁴,
  // so a doubling of m is a factor 16 in error, and the cheapest configuration that reaches a
  // bound on a grid of powers of two can cost up to twice what the bound needs (the spinner:
  // m = 32 misses 1e-8 by 30 %, m = 64 overshoots it tenfold).
  const std::vector<int> mrk = long_case ? std::vector<int>{8, 16, 32, 64, 80, 96, 128}
                                         : std::vector<int>{1, 2, 4, 8, 16, 24, 32, 40, 48, 64, 80, 96, 128};
  for (int m : m2) {
    add("splitting-strang", "m:" + std::to_string(m), [m](bool w) { return splitting_run<Case>(SplittingMethod::strang, m, w); });
    add("simo-kappa", "m:" + std::to_string(m), [m](bool w) { return simo_run<Case>(2, m, w); });
  }
  for (int m : m4) {
    add("splitting-suzuki-5", "m:" + std::to_string(m), [m](bool w) { return splitting_run<Case>(SplittingMethod::suzuki_5, m, w); });
    if (!long_case || m >= 4) add("simo-kappa-o4s", "m:" + std::to_string(m), [m](bool w) { return simo_run<Case>(4, m, w); });
  }
  for (int m : m6) {
    add("splitting-kahan-li-9", "m:" + std::to_string(m), [m](bool w) { return splitting_run<Case>(SplittingMethod::kahan_li_9, m, w); });
    add("simo-kappa-o6", "m:" + std::to_string(m), [m](bool w) { return simo_run<Case>(6, m, w); });
  }
  // The near-integrable compositions with wheels [W18]: the hub's exact free
  // flow and the wheels' rotor flow, error O(εh^{2n} + ε²h²) with ε the rotor's size.
  if constexpr (Case::near_integrable)
    for (SplittingMethod method : {SplittingMethod::sbab2c, SplittingMethod::saba2c, SplittingMethod::saba3c})
      for (int m : m4)
        add(std::string("splitting-") + to_string(method), "m:" + std::to_string(m),
            [method, m](bool w) { return splitting_run<Case>(method, m, w); });
  // Steps that follow the rate [W16]: each hold in the fewest steps that turn the body by at
  // most θ at the sample's rate (one step a sample at least).
  for (const char* theta : {"0.1", "0.15", "0.2"}) {
    const double th = std::stod(theta);
    add("splitting-kahan-li-9", std::string("angle:") + theta,
        [th](bool w) { return splitting_run<Case>(SplittingMethod::kahan_li_9, 1, w, th); });
  }
  if constexpr (!Case::with_odeint) return;
  for (int m : mrk) add("odeint-rk4", "m:" + std::to_string(m), [m](bool w) { return rk4_run<Case>(m, w); });
  // dopri5's tolerances in decades, and in half decades (3e-k) where the cases cross their bounds;
  // each with the first step guessed at T/1000 (a cautious guess: a ramp of ~5 steps, each
  // 5× the last, up to the hold), T/10 and T (solve_ivp estimates its own from the derivatives
  // at the hold's start).
  for (const char* tol_text : {"1e-6", "1e-8", "1e-9", "1e-10", "1e-11", "1e-12", "3e-13", "1e-13", "3e-14", "1e-14"}) {
    const double tol = std::stod(tol_text);
    add("odeint-dopri5", std::string("tol:") + tol_text, [tol](bool w) { return dopri5_run<Case>(tol, w); });
    add("odeint-dopri5", std::string("tol:") + tol_text + ",first:T", [tol](bool w) { return dopri5_run<Case>(tol, w, 1.0); });
    add("odeint-dopri5", std::string("tol:") + tol_text + ",first:0.1T", [tol](bool w) { return dopri5_run<Case>(tol, w, 0.1); });
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  register_case<RwCase>();
  register_case<RwFrictionCase>();
  register_case<PointingCase>();
  register_case<SpinnerCase>();
  register_case<BdotCase>();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
