// trompo-bench: what accuracy costs in time (docs/accuracy.md).
//
// Two Google Benchmark families, JSON out with --benchmark_out=FILE:
//
//  step/<case>/<method>          cost of one step at a representative h (HT1, HT2: 1e-3;
//                                FB1: 1e-2). Time per iteration = ns per step; counter
//                                `newton` = Newton iterations per step (summed over
//                                sub-steps for the composed methods).
//  sweep/<case>/<method>/<h|tol> one full run to the case's end time (HT0, HT1: 10;
//                                HT2: 2; FB1: 100) for a geometric grid of h (or, for
//                                dopri5, of tolerances). CPU time per iteration = the
//                                run's CPU time. Counters, from one more (untimed,
//                                instrumented) run with the same configuration:
//                                  steps, h, max_dH (max |ΔH/H|), max_dmu (max |Δμ/μ|;
//                                  FB1: max ‖Δπ‖/‖π‖), err_rot (‖Λ − Λref‖_F at the end),
//                                  err_omega (‖Ω − Ωref‖/‖Ωref‖ at the end), newton
//                                  (iterations per step), rhs (right-hand-side
//                                  evaluations, explicit methods).
//                                A configuration whose step fails is reported as an error.
//
// Every benchmark's label is "key=value;…" (case, method, scheme, order, h, tol, stages)
// for scripts/report.py. Methods: simo-alpha (½), simo-collocation, simo-kappa,
// geradin-bauchau, geradin-bauchau-paper, each at order 2; the three energy-exact ones
// composed (ComposedStepper) to order 4 by the triple jump (-o4) and by Suzuki's five
// steps (-o4s), and to order 6 by Kahan–Li (-o6); our RK4; and, when Boost is found,
// odeint's runge_kutta4 and runge_kutta_dopri5 on the quaternion ODE.
//
// References at the end time: the closed-form Lagrange top (HT0, HT1) and free body
// (FB1) from trompo/exact (with Boost; else a converged composed run, Simo-κ order 6),
// each cross-checked against the independent published solution at the end time
// (compiled in below); HT2: the published 128-bit solution, cross-checked against a
// converged composed run. The checks are put in the JSON context.
//
// Extra flag (then no benchmark runs):
//   --trompo_energy_series=FILE   energy error over time for a long run of each method
//                                 on HT1 (h = 1e-3, t ∈ [0, 500]), CSV.
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <functional>
#include <iomanip>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "trompo/cases.hpp"
#include "trompo/composition.hpp"
#include "trompo/schemes/geradin_bauchau.hpp"
#include "trompo/schemes/geradin_bauchau_paper.hpp"
#include "trompo/schemes/rk4.hpp"
#include "trompo/schemes/simo.hpp"
#include "trompo/stepper.hpp"

// The closed forms use Boost.Math's Carlson integrals, so they need Boost too.
#if defined(TROMPO_HAVE_BOOST) && __has_include("trompo/exact/lagrange_top.hpp") && \
    __has_include("trompo/exact/free_body.hpp")
#include "trompo/exact/free_body.hpp"
#include "trompo/exact/lagrange_top.hpp"
#define TROMPO_BENCH_EXACT 1
#else
#define TROMPO_BENCH_EXACT 0
#endif

#include "odeint_baseline.hpp"

namespace {

using namespace trompo;
using V3 = Eigen::Vector3d;
using M3 = Eigen::Matrix3d;
using Top = cases::Top<double>;
using Free = cases::Free<double>;

// ---- references -------------------------------------------------------------------------

struct Reference {
  M3 rotation;
  V3 omega;
  std::string source;
  std::string check;  ///< how the reference was cross-checked, with the distance found
};

/// The published solutions at each case's end time (docs/theory.md §8):
/// closed forms at 40 digits (HT0, HT1, FB1), RKF7(8) in 128-bit floats (HT2); printed
/// with 17 significant digits, i.e. exact to double precision.
struct Published {
  double t;
  double R[9];
  double w[3];
};
const Published published_ht0 = {10.0,
                                 {0.44138808956316702, 0.84854595362565453, -0.29179842182113701,
                                  -0.35797409062881863, -0.13167591265389697, -0.92440034858562967,
                                  -0.82281899882674561, 0.51247557855208266, 0.24563728657811735},
                                 {-5.4491719004681583, 5.099384179984398, 50.0}};
const Published published_ht1 = {10.0,
                                 {-0.88035320824679323, 0.47197116595071544, -0.047132231441981876,
                                  -0.47343918466276825, -0.88042026680667489, 0.026748686358709885,
                                  -0.028871563092973333, 0.04586253707750627, 0.99853045048079672},
                                 {-0.030618399441827205, 0.028652974173320288, 50.0}};
const Published published_ht2 = {2.0,
                                 {-0.48744908223626571, -0.15041682274564176, 0.86009776866477712,
                                  -0.53793974384415059, -0.72416559163689565, -0.43151480609832443,
                                  0.68776029561171377, -0.6730222695604441, 0.27207866593284563},
                                 {0.12223321949739424, 150.0, -5.8556245892054577}};
const Published published_fb1 = {100.0,
                                 {-0.49160457441821394, -0.010697307057550467, -0.87075284095591858,
                                  0.010572869065672174, -0.99992416458075367, 0.0063150239272708358,
                                  -0.87075436079919055, -0.0061018611257821765, 0.49168039460608429},
                                 {0.011252799694530839, -1.9999933436136818, 0.010434326379235562}};

Reference from_published(const Published& p, const std::string& source) {
  return {Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(p.R), V3(p.w[0], p.w[1], p.w[2]), source, ""};
}

/// ‖ΔΛ‖_F + ‖ΔΩ‖/‖Ω‖ between two references.
double distance(const Reference& a, const Reference& b) {
  return (a.rotation - b.rotation).norm() + (a.omega - b.omega).norm() / b.omega.norm();
}

/// A converged composed run: Simo-κ, order 6, n steps to t_end.
template <class SceneT>
Reference composed_reference(const cases::Case<SceneT>& c, long n) {
  const ComposedStepper<SimoKappa, SceneT> stepper(SimoKappa{}, c.scene, 6);
  State<double> s = c.initial;
  const double h = c.t_end / double(n);
  for (long i = 0; i < n; ++i)
    if (!stepper.step(s, h).ok()) throw std::runtime_error("trompo-bench: the reference run failed");
  std::ostringstream os;
  os << "converged composed run (simo-kappa, order 6, h = " << h << ")";
  return {s.rotation.matrix(), s.omega, os.str(), ""};
}

Reference lagrange_reference(const cases::Case<Top>& c, double A, double C) {
#if TROMPO_BENCH_EXACT
  const auto& g = c.scene.effect<UniformGravity<double>>();
  const exact::LagrangeTop top(A, C, g.Mgl(), c.initial.rotation.matrix(), c.initial.omega, g.up());
  return {top.rotation(c.t_end), top.omega(c.t_end), "exact::LagrangeTop (closed form)", ""};
#else
  (void)A;
  (void)C;
  return composed_reference(c, 10000);
#endif
}

Reference free_body_reference(const cases::Case<Free>& c) {
#if TROMPO_BENCH_EXACT
  const exact::FreeBody body(c.scene.body().inertia().diagonal(), c.initial.rotation.matrix(), c.initial.omega);
  return {body.rotation(c.t_end), body.omega(c.t_end), "exact::FreeBody (closed form)", ""};
#else
  return composed_reference(c, 20000);
#endif
}

// ---- problems ---------------------------------------------------------------------------

/// A geometric grid of step sizes from hi down to lo, ratio 1/√2, snapped so that the end
/// time is a whole number of steps.
struct Grid {
  double hi, lo;
};

template <class SceneT>
struct Problem {
  cases::Case<SceneT> c;
  Reference ref;
  double h_step;  ///< representative h for the per-step family
  Grid o2, o4, o6, rk4, o4s;
};

std::deque<Problem<Top>> tops;    // stable addresses for the registered lambdas
std::deque<Problem<Free>> frees;

std::vector<double> grid(const Grid& g, double t_end) {
  std::vector<double> hs;
  for (int k = 0;; ++k) {
    const double h = g.hi * std::pow(2.0, -0.5 * k);
    if (h < g.lo * (1 - 1e-9)) break;
    const double n = std::max(1.0, std::round(t_end / h));
    hs.push_back(t_end / n);
  }
  return hs;
}

// ---- runs --------------------------------------------------------------------------------

template <class SceneT>
struct Invariants {
  double H0, mu0;
  V3 pi0;
  double max_dH = 0, max_dmu = 0;
  Invariants(const SceneT& scene, const State<double>& s)
      : H0(scene.energy(s)), mu0(scene.momentum_map(s)), pi0(scene.spatial_momentum(s)) {}
  void update(const SceneT& scene, const State<double>& s) {
    max_dH = std::max(max_dH, std::abs(scene.energy(s) - H0) / std::abs(H0));
    if constexpr (SceneT::is_free)
      max_dmu = std::max(max_dmu, (scene.spatial_momentum(s) - pi0).norm() / pi0.norm());
    else
      max_dmu = std::max(max_dmu, std::abs(scene.momentum_map(s) - mu0) / std::abs(mu0));
  }
};

struct RunResult {
  State<double> end;
  long steps = 0;
  long newton = 0;
  long rhs = 0;
  double max_dH = 0, max_dmu = 0;
  bool ok = true;
  std::string why;
};

/// n steps of a trompo stepper (Stepper or ComposedStepper). Instrumented: also tracks
/// the invariants after every step and counts Newton iterations.
template <bool Instrumented, class StepperT, class SceneT>
RunResult run_trompo(const StepperT& stepper, const cases::Case<SceneT>& c, double h, long n) {
  RunResult r;
  State<double> s = c.initial;
  Invariants<SceneT> inv(c.scene, s);
  for (long i = 0; i < n; ++i) {
    const StepReport<double> rep = stepper.step(s, h);
    if (!rep.ok()) {
      r.ok = false;
      r.why = rep.reason();
      break;
    }
    if constexpr (Instrumented) {
      r.newton += rep.iterations;
      inv.update(c.scene, s);
    }
    ++r.steps;
  }
  r.end = s;
  r.max_dH = inv.max_dH;
  r.max_dmu = inv.max_dmu;
  return r;
}

#ifdef TROMPO_HAVE_BOOST
template <bool Instrumented, class SceneT>
RunResult run_odeint_rk4(const cases::Case<SceneT>& c, double h, long n) {
  RunResult r;
  bench::QuaternionOde<SceneT> ode{&c.scene};
  bench::OdeState x = bench::to_ode(c.initial);
  Invariants<SceneT> inv(c.scene, c.initial);
  bench::odeint_rk4(ode, x, c.initial.time, h, n, [&](const bench::OdeState& y, double t) {
    if constexpr (Instrumented) inv.update(c.scene, bench::from_ode(y, t));
  });
  r.end = bench::from_ode(x, c.initial.time + double(n) * h);
  r.steps = n;
  r.rhs = ode.evaluations;
  r.max_dH = inv.max_dH;
  r.max_dmu = inv.max_dmu;
  return r;
}

template <bool Instrumented, class SceneT>
RunResult run_odeint_dopri5(const cases::Case<SceneT>& c, double tol) {
  RunResult r;
  bench::QuaternionOde<SceneT> ode{&c.scene};
  bench::OdeState x = bench::to_ode(c.initial);
  Invariants<SceneT> inv(c.scene, c.initial);
  r.steps = bench::odeint_dopri5(ode, x, c.initial.time, c.t_end, tol, [&](const bench::OdeState& y, double t) {
    if constexpr (Instrumented) inv.update(c.scene, bench::from_ode(y, t));
  });
  r.end = bench::from_ode(x, c.t_end);
  r.rhs = ode.evaluations;
  r.max_dH = inv.max_dH;
  r.max_dmu = inv.max_dmu;
  return r;
}
#endif

// ---- reporting -----------------------------------------------------------------------------

std::string num(double x) {
  std::ostringstream os;
  os << std::setprecision(6) << x;
  return os.str();
}

/// Sets the counters and label of a sweep benchmark from its instrumented run; false (and
/// the benchmark marked as an error, its loop skipped) if the run failed.
template <class SceneT>
bool report(benchmark::State& st, const Problem<SceneT>& p, const RunResult& r, double h, const std::string& label) {
  st.SetLabel(label);
  if (!r.ok) {
    st.SkipWithError(("step failed at t = " + num(r.end.time) + ": " + r.why).c_str());
    return false;
  }
  const double steps = double(r.steps);
  st.counters["steps"] = steps;
  st.counters["h"] = h;
  st.counters["max_dH"] = r.max_dH;
  st.counters["max_dmu"] = r.max_dmu;
  st.counters["err_rot"] = (r.end.rotation.matrix() - p.ref.rotation).norm();
  st.counters["err_omega"] = (r.end.omega - p.ref.omega).norm() / p.ref.omega.norm();
  st.counters["newton"] = steps > 0 ? double(r.newton) / steps : 0.0;
  st.counters["rhs"] = double(r.rhs);
  return true;
}

std::string label_of(const std::string& case_name, const std::string& method, const std::string& scheme, int order,
                     double h, double tol = 0, int stages = 1) {
  std::ostringstream os;
  os << std::setprecision(10) << "case=" << case_name << ";method=" << method << ";scheme=" << scheme
     << ";order=" << order << ";h=" << h << ";tol=" << tol << ";stages=" << stages;
  return os.str();
}

/// scheme, scheme-o4 (triple jump), scheme-o4s (Suzuki's five steps), scheme-o6 (Kahan–Li).
std::string method_name(const char* scheme, Composition method) {
  switch (method) {
    case Composition::base: return scheme;
    case Composition::triple_jump: return std::string(scheme) + "-o4";
    case Composition::suzuki5: return std::string(scheme) + "-o4s";
    case Composition::kahan_li9: return std::string(scheme) + "-o6";
  }
  return scheme;
}
std::string method_name(const char* scheme, int order) { return method_name(scheme, composition_of_order(order)); }

std::string h_text(double h) {
  std::ostringstream os;
  os << std::scientific << std::setprecision(3) << h;
  return os.str();
}

constexpr double sweep_min_time = 0.05;

// ---- sweep family ----------------------------------------------------------------------------

template <class Scheme, class SceneT>
void register_sweep(const Problem<SceneT>& p, Scheme scheme, Composition composition, const Grid& g) {
  const std::string method = method_name(Scheme::name, composition);
  for (double h : grid(g, p.c.t_end)) {
    const std::string name = "sweep/" + std::string(p.c.name) + "/" + method + "/h:" + h_text(h);
    benchmark::RegisterBenchmark(name.c_str(), [&p, scheme, composition, h, method](benchmark::State& st) {
      const ComposedStepper<Scheme, SceneT> stepper(scheme, p.c.scene, composition);
      const long n = std::lround(p.c.t_end / h);
      // The instrumented run first: a configuration that fails is reported, not timed.
      const RunResult r = run_trompo<true>(stepper, p.c, h, n);
      if (!report(st, p, r, h, label_of(p.c.name, method, Scheme::name, stepper.order(), h, 0, stepper.stages())))
        return;
      for (auto _ : st) {
        RunResult timed = run_trompo<false>(stepper, p.c, h, n);
        benchmark::DoNotOptimize(timed.end);
      }
    })->MinTime(sweep_min_time)->Unit(benchmark::kMillisecond);
  }
}

template <class SceneT>
void register_sweep_rk4(const Problem<SceneT>& p) {
  for (double h : grid(p.rk4, p.c.t_end)) {
    const std::string name = "sweep/" + std::string(p.c.name) + "/rk4/h:" + h_text(h);
    benchmark::RegisterBenchmark(name.c_str(), [&p, h](benchmark::State& st) {
      const Stepper<RK4, SceneT> stepper(RK4{}, p.c.scene);
      const long n = std::lround(p.c.t_end / h);
      RunResult r = run_trompo<true>(stepper, p.c, h, n);
      r.rhs = 4 * r.steps;
      if (!report(st, p, r, h, label_of(p.c.name, "rk4", "rk4", 4, h))) return;
      for (auto _ : st) {
        RunResult timed = run_trompo<false>(stepper, p.c, h, n);
        benchmark::DoNotOptimize(timed.end);
      }
    })->MinTime(sweep_min_time)->Unit(benchmark::kMillisecond);
  }
#ifdef TROMPO_HAVE_BOOST
  for (double h : grid(p.rk4, p.c.t_end)) {
    const std::string name = "sweep/" + std::string(p.c.name) + "/odeint-rk4/h:" + h_text(h);
    benchmark::RegisterBenchmark(name.c_str(), [&p, h](benchmark::State& st) {
      const long n = std::lround(p.c.t_end / h);
      const RunResult r = run_odeint_rk4<true>(p.c, h, n);
      if (!report(st, p, r, h, label_of(p.c.name, "odeint-rk4", "odeint-rk4", 4, h))) return;
      for (auto _ : st) {
        RunResult timed = run_odeint_rk4<false>(p.c, h, n);
        benchmark::DoNotOptimize(timed.end);
      }
    })->MinTime(sweep_min_time)->Unit(benchmark::kMillisecond);
  }
  // dopri5: tolerances 1e-3 … 1e-14, half a decade apart.
  for (int k = 6; k <= 28; ++k) {
    const double tol = std::pow(10.0, -0.5 * k);
    const std::string name = "sweep/" + std::string(p.c.name) + "/odeint-dopri5/tol:" + h_text(tol);
    benchmark::RegisterBenchmark(name.c_str(), [&p, tol](benchmark::State& st) {
      const RunResult r = run_odeint_dopri5<true>(p.c, tol);
      const double h_mean = p.c.t_end / double(std::max(1L, r.steps));
      if (!report(st, p, r, h_mean, label_of(p.c.name, "odeint-dopri5", "odeint-dopri5", 5, h_mean, tol))) return;
      for (auto _ : st) {
        RunResult timed = run_odeint_dopri5<false>(p.c, tol);
        benchmark::DoNotOptimize(timed.end);
      }
    })->MinTime(sweep_min_time)->Unit(benchmark::kMillisecond);
  }
#endif
}

template <class SceneT>
void register_sweeps(const Problem<SceneT>& p) {
  register_sweep(p, SimoAlpha{}, Composition::base, p.o2);
  register_sweep(p, GeradinBauchauPaper{}, Composition::base, p.o2);
  register_sweep(p, SimoKappa{}, Composition::base, p.o2);
  register_sweep(p, SimoCollocation{}, Composition::base, p.o2);
  register_sweep(p, GeradinBauchau{}, Composition::base, p.o2);
  for (Composition m : {Composition::triple_jump, Composition::suzuki5, Composition::kahan_li9}) {
    const Grid& g = m == Composition::triple_jump ? p.o4 : m == Composition::suzuki5 ? p.o4s : p.o6;
    register_sweep(p, SimoKappa{}, m, g);
    register_sweep(p, SimoCollocation{}, m, g);
    register_sweep(p, GeradinBauchau{}, m, g);
  }
  register_sweep_rk4(p);
}

// ---- per-step family ---------------------------------------------------------------------------

template <class StepperT, class SceneT>
void step_loop(benchmark::State& st, const StepperT& stepper, const Problem<SceneT>& p) {
  const double h = p.h_step;
  State<double> s = p.c.initial;
  long newton = 0;
  for (auto _ : st) {
    const StepReport<double> rep = stepper.step(s, h);
    newton += rep.iterations;
    benchmark::DoNotOptimize(s);
    if (s.time > p.c.t_end) s = p.c.initial;  // stay on the case's trajectory
  }
  st.counters["newton"] = benchmark::Counter(double(newton), benchmark::Counter::kAvgIterations);
  st.counters["h"] = h;
}

constexpr double step_min_time = 0.25;
constexpr int step_repetitions = 3;

template <class Scheme, class SceneT, class Method>
void register_step(const Problem<SceneT>& p, Scheme scheme, Method order) {
  const std::string method = method_name(Scheme::name, order);
  const std::string name = "step/" + std::string(p.c.name) + "/" + method;
  benchmark::RegisterBenchmark(name.c_str(), [&p, scheme, order, method](benchmark::State& st) {
    const ComposedStepper<Scheme, SceneT> stepper(scheme, p.c.scene, order);
    step_loop(st, stepper, p);
    st.counters["substeps"] = stepper.stages();
    st.SetLabel(label_of(p.c.name, method, Scheme::name, stepper.order(), p.h_step, 0, stepper.stages()));
  })->MinTime(step_min_time)->Repetitions(step_repetitions)->Unit(benchmark::kNanosecond);
}

template <class SceneT>
void register_steps(const Problem<SceneT>& p) {
  // RK4 first and the energy-exact schemes right after it, so that the ratio of the
  // targets compares runs made close together in time.
  benchmark::RegisterBenchmark(("step/" + std::string(p.c.name) + "/rk4").c_str(), [&p](benchmark::State& st) {
    const Stepper<RK4, SceneT> stepper(RK4{}, p.c.scene);
    step_loop(st, stepper, p);
    st.counters["substeps"] = 1;
    st.SetLabel(label_of(p.c.name, "rk4", "rk4", 4, p.h_step));
  })->MinTime(step_min_time)->Repetitions(step_repetitions)->Unit(benchmark::kNanosecond);
  register_step(p, SimoKappa{}, 2);
#ifdef TROMPO_HAVE_BOOST
  benchmark::RegisterBenchmark(("step/" + std::string(p.c.name) + "/odeint-rk4").c_str(), [&p](benchmark::State& st) {
    namespace odeint = boost::numeric::odeint;
    bench::QuaternionOde<SceneT> ode{&p.c.scene};
    odeint::runge_kutta4<bench::OdeState> rk;
    const bench::OdeState x0 = bench::to_ode(p.c.initial);
    bench::OdeState x = x0;
    double t = 0;
    for (auto _ : st) {
      rk.do_step(std::cref(ode), x, t, p.h_step);
      t += p.h_step;
      benchmark::DoNotOptimize(x);
      if (t > p.c.t_end) {
        x = x0;
        t = 0;
      }
    }
    st.counters["newton"] = 0;
    st.counters["h"] = p.h_step;
    st.counters["substeps"] = 1;
    st.SetLabel(label_of(p.c.name, "odeint-rk4", "odeint-rk4", 4, p.h_step));
  })->MinTime(step_min_time)->Repetitions(step_repetitions)->Unit(benchmark::kNanosecond);
#endif
  register_step(p, SimoAlpha{}, 2);
  register_step(p, SimoCollocation{}, 2);
  register_step(p, GeradinBauchau{}, 2);
  register_step(p, GeradinBauchauPaper{}, 2);
  for (Composition m : {Composition::triple_jump, Composition::suzuki5, Composition::kahan_li9}) {
    register_step(p, SimoKappa{}, m);
    register_step(p, SimoCollocation{}, m);
    register_step(p, GeradinBauchau{}, m);
  }
}

// ---- the long run: energy error over time ----------------------------------------------------

/// Writes, for each method, |ΔH/H| over a long HT1 run (h = 1e-3, 5·10⁵ steps to t = 500):
/// the maximum over each window of one time unit (1000 steps), one row per window. Also
/// dopri5 at tolerance 1e-10, windowed the same way.
int energy_series(const std::string& path) {
  const auto c = cases::ht1<double>();
  const double h = 1e-3;
  const long n = 500000;
  const double window = 1.0;
  std::ofstream out(path);
  if (!out) {
    std::fprintf(stderr, "trompo-bench: cannot write %s\n", path.c_str());
    return 1;
  }
  out << "method,t,max_dH\n" << std::setprecision(6);
  const double H0 = c.scene.energy(c.initial);
  // Collects max |ΔH/H| per window of time.
  struct Windows {
    std::ofstream& out;
    std::string method;
    double H0, window;
    double worst = 0, next;
    void add(double t, double H) {
      worst = std::max(worst, std::abs(H - H0) / std::abs(H0));
      if (t >= next - 1e-9) {
        out << method << ',' << next << ',' << worst << '\n';
        worst = 0;
        next += window;
      }
    }
  };
  auto timed = [&](const std::string& method, auto&& body) {
    const auto t0 = std::chrono::steady_clock::now();
    Windows w{out, method, H0, window, 0.0, window};
    body(w);
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fprintf(stderr, "energy series: %-24s %.2f s\n", method.c_str(), sec);
  };
  auto fixed_step = [&](const std::string& method, auto&& step) {
    timed(method, [&](Windows& w) {
      State<double> s = c.initial;
      for (long i = 1; i <= n; ++i) {
        if (!step(s)) {
          std::fprintf(stderr, "trompo-bench: %s failed at t = %g\n", method.c_str(), s.time);
          return;
        }
        w.add(double(i) * h, c.scene.energy(s));
      }
    });
  };
  auto trompo_series = [&](auto scheme, int order) {
    using Scheme = decltype(scheme);
    const ComposedStepper<Scheme, Top> stepper(scheme, c.scene, order);
    fixed_step(method_name(Scheme::name, order), [&](State<double>& s) { return stepper.step(s, h).ok(); });
  };
  trompo_series(SimoAlpha{}, 2);
  trompo_series(SimoKappa{}, 2);
  trompo_series(SimoCollocation{}, 2);
  trompo_series(GeradinBauchau{}, 2);
  trompo_series(GeradinBauchauPaper{}, 2);
  trompo_series(SimoKappa{}, 4);
  trompo_series(SimoKappa{}, 6);
  {
    const Stepper<RK4, Top> rk4(RK4{}, c.scene);
    fixed_step("rk4", [&](State<double>& s) { return rk4.step(s, h).ok(); });
  }
#ifdef TROMPO_HAVE_BOOST
  {
    namespace odeint = boost::numeric::odeint;
    bench::QuaternionOde<Top> ode{&c.scene};
    odeint::runge_kutta4<bench::OdeState> rk;
    bench::OdeState x = bench::to_ode(c.initial);
    long i = 0;
    fixed_step("odeint-rk4", [&](State<double>& s) {
      rk.do_step(std::cref(ode), x, s.time, h);
      ++i;
      s = bench::from_ode(x, double(i) * h);
      return true;
    });
    timed("odeint-dopri5-tol1e-10", [&](Windows& w) {
      bench::QuaternionOde<Top> ode5{&c.scene};
      bench::OdeState y = bench::to_ode(c.initial);
      bench::odeint_dopri5(ode5, y, 0.0, double(n) * h, 1e-10, [&](const bench::OdeState& z, double t) {
        w.add(t, c.scene.energy(bench::from_ode(z, t)));
      });
    });
  }
#endif
  return 0;
}

// ---- context ----------------------------------------------------------------------------------

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(colon + 2);
    }
  return "unknown";
}

template <class SceneT>
void add_reference_context(const Problem<SceneT>& p) {
  const std::string key = std::string("reference_") + p.c.name;
  benchmark::AddCustomContext(key, p.ref.source);
  benchmark::AddCustomContext(key + "_check", p.ref.check);
}

}  // namespace

int main(int argc, char** argv) {
  // Our own flags first; Google Benchmark rejects flags it does not know.
  std::string series_path;
  std::vector<char*> args;
  for (int i = 0; i < argc; ++i) {
    const char* flag = "--trompo_energy_series=";
    if (std::strncmp(argv[i], flag, std::strlen(flag)) == 0)
      series_path = argv[i] + std::strlen(flag);
    else
      args.push_back(argv[i]);
  }
  if (!series_path.empty()) return energy_series(series_path);
  int n_args = int(args.size());
  benchmark::Initialize(&n_args, args.data());
  if (benchmark::ReportUnrecognizedArguments(n_args, args.data())) return 1;

  // The cases and their step-size grids (h ranges chosen so that every method spans from
  // its largest workable step down to errors near 1e-10 or round-off, within the time
  // budget of scripts/report.sh).
  //                                       h_step  order 2        order 4 (3 st.)  order 6       RK4 (ours, odeint) order 4 (Suzuki)
  tops.push_back({cases::ht0<double>(), {}, 1e-3, {1e-2, 5e-5}, {1e-2, 1e-4}, {2e-2, 5e-4}, {1e-2, 2e-5}, {2e-2, 2e-4}});
  tops.push_back({cases::ht1<double>(), {}, 1e-3, {1e-2, 5e-5}, {1e-2, 1e-4}, {2e-2, 5e-4}, {1e-2, 2e-5}, {2e-2, 2e-4}});
  tops.push_back({cases::ht2<double>(), {}, 1e-3, {2e-3, 1e-5}, {2e-3, 2.5e-5}, {4e-3, 1e-4}, {2e-3, 1e-5}, {4e-3, 5e-5}});
  frees.push_back({cases::fb1<double>(), {}, 1e-2, {1e-1, 4e-4}, {2e-1, 1e-3}, {4e-1, 4e-3}, {1e-1, 2e-4}, {2e-1, 2e-3}});

  const auto t0 = std::chrono::steady_clock::now();
  auto check = [](Reference& r, const Reference& other, const std::string& what) {
    r.check = "differs from " + what + " by " + num(distance(r, other));
  };
  tops[0].ref = lagrange_reference(tops[0].c, 5.0, 1.0);
  tops[1].ref = lagrange_reference(tops[1].c, 5.0, 1.0);
  frees[0].ref = free_body_reference(frees[0].c);
  check(tops[0].ref, from_published(published_ht0, ""), "the published closed form");
  check(tops[1].ref, from_published(published_ht1, ""), "the published closed form");
  check(frees[0].ref, from_published(published_fb1, ""), "the published closed form");
  // HT2 has no closed form in trompo. A converged composed run (h = 5e-4) agrees with the
  // published 128-bit RKF7(8) solution to ~1e-11 (its round-off over 36,000 sub-steps),
  // and it is itself a point of the sweep; so the sweep measures against the published
  // solution, exact to double precision, and the composed run is the cross-check.
  tops[2].ref = from_published(published_ht2, "published RKF7(8) solution in 128-bit floats (tolerance 1e-26)");
  check(tops[2].ref, composed_reference(tops[2].c, 4000), "a converged composed run (simo-kappa, order 6, h = 5e-4)");
  const double ref_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  benchmark::AddCustomContext("cpu_model", cpu_model());
#ifdef NDEBUG
  benchmark::AddCustomContext("trompo_build", "optimised (NDEBUG)");
#else
  benchmark::AddCustomContext("trompo_build", "assertions on (not a Release build)");
#endif
  benchmark::AddCustomContext("compiler", __VERSION__);
#ifdef TROMPO_HAVE_BOOST
  benchmark::AddCustomContext("odeint", "Boost " + std::to_string(BOOST_VERSION / 100000) + "." +
                                            std::to_string(BOOST_VERSION / 100 % 1000));
#else
  benchmark::AddCustomContext("odeint", "not available (Boost not found)");
#endif
  benchmark::AddCustomContext("reference_seconds", num(ref_seconds));
  for (const auto& p : tops) add_reference_context(p);
  for (const auto& p : frees) add_reference_context(p);

  // Per-step family on HT1, HT2, FB1; the sweep on all four cases.
  register_steps(tops[1]);
  register_steps(tops[2]);
  register_steps(frees[0]);
  for (const auto& p : tops) register_sweeps(p);
  for (const auto& p : frees) register_sweeps(p);

  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
