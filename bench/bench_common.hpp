#pragma once
// The machinery of trompo-bench (bench_main.cpp): references, problems, instrumented runs,
// labels, and the registration of sweep and per-step benchmarks. Every trompo run goes
// through the library's driver, trompo::integrate() (drivers/integrate.hpp), with recovery
// off: its grid, its handling of a scheme's memory (a fresh trajectory per run) and its
// deferred output (a processed composition without observer outputs once) are the ones
// timed, not a copy of them here. bench_main.cpp registers
// the implicit schemes, RK4 and the odeint baselines; every file in bench/methods/ adds a
// family of methods to the same executable through a MethodFamily (at the end of this
// file), so that all methods are timed in one run on the same problems.

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
#include <tuple>
#include <vector>

#include "trompo/drivers/integrate.hpp"
#include "data/reference_cases.hpp"  // tests/data: the project's one reference set
#include "trompo/model/cases.hpp"
#include "trompo/schemes/registry.hpp"
#include "trompo/steppers/composition.hpp"
#include "trompo/steppers/processed_composition.hpp"
#include "trompo/steppers/stepper.hpp"

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

namespace trompo_bench {
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

/// The published solutions at each case's end time (docs/theory.md §8), rows of the
/// project's one reference set (tests/data/reference_cases.hpp): closed forms at 40 digits
/// (HT0, HT1, FB1), RKF7(8) in 128-bit floats (HT2), exact to double precision.
inline const double* const published_ht0 = trompo_test::reference::ht0[20];  // t = 10
inline const double* const published_ht1 = trompo_test::reference::ht1[20];  // t = 10
inline const double* const published_ht2 = trompo_test::reference::ht2[1];   // t = 2
inline const double* const published_fb1 = trompo_test::reference::fb1[20];  // t = 100

/// A row of the reference set as a Reference.
inline Reference from_published(const double* row, const std::string& source) {
  using trompo_test::reference::omega_of, trompo_test::reference::rotation_of;
  return {Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(rotation_of(row)),
          V3(omega_of(row)[0], omega_of(row)[1], omega_of(row)[2]), source, ""};
}

/// ‖ΔΛ‖_F + ‖ΔΩ‖/‖Ω‖ between two references.
inline double distance(const Reference& a, const Reference& b) {
  return (a.rotation - b.rotation).norm() + (a.omega - b.omega).norm() / b.omega.norm();
}

/// A converged composed run: Simo-κ, order 6, n steps to t_end.
template <class SceneT>
Reference composed_reference(const cases::Case<SceneT>& c, long n) {
  const ComposedStepper<SimoKappa, SceneT> stepper(SimoKappa{}, c.scene, 6);
  State<double> s = c.initial;
  const double h = c.t_end / double(n);
  if (!integrate(stepper, s, c.initial.time + double(n) * h, h, NoObserver{}, IntegrateOptions{.max_halvings = 0}).ok())
    throw std::runtime_error("trompo-bench: the reference run failed");
  std::ostringstream os;
  os << "converged composed run (simo-kappa, order 6, h = " << h << ")";
  return {s.rotation.matrix(), s.omega, os.str(), ""};
}

inline Reference lagrange_reference(const cases::Case<Top>& c, double A, double C) {
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

inline Reference free_body_reference(const cases::Case<Free>& c) {
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
  /// h_k = hi·2^(−step·k): √2 apart by default; a method of high order may take ¼ so that
  /// its error is resolved as finely as dopri5's half decades of tolerance.
  double step = 0.5;
};

template <class SceneT>
struct Problem {
  cases::Case<SceneT> c;
  Reference ref;
  double h_step;  ///< representative h for the per-step family
  Grid o2, o4, o6, rk4, o4s;
};

inline std::deque<Problem<Top>> tops;    // stable addresses for the registered lambdas
inline std::deque<Problem<Free>> frees;

inline std::vector<double> grid(const Grid& g, double t_end) {
  std::vector<double> hs;
  for (int k = 0;; ++k) {
    const double h = g.hi * std::pow(2.0, -g.step * k);
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

/// The bench's runs: no recovery by sub-stepping, so that a configuration whose step fails
/// is reported as failed (and not timed), not timed with sub-steps.
inline constexpr IntegrateOptions no_recovery{.max_halvings = 0};

/// What a per-step loop steps: the stepper's Trajectory (state and scheme memory, e.g. the
/// history predictor's) if it has one, else the State.
template <class StepperT>
auto start_of(const StepperT& stepper, const State<double>& s) {
  if constexpr (requires { stepper.start(s); }) return stepper.start(s);
  else return s;
}

/// n steps of h of a trompo stepper (Stepper, ComposedStepper, ProcessedStepper) from the
/// case's initial state, by trompo::integrate. Timed (Instrumented = false): no observer,
/// so a processed composition advances its kernel and outputs once at the end. Instrumented:
/// an observer tracks the invariants after every step (a processed composition then outputs
/// every step) and the summary gives the Newton iterations.
template <bool Instrumented, class StepperT, class SceneT>
RunResult run_trompo(const StepperT& stepper, const cases::Case<SceneT>& c, double h, long n) {
  RunResult r;
  State<double> s = c.initial;
  const double t_end = c.initial.time + double(n) * h;
  IntegrationSummary<double> sum;
  Invariants<SceneT> inv(c.scene, s);
  if constexpr (Instrumented) {
    sum = integrate(stepper, s, t_end, h, [&](const State<double>& x) { inv.update(c.scene, x); }, no_recovery);
    r.newton = sum.iterations;
  } else {
    sum = integrate(stepper, s, t_end, h, NoObserver{}, no_recovery);
  }
  r.steps = sum.steps;
  r.ok = sum.ok();
  if (!r.ok) r.why = sum.reason();
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

inline std::string num(double x) {
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

inline std::string label_of(const std::string& case_name, const std::string& method, const std::string& scheme, int order,
                     double h, double tol = 0, int stages = 1) {
  std::ostringstream os;
  os << std::setprecision(10) << "case=" << case_name << ";method=" << method << ";scheme=" << scheme
     << ";order=" << order << ";h=" << h << ";tol=" << tol << ";stages=" << stages;
  return os.str();
}

/// scheme, scheme-o4 (triple jump), scheme-o4s (Suzuki's five steps), scheme-o6 (Kahan–Li),
/// scheme-o8 (Kahan–Li, 17 steps), scheme-o8m (McLachlan, 15 steps).
inline std::string method_name(const char* scheme, Composition method) {
  switch (method) {
    case Composition::base: return scheme;
    case Composition::triple_jump: return std::string(scheme) + "-o4";
    case Composition::suzuki5: return std::string(scheme) + "-o4s";
    case Composition::kahan_li9: return std::string(scheme) + "-o6";
    case Composition::mclachlan15: return std::string(scheme) + "-o8m";
    case Composition::kahan_li17: return std::string(scheme) + "-o8";
  }
  return scheme;
}
inline std::string method_name(const char* scheme, int order) { return method_name(scheme, composition_of_order(order)); }

inline std::string h_text(double h) {
  std::ostringstream os;
  os << std::scientific << std::setprecision(3) << h;
  return os.str();
}

inline constexpr double sweep_min_time = 0.05;

// ---- sweep family ----------------------------------------------------------------------------

/// The number of sub-steps of a stepper's step (1 for a plain Stepper).
template <class StepperT>
int stages_of(const StepperT& stepper) {
  if constexpr (requires { stepper.stages(); }) return stepper.stages();
  else return 1;
}

/// Registers sweep/<case>/<method>/h:<h> for every h of the grid: one run to the case's
/// end time with the stepper that `make(scene)` returns (anything with step(State&, h) and
/// order(); stages() if it has sub-steps). `scheme` goes into the label.
template <class SceneT, class MakeStepper>
void register_sweep_with(const Problem<SceneT>& p, const std::string& method, const std::string& scheme,
                         const Grid& g, MakeStepper make) {
  for (double h : grid(g, p.c.t_end)) {
    const std::string name = "sweep/" + std::string(p.c.name) + "/" + method + "/h:" + h_text(h);
    benchmark::RegisterBenchmark(name.c_str(), [&p, make, h, method, scheme](benchmark::State& st) {
      const auto stepper = make(p.c.scene);
      const long n = std::lround(p.c.t_end / h);
      // The instrumented run first: a configuration that fails is reported, not timed.
      const RunResult r = run_trompo<true>(stepper, p.c, h, n);
      if (!report(st, p, r, h, label_of(p.c.name, method, scheme, stepper.order(), h, 0, stages_of(stepper))))
        return;
      for (auto _ : st) {
        RunResult timed = run_trompo<false>(stepper, p.c, h, n);
        benchmark::DoNotOptimize(timed.end);
      }
    })->MinTime(sweep_min_time)->Unit(benchmark::kMillisecond);
  }
}

/// The sweep of a symmetric scheme composed by `composition` (base = the scheme itself).
template <class Scheme, class SceneT>
void register_sweep(const Problem<SceneT>& p, Scheme scheme, Composition composition, const Grid& g) {
  register_sweep_with(p, method_name(Scheme::name, composition), Scheme::name, g,
                      [scheme, composition](const SceneT& scene) {
                        return ComposedStepper<Scheme, SceneT>(scheme, scene, composition);
                      });
}

#ifdef TROMPO_HAVE_BOOST
/// sweep/<case>/odeint-rk4/h:<h>: odeint's runge_kutta4 at step h to the case's end time.
template <class SceneT>
void register_odeint_rk4(const Problem<SceneT>& p, double h) {
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

/// sweep/<case>/odeint-dopri5/tol:<tol>: odeint's adaptive dopri5 to the case's end time.
template <class SceneT>
void register_odeint_dopri5(const Problem<SceneT>& p, double tol) {
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
  for (double h : grid(p.rk4, p.c.t_end)) register_odeint_rk4(p, h);
  // dopri5: tolerances 1e-3 … 1e-14, half a decade apart.
  for (int k = 6; k <= 28; ++k) register_odeint_dopri5(p, std::pow(10.0, -0.5 * k));
#endif
}


// ---- per-step family ---------------------------------------------------------------------------

/// The timed loop of a per-step benchmark: whole runs of the case from its initial state to
/// its end time (n steps of p.h_step) by trompo::integrate, each counted by Google Benchmark
/// as n iterations (KeepRunningBatch), so the figure is per step. As the old step-by-step
/// loop, every run starts a fresh trajectory (a history predictor refills its memory once
/// a run); a batch shorter than the run would disturb it at every batch's last step (the
/// grid's rounded last h). A stepper with a deferred output (ProcessedStepper) advances its
/// kernel and outputs once a run, as integrate() without observer runs it.
/// A stepper as integrate() sees it, that also sums the residual evaluations and tangents
/// of its StepReports (integrate's summary counts Newton iterations only): the counters
/// `evals` and `tangents` of the per-step family (docs/predictor.md). Forwards step(), and
/// advance/output/time/set_time where the stepper has them, so that integrate() takes the
/// same path (deferred output or not) as with the stepper itself.
template <class StepperT>
struct Counted {
  using Scalar = double;
  const StepperT& stepper;
  mutable long evaluations = 0, tangents = 0;
  StepReport<double> count(const StepReport<double>& rep) const {
    evaluations += rep.evaluations;
    tangents += rep.tangents;
    return rep;
  }
  template <class StateT>
  StepReport<double> step(StateT& s, double h) const {
    return count(stepper.step(s, h));
  }
  template <class StateT>
    requires requires(const StepperT& st, StateT& x) { st.advance(x, 0.0); }
  StepReport<double> advance(StateT& s, double h) const {
    return count(stepper.advance(s, h));
  }
  template <class StateT>
    requires requires(const StepperT& st, StateT& x) { st.output(x); }
  StepReport<double> output(StateT& s) const {
    return count(stepper.output(s));
  }
  template <class StateT>
    requires requires(const StepperT& st, StateT& x) { st.time(x); }
  double time(const StateT& s) const {
    return stepper.time(s);
  }
  template <class StateT>
    requires requires(const StepperT& st, StateT& x) { st.set_time(x, 0.0); }
  void set_time(StateT& s, double t) const {
    stepper.set_time(s, t);
  }
};

template <class StepperT, class SceneT>
void step_loop(benchmark::State& st, const StepperT& stepper, const Problem<SceneT>& p) {
  const double h = p.h_step;
  const long n = std::max(1L, std::lround((p.c.t_end - p.c.initial.time) / h));
  const double t_end = p.c.initial.time + double(n) * h;
  const Counted<StepperT> counted{stepper};
  long newton = 0;
  while (st.KeepRunningBatch(n)) {
    auto s = start_of(stepper, p.c.initial);
    const IntegrationSummary<double> sum = integrate(counted, s, t_end, h, NoObserver{}, no_recovery);
    newton += sum.iterations;
    benchmark::DoNotOptimize(s);
  }
  st.counters["newton"] = benchmark::Counter(double(newton), benchmark::Counter::kAvgIterations);
  st.counters["evals"] = benchmark::Counter(double(counted.evaluations), benchmark::Counter::kAvgIterations);
  st.counters["tangents"] = benchmark::Counter(double(counted.tangents), benchmark::Counter::kAvgIterations);
  st.counters["h"] = h;
}

inline constexpr double step_min_time = 0.25;
inline constexpr int step_repetitions = 3;

/// Registers step/<case>/<method>: the cost of one step at the problem's h_step, with the
/// stepper that `make(scene)` returns (as register_sweep_with).
template <class SceneT, class MakeStepper>
void register_step_with(const Problem<SceneT>& p, const std::string& method, const std::string& scheme,
                        MakeStepper make) {
  const std::string name = "step/" + std::string(p.c.name) + "/" + method;
  benchmark::RegisterBenchmark(name.c_str(), [&p, make, method, scheme](benchmark::State& st) {
    const auto stepper = make(p.c.scene);
    step_loop(st, stepper, p);
    st.counters["substeps"] = stages_of(stepper);
    st.SetLabel(label_of(p.c.name, method, scheme, stepper.order(), p.h_step, 0, stages_of(stepper)));
  })->MinTime(step_min_time)->Repetitions(step_repetitions)->Unit(benchmark::kNanosecond);
}

/// sweep/<case>/<scheme>-p6/h:<h>: the processed order-6 composition of a symmetric scheme.
template <class Scheme, class SceneT>
void register_processed_sweep(const Problem<SceneT>& p, Scheme scheme, const Grid& g) {
  register_sweep_with(p, std::string(Scheme::name) + "-p6", Scheme::name, g,
                      [scheme](const SceneT& scene) { return ProcessedStepper<Scheme, SceneT>(scheme, scene); });
}

/// step/<case>/<scheme>-p6: one kernel step of the processed composition (13 base steps), the
/// cost per step of a run whose output is post-processed once (integrate() without observer).
template <class Scheme, class SceneT>
void register_processed_step(const Problem<SceneT>& p, Scheme scheme) {
  register_step_with(p, std::string(Scheme::name) + "-p6", Scheme::name,
                     [scheme](const SceneT& scene) { return ProcessedStepper<Scheme, SceneT>(scheme, scene); });
}

/// The step of a symmetric scheme composed by `order` (an order 2/4/6 or a Composition).
template <class Scheme, class SceneT, class Method>
void register_step(const Problem<SceneT>& p, Scheme scheme, Method order) {
  register_step_with(p, method_name(Scheme::name, order), Scheme::name, [scheme, order](const SceneT& scene) {
    return ComposedStepper<Scheme, SceneT>(scheme, scene, order);
  });
}

/// step-pair/<case>/<method>/vs:<baseline>: a method's step (or sub-step) against a
/// baseline's step, the two timed in alternation. `setup(p)` returns {run_baseline,
/// run_method, stages, order}: each run takes `pair_steps` steps from the case's first state
/// (false: it failed), and the method's time is divided by `stages` (its base steps per step:
/// a composition's sub-step against its base step; 1 against another scheme's step). Each
/// iteration runs the baseline and then the method, so that the two see the same machine
/// load: measured in two benchmarks minutes apart, such a ratio moved by 40 % with the load
/// (MJ10: 1.42–1.43× for the Simo-κ compositions, whose instruction count says 1.03×).
/// Counters: baseline_ns per baseline step, method_ns per (sub-)step (the runs' sums), ratio
/// the median over the iterations of each pair's method_ns / baseline_ns. The benchmark's
/// time is the method's runs' (manual time).
inline constexpr int pair_steps = 1000;

template <class SceneT, class Setup>
void register_timed_pair(const Problem<SceneT>& p, const std::string& method, const std::string& baseline,
                         const std::string& scheme, Setup setup) {
  const std::string name = "step-pair/" + std::string(p.c.name) + "/" + method + "/vs:" + baseline;
  benchmark::RegisterBenchmark(name.c_str(), [&p, method, baseline, scheme, setup](benchmark::State& st) {
    using clock = std::chrono::steady_clock;
    auto [run_baseline, run_method, stages, order] = setup(p);
    double baseline_s = 0, method_s = 0;
    std::vector<double> ratios;
    ratios.reserve(4096);
    for (auto _ : st) {
      const auto t0 = clock::now();
      const bool ok_baseline = run_baseline();
      const auto t1 = clock::now();
      const bool ok_method = run_method();
      const auto t2 = clock::now();
      if (!ok_baseline || !ok_method) {
        st.SkipWithError("a run of the pair failed");
        return;
      }
      const double tb = std::chrono::duration<double>(t1 - t0).count(), tm = std::chrono::duration<double>(t2 - t1).count();
      baseline_s += tb;
      method_s += tm;
      if (ratios.size() < ratios.capacity()) ratios.push_back(tm / (tb * stages));
      st.SetIterationTime(tm);
    }
    const double runs = double(st.iterations());
    std::sort(ratios.begin(), ratios.end());
    const std::size_t m = ratios.size();
    st.counters["substeps"] = stages;
    st.counters["h"] = p.h_step;
    st.counters["pairs"] = double(m);
    st.counters["baseline_ns"] = 1e9 * baseline_s / (runs * pair_steps);
    st.counters["method_ns"] = 1e9 * method_s / (runs * pair_steps * stages);
    st.counters["ratio"] = m == 0 ? 0.0 : (m % 2 ? ratios[m / 2] : 0.5 * (ratios[m / 2 - 1] + ratios[m / 2]));
    st.SetLabel(label_of(p.c.name, method, scheme, order, p.h_step, 0, stages) + ";baseline=" + baseline);
  })->MinTime(step_min_time)->Repetitions(step_repetitions)->UseManualTime()->Unit(benchmark::kMicrosecond);
}

/// pair_steps steps of `stepper` along a trajectory from p's first state (as step/…).
template <class StepperT, class SceneT>
bool run_pair_steps(const StepperT& stepper, const Problem<SceneT>& p) {
  auto s = start_of(stepper, p.c.initial);
  const IntegrationSummary<double> sum =
      integrate(stepper, s, p.c.initial.time + pair_steps * p.h_step, p.h_step, NoObserver{}, no_recovery);
  benchmark::DoNotOptimize(s);
  return sum.ok();
}

/// The composed stepper that `make(scene)` returns against its base scheme's step, per
/// sub-step: step-pair/<case>/<method>/vs:<scheme>.
template <class Scheme, class SceneT, class MakeStepper>
void register_step_pair(const Problem<SceneT>& p, const std::string& method, Scheme scheme, MakeStepper make) {
  register_timed_pair(p, method, Scheme::name, Scheme::name, [scheme, make](const Problem<SceneT>& q) {
    auto base = std::make_shared<const Stepper<Scheme, SceneT>>(scheme, q.c.scene);
    auto composed = std::make_shared<const decltype(make(q.c.scene))>(make(q.c.scene));
    return std::make_tuple([base, &q] { return run_pair_steps(*base, q); },
                           [composed, &q] { return run_pair_steps(*composed, q); }, stages_of(*composed), composed->order());
  });
}

#ifdef TROMPO_HAVE_BOOST
/// The stepper that `make(scene)` returns against odeint's runge_kutta4 step (the step/…/odeint-rk4
/// loop), per step: step-pair/<case>/<method>/vs:odeint-rk4.
template <class SceneT, class MakeStepper>
void register_pair_vs_odeint_rk4(const Problem<SceneT>& p, const std::string& method, const std::string& scheme,
                                 MakeStepper make) {
  register_timed_pair(p, method, "odeint-rk4", scheme, [make](const Problem<SceneT>& q) {
    namespace odeint = boost::numeric::odeint;
    auto stepper = std::make_shared<const decltype(make(q.c.scene))>(make(q.c.scene));
    auto rk = std::make_shared<odeint::runge_kutta4<bench::OdeState>>();
    const auto odeint_run = [rk, &q] {
      const bench::QuaternionOde<SceneT> ode{&q.c.scene};
      bench::OdeState x = bench::to_ode(q.c.initial);
      double t = q.c.initial.time;
      for (int i = 0; i < pair_steps; ++i) {
        rk->do_step(std::cref(ode), x, t, q.h_step);
        t += q.h_step;
      }
      benchmark::DoNotOptimize(x);
      return true;
    };
    return std::make_tuple(odeint_run, [stepper, &q] { return run_pair_steps(*stepper, q); }, 1, stepper->order());
  });
}
#endif

/// The pairs of the report's target "composed sub-step ≤ 1.05× base step" (docs/predictor.md):
/// each composition of `ms` against its base step, on `p`.
template <class Scheme, class SceneT>
void register_composition_pairs(const Problem<SceneT>& p, Scheme scheme, std::initializer_list<Composition> ms) {
  for (Composition m : ms)
    register_step_pair(p, method_name(Scheme::name, m), scheme,
                       [scheme, m](const SceneT& scene) { return ComposedStepper<Scheme, SceneT>(scheme, scene, m); });
}

/// step-pair/<case>/<scheme>-p6/vs:<scheme>: the processed composition's kernel step (13 base
/// steps, as step/<case>/<scheme>-p6) against its base step.
template <class Scheme, class SceneT>
void register_processed_pair(const Problem<SceneT>& p, Scheme scheme) {
  register_step_pair(p, std::string(Scheme::name) + "-p6", scheme,
                     [scheme](const SceneT& scene) { return ProcessedStepper<Scheme, SceneT>(scheme, scene); });
}

// ---- families of methods from other files ----------------------------------------------------

/// A family of methods that another translation unit of trompo-bench (bench/methods/*.cpp)
/// adds to the run. Define one at namespace scope there:
///
///   const trompo_bench::MethodFamily splitting{"splitting", register_my_steps, register_my_sweeps};
///
/// main() calls every family's `steps` after the core per-step benchmarks and its `sweeps`
/// after the core sweeps; both read the problems from `tops` and `frees` (HT0, HT1, HT2;
/// FB1), which are set up with their references by then. Either may be null.
/// The largest relative change |E − E0|/|E0| over each window of time, for the long-run
/// series (bench_main.cpp: H over 500 time units; methods/satellite.cpp: E_J over 1000
/// orbits): add() every sample; the first sample at or past a window's end calls
/// emit(that end, the window's largest change) and starts the next window.
struct WindowedMax {
  double E0, window, next, worst = 0;
  WindowedMax(double E0_, double window_) : E0(E0_), window(window_), next(window_) {}
  template <class Emit>
  void add(double t, double E, Emit&& emit) {
    worst = std::max(worst, std::abs(E - E0) / std::abs(E0));
    if (t >= next - 1e-9 * window) {
      emit(next, worst);
      worst = 0;
      next += window;
    }
  }
};

/// sat1 over 1000 orbits for the report's satellite figure (methods/satellite.cpp):
/// trompo-bench --trompo_satellite_series=FILE.
int satellite_series(const std::string& path);

struct MethodFamily {
  using Registration = void (*)();
  const char* name;
  Registration steps;
  Registration sweeps;
  MethodFamily(const char* name_, Registration steps_, Registration sweeps_);
};

/// The families registered so far (a function-local static: safe during static initialisation).
inline std::vector<const MethodFamily*>& method_families() {
  static std::vector<const MethodFamily*> families;
  return families;
}

inline MethodFamily::MethodFamily(const char* name_, Registration steps_, Registration sweeps_)
    : name(name_), steps(steps_), sweeps(sweeps_) {
  method_families().push_back(this);
}

}  // namespace trompo_bench
