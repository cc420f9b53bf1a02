#pragma once
// The Scheme concept: what a type must provide to be stepped by Stepper, composed by
// ComposedStepper and driven by integrate().
//
// A scheme is a small value type (its parameters, e.g. Simo-α's α) with
//
//   static constexpr const char* name;          // "simo-kappa": CLI, reports, test names
//   static constexpr int order;                 // order of accuracy (at its default parameters)
//   static constexpr bool symmetric;            // Φ_{−h} = Φ_h⁻¹ for some parameters: composable
//   template <class Scene>
//   static constexpr Keeps keeps;               // what it keeps exactly on that kind of scene
//   template <class Scene>
//   StepReport<Scalar> step(const Scene&, const State<Scalar>& in, Scalar h,
//                           const NewtonOptions<Scalar>&, State<Scalar>& out,
//                           Memory<Scene>& memory) const;
//
// and, optionally,
//
//   template <class Scene> using Memory = …;    // per-trajectory memory (default NoMemory)
//   bool is_symmetric() const;                  // the run-time refinement of `symmetric`
//   int order_of_accuracy() const;              // the run-time refinement of `order`
//   template <class Scene> Keeps kept() const;  // the run-time refinement of `keeps`
//   void validate() const;                      // throws invalid_input for a bad parameter
//
// The run-time refinements are for families whose parameters change a property: Simo-α is
// symmetric and of order 2 only for α = ½. Read the properties through trompo::symmetric,
// trompo::order_of_accuracy and trompo::keeps, which fall back on the static traits.
// A scheme's parameters are public fields (SimoAlpha{}.alpha, LieGenAlpha{}.rho_inf), so a
// value set after construction is checked again where it is used: the Stepper's
// constructor (and so ComposedStepper's) calls trompo::validate_scheme, i.e. validate().
//
// The step contract. `step` reads `in` and the memory and writes `out` and the memory;
// its report says whether the step is good. It may leave `out` and `memory` in any state
// when it fails: the Stepper passes it copies and commits both only on success, so a
// failed step leaves the caller's state *and* memory bit-identical. `step` never throws
// for numerical trouble, and never allocates.
//
// Memory between steps. A scheme that remembers something from step to step (the
// acceleration-like variable of a generalised-α method, the last increments for a
// history predictor) declares its type as `Memory<Scene>`. A default-constructed
// Memory means "fresh": the first step of a trajectory, or the first after a reset, must
// work from it (and initialise what it needs from the state). The memory travels with
// the state in a Trajectory<Scalar, Memory> (below): Stepper::step and integrate() take
// one, and a user who edits the state by hand calls reset(). Sub-steps of a recovered
// interval in integrate() see the memory as the state: in sequence, with their own
// (halved) step size. ComposedStepper keeps one memory per sub-step index (its sub-steps
// differ in size and sign). A scheme whose memory depends on h must record the h it
// was built with and start afresh when it changes. A memoryless scheme pays nothing:
// NoMemory is empty and its copies compile away.
//
// Memory written on success only (optional). A scheme may declare
// `static constexpr bool writes_memory_on_success = true`: its `step` then promises to
// change the memory only when it returns ok, after it has checked `out` with
// detail::committable (state.hpp), and never otherwise. The Stepper then steps the
// caller's memory in place instead of a copy committed on success (two copies of the
// memory per step saved: 248 bytes for the history predictor's), and leaves that check
// to the scheme. The failure contract is the same.
#include <concepts>
#include <type_traits>

#include "trompo/solvers/newton.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// Which quantities a scheme keeps exactly (to round-off) on a kind of scene, wherever
/// the scene's own flow keeps them: H without applied torques (with them, the discrete
/// power balance is exact instead), μ = γ·π on scenes symmetric about γ (gravity, a
/// rotor), π on the torque-free body.
struct Keeps {
  bool energy = false;            ///< H_{n+1} = H_n (or the exact discrete power balance)
  bool momentum_map = false;      ///< μ_{n+1} = μ_n
  bool spatial_momentum = false;  ///< π_{n+1} = π_n (free body)
  bool energy_decays = false;     ///< H_{n+1} ≤ H_n at every step (dissipative schemes)
};

/// The memory of a scheme that remembers nothing between steps.
struct NoMemory {
  /// All fresh memories are equal.
  friend bool operator==(const NoMemory&, const NoMemory&) = default;
};

namespace detail {
template <class S, class Scene>
struct memory_of {
  using type = NoMemory;
};
template <class S, class Scene>
  requires requires { typename S::template Memory<Scene>; }
struct memory_of<S, Scene> {
  using type = typename S::template Memory<Scene>;
};
}  // namespace detail

/// The per-trajectory memory type of scheme S on Scene (NoMemory unless S declares one).
template <class S, class Scene>
using scheme_memory_t = typename detail::memory_of<S, Scene>::type;

/// Whether scheme S carries memory between steps on Scene.
template <class S, class Scene>
inline constexpr bool has_memory_v = !std::is_same_v<scheme_memory_t<S, Scene>, NoMemory>;

/// Whether S's memory is only a hint (a history predictor): a step from fresh memory is a
/// correct step, so a plain State may be stepped, each step from fresh memory. A scheme
/// says so with `static constexpr bool memory_is_hint = true`; memoryless schemes count.
template <class S, class Scene>
inline constexpr bool memory_is_hint_v = [] {
  if constexpr (!has_memory_v<S, Scene>) return true;
  else if constexpr (requires { S::memory_is_hint; }) return static_cast<bool>(S::memory_is_hint);
  else return false;
}();

/// Whether S's step changes its memory only on success, after checking `out` itself
/// (`static constexpr bool writes_memory_on_success = true`, see the file comment): the
/// Stepper then steps the memory in place. False unless declared (memoryless schemes: no
/// memory to copy anyway).
template <class S, class Scene>
inline constexpr bool writes_memory_on_success_v = [] {
  if constexpr (requires { S::writes_memory_on_success; }) return static_cast<bool>(S::writes_memory_on_success);
  else return false;
}();

/// S models a scheme that can step Scene (see the file comment).
template <class S, class Scene>
concept SchemeFor =
    std::copy_constructible<S> && std::default_initializable<scheme_memory_t<S, Scene>> &&
    std::copyable<scheme_memory_t<S, Scene>> &&
    requires(const S& s, const Scene& scene, const State<typename Scene::Scalar>& in, typename Scene::Scalar h,
             const NewtonOptions<typename Scene::Scalar>& options, State<typename Scene::Scalar>& out,
             scheme_memory_t<S, Scene>& memory) {
      { S::name } -> std::convertible_to<const char*>;
      { S::order } -> std::convertible_to<int>;
      { S::symmetric } -> std::convertible_to<bool>;
      { S::template keeps<Scene> } -> std::convertible_to<Keeps>;
      { s.step(scene, in, h, options, out, memory) } -> std::same_as<StepReport<typename Scene::Scalar>>;
    };

/// Whether `scheme`, with its parameters, is symmetric (Φ_{−h} = Φ_h⁻¹): composable.
template <class S>
constexpr bool symmetric(const S& scheme) {
  if constexpr (!S::symmetric) return false;
  else if constexpr (requires { scheme.is_symmetric(); }) return scheme.is_symmetric();
  else return true;
}

/// The order of accuracy of `scheme` with its parameters.
template <class S>
constexpr int order_of_accuracy(const S& scheme) {
  if constexpr (requires { scheme.order_of_accuracy(); }) return scheme.order_of_accuracy();
  else return S::order;
}

/// What `scheme`, with its parameters, keeps exactly on Scene.
/// On a scene with a time-dependent potential (gravity gradient) the energy is the Jacobi
/// integral E_J [G4]; a scheme keeps it only if it declares `keeps_jacobi_integral<Scene>`
/// true (the energy-projected splitting): the implicit schemes freeze t at the mid time.
template <class Scene, class S>
constexpr Keeps keeps(const S& scheme) {
  Keeps k;
  if constexpr (requires { scheme.template kept<Scene>(); }) k = scheme.template kept<Scene>();
  else k = S::template keeps<Scene>;
  if constexpr (requires { Scene::has_time_dependent_potential; }) {
    if constexpr (Scene::has_time_dependent_potential) {
      if constexpr (requires { S::template keeps_jacobi_integral<Scene>; }) k.energy = S::template keeps_jacobi_integral<Scene>;
      else k.energy = false;
    }
  }
  return k;
}

/// Throws invalid_input if a parameter of `scheme` is out of range (its validate());
/// a scheme without validate() has nothing to check. Stepper's constructor calls it.
template <class S>
void validate_scheme(const S& scheme) {
  if constexpr (requires { scheme.validate(); }) scheme.validate();
}

/// A state and the memory its scheme carries along it. For a memoryless scheme this is
/// just the State; Stepper::step and integrate() accept a plain State then.
///
///   Stepper<MyScheme, HeavyTop<double>> stepper(MyScheme{}, scene);
///   auto traj = stepper.start(c.initial);   // fresh memory
///   stepper.step(traj, h);
///   traj.omega *= 2; traj.reset();          // edited by hand: forget the history
template <class Scalar_, class Memory_ = NoMemory>
struct Trajectory : State<Scalar_> {
  /// The scalar type.
  using Scalar = Scalar_;
  /// The scheme's memory type.
  using Memory = Memory_;
  /// What the scheme carries from step to step along this trajectory.
  Memory memory{};

  Trajectory() = default;
  /// Starts a trajectory at `s` with fresh memory.
  explicit Trajectory(const State<Scalar>& s) : State<Scalar>(s) {}

  /// The state alone.
  State<Scalar>& state() { return *this; }
  /// The state alone.
  const State<Scalar>& state() const { return *this; }
  /// Forgets the memory (after the state was changed by hand): the next step starts afresh.
  void reset() { memory = Memory{}; }
};

}  // namespace trompo
