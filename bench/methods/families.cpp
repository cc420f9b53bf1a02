// The other families (docs/families.md, docs/theory.md §11) in trompo-bench: Lie-group
// generalised-α, the constrained trapezoid and the energy-decaying scheme join the Δt sweep
// and the per-step family of the energy-momentum schemes, on the same problems.
//
// These schemes carry memory between steps (gen-α's a_n, the last increment as predictor,
// the sensor's history): the bench's runs go through trompo::integrate(), which starts a
// fresh trajectory for every run, and the per-step loop restarts one (bench_common.hpp).
#include <string>

#include "bench_common.hpp"
#include "trompo/schemes/families/constrained_trapezoid.hpp"
#include "trompo/schemes/families/energy_decaying.hpp"
#include "trompo/schemes/families/lie_gen_alpha.hpp"
#include "trompo/schemes/simo/simo_kappa.hpp"

namespace {

using namespace trompo;
using namespace trompo_bench;

/// The configurations measured: method name (as in the report), scheme, parameters.
template <class SceneT, class F>
void for_each_configuration(F&& f) {
  f("lie-gen-alpha-r1", LieGenAlpha(1.0));
  f("lie-gen-alpha-r0.8", LieGenAlpha(0.8));
  f("lie-gen-alpha-r0", LieGenAlpha(0.0));
  f("constrained-trapezoid", ConstrainedTrapezoid{});
  f("energy-decaying-chi0", EnergyDecaying(0.0));
  f("energy-decaying-sensor0.11", EnergyDecaying(1.0 / 9, ChiSchedule::sensor));
  f("energy-decaying-const0.11", EnergyDecaying(1.0 / 9));
}

template <class SceneT>
void sweeps_of(const Problem<SceneT>& p) {
  for_each_configuration<SceneT>([&p](const char* method, auto scheme) {
    using S = decltype(scheme);
    register_sweep_with(p, method, S::name, p.o2,
                        [scheme](const SceneT& scene) { return Stepper<S, SceneT>(scheme, scene); });
  });
}

template <class SceneT>
void steps_of(const Problem<SceneT>& p) {
  for_each_configuration<SceneT>([&p](const char* method, auto scheme) {
    using S = decltype(scheme);
    register_step_with(p, method, S::name, [scheme](const SceneT& scene) { return Stepper<S, SceneT>(scheme, scene); });
  });
}

/// large/ht0/<method>: the under-resolved step of docs/theory.md §11 Table 3 — HT0 at
/// h = 0.05 for 10 s (200 steps). One instrumented run; the counters hold H/H0 every
/// 0.25 s (e00 … e40), max |Δμ|/|μ0|, Ω3(10), max |Ω⊥| and the largest one-step rise of H.
template <class Scheme>
void register_large_step(const Problem<Top>& p, const char* method, Scheme scheme) {
  const std::string name = "large/" + std::string(p.c.name) + "/" + method;
  benchmark::RegisterBenchmark(name.c_str(), [&p, method, scheme](benchmark::State& st) {
    const double h = 0.05;
    const long n = 200;
    for (auto _ : st) {
      Stepper<Scheme, Top> stepper(scheme, p.c.scene);
      auto traj = stepper.start(p.c.initial);
      const double H0 = p.c.scene.energy(traj), mu0 = p.c.scene.momentum_map(traj);
      double H_prev = H0, rise = -1e300, dmu = 0, perp = traj.omega.template head<2>().norm();
      long newton = 0, k = 0;
      st.counters["e00"] = 1.0;
      for (; k < n; ++k) {
        const StepReport<double> rep = stepper.step(traj, h);
        if (!rep.ok()) break;
        newton += rep.iterations;
        const double H = p.c.scene.energy(traj);
        rise = std::max(rise, (H - H_prev) / H0);
        H_prev = H;
        dmu = std::max(dmu, std::abs(p.c.scene.momentum_map(traj) - mu0) / std::abs(mu0));
        perp = std::max(perp, traj.omega.template head<2>().norm());
        if ((k + 1) % 5 == 0) {
          const int i = int((k + 1) / 5);
          st.counters[std::string(i < 10 ? "e0" : "e") + std::to_string(i)] = H / H0;
        }
      }
      st.counters["steps"] = double(k);
      st.counters["max_dmu"] = dmu;
      st.counters["omega3_end"] = traj.omega(2);
      st.counters["max_omega_perp"] = perp;
      st.counters["max_rise"] = rise;
      st.counters["newton"] = k > 0 ? double(newton) / double(k) : 0.0;
      if (k < n) st.SkipWithError(("step failed at t = " + num(traj.time)).c_str());
    }
    st.SetLabel(label_of(p.c.name, method, Scheme::name, 2, 0.05));
  })->Iterations(1)->Unit(benchmark::kMillisecond);
}

void register_family_sweeps() {
  for (const auto& p : tops) sweeps_of(p);
  for (const auto& p : frees) sweeps_of(p);
  for (const auto& p : tops) {
    if (std::string(p.c.name) != "ht0") continue;
    for_each_configuration<Top>([&p](const char* method, auto scheme) { register_large_step(p, method, scheme); });
    register_large_step(p, "simo-kappa", SimoKappa{});
    register_large_step(p, "energy-decaying-const1", EnergyDecaying(1.0));
  }
}

void register_family_steps() {
  for (const auto& p : tops) steps_of(p);
  for (const auto& p : frees) steps_of(p);
}

}  // namespace

const trompo_bench::MethodFamily families{"families", register_family_steps, register_family_sweeps};
