// The engine of trompo-simulate and the Python module (interface: simulate_core.hpp): the
// scene and scheme dispatch over the scheme registry (include/trompo/schemes/registry.hpp),
// the run loops and the ensembles. Compiled once, into trompo_simulate_core.
#include "simulate/simulate_core.hpp"

#include <chrono>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <utility>

#if TROMPO_HAVE_EXACT
#include "trompo/exact/free_body.hpp"
#include "trompo/exact/lagrange_top.hpp"
#endif
#include "trompo/drivers/adaptive.hpp"
#include "trompo/drivers/ensemble.hpp"
#include "trompo/trompo.hpp"

namespace trompo_simulate {

/// Counts the Newton iterations of the steps since the last written row (a recovered
/// interval counts all its sub-steps); forwards to the wrapped stepper.
/// For a scheme with memory (splitting, the families) it has the stepper's Memory and
/// start(), so that integrate() steps a Trajectory through it.
template <class StepperT>
struct CountingStepper {
  using Scalar = double;
  using Memory = typename StepperT::Memory;
  const StepperT& stepper;
  mutable long iterations = 0;
  /// A trajectory with fresh memory (integrate() calls it for a scheme with memory).
  auto start(const trompo::State<double>& s) const { return stepper.start(s); }
  /// A State, or a Trajectory for a scheme with memory.
  template <class StateT>
  trompo::StepReport<double> step(StateT& s, double h) const {
    const auto rep = stepper.step(s, h);
    iterations += rep.iterations;
    return rep;
  }
};

/// One row of state s.
template <class Scene>
void write_row(RowSink& out, const Scene& scene, const V3& up, const trompo::State<double>& st, long iterations) {
  const M3 R = st.rotation.matrix();
  const V3 pi = scene.spatial_momentum(st);
  out.row(st.time, R, st.omega, scene.energy(st), up.dot(pi), pi, iterations);
}

/// The number of steps of the grid t0 + k·h to t_end (the last one shortened): as integrate().
inline long step_count(const Config& c) {
  const double ratio = *c.t_end / *c.dt;
  const double eps = std::numeric_limits<double>::epsilon();
  return std::max(1L, static_cast<long>(std::ceil(ratio - 8 * eps * std::max(ratio, 1.0))));
}

// ---- adaptive steps: the run (--rtol) ----
template <class Scene>
trompo::SplittingMethod splitting_method(const Config& c, const Scene& scene);

/// The method an adaptive run steps with, as its summary line names it: "splitting
/// chin-triple-jump (order 6)", "simo-kappa kahan-li-9 (order 6)", "rk4 (order 2)" (the
/// CLI's order: 2 for a scheme not composed).
template <class Scene>
std::string method_text(const Config& c, const Scene& scene) {
  if (c.scheme == "splitting") {
    const trompo::SplittingMethod m = splitting_method(c, scene);
    // the order on this scene: SABA/SBAB with wheels are of order 2 [W18]
    return "splitting " + std::string(trompo::to_string(m)) + " (order " + std::to_string(trompo::Splitting(m).order_on(scene)) + ")";
  }
  if (c.order == 2) return c.scheme + " (order 2)";
  return c.scheme + " " + trompo::to_string(c.composition ? *c.composition : trompo::composition_of_order(c.order)) +
         " (order " + std::to_string(c.order) + ")";
}

/// The warning of an --rtol raised to its floor.
inline std::string rtol_warning(const Config& c) {
  return format("warning: --rtol %g is below the round-off floor 100*eps = %.3g; raised to it (as SciPy does)",
                *c.adaptive.rtol_asked, c.adaptive.rtol);
}

/// The driver's options from --rtol, --atol, --control, --tol-scope, --estimate, --substeps,
/// --hold-third-integral and --dt (the first step; none: the driver's rule).
inline trompo::AdaptiveOptions<double> adaptive_options(const Config& c) {
  using namespace trompo;
  const AdaptiveFlags& a = c.adaptive;
  AdaptiveOptions<double> opt;
  opt.rtol = a.rtol;
  opt.atol = a.atol;
  opt.control = a.control == "reversible" ? StepControl::reversible : StepControl::tolerance;
  opt.tolerance_over_span = a.tol_scope == "span";
  opt.estimate = a.estimate == "defect"       ? ErrorEstimate::defect
                 : a.estimate == "doubling"   ? ErrorEstimate::doubling
                 : a.estimate == "richardson" ? ErrorEstimate::richardson
                                              : ErrorEstimate::automatic;
  opt.substeps = a.substeps;
  opt.hold_third_integral = a.hold_third_integral;
  opt.first_step = c.dt ? std::abs(*c.dt) : 0.0;  // 0: the driver's rule (docs/adaptive.md)
  return opt;
}

/// The events of --event on `scene`, then those given as code.
template <class Scene>
std::vector<trompo::Event<double>> adaptive_events(const Config& c, const Scene& scene) {
  std::vector<trompo::Event<double>> ev;
  for (const auto& [name, terminal] : c.adaptive.events) ev.push_back(trompo::events::by_name(scene, name, terminal));
  for (const trompo::Event<double>& e : c.adaptive.code_events) ev.push_back(e);
  return ev;
}

/// --event-csv opened with its header (nullptr without it).
inline std::FILE* open_event_csv(const Config& c, const std::vector<trompo::Event<double>>& ev) {
  const AdaptiveFlags& a = c.adaptive;
  if (a.event_csv.empty()) return nullptr;
  if (ev.empty()) throw invalid_input("--event-csv: needs at least one --event");
  std::FILE* f = std::fopen(a.event_csv.c_str(), "w");
  if (!f) throw invalid_input("--event-csv: cannot open '" + a.event_csv + "': " + std::strerror(errno));
  std::fprintf(f, "event,%s", kHeader);
  return f;
}

/// The summary line of an adaptive run (the Python module reads it: trompo/__init__.py).
inline std::string adaptive_summary_text(const Config& c, const trompo::AdaptiveSummary<double>& sum,
                                         const std::string& method) {
  const AdaptiveFlags& a = c.adaptive;
  return format("adaptive (%s, rtol %g, atol %g): %lld accepted, %lld rejected, %lld failed attempts, %lld Newton "
                "iterations; %s; method %s%s",
                a.control.c_str(), a.rtol, a.atol, static_cast<long long>(sum.accepted),
                static_cast<long long>(sum.rejected), static_cast<long long>(sum.failures),
                static_cast<long long>(sum.iterations),
                sum.status == trompo::AdaptiveStatus::event ? "stopped by a terminal event"
                : sum.ok()                                   ? "reached t_end"
                                                             : sum.message(),
                method.c_str(), a.picked ? ", picked for the scene and tolerance (docs/adaptive.md)" : "");
}

/// Runs `stepper` through trompo::integrate_adaptive (drivers/adaptive.hpp): rows at every
/// --every-th accepted step (and the last), or at exactly the --t-eval times from the dense
/// output; --event rows to --event-csv ("event," then the usual columns); one summary line.
template <class StepperT>
int run_adaptive(const StepperT& stepper, const Config& c, trompo::State<double> s, RowSink& out) {
  using namespace trompo;
  if constexpr (detail::is_processed<StepperT>()) {
    throw invalid_input("--rtol: the processed composition's processor is tied to h: use --order 6");
  } else {
    const AdaptiveFlags& a = c.adaptive;
    const auto& scene = stepper.scene();
    const V3 up = c.up.normalized();
    const AdaptiveOptions<double> opt = adaptive_options(c);
    if (a.rtol_asked) out.message(rtol_warning(c));
    std::vector<Event<double>> ev = adaptive_events(c, scene);
    std::FILE* event_file = open_event_csv(c, ev);
    out.header();
    const bool at_times = !a.t_eval.empty();
    std::size_t next = 0;
    long k = 0, written_iterations = 0;
    double last_row = std::numeric_limits<double>::quiet_NaN();
    auto row = [&](const State<double>& st, long iterations) {
      write_row(out, scene, up, st, iterations - written_iterations);
      written_iterations = iterations;
      last_row = st.time;
    };
    if (!at_times || a.t_eval[0] == s.time) {
      row(s, 0);
      next = at_times ? 1 : 0;
    }
    auto observer = [&](const DenseNode<double>& na, const DenseNode<double>& nb, const AdaptiveSummary<double>& sum) {
      const long its = static_cast<long>(sum.iterations);
      if (!at_times) {
        if (++k % c.every == 0) row(nb.state, its);
        return;
      }
      const double tb = nb.state.time;
      const bool forward = tb >= na.state.time;
      if (next < a.t_eval.size() && (forward ? a.t_eval[next] <= tb : a.t_eval[next] >= tb)) {
        const LieHermite<double> seg(na, nb, opt.quintic);
        while (next < a.t_eval.size() && (forward ? a.t_eval[next] <= tb : a.t_eval[next] >= tb)) {
          row(a.t_eval[next] == tb ? nb.state : seg.state(a.t_eval[next]), its);
          ++next;
        }
      }
    };
    auto sink = [&](int index, const State<double>& st, bool) {
      if (!event_file) return;
      std::fprintf(event_file, "%s,", ev[static_cast<std::size_t>(index)].name.c_str());
      CsvSink(event_file).row(st.time, st.rotation.matrix(), st.omega, scene.energy(st), up.dot(scene.spatial_momentum(st)),
                              scene.spatial_momentum(st), 0);
    };
    const AdaptiveSummary<double> sum = integrate_adaptive(stepper, s, *c.t_end, opt, observer, &ev, sink);
    if (!at_times && !(s.time == last_row)) row(s, static_cast<long>(sum.iterations));  // the end, always
    if (event_file) std::fclose(event_file);
    out.message(adaptive_summary_text(c, sum, method_text(c, scene)));
    if (!sum.ok()) {
      out.flush();
      out.message(format("adaptive run failed at t = %.17g: %s", s.time, sum.message()));
      return 3;
    }
    return 0;
  }
}
// ---- end adaptive ----

// ---- long runs: the estimate before, the progress during ----------------------------------

/// A run of more steps than this states its estimated time before it starts.
constexpr double kAnnounceSteps = 1e8;

/// A duration for a person: seconds up to two minutes, then minutes, hours, days, years.
inline std::string duration_text(double seconds) {
  if (!(seconds < 1e300)) return "forever";
  if (seconds < 120) return format("%.3g s", seconds);
  if (seconds < 2 * 3600) return format("%.3g min", seconds / 60);
  if (seconds < 2 * 86400) return format("%.3g h", seconds / 3600);
  if (seconds < 2 * 365.25 * 86400) return format("%.3g days", seconds / 86400);
  return format("%.3g years", seconds / (365.25 * 86400));
}

/// Seconds per grid step of `stepper` from state s, timed on a short probe: the same
/// integrate() with the same rows (every c.every-th step, formatted by a CsvSink into
/// /dev/null, so that a run with --every 1 counts its output too) on a copy of s, 64, 256,
/// … steps until one probe takes 50 ms or 4^10 steps. The run itself and its output are not
/// touched. Returns {seconds per step, steps timed}; {NaN, m} when the probe failed a step.
template <class StepperT>
std::pair<double, long> time_per_step(const StepperT& stepper, const Config& c, const trompo::State<double>& s) {
  using clock = std::chrono::steady_clock;
  std::FILE* null = std::fopen("/dev/null", "w");  // no rows timed where there is none
  CsvSink sink(null);
  const V3 up = c.up.normalized();
  const double h = *c.dt;
  std::pair<double, long> result{std::numeric_limits<double>::quiet_NaN(), 0};
  for (long m = 64;; m *= 4) {
    trompo::State<double> probe = s;
    long k = -1;
    const auto start = clock::now();
    const auto sum = trompo::integrate(stepper, probe, s.time + static_cast<double>(m) * h, h,
                                       [&](const trompo::State<double>& st) {
                                         if (null && ++k % c.every == 0) write_row(sink, stepper.scene(), up, st, 0);
                                       });
    const double elapsed = std::chrono::duration<double>(clock::now() - start).count();
    result = {sum.ok() ? elapsed / static_cast<double>(m) : std::numeric_limits<double>::quiet_NaN(), m};
    if (!sum.ok() || elapsed >= 0.05 || m >= (1L << 20)) break;
  }
  if (null) std::fclose(null);
  return result;
}

/// The line a run of more than kAnnounceSteps steps prints before it starts.
template <class StepperT>
std::string estimate_text(const StepperT& stepper, const Config& c, const trompo::State<double>& s, double steps) {
  const auto [per_step, timed] = time_per_step(stepper, c, s);
  if (!(per_step >= 0))
    return format("%.3g steps of h = %.17g: no time estimate (a step of the %ld-step probe failed)", steps, *c.dt,
                  timed);
  return format("%.3g steps of h = %.17g: estimated %s (%.3g s a step, timed on a probe of %ld steps)", steps, *c.dt,
                duration_text(per_step * steps).c_str(), per_step, timed);
}

/// Runs `stepper` through trompo::integrate (failed steps are retried as sub-steps) and
/// writes the CSV rows. More than kAnnounceSteps steps: the estimated time on stderr first;
/// stderr a terminal: a progress line once a second after the first c.progress_after seconds
/// (--progress-after, default 3).
template <class StepperT>
int run(const StepperT& stepper, const Config& c, trompo::State<double> s, RowSink& out) {
  if (c.adaptive.on) return run_adaptive(stepper, c, s, out);  // adaptive steps (--rtol)
  const auto& scene = stepper.scene();
  const V3 up = c.up.normalized();  // μ = γ·π about the given up axis, with or without gravity
  const double steps = std::abs((*c.t_end - s.time) / *c.dt);
  if (steps > kAnnounceSteps && out.announces_long_runs()) out.notice(estimate_text(stepper, c, s, steps));
  out.header();
  const long n = step_count(c);
  const CountingStepper<StepperT> counting{stepper};
  using clock = std::chrono::steady_clock;
  const bool progress = out.shows_progress();
  const auto start = clock::now();
  double next_progress = c.progress_after;
  bool progress_shown = false;
  long k = -1;  // the observer's first call is at t0
  auto observer = [&](const trompo::State<double>& st) {
    ++k;
    if (k == 0 || k % c.every == 0 || k == n) {
      write_row(out, scene, up, st, counting.iterations);
      counting.iterations = 0;
    }
    if (progress && k > 0 && (k & 0xFFF) == 0) {  // the clock every 4096 steps (not at t0: no rate yet)
      const double elapsed = std::chrono::duration<double>(clock::now() - start).count();
      if (elapsed >= next_progress) {
        const double done = static_cast<double>(k) / static_cast<double>(n);
        out.progress(format("t = %.6g of %.6g (%.1f%%), %s elapsed, about %s left", st.time, *c.t_end, 100 * done,
                            duration_text(elapsed).c_str(), duration_text(elapsed * (1 - done) / done).c_str()),
                     false);
        progress_shown = true;
        next_progress = elapsed + 1;
      }
    }
  };
  const auto sum = trompo::integrate(counting, s, *c.t_end, *c.dt, observer);
  if (progress_shown)
    out.progress(format("t = %.6g of %.6g, %s after %s", s.time, *c.t_end, sum.ok() ? "done" : "stopped",
                        duration_text(std::chrono::duration<double>(clock::now() - start).count()).c_str()),
                 true);
  if (sum.recovered > 0)
    out.message(format("%lld interval(s) recovered by sub-stepping (%lld failed attempts, %lld sub-steps, depth <= %d)",
                       static_cast<long long>(sum.recovered), static_cast<long long>(sum.failures),
                       static_cast<long long>(sum.substeps), sum.max_depth));
  if (!sum.ok()) {
    out.flush();
    out.message(format("step failed at t = %.17g (h = %.17g), not recovered by sub-stepping: %s", s.time, *c.dt,
                       sum.reason()));
    return 3;
  }
  return 0;
}

/// The closed form (docs/theory.md §8) on the same grid: the Lagrange top (J diagonal with
/// J11 = J22, centre of mass on body axis 3) or the torque-free body (J diagonal).
inline int run_exact(const Config& c, const trompo::RigidBody<double>& body, const trompo::State<double>& s0, RowSink& out) {
  using namespace trompo;
#if !TROMPO_HAVE_EXACT
  (void)c, (void)body, (void)s0, (void)out;
  throw invalid_input("--scheme exact: this build has no closed forms (Boost.Math headers were not found)");
#else
  const M3& J = body.inertia();
  const double scale = J.cwiseAbs().maxCoeff();
  if (c.have_effects) throw invalid_input("--scheme exact: no closed form with damping, torques or a rotor");
  if (!body.is_diagonal()) throw invalid_input("--scheme exact: no closed form for a non-diagonal inertia (give principal axes)");
  const M3 L0 = s0.rotation.matrix();
  auto emit = [&](const auto& exact, const auto& scene) {
    out.header();
    const long n = step_count(c);
    for (long k = 0; k <= n; ++k) {
      State<double> s;
      s.time = (k == n) ? *c.t_end : static_cast<double>(k) * *c.dt;
      if (!(k == 0 || k % c.every == 0 || k == n)) continue;
      s.rotation = SO3d::renormalized(Eigen::Quaterniond(exact.rotation(s.time)));
      s.omega = exact.omega(s.time);
      write_row(out, scene, c.up.normalized(), s, 0);
    }
    return 0;
  };
  if (c.mgl == 0) return emit(exact::FreeBody(J.diagonal(), L0, s0.omega), FreeScene<double>(body));
  if (std::abs(J(0, 0) - J(1, 1)) > 1e-12 * scale)
    throw invalid_input("--scheme exact: no closed form for this top (needs J11 = J22, a Lagrange top)");
  const V3 E = c.com.normalized();
  if ((E - V3::UnitZ()).norm() > 1e-14)
    throw invalid_input("--scheme exact: no closed form for this top (needs --com along the symmetry axis 0,0,1)");
  const HeavyTop<double> scene(body, UniformGravity<double>(c.mgl, c.com, c.up));
  return emit(exact::LagrangeTop(J(0, 0), J(2, 2), c.mgl, L0, s0.omega, c.up.normalized()), scene);
#endif
}

/// A symmetric scheme, plain or composed (--order 4 or 6, --composition).
template <class Scheme, class Scene, class Out>
int run_scheme(const Config& c, Scheme scheme, const Scene& scene, const trompo::State<double>& s0, Out& out) {
  if (c.order == 2) return run(trompo::Stepper<Scheme, Scene>(scheme, scene), c, s0, out);
  if (c.processed) return run(trompo::ProcessedStepper<Scheme, Scene>(scheme, scene), c, s0, out);
  return run(trompo::ComposedStepper<Scheme, Scene>(scheme, scene,
                                                    c.composition ? *c.composition : trompo::composition_of_order(c.order)),
             c, s0, out);
}

// ---- splitting (--scheme splitting) ----
/// The splitting method of --composition, or the default of --order for this scene.
template <class Scene>
trompo::SplittingMethod splitting_method(const Config& c, const Scene& scene) {
  using trompo::SplittingMethod;
  if (!c.composition_name) return trompo::Splitting::default_for(scene, c.order).method;
  for (const auto m : trompo::all_splitting_methods)
    if (*c.composition_name == trompo::to_string(m)) return m;
  throw invalid_input("--composition: unknown splitting method " + *c.composition_name);
}

/// Throws invalid_input (exit 2) for a method or projection the scene does not allow.
template <class Scene>
void check_splitting(const Config& c, const Scene& scene) {
  trompo::Splitting(splitting_method(c, scene)).check(scene);
  if (c.energy_projection && !trompo::detail::splitting_effects_of<Scene>::conservative)
    throw invalid_input("--energy-projection: needs a conservative scene (gravity only): not with --damping, --torque, "
                        "--space-torque or --rotor");
}

template <class Scene, class Out>
int run_splitting(const Config& c, const Scene& scene, const trompo::State<double>& s0, Out& out) {
  using namespace trompo;
  const SplittingMethod m = splitting_method(c, scene);
  check_splitting(c, scene);
  if constexpr (detail::splitting_effects_of<Scene>::conservative)
    if (c.energy_projection) return run(Stepper<SplittingProjected, Scene>(SplittingProjected(m), scene), c, s0, out);
  return run(Stepper<Splitting, Scene>(Splitting(m), scene), c, s0, out);
}
// ---- end splitting ----

// ---- the registry's schemes with the CLI's parameters ----
/// The scheme of --scheme built from the CLI's parameters: S{} unless the scheme has flags
/// of its own, whose overload of make_scheme stands here, next to them.
template <class S>
S make_scheme(std::type_identity<S>, const Config&) {
  return S{};
}
inline trompo::SimoKappa make_scheme(std::type_identity<trompo::SimoKappa>, const Config& c) {
  trompo::SimoKappa s;
  s.compensated = c.compensated;  // --compensated
  return s;
}
inline trompo::SimoCollocation make_scheme(std::type_identity<trompo::SimoCollocation>, const Config& c) {
  trompo::SimoCollocation s;
  s.compensated = c.compensated;  // --compensated
  return s;
}
inline trompo::LGVI make_scheme(std::type_identity<trompo::LGVI>, const Config& c) {
  trompo::LGVI s;
  s.compensated = c.compensated;  // --compensated
  return s;
}
inline trompo::SimoAlpha make_scheme(std::type_identity<trompo::SimoAlpha>, const Config& c) {
  return trompo::SimoAlpha(c.alpha.value_or(0.5));  // --alpha
}
inline trompo::LieGenAlpha make_scheme(std::type_identity<trompo::LieGenAlpha>, const Config& c) {
  return trompo::LieGenAlpha(c.rho_inf.value_or(0.8));  // --rho-inf
}
inline trompo::EnergyDecaying make_scheme(std::type_identity<trompo::EnergyDecaying>, const Config& c) {
  // --chi, --chi-schedule
  const trompo::ChiSchedule schedule =
      c.chi_schedule.value_or("constant") == "sensor" ? trompo::ChiSchedule::sensor : trompo::ChiSchedule::constant;
  return trompo::EnergyDecaying(c.chi.value_or(0.0), schedule);
}

/// A scheme with compositions of its own (Compositions::own) runs its own way.
template <class Scene, class Out>
int run_own(std::type_identity<trompo::Splitting>, const Config& c, const Scene& scene, const trompo::State<double>& s0,
            Out& out) {
  return run_splitting(c, scene, s0, out);
}

/// The registry entry Entry on `scene`: plain, or composed as --order/--composition ask
/// where the entry lets the tools compose it.
template <class Entry, class Scene, class Out>
int run_registered(const Config& c, [[maybe_unused]] const Scene& scene, [[maybe_unused]] const trompo::State<double>& s0,
                   [[maybe_unused]] Out& out) {
  using S = typename Entry::Scheme;
  if constexpr (!Entry::template steps<Scene>) {
    throw invalid_input("--scheme " + std::string(S::name) + ": does not step this scene (" + c.scheme + ")");
  } else if constexpr (Entry::compositions == trompo::Compositions::own) {
    return run_own(std::type_identity<S>{}, c, scene, s0, out);
  } else if constexpr (Entry::compositions == trompo::Compositions::none) {
    return run(trompo::Stepper<S, Scene>(make_scheme(std::type_identity<S>{}, c), scene), c, s0, out);
  } else {
    return run_scheme(c, make_scheme(std::type_identity<S>{}, c), scene, s0, out);
  }
}

/// --scheme's registry entry on `scene`.
template <class Scene, class Out>
int dispatch_scheme(const Config& c, const Scene& scene, const trompo::State<double>& s0, Out& out) {
  int code = 0;
  if (!trompo::RegisteredSchemes::visit(
          c.scheme, [&](auto entry) { code = run_registered<typename decltype(entry)::type>(c, scene, s0, out); }))
    throw invalid_input("--scheme: unknown scheme '" + c.scheme + "'");
  return code;
}

// ---- control in the loop (--wheels, --controller, field flags) ---------------------------

/// The control run's scene (ControlScene, simulate_core.hpp): the hub of --inertia less the
/// wheels [W1], the wheels, a held body torque at zero, and magnetorquers in the field of
/// --orbit-radius (without it a placeholder orbit and the dipole at zero: no torque). Throws
/// invalid_input naming the field (the hub's inertia, the orbit).
inline ControlScene control_scene(const Config& c, const M3& inertia) {
  using namespace trompo;
  const ControlFlags& k = c.control;
  ReactionWheels<double> rw;
  for (const auto& w : k.wheels) rw.add_wheel(w);
  const RigidBody<double> hub = rw.hub_body(inertia);
  constexpr double pi = 3.14159265358979323846;
  const CircularOrbit<double> orbit(k.orbit_radius.value_or(7000e3), k.inclination_deg.value_or(0.0) * pi / 180);
  const Magnetorquer<double> mtq(DipoleField<double>(orbit),
                                 V3::Constant(k.max_dipole.value_or(std::numeric_limits<double>::infinity())));
  return ControlScene(hub, rw, held_body_torque<double>(), mtq);
}
inline ControlScene control_scene(const Config& c) { return control_scene(c, c.inertia); }
/// Member i's control scene: its own inertia (the whole spacecraft's) or --inertia.
inline ControlScene member_control_scene(const Config& c, const EnsembleInput& in, std::size_t i) {
  return control_scene(c, in.inertia.empty() ? c.inertia : in.inertia[i]);
}

/// --controller as one copyable type (one instantiation of the sampled driver per stepper):
/// none (u = 0: the wheels spin freely), mrp-pd or bdot.
struct CliController {
  int kind = 0;  ///< 0 none, 1 mrp-pd, 2 bdot, 3 code (ControlFlags::code: Python's callable)
  trompo::MrpPd<double> pd;
  trompo::BDot<double> bdot;
  /// Shared by the driver's trial copies: the code keeps its own memory (Python: a dict).
  std::function<trompo::Command<double>(const trompo::Sample<double>&)> code;
  trompo::Command<double> operator()(const trompo::Sample<double>& s) {
    if (kind == 1) return pd(s);
    if (kind == 2) return bdot(s);
    if (kind == 3) return code(s);
    return {};
  }
};

inline CliController make_controller(const Config& c) {
  CliController ctrl;
  const ControlFlags& k = c.control;
  if (k.controller == "mrp-pd") {
    ctrl.kind = 1;
    ctrl.pd.K = k.K;
    ctrl.pd.P = k.P;
    ctrl.pd.target = k.target_matrix ? *k.target_matrix : attitude_of(k.target.value_or(V3::Zero()), "--target-rotation").matrix();
    ctrl.pd.validate();
  } else if (k.controller == "bdot") {
    ctrl.kind = 2;
    ctrl.bdot.k = k.k;
    ctrl.bdot.validate();
  } else if (k.controller == "code") {
    if (!k.code) throw invalid_input("--controller code: a controller given as code (the Python module's trompo.control)");
    ctrl.kind = 3;
    ctrl.code = k.code;
  }
  return ctrl;
}

/// The sample period: --control-period, or without a controller one hold over the whole run
/// (the wheels at constant momentum).
inline double control_period(const Config& c) {
  return c.control.period.value_or(std::max(std::abs(*c.t_end), std::abs(c.dt.value_or(0.0))));
}
/// Fixed steps of --dt between the samples, following the rate with --max-step-angle [W16].
inline trompo::FixedSteps<double> control_fixed_steps(const Config& c) {
  return {*c.dt, {}, c.control.max_angle.value_or(0.0)};
}

/// A stepper the sampled driver can hold commands in (its scene, mutable) that counts the
/// Newton iterations since the last written row, as CountingStepper does.
template <class StepperT>
struct ControlStepper {
  using Scalar = double;
  using Scene = typename StepperT::Scene;
  using Memory = typename StepperT::Memory;
  StepperT inner;
  mutable long iterations = 0;
  Scene& scene() { return inner.scene(); }
  const Scene& scene() const { return inner.scene(); }
  // what the adaptive driver asks of a stepper (--rtol between the samples)
  int order() const { return inner.order(); }
  auto keeps() const { return inner.keeps(); }
  decltype(auto) scheme() const { return inner.scheme(); }
  int stages() const
    requires requires(const StepperT& x) { x.stages(); }
  {
    return inner.stages();
  }
  auto start(const trompo::State<double>& s) const { return inner.start(s); }
  template <class StateT>
  trompo::StepReport<double> step(StateT& s, double h) const {
    const auto rep = inner.step(s, h);
    iterations += rep.iterations;
    return rep;
  }
  // A composed step with the wheels' friction flow around each sub-step (docs/theory.md [W17]).
  template <class StateT, class Flow>
  trompo::StepReport<double> step(StateT& s, double h, Flow&& flow) const
    requires requires(const StepperT& x) { x.step(s, h, flow); }
  {
    const auto rep = inner.step(s, h, flow);
    iterations += rep.iterations;
    return rep;
  }
};

/// Between the samples with --rtol: integrate_adaptive over each hold (a new run each hold,
/// its first step from --dt, else the driver's rule), with the run's events, `nodes(a, b,
/// t_next, wheels_at)` at each accepted step (wheels_at(t) puts the wheels at a time between
/// a and b before a row from the interpolant: with friction, where they are, [W17]; else
/// nothing to do); the driver's counts summed over the holds in `total`.
template <class Nodes, class Sink>
struct HoldAdaptive {
  const trompo::AdaptiveOptions<double>& options;
  std::vector<trompo::Event<double>>* events;  ///< nullptr: none
  Nodes& nodes;
  Sink& sink;
  trompo::AdaptiveSummary<double>* total;
  /// The scene's wheels when they have viscous friction (else nullptr): each hold then steps the
  /// split step [W17] (trompo::detail::friction_split_hold), as the library's AdaptiveSteps
  /// does, its nodes' rates and the wheels between them with the friction (W17.a-b).
  trompo::ReactionWheels<double>* friction_wheels = nullptr;
  static constexpr bool applies_friction = true;
  template <class StepperT, class Traj, class Obs>
  bool operator()(const StepperT& stepper, Traj& traj, double t_next, Obs&&, trompo::SampledSummary<double>& sum) const {
    using namespace trompo;
    auto observer = [&](const DenseNode<double>& a, const DenseNode<double>& b, const AdaptiveSummary<double>&) {
      nodes(a, b, t_next, [](double) {});
    };
    AdaptiveSummary<double> s;
    if (friction_wheels != nullptr) {  // the rows' wheel speeds and total momentum at their own times
      auto split_observer = [&](const DenseNode<double>& a, const DenseNode<double>& b, const auto& wheels_at) {
        nodes(a, b, t_next, wheels_at);
      };
      s = detail::friction_split_hold(stepper, *friction_wheels, traj, t_next, options, split_observer, events, sink);
    } else {
      s = integrate_adaptive(stepper, traj, t_next, options, observer, events, sink);
    }
    total->accepted += s.accepted;
    total->rejected += s.rejected;
    total->failures += s.failures;
    total->iterations += s.iterations;
    total->status = s.status;
    total->failure = s.failure;
    total->time = s.time;
    total->step_too_small = s.step_too_small;
    sum.add_adaptive_hold(s);
    return s.ok();
  }
};

/// Runs a control run with `st` by trompo::integrate_sampled: fixed steps of --dt between
/// the samples, rows at t0, every --every-th grid point and the end; or (--rtol) adaptive
/// steps over each hold (HoldAdaptive), rows at t0, every sample, every --every-th accepted
/// step and the end, or at exactly the --t-eval times (each from its step's dense segment;
/// a time on a sample is written after the new command is held), --event rows to
/// --event-csv. The wheel columns with each row. Returns 0, or 3 if a step failed or a
/// command was refused (stderr names t and why).
template <class StepperT>
int run_control_with(StepperT st, const Config& c, trompo::State<double> s, RowSink& out) {
  using namespace trompo;
  ControlStepper<StepperT> stepper{std::move(st)};
  stepper.scene().template effect<ReactionWheels<double>>().start(s.time, s.omega);
  const int n = stepper.scene().template effect<ReactionWheels<double>>().size();
  CliController ctrl = make_controller(c);
  const double period = control_period(c);
  const V3 up = c.up.normalized();
  out.wheel_header(n);
  long k = -1;
  double last_row = std::numeric_limits<double>::quiet_NaN();
  auto row = [&](const State<double>& x) {
    const auto& scene = stepper.scene();
    const auto& rw = scene.template effect<ReactionWheels<double>>();
    const ReactionWheels<double>::WheelVector w = rw.speeds(x.time, x.omega);
    const ReactionWheels<double>::WheelVector u = rw.torques();
    const V3 pi = scene.spatial_momentum(x);
    out.wheel_row(x.time, x.rotation.matrix(), x.omega, scene.energy(x), up.dot(pi), pi, stepper.iterations, w.data(),
                  u.data(), n);
    stepper.iterations = 0;
    last_row = x.time;
  };
  auto failed = [&](const std::string& why) {
    out.flush();
    out.message(format("control run failed at t = %.17g: %s", s.time, why.c_str()));
    return 3;
  };
  if (!c.adaptive.on) {
    auto observer = [&](const State<double>& x) {
      if (++k % c.every == 0) row(x);
    };
    const SampledSummary<double> sum =
        integrate_sampled(stepper, s, *c.t_end, period, ctrl, control_fixed_steps(c), observer);
    if (!(s.time == last_row)) row(s);  // the end, always
    return sum.ok() ? 0 : failed(sum.reason());
  }
  // ---- adaptive steps over each hold (--rtol) ----
  const AdaptiveFlags& a = c.adaptive;
  const AdaptiveOptions<double> opt = adaptive_options(c);
  if (a.rtol_asked) out.message(rtol_warning(c));
  std::vector<Event<double>> ev = adaptive_events(c, stepper.scene());
  std::FILE* event_file = open_event_csv(c, ev);
  const bool at_times = !a.t_eval.empty();
  std::size_t next = 0;  // the next --t-eval time
  const double t_end = *c.t_end;
  const bool forward = t_end >= s.time;
  auto due = [&](double t) { return next < a.t_eval.size() && (forward ? a.t_eval[next] <= t : a.t_eval[next] >= t); };
  auto sample = [&](const State<double>& x) {  // t0 and each sample, the new command held
    if (!at_times) {
      row(x);
    } else if (next < a.t_eval.size() && a.t_eval[next] == x.time) {
      row(x);
      ++next;
    }
  };
  auto nodes = [&](const DenseNode<double>& na, const DenseNode<double>& nb, double t_next, const auto& wheels_at) {
    const double tb = nb.state.time;
    const bool at_sample = tb == t_next && t_next != t_end;  // its row comes with the next command
    if (!at_times) {
      if (!at_sample && ++k % c.every == 0) row(nb.state);
      return;
    }
    if (!due(tb)) return;
    const LieHermite<double> seg(na, nb, opt.quintic);
    while (due(tb) && !(at_sample && a.t_eval[next] == tb)) {
      wheels_at(a.t_eval[next]);
      row(a.t_eval[next] == tb ? nb.state : seg.state(a.t_eval[next]));
      ++next;
    }
    wheels_at(tb);
  };
  const auto& scene = stepper.scene();
  auto sink = [&](int index, const State<double>& x, bool) {
    if (!event_file) return;
    std::fprintf(event_file, "%s,", ev[static_cast<std::size_t>(index)].name.c_str());
    CsvSink(event_file).row(x.time, x.rotation.matrix(), x.omega, scene.energy(x), up.dot(scene.spatial_momentum(x)),
                            scene.spatial_momentum(x), 0);
  };
  AdaptiveSummary<double> total;
  auto& wheels = stepper.scene().template effect<ReactionWheels<double>>();
  const HoldAdaptive<decltype(nodes), decltype(sink)> between{opt, ev.empty() ? nullptr : &ev, nodes, sink, &total,
                                                              wheels.has_friction() ? &wheels : nullptr};
  const SampledSummary<double> sum = integrate_sampled(stepper, s, t_end, period, ctrl, between, sample);
  if (!at_times && !(s.time == last_row)) row(s);  // the end, always
  if (event_file) std::fclose(event_file);
  if (!sum.command_error.empty()) return failed(sum.reason());
  out.message(adaptive_summary_text(c, total, method_text(c, scene)));
  if (!total.ok()) return failed(total.message());
  return 0;
}

template <class Scheme, class SceneT>
trompo::Stepper<Scheme, SceneT> with_scene(const Config&, const trompo::Stepper<Scheme, SceneT>& st, SceneT scene);
template <class Scheme, class SceneT>
trompo::ComposedStepper<Scheme, SceneT> with_scene(const Config&, const trompo::ComposedStepper<Scheme, SceneT>& st,
                                                   SceneT scene);

/// A closed-loop ensemble (--ensemble FILE with the control flags): member i is the control
/// run of its row by trompo::integrate_sampled_ensemble, on its own copies of the stepper
/// (its wheels started at its state; its own scene when the file gives its inertia) and of
/// the controller, between the samples fixed steps of --dt (--max-step-angle) or, with
/// --rtol, adaptive steps over each hold. Each member is its single run bit for bit.
template <class StepperT>
int run_control_with(StepperT stepper, const Config& c, trompo::State<double>, EnsembleRun& e) {
  using namespace trompo;
  const EnsembleInput& in = e.input;
  const std::size_t n = in.size();
  std::vector<State<double>> starts(n);
  for (std::size_t i = 0; i < n; ++i) {
    starts[i].rotation = in.rotation[i];
    starts[i].omega = in.omega[i];
  }
  const CliController ctrl = make_controller(c);
  const double period = control_period(c);
  EnsembleOptions options{.threads = c.threads};
  options.progress = e.progress;
  auto setup = [&](std::size_t i, StepperT& st, CliController&) {
    if (in.inertia.empty()) return;
    st = with_scene(c, st, member_control_scene(c, in, i));
    st.scene().template effect<ReactionWheels<double>>().start(starts[i].time, starts[i].omega);
  };
  if (c.adaptive.on) {
    if (c.adaptive.rtol_asked) e.messages.push_back(rtol_warning(c));
    const AdaptiveSteps<double> between{adaptive_options(c)};
    e.sampled = integrate_sampled_ensemble(stepper, starts, *c.t_end, period, ctrl, between, options, setup);
  } else {
    const FixedSteps<double> between = control_fixed_steps(c);
    e.sampled = integrate_sampled_ensemble(stepper, starts, *c.t_end, period, ctrl, between, options, setup);
  }
  e.wheels = stepper.scene().template effect<ReactionWheels<double>>().size();
  const V3 up = c.up.normalized();
  e.states.resize(n);
  e.energy.resize(n);
  e.momentum_map.resize(n);
  e.spatial_momentum.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    e.states[i] = e.sampled[i].state;
    e.energy[i] = e.sampled[i].energy;
    e.spatial_momentum[i] = e.sampled[i].spatial_momentum;
    e.momentum_map[i] = up.dot(e.spatial_momentum[i]);
  }
  return e.failed() ? 3 : 0;
}

/// A control run: --scheme (plain, or composed by --order/--composition) on ControlScene.
template <class Out>
int run_control(const Config& c, Out& out) {
  using namespace trompo;
  const ControlScene scene = control_scene(c);
  State<double> s0;
  s0.rotation = initial_attitude(c);
  s0.omega = c.omega;
  int code = 0;
  const bool known = RegisteredSchemes::visit(c.scheme, [&](auto entry) {
    using E = typename decltype(entry)::type;
    using S = typename E::Scheme;
    if constexpr (!E::template steps<ControlScene>) {
      throw invalid_input("--scheme " + c.scheme + ": cannot carry reaction wheels (control runs: " +
                          control_scheme_names() + ")");
    } else if constexpr (std::is_same_v<S, Splitting>) {
      // The splitting carries the wheels by its rotor flow [W14]; --composition / --order
      // pick the method as for any scene (Chin's are refused; SABA/SBAB run on the hub's
      // exact flow with the rotor and the held torques as B [W18]).
      const Splitting split(splitting_method(c, scene));
      split.check(scene);
      code = run_control_with(Stepper<Splitting, ControlScene>(split, scene), c, s0, out);
    } else {
      if constexpr (E::compositions == Compositions::symmetric) {
        if (c.order != 2) {
          code = run_control_with(
              ComposedStepper<S, ControlScene>(make_scheme(std::type_identity<S>{}, c), scene,
                                               c.composition ? *c.composition : composition_of_order(c.order)),
              c, s0, out);
          return;
        }
      }
      code = run_control_with(Stepper<S, ControlScene>(make_scheme(std::type_identity<S>{}, c), scene), c, s0, out);
    }
  });
  if (!known) throw invalid_input("--scheme: unknown scheme '" + c.scheme + "'");
  return code;
}
// ---- end control ----

// ---- torque laws given as code (trompo.TorqueLaw; no flag) ------------------------------

/// A CodeTorque as the callable of trompo::TorqueLaw (model/effects/torque_law.hpp): the law's
/// value, and its Jacobians (in the law's own axes, theory [W8]) from the code's own or by
/// central differences: ∂τ/∂w_k ≈ (τ(Λ exp(δ ê_k)) − τ(Λ exp(−δ ê_k)))/2δ with δ = ε^{1/3},
/// and ∂τ/∂Ω_k with δ_k = ε^{1/3} max(1, |Ω|∞): truncation and round-off both O(ε^{2/3}),
/// which Newton's convergence does not notice (it needs a tangent, not an exact one).
struct CodeLaw {
  CodeTorque law;
  V3 operator()(double t, const M3& Lambda, const V3& omega) const {
    return law.on() ? law.torque(t, Lambda, omega) : V3::Zero();
  }
  void jacobians(double t, const M3& Lambda, const V3& omega, M3& D_w, M3& D_v) const {
    if (!law.on()) {
      D_w.setZero();
      D_v.setZero();
      return;
    }
    if (law.jacobians) {
      law.jacobians(t, Lambda, omega, D_w, D_v);
      return;
    }
    const double d = std::cbrt(std::numeric_limits<double>::epsilon());
    const double dv = d * std::max(1.0, omega.cwiseAbs().maxCoeff());
    for (int k = 0; k < 3; ++k) {
      const V3 e = d * V3::Unit(k);
      D_w.col(k) = (law.torque(t, Lambda * trompo::SO3d::exp(e).matrix(), omega) -
                    law.torque(t, Lambda * trompo::SO3d::exp(-e).matrix(), omega)) / (2 * d);
      D_v.col(k) = (law.torque(t, Lambda, omega + dv * V3::Unit(k)) - law.torque(t, Lambda, omega - dv * V3::Unit(k))) /
                   (2 * dv);
    }
  }
};

/// The scene of a run with torque laws as code: the effects scene (zeros where not given)
/// and one law in body axes, one in space axes (zero where not given).
using CodeTorqueScene =
    trompo::Scene<double, trompo::UniformGravity<double>, trompo::ViscousDamping<double>, trompo::ConstantBodyTorque<double>,
                  trompo::ConstantSpaceTorque<double>, trompo::Rotor<double>,
                  trompo::TorqueLaw<double, CodeLaw, trompo::Axes::body>, trompo::TorqueLaw<double, CodeLaw, trompo::Axes::space>>;

inline CodeTorqueScene code_torque_scene(const Config& c, const trompo::RigidBody<double>& body) {
  using namespace trompo;
  return CodeTorqueScene(body, UniformGravity<double>(c.mgl, c.com, c.up), ViscousDamping<double>(c.damping),
                         ConstantBodyTorque<double>(c.body_torque), ConstantSpaceTorque<double>(c.space_torque),
                         Rotor<double>(c.rotor), TorqueLaw<double, CodeLaw, Axes::body>(CodeLaw{c.body_law}),
                         TorqueLaw<double, CodeLaw, Axes::space>(CodeLaw{c.space_law}));
}

/// The schemes compiled for torque laws as code: each is a call into the interpreter, so
/// only the applied-torque schemes worth that cost are instantiated (compile time).
constexpr const char* kCodeTorqueSchemes = "simo-kappa, simo-collocation (plain or composed: order, composition) or rk4";

/// Throws invalid_input for what a torque law as code cannot run with.
inline void check_code_torques(const Config& c) {
  if (c.scheme != "simo-kappa" && c.scheme != "simo-collocation" && c.scheme != "rk4")
    throw invalid_input(std::string("TorqueLaw: runs with scheme ") + kCodeTorqueSchemes + ", got " + c.scheme);
  if (c.gravity_gradient) throw invalid_input("TorqueLaw: not with GravityGradient (a satellite scene has it alone)");
  if (c.control.on()) throw invalid_input("TorqueLaw: not in a control run (give the torque as the controller's command)");
  if (!c.ensemble.empty()) throw invalid_input("TorqueLaw: not in an ensemble (each call takes the interpreter's lock)");
}

/// A run with torque laws as code, on kCodeTorqueSchemes.
inline int run_code_torque(const Config& c, const trompo::RigidBody<double>& body, const trompo::State<double>& s0,
                           RowSink& out) {
  using namespace trompo;
  check_code_torques(c);
  const CodeTorqueScene scene = code_torque_scene(c, body);
  if (c.scheme == "simo-kappa") return run_scheme(c, make_scheme(std::type_identity<SimoKappa>{}, c), scene, s0, out);
  if (c.scheme == "simo-collocation")
    return run_scheme(c, make_scheme(std::type_identity<SimoCollocation>{}, c), scene, s0, out);
  return run(Stepper<RK4, CodeTorqueScene>(RK4{}, scene), c, s0, out);
}
// ---- end torque laws ----

// ---- the checks and the scenes (formerly main's body) ----------------------------------

/// Calls f(scene) with the scene simulate() runs for `body` and weight `mgl`. The library
/// compiles in exactly the effects a scene names; the CLI keeps three scenes: the free body
/// (mgl 0: no torque computed at all), the heavy top, and, when any of
/// --damping/--torque/--space-torque/--rotor is given, a scene with all of them (those not
/// given are zero) to keep the number of compiled variants small. `heavy`: a heavy top even
/// at mgl 0 (an ensemble whose members carry their own mgl). simulate(), validate() and
/// validate_member() all choose here, so that a check sees the scene that runs.
template <class F>
decltype(auto) with_scene_of(const Config& c, const trompo::RigidBody<double>& body, double mgl, bool heavy, F&& f) {
  using namespace trompo;
  const UniformGravity<double> gravity(mgl, c.com, c.up);
  if (c.gravity_gradient)  // a satellite (docs/spacecraft.md): its H column is the Jacobi integral
    return f(cases::Satellite<double>(body, GravityGradient<double>(body, *c.gravity_gradient, c.orbit_normal, c.radial)));
  if (c.have_effects)
    return f(Scene<double, UniformGravity<double>, ViscousDamping<double>, ConstantBodyTorque<double>,
                   ConstantSpaceTorque<double>, Rotor<double>>(body, gravity, ViscousDamping<double>(c.damping),
                                                               ConstantBodyTorque<double>(c.body_torque),
                                                               ConstantSpaceTorque<double>(c.space_torque),
                                                               Rotor<double>(c.rotor)));
  if (mgl == 0 && !heavy) return f(FreeScene<double>(body));
  return f(HeavyTop<double>(body, gravity));
}

/// The initial state on its scene, before any row: an Omega whose energy H or momentum pi
/// overflows for this inertia has no first row, and would fail the first step as
/// "non-finite". Bad input: throws invalid_input naming the field. (A rotation vector whose
/// length overflows is refused where it is read, attitude_of.)
template <class Scene>
void check_initial_state(const Scene& scene, const trompo::State<double>& s, const std::string& omega_field) {
  const double H = scene.energy(s);
  const V3 pi = scene.spatial_momentum(s);
  if (!std::isfinite(H) || !pi.allFinite())
    throw invalid_input(omega_field + ": the initial " + (std::isfinite(H) ? "momentum pi" : "energy H") +
                        " is not finite (overflows for this Omega and inertia)");
}

/// Everything trompo-simulate checks before it writes anything; throws invalid_input.
void validate(const Config& c) {
  using namespace trompo;
  State<double> s0;
  const RigidBody<double> body =
      c.unphysical_ok ? RigidBody<double>(c.inertia, allow_unphysical_inertia) : RigidBody<double>(c.inertia);
  s0.rotation = initial_attitude(c);
  s0.omega = c.omega;
  s0.validate();
  // Validate the scheme name and the gravity parameters before writing anything.
  if (!known_scheme(c.scheme)) throw invalid_input("--scheme: unknown scheme '" + c.scheme + "'");
  if (c.control.on()) {  // control in the loop: its own scene (the hub's inertia, the orbit)
    check_initial_state(control_scene(c), s0, "--omega");
    (void)make_controller(c);
    return;
  }
  if (c.code_torques()) {  // torque laws as code (trompo.TorqueLaw): their own scene
    check_code_torques(c);
    check_initial_state(code_torque_scene(c, body), s0, "omega");
  }
  const UniformGravity<double> gravity(c.mgl, c.com, c.up);
  // Effects are validated here too, before any row is written.
  const ViscousDamping<double> damping(c.damping);
  const ConstantBodyTorque<double> body_torque(c.body_torque);
  const ConstantSpaceTorque<double> space_torque(c.space_torque);
  const Rotor<double> rotor(c.rotor);
  (void)gravity, (void)damping, (void)body_torque, (void)space_torque, (void)rotor;
  if (c.gravity_gradient) (void)GravityGradient<double>(body, *c.gravity_gradient, c.orbit_normal, c.radial);
  with_scene_of(c, body, c.mgl, false, [&](const auto& scene) { check_initial_state(scene, s0, "--omega"); });
  // ---- splitting: method and projection against the scene, before any output (an
  // ensemble's members are checked again on their own scenes: validate_member) ----
  if (c.scheme == "splitting")
    with_scene_of(c, body, c.mgl, false, [&](const auto& scene) { check_splitting(c, scene); });
  // ---- adaptive: every --event built on the run's scene before any row (events::flip
  // refuses a body without an intermediate axis, naming its moments) ----
  if (c.adaptive.on)
    with_scene_of(c, body, c.mgl, false, [&](const auto& scene) {
      for (const auto& [name, terminal] : c.adaptive.events) {
        try {
          (void)events::by_name(scene, name, terminal);
        } catch (const invalid_input& e) {  // the library's "event NAME: …" as the flag's
          const std::string why = e.what();
          throw invalid_input(why.rfind("event ", 0) == 0 ? "--" + why : "--event " + name + ": " + why);
        }
      }
    });
  if (c.scheme == "exact" && !c.ensemble.empty())
    throw invalid_input("--ensemble: not with --scheme exact (the closed forms run one top at a time)");
  if (c.scheme == "exact" && c.have_effects)
    throw invalid_input("--scheme exact: no closed form with damping, torques or a rotor");
  if (c.scheme == "exact" && !body.is_diagonal())
    throw invalid_input("--scheme exact: no closed form for a non-diagonal inertia (give principal axes)");
  if (c.scheme == "exact" && c.mgl != 0 &&
      (std::abs(c.inertia(0, 0) - c.inertia(1, 1)) > 1e-12 * c.inertia.cwiseAbs().maxCoeff() ||
       (c.com.normalized() - V3::UnitZ()).norm() > 1e-14))
    throw invalid_input("--scheme exact: no closed form for this top (needs J11 = J22 and --com 0,0,1: a Lagrange top)");
}

/// Whether the members carry their own mgl (then every member's scene is a heavy top).
inline bool member_weights(const RowSink&) { return false; }
inline bool member_weights(const EnsembleRun& e) { return !e.input.mgl.empty(); }
inline int run_exact(const Config& c, const trompo::RigidBody<double>& body, const trompo::State<double>& s0, EnsembleRun& out);

/// Runs a validated Config into `out`: a RowSink (rows of one trajectory) or an
/// EnsembleRun. Returns the CLI's exit status (0 done, 3 a step failed).
template <class Out>
int simulate_any(const Config& c, Out& out) {
  using namespace trompo;
  const RigidBody<double> body =
      c.unphysical_ok ? RigidBody<double>(c.inertia, allow_unphysical_inertia) : RigidBody<double>(c.inertia);
  State<double> s0;
  s0.rotation = initial_attitude(c);
  s0.omega = c.omega;
  if (c.scheme == "exact") return run_exact(c, body, s0, out);
  if (c.control.on()) return run_control(c, out);  // control in the loop (one run or an ensemble of them)
  if constexpr (std::is_same_v<Out, RowSink>) {
    if (c.code_torques()) return run_code_torque(c, body, s0, out);  // trompo.TorqueLaw
  }
  // The scene of with_scene_of; an ensemble with a per-member mgl is a heavy top even
  // where a member's mgl is 0.
  return with_scene_of(c, body, c.mgl, member_weights(out),
                       [&](const auto& scene) { return dispatch_scheme(c, scene, s0, out); });
}

inline int run_exact(const Config&, const trompo::RigidBody<double>&, const trompo::State<double>&, EnsembleRun&) {
  throw invalid_input("--ensemble: not with --scheme exact (the closed forms run one top at a time)");
}

/// Member i's body: its own inertia or the Config's.
inline trompo::RigidBody<double> member_body(const Config& c, const EnsembleInput& in, std::size_t i) {
  using trompo::RigidBody;
  if (in.inertia.empty())
    return c.unphysical_ok ? RigidBody<double>(c.inertia, trompo::allow_unphysical_inertia) : RigidBody<double>(c.inertia);
  return RigidBody<double>(in.inertia[i]);
}

/// Member i's scene, built as simulate() builds the single run's (same constructors, same
/// arguments): its rows are what `trompo-simulate` gives with that member's flags.
template <class SceneT>
SceneT member_scene(const Config& c, const EnsembleInput& in, std::size_t i) {
  using namespace trompo;
  const RigidBody<double> body = member_body(c, in, i);
  if constexpr (SceneT::is_free) {
    return SceneT(body);
  } else if constexpr (std::is_same_v<SceneT, cases::Satellite<double>>) {  // not reached: parse_flags refuses it
    return SceneT(body, GravityGradient<double>(body, c.gravity_gradient.value_or(0.0), c.orbit_normal, c.radial));
  } else {
    const UniformGravity<double> gravity(in.mgl.empty() ? c.mgl : in.mgl[i], c.com, c.up);
    if constexpr (std::is_same_v<SceneT, HeavyTop<double>>)
      return SceneT(body, gravity);
    else
      return SceneT(body, gravity, ViscousDamping<double>(c.damping), ConstantBodyTorque<double>(c.body_torque),
                    ConstantSpaceTorque<double>(c.space_torque), Rotor<double>(c.rotor));
  }
}

/// Checks member i (finite numbers, a rigid body's inertia, a valid weight, and for
/// --scheme splitting the method on the member's own scene, of the type simulate() runs);
/// throws invalid_input naming the field.
void validate_member(const Config& c, const EnsembleInput& in, std::size_t i) {
  using namespace trompo;
  State<double> s;
  s.rotation = in.rotation[i];
  s.omega = in.omega[i];
  s.validate();
  if (c.control.on()) {  // a closed loop: the control scene with the member's inertia
    if (!in.mgl.empty()) throw invalid_input("column mgl: a control run's scene has no gravity");
    check_initial_state(member_control_scene(c, in, i), s, "omega1,2,3");
    return;
  }
  const RigidBody<double> body = member_body(c, in, i);
  const double mgl = in.mgl.empty() ? c.mgl : in.mgl[i];
  const UniformGravity<double> gravity(mgl, c.com, c.up);
  (void)gravity;
  with_scene_of(c, body, mgl, !in.mgl.empty(),
                [&](const auto& scene) { check_initial_state(scene, s, "omega1,2,3"); });
  if (c.scheme == "splitting")
    with_scene_of(c, body, mgl, !in.mgl.empty(), [&](const auto& scene) { check_splitting(c, scene); });
}

/// The same stepper on member i's scene (of the same type).
template <class Scheme, class SceneT>
trompo::Stepper<Scheme, SceneT> with_scene(const Config&, const trompo::Stepper<Scheme, SceneT>& st, SceneT scene) {
  return trompo::Stepper<Scheme, SceneT>(st.scheme(), std::move(scene), st.options());
}
template <class Scheme, class SceneT>
trompo::ComposedStepper<Scheme, SceneT> with_scene(const Config&, const trompo::ComposedStepper<Scheme, SceneT>& st,
                                                   SceneT scene) {
  return trompo::ComposedStepper<Scheme, SceneT>(st.scheme(), std::move(scene), st.method(), st.options());
}
template <class Scheme, class SceneT>
trompo::ProcessedStepper<Scheme, SceneT> with_scene(const Config&, const trompo::ProcessedStepper<Scheme, SceneT>& st,
                                                    SceneT scene) {
  return trompo::ProcessedStepper<Scheme, SceneT>(st.scheme(), std::move(scene), st.options());
}
/// A splitting stepper on member i's scene: the method of --composition, or the default of
/// --order chosen for this member's body (Chin where its free flow is exact), as the single
/// run with the member's --inertia chooses it, not for the Config's body.
template <bool EnergyProjection, class SceneT>
trompo::Stepper<trompo::SplittingScheme<EnergyProjection>, SceneT> with_scene(
    const Config& c, const trompo::Stepper<trompo::SplittingScheme<EnergyProjection>, SceneT>& st, SceneT scene) {
  const trompo::SplittingScheme<EnergyProjection> scheme(splitting_method(c, scene));
  return trompo::Stepper<trompo::SplittingScheme<EnergyProjection>, SceneT>(scheme, std::move(scene), st.options());
}

/// One adaptive member (--rtol): the driver from `s` to t_end with the member's events,
/// keeping the states at --t-eval (from each step's dense segment, as run_adaptive writes
/// them) and the events' states; `s` ends at the member's final state. The same steps as
/// the single run's (the same options, an observer as run_adaptive has).
template <class StepperT>
trompo::AdaptiveSummary<double> run_member(const StepperT& stepper, const Config& c, const trompo::AdaptiveOptions<double>& opt,
                                           trompo::State<double>& s, std::vector<trompo::State<double>>& at_times,
                                           std::vector<std::vector<trompo::State<double>>>& found) {
  using namespace trompo;
  const std::vector<double>& t_eval = c.adaptive.t_eval;
  std::vector<Event<double>> ev = adaptive_events(c, stepper.scene());
  found.assign(ev.size(), {});
  std::size_t next = 0;
  if (!t_eval.empty() && t_eval[0] == s.time) {
    at_times.push_back(s);
    next = 1;
  }
  const bool forward = *c.t_end >= s.time;
  auto observer = [&](const DenseNode<double>& na, const DenseNode<double>& nb) {
    const double tb = nb.state.time;
    auto due = [&] { return next < t_eval.size() && (forward ? t_eval[next] <= tb : t_eval[next] >= tb); };
    if (!due()) return;
    const LieHermite<double> seg(na, nb, opt.quintic);
    for (; due(); ++next) at_times.push_back(t_eval[next] == tb ? nb.state : seg.state(t_eval[next]));
  };
  auto sink = [&](int index, const State<double>& x, bool) { found[static_cast<std::size_t>(index)].push_back(x); };
  return integrate_adaptive(stepper, s, *c.t_end, opt, observer, ev.empty() ? nullptr : &ev, sink);
}

/// The ensemble counterpart of run(): every member from t = 0 to t_end by integrate_ensemble
/// (--threads), or with --rtol by run_member on integrate_ensemble's schedule; one shared
/// stepper unless members carry their own mgl or inertia.
template <class StepperT>
int run(const StepperT& stepper, const Config& c, const trompo::State<double>&, EnsembleRun& e) {
  using SceneT = typename StepperT::Scene;
  const EnsembleInput& in = e.input;
  const std::size_t n = in.size();
  e.states.assign(n, trompo::State<double>{});
  for (std::size_t i = 0; i < n; ++i) {
    e.states[i].rotation = in.rotation[i];
    e.states[i].omega = in.omega[i];
  }
  trompo::EnsembleOptions options{.threads = c.threads};
  options.progress = e.progress;
  std::vector<StepperT> steppers;
  if (!in.mgl.empty() || !in.inertia.empty()) {
    steppers.reserve(n);
    for (std::size_t i = 0; i < n; ++i) steppers.push_back(with_scene(c, stepper, member_scene<SceneT>(c, in, i)));
  }
  if (c.adaptive.on) {
    if constexpr (trompo::detail::is_processed<StepperT>()) {
      throw invalid_input("--rtol: the processed composition's processor is tied to h: use --order 6");
    } else {
      const trompo::AdaptiveOptions<double> opt = adaptive_options(c);
      if (c.adaptive.rtol_asked) e.messages.push_back(rtol_warning(c));
      e.adaptive.assign(n, {});
      e.at_times.assign(n, {});
      e.events.assign(n, {});
      trompo::detail::for_each_member(n, options, [&](std::size_t i) {
        e.adaptive[i] =
            run_member(steppers.empty() ? stepper : steppers[i], c, opt, e.states[i], e.at_times[i], e.events[i]);
      });
    }
  } else if (steppers.empty()) {
    e.summaries = trompo::integrate_ensemble(stepper, e.states, *c.t_end, *c.dt, options);
  } else {
    e.summaries = trompo::integrate_ensemble(steppers, e.states, *c.t_end, *c.dt, options);
  }
  const V3 up = c.up.normalized();
  e.energy.resize(n);
  e.momentum_map.resize(n);
  e.spatial_momentum.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const SceneT& scene = steppers.empty() ? stepper.scene() : steppers[i].scene();
    e.spatial_momentum[i] = scene.spatial_momentum(e.states[i]);
    e.energy[i] = scene.energy(e.states[i]);
    e.momentum_map[i] = up.dot(e.spatial_momentum[i]);
  }
  return e.failed() ? 3 : 0;
}

/// The columns an ensemble file may have; the first six are required.
inline const std::vector<std::string>& ensemble_columns() {
  static const std::vector<std::string> names = {"rotation1", "rotation2", "rotation3", "omega1", "omega2", "omega3",
                                                 "mgl",       "J11",       "J22",       "J33",    "J12",    "J13",
                                                 "J23"};
  return names;
}

/// Reads --ensemble FILE: a header line naming the columns (any order; rotation1..3 and
/// omega1..3 required, mgl and J11,J22,J33[,J12,J13,J23] optional), then one member per
/// line; blank lines and lines starting with '#' are skipped. Every member is validated.
/// Throws invalid_input naming the file, the line and the reason.
EnsembleInput read_ensemble(const Config& c) {
  const std::string& path = c.ensemble;
  std::ifstream file(path);
  if (!file) throw invalid_input("--ensemble: cannot open '" + path + "': " + std::strerror(errno));
  const auto& known = ensemble_columns();
  std::vector<int> column_of;  // index into `known` for each column of the file
  std::vector<bool> seen(known.size(), false);
  EnsembleInput in;
  std::string line;
  long line_no = 0;
  auto where = [&] { return "--ensemble: " + path + ":" + std::to_string(line_no) + ": "; };
  auto split = [](const std::string& text) {
    std::vector<std::string> fields;
    std::stringstream ss(text);
    std::string f;
    while (std::getline(ss, f, ',')) {
      const auto b = f.find_first_not_of(" \t\r"), e = f.find_last_not_of(" \t\r");
      fields.push_back(b == std::string::npos ? std::string() : f.substr(b, e - b + 1));
    }
    if (!text.empty() && text.back() == ',') fields.emplace_back();
    return fields;
  };
  while (std::getline(file, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[line.find_first_not_of(" \t\r")] == '#') continue;
    const auto fields = split(line);
    if (column_of.empty()) {  // the header
      for (const auto& name : fields) {
        const auto it = std::find(known.begin(), known.end(), name);
        if (it == known.end())
          throw invalid_input(where() + "unknown column '" + name +
                              "' (rotation1,rotation2,rotation3,omega1,omega2,omega3[,mgl][,J11,J22,J33[,J12,J13,J23]])");
        const auto k = static_cast<std::size_t>(it - known.begin());
        if (seen[k]) throw invalid_input(where() + "column '" + name + "' given twice");
        seen[k] = true;
        column_of.push_back(static_cast<int>(k));
      }
      for (std::size_t k = 0; k < 6; ++k)
        if (!seen[k]) throw invalid_input(where() + "missing column '" + known[k] + "' in the header");
      const bool diag = seen[7] || seen[8] || seen[9], off = seen[10] || seen[11] || seen[12];
      if ((diag && !(seen[7] && seen[8] && seen[9])) || (off && !(seen[10] && seen[11] && seen[12])) || (off && !diag))
        throw invalid_input(where() + "inertia columns must be J11,J22,J33 or all six J11..J23");
      continue;
    }
    if (fields.size() != column_of.size())
      throw invalid_input(where() + "expected " + std::to_string(column_of.size()) + " fields, got " +
                          std::to_string(fields.size()));
    double v[13] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (std::size_t f = 0; f < fields.size(); ++f) {
      const auto k = static_cast<std::size_t>(column_of[f]);
      v[k] = parse_number(where() + known[k], fields[f]);
    }
    in.rotation.push_back(attitude_of(V3(v[0], v[1], v[2]), where() + "rotation1,2,3"));
    in.omega.emplace_back(v[3], v[4], v[5]);
    if (seen[6]) in.mgl.push_back(v[6]);
    if (seen[7]) {
      M3 J = M3::Zero();
      J.diagonal() << v[7], v[8], v[9];
      J(0, 1) = J(1, 0) = v[10];
      J(0, 2) = J(2, 0) = v[11];
      J(1, 2) = J(2, 1) = v[12];
      in.inertia.push_back(J);
    }
    try {
      validate_member(c, in, in.size() - 1);
    } catch (const invalid_input& e) {
      throw invalid_input(where() + e.what());
    }
  }
  if (column_of.empty()) throw invalid_input("--ensemble: " + path + ": no header line");
  if (in.size() == 0) throw invalid_input("--ensemble: " + path + ": no members (only a header)");
  return in;
}

/// The ensemble's CSV: one row per member, its final (or last good) state in the columns
/// of kHeader (iterations: the member's total), between its index and its status.
void write_ensemble(std::FILE* out, const EnsembleRun& e) {
  std::fputs("member,t,R00,R01,R02,R10,R11,R12,R20,R21,R22,W1,W2,W3,H,mu,pi1,pi2,pi3,iterations", out);
  for (int j = 1; j <= e.wheels; ++j) std::fprintf(out, ",wheel%d", j);
  for (int j = 1; j <= e.wheels; ++j) std::fprintf(out, ",u%d", j);
  std::fputs(",status\n", out);
  for (std::size_t i = 0; i < e.states.size(); ++i) {
    const auto& s = e.states[i];
    const M3 R = s.rotation.matrix();
    const V3& pi = e.spatial_momentum[i];
    char line[640];
    char* p = std::to_chars(line, line + 24, i).ptr;
    *p++ = ',';
    p = put_state_columns(p, s.time, R, s.omega, e.energy[i], e.momentum_map[i], pi, e.iterations(i));
    *p++ = ',';
    std::fwrite(line, 1, static_cast<std::size_t>(p - line), out);
    for (int j = 0; j < e.wheels; ++j) std::fprintf(out, "%.17g,", e.sampled[i].wheel_speeds(j));  // [W1] speeds
    for (int j = 0; j < e.wheels; ++j) std::fprintf(out, "%.17g,", e.sampled[i].wheel_torques(j));  // held u
    std::fprintf(out, "%s\n", e.reason(i).c_str());
  }
}

int simulate(const Config& c, RowSink& out) { return simulate_any(c, out); }
int simulate(const Config& c, EnsembleRun& e) { return simulate_any(c, e); }

}  // namespace trompo_simulate
