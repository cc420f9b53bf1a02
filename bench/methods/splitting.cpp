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
  }
  return "?";
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
/// t ∈ [0, 10]. No closed form: the reference is a converged Kahan–Li splitting run.
cases::Case<Top> hta() {
  const M3 R = SO3<double>::exp(V3(0.3, -0.2, 0.4)).matrix();
  State<double> s;
  s.rotation = SO3<double>::exp(V3(0.05, 0, 0));
  s.omega = R * V3(0, 0, 50);
  return {"hta", Top(RigidBody<double>(M3(R * V3(5, 5.5, 1).asDiagonal() * R.transpose())),
                     UniformGravity<double>(20, R * V3::UnitZ())),
          s, 10.0};
}

/// HT2A: HT2 made asymmetric (J3 = 15.6 instead of 15.234375: 2.4 %) and turned in the body by
/// the same R: J = R diag(15.234375, 0.46875, 15.6) Rᵀ, E = R e2, Mgl = 15·9.81, Λ0 = I,
/// Ω0 = R (0, 150, −4.61538), t ∈ [0, 2]: a fast asymmetric top (150 rad/s).
cases::Case<Top> ht2a() {
  const M3 R = SO3<double>::exp(V3(0.3, -0.2, 0.4)).matrix();
  State<double> s;
  s.omega = R * V3(0, 150, -4.61538);
  return {"ht2a", Top(RigidBody<double>(M3(R * V3(15.234375, 0.46875, 15.6).asDiagonal() * R.transpose())),
                      UniformGravity<double>(15 * 9.81, R * V3::UnitY())),
          s, 2.0};
}

Reference splitting_reference(const cases::Case<Top>& c, long n) {
  const Stepper<Splitting, Top> stepper(Splitting(SplittingMethod::kahan_li_9), c.scene);
  const double h = c.t_end / double(n);
  const RunResult r = run_trompo<false>(stepper, c, h, n);
  if (!r.ok) throw std::runtime_error("trompo-bench: the HTA reference run failed");
  return {r.end.rotation.matrix(), r.end.omega, "converged splitting run (kahan-li-9, h = " + num(h) + ")", ""};
}

void register_splitting_steps() {
  for (const Problem<Top>* p : {&tops[1], &tops[2]}) {
    for (SplittingMethod m : {SplittingMethod::strang, SplittingMethod::chin_4a, SplittingMethod::chin_triple_jump,
                              SplittingMethod::suzuki_5, SplittingMethod::kahan_li_9})
      step<Splitting>(*p, m);
    step<SplittingProjected>(*p, SplittingMethod::strang);
    step<SplittingProjected>(*p, SplittingMethod::chin_4a);
  }
  for (SplittingMethod m : {SplittingMethod::strang, SplittingMethod::suzuki_5, SplittingMethod::kahan_li_9})
    step<Splitting>(frees[0], m);
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
  const auto a = hta();
  long_tops.push_back({a, splitting_reference(a, 10000), 1e-3, {}, {}, {}, {}, {}});
  {
    const Reference coarser = splitting_reference(a, 5000);
    long_tops[2].ref.check = "differs from the same run at h = 2e-3 by " + num(distance(long_tops[2].ref, coarser));
    benchmark::AddCustomContext("reference_hta", long_tops[2].ref.source + "; " + long_tops[2].ref.check);
  }
  const auto b = ht2a();
  long_tops.push_back({b, splitting_reference(b, 8000), 1e-3, {}, {}, {}, {}, {}});
  {
    const Reference coarser = splitting_reference(b, 4000);
    long_tops[3].ref.check = "differs from the same run at h = 5e-4 by " + num(distance(long_tops[3].ref, coarser));
    benchmark::AddCustomContext("reference_ht2a", long_tops[3].ref.source + "; " + long_tops[3].ref.check);
  }
  const Problem<Top>& p0 = long_tops[0];
  const Problem<Top>& p1 = long_tops[1];
  const Problem<Top>& pa = long_tops[2];
  const Problem<Top>& pb = long_tops[3];
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
  register_baselines(pb, {1e-6, 3.1623e-7, 1e-7, 3.1623e-8, 1e-8, 3.1623e-9, 1e-9, 3.1623e-10, 1e-10, 3.1623e-11,
                          1e-11, 3.1623e-12, 1e-12, 3.1623e-13},
                     {});
#endif
}

}  // namespace

const MethodFamily splitting_family{"splitting", register_splitting_steps, register_splitting_sweeps};

}  // namespace trompo_bench
