#pragma once
// integrate(stepper, state, t_end, h[, observer[, options]]): fixed steps from
// state.time to t_end, recovering from failed steps by sub-stepping.
//
//   auto c = trompo::cases::ht1<double>();
//   Stepper<SimoKappa, HeavyTop<double>> stepper(SimoKappa{}, c.scene);
//   State<double> s = c.initial;
//   IntegrationSummary<double> sum = integrate(stepper, s, c.t_end, 0.001);
//   if (!sum.ok()) std::cerr << sum.reason() << " at t = " << s.time << '\n';
//
// The grid. Steps go from t0 = state.time towards t_end through t_k = t0 + k·h; every
// step but the last has size exactly h (so Λ and Ω are bit-identical to those of
// stepper.step(state, h) in a loop, for time-independent scenes), and the last one,
// t_end − t_{n−1}, lands exactly on
// t_end. Its size is in (0, |h|] up to round-off: a remainder within 8 ulps (of the times) of a whole
// number of steps is absorbed, not taken as a step of ~1e-16·h. After every accepted
// step state.time is set to the grid time t_k, so times do not accumulate round-off.
// h < 0 integrates backward; t_end must then be ≤ t0.
//
// The recovery rule (docs/robustness.md). A step that fails (any StepStatus but ok:
// Newton did not converge, singular tangent, out of domain, wrong branch, non-finite)
// leaves the state untouched (Stepper::step). integrate then retries the same interval
// as two steps of half the size, and recursively halves any half that fails, down to
// options.max_halvings levels (interval/2^max_halvings). The exact schemes keep H and
// μ on every sub-step, so a recovered interval keeps them too; only the local error
// changes (it shrinks). If a piece still fails at the deepest level, integration stops:
// the state is the last accepted one (state.time says where), and the summary's
// status is that piece's failure. Nothing is lost and nothing is half-committed.
//
// The observer, if given, is called as observer(const State&) at the start and after
// each whole interval of the grid (never on sub-steps). Without one the calls are
// compiled out (`if constexpr`): no cost, no branch.
//
// Deferred output. A stepper whose outputs cost extra (ProcessedStepper: a post-processor
// of 12 base steps) offers advance(traj, h), output(traj), time(traj), set_time(traj, t).
// Without an observer, integrate then advances the kernel through the grid and outputs
// once, at the end (or where a failure stopped it); the grid, the recovery rule and the
// summary are as above. If that last output fails, the state stays the previous output
// (state.time says when) and the summary carries the failure.
//
// Schemes with memory (scheme.hpp). Pass the stepper's Trajectory (stepper.start(s)) to
// carry the memory across calls; a failed interval leaves state and memory as they were,
// and the sub-steps of a recovered interval see the memory in sequence, as the state. A
// plain State passed with such a stepper starts a fresh trajectory for this call (its
// memory is dropped at the end).
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>

#include "trompo/errors.hpp"
#include "trompo/solvers/newton.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// The default observer: none. integrate compiles its calls out.
struct NoObserver {};

/// Controls of integrate's recovery.
struct IntegrateOptions {
  /// Deepest halving of a failed interval (2^max_halvings sub-steps at most); 0 turns
  /// recovery off (the first failed step ends the integration).
  int max_halvings = 10;
};

namespace detail {
/// Whether a step h between t0 and t_end is above the time resolution at the far end,
/// |h| > 4ε·max(|t0|, |t_end|): integrate() refuses a smaller one (its grid times would not be
/// distinct), and the adaptive driver takes no such step.
template <class Scalar>
bool resolves(Scalar h, Scalar t0, Scalar t_end) {
  using std::abs;
  const Scalar far = abs(t0) > abs(t_end) ? abs(t0) : abs(t_end);
  return abs(h) > Scalar(4) * std::numeric_limits<Scalar>::epsilon() * far;  // false for NaN
}
}  // namespace detail

/// What integrate did.
template <class Scalar>
struct IntegrationSummary {
  std::int64_t steps = 0;         ///< grid intervals taken in a single step
  std::int64_t substeps = 0;      ///< accepted sub-steps inside recovered intervals
  std::int64_t recovered = 0;     ///< grid intervals that needed sub-steps
  std::int64_t failures = 0;      ///< failed step attempts (recovered or not)
  std::int64_t iterations = 0;    ///< Newton iterations of the accepted and failed steps
  int max_depth = 0;              ///< deepest halving used (0: no sub-stepping)
  StepStatus status = StepStatus::ok;        ///< ok, or the failure that stopped it
  StepStatus last_failure = StepStatus::ok;  ///< the last failure seen, even if recovered
  Scalar time = Scalar(0);        ///< the time reached (t_end when ok)

  /// True when the integration reached t_end.
  bool ok() const { return status == StepStatus::ok; }
  /// The failure that stopped it, as text ("ok" when none).
  const char* reason() const { return to_string(status); }
};

namespace detail {

/// Whether a stepper's scene has reaction wheels, whose momentum h_w(t) the steps read at
/// their times: the drivers then step the differences of the stored times (theory [W4]).
template <class Stepper>
inline constexpr bool stepper_has_wheels_v = [] {
  if constexpr (requires { Stepper::Scene::has_wheels; }) return Stepper::Scene::has_wheels;
  else return false;
}();

/// Whether integrate() may defer the output: a stepper with advance/output (a processed
/// composition, processed_composition.hpp) on its trajectory, and no observer.
template <class Stepper, class StateT, class Observer>
constexpr bool defers_output() {
  if constexpr (!std::is_same_v<std::decay_t<Observer>, NoObserver>) return false;
  else
    return requires(const Stepper& st, StateT& s, typename Stepper::Scalar t) {
      st.advance(s, t);
      st.output(s);
      st.set_time(s, t);
      { st.time(s) } -> std::convertible_to<typename Stepper::Scalar>;
    };
}

template <class Stepper, class StateT, bool Deferred = false>
struct Integrator {
  using Scalar = typename Stepper::Scalar;
  const Stepper& stepper;
  StateT& state;
  IntegrationSummary<Scalar>& sum;
  int max_halvings;

  /// The time reached (with a deferred output, the stepper's kernel is ahead of the state).
  Scalar time() const {
    if constexpr (Deferred) return stepper.time(state);
    else return state.time;
  }

  /// Whether the stepper's scene has reaction wheels (stepper_has_wheels_v).
  static constexpr bool wheels = stepper_has_wheels_v<Stepper>;

  /// One step of size dt that should end at the (sub-)grid time t_b.
  bool attempt(Scalar dt, Scalar t_b) {
    // With wheels the step spans t_b − t_a, exact for nearby times, so that it ends at t_b
    // itself: a step of dt that ended an ulp off t_b accounts for h_w(t_a + dt), and setting
    // the time to t_b then moved the wheels by u·(t_b − t_a − dt) outside any step, which
    // walked the total momentum π (1.1e-12 over 5·10⁴ steps of a held command).
    if constexpr (wheels) dt = t_b - time();
    StepReport<Scalar> rep;
    if constexpr (Deferred) rep = stepper.advance(state, dt);
    else rep = stepper.step(state, dt);
    sum.iterations += rep.iterations;
    if (rep.ok()) {
      // The grid time, not t_a + dt with its rounding.
      if constexpr (Deferred) stepper.set_time(state, t_b);
      else state.time = t_b;
      return true;
    }
    ++sum.failures;
    sum.last_failure = rep.status;
    sum.status = rep.status;
    return false;
  }

  /// Covers [time(), t_b], of size dt, by two halves at `depth` (≥ 1); a half that
  /// fails as one step is halved again, down to max_halvings.
  bool halve(Scalar dt, Scalar t_b, int depth) {
    if (depth > sum.max_depth) sum.max_depth = depth;
    const Scalar half = dt / Scalar(2);  // exact in binary floating point
    const Scalar t_mid = time() + half;
    if (!(t_mid != time() && t_mid != t_b)) return false;  // no room left to halve
    for (const Scalar t : {t_mid, t_b}) {
      if (attempt(half, t)) {
        ++sum.substeps;
        continue;
      }
      if (depth >= max_halvings || !halve(half, t, depth + 1)) return false;
    }
    return true;
  }

  /// One grid interval [time(), t_b] of size dt.
  bool interval(Scalar dt, Scalar t_b) {
    if (attempt(dt, t_b)) {
      ++sum.steps;
      return true;
    }
    if (max_halvings <= 0 || !halve(dt, t_b, 1)) return false;
    ++sum.recovered;
    sum.status = StepStatus::ok;
    return true;
  }

  /// With a deferred output: brings the state up to the time reached (after the last
  /// interval, or after a failure). A failure here is the summary's status.
  void finish() {
    if constexpr (Deferred) {
      const StepReport<Scalar> rep = stepper.output(state);
      sum.iterations += rep.iterations;
      if (!rep.ok()) {
        ++sum.failures;
        sum.last_failure = rep.status;
        sum.status = rep.status;
      }
    }
  }
};

}  // namespace detail

namespace detail {
/// Whether a stepper splits the wheels' friction itself (declares `splits_friction = true`:
/// the sampled driver's FrictionSplitStepper).
template <class Stepper>
inline constexpr bool splits_friction_v = [] {
  if constexpr (requires { Stepper::splits_friction; }) return bool(Stepper::splits_friction);
  else return false;
}();

/// Throws invalid_input if the stepper's scene has wheels with viscous friction [W17]: its
/// flow is split around each step by integrate_sampled only (it owns the wheels' hold line,
/// which the flow moves), so `driver` (the caller's name) would leave it out. The sampled
/// driver's own split step (FrictionSplitStepper, for its adaptive holds) passes.
template <class Stepper>
void refuse_wheel_friction(const Stepper& stepper, const char* driver) {
  if constexpr (splits_friction_v<Stepper>) {  // the sampled driver's split step
    (void)stepper, (void)driver;
  } else if constexpr (requires { stepper.scene().wheel_friction(); }) {
    if (stepper.scene().wheel_friction())
      detail::fail(driver, ": the wheels have viscous friction, which only integrate_sampled applies (split "
                   "around each step, docs/theory.md [W17]); ", driver, " would leave it out");
  }
}

/// The number of steps of integrate's grid from t0 to t_end at h: ceil(span/h), less a few ulps so
/// that a span of a whole number of steps up to round-off does not end with a vanishing step. The
/// round-off of span is that of the times, ε·max(|t0|, |t_end|), which far from t = 0 exceeds
/// ε·span (a hold of the sampled driver from t = 16.1 to 16.2 at h = 0.02 has span/h = 5 + 7e-14).
/// Throws invalid_input for too many steps, or an h below the time resolution at the far end
/// (the grid times would not be distinct). span = t_end − t0 is non-zero, of h's sign.
template <class Scalar>
std::int64_t grid_steps(Scalar t0, Scalar t_end, Scalar h) {
  using std::abs, std::ceil;
  const Scalar ratio = (t_end - t0) / h;  // > 0
  const Scalar eps = std::numeric_limits<Scalar>::epsilon();
  const Scalar times = (abs(t0) > abs(t_end) ? abs(t0) : abs(t_end)) / abs(h);
  const Scalar reach = ratio > times ? ratio : times;
  const Scalar n_real = ceil(ratio - Scalar(8) * eps * (reach > Scalar(1) ? reach : Scalar(1)));
  if (!(n_real < Scalar(9.0e18))) detail::fail("integrate: ", ratio, " steps of h = ", h, " is too many");
  if (!detail::resolves(h, t0, t_end))
    detail::fail("integrate: time step h = ", h, " is below the time resolution at t = ",
                 abs(t0) > abs(t_end) ? abs(t0) : abs(t_end));
  return n_real < Scalar(1) ? 1 : static_cast<std::int64_t>(n_real);
}

/// integrate's checks of its step and options: h finite and non-zero, max_halvings ≥ 0
/// (throws invalid_input); integrate_steps and the sampled driver's friction split use them.
template <class Scalar>
void check_step_options(Scalar h, const IntegrateOptions& options) {
  using std::isfinite;
  if (!static_cast<bool>(isfinite(h)) || h == Scalar(0))
    detail::fail("integrate: time step h must be finite and non-zero, got ", h);
  if (options.max_halvings < 0) detail::fail("integrate: max_halvings must be >= 0, got ", options.max_halvings);
}

/// The number of steps of integrate's grid over a hold from t_a to t_b (≠ t_a) at `step`, after
/// integrate()'s checks of the step (throws invalid_input as integrate() would): the sampled
/// driver's FixedSteps::max_steps and its friction split use it.
template <class Scalar>
std::int64_t hold_grid(Scalar t_a, Scalar t_b, Scalar step, const IntegrateOptions& options) {
  check_step_options(step, options);
  if ((step > Scalar(0)) != (t_b > t_a))
    detail::fail("integrate: time step h = ", step, " is against the direction of the run to ", t_b);
  return grid_steps(t_a, t_b, step);
}

/// Whether a plain State is integrated with a stepper whose scheme carries memory.
template <class Stepper, class StateT>
constexpr bool needs_trajectory() {
  if constexpr (requires { typename Stepper::Memory; })
    return std::is_same_v<StateT, State<typename Stepper::Scalar>> &&
           !std::is_same_v<typename Stepper::Memory, NoMemory>;
  else
    return false;
}

template <class Stepper, class StateT, class Observer>
IntegrationSummary<typename Stepper::Scalar> integrate_steps(const Stepper& stepper, StateT& state,
                                                             typename Stepper::Scalar t_end,
                                                             typename Stepper::Scalar h, Observer&& observer,
                                                             IntegrateOptions options);
}  // namespace detail

/// Integrates `state` from state.time to t_end with steps h (see the file comment for
/// the grid, the recovery rule and the observer). Throws invalid_input, before taking
/// any step, if h is zero or not finite, if t_end is not finite or behind the start
/// (in the direction of h), if the state is not finite, or if h is below the time
/// resolution at t_end, or if the scene's wheels have viscous friction (integrate_sampled
/// applies it). Numerical failures never throw: they are in the summary.
template <class Stepper, class StateT, class Observer = NoObserver>
  requires std::derived_from<StateT, State<typename Stepper::Scalar>>
IntegrationSummary<typename Stepper::Scalar> integrate(const Stepper& stepper, StateT& state,
                                                       typename Stepper::Scalar t_end,
                                                       typename Stepper::Scalar h,
                                                       Observer&& observer = {},
                                                       IntegrateOptions options = {}) {
  using Scalar = typename Stepper::Scalar;
  detail::refuse_wheel_friction(stepper, "integrate");
  if constexpr (detail::needs_trajectory<Stepper, StateT>()) {
    // A plain State with a stepper whose scheme has memory: a fresh trajectory for this call.
    auto traj = stepper.start(state);
    const IntegrationSummary<Scalar> sum = integrate(stepper, traj, t_end, h, std::forward<Observer>(observer), options);
    static_cast<State<Scalar>&>(state) = traj.state();
    return sum;
  } else {
    return detail::integrate_steps(stepper, state, t_end, h, std::forward<Observer>(observer), options);
  }
}

namespace detail {

template <class Stepper, class StateT, class Observer>
IntegrationSummary<typename Stepper::Scalar> integrate_steps(const Stepper& stepper, StateT& state,
                                                             typename Stepper::Scalar t_end,
                                                             typename Stepper::Scalar h, Observer&& observer,
                                                             IntegrateOptions options) {
  using Scalar = typename Stepper::Scalar;
  using std::abs;
  using std::ceil;
  constexpr bool observed = !std::is_same_v<std::decay_t<Observer>, NoObserver>;
  using std::isfinite;
  const auto finite = [](Scalar x) { return static_cast<bool>(isfinite(x)); };

  check_step_options(h, options);
  if (!finite(t_end)) detail::fail("integrate: end time t_end must be finite, got ", t_end);
  if constexpr (requires { stepper.output(state); }) {
    // A trajectory left with its output pending (ProcessedStepper::advance by hand): start
    // from that output.
    const StepReport<Scalar> rep = stepper.output(state);
    if (!rep.ok()) {
      IntegrationSummary<Scalar> failed;
      failed.status = failed.last_failure = rep.status;
      failed.failures = 1;
      failed.time = state.time;
      return failed;
    }
  }
  state.validate();
  const Scalar t0 = state.time;
  const Scalar span = t_end - t0;
  if (!finite(span)) detail::fail("integrate: interval from t0 = ", t0, " to t_end = ", t_end, " overflows");
  if ((h > 0 && span < 0) || (h < 0 && span > 0))
    detail::fail("integrate: end time t_end = ", t_end, " is behind the start t0 = ", t0,
                 " for the direction of h = ", h);

  IntegrationSummary<Scalar> sum;
  sum.time = t0;
  if constexpr (observed) observer(static_cast<const State<Scalar>&>(state));
  if (span == Scalar(0)) return sum;

  const std::int64_t n = grid_steps(t0, t_end, h);

  Integrator<Stepper, StateT, defers_output<Stepper, StateT, Observer>()> run{stepper, state, sum,
                                                                                options.max_halvings};
  for (std::int64_t k = 1; k <= n; ++k) {
    // Whole steps of exactly h; the last one is whatever is left to t_end.
    const bool last = k == n;
    const Scalar t_b = last ? t_end : t0 + static_cast<Scalar>(k) * h;
    if (!run.interval(last ? t_end - run.time() : h, t_b)) break;
    if constexpr (observed) observer(static_cast<const State<Scalar>&>(state));
  }
  run.finish();
  sum.time = state.time;
  return sum;
}

}  // namespace detail
}  // namespace trompo
