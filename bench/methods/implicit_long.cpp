// trompo-bench, long horizon (docs/predictor.md): the implicit energy-momentum schemes on
// HT0 and HT1 to t = 1000, under the case names "ht0-t1000" and "ht1-t1000".
//
// The explicit baselines of these cases (odeint's dopri5 and RK4) are registered by the
// splitting family (bench/methods/splitting.cpp) on problems with the same names, end time
// and reference, so that both families' rows meet in scripts/report/implicit.py. Building
// with -DTROMPO_IMPLICIT_LONG_EXPLICIT=1 registers them here too (for a measurement without
// the splitting family; off in the repository, so that they do not run twice).
//
// A few grid points per method suffice: the rows that matter are the cheapest ones that
// reach the joint bound (‖ΔΛ‖ ≤ 1e-6 and max |ΔH/H| ≤ 1e-12) or an attitude bound.
// Also here: the order-8 compositions (Kahan–Li, 17 steps) and the processed order-6 method
// (Blanes–Casas–Murua) on the t = 10 cases, and their steps on HT1; and step-pair/ht1/…,
// each composed sub-step against its base step, and Simo-κ's step against odeint's
// runge_kutta4, timed in alternation (bench_common.hpp).
#include "bench_common.hpp"

#ifndef TROMPO_IMPLICIT_LONG_EXPLICIT
#define TROMPO_IMPLICIT_LONG_EXPLICIT 0
#endif

namespace {

using namespace trompo;
using namespace trompo_bench;

std::deque<Problem<Top>> long_tops;  // stable addresses for the registered lambdas

/// The case `c` to t = 1000 under `name`, with the closed-form reference there.
Problem<Top>& long_problem(cases::Case<Top> c, const char* name) {
  c.name = name;
  c.t_end = 1000.0;
  //                        h_step  order 2       order 4       order 6       RK4            order 4 (Suzuki)
  long_tops.push_back({c, {}, 1e-3, {1e-3, 1e-3}, {1e-2, 1e-2}, {2e-2, 5e-3}, {2e-3, 2.5e-4}, {1e-2, 2.5e-3}});
  Problem<Top>& p = long_tops.back();
  p.ref = lagrange_reference(p.c, 5.0, 1.0);
  return p;
}

void register_long_sweeps() {
  for (Problem<Top>* p : {&long_problem(cases::ht0<double>(), "ht0-t1000"), &long_problem(cases::ht1<double>(), "ht1-t1000")}) {
    // Order 4 (Suzuki), 6 (Kahan–Li 9) and 8 (Kahan–Li 17) of the two cheapest exact schemes.
    register_sweep(*p, SimoKappa{}, Composition::suzuki5, p->o4s);
    register_sweep(*p, SimoKappa{}, Composition::kahan_li9, p->o6);
    register_sweep(*p, GeradinBauchau{}, Composition::kahan_li9, p->o6);
    const Grid o8{4e-2, 1e-2};
    register_sweep(*p, SimoKappa{}, Composition::kahan_li17, o8);
    register_sweep(*p, GeradinBauchau{}, Composition::kahan_li17, o8);
    // The processed order-6 method (Blanes–Casas–Murua, 13-step kernel).
    register_processed_sweep(*p, SimoKappa{}, Grid{4e-2, 1e-2});
    // The symplectic LGVI (docs/theory.md §19) beside them: H bounded, not exact, at t = 1000.
    register_sweep(*p, LGVI{}, Composition::base, p->o2);
#if TROMPO_IMPLICIT_LONG_EXPLICIT
    register_sweep_rk4(*p);
#endif
  }
}

/// Order 8 (Kahan–Li, 17 steps) on the t = 10 problems too: a candidate for the cheapest
/// implicit configuration at tight attitude bounds (‖ΔΛ‖ ≤ 1e-10).
void register_order8_sweeps() {
  for (std::size_t i = 0; i < tops.size(); ++i) {
    const Grid g = tops[i].c.t_end < 5 ? Grid{8e-3, 2e-3} : Grid{4e-2, 1e-2};  // HT2 (t = 2) is faster
    register_sweep(tops[i], SimoKappa{}, Composition::kahan_li17, g);
    register_sweep(tops[i], GeradinBauchau{}, Composition::kahan_li17, g);
  }
}

/// The processed order-6 method (Blanes–Casas–Murua) on the t = 10 problems: its kernel's
/// error constant is far below Kahan–Li's, for 13 base steps per step and 24 per run.
void register_processed_sweeps() {
  for (std::size_t i = 0; i < tops.size(); ++i) {
    const Grid g = tops[i].c.t_end < 5 ? Grid{6e-3, 4e-4} : Grid{3e-2, 1.5e-3};  // HT2 (t = 2) is faster
    register_processed_sweep(tops[i], SimoKappa{}, g);
    register_processed_sweep(tops[i], GeradinBauchau{}, g);
  }
}

void register_sweeps_all() {
  register_order8_sweeps();
  register_processed_sweeps();
  register_long_sweeps();
}

/// The order-8 and processed steps on HT1 (cost per sub-step vs the base step).
void register_steps_all() {
  if (tops.size() > 1) {
    register_step(tops[1], SimoKappa{}, Composition::kahan_li17);
    register_processed_step(tops[1], SimoKappa{});
    register_processed_step(tops[1], GeradinBauchau{});
    // the same sub-steps against their base steps, timed in alternation
    register_composition_pairs(tops[1], SimoKappa{},
                               {Composition::suzuki5, Composition::kahan_li9, Composition::kahan_li17});
    register_composition_pairs(tops[1], GeradinBauchau{}, {Composition::suzuki5, Composition::kahan_li9});
    register_processed_pair(tops[1], SimoKappa{});
    register_processed_pair(tops[1], GeradinBauchau{});
#ifdef TROMPO_HAVE_BOOST
    // the base step's target: Simo-κ against odeint's runge_kutta4 step, in alternation too
    register_pair_vs_odeint_rk4(tops[1], SimoKappa::name, SimoKappa::name,
                                [](const Top& scene) { return Stepper<SimoKappa, Top>(SimoKappa{}, scene); });
#endif
  }
}

const trompo_bench::MethodFamily implicit_long{"implicit-long", register_steps_all, register_sweeps_all};

}  // namespace
