// The adaptive driver in trompo-bench (drivers/adaptive.hpp, docs/adaptive.md):
//
//   sweep/<case>/adaptive-<method>/tol:<tol>   tolerance sweep (rtol = atol = tol, 10× apart)
//                                              to the case's end time, on HT0, HT1, HT2, FB1
//   sweep/spin-down/adaptive-<method>/tol:<tol> the same on the case whose time scale varies
//                                              (below), orders 4 and 6, beside their fixed-h
//                                              sweeps sweep/spin-down/<method>/h:<h>
//   step-adaptive/ht1/<method>                 one accepted adaptive step at HT1's h_step
//                                              (h held there by max_step): the estimator's
//                                              cost against the same run at fixed h, timed
//                                              in alternation (counter `ratio`)
//
// Methods: simo-kappa (order 2), simo-kappa-o4s (Suzuki's five steps), simo-kappa-o6
// (Kahan–Li's nine), splitting-strang, splitting-suzuki-5, splitting-kahan-li-9. The sweeps
// sit beside the fixed-h sweeps of the same methods (sweep/<case>/<method>/h:…) and odeint's
// dopri5 at the same tolerances (sweep/<case>/odeint-dopri5/tol:…), all from the core run.
// Counters of a sweep: as the fixed-h sweeps (err_rot = ‖ΔΛ‖_F at the end against the case's
// reference, max_dH = max |ΔH/H0|, steps = accepted steps, h = mean step) plus accepted,
// rejected, and newton per accepted step (all attempts' iterations). scripts/report/adaptive.py
// makes the figures and tables of docs/accuracy.md's "Adaptive steps" from the JSON.
#include <chrono>
#include <cmath>
#include <string>

#include "bench_common.hpp"
#include "trompo/drivers/adaptive.hpp"
#include "trompo/model/effects/viscous_damping.hpp"
#include "trompo/schemes/simo/simo_kappa.hpp"
#include "trompo/schemes/splitting/splitting.hpp"

namespace trompo_bench {
namespace {

/// Smallest tolerance of the sweep per order: below it the run costs more than the
/// bench's budget (order 2 at 1e-8 on FB1 would take ~10^7 steps) or sits in round-off.
double smallest_tol(int order) { return order <= 2 ? 1e-7 : order <= 4 ? 1e-11 : 1e-12; }

struct AdaptiveResult {
  RunResult run;
  AdaptiveSummary<double> summary;
};

/// One adaptive run of the case; Instrumented: the invariants after every accepted step.
template <bool Instrumented, class StepperT, class SceneT>
AdaptiveResult run_adaptive(const StepperT& stepper, const cases::Case<SceneT>& c, const AdaptiveOptions<double>& opt) {
  AdaptiveResult r;
  State<double> s = c.initial;
  Invariants<SceneT> inv(c.scene, s);
  if constexpr (Instrumented) {
    r.summary = integrate_adaptive(stepper, s, c.t_end, opt,
                                   [&](const DenseNode<double>&, const DenseNode<double>& b) { inv.update(c.scene, b.state); });
  } else {
    r.summary = integrate_adaptive(stepper, s, c.t_end, opt);
  }
  r.run.end = s;
  r.run.steps = long(r.summary.accepted);
  r.run.newton = long(r.summary.iterations);
  r.run.max_dH = inv.max_dH;
  r.run.max_dmu = inv.max_dmu;
  r.run.ok = r.summary.ok();
  if (!r.run.ok) r.run.why = r.summary.message();
  return r;
}

template <class SceneT, class MakeStepper>
void register_tolerance_sweep(const Problem<SceneT>& p, const std::string& method, const std::string& scheme, int order,
                              MakeStepper make, double tightest = 0) {
  for (int k = 3; k <= 12; ++k) {
    const double tol = std::pow(10.0, -k);
    if (tol < std::max(smallest_tol(order), tightest) * (1 - 1e-9)) break;
    const std::string name = "sweep/" + std::string(p.c.name) + "/adaptive-" + method + "/tol:" + h_text(tol);
    benchmark::RegisterBenchmark(name.c_str(), [&p, make, tol, method, scheme](benchmark::State& st) {
      const auto stepper = make(p.c.scene);
      AdaptiveOptions<double> opt;
      opt.rtol = tol;
      opt.atol = tol;
      const AdaptiveResult r = run_adaptive<true>(stepper, p.c, opt);
      const double h_mean = p.c.t_end / double(std::max(1L, r.run.steps));
      if (!report(st, p, r.run, h_mean,
                  label_of(p.c.name, "adaptive-" + method, scheme, stepper.order(), h_mean, tol, stages_of(stepper))))
        return;
      st.counters["accepted"] = double(r.summary.accepted);
      st.counters["rejected"] = double(r.summary.rejected);
      st.counters["failures"] = double(r.summary.failures);
      st.counters["base_steps"] = double(r.summary.base_steps);
      st.counters["tol"] = tol;
      for (auto _ : st) {
        AdaptiveResult timed = run_adaptive<false>(stepper, p.c, opt);
        benchmark::DoNotOptimize(timed.run.end);
      }
    })->MinTime(sweep_min_time)->Unit(benchmark::kMillisecond);
  }
}

/// step-adaptive/<case>/<method>: the time of one accepted adaptive step at h = h_step
/// (max_step = first_step = h_step and a tolerance loose enough that no step is rejected):
/// the step, its error estimate (the defect [D4] for Simo-κ; for the splitting Richardson's
/// [A8], one coarse step of 8h per 8 steps kept), its norm and the controller [A1]–[A3]. Each iteration runs the same 1000 steps twice, at fixed h (integrate(), as
/// step/<case>/<method>) and adaptive, one after the other, so that the ratio of the two
/// sees the same machine load (on a shared machine, the load drifts between two benchmarks
/// by more than the overhead measured). The benchmark's time is the adaptive runs' (manual
/// time); s_per_step: seconds per accepted adaptive step, plain_s_per_step: per fixed-h step,
/// ratio: their quotient.
template <class SceneT, class MakeStepper>
void register_adaptive_step(const Problem<SceneT>& p, const std::string& method, const std::string& scheme,
                            MakeStepper make) {
  const std::string name = "step-adaptive/" + std::string(p.c.name) + "/" + method;
  benchmark::RegisterBenchmark(name.c_str(), [&p, make, method, scheme](benchmark::State& st) {
    using clock = std::chrono::steady_clock;
    const auto stepper = make(p.c.scene);
    AdaptiveOptions<double> opt;
    opt.rtol = 1e-2;
    opt.atol = 1e-2;
    opt.tolerance_over_span = false;  // per unit time: the same test whatever the run's length
    opt.first_step = p.h_step;
    opt.max_step = p.h_step;
    constexpr int n = 1000;
    const double t_end = p.c.initial.time + n * p.h_step;
    cases::Case<SceneT> c = p.c;
    c.t_end = t_end;
    const AdaptiveResult r = run_adaptive<false>(stepper, c, opt);
    if (!r.run.ok || r.summary.rejected != 0 || r.summary.accepted != n) {
      st.SkipWithError("the adaptive run at fixed h failed, rejected a step or took another number of steps");
      return;
    }
    double plain_seconds = 0, adaptive_seconds = 0;
    for (auto _ : st) {
      const auto t0 = clock::now();
      auto s = start_of(stepper, p.c.initial);
      const IntegrationSummary<double> fixed = integrate(stepper, s, t_end, p.h_step, NoObserver{}, no_recovery);
      benchmark::DoNotOptimize(s);
      benchmark::DoNotOptimize(fixed);
      const auto t1 = clock::now();
      AdaptiveResult timed = run_adaptive<false>(stepper, c, opt);
      benchmark::DoNotOptimize(timed.run.end);
      const auto t2 = clock::now();
      plain_seconds += std::chrono::duration<double>(t1 - t0).count();
      const double a = std::chrono::duration<double>(t2 - t1).count();
      adaptive_seconds += a;
      st.SetIterationTime(a);
    }
    const double runs = double(st.iterations());
    st.counters["accepted"] = double(n);
    st.counters["newton"] = double(r.summary.iterations) / double(n);
    st.counters["h"] = p.h_step;
    st.counters["s_per_step"] = adaptive_seconds / (runs * n);
    st.counters["plain_s_per_step"] = plain_seconds / (runs * n);
    st.counters["ratio"] = adaptive_seconds / plain_seconds;
    st.SetLabel(label_of(p.c.name, "adaptive-" + method, scheme, stepper.order(), p.h_step, 1e-2, stages_of(stepper)));
  })->MinTime(step_min_time)->Repetitions(step_repetitions)->UseManualTime()->Unit(benchmark::kMicrosecond);
}

/// f(method, scheme, order, make) for every configuration measured.
template <class SceneT, class F>
void for_each_configuration(F&& f) {
  for (Composition m : {Composition::base, Composition::suzuki5, Composition::kahan_li9}) {
    const int order = m == Composition::base ? 2 : m == Composition::suzuki5 ? 4 : 6;
    f(method_name(SimoKappa::name, m), std::string(SimoKappa::name), order,
      [m](const SceneT& scene) { return ComposedStepper<SimoKappa, SceneT>(SimoKappa{}, scene, m); });
  }
  struct Named {
    SplittingMethod m;
    const char* name;
    int order;
  };
  for (Named s : {Named{SplittingMethod::strang, "splitting-strang", 2}, Named{SplittingMethod::suzuki_5, "splitting-suzuki-5", 4},
                  Named{SplittingMethod::kahan_li_9, "splitting-kahan-li-9", 6}})
    f(std::string(s.name), std::string(Splitting::name), s.order,
      [m = s.m](const SceneT& scene) { return Stepper<Splitting, SceneT>(Splitting(m), scene); });
}

template <class SceneT>
void sweeps_of(const Problem<SceneT>& p) {
  for_each_configuration<SceneT>([&p](const std::string& method, const std::string& scheme, int order, auto make) {
    register_tolerance_sweep(p, method, scheme, order, make);
  });
}

// The case whose time scale varies (issue: "≥ 2× fewer steps than the best fixed h"): a free
// body J = diag(1, 2, 3) spun at 30 rad/s about its minor axis (Ω₀ = (30, 0.5, 0.5)) under
// viscous damping c = 0.05, to t = 100: the spin falls to 0.2 rad/s, so a fixed h must
// resolve the first seconds and the adaptive steps grow as it decays (tests/test_adaptive.cpp
// has the same body at rtol 1e-6). Simo-κ at orders 4 and 6 only: order 2 at the sweep's
// tolerances would take ~10⁷ steps. The reference: Simo-κ, order 6, h = 1e-3 (100,000
// steps); the runs at h = 5e-4 and 2.5e-4 differ from it by 4e-12 to 2e-11 in ‖ΔΛ‖_F, the
// round-off of ~10⁶ sub-steps over the 600 rad the body turns, so errors below ~1e-10 are
// not resolved (the report leaves such round-off-floor points out of its ratios).
using Damped = Scene<double, ViscousDamping<double>>;
std::deque<Problem<Damped>> spin_downs;

cases::Case<Damped> spin_down() {
  State<double> s;
  s.omega = V3(30, 0.5, 0.5);
  return {"spin-down", Damped(RigidBody<double>(V3(1, 2, 3)), ViscousDamping<double>(0.05)), s, 100.0};
}

void register_spin_down() {
  Problem<Damped>& p = spin_downs.emplace_back(Problem<Damped>{spin_down(), {}, 1e-3, {}, {}, {}, {}, {}});
  p.ref = composed_reference(p.c, 100000);
  benchmark::AddCustomContext("reference_spin-down", p.ref.source);
  const Grid o4{0.05, 2.5e-4}, o6{0.1, 1e-3};
  for (Composition m : {Composition::suzuki5, Composition::kahan_li9}) {
    const int order = m == Composition::suzuki5 ? 4 : 6;
    register_sweep(p, SimoKappa{}, m, order == 4 ? o4 : o6);
    register_tolerance_sweep(p, method_name(SimoKappa::name, m), std::string(SimoKappa::name), order,
                             [m](const Damped& scene) { return ComposedStepper<SimoKappa, Damped>(SimoKappa{}, scene, m); },
                             1e-8);
  }
}

void register_adaptive_sweeps() {
  for (const auto& p : tops) sweeps_of(p);
  for (const auto& p : frees) sweeps_of(p);
  register_spin_down();
}

void register_adaptive_steps() {
  const Problem<Top>& ht1 = tops[1];
  for_each_configuration<Top>([&ht1](const std::string& method, const std::string& scheme, int, auto make) {
    register_adaptive_step(ht1, method, scheme, make);
  });
}

}  // namespace
}  // namespace trompo_bench

const trompo_bench::MethodFamily adaptive{"adaptive", trompo_bench::register_adaptive_steps,
                                          trompo_bench::register_adaptive_sweeps};
