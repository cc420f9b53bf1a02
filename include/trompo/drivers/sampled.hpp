#pragma once
// integrate_sampled: flight software in the loop. A controller is called at the samples
// t_k = t_0 + kT with the state at t_k; its commands (wheel motor torques, a body torque, a
// magnetic dipole) are saturated and held constant on [t_k, t_{k+1}) (zero-order hold), and
// any integrator of the library steps between the samples, every step landing on them
// (docs/theory.md [W5]; docs/control.md).
//
//   ReactionWheels<double> rw = ...;                          // the spacecraft's wheels
//   Scene<double, ReactionWheels<double>> sc(rw.hub_body(J), rw);
//   Stepper<SimoKappa, decltype(sc)> stepper(SimoKappa{}, sc);
//   stepper.scene().effect<ReactionWheels<double>>().start(s.time, s.omega);
//   MrpPd<double> pd{.K = 3.5, .P = 30};
//   SampledSummary<double> sum = integrate_sampled(stepper, s, 600.0, 0.1, pd, FixedSteps<double>{0.1});
//
// The loop. At t_k: the sample (state, wheel speeds, field in body axes) goes to a copy of
// the controller; a command that is not finite, or one the scene cannot apply (wheel torques
// without wheels, or of the wrong count; a body torque without HeldBodyTorque; a dipole
// without Magnetorquer), stops the run there with the state, the wheels and the controller
// as they were before the call (the summary names the command and t_k). Otherwise the copy
// becomes the controller, the command is saturated ([W5]: wheels clipped to ±u_max and cut at
// their speed limit; dipoles clipped per axis) and written into the scene's effects (the
// wheels' hold moves to t_k, exactly), and `between` integrates to min(t_{k+1}, t_end).
// A failed step stops the run at the last accepted state (integrate's recovery first): the
// wheels' hold still describes h_i at that state's time, and the controller's memory is that
// of the last sample, so the run can go on from there.
//
// Wheels with viscous friction [W17]: FixedSteps splits the friction's exact flow around each
// step (around each sub-step of a ComposedStepper, which so keeps its order), with integrate's
// grid and recovery by halves; a failed interval keeps the state and the wheels' hold line.
// AdaptiveSteps adapts the split step itself: integrate_adaptive runs on FrictionSplitStepper,
// whose trajectory carries the wheels' hold line (a refused attempt puts the wheels back with
// the state), under tolerance control with Richardson's estimate (the defect estimate [D4]
// and reversible control, built for a scheme's own step, are refused); its dense nodes see
// the friction, and the wheels between them lie on their Hermite interpolant (W17.a-b). A
// `between` of one's own is refused with friction unless it declares applies_friction (the
// CLI's adaptive holds, which step FrictionSplitStepper themselves).
//
// The observer, if given, is called as observer(const State&) at t_0 and at each grid point
// after it, once; at a sample it is called after the new command is held, so that
// stepper.scene() shows the command that starts there.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <sstream>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>

#include "trompo/control/command.hpp"
#include "trompo/drivers/adaptive.hpp"
#include "trompo/drivers/integrate.hpp"
#include "trompo/errors.hpp"
#include "trompo/model/effects/external_torque.hpp"
#include "trompo/model/effects/magnetorquer.hpp"
#include "trompo/model/effects/reaction_wheels.hpp"
#include "trompo/model/scene.hpp"

namespace trompo {

/// A body torque held over each sample interval (the value is set by the sampled driver).
template <class Scalar>
using HeldBodyTorque = ConstantBodyTorque<Scalar>;

/// A held body torque starting at zero.
template <class Scalar>
HeldBodyTorque<Scalar> held_body_torque() {
  return HeldBodyTorque<Scalar>(Eigen::Matrix<Scalar, 3, 1>::Zero());
}

/// What integrate_sampled did.
template <class Scalar>
struct SampledSummary {
  std::int64_t samples = 0;     ///< controller calls whose command was held
  std::int64_t steps = 0;       ///< accepted steps (whole grid intervals or adaptive steps)
  std::int64_t failures = 0;    ///< failed step attempts (recovered or not)
  std::int64_t rejected = 0;    ///< adaptive attempts refused by the error test
  std::int64_t iterations = 0;  ///< Newton iterations of all steps and attempts
  StepStatus status = StepStatus::ok;  ///< a step failure that stopped the run, or ok
  std::string command_error;    ///< why a command was refused (empty: none)
  bool too_many_steps = false;  ///< a hold asked more steps than AdaptiveOptions::max_steps or FixedSteps::max_steps
  bool step_too_small = false;  ///< an adaptive hold's step fell below the time resolution before its sample
  Scalar time = Scalar(0);      ///< where the run ended
  /// Whether the run reached t_end.
  bool ok() const { return status == StepStatus::ok && command_error.empty() && !too_many_steps && !step_too_small; }
  /// Why it stopped, or "ok".
  std::string reason() const {
    if (!command_error.empty()) return command_error;
    if (status == StepStatus::ok && too_many_steps) return "Too many steps.";
    if (status == StepStatus::ok && step_too_small) return AdaptiveSummary<Scalar>::step_too_small_message;
    return status == StepStatus::ok ? std::string("ok") : std::string(to_string(status));
  }
  /// Adds an adaptive hold's counts and outcome (AdaptiveSteps; a driver of one's own that
  /// runs integrate_adaptive over each hold, as the CLI's with events). A run stopped by
  /// max_steps, or by a step below the time resolution, fails with no step failure
  /// (StepStatus::ok): the summary says which, rather than ok() at a time short of t_end
  /// (found by the fuzzer).
  void add_adaptive_hold(const AdaptiveSummary<Scalar>& s) {
    steps += s.accepted;
    rejected += s.rejected;
    failures += s.failures;
    iterations += s.iterations;
    status = s.failure;
    const bool failed_without_status = !s.ok() && s.failure == StepStatus::ok;
    too_many_steps = failed_without_status && !s.step_too_small;
    step_too_small = failed_without_status && s.step_too_small;
  }
};

/// Between samples: fixed steps of h by integrate() (recovery by sub-steps), landing on the
/// samples. With max_angle > 0 the steps follow the body's rate [W16]: each hold is divided into
/// the fewest equal steps, none longer than |h|, that turn the body by at most max_angle at the
/// rate of the hold's start, n = max(⌈|Δt|/|h|⌉, ⌈|Ω_k||Δt|/max_angle⌉): a tumbling body gets
/// several steps a sample, a slow one a single step of the whole hold.
template <class Scalar>
struct FixedSteps {
  Scalar h;                      ///< the step (its sign must match the direction of the run)
  IntegrateOptions options{};    ///< integrate's recovery
  Scalar max_angle = Scalar(0);  ///< the most a step may turn the body (rad) at the sample's rate; 0: off
  /// The most steps a hold may take (0: no limit). A hold that asks more (with max_angle, a body
  /// that has spun up) stops the run at its sample with SampledSummary::too_many_steps, rather
  /// than run on for as long as the rate asks: the state and the wheels are those of the sample,
  /// whose command was held (and observed) and whose controller memory was kept, so the run can
  /// go on from there with a larger limit.
  std::int64_t max_steps = 0;

  /// Throws invalid_input for a max_angle that is negative or not finite, or a negative
  /// max_steps (integrate_sampled calls it before anything runs; h is checked by the stepper).
  void validate() const {
    if (!std::isfinite(static_cast<double>(max_angle)) || !(max_angle >= Scalar(0)))
      detail::fail("sampled: max_angle must be finite and >= 0 (rad), got ", max_angle);
    if (max_steps < 0) detail::fail("sampled: max_steps must be >= 0 (0: no limit), got ", max_steps);
  }
  /// Whether a hold of n steps is more than max_steps allows.
  bool too_many(std::int64_t n) const { return max_steps > 0 && n > max_steps; }
  /// The step for a hold of signed length `span` at the rate |Ω| = `rate`: h, or with
  /// max_angle > 0, span/n as above.
  Scalar step_for(Scalar rate, Scalar span) const {
    using std::abs, std::ceil, std::max;
    // Off, or an h that integrate() refuses anyway (zero, or against the run's direction).
    if (!(max_angle > Scalar(0)) || !(abs(h) > Scalar(0)) || span == Scalar(0) || (h > Scalar(0)) != (span > Scalar(0)))
      return h;
    const Scalar by_h = ceil(abs(span) / abs(h)), by_angle = ceil(rate * abs(span) / max_angle);
    const Scalar n = max(Scalar(1), max(by_h, by_angle));
    if (!std::isfinite(static_cast<double>(n))) return h;
    return span / n;
  }
  /// Integrates `traj` to t_next; adds to the summary; false on an unrecovered failure.
  template <class StepperT, class Traj, class Obs>
  bool operator()(const StepperT& stepper, Traj& traj, Scalar t_next, Obs&& obs, SampledSummary<Scalar>& sum) const {
    const Scalar step = step_for(traj.omega.norm(), t_next - traj.time);
    if (max_steps > 0 && traj.time != t_next && too_many(detail::hold_grid(traj.time, t_next, step, options))) {
      sum.too_many_steps = true;
      return false;
    }
    const IntegrationSummary<Scalar> s = integrate(stepper, traj, t_next, step, std::forward<Obs>(obs), options);
    sum.steps += s.steps + s.substeps;
    sum.failures += s.failures;
    sum.iterations += s.iterations;
    sum.status = s.status;
    return s.ok();
  }
};

/// Between samples: adaptive steps by integrate_adaptive() to t_next, each hold a new run
/// (its first step from options.first_step, or the driver's rule).
template <class Scalar>
struct AdaptiveSteps {
  AdaptiveOptions<Scalar> options;  ///< tolerances and controls
  /// Integrates `traj` to t_next; adds to the summary; false on a failure.
  template <class StepperT, class Traj, class Obs>
  bool operator()(const StepperT& stepper, Traj& traj, Scalar t_next, Obs&& obs, SampledSummary<Scalar>& sum) const {
    AdaptiveSummary<Scalar> s;
    if constexpr (std::is_same_v<std::decay_t<Obs>, NoObserver>) {
      s = integrate_adaptive(stepper, traj, t_next, options);
    } else {
      auto node_observer = [&](const DenseNode<Scalar>&, const DenseNode<Scalar>& b) { obs(b.state); };
      s = integrate_adaptive(stepper, traj, t_next, options, node_observer);
    }
    sum.add_adaptive_hold(s);
    return s.ok();
  }
};

namespace detail {
template <class E, class Scene>
struct scene_has;
template <class Between>
struct is_fixed_steps : std::false_type {};
template <class Scalar>
struct is_fixed_steps<FixedSteps<Scalar>> : std::true_type {};
template <class Between>
struct is_adaptive_steps : std::false_type {};
template <class Scalar>
struct is_adaptive_steps<AdaptiveSteps<Scalar>> : std::true_type {};
/// Whether a `between` of one's own applies the wheels' friction itself (it declares
/// `static constexpr bool applies_friction = true`, e.g. by stepping FrictionSplitStepper).
template <class Between>
inline constexpr bool applies_friction_v = [] {
  if constexpr (requires { Between::applies_friction; }) return bool(Between::applies_friction);
  else return false;
}();
template <class E, class Scalar, class... Effects>
struct scene_has<E, Scene<Scalar, Effects...>> : std::bool_constant<(std::is_same_v<E, Effects> || ...)> {};
}  // namespace detail

/// Whether Scene lists the effect E.
template <class E, class Scene>
inline constexpr bool scene_has_v = detail::scene_has<E, Scene>::value;

/// The sample at the state s: wheel speeds and the field in body axes where the scene has them.
/// With magnetorquers `field` receives the field's expansion about s.time for a hold of length
/// `span` [W16], of which the sample reads B(t_k) and the hold keeps the rest (hold_command).
template <class Scene>
Sample<typename Scene::Scalar> make_sample(const Scene& scene, const State<typename Scene::Scalar>& s, long long k,
                                           typename DipoleField<typename Scene::Scalar>::Expansion& field,
                                           typename Scene::Scalar span) {
  using Scalar = typename Scene::Scalar;
  Sample<Scalar> smp;
  smp.index = k;
  smp.time = s.time;
  smp.state = s;
  if constexpr (scene_has_v<ReactionWheels<Scalar>, Scene>) {
    const auto& rw = scene.template effect<ReactionWheels<Scalar>>();
    smp.wheel_speeds = rw.speeds(s.time, s.omega);
    smp.wheel_axes = rw.axes();
  }
  if constexpr (scene_has_v<Magnetorquer<Scalar>, Scene>) {
    field = scene.template effect<Magnetorquer<Scalar>>().field().expansion(s.time, span);
    smp.field = s.rotation.inverse() * field.B[0];
    smp.has_field = true;
  }
  return smp;
}

/// Checks a command against the scene; empty if it can be held, else why not (naming the
/// command and t). Allocates only to say what is wrong.
template <class Scene>
std::string command_problem(const Scene& scene, const Command<typename Scene::Scalar>& c, typename Scene::Scalar t) {
  using Scalar = typename Scene::Scalar;
  const auto at = [t](const std::string& what) {
    std::ostringstream text;
    text << what << " at t = " << std::setprecision(15) << static_cast<double>(t);
    return text.str();
  };
  if (const char* bad = c.non_finite()) return at(std::string("controller: non-finite command ") + bad);
  if (c.wheel_torques.size() > 0) {
    if constexpr (scene_has_v<ReactionWheels<Scalar>, Scene>) {
      const int n = scene.template effect<ReactionWheels<Scalar>>().size();
      if (c.wheel_torques.size() != n)
        return at("controller: wheel_torques has " + std::to_string(c.wheel_torques.size()) + " entries for " +
                  std::to_string(n) + " wheels");
    } else {
      return at("controller: wheel_torques commanded, but the scene has no wheels");
    }
  }
  if constexpr (!scene_has_v<HeldBodyTorque<Scalar>, Scene>)
    if (c.body_torque != Eigen::Matrix<Scalar, 3, 1>::Zero())
      return at("controller: body_torque commanded, but the scene has no held body torque");
  if constexpr (!scene_has_v<Magnetorquer<Scalar>, Scene>)
    if (c.dipole != Eigen::Matrix<Scalar, 3, 1>::Zero())
      return at("controller: dipole commanded, but the scene has no magnetorquers");
  return {};
}

/// Saturates a command [W5] and holds it in the scene's effects from t on (the field's
/// expansion about t from make_sample).
template <class Scene>
void hold_command(Scene& scene, const Command<typename Scene::Scalar>& c, const Sample<typename Scene::Scalar>& smp,
                  const typename DipoleField<typename Scene::Scalar>::Expansion& field) {
  using Scalar = typename Scene::Scalar;
  if constexpr (scene_has_v<ReactionWheels<Scalar>, Scene>) {
    auto& rw = scene.template effect<ReactionWheels<Scalar>>();
    typename ReactionWheels<Scalar>::WheelVector u =
        c.wheel_torques.size() > 0 ? c.wheel_torques : ReactionWheels<Scalar>::WheelVector::Zero(rw.size()).eval();
    rw.hold(smp.time, rw.saturate(u, smp.wheel_speeds));
  }
  if constexpr (scene_has_v<HeldBodyTorque<Scalar>, Scene>)
    scene.template effect<HeldBodyTorque<Scalar>>().function().value = c.body_torque;
  if constexpr (scene_has_v<Magnetorquer<Scalar>, Scene>) {
    auto& mtq = scene.template effect<Magnetorquer<Scalar>>();
    mtq.hold(mtq.saturate(c.dipole), field);
  }
}

namespace detail {
/// [W17] One attempt of the split over [t_a, t_b], Δ = t_b − t_a, from traj at t_a: F(Δ/2) ∘ Φ_Δ ∘
/// F(Δ/2), F the exact friction flow and Φ the stepper's step, of order 2; a ComposedStepper
/// splits F around each of its sub-steps instead (ComposedStepper::step with a flow), so that
/// it keeps its order. A flow whose result is not finite fails as non-finite. On failure traj
/// and the wheels may be partly advanced: the caller restores them.
template <class StepperT, class Traj>
StepReport<typename StepperT::Scalar> friction_split_attempt(const StepperT& stepper,
                                                             ReactionWheels<typename StepperT::Scalar>& rw, Traj& traj,
                                                             typename StepperT::Scalar t_b) {
  using Scalar = typename StepperT::Scalar;
  const Scalar dt = t_b - traj.time;
  const auto flow = [&rw](State<Scalar>& s, Scalar tau) { rw.friction_flow(s.time, tau, s.omega); };
  const auto finite = [&] { return detail::all_finite(traj.omega) && detail::all_finite(rw.momenta(traj.time)); };
  StepReport<Scalar> rep;
  if constexpr (requires { stepper.step(traj, dt, flow); }) {
    rep = stepper.step(traj, dt, flow);
    if (!rep.ok()) return rep;
  } else {
    flow(traj, dt / Scalar(2));
    if (!finite()) {
      rep.status = StepStatus::non_finite;
      return rep;
    }
    rep = stepper.step(traj, dt);
    if (!rep.ok()) return rep;
    traj.time = t_b;
    flow(traj, dt / Scalar(2));
  }
  traj.time = t_b;
  if (!finite()) rep.status = StepStatus::non_finite;
  return rep;
}

/// [W17] The split over [t_a, t_b], with integrate's recovery: an interval that fails is tried
/// again as two halves, each recursively, down to `depth_left` halvings; a piece that still
/// fails stops it with the state and the wheels as they were at that piece's start. (A
/// composed step commits its memory on success only, so its state alone is saved; another
/// stepper's last flow comes after its step's commit, so the trajectory is.)
template <class StepperT, class Traj>
bool friction_split_interval(const StepperT& stepper, ReactionWheels<typename StepperT::Scalar>& rw, Traj& traj,
                             typename StepperT::Scalar t_b, int depth_left, SampledSummary<typename StepperT::Scalar>& sum) {
  using Scalar = typename StepperT::Scalar;
  const auto flow = [](State<Scalar>&, Scalar) {};
  using Saved = std::conditional_t<requires { stepper.step(traj, t_b, flow); }, State<Scalar>, Traj>;
  const Saved saved = traj;
  const typename ReactionWheels<Scalar>::HoldLine line = rw.hold_line();
  const StepReport<Scalar> rep = friction_split_attempt(stepper, rw, traj, t_b);
  sum.iterations += rep.iterations;
  if (rep.ok()) {
    ++sum.steps;
    return true;
  }
  ++sum.failures;
  static_cast<Saved&>(traj) = saved;
  rw.set_hold_line(line);
  const Scalar t_mid = traj.time + (t_b - traj.time) / Scalar(2);
  if (depth_left <= 0 || !detail::resolves(t_mid - traj.time, traj.time, t_b)) {
    sum.status = rep.status;
    return false;
  }
  return friction_split_interval(stepper, rw, traj, t_mid, depth_left - 1, sum) &&
         friction_split_interval(stepper, rw, traj, t_b, depth_left - 1, sum);
}

/// [W17] A hold of fixed steps with the wheels' viscous friction split around each step (see
/// friction_split_attempt), on integrate's grid, each interval with integrate's recovery; the
/// observer at each grid point.
template <class StepperT, class Traj, class Obs>
bool friction_split_steps(StepperT& stepper, Traj& traj, typename StepperT::Scalar t_next,
                          const FixedSteps<typename StepperT::Scalar>& between, Obs&& obs,
                          SampledSummary<typename StepperT::Scalar>& sum) {
  using Scalar = typename StepperT::Scalar;
  auto& rw = stepper.scene().template effect<ReactionWheels<Scalar>>();
  const Scalar t0 = traj.time;
  const Scalar step = between.step_for(traj.omega.norm(), t_next - t0);
  const std::int64_t n = hold_grid(t0, t_next, step, between.options);
  if (between.too_many(n)) {
    sum.too_many_steps = true;
    return false;
  }
  for (std::int64_t k = 1; k <= n; ++k) {
    const Scalar t_b = k == n ? t_next : t0 + static_cast<Scalar>(k) * step;
    if (!friction_split_interval(std::as_const(stepper), rw, traj, t_b, between.options.max_halvings, sum)) return false;
    if constexpr (!std::is_same_v<std::decay_t<Obs>, NoObserver>) obs(static_cast<const State<Scalar>&>(traj));
  }
  return true;
}

/// [W17] The split step S_Δ of friction_split_attempt as a stepper, for the adaptive driver
/// (AdaptiveSteps with friction). Its trajectory is the stepper's with the wheels' hold line
/// (their momenta) beside it: each step starts the wheels from the line it carries and stores
/// the line it leaves, so that an attempt the driver refuses, or one that fails, puts the
/// wheels back with the state. Its order is the composition's (a ComposedStepper splits F
/// around each sub-step) or 2 (Strang's split around any other step); it keeps what the
/// stepper keeps, less the energy, which friction dissipates. `splits_friction` tells
/// integrate_adaptive that the friction is not left out. It must not expose scheme() or
/// stages(): the adaptive driver would then copy a trajectory's state without its line (its
/// in-place attempts and partial copies of a composition's memory).
template <class StepperT, class Traj>
class FrictionSplitStepper {
 public:
  /// The stepper's scene.
  using Scene = typename StepperT::Scene;
  /// The scalar.
  using Scalar = typename StepperT::Scalar;
  /// The stepper's trajectory (or State) and the wheels' hold line.
  struct Trajectory : Traj {
    typename ReactionWheels<Scalar>::HoldLine line{};  ///< the wheels' momenta h_i at a time, and that time
  };
  /// What this stepper steps.
  using TrajectoryType = Trajectory;
  /// The friction is split here, not left out (refuse_wheel_friction).
  static constexpr bool splits_friction = true;

  /// Steps `stepper` (not owned) with the friction of `wheels` (its scene's, not owned).
  FrictionSplitStepper(const StepperT& stepper, ReactionWheels<Scalar>& wheels) : stepper_(&stepper), wheels_(&wheels) {}
  /// The stepper's scene.
  const Scene& scene() const { return stepper_->scene(); }
  /// The split step's order: the composition's, else min(2, the scheme's).
  int order() const {
    const auto flow = [](State<Scalar>&, Scalar) {};
    if constexpr (requires(Traj& t) { stepper_->step(t, Scalar(1), flow); }) return stepper_->order();
    else return std::min(stepper_->order(), 2);
  }
  /// What the stepper keeps, less the energy.
  Keeps keeps() const {
    Keeps k = stepper_->keeps();
    k.energy = false;
    k.energy_decays = false;
    return k;
  }
  /// A trajectory at `t` with the wheels' present line (kept as the hold's start, for
  /// wheels_at).
  Trajectory start(const Traj& t) const {
    Trajectory r;
    static_cast<Traj&>(r) = t;
    r.line = wheels_->hold_line();
    start_ = {t.time, r.line, t.omega};
    return r;
  }
  /// S_h from `t` (its wheels first); on failure `t` and its line are untouched.
  StepReport<Scalar> step(Trajectory& t, Scalar h) const {
    wheels_->set_hold_line(t.line);
    const Traj saved = t;
    const End start{t.time, t.line, t.omega};
    const StepReport<Scalar> rep = friction_split_attempt(*stepper_, *wheels_, static_cast<Traj&>(t), t.time + h);
    if (!rep.ok()) {
      static_cast<Traj&>(t) = saved;
      wheels_->set_hold_line(t.line);
      return rep;
    }
    t.line = wheels_->hold_line();
    last_ = (last_ + 1) % recent_size;
    recent_[static_cast<std::size_t>(last_)] = {start, {t.time, t.line, t.omega}};
    return rep;
  }
  /// Puts the wheels where the motion has them at time `t`, from the last few steps, the
  /// latest first: at the line a step left at its end or found at its start, when t is there
  /// within a few ulps, or at the cubic Hermite interpolant of the momenta between its two
  /// ends when t is inside it, with the rates ḣ_i = u_i − c_i Ω_i there [W17]; else at the
  /// hold's start if t is there; a time outside them all leaves the wheels as they are. The
  /// latest first, since an attempt the driver refused is older than the one it accepted,
  /// whose steps cover the attempt's span: a refused step's line is not taken where an
  /// accepted step covers t. The adaptive driver forms its nodes (node_at) and reports the
  /// inner steps of Richardson's attempt after all of its steps, when the wheels are at the
  /// last one's line, and what reads them at a node, a row between nodes or an event (the
  /// total momentum, the wheels' speeds, Ω̇ with the friction) must see that time's. "At t"
  /// within a few ulps of the step: the driver stores its own grid time t_b after a step of
  /// t_b − t from t, and t + (t_b − t) is t_b only where the subtraction is exact (not across
  /// t = 0).
  void wheels_at(Scalar t) const {
    for (int k = 0; k < recent_size; ++k) {
      const Recent& r = recent_[static_cast<std::size_t>((last_ - k + recent_size) % recent_size)];
      const Scalar span = r.end.time - r.start.time;
      if (near(r.end.time, t, span)) {
        wheels_->set_hold_line(r.end.line);
        return;
      }
      if (near(r.start.time, t, span)) {
        wheels_->set_hold_line(r.start.line);
        return;
      }
      if ((t - r.start.time) * (r.end.time - t) > Scalar(0)) {  // inside the step
        wheels_->set_hold_line(between(r.start, r.end, t));
        return;
      }
    }
    if (near(start_.time, t, Scalar(0))) wheels_->set_hold_line(start_.line);
  }

 private:
  const StepperT* stepper_;
  ReactionWheels<Scalar>* wheels_;
  /// One end of a step: its time, the wheels' line and Ω there.
  struct End {
    Scalar time = std::numeric_limits<Scalar>::quiet_NaN();
    typename ReactionWheels<Scalar>::HoldLine line{};
    Eigen::Matrix<Scalar, 3, 1> omega = Eigen::Matrix<Scalar, 3, 1>::Zero();
  };
  /// A step taken: where it started and where it ended.
  struct Recent {
    End start, end;
  };
  /// Whether a and b are the same time within a few ulps of them and of a step's `span`.
  static bool near(Scalar a, Scalar b, Scalar span) {
    using std::abs;
    return abs(a - b) <= Scalar(4) * std::numeric_limits<Scalar>::epsilon() * (abs(b) + abs(span));
  }
  /// The line at t inside one step: h_i(t) by the cubic Hermite of (h_i, ḣ_i) at its two ends
  /// a and b, ḣ_i = u_i − c_i Ω_i with each end's own line and Ω.
  typename ReactionWheels<Scalar>::HoldLine between(const End& a, const End& b, Scalar t) const {
    wheels_->set_hold_line(a.line);
    const auto rate_a = wheels_->momentum_rates(a.time, a.omega);
    wheels_->set_hold_line(b.line);
    const auto rate_b = wheels_->momentum_rates(b.time, b.omega);
    const Scalar dt = b.time - a.time, x = (t - a.time) / dt, x2 = x * x, x3 = x2 * x;
    const Scalar h00 = Scalar(2) * x3 - Scalar(3) * x2 + Scalar(1), h10 = x3 - Scalar(2) * x2 + x;
    const Scalar h01 = Scalar(3) * x2 - Scalar(2) * x3, h11 = x3 - x2;
    const auto& ha = a.line.momenta;
    const auto& hb = b.line.momenta;
    return {(h00 * ha + (h10 * dt) * rate_a + h01 * hb + (h11 * dt) * rate_b).eval(), t};
  }
  /// The last steps taken: an attempt's coarse step and its m inner steps at most (the
  /// accepted attempt's are the latest when the driver reads the wheels), and one more.
  static constexpr int recent_size = AdaptiveOptions<Scalar>::max_substeps + 2;
  mutable std::array<Recent, recent_size> recent_{};
  mutable int last_ = 0;
  mutable End start_{};  ///< the hold's start (start())
};

/// [W17] The adaptive options of the split step: the estimate Richardson's (automatic becomes
/// doubling, or Richardson's with the `substeps` given; integrate_sampled refuses the defect
/// estimate and the reversible control with friction, built for a scheme's own step).
template <class Scalar>
AdaptiveOptions<Scalar> friction_split_options(AdaptiveOptions<Scalar> options) {
  if (options.estimate == ErrorEstimate::automatic)
    options.estimate = options.substeps != 0 ? ErrorEstimate::richardson : ErrorEstimate::doubling;
  return options;
}

/// [W17] One hold of adaptive steps with the wheels' viscous friction: integrate_adaptive on
/// the split step (FrictionSplitStepper of `stepper` and its scene's `wheels`) from `traj` to
/// t_next, with friction_split_options, and `events` (nullptr: none) to `sink`. At each
/// accepted step `observe(a, b)` with the wheels at b's own line, or `observe(a, b, wheels_at)`
/// for an observer that reads the wheels between the nodes (rows from the interpolant):
/// wheels_at(t) puts them at time t of that step ([W17], FrictionSplitStepper::wheels_at);
/// the sink's state comes with the wheels at its time. NoObserver: none. `traj` and the
/// wheels end at the last accepted step (a refused attempt may have moved the wheels). The
/// library's AdaptiveSteps and the CLI's adaptive holds both step here.
template <class StepperT, class Traj, class NodeObserver = NoObserver, class Sink = NoEventSink>
AdaptiveSummary<typename StepperT::Scalar> friction_split_hold(
    const StepperT& stepper, ReactionWheels<typename StepperT::Scalar>& wheels, Traj& traj,
    typename StepperT::Scalar t_next, AdaptiveOptions<typename StepperT::Scalar> options, NodeObserver&& observe = {},
    const std::vector<Event<typename StepperT::Scalar>>* events = nullptr, Sink&& sink = {}) {
  using Scalar = typename StepperT::Scalar;
  const FrictionSplitStepper<StepperT, Traj> split(stepper, wheels);
  auto t = split.start(traj);
  options = friction_split_options(options);
  const auto wheels_at = [&split](Scalar time) { split.wheels_at(time); };
  auto node_observer = [&](const DenseNode<Scalar>& a, const DenseNode<Scalar>& b) {
    if constexpr (!std::is_same_v<std::decay_t<NodeObserver>, NoObserver>) {
      split.wheels_at(b.state.time);
      if constexpr (std::is_invocable_v<NodeObserver&, const DenseNode<Scalar>&, const DenseNode<Scalar>&,
                                        decltype(wheels_at)>)
        observe(a, b, wheels_at);
      else
        observe(a, b);
    }
  };
  auto event_sink = [&](int index, const State<Scalar>& x, bool terminal) {
    if constexpr (!std::is_same_v<std::decay_t<Sink>, NoEventSink>) {
      split.wheels_at(x.time);
      sink(index, x, terminal);
    }
  };
  AdaptiveSummary<Scalar> s;
  if constexpr (std::is_same_v<std::decay_t<NodeObserver>, NoObserver> && std::is_same_v<std::decay_t<Sink>, NoEventSink>)
    s = integrate_adaptive(split, t, t_next, options);
  else
    s = integrate_adaptive(split, t, t_next, options, node_observer, events, event_sink);
  static_cast<Traj&>(traj) = static_cast<const Traj&>(t);
  wheels.set_hold_line(t.line);
  return s;
}

/// [W17] A hold of AdaptiveSteps with the wheels' viscous friction (friction_split_hold); the
/// observer at each accepted step.
template <class StepperT, class Traj, class Obs>
bool friction_split_adaptive(StepperT& stepper, Traj& traj, typename StepperT::Scalar t_next,
                             const AdaptiveSteps<typename StepperT::Scalar>& between, Obs&& obs,
                             SampledSummary<typename StepperT::Scalar>& sum) {
  using Scalar = typename StepperT::Scalar;
  auto& rw = stepper.scene().template effect<ReactionWheels<Scalar>>();
  AdaptiveSummary<Scalar> s;
  if constexpr (std::is_same_v<std::decay_t<Obs>, NoObserver>)
    s = friction_split_hold(std::as_const(stepper), rw, traj, t_next, between.options);
  else
    s = friction_split_hold(std::as_const(stepper), rw, traj, t_next, between.options,
                            [&](const DenseNode<Scalar>&, const DenseNode<Scalar>& b) { obs(b.state); });
  sum.add_adaptive_hold(s);
  return s.ok();
}
}  // namespace detail

/// Integrates `state` (a State or the stepper's Trajectory) from state.time to t_end with the
/// controller sampled every `period` (> 0; the run may go backward, t_end < t_0, with samples
/// at t_0 − kT), `between` stepping each hold (FixedSteps or AdaptiveSteps). Throws
/// invalid_input for a bad period, t_end or state, before anything runs; see the file comment.
template <class StepperT, class StateT, class Controller, class Between, class Observer = NoObserver>
SampledSummary<typename StepperT::Scalar> integrate_sampled(StepperT& stepper, StateT& state,
                                                           typename StepperT::Scalar t_end,
                                                           typename StepperT::Scalar period, Controller& controller,
                                                           const Between& between, Observer observer = {}) {
  using Scalar = typename StepperT::Scalar;
  using std::abs;
  if constexpr (detail::needs_trajectory<StepperT, StateT>()) {
    // A plain State with a stepper whose scheme has memory: one trajectory for the whole
    // run, so that the memory (a splitting's frame, a history) carries across the samples.
    auto traj = stepper.start(state);
    const SampledSummary<Scalar> sum = integrate_sampled(stepper, traj, t_end, period, controller, between, observer);
    static_cast<State<Scalar>&>(state) = traj.state();
    return sum;
  }
  if (!std::isfinite(static_cast<double>(period)) || !(period > Scalar(0)))
    detail::fail("sampled: control period must be finite and > 0, got ", period);
  if (!std::isfinite(static_cast<double>(t_end))) detail::fail("sampled: t_end must be finite, got ", t_end);
  if constexpr (requires { between.validate(); }) between.validate();
  state.validate();
  // [W17] Wheels with viscous friction: its exact flow is split around each step.
  bool friction = false;
  if constexpr (scene_has_v<ReactionWheels<Scalar>, std::decay_t<decltype(stepper.scene())>>) {
    auto& rw = stepper.scene().template effect<ReactionWheels<Scalar>>();
    friction = rw.has_friction();
    if (friction) {
      if constexpr (!detail::is_fixed_steps<Between>::value && !detail::is_adaptive_steps<Between>::value &&
                    !detail::applies_friction_v<Between>) {
        detail::fail("sampled: the wheels have viscous friction, whose flow FixedSteps and AdaptiveSteps split "
                     "around their steps (docs/theory.md [W17]); a driver of one's own between the samples would "
                     "leave it out (unless it applies it and says so: applies_friction)");
      } else if constexpr (detail::is_adaptive_steps<Between>::value) {
        // The split step's error is estimated by Richardson's rule; the defect [D4] and the
        // reversible control [A5] are built for a scheme's own step, not for the split step.
        if (between.options.estimate == ErrorEstimate::defect)
          detail::fail("sampled: the wheels have viscous friction, whose split step (docs/theory.md [W17]) "
                       "adaptive steps estimate by Richardson's rule: estimate = defect is built for a scheme's "
                       "own step; use automatic, doubling or richardson");
        if (between.options.control != StepControl::tolerance)
          detail::fail("sampled: the wheels have viscous friction, whose split step (docs/theory.md [W17]) "
                       "adaptive steps take under tolerance control: control = reversible is built for a "
                       "scheme's own step");
      }
      // The processed composition steps a kernel that is not the output state: a flow on the
      // output would be lost at the next kernel step while the wheels kept its momentum.
      if constexpr (detail::is_processed<StepperT>())
        detail::fail("sampled: the wheels have viscous friction, whose flow the processed composition cannot "
                     "take (it steps a kernel, not the output; docs/theory.md [W17]): use a ComposedStepper");
      rw.prepare_friction(stepper.scene().body().inertia_inverse());
    }
  }
  constexpr bool observed = !std::is_same_v<Observer, NoObserver>;
  SampledSummary<Scalar> sum;
  const Scalar t0 = state.time;
  const Scalar dir = t_end >= t0 ? Scalar(1) : Scalar(-1);
  // The samples t_k = t_0 + kT (multiplied, not summed: no drift of the grid).
  const Scalar span = abs(t_end - t0);
  const long long n_samples = static_cast<long long>(std::ceil(static_cast<double>(span / period) - 1e-9));
  for (long long k = 0; k < std::max<long long>(n_samples, 1); ++k) {
    const Scalar t_k = t0 + dir * Scalar(k) * period;
    const Scalar t_next = k + 1 >= n_samples ? t_end : t0 + dir * Scalar(k + 1) * period;
    typename DipoleField<Scalar>::Expansion field;
    const Sample<Scalar> smp = make_sample(stepper.scene(), static_cast<const State<Scalar>&>(state), k, field, t_next - t_k);
    Command<Scalar> cmd;
    if constexpr (std::is_copy_assignable_v<Controller>) {
      // Called on a copy, kept only if its command is held: a refused command leaves the
      // controller's memory as it was.
      Controller trial = controller;
      cmd = trial(smp);
      sum.command_error = command_problem(stepper.scene(), cmd, t_k);
      if (!sum.command_error.empty()) break;
      controller = trial;
    } else {
      // A lambda (not assignable): called in place; what it captured is its own.
      cmd = controller(smp);
      sum.command_error = command_problem(stepper.scene(), cmd, t_k);
      if (!sum.command_error.empty()) break;
    }
    hold_command(stepper.scene(), cmd, smp, field);
    ++sum.samples;
    if constexpr (observed) observer(static_cast<const State<Scalar>&>(state));
    if (t_next == state.time) break;  // t_end = t_0
    // Grid points inside the hold and its end (the end again at the next sample, after the
    // command changes, unless it is t_end).
    const bool last = t_next == t_end;
    auto inner = [&](const State<Scalar>& s) {
      if constexpr (observed) {
        if (s.time != t_k && (last || s.time != t_next)) observer(s);
      } else {
        (void)s;
      }
    };
    bool ok;
    if constexpr ((detail::is_fixed_steps<Between>::value || detail::is_adaptive_steps<Between>::value) &&
                  !detail::is_processed<StepperT>() &&
                  scene_has_v<ReactionWheels<Scalar>, std::decay_t<decltype(stepper.scene())>>) {
      if (friction) {  // (refused above for the processed composition)
        if constexpr (detail::is_fixed_steps<Between>::value) {
          if constexpr (observed) ok = detail::friction_split_steps(stepper, state, t_next, between, inner, sum);
          else ok = detail::friction_split_steps(stepper, state, t_next, between, NoObserver{}, sum);
        } else {
          if constexpr (observed) ok = detail::friction_split_adaptive(stepper, state, t_next, between, inner, sum);
          else ok = detail::friction_split_adaptive(stepper, state, t_next, between, NoObserver{}, sum);
        }
        if (!ok) break;
        continue;
      }
    }
    if constexpr (observed) ok = between(std::as_const(stepper), state, t_next, inner, sum);
    else ok = between(std::as_const(stepper), state, t_next, NoObserver{}, sum);
    if (!ok) break;
  }
  sum.time = state.time;
  return sum;
}

}  // namespace trompo
