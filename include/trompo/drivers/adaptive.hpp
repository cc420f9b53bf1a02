#pragma once
// Adaptive steps: a tolerance in, a solution out (docs/adaptive.md; docs/theory.md §16, [A1]–[A7]).
//
//   auto c = trompo::cases::ht1<double>();
//   ComposedStepper<SimoKappa, HeavyTop<double>> stepper(SimoKappa{}, c.scene, 4);
//   AdaptiveOptions<double> opt;  opt.rtol = 1e-8;  opt.atol = 1e-8;
//   // Odeint-like: advance a state to t_end, an observer sees every accepted step
//   State<double> s = c.initial;
//   AdaptiveSummary<double> sum = integrate_adaptive(stepper, s, c.t_end, opt);
//   // SciPy-like: a solution object with dense output, t_eval and events
//   AdaptiveRun<double> run = solve(stepper, c.initial, c.t_end, opt, {0.5, 1.0}, {nutation_max(c.scene)});
//   State<double> mid = run.solution(0.25);
//
// Tolerance mode [A1]. The run advances with steps of the scheme only (a composition whole),
// so whatever the scheme keeps (H and μ for Simo-κ, also in its compositions) stays exact
// for the whole variable-step run; no extrapolated value is ever used (it would break H, μ).
// The one correction is [A7]'s (`hold_invariants`, drivers/invariant_hold.hpp): after the
// error test of every 8th accepted attempt (a step; with Richardson's estimate, m), a nudge of at most 64ε back onto the first state's
// H and μ (π), which stops round-off's √N·ε walk over long runs. Three error estimates (`AdaptiveOptions::estimate`):
//  - defect (default up to order 6) [D4]: the step Ψ_h(y) is taken once; its local error is
//    the integral of the defect u' − f(u) of the step's Lie–Hermite interpolant u (cubic at
//    order 2, quintic at orders 4 and 6), by Simpson's rule (order 2) or Hermite's (orders
//    4 and 6: Simpson's nodes plus the rates' derivatives at the ends, which the quintic
//    has), whose ends are the nodes' rates: 1 new evaluation of Ω̇ per attempt, plus the
//    end node (Ω̇, and Ω̈ for the quintic), which the dense output and events reuse;
//  - richardson (default for schemes whose error scales with the load: the splitting) [A8]:
//    an attempt is m steps of h (the run advancing with them) and one coarse step of m·h from
//    the same start, e = (Ψ_h^m − Ψ_{mh})/(m^p − 1): the scheme's own error, whatever its
//    size, at 1/m of a step per step (m = `substeps`, 8 unless given);
//  - doubling (orders above 6): Richardson's with m = 2, Ψ_{2h}(y) against Ψ_h∘Ψ_h(y);
//    three steps for the two kept (above order 6 a given `substeps` makes it Richardson's).
// With Richardson's estimate h, first_step and max_step are those of the steps the run
// advances with (an attempt spans m of them), `accepted` counts them, and each has its
// dense node; the controller acts once per attempt. The rotation cap bounds the coarse step,
// except for the splitting, whose exact free flow may turn m times as far (then it bounds
// the kept steps).
// The estimate is measured in the frame-invariant RMS norm [A2] and divided by |h| (error
// per unit step), so that the global error is ∝ tol.
// Söderlind's H211b filter [A3] picks the next h; a rejected step retries with the
// elementary controller; a Newton failure (any StepStatus but ok) is a rejection that
// quarters h and caps the next growth at 1.5×; the failure contract holds: a failed step
// leaves the trajectory untouched, and a rejected one is undone (its state put back; a
// memory that is only a hint, such as Simo-κ's history or the splitting's frame, keeps
// that step as a hint, any other memory is stepped in a copy committed on acceptance only).
// A composition (ComposedStepper) is stepped whole: h changes only between whole
// composed steps. The processed composition is not accepted (a compile-time error): its
// processor P_h is tied to h, so every change of h would cost P_{h'}∘P_h⁻¹ (24 base steps,
// about two kernel steps) and make the outputs depend on the step history; run it at fixed
// h with integrate().
//
// Reversible mode [A5] (Hairer & Söderlind 2005) for conservative scenes and long runs,
// e.g. of the splitting: no estimator, no rejection; the step is h = ε/ρ with the step
// density ρ updated explicitly and symmetrically from the control function
// Q(y) = √(|Ω|² + ω₀²) (the rotation per step ≈ ε), G = d/dt log Q = Ω·Ω̇/Q². Q is even
// under the reversal (Λ, Ω) ↦ (Λ, −Ω) of the conservative tops, and G odd, as the method
// requires. ε is set from the tolerance by a pilot of 20 tolerance-mode attempts (mean of h·Q)
// unless given. Only the last step is shortened to land on t_end.
//
// Events [A6] (SciPy's semantics). g(t, Λ, Ω) is sampled at the step ends and at three
// interior points of the interpolant; a sign change (filtered by `direction`) is located by
// Brent's method on the interpolant to a few ulp in t. A terminal event (its count reached)
// ends the run with a real step from the last node to the event time, so the invariants
// are exact there too.
//
// No heap allocation in the step loop: the scratch of the events is reserved before it;
// only solve()'s solution object grows (its vectors of nodes, t_eval states and events).
//
// The driver's parts (docs/adaptive.md, "The driver's parts"), each behind one concept:
//   drivers/adaptive/error_estimate.hpp   ErrorEstimator: DefectEstimate [D4],
//                                         RichardsonEstimate [A8]; the norm ErrorNorm [A2]
//   drivers/adaptive/step_controller.hpp  StepController: ToleranceController [A3],
//                                         ReversibleController [A5]
//   drivers/adaptive/event_location.hpp   Event, events::, the locator (Brent's method) [A6]
//   drivers/invariant_hold.hpp            the hold [A7]
//   drivers/dense_output.hpp              the dense nodes and interpolant [D1]–[D4]
// What stays here: the options and summary, the attempts (one step, or Richardson's m + 1),
// their commits (dense nodes, events, a terminal event's real step), the step bounds (the
// rotation cap, t_end) and the two loops, run_tolerance and run_reversible.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "trompo/drivers/adaptive/error_estimate.hpp"
#include "trompo/drivers/adaptive/event_location.hpp"
#include "trompo/drivers/adaptive/step_controller.hpp"
#include "trompo/drivers/dense_output.hpp"
#include "trompo/drivers/integrate.hpp"
#include "trompo/drivers/invariant_hold.hpp"
#include "trompo/errors.hpp"
#include "trompo/model/state.hpp"
#include "trompo/schemes/scheme.hpp"

namespace trompo {

/// Options of the adaptive driver (names as SciPy's solve_ivp where they exist).
template <class Scalar>
struct AdaptiveOptions {
  Scalar rtol = Scalar(1e-6);             ///< relative tolerance (> 0)
  Scalar atol = Scalar(1e-6);             ///< absolute tolerance (≥ 0; rad and rad/s)
  /// Tolerance (error estimate + PI control) or reversible (step density) mode.
  StepControl control = StepControl::tolerance;
  /// Tolerance mode: the error estimate (automatic: Richardson's for the splitting, else
  /// the defect up to order 6 and doubling above).
  ErrorEstimate estimate = ErrorEstimate::automatic;
  /// Richardson's estimate: the steps m per attempt, 2 … 16 (0: 8; doubling is m = 2;
  /// ignored where automatic picks the defect; above order 6 automatic takes Richardson's
  /// with this m instead of doubling) [A8].
  int substeps = 0;
  /// Tolerance mode: true (default) — the tolerances bound the error at the end of the span
  /// T = |t_end − t₀|: the error per unit step is held to tol/T, so that the end error,
  /// which grows like t for a rigid body (its phase), is ≈ tol whatever T [A2]; false — the
  /// tolerances bound the error per unit time, and the end error grows like tol·T.
  bool tolerance_over_span = true;
  Scalar first_step = Scalar(0);          ///< |h| of the first step; 0: selected [A3]
  Scalar max_step = std::numeric_limits<Scalar>::infinity();  ///< largest |h|
  /// Largest rotation per step, |h|·|Ω| (rad): keeps the Newton increments of the
  /// sub-steps below π and the dense output's log on its branch.
  Scalar max_rotation = Scalar(3);
  Scalar safety = Scalar(0.9);            ///< controller safety factor
  Scalar min_factor = Scalar(0.2);        ///< smallest h_{n+1}/h_n
  Scalar max_factor = Scalar(5);          ///< largest h_{n+1}/h_n
  std::int64_t max_steps = 100000000;     ///< accepted + rejected attempts before giving up
  /// Reversible mode: ε of h = ε/ρ (0: from the tolerance by a pilot run) and the floor
  /// ω₀ of Q (0: max(1e-3|Ω₀|, √|Ω̇₀|, 1e-8)).
  Scalar epsilon = Scalar(0);
  /// Reversible mode: the floor ω₀ of the control function Q = √(|Ω|² + ω₀²).
  Scalar omega_floor = Scalar(0);
  /// Dense output and events: quintic (else cubic) Lie–Hermite interpolant [D2].
  bool quintic = true;
  /// Hold what the stepper keeps (H, μ, π) at the first state's values against round-off
  /// [A7] (drivers/invariant_hold.hpp): after every 8th accepted attempt a first-order
  /// correction of O(ε) removes the √N·ε walk of long runs. false: the steps' states as
  /// they come.
  bool hold_invariants = true;
  /// With hold_invariants, also hold a Lagrange top's third integral Ω_s where H and μ are
  /// held [A9] (drivers/invariant_hold.hpp): the nutation phase of long runs.
  bool hold_third_integral = false;

  /// The largest `substeps`.
  static constexpr int max_substeps = 16;

  /// Throws invalid_input naming the first bad field.
  void validate() const {
    using std::isfinite;
    const auto fin = [](Scalar x) { return static_cast<bool>(std::isfinite(static_cast<double>(x))); };
    if (!(fin(rtol) && rtol > 0)) detail::fail("adaptive: rtol must be finite and > 0, got ", rtol);
    if (!(fin(atol) && atol >= 0)) detail::fail("adaptive: atol must be finite and >= 0, got ", atol);
    if (!(fin(first_step) && first_step >= 0))
      detail::fail("adaptive: first_step must be finite and >= 0 (0: selected), got ", first_step);
    if (!(max_step > 0)) detail::fail("adaptive: max_step must be > 0, got ", max_step);
    if (!(fin(max_rotation) && max_rotation > 0 && max_rotation <= Scalar(4)))
      detail::fail("adaptive: max_rotation must be in (0, 4] rad, got ", max_rotation);
    if (!(fin(safety) && safety > 0 && safety <= 1)) detail::fail("adaptive: safety must be in (0, 1], got ", safety);
    if (!(fin(min_factor) && min_factor > 0 && min_factor < 1))
      detail::fail("adaptive: min_factor must be in (0, 1), got ", min_factor);
    if (!(fin(max_factor) && max_factor > 1)) detail::fail("adaptive: max_factor must be finite and > 1, got ", max_factor);
    if (max_steps < 1) detail::fail("adaptive: max_steps must be >= 1, got ", max_steps);
    if (substeps != 0 && (substeps < 2 || substeps > max_substeps))
      detail::fail("adaptive: substeps must be 0 (automatic) or in [2, ", max_substeps, "], got ", substeps);
    if (estimate == ErrorEstimate::doubling && substeps != 0 && substeps != 2)
      detail::fail("adaptive: estimate = doubling takes 2 substeps, got substeps = ", substeps);
    if (estimate == ErrorEstimate::defect && substeps != 0)
      detail::fail("adaptive: substeps are Richardson's; estimate = defect takes none, got substeps = ", substeps);
    if (!(fin(epsilon) && epsilon >= 0)) detail::fail("adaptive: epsilon must be finite and >= 0, got ", epsilon);
    if (!(fin(omega_floor) && omega_floor >= 0))
      detail::fail("adaptive: omega_floor must be finite and >= 0, got ", omega_floor);
  }
};

/// How an adaptive run ended (SciPy's status codes).
enum class AdaptiveStatus : int {
  failed = -1,      ///< a step could not be taken (see AdaptiveSummary::failure)
  reached_end = 0,  ///< t_end reached
  event = 1         ///< a terminal event ended the run
};

/// What the adaptive driver did.
template <class Scalar>
struct AdaptiveSummary {
  std::int64_t accepted = 0;    ///< accepted steps (with Richardson's estimate, each of an attempt's m)
  std::int64_t rejected = 0;    ///< attempts rejected by the error test
  std::int64_t failures = 0;    ///< attempts whose step failed (Newton, …), retried shorter
  std::int64_t iterations = 0;  ///< Newton iterations of all attempts
  std::int64_t base_steps = 0;  ///< step() calls on the stepper (each a whole composition)
  /// How the run ended.
  AdaptiveStatus status = AdaptiveStatus::reached_end;
  StepStatus failure = StepStatus::ok;  ///< the step failure that stopped a failed run
  Scalar time = Scalar(0);              ///< the time reached
  Scalar epsilon = Scalar(0);           ///< reversible mode: the ε used
  Scalar h_last = Scalar(0);            ///< the last accepted step
  int substeps = 1;                     ///< steps per attempt: Richardson's m, else 1
  bool step_too_small = false;          ///< a failed run whose next step fell below the time resolution at t
  /// SciPy's message for a step below the time resolution.
  static constexpr const char* step_too_small_message = "Required step size is less than spacing between numbers.";
  /// True unless the run failed.
  bool ok() const { return status != AdaptiveStatus::failed; }
  /// SciPy's message.
  const char* message() const {
    switch (status) {
      case AdaptiveStatus::reached_end: return "The solver successfully reached the end of the integration interval.";
      case AdaptiveStatus::event: return "A termination event occurred.";
      case AdaptiveStatus::failed: break;
    }
    if (failure != StepStatus::ok) return to_string(failure);
    return step_too_small ? step_too_small_message : "Too many steps.";
  }
};

/// The default observer of integrate_adaptive: none.
struct NoStepObserver {};
/// The default event sink: none.
struct NoEventSink {};

namespace detail {

/// Whether T is a std::array (a composition's memory, AdaptiveLoop::assign).
template <class T>
struct is_std_array : std::false_type {};
template <class T, std::size_t N>
struct is_std_array<std::array<T, N>> : std::true_type {};
/// The memory type of a trajectory (void for a plain State).
template <class Traj>
struct trajectory_memory {
  using type = void;
};
template <class Traj>
  requires requires { typename Traj::Memory; }
struct trajectory_memory<Traj> {
  using type = typename Traj::Memory;
};


/// The adaptive loop (integrate_adaptive and solve).
template <class Stepper, class Traj, class Observer, class Sink>
struct AdaptiveLoop {
  using Scalar = typename Stepper::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  template <class T>
  using MemoryOf = typename trajectory_memory<T>::type;
  const Stepper& stepper;
  Traj& traj;
  Scalar t_end;
  const AdaptiveOptions<Scalar>& opt;
  Observer& observer;
  Sink& sink;
  AdaptiveSummary<Scalar> sum{};

  /// The node of the motion at `s` (Ω̇, and Ω̈ with `second`): a stepper that carries what
  /// moves with its trajectory outside the state (the friction's split step, the wheels' line
  /// [W17]) first puts it at s's time.
  DenseNode<Scalar> node_at(const State<Scalar>& s, bool second = true) const {
    if constexpr (requires { stepper.wheels_at(s.time); }) stepper.wheels_at(s.time);
    return dense_node(stepper.scene(), s, second);
  }
  /// Adds Ω̈ to a node (as node_at, at the node's own time).
  void add_second(DenseNode<Scalar>& n) const {
    if (n.second) return;
    if constexpr (requires { stepper.wheels_at(n.state.time); }) stepper.wheels_at(n.state.time);
    add_second_rate(stepper.scene(), n);
  }

  AdaptiveLoop(const Stepper& st, Traj& tr, Scalar te, const AdaptiveOptions<Scalar>& o, Observer& ob, Sink& si,
               const std::vector<Event<Scalar>>* ev)
      : stepper(st), traj(tr), t_end(te), opt(o), observer(ob), sink(si) {
    using std::abs;
    span = opt.tolerance_over_span ? abs(te - tr.time) : Scalar(1);
    if (!(span > 0)) span = Scalar(1);
    norm = ErrorNorm<Scalar>{opt.atol, opt.rtol, span};
    if (opt.hold_invariants) hold = InvariantHold<SceneOf>(st.scene(), tr, st.keeps(), opt.hold_third_integral);
    events.list = ev;
  }
  using SceneOf = std::decay_t<decltype(std::declval<const Stepper&>().scene())>;
  /// What the run holds at the first state's values [A7] (nothing unless opt.hold_invariants).
  InvariantHold<SceneOf> hold{};
  /// [A7] after every hold_period-th accepted attempt (one step, or Richardson's m): round-off
  /// adds a few ε in between, and
  /// the hold (336 instructions, and a fresh end node) costs +0.6 % of a Suzuki-5 step of
  /// Simo-κ instead of +4.5 % at every step.
  static constexpr int hold_period = 8;
  int since_hold = 0;
  /// [A7] on a state a step produced.
  void held(State<Scalar>& s) const {
    if (hold.active()) hold.apply(stepper.scene(), s);
  }
  /// The span T the tolerances are spread over (1: per unit time).
  Scalar span = Scalar(1);
  /// The error norm per unit step [A2] (drivers/adaptive/error_estimate.hpp).
  ErrorNorm<Scalar> norm{};

  static constexpr bool observed = !std::is_same_v<std::decay_t<Observer>, NoStepObserver>;
  bool dense() const { return observed || events.any(); }

  // Tolerance mode with the defect estimate [D4]: its quadrature (Simpson's for order 2,
  // Hermite's for orders 4 and 6), and the dense nodes of the current state (a) and of the
  // attempt (b), kept so that each accepted step evaluates one new node.
  bool use_defect = false;
  DefectEstimate<SceneOf> defect{};
  RichardsonEstimate<Scalar> richardson{};
  static_assert(ErrorEstimator<DefectEstimate<SceneOf>> && ErrorEstimator<RichardsonEstimate<Scalar>>);
  /// Steps per attempt: Richardson's m [A8], 1 with the defect estimate.
  int m = 1;
  /// The defect attempt steps `traj` itself when the stepper's memory is only a hint (a
  /// history predictor) or absent: a rejected step puts back the state alone, the memory
  /// keeping that step's history as a hint (any memory is a correct start for such a
  /// scheme), so no copy of the memory is made per step. Otherwise it steps a copy.
  static constexpr bool in_place = [] {
    if constexpr (requires(const Stepper& st) {
                    st.scheme();
                    st.scene();
                  })
      return memory_is_hint_v<std::decay_t<decltype(std::declval<const Stepper&>().scheme())>,
                              std::decay_t<decltype(std::declval<const Stepper&>().scene())>>;
    else
      return false;
  }();
  /// Whether the scene has reaction wheels (stepper_has_wheels_v).
  static constexpr bool has_wheels = stepper_has_wheels_v<Stepper>;
  State<Scalar> start_state{};  ///< the state before an in-place attempt
  Traj coarse{};                ///< Richardson's Ψ_{mh}, kept across attempts (assign copies the used memory)
  /// Richardson's attempt: what its first m − 1 steps leave, for their dense nodes and
  /// events: the state where the memory is a hint (the attempt's last memory serves them),
  /// else the whole trajectory, memory and all (a terminal event in an inner step steps
  /// again from there); and the trajectory the states are committed through.
  using Inner = std::conditional_t<in_place, State<Scalar>, Traj>;
  std::array<Inner, AdaptiveOptions<Scalar>::max_substeps - 1> substates{};
  Traj substep{};
  /// Steps in the current attempt: m, or 1 for a last attempt too short to divide.
  int attempt_m = 1;
  /// The coarse step may turn m times the rotation cap: the scheme's error scales with the
  /// load (the splitting's free flow is exact at any angle). Otherwise the cap bounds the
  /// coarse step, which for an implicit scheme must keep its Newton increments below π.
  bool coarse_turns_freely = false;
  DenseNode<Scalar> node_a{}, node_b{};
  bool have_node_a = false;
  LieHermite<Scalar> attempt_segment{};

  /// The events [A6] (drivers/adaptive/event_location.hpp), their scratch reserved before the loop.
  EventLocator<Scalar> events{};

  Scalar direction() const { return t_end >= traj.time ? Scalar(1) : Scalar(-1); }

  /// The span |h| (≥ 0) of `steps` steps, each within max_step and the rotation cap
  /// |h||Ω| ≤ max_rotation (the span within the cap unless the coarse step turns freely),
  /// tested on squares: the square root and the division only when the rotation cap binds
  /// (between steps they would wait on the step's end).
  Scalar capped(Scalar h_abs, const Vector3& omega, int steps = 1) const {
    using std::sqrt;
    const Scalar k = Scalar(steps);
    h_abs = std::min(h_abs, k * opt.max_step);
    const Scalar w2 = omega.squaredNorm(), turn = (coarse_turns_freely ? k : Scalar(1)) * opt.max_rotation;
    if (h_abs * h_abs * w2 > turn * turn) h_abs = turn / sqrt(w2);
    return h_abs;
  }

  /// The first attempt's span: m first steps (Hairer–Nørsett–Wanner II.4, in the norm of
  /// [A2]: ToleranceController::first_step), each within the caps.
  Scalar first_step() const {
    if (opt.first_step > 0) return capped(Scalar(m) * opt.first_step, traj.omega, m);
    const Scalar h = ToleranceController<Scalar>::first_step(stepper.scene(), traj, opt.atol, opt.rtol, stepper.order(),
                                                             direction(), [&](Scalar x) { return capped(x, traj.omega); });
    return capped(Scalar(m) * h, traj.omega, m);
  }

  /// The observer: observer(a, b), or observer(a, b, summary) for one that wants the counts.
  void notify(const DenseNode<Scalar>& a, const DenseNode<Scalar>& b) {
    if constexpr (std::is_invocable_v<Observer&, const DenseNode<Scalar>&, const DenseNode<Scalar>&,
                                      const AdaptiveSummary<Scalar>&>)
      observer(a, b, static_cast<const AdaptiveSummary<Scalar>&>(sum));
    else
      observer(a, b);
  }

  // ---- events ------------------------------------------------------------------------
  void start_events() { events.start(events.list, traj); }

  // ---- the step ------------------------------------------------------------------------
  /// to = from. Of a composition's memory (one base memory per sub-step index, for the
  /// largest composition: 17 × 240 bytes with Simo-κ's history) only the entries its
  /// sub-steps use are copied: whole copies cost a quarter of an order-2 adaptive step.
  void assign(Traj& to, const Traj& from) const {
    if constexpr (requires { stepper.stages(); } && detail::is_std_array<MemoryOf<Traj>>::value) {
      static_cast<State<Scalar>&>(to) = static_cast<const State<Scalar>&>(from);
      const std::size_t n = std::min(static_cast<std::size_t>(stepper.stages()), from.memory.size());
      for (std::size_t i = 0; i < n; ++i) to.memory[i] = from.memory[i];
    } else {
      to = from;
    }
  }

  /// One attempt of span h ending at t_next: on success `next` holds the state the run
  /// advances with (Ψ_h(y) with the defect estimate, Ψ_{h/m}^m(y) with Richardson's) and the
  /// return value is r², r the error per unit step; on failure the status is set, traj untouched.
  Scalar attempt(Scalar h, Scalar t_next, Traj& next, StepStatus& status) {
    if (!use_defect) return attempt_richardson(h, next, status);
    // The estimate's interpolant [D4]: the cubic for order 2 (its O(h⁴) error enters the
    // estimate as O(h⁵), below the O(h³) local error, and it needs no Ω̈), else the quintic.
    const bool quintic_estimate = defect.quintic();
    if (!have_node_a) {
      node_a = node_at(static_cast<const State<Scalar>&>(traj), quintic_estimate);
      have_node_a = true;
    }
    // In place (a hint memory): the state is kept, and put back by undo() on rejection.
    Traj& end = in_place ? traj : next;
    if constexpr (in_place) start_state = static_cast<const State<Scalar>&>(traj);
    else assign(next, traj);
    const StepReport<Scalar> r = stepper.step(end, h);  // on failure `end` is untouched
    sum.iterations += r.iterations;
    ++sum.base_steps;
    status = r.status;
    if (!r.ok()) return Scalar(0);
    end.time = t_next;
    node_b = node_at(static_cast<const State<Scalar>&>(end), quintic_estimate);
    if (quintic_estimate) add_second(node_a);  // a cubic attempt's start
    attempt_segment = LieHermite<Scalar>(node_a, node_b, quintic_estimate);
    return defect.squared_error(norm, {node_a, node_b, attempt_segment, h});
  }

  /// After a rejected attempt: the state before it (stepped in place), or nothing.
  void undo() {
    if constexpr (in_place)
      if (use_defect) static_cast<State<Scalar>&>(traj) = start_state;
  }

  /// Richardson's attempt [A8]: `fine` = Ψ_{h/m}^m(y), the run's m steps (their first m − 1
  /// states kept in `substates` for the dense output), against one coarse step Ψ_h(y); the
  /// estimate (Ψ_{h/m}^m − Ψ_h)/(m^p − 1) of the m steps' error.
  Scalar attempt_richardson(Scalar h, Traj& fine, StepStatus& status) {
    assign(coarse, traj);
    assign(fine, traj);
    StepReport<Scalar> r = stepper.step(coarse, h);
    sum.iterations += r.iterations;
    ++sum.base_steps;
    // a last attempt of a few ulp of t is one step (its inner times would coincide)
    attempt_m = too_small(h / Scalar(m)) ? 1 : m;
    const Scalar h_step = h / Scalar(attempt_m);
    const bool keep = dense();
    const Scalar t_a = traj.time, t_next = coarse.time;
    for (int j = 0; j < attempt_m && r.ok(); ++j) {
      if constexpr (has_wheels) {
        // With wheels, the inner steps lie on t_a + (j + 1)h/m, each rounded once, the last
        // on the attempt's end, and span their differences, so that h_w(t) telescopes and
        // the steps cover the attempt exactly (a composed step's clock, theory [W4]).
        const Scalar t_b = j + 1 == attempt_m ? t_next : t_a + Scalar(j + 1) * h_step;
        r = stepper.step(fine, t_b - fine.time);
        fine.time = t_b;
      } else {
        r = stepper.step(fine, h_step);
      }
      sum.iterations += r.iterations;
      ++sum.base_steps;
      if (keep && j + 1 < attempt_m) keep_inner(j, fine);
    }
    status = r.status;
    if (!r.ok()) return Scalar(0);
    return richardson.squared_error(norm, {traj, coarse, fine, h, attempt_m});
  }

  /// Keeps what the j-th inner step of Richardson's attempt left (`substates`).
  void keep_inner(int j, const Traj& fine) {
    if constexpr (in_place) substates[static_cast<std::size_t>(j)] = static_cast<const State<Scalar>&>(fine);
    else assign(substates[static_cast<std::size_t>(j)], fine);
  }

  /// The trajectory at the end of the j-th inner step, to commit: its state with the
  /// attempt's memory (a hint) in `substep`, or the whole trajectory kept.
  Traj& inner(int j) {
    if constexpr (in_place) {
      static_cast<State<Scalar>&>(substep) = substates[static_cast<std::size_t>(j)];
      return substep;
    } else {
      return substates[static_cast<std::size_t>(j)];
    }
  }

  /// Commits an accepted attempt ending at t_next: the defect's one step, or Richardson's m
  /// steps, each with its dense node and events where they are wanted. False when a
  /// terminal event ended the run.
  /// Counts each step as accepted before it is committed (a terminal event in an inner step
  /// leaves the rest uncounted).
  bool commit_attempt(Traj& next, Scalar t_next) {
    if (use_defect) {
      ++sum.accepted;
      return commit(next, t_next, true, in_place);
    }
    if (!dense()) {
      sum.accepted += attempt_m;
      return commit(next, t_next);
    }
    if constexpr (in_place) assign(substep, next);  // the memory, a hint
    for (int j = 0; j + 1 < attempt_m; ++j) {
      Traj& step_end = inner(j);
      ++sum.accepted;
      if (!commit(step_end, step_end.time, false, false, false)) return false;
    }
    ++sum.accepted;
    return commit(next, t_next);
  }

  /// Commits `next` (ending at t_next), reports the step and its events. Returns false when
  /// a terminal event ended the run (traj then at the event time).
  /// `node_b_ready`: node_b (and attempt_segment) belong to the step's end (the defect
  /// estimate). `stepped_in_place`: the step's end is already `traj` (the defect attempt on
  /// a hint memory) and its start is `start_state`; otherwise the end is `next`.
  /// `attempt_end`: false for the inner steps of Richardson's attempt, which the hold skips
  /// (it would be lost: the attempt's next steps were taken from the unheld state).
  bool commit(Traj& next, Scalar t_next, bool node_b_ready = false, bool stepped_in_place = false,
              bool attempt_end = true) {
    Traj& now = stepped_in_place ? traj : next;
    now.time = t_next;
    // [A7] after the error test (the estimate judges the scheme's step, not the nudge); the
    // end node is then evaluated afresh at the held state, so that the events' segment, the
    // observer, the dense solution and the next step all start from the state kept.
    bool held_now = false;
    if (attempt_end && hold.active() && ++since_hold == hold_period) {
      since_hold = 0;
      held(now);
      held_now = true;
      if (node_b_ready) node_b = node_at(static_cast<const State<Scalar>&>(now), node_b.second);
    }
    const State<Scalar>& before = stepped_in_place ? start_state : static_cast<const State<Scalar>&>(traj);
    if (!dense()) {
      if (!stepped_in_place) assign(traj, next);
      if (node_b_ready) node_a = node_b;
      have_node_a = node_b_ready;
      return true;
    }
    if (!have_node_a) node_a = node_at(before);
    if (!node_b_ready) node_b = node_at(static_cast<const State<Scalar>&>(now));
    if (opt.quintic) {  // the estimate's nodes of an order-2 run lack Ω̈
      add_second(node_a);
      add_second(node_b);
    }
    // A finite state whose Ω̇ or Ω̈ overflows (|Ω| near 1e110, or a step without error
    // control gone far astray) has no interpolant: the step is not committed and the run
    // fails as non-finite, at the last node whose rates were finite (found by the fuzzer).
    // Likewise a step that turns the body so far that the interpolant's rotation vector
    // would overflow when squared in exp (found by the fuzzer: |Ω| ≈ 1e240 after a wild
    // potential under the reversible control, which has no error test).
    if (!rates_finite(node_a) || !rates_finite(node_b) || !interpolable(node_a, node_b)) {
      if (stepped_in_place) static_cast<State<Scalar>&>(traj) = start_state;
      have_node_a = false;
      --sum.accepted;
      sum.status = AdaptiveStatus::failed;
      sum.failure = StepStatus::non_finite;
      return false;
    }
    const DenseNode<Scalar>& a = node_a;
    const DenseNode<Scalar>& b = node_b;
    const LieHermite<Scalar> seg = node_b_ready && !held_now && attempt_segment.quintic() == opt.quintic
                                       ? attempt_segment
                                       : LieHermite<Scalar>(a, b, opt.quintic);
    if (events.any()) {
      events.locate(seg, before.time, t_next, direction());
      for (const Occurrence<Scalar>& o : events.found) {
        const bool terminal = events.ends_run(static_cast<std::size_t>(o.index));
        if (!terminal) {
          if constexpr (!std::is_same_v<std::decay_t<Sink>, NoEventSink>) sink(o.index, seg.state(o.t), false);
          continue;
        }
        // A real step from the last node to the event time [A6] (the memory: the last
        // accepted step's, or stepped in place, this step's hint).
        Traj real = traj;
        static_cast<State<Scalar>&>(real) = before;
        IntegrationSummary<Scalar> s;
        // (above the run's resolution, and integrate's own from the step's start to the
        // event, which a step whose end is nearer t = 0 than its start may miss alone)
        if (!too_small(o.t - before.time) && detail::resolves(o.t - before.time, before.time, o.t)) {
          s = integrate(stepper, real, o.t, o.t - before.time);
          sum.iterations += s.iterations;
          sum.base_steps += s.steps + s.substeps;
          if (s.ok()) held(real);
        }
        if (!s.ok()) {  // keep the step's end; report the event from the interpolant
          if constexpr (!std::is_same_v<std::decay_t<Sink>, NoEventSink>) sink(o.index, seg.state(o.t), false);
          continue;
        }
        // An event within a few ulp of t of the step's start (no step to take) ends the run
        // at that node, which the observer has seen: no step of zero length is reported
        // (its interpolant would divide by h = 0).
        // Its node is checked as commit's are: a state whose rates overflow has no interpolant
        // (found by the fuzzer: Ω̈ = NaN at an event reached by a step of 1.6e-15 from
        // |Ω̇| ≈ 1e43); the event is then reported from the step's own interpolant, as when the
        // real step fails, and the run goes on.
        if constexpr (observed) {
          if (real.time != a.state.time) {
            DenseNode<Scalar> end = node_at(static_cast<const State<Scalar>&>(real));
            if (opt.quintic) add_second(end);
            if (!rates_finite(end) || !interpolable(a, end)) {
              if constexpr (!std::is_same_v<std::decay_t<Sink>, NoEventSink>) sink(o.index, seg.state(o.t), false);
              continue;
            }
            notify(a, end);
          }
        }
        if constexpr (!std::is_same_v<std::decay_t<Sink>, NoEventSink>) sink(o.index, static_cast<const State<Scalar>&>(real), true);
        traj = real;
        have_node_a = false;
        sum.status = AdaptiveStatus::event;
        return false;
      }
      events.passed(now);
    }
    if constexpr (observed) notify(a, b);
    if (!stepped_in_place) assign(traj, next);
    node_a = node_b;
    have_node_a = true;
    return true;
  }

  /// Whether a node's rates (Ω̇, and Ω̈ where the quintic needs it) are finite.
  bool rates_finite(const DenseNode<Scalar>& n) const {
    return detail::all_finite(n.omega_dot) && (!opt.quintic || detail::all_finite(n.omega_ddot));
  }

  /// Whether the segment between two nodes can be evaluated: its rotation vector, at most
  /// |h|(|Ω_a| + |Ω_b|) + h²(|Ω̇_a| + |Ω̇_b|) (+ |h|³(|Ω̈_a| + |Ω̈_b|) for the quintic) in each
  /// component, stays far below √(max) (~1e154 in double), whose square exp would overflow;
  /// and its rate's Hermite data, |Ω_a| + |Ω_b| + |h|(|Ω̇_a| + |Ω̇_b|) (+ h²(|Ω̈_a| + |Ω̈_b|)),
  /// far below max, so that Ω_b − Ω_a and the basis' sums do not overflow (found by the fuzzer:
  /// |Ω| near 1e308 over a step of 1e-160, whose interpolant gave NaN at its own nodes).
  bool interpolable(const DenseNode<Scalar>& a, const DenseNode<Scalar>& b) const {
    using std::abs, std::sqrt;
    const Scalar h = abs(b.state.time - a.state.time);
    const auto largest = [](const Eigen::Matrix<Scalar, 3, 1>& v) { return v.cwiseAbs().maxCoeff(); };
    Scalar rates = largest(a.state.omega) + largest(b.state.omega) + h * (largest(a.omega_dot) + largest(b.omega_dot));
    if (opt.quintic) rates += h * h * (largest(a.omega_ddot) + largest(b.omega_ddot));
    const Scalar size = h * rates;
    return size <= sqrt(std::numeric_limits<Scalar>::max()) / Scalar(1024) &&  // false for NaN
           rates <= std::numeric_limits<Scalar>::max() / Scalar(1024);
  }

  /// Whether a step from t of size h lands on (or beyond) t_end: then it is shortened.
  Scalar clip(Scalar h, bool& last) const {
    using std::abs;
    const Scalar left = t_end - traj.time;
    last = abs(h) >= abs(left) * (Scalar(1) - Scalar(8) * std::numeric_limits<Scalar>::epsilon());
    return last ? left : h;
  }

  /// Whether a step h is zero or below the time resolution at the run's far end
  /// (integrate's rule, detail::resolves, from the current time to t_end).
  bool too_small(Scalar h) const { return !detail::resolves(h, traj.time, t_end) || h == Scalar(0); }

  // ---- tolerance mode [A3] --------------------------------------------------------------
  /// Whether the scheme's error scales with the load (SchemeTraits::error_scales_with_load).
  static bool error_scales_with_load(const Stepper& st) {
    if constexpr (requires { st.scheme(); }) return traits_of(st.scheme()).error_scales_with_load;
    else return false;
  }

  /// The estimate of opt.estimate: the defect, or Richardson's with its m [A8].
  void choose_estimate() {
    const int p = stepper.order();
    const detail::EstimateChoice c = detail::choose_estimate(opt.estimate, p, error_scales_with_load(stepper), opt.substeps);
    use_defect = c.defect;
    m = c.m;
    defect = DefectEstimate<SceneOf>{&stepper.scene(), DefectEstimate<SceneOf>::rule_for(p)};  // [D4]
    richardson.order = p;
    attempt_m = m;
    sum.substeps = m;
    coarse_turns_freely = !use_defect && error_scales_with_load(stepper);
  }

  void run_tolerance() {
    using std::abs;
    const Scalar dir = direction();
    choose_estimate();
    ToleranceController<Scalar> ctl(dir * first_step(), stepper.order(), opt.safety, opt.min_factor, opt.max_factor);
    Traj next = traj;
    std::int64_t attempts = 0;
    while (traj.time != t_end) {
      if (++attempts > opt.max_steps) {
        sum.status = AdaptiveStatus::failed;
        return;
      }
      ctl.h = dir * capped(abs(ctl.h), traj.omega, m);
      bool last = false;
      const Scalar h_clipped = clip(ctl.proposal(), last);
      if (too_small(h_clipped) && !last) {
        sum.status = AdaptiveStatus::failed;
        sum.step_too_small = true;
        sum.time = traj.time;
        return;
      }
      // The step actually taken is the difference of the two stored times, so that the
      // times are the sum of the steps and the defect estimate [D4] sees the same h (an
      // h off by an ulp of t would show as an error of |Ω̇|·ulp(t), above a tight tol).
      const Scalar t_next = last ? t_end : traj.time + h_clipped;
      const Scalar h_try = t_next - traj.time;
      StepStatus status = StepStatus::ok;
      const Scalar r2 = attempt(h_try, t_next, next, status);  // r², r the error per unit step
      if (status != StepStatus::ok) {  // Newton failure: shorter step, nothing committed
        ++sum.failures;
        sum.failure = status;
        ctl.fail(h_try);
        if (too_small(ctl.proposal())) {
          sum.status = AdaptiveStatus::failed;
          return;
        }
        continue;
      }
      if (!(r2 <= Scalar(1))) {  // rejected
        ++sum.rejected;
        ctl.reject(h_try, r2);
        undo();
        continue;
      }
      ctl.accept(h_try, r2, last);
      sum.h_last = h_try / Scalar(attempt_m);
      if (!commit_attempt(next, t_next)) break;
    }
    sum.time = traj.time;
  }

  // ---- reversible mode [A5] ----------------------------------------------------------------
  /// The floor ω₀ of the control function Q (drivers/adaptive/step_controller.hpp).
  Scalar omega_floor() const {
    return ReversibleController<Scalar>::omega_floor(stepper.scene(), traj, opt.omega_floor);
  }

  void run_reversible(Scalar epsilon) {
    using std::abs;
    const Scalar dir = direction();
    const Scalar w0 = omega_floor();
    Scalar Q, G;
    ReversibleController<Scalar>::control(stepper.scene(), traj, w0, Q, G);
    sum.epsilon = epsilon;
    ReversibleController<Scalar> ctl(epsilon, dir, Q, G);
    Traj next = traj;
    std::int64_t steps = 0;
    while (traj.time != t_end) {
      if (++steps > opt.max_steps) {
        sum.status = AdaptiveStatus::failed;
        return;
      }
      bool last = false;
      const Scalar h = clip(ctl.proposal(), last);
      if (too_small(h) && !last) {
        // ρ overflowed (Ω·Ω̇ beyond the range) or is NaN, or h fell below a few ulp of t:
        // a step of h = 0 would throw in the recovery below, one below ulp(t) would not
        // advance t. The run fails where it is.
        sum.status = AdaptiveStatus::failed;
        sum.failure = StepStatus::non_finite;
        sum.time = traj.time;
        return;
      }
      const Scalar t_next = last ? t_end : traj.time + h;
      // The step taken is the difference of the stored times (as in tolerance mode): a step
      // of h whose clock moved by fl(t + h) − t ran the dynamics ahead of the clock by up to
      // ulp(t) a step (a free body started at t = 1e8 drifted 3.4e-6 in 100 s,
      // tests/test_adaptive.cpp).
      const Scalar h_step = t_next - traj.time;
      assign(next, traj);
      StepReport<Scalar> r = stepper.step(next, h_step);
      sum.iterations += r.iterations;
      ++sum.base_steps;
      if (!r.ok()) {  // recovery by halves, as integrate(): the interval is kept
        ++sum.failures;
        sum.failure = r.status;
        assign(next, traj);
        if (!detail::resolves(h_step / Scalar(2), traj.time, t_next)) {
          // halves below the time resolution (integrate would refuse them): the run fails
          // where it is, with the step's own failure (found by the fuzzer)
          sum.status = AdaptiveStatus::failed;
          sum.time = traj.time;
          return;
        }
        const IntegrationSummary<Scalar> s = integrate(stepper, next, t_next, h_step / Scalar(2));
        sum.iterations += s.iterations;
        sum.base_steps += s.steps + s.substeps;
        if (!s.ok()) {
          sum.failure = s.status;
          sum.status = AdaptiveStatus::failed;
          sum.time = traj.time;
          return;
        }
      }
      ++sum.accepted;
      sum.h_last = h_step;
      if (!commit(next, t_next)) break;
      ReversibleController<Scalar>::control(stepper.scene(), traj, w0, Q, G);
      ctl.accept(h, G, last);
    }
    sum.time = traj.time;
  }
};

/// Reversible mode's ε when none is given [A5]: 20 tolerance-mode attempts on a copy of
/// `state`; ε = the mean of |h|·Q (Q with the floor w0) along their steps. Their Newton
/// iterations and base steps are added to `sum`.
template <class Stepper, class StateT>
typename Stepper::Scalar pilot_epsilon(const Stepper& stepper, const StateT& state, typename Stepper::Scalar t_end,
                                       const AdaptiveOptions<typename Stepper::Scalar>& options,
                                       typename Stepper::Scalar w0, AdaptiveSummary<typename Stepper::Scalar>& sum) {
  using Scalar = typename Stepper::Scalar;
  StateT pilot = state;
  AdaptiveOptions<Scalar> po = options;
  po.control = StepControl::tolerance;
  po.max_steps = 20;
  Scalar acc = Scalar(0);
  int n = 0;
  auto pobs = [&](const DenseNode<Scalar>& a, const DenseNode<Scalar>& b) {
    using std::abs;
    using std::sqrt;
    acc += abs(b.state.time - a.state.time) * sqrt(a.state.omega.squaredNorm() + w0 * w0);
    ++n;
  };
  NoEventSink none;
  AdaptiveLoop<Stepper, StateT, decltype(pobs), NoEventSink> pl(stepper, pilot, t_end, po, pobs, none, nullptr);
  pl.run_tolerance();
  sum.iterations += pl.sum.iterations;
  sum.base_steps += pl.sum.base_steps;
  if (n == 0) detail::fail("adaptive: reversible mode could not set epsilon (the pilot took no step: ",
                           pl.sum.message(), "); give epsilon");
  return acc / Scalar(n);
}

template <class Stepper>
constexpr bool is_processed() {
  return requires(const Stepper& st, typename Stepper::TrajectoryType& tr) { st.advance(tr, typename Stepper::Scalar(1)); };
}

}  // namespace detail

/// Integrates `state` (a State, or the stepper's Trajectory) from state.time to t_end with
/// adaptive steps (file comment). observer(const DenseNode& a, const DenseNode& b) is called
/// after each accepted step (LieHermite(a, b) is its interpolant; an observer that also
/// takes a third argument gets the AdaptiveSummary so far); sink(index, state,
/// terminal) for each event found. Throws invalid_input on bad options, a non-finite t_end
/// or state, bad events, or wheels with viscous friction [W17], before any step. Step failures never throw: see the summary.
template <class Stepper, class StateT, class Observer = NoStepObserver, class Sink = NoEventSink>
  requires std::derived_from<StateT, State<typename Stepper::Scalar>>
AdaptiveSummary<typename Stepper::Scalar> integrate_adaptive(const Stepper& stepper, StateT& state,
                                                            typename Stepper::Scalar t_end,
                                                            const AdaptiveOptions<typename Stepper::Scalar>& options,
                                                            Observer&& observer = {},
                                                            const std::vector<Event<typename Stepper::Scalar>>* event_list = nullptr,
                                                            Sink&& sink = {}) {
  using Scalar = typename Stepper::Scalar;
  static_assert(!detail::is_processed<Stepper>(),
                "integrate_adaptive: the processed composition's processor is tied to h (a change of h costs "
                "P_h'∘P_h⁻¹, 24 base steps, and its outputs would depend on the step history): run it at fixed h "
                "with integrate(), or adapt a ComposedStepper");
  detail::refuse_wheel_friction(stepper, "integrate_adaptive");
  if constexpr (detail::needs_trajectory<Stepper, StateT>()) {
    auto traj = stepper.start(state);
    const AdaptiveSummary<Scalar> sum =
        integrate_adaptive(stepper, traj, t_end, options, std::forward<Observer>(observer), event_list, std::forward<Sink>(sink));
    static_cast<State<Scalar>&>(state) = traj.state();
    return sum;
  } else {
    options.validate();
    if (options.estimate == ErrorEstimate::defect && stepper.order() > 6)
      detail::fail("adaptive: estimate = defect suits schemes of order <= 6 (the quintic interpolant's own error "
                   "enters at O(h^7)); use richardson, doubling or automatic, got order ", stepper.order());
    if (!std::isfinite(static_cast<double>(t_end))) detail::fail("adaptive: t_end must be finite, got ", t_end);
    state.validate();
    detail::AdaptiveLoop<Stepper, StateT, Observer, Sink> loop(stepper, state, t_end, options, observer, sink, event_list);
    loop.start_events();
    loop.sum.time = state.time;
    if (state.time == t_end) return loop.sum;
    if (options.control == StepControl::tolerance) {
      loop.run_tolerance();
    } else {
      const Scalar epsilon = options.epsilon != Scalar(0)
                                 ? options.epsilon
                                 : detail::pilot_epsilon(stepper, state, t_end, options, loop.omega_floor(), loop.sum);
      loop.run_reversible(epsilon);
    }
    loop.sum.time = state.time;
    return loop.sum;
  }
}

/// The result of solve(): SciPy's fields (t, y as states, sol, t_events, y_events, status)
/// and the summary.
template <class Scalar>
struct AdaptiveRun {
  std::vector<State<Scalar>> states;               ///< at t_eval, or at every accepted step
  DenseSolution<Scalar> solution;                  ///< sol(t): anywhere in the span
  std::vector<std::vector<State<Scalar>>> events;  ///< per event, the states where it occurred
  /// Steps, rejections, Newton iterations and the status of the run.
  AdaptiveSummary<Scalar> summary;
  /// SciPy's success: the run did not fail.
  bool success() const { return summary.ok(); }
};

/// SciPy-like solve: integrates `initial` to t_end (file comment) and returns the states at
/// t_eval (sorted in the direction of the run, inside the span; empty: every accepted step),
/// the dense solution (if `dense`), and the event states. Throws invalid_input on bad
/// options, t_eval or events.
template <class Stepper>
AdaptiveRun<typename Stepper::Scalar> solve(const Stepper& stepper, const State<typename Stepper::Scalar>& initial,
                                            typename Stepper::Scalar t_end,
                                            const AdaptiveOptions<typename Stepper::Scalar>& options,
                                            const std::vector<typename Stepper::Scalar>& t_eval = {},
                                            const std::vector<Event<typename Stepper::Scalar>>& event_list = {},
                                            bool dense = true) {
  using Scalar = typename Stepper::Scalar;
  options.validate();
  const Scalar t0 = initial.time;
  const bool forward = t_end >= t0;
  for (std::size_t i = 0; i < t_eval.size(); ++i) {
    const Scalar t = t_eval[i];
    if (!std::isfinite(static_cast<double>(t)) || (forward ? (t < t0 || t > t_end) : (t > t0 || t < t_end)))
      detail::fail("solve: t_eval[", i, "] = ", t, " is outside the span [", t0, ", ", t_end, "]");
    if (i > 0 && (forward ? !(t > t_eval[i - 1]) : !(t < t_eval[i - 1])))
      detail::fail("solve: t_eval must be strictly ", forward ? "increasing" : "decreasing", " (entry ", i, ")");
  }
  AdaptiveRun<Scalar> run;
  run.solution.set_quintic(options.quintic);
  run.events.resize(event_list.size());
  std::size_t next = 0;
  const bool every_step = t_eval.empty();
  if (!every_step && t_eval[0] == t0) {
    run.states.push_back(initial);
    next = 1;
  }
  if (every_step) run.states.push_back(initial);
  bool first = true;
  auto observer = [&](const DenseNode<Scalar>& a, const DenseNode<Scalar>& b) {
    if (dense) {
      if (first) run.solution.push(a);
      run.solution.push(b);
    }
    first = false;
    if (every_step) {
      run.states.push_back(b.state);
      return;
    }
    const Scalar tb = b.state.time;
    if (next < t_eval.size() && (forward ? t_eval[next] <= tb : t_eval[next] >= tb)) {
      const LieHermite<Scalar> seg(a, b, options.quintic);
      while (next < t_eval.size() && (forward ? t_eval[next] <= tb : t_eval[next] >= tb)) {
        run.states.push_back(t_eval[next] == tb ? b.state : seg.state(t_eval[next]));
        ++next;
      }
    }
  };
  auto sink = [&](int index, const State<Scalar>& s, bool) { run.events[static_cast<std::size_t>(index)].push_back(s); };
  State<Scalar> s = initial;
  run.summary = integrate_adaptive(stepper, s, t_end, options, observer, &event_list, sink);
  if (dense && first) run.solution.push(dense_node(stepper.scene(), initial));
  return run;
}

}  // namespace trompo
