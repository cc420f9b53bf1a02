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
// for scripts/report/ (python3 -m report). Methods: every registered scheme the tools compose
// (include/trompo/schemes/registry.hpp: the Simo and Géradin–Bauchau schemes), each at order 2; the three energy-exact ones
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
//   --trompo_satellite_series=FILE   sat1 over 1000 orbits: the local vertical in body axes,
//                                 E_J per orbit (methods/satellite.cpp), CSV.
#include "bench_common.hpp"

namespace {

using namespace trompo;
using namespace trompo_bench;

/// Calls f(Scheme{}) for every registered scheme (include/trompo/schemes/registry.hpp) that
/// the tools compose (Compositions::symmetric: the implicit schemes and any added one) and
/// that steps SceneT; RK4, splitting and the families have benchmarks of their own
/// (below, bench/methods/).
template <class SceneT, class F>
void for_each_registered(F&& f) {
  RegisteredSchemes::for_each([&](auto entry) {
    using Entry = typename decltype(entry)::type;
    if constexpr (Entry::compositions == Compositions::symmetric && Entry::template steps<SceneT>)
      f(typename Entry::Scheme{});
  });
}

template <class SceneT>
void register_sweeps(const Problem<SceneT>& p) {
  for_each_registered<SceneT>([&](auto scheme) { register_sweep(p, scheme, Composition::base, p.o2); });
  for (Composition m : {Composition::triple_jump, Composition::suzuki5, Composition::kahan_li9}) {
    const Grid& g = m == Composition::triple_jump ? p.o4 : m == Composition::suzuki5 ? p.o4s : p.o6;
    register_sweep(p, SimoKappa{}, m, g);
    register_sweep(p, SimoCollocation{}, m, g);
    register_sweep(p, GeradinBauchau{}, m, g);
  }
  register_sweep_rk4(p);
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
  for_each_registered<SceneT>([&]([[maybe_unused]] auto scheme) {
    if constexpr (!std::is_same_v<decltype(scheme), SimoKappa>) register_step(p, scheme, 2);  // Simo-κ: above
  });
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
  // max |ΔH/H| per window of time, one row each.
  struct Windows {
    std::ofstream& out;
    std::string method;
    WindowedMax max;
    void add(double t, double H) {
      max.add(t, H, [&](double end, double worst) { out << method << ',' << end << ',' << worst << '\n'; });
    }
  };
  auto timed = [&](const std::string& method, auto&& body) {
    const auto t0 = std::chrono::steady_clock::now();
    Windows w{out, method, WindowedMax(H0, window)};
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
  for_each_registered<Top>([&](auto scheme) { trompo_series(scheme, 2); });
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
#ifdef TROMPO_BENCH_COMPILE_CHECK
  std::fprintf(stderr, "trompo-bench: built with TROMPO_BENCH_COMPILE_CHECK (-O0): its timings mean nothing\n");
#endif
  // Our own flags first; Google Benchmark rejects flags it does not know.
  std::string series_path, satellite_path;
  std::vector<char*> args;
  for (int i = 0; i < argc; ++i) {
    const char* flag = "--trompo_energy_series=";
    const char* sat_flag = "--trompo_satellite_series=";
    if (std::strncmp(argv[i], flag, std::strlen(flag)) == 0)
      series_path = argv[i] + std::strlen(flag);
    else if (std::strncmp(argv[i], sat_flag, std::strlen(sat_flag)) == 0)
      satellite_path = argv[i] + std::strlen(sat_flag);
    else
      args.push_back(argv[i]);
  }
  if (!series_path.empty()) return energy_series(series_path);
  if (!satellite_path.empty()) return satellite_series(satellite_path);
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
  for (const MethodFamily* f : method_families())
    if (f->steps) f->steps();
  for (const auto& p : tops) register_sweeps(p);
  for (const auto& p : frees) register_sweeps(p);
  for (const MethodFamily* f : method_families())
    if (f->sweeps) f->sweeps();

  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
