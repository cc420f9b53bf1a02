// The spin-exact splitting family in trompo-bench (schemes/splitting.hpp, docs/splitting.md).
//
//   step/<case>/splitting-<method>            per-step cost on HT1, HT2, FB1
//   sweep/<case>/splitting[-projected]-<method>/h:…   the Δt sweep of HT0, HT1, HT2, FB1
//   sweep/ht0-t1000/…, sweep/ht1-t1000/…      t = 1000 (few points), with odeint's dopri5
//                                             and runge_kutta4 in the same run
//   sweep/hta/…, sweep/ht2a/…                 two fast asymmetric heavy tops with a full
//                                             inertia (below), with dopri5
//
// Method names: splitting-strang, splitting-chin-4a, splitting-chin-tj (triple jump of Chin,
// order 6), splitting-suzuki-5, splitting-kahan-li-9; the projected variants [S12] are
// splitting-projected-<method>. scripts/report/splitting.py reads them for the target table.
#include <array>
#include <cstddef>
#include <deque>
#include <string>

#include "bench_common.hpp"
#include "trompo/schemes/splitting/splitting.hpp"

namespace trompo_bench {
namespace {

/// The splitting keeps its working frame as per-trajectory memory (schemes/splitting.hpp):
/// the bench's runs go through trompo::integrate(), which starts a fresh trajectory for every
/// run, and the per-step loop restarts one (bench_common.hpp). So a plain Stepper is run.
const char* short_name(SplittingMethod m) {
  switch (m) {
    case SplittingMethod::strang: return "strang";
    case SplittingMethod::chin_4a: return "chin-4a";
    case SplittingMethod::chin_triple_jump: return "chin-tj";
    case SplittingMethod::suzuki_5: return "suzuki-5";
    case SplittingMethod::kahan_li_9: return "kahan-li-9";
    default: return to_string(m);  // saba2c … sbab3c
  }
}

template <class Scheme>
std::string method_of(SplittingMethod m) {
  return std::string(Scheme::name) + "-" + short_name(m);
}

template <class Scheme, class SceneT>
void sweep(const Problem<SceneT>& p, SplittingMethod m, const Grid& g) {
  register_sweep_with(p, method_of<Scheme>(m), Scheme::name, g, [m](const SceneT& scene) {
    return Stepper<Scheme, SceneT>(Scheme(m), scene);
  });
}

template <class Scheme, class SceneT>
void step(const Problem<SceneT>& p, SplittingMethod m) {
  register_step_with(p, method_of<Scheme>(m), Scheme::name, [m](const SceneT& scene) {
    return Stepper<Scheme, SceneT>(Scheme(m), scene);
  });
}

/// Step-size grids per order (ratio 1/√2), chosen per case from the errors of docs/splitting.md:
/// from about 1e-5 down to about 1e-11 or the round-off floor.
struct SplitGrids {
  Grid o2, o4, o6;
};

template <class SceneT>
void sweep_all(const Problem<SceneT>& p, const SplitGrids& g, bool chin) {
  for (const bool projected : {false, true}) {
    auto one = [&](SplittingMethod m, const Grid& grid) {
      if (projected) sweep<SplittingProjected>(p, m, grid);
      else sweep<Splitting>(p, m, grid);
    };
    one(SplittingMethod::strang, g.o2);
    one(SplittingMethod::suzuki_5, g.o4);
    one(SplittingMethod::kahan_li_9, g.o6);
    if (chin) {
      one(SplittingMethod::chin_4a, g.o4);
      one(SplittingMethod::chin_triple_jump, g.o6);
    }
  }
}

#ifdef TROMPO_HAVE_BOOST
/// dopri5 at the given tolerances and odeint's runge_kutta4 at the given steps (t = 1000
/// and HTA: fewer points than the core sweep, whose finest ones would take minutes there).
template <class SceneT>
void register_baselines(const Problem<SceneT>& p, const std::vector<double>& tolerances,
                        const std::vector<double>& rk4_steps) {
  for (double tol : tolerances) register_odeint_dopri5(p, tol);
  for (double h0 : rk4_steps) register_odeint_rk4(p, p.c.t_end / std::round(p.c.t_end / h0));
}
#endif

// Problems of this family: HT0 and HT1 to t = 1000, and HTA.
std::deque<Problem<Top>> long_tops;

/// HTA: a fast asymmetric heavy top with a full inertia tensor. HT1's top made asymmetric
/// (principal moments 5, 5.5, 1) and turned in the body by R = exp((0.3, −0.2, 0.4)^):
/// J = R diag(5, 5.5, 1) Rᵀ, E = R e3, Mgl = 20, Λ0 = exp(0.05 ê1), Ω0 = R (0, 0, 50),
/// t ∈ [0, 10]. No closed form: the reference is a converged long-double splitting run.
template <class S = double>
cases::Case<cases::Top<S>> hta() {
  using V = Eigen::Matrix<S, 3, 1>;
  using M = Eigen::Matrix<S, 3, 3>;
  const M R = SO3<S>::exp(V(S(0.3), S(-0.2), S(0.4))).matrix();
  State<S> s;
  s.rotation = SO3<S>::exp(V(S(0.05), 0, 0));
  s.omega = R * V(0, 0, 50);
  return {"hta", cases::Top<S>(RigidBody<S>(M(R * V(5, S(5.5), 1).asDiagonal() * R.transpose())),
                               UniformGravity<S>(20, R * V::UnitZ())),
          s, S(10)};
}

/// HT2A: HT2 made asymmetric (J3 = 15.6 instead of 15.234375: 2.4 %) and turned in the body by
/// the same R: J = R diag(15.234375, 0.46875, 15.6) Rᵀ, E = R e2, Mgl = 15·9.81, Λ0 = I,
/// Ω0 = R (0, 150, −4.61538), t ∈ [0, 2]: a fast asymmetric top (150 rad/s).
template <class S = double>
cases::Case<cases::Top<S>> ht2a() {
  using V = Eigen::Matrix<S, 3, 1>;
  using M = Eigen::Matrix<S, 3, 3>;
  const M R = SO3<S>::exp(V(S(0.3), S(-0.2), S(0.4))).matrix();
  State<S> s;
  s.omega = R * V(0, 150, S(-4.61538));
  return {"ht2a", cases::Top<S>(RigidBody<S>(M(R * V(S(15.234375), S(0.46875), S(15.6)).asDiagonal() * R.transpose())),
                                UniformGravity<S>(S(15 * 9.81), R * V::UnitY())),
          s, S(2)};
}

/// HTN (ours): a nearly symmetric fast top, J = R diag(5, 5.05, 1) Rᵀ (1 % asymmetry), E off
/// the axis (R (0.1, 0, 1)/|·|), Mgl = 20, Λ0 = exp(0.1 ê1), Ω0 = R (1, 0.5, 40), t ∈ [0, 10].
template <class S = double>
cases::Case<cases::Top<S>> htn() {
  using V = Eigen::Matrix<S, 3, 1>;
  using M = Eigen::Matrix<S, 3, 3>;
  const M R = SO3<S>::exp(V(S(-0.2), S(0.4), S(0.1))).matrix();
  State<S> s;
  s.rotation = SO3<S>::exp(V(S(0.1), 0, 0));
  s.omega = R * V(1, S(0.5), 40);
  return {"htn", cases::Top<S>(RigidBody<S>(M(R * V(5, S(5.05), 1).asDiagonal() * R.transpose())),
                               UniformGravity<S>(20, R * V(S(0.1), 0, 1).normalized())),
          s, S(10)};
}

/// HTF (ours): a strongly asymmetric fast top, J = R diag(2, 3, 4.5) Rᵀ, E = R (0.3, 0.2, 1)/|·|,
/// Mgl = 10, Λ0 = exp((0.2, −0.1, 0)^), Ω0 = R (20, 3, 30) (tumbling near the max axis), t ∈ [0, 5].
template <class S = double>
cases::Case<cases::Top<S>> htf() {
  using V = Eigen::Matrix<S, 3, 1>;
  using M = Eigen::Matrix<S, 3, 3>;
  const M R = SO3<S>::exp(V(S(0.1), S(0.3), S(-0.2))).matrix();
  State<S> s;
  s.rotation = SO3<S>::exp(V(S(0.2), S(-0.1), 0));
  s.omega = R * V(20, 3, 30);
  return {"htf", cases::Top<S>(RigidBody<S>(M(R * V(2, 3, S(4.5)).asDiagonal() * R.transpose())),
                               UniformGravity<S>(10, R * V(S(0.3), S(0.2), 1).normalized())),
          s, S(5)};
}

/// A converged long-double run: Chin's triple jump on the exact free flow (order 6) with n
/// and n/2 steps; the reference is the finer one, its check the distance between the two.
template <cases::Case<cases::Top<long double>> (*make)()>
Reference long_double_reference(long n) {
  using LD = long double;
  const auto c = make();
  auto run = [&](long steps) {
    const Stepper<Splitting, cases::Top<LD>> st(Splitting(SplittingMethod::chin_triple_jump), c.scene);
    auto traj = st.start(c.initial);
    const LD h = c.t_end / LD(steps);
    for (long i = 0; i < steps; ++i)
      if (!st.step(traj, h).ok()) throw std::runtime_error("trompo-bench: a long-double reference run failed");
    return traj.state();
  };
  const State<LD> fine = run(n), coarse = run(n / 2);
  Reference r{fine.rotation.matrix().template cast<double>(), fine.omega.template cast<double>(),
              "long-double chin-tj on the exact free flow, n = " + std::to_string(n), ""};
  const double d = double((fine.rotation.matrix() - coarse.rotation.matrix()).norm() +
                          (fine.omega - coarse.omega).norm() / fine.omega.norm());
  r.check = "differs from n = " + std::to_string(n / 2) + " by " + num(d);
  return r;
}

void register_splitting_steps() {
  for (const Problem<Top>* p : {&tops[1], &tops[2]}) {
    for (SplittingMethod m : {SplittingMethod::strang, SplittingMethod::chin_4a, SplittingMethod::chin_triple_jump,
                              SplittingMethod::suzuki_5, SplittingMethod::kahan_li_9})
      step<Splitting>(*p, m);
    step<SplittingProjected>(*p, SplittingMethod::strang);
    step<SplittingProjected>(*p, SplittingMethod::chin_4a);
  }
  // On FB1 (asymmetric, torque-free) every method is the exact free flow [F1]–[F7]: these
  // are its per-step cost, beside step/fb1/odeint-rk4.
  for (SplittingMethod m : {SplittingMethod::strang, SplittingMethod::suzuki_5, SplittingMethod::kahan_li_9})
    step<Splitting>(frees[0], m);
#ifdef TROMPO_HAVE_BOOST
  // The Strang step against odeint's runge_kutta4 step on HT1 and FB1 (the report's targets),
  // timed in alternation (bench_common.hpp).
  register_pair_vs_odeint_rk4(tops[1], method_of<Splitting>(SplittingMethod::strang), Splitting::name,
                              [](const Top& scene) { return Stepper<Splitting, Top>(Splitting(SplittingMethod::strang), scene); });
  register_pair_vs_odeint_rk4(frees[0], method_of<Splitting>(SplittingMethod::strang), Splitting::name,
                              [](const Free& scene) { return Stepper<Splitting, Free>(Splitting(SplittingMethod::strang), scene); });
#endif
#if TROMPO_BENCH_EXACT
  // step/fb1/exact-free-body: exact::FreeBody evaluated at any t, one Λ(t) per iteration at
  // 1,000 times spread over [0, 1000] (one call of the free flow over t modulo the period of Π,
  // then the whole periods' precession; Ω(t) costs as much again). Per evaluation, in ns.
  benchmark::RegisterBenchmark("step/fb1/exact-free-body", [](benchmark::State& st) {
    const Problem<Free>& p = frees[0];
    const exact::FreeBody body(p.c.scene.body().inertia().diagonal(), p.c.initial.rotation.matrix(), p.c.initial.omega);
    std::array<double, 1000> times{};
    for (std::size_t i = 0; i < times.size(); ++i) times[i] = 1000.0 * double((i * 617) % times.size()) / double(times.size()) + 0.37;
    std::size_t k = 0;
    for (auto _ : st) {
      benchmark::DoNotOptimize(body.rotation(times[k]));
      k = k + 1 == times.size() ? 0 : k + 1;
    }
    st.SetLabel(label_of("fb1", "exact-free-body", "exact::FreeBody", 0, 1000.0, 0, 1));
  })->MinTime(step_min_time)->Repetitions(step_repetitions)->Unit(benchmark::kNanosecond);
  // step/fb1/free-flow-h100: one Strang step of h = 100 (9.1 half periods of Π) from the same
  // 1,000 states of FB1: the half periods are one turn in closed form [F9], so it costs one
  // call over a remainder of under a quarter period, as an exact::FreeBody evaluation does
  // (issue 37's target: ≤ 1.5× that row).
  benchmark::RegisterBenchmark("step/fb1/free-flow-h100", [](benchmark::State& st) {
    const Problem<Free>& p = frees[0];
    const exact::FreeBody body(p.c.scene.body().inertia().diagonal(), p.c.initial.rotation.matrix(), p.c.initial.omega);
    const Stepper<Splitting, Free> stepper(Splitting(SplittingMethod::strang), p.c.scene);
    std::array<State<double>, 1000> starts{};
    for (std::size_t i = 0; i < starts.size(); ++i) {
      const double t = 1000.0 * double((i * 617) % starts.size()) / double(starts.size()) + 0.37;
      starts[i].rotation = SO3<double>::from_matrix(body.rotation(t));
      starts[i].omega = body.omega(t);
      starts[i].time = t;
    }
    std::size_t k = 0;
    for (auto _ : st) {
      State<double> s = starts[k];
      if (!stepper.step(s, 100.0).ok()) st.SkipWithError("a step of h = 100 failed");
      benchmark::DoNotOptimize(s);
      k = k + 1 == starts.size() ? 0 : k + 1;
    }
    st.SetLabel(label_of("fb1", "free-flow-h100", Splitting::name, 2, 100.0, 0, 1));
  })->MinTime(step_min_time)->Repetitions(step_repetitions)->Unit(benchmark::kNanosecond);
#endif
}

void register_splitting_sweeps() {
  // t = 10 (HT0, HT1), 2 (HT2), 100 (FB1).          order 2          order 4          order 6
  sweep_all(tops[0], {{1e-3, 2e-5}, {2e-2, 5e-4}, {5e-2, 3e-3}}, true);
  sweep_all(tops[1], {{1e-2, 1e-4}, {1e-1, 2e-3}, {2e-1, 1e-2}}, true);
  sweep_all(tops[2], {{1e-3, 1e-5}, {5e-2, 1e-3}, {1e-1, 8e-3}}, true);
  sweep_all(frees[0], {{1e-2, 1e-4}, {2e-1, 5e-3}, {4e-1, 2e-2}}, false);

  // t = 1000: HT0 and HT1 with the closed form at t = 1000; HTA.
  auto ht0 = cases::ht0<double>();
  ht0.name = "ht0-t1000";
  ht0.t_end = 1000;
  auto ht1 = cases::ht1<double>();
  ht1.name = "ht1-t1000";
  ht1.t_end = 1000;
  long_tops.push_back({ht0, lagrange_reference(ht0, 5.0, 1.0), 1e-3, {}, {}, {}, {}, {}});
  long_tops.push_back({ht1, lagrange_reference(ht1, 5.0, 1.0), 1e-3, {}, {}, {}, {}, {}});
  // The asymmetric tops' references: converged long-double runs (the earlier double
  // Kahan–Li-9 references were off by ~2.5e-10, the level of the 1e-10 rows).
  long_tops.push_back({hta<double>(), long_double_reference<hta<long double>>(8000), 1e-3, {}, {}, {}, {}, {}});
  long_tops.push_back({ht2a<double>(), long_double_reference<ht2a<long double>>(8000), 1e-3, {}, {}, {}, {}, {}});
  long_tops.push_back({htn<double>(), long_double_reference<htn<long double>>(8000), 1e-3, {}, {}, {}, {}, {}});
  long_tops.push_back({htf<double>(), long_double_reference<htf<long double>>(8000), 1e-3, {}, {}, {}, {}, {}});
  for (const char* name : {"hta", "ht2a", "htn", "htf"})
    for (const auto& p : long_tops)
      if (std::string(p.c.name) == name)
        benchmark::AddCustomContext(std::string("reference_") + name, p.ref.source + "; " + p.ref.check);
  const Problem<Top>& p0 = long_tops[0];
  const Problem<Top>& p1 = long_tops[1];
  const Problem<Top>& pa = long_tops[2];
  const Problem<Top>& pb = long_tops[3];
  const Problem<Top>& pn = long_tops[4];
  const Problem<Top>& pf = long_tops[5];
  for (const bool projected : {false, true}) {
    auto one = [&](const Problem<Top>& p, SplittingMethod m, const Grid& grid) {
      if (projected) sweep<SplittingProjected>(p, m, grid);
      else sweep<Splitting>(p, m, grid);
    };
    one(p1, SplittingMethod::chin_4a, {0.025, 0.004});
    one(p1, SplittingMethod::chin_triple_jump, {0.07, 0.015});
    one(p0, SplittingMethod::chin_4a, {0.009, 0.0008});
    one(p0, SplittingMethod::chin_triple_jump, {0.025, 0.004});
    if (!projected) {
      one(p1, SplittingMethod::kahan_li_9, {0.05, 0.012});
      one(p0, SplittingMethod::kahan_li_9, {0.018, 0.003});
    }
  }
  // HTA (asymmetric): the Strang compositions (the defaults there) and Chin with its
  // composed free flow.
  sweep<Splitting>(pa, SplittingMethod::strang, {2e-3, 1e-4});
  sweep<Splitting>(pa, SplittingMethod::suzuki_5, {2e-2, 5e-4});
  sweep<Splitting>(pa, SplittingMethod::kahan_li_9, {4e-2, 2e-3});
  sweep<Splitting>(pa, SplittingMethod::chin_4a, {2e-2, 1e-3});
  sweep<Splitting>(pa, SplittingMethod::chin_triple_jump, {4e-2, 3e-3});
  sweep<SplittingProjected>(pa, SplittingMethod::kahan_li_9, {4e-2, 2e-3});
  sweep<Splitting>(pb, SplittingMethod::suzuki_5, {5e-3, 2.5e-4});
  sweep<Splitting>(pb, SplittingMethod::kahan_li_9, {1e-2, 1e-3});
  sweep<Splitting>(pb, SplittingMethod::chin_4a, {5e-3, 2.5e-4});
  sweep<Splitting>(pb, SplittingMethod::chin_triple_jump, {1e-2, 1e-3});
  // The methods on the exact free flow [F8] (Chin's T is exact on these bodies now): the
  // near-integrable compositions with correctors, on HTA, HT2A and our two tops.
  for (SplittingMethod m : {SplittingMethod::saba2c, SplittingMethod::saba3c, SplittingMethod::saba4c,
                            SplittingMethod::sbab2c, SplittingMethod::sbab3c}) {
    sweep<Splitting>(pa, m, {5e-2, 2e-3});
    sweep<Splitting>(pb, m, {1e-2, 5e-4});
    sweep<Splitting>(pn, m, {5e-2, 2e-3});
    sweep<Splitting>(pf, m, {5e-2, 2e-3});
  }
  for (const Problem<Top>* p : {&pn, &pf}) {
    sweep<Splitting>(*p, SplittingMethod::chin_4a, {5e-2, 2e-3});
    sweep<Splitting>(*p, SplittingMethod::chin_triple_jump, {8e-2, 4e-3});
    sweep<Splitting>(*p, SplittingMethod::kahan_li_9, {4e-2, 2e-3});
  }
  // FB1 to t = 100: every method is the exact free flow; large steps.
  sweep<Splitting>(frees[0], SplittingMethod::strang, {100.0, 0.35});
#ifdef TROMPO_HAVE_BOOST
  // t = 1000: dopri5 from tolerance 1e-9 to 1e-14 (HT0 needs 1e-13 for 1e-6 and does not
  // reach 1e-8), and a few runge_kutta4 steps around the bounds (HT0 at 1e-8: h ≈ 3e-5).
  const std::vector<double> tols = {1e-9, 3.1623e-10, 1e-10, 3.1623e-11, 1e-11, 3.1623e-12,
                                    1e-12, 3.1623e-13, 1e-13, 3.1623e-14, 1e-14};
  register_baselines(p1, tols, {2.5e-4, 1.25e-4, 6.25e-5});
  register_baselines(p0, tols, {8.84e-5, 5.26e-5, 4.42e-5});
  register_baselines(pa, {1e-6, 3.1623e-7, 1e-7, 3.1623e-8, 1e-8, 3.1623e-9, 1e-9, 3.1623e-10, 1e-10, 3.1623e-11,
                          1e-11, 3.1623e-12, 1e-12, 3.1623e-13},
                     {1e-3, 5e-4, 2.5e-4});
  for (const Problem<Top>* p : {&pb, &pn, &pf})
    register_baselines(*p, {1e-6, 3.1623e-7, 1e-7, 3.1623e-8, 1e-8, 3.1623e-9, 1e-9, 3.1623e-10, 1e-10, 3.1623e-11,
                            1e-11, 3.1623e-12, 1e-12, 3.1623e-13, 1e-13, 3.1623e-14},
                       {});
#endif
}

}  // namespace

const MethodFamily splitting_family{"splitting", register_splitting_steps, register_splitting_sweeps};

}  // namespace trompo_bench
