// The satellite in trompo-bench (docs/spacecraft.md): sat1, a tumbling satellite in the
// gravity gradient of a circular orbit, over its 10 orbits (t_end = 20π/n ≈ 57 120 s).
//
//   sweep/sat1/splitting-<method>/h:…     the splittings of every order
//   sweep/sat1/simo-kappa-o6/h:…          Simo-κ composed to order 6 (Kahan–Li); a failed
//                                         step is retried as two halves (Recovering)
//   sweep/sat1/simo-collocation-o6/h:…    Simo-collocation composed to order 6
//   sweep/sat1/geradin-bauchau-o6/h:…     Géradin–Bauchau composed to order 6
//   sweep/sat1/rk4/h:…, odeint-rk4, odeint-dopri5/tol:…   the explicit baselines
//
// The counter max_dH is the largest relative change of the scene's energy, here the
// Jacobi integral E_J [G4]. A new splitting method is one more line of `methods` below.
//
// Reference: a converged long-double run (Kahan–Li-9 splitting, h = 0.5 s), checked two ways
// and the distances put in the JSON context: against the same method at h = 1 s, and
// against an independent one (Chin's triple jump at h = 0.5 s, also in long double).
#include <chrono>
#include <cstdio>
#include <deque>
#include <string>

#include "bench_common.hpp"
#include "trompo/schemes/splitting/splitting.hpp"

namespace trompo_bench {
namespace {

using Sat = cases::Satellite<double>;

/// The splitting's working frame is per-trajectory memory; the bench steps a plain State
/// from the case's initial state, so the runner keeps the memory of that trajectory.
template <class SceneT>
struct SatSplittingRunner {
  using Scalar = typename SceneT::Scalar;  // what trompo::integrate() asks of a stepper
  Stepper<Splitting, SceneT> stepper;
  mutable typename Stepper<Splitting, SceneT>::Memory memory{};
  SatSplittingRunner(Splitting scheme, SceneT scene) : stepper(scheme, std::move(scene)) {}
  StepReport<typename SceneT::Scalar> step(State<typename SceneT::Scalar>& s, typename SceneT::Scalar h) const {
    return stepper.step(s, memory, h);
  }
  int order() const { return stepper.order(); }
};

/// The final state of sat1 in long double: `method` with n steps over the 10 orbits.
Reference long_double_run(SplittingMethod method, long n) {
  const auto c = cases::sat1<long double>();
  const SatSplittingRunner<cases::Satellite<long double>> run(Splitting(method), c.scene);
  State<long double> s = c.initial;
  const long double h = c.t_end / static_cast<long double>(n);
  for (long i = 0; i < n; ++i)
    if (!run.step(s, h).ok()) throw std::runtime_error("trompo-bench: the sat1 reference run failed");
  return {s.rotation.matrix().cast<double>(), s.omega.cast<double>(),
          std::string("converged long-double splitting run (") + to_string(method) + ", h = " +
              num(static_cast<double>(h)) + " s)",
          ""};
}

/// A composed implicit stepper whose failed steps are retried as two halves (recursively, as
/// integrate() recovers them): Simo-κ's projection for a potential that is not linear in Λ
/// has no κ where the step's midpoint sits at an extremum of V along the path
/// (schemes/simo/simo_step.hpp), which a tumbling satellite meets every few hundred steps.
template <class Scheme>
struct Recovering {
  using Scalar = double;  // what trompo::integrate() asks of a stepper
  ComposedStepper<Scheme, Sat> stepper;
  StepReport<double> step(State<double>& s, double h, int depth = 0) const {
    StepReport<double> rep = stepper.step(s, h);
    if (rep.ok() || depth >= 12) return rep;
    rep = step(s, h / 2, depth + 1);
    return rep.ok() ? step(s, h / 2, depth + 1) : rep;
  }
  int order() const { return stepper.order(); }
  int stages() const { return stepper.stages(); }
};

std::deque<Problem<Sat>> satellites;

/// The splittings on sat1 with their step grids (ratio 1/√2, from about 1e-4 down to the
/// round-off floor of ‖ΔΛ‖). Add a method here.
struct SplittingSweep {
  SplittingMethod method;
  Grid grid;
};
const SplittingSweep methods[] = {
    {SplittingMethod::strang, {8, 0.125}},
    {SplittingMethod::suzuki_5, {32, 0.25}},
    {SplittingMethod::chin_4a, {32, 0.25}},
    {SplittingMethod::kahan_li_9, {64, 0.7}},
    {SplittingMethod::chin_triple_jump, {64, 0.7}},
    // The near-integrable compositions with corrector [F8] on the exact free flow: the
    // torque is ~1e-4 of the spin terms here, so their ε h^p + ε² h^q error pays.
    {SplittingMethod::sbab3c, {32, 1.4}},
    // SABA4C's error changes 16× per √2 in h here (order ~8), dopri5's ≈ 3× per half decade
    // of tolerance: its grid is 2^(1/4) apart so that both sides resolve the error alike.
    {SplittingMethod::saba4c, {45, 1.4, 0.25}},
};

void register_satellite_sweeps() {
  const auto c = cases::sat1<double>();
  // h = 0.5 s: Kahan–Li-9 at h = 1 s and 2 s differ by 1.7e-9 (order 6: 2.7e-11 at 1 s),
  // so the reference is good to ~4e-13; the checks below say so in every run.
  const long n_ref = 2 * std::lround(static_cast<double>(c.t_end));
  satellites.push_back({c, long_double_run(SplittingMethod::kahan_li_9, n_ref), 1.0, {}, {}, {}, {}, {}});
  Problem<Sat>& p = satellites.back();
  const double coarser = distance(p.ref, long_double_run(SplittingMethod::kahan_li_9, n_ref / 2));
  const double other = distance(p.ref, long_double_run(SplittingMethod::chin_triple_jump, n_ref));
  p.ref.check = "differs from the same run at h = 1 s by " + num(coarser) +
                " and from chin-triple-jump (long double, h = 0.5 s) by " + num(other);
  benchmark::AddCustomContext("reference_sat1", p.ref.source);
  benchmark::AddCustomContext("reference_sat1_check", p.ref.check);

  for (const SplittingSweep& m : methods)
    register_sweep_with(p, std::string("splitting-") + to_string(m.method), Splitting::name, m.grid,
                        [method = m.method](const Sat& scene) { return SatSplittingRunner<Sat>(Splitting(method), scene); });
  register_sweep_with(p, "simo-kappa-o6", SimoKappa::name, {8, 0.5}, [](const Sat& scene) {
    return Recovering<SimoKappa>{ComposedStepper<SimoKappa, Sat>(SimoKappa{}, scene, Composition::kahan_li9)};
  });
  register_sweep(p, SimoCollocation{}, Composition::kahan_li9, {8, 0.5});
  register_sweep(p, GeradinBauchau{}, Composition::kahan_li9, {8, 0.5});  // order 6 observed here
  p.rk4 = {4, 0.125};
  register_sweep_rk4(p);  // trompo's RK4, and with Boost odeint's runge_kutta4 and dopri5
}

}  // namespace

const MethodFamily satellite_family{"satellite", nullptr, register_satellite_sweeps};

/// --trompo_satellite_series=FILE (bench_main.cpp): what a spacecraft engineer reads of sat1.
/// Rows `method,t,c_x,c_y,c_z,dEJ`: for SABA4C at h = 8 s (its cheapest run reaching 1e-8
/// over 10 orbits) over 1000 orbits, the local vertical in body axes c = Λᵀr̂(t) [G1] at every
/// step of the first 20 minutes, and at every orbit the largest |ΔE_J/E_J| [G4] over that
/// orbit; the same E_J record for dopri5 (tolerance 1e-10, its 1e-6 run) over 1000 orbits.
int satellite_series(const std::string& path) {
  const auto c = cases::sat1<double>();
  const auto& gg = std::get<0>(c.scene.effects());
  const double orbit = 2 * 3.14159265358979323846 / gg.orbit_rate();
  const long orbits = 1000;
  std::FILE* out = std::fopen(path.c_str(), "w");
  if (!out) {
    std::fprintf(stderr, "trompo-bench: cannot write %s\n", path.c_str());
    return 1;
  }
  std::fprintf(out, "method,t,c_x,c_y,c_z,dEJ\n");
  const double E0 = c.scene.energy(c.initial);
  // the largest |ΔE_J/E_J| of each orbit, one row at its end
  auto per_orbit = [&](const char* method) {
    return [out, method, max = WindowedMax(E0, orbit)](double t, double E) mutable {
      max.add(t, E, [&](double end, double worst) { std::fprintf(out, "%s,%.9g,,,,%.6g\n", method, end, worst); });
    };
  };
  {
    const SatSplittingRunner<Sat> run(Splitting(SplittingMethod::saba4c), c.scene);
    const double h = 8.0;
    State<double> s = c.initial;
    auto record = per_orbit("splitting-saba4c");
    const auto t0 = std::chrono::steady_clock::now();
    const long n = std::lround(double(orbits) * orbit / h);
    for (long i = 1; i <= n; ++i) {
      if (!run.step(s, h).ok()) {
        std::fprintf(stderr, "trompo-bench: the satellite series failed at t = %g\n", s.time);
        std::fclose(out);
        return 1;
      }
      if (s.time <= 1200) {  // the first 20 minutes: about 20 turns of the tumble
        const V3 cb = s.rotation.matrix().transpose() * gg.radial_at(s.time);
        std::fprintf(out, "attitude,%.9g,%.9g,%.9g,%.9g,\n", s.time, cb.x(), cb.y(), cb.z());
      }
      record(s.time, c.scene.energy(s));
    }
    std::fprintf(stderr, "satellite series: saba4c h = 8 s, %ld steps, %.2f s\n", n,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
#ifdef TROMPO_HAVE_BOOST
  {
    const bench::QuaternionOde<Sat> ode{&c.scene};
    bench::OdeState x = bench::to_ode(c.initial);
    auto record = per_orbit("odeint-dopri5-tol1e-10");
    const auto t0 = std::chrono::steady_clock::now();
    const long steps = bench::odeint_dopri5(ode, x, 0.0, double(orbits) * orbit, 1e-10, [&](const bench::OdeState& y, double t) {
      record(t, c.scene.energy(bench::from_ode(y, t)));
    });
    std::fprintf(stderr, "satellite series: dopri5 tol 1e-10, %ld steps, %.2f s\n", steps,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
#endif
  std::fclose(out);
  return 0;
}

}  // namespace trompo_bench
