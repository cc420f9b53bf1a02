#pragma once
// Stepper<Scheme, Scene>: one time step of a scheme on a scene.
//
//   Stepper<SimoKappa, HeavyTop<double>> stepper(SimoKappa{}, scene);
//   StepReport<double> rep = stepper.step(state, h);   // h < 0 integrates backward
//
// Any type that models SchemeFor<Scheme, Scene> (scheme.hpp) can be stepped; the
// stepper knows no scheme by name. A scheme with memory is stepped on a Trajectory,
// which carries the state and the memory together:
//
//   auto traj = stepper.start(state);       // fresh memory
//   stepper.step(traj, h);
//
// A step that fails (Newton did not converge, left the domain, took a wrong branch,
// produced a NaN, or h is 0/non-finite) returns its status and leaves the state, and the
// memory, exactly as they were. No heap allocation, no virtual call.
#include <cmath>
#include <limits>
#include <type_traits>

#include "trompo/solvers/newton.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// One time step of a scheme on a scene; a failed step leaves state and memory unchanged.
template <class Scheme, class Scene_>
  requires SchemeFor<Scheme, Scene_>
class Stepper {
 public:
  /// The scene type.
  using Scene = Scene_;
  /// The scalar type of the scene.
  using Scalar = typename Scene::Scalar;
  /// The scheme's per-trajectory memory (NoMemory unless the scheme declares one).
  using Memory = scheme_memory_t<Scheme, Scene>;
  /// What this stepper steps: the State itself for a memoryless scheme.
  using TrajectoryType = Trajectory<Scalar, Memory>;

  /// The scheme, the scene and the Newton options of every step. Throws invalid_input if a
  /// parameter of the scheme is out of range (validate_scheme: a field set after the
  /// scheme's construction, e.g. LieGenAlpha::rho_inf = 2, is caught here).
  explicit Stepper(Scheme scheme, Scene scene, NewtonOptions<Scalar> options = {})
      : scheme_(scheme), scene_(std::move(scene)), options_(options) {
    validate_scheme(scheme_);
  }

  /// A trajectory starting at `s`, with fresh memory.
  TrajectoryType start(const State<Scalar>& s) const { return TrajectoryType(s); }

  /// Advances a trajectory by h. On failure state and memory are untouched and the
  /// report says why.
  StepReport<Scalar> step(TrajectoryType& traj, Scalar h) const {
    // step(state, memory, h) commits both on success only: no copy needed here.
    return step(traj.state(), traj.memory, h);
  }

  /// Advances `state` by h (memoryless schemes, or memory that is only a hint, e.g. a
  /// history predictor: each such step starts from fresh memory). On failure `state` is
  /// untouched.
  StepReport<Scalar> step(State<Scalar>& state, Scalar h) const {
    static_assert(memory_is_hint_v<Scheme, Scene>,
                  "Stepper::step(State&, h): this scheme carries memory between steps; step a "
                  "Trajectory instead (auto traj = stepper.start(state); stepper.step(traj, h))");
    if constexpr (!has_memory_v<Scheme, Scene>) {
      Memory memory{};
      return step(state, memory, h);
    } else {
      // Fresh memory, discarded afterwards: no need to keep a copy for a failed step.
      StepReport<Scalar> rep = detail::check_step_size(h);
      if (!rep.ok()) return rep;
      State<Scalar> next;
      Memory scratch{};
      rep = scheme_.step(scene_, static_cast<const State<Scalar>&>(state), h, options_, next, scratch);
      if constexpr (!writes_memory_on_success_v<Scheme, Scene>)  // else the scheme checked `next`
        if (rep.ok() && !detail::committable(next)) rep.status = StepStatus::non_finite;
      if (rep.ok()) state = next;
      return rep;
    }
  }

  /// The step on an explicit (state, memory) pair: both are committed on success only.
  /// ComposedStepper and integrate() use it; most callers want step(traj, h).
  StepReport<Scalar> step(State<Scalar>& state, Memory& memory, Scalar h) const {
    StepReport<Scalar> rep = detail::check_step_size(h);
    if (!rep.ok()) return rep;
    State<Scalar> next;
    if constexpr (writes_memory_on_success_v<Scheme, Scene>) {
      // The scheme changes `memory` only when it succeeds, after checking `next` with
      // detail::committable (scheme.hpp): stepped in place, no copy in and out (measured:
      // the two copies of the history predictor's memory were ~4 % of a Simo-κ step), and
      // the committability check is the scheme's, once.
      rep = scheme_.step(scene_, static_cast<const State<Scalar>&>(state), h, options_, next, memory);
      if (rep.ok()) state = next;
      return rep;
    } else {
      Memory next_memory = memory;
      rep = scheme_.step(scene_, static_cast<const State<Scalar>&>(state), h, options_, next, next_memory);
      // Last line of defence for "no NaN behind ok": whatever a scheme returned, an ok step
      // must give a finite state with a unit quaternion (the fuzzer found RK4 overflowing
      // |q|² to a zero quaternion), else it is reported as non_finite and not committed.
      if (rep.ok() && !detail::committable(next)) rep.status = StepStatus::non_finite;
      if (rep.ok()) {
        state = next;
        memory = next_memory;
      }
      return rep;
    }
  }

  /// Whether one step of +h then −h returns to the start (scheme.hpp: trompo::symmetric).
  bool symmetric() const { return trompo::symmetric(scheme_); }
  /// The scheme's order of accuracy with its parameters, on this scene where the scheme
  /// says it differs (`order_on(scene)`: the near-integrable splittings with wheels, [W18]).
  int order() const {
    if constexpr (requires { scheme_.order_on(scene_); }) return scheme_.order_on(scene_);
    else return order_of_accuracy(scheme_);
  }
  /// What the scheme keeps exactly on this scene.
  Keeps keeps() const { return trompo::keeps<Scene>(scheme_); }

  /// The scheme.
  const Scheme& scheme() const { return scheme_; }
  /// The scene.
  const Scene& scene() const { return scene_; }
  /// The scene, to change between steps: the sampled driver moves the wheels' hold and sets
  /// held commands in its effects (drivers/sampled.hpp). Never while a step runs.
  Scene& scene() { return scene_; }
  /// The Newton options.
  const NewtonOptions<Scalar>& options() const { return options_; }
  /// The Newton options, to modify.
  NewtonOptions<Scalar>& options() { return options_; }

 private:
  Scheme scheme_;
  Scene scene_;
  NewtonOptions<Scalar> options_;
};

}  // namespace trompo
