#pragma once
// The Scheme concept: what a type must provide to be stepped by Stepper, composed by
// ComposedStepper and driven by integrate().
//
// A scheme is a small value type (its parameters, e.g. Simo-α's α) with
//
//   static constexpr const char* name;          // "simo-kappa": CLI, reports, test names
//   static constexpr SchemeTraits traits{…};    // its properties, in one required value
//   template <class Scene>
//   StepReport<Scalar> step(const Scene&, const State<Scalar>& in, Scalar h,
//                           const NewtonOptions<Scalar>&, State<Scalar>& out,
//                           Memory<Scene>& memory) const;
//
// The traits value says everything the library reads off a scheme: its order, whether it
// is symmetric (composable), what it keeps exactly on each kind of scene, what its memory
// is, and which of the optional members below it defines. Each field is named
// (designated initialisers), so a misspelt field does not compile, and each optional member
// is declared there, so the concept refuses a scheme whose members and traits disagree (a
// misspelt `refined` or `validate`, a `Memory` the traits do not announce or the reverse):
//
//   template <class Scene> using Memory = …;    // iff traits.memory != MemoryUse::none
//   SchemeTraits refined() const;               // iff traits.refined: the run-time refinement
//   void validate() const;                      // iff traits.validated: throws invalid_input
//
// The run-time refinement is for families whose parameters change a property: Simo-α is
// symmetric and of order 2 only for α = ½. Read the properties through trompo::symmetric,
// trompo::order_of_accuracy and trompo::keeps, which take the refinement when there is one
// (and the static traits otherwise; scheme_keeps_v and S::traits at compile time).
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
// history predictor) declares its type as `Memory<Scene>` and its role in traits.memory
// (MemoryUse::carried, or MemoryUse::hint when a step from fresh memory is a correct step,
// so that a plain State may be stepped). A default-constructed
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
// `.writes_memory_on_success = true` in its traits: its `step` then promises to
// change the memory only when it returns ok, after it has checked `out` with
// detail::committable (state.hpp), and never otherwise. The Stepper then steps the
// caller's memory in place instead of a copy committed on success (two copies of the
// memory per step saved: 248 bytes for the history predictor's), and leaves that check
// to the scheme. The failure contract is the same.
#include <cmath>
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

/// The kind of a scene, as far as what a scheme keeps depends on it (model/scene.hpp).
struct SceneKind {
  bool is_free = false;             ///< no effect at all: the torque-free body
  bool has_potential = false;       ///< some effect is a potential (enters H)
  bool potentials_linear = true;    ///< every potential is linear in Λ (uniform gravity)
  bool has_applied_torque = false;  ///< some effect is an applied torque
  bool has_rotor = false;           ///< some effect is a rotor
  bool has_time_dependent_potential = false;  ///< some potential depends on t (gravity gradient)
  bool has_wheels = false;          ///< some effect is a rotor of time-dependent momentum (wheels)

  /// Wheels and no external load (no potential, no applied torque): the spacecraft whose
  /// total momentum π = Λ(J_hubΩ + h_w) the wheel-carrying momentum schemes keep [W4].
  constexpr bool wheels_only() const { return has_wheels && !has_potential && !has_applied_torque; }
};

/// The kind of Scene.
template <class Scene>
inline constexpr SceneKind scene_kind_v{.is_free = Scene::is_free,
                                        .has_potential = Scene::has_potential,
                                        .potentials_linear = Scene::potentials_linear,
                                        .has_applied_torque = Scene::has_applied_torque,
                                        .has_rotor = Scene::has_rotor,
                                        .has_time_dependent_potential = Scene::has_time_dependent_potential,
                                        .has_wheels = Scene::has_wheels};

/// What a scheme's memory is (its `Memory<Scene>`, scheme.hpp's file comment).
enum class MemoryUse {
  none,     ///< memoryless: no Memory<Scene> (NoMemory)
  carried,  ///< part of the trajectory (gen-α's a_n): a plain State cannot be stepped
  hint      ///< only speeds steps up (a history predictor): a step from fresh memory is correct
};

/// What keeps nothing exactly keeps, on any scene.
constexpr Keeps keeps_nothing(SceneKind) { return {}; }

/// A scheme's properties, in its one required `static constexpr SchemeTraits traits`.
/// Written with designated initialisers, so that a misspelt field is a compile error:
///
///   static constexpr SchemeTraits traits{
///       .order = 2, .symmetric = true,
///       .keeps = [](SceneKind s) { return Keeps{.energy = true, .spatial_momentum = s.is_free}; },
///       .memory = MemoryUse::hint};
struct SchemeTraits {
  /// Order of accuracy (at the default parameters; refined() may lower it).
  int order = 0;
  /// Φ_{−h} = Φ_h⁻¹ (for some parameters): may be composed to higher order.
  bool symmetric = false;
  /// What it keeps exactly on a kind of scene.
  Keeps (*keeps)(SceneKind) = keeps_nothing;
  /// Its error scales with the load (the part of H it does not flow exactly), not with the
  /// motion's derivatives: the spin-exact splitting. An interpolant's defect, which sees the
  /// derivatives, overestimates such an error, by up to 10⁵ on the tops; the adaptive
  /// driver's automatic error estimate is then Richardson's, from the scheme's own steps
  /// (drivers/adaptive.hpp, docs/theory.md [A8]).
  bool error_scales_with_load = false;
  /// On a scene with a time-dependent potential (gravity gradient) the energy is the Jacobi
  /// integral E_J [G4]: `keeps(...).energy` counts there only if this is set (the
  /// energy-projected splitting); the implicit schemes freeze t at the mid time.
  bool keeps_jacobi_integral = false;
  /// It steps scenes with reaction wheels (Scene::has_wheels): its momentum balance reads the
  /// wheels' h_w(t) at both ends of the step, Π_{n+1} − Π_n ∋ h_w(t_{n+1}) − h_w(t_n)
  /// (docs/theory.md [W4]). A scheme without it is not a SchemeFor such a scene.
  bool carries_wheels = false;
  /// What its Memory<Scene> is; none: the scheme declares no Memory.
  MemoryUse memory = MemoryUse::none;
  /// Its step changes the memory only on success, after checking `out` with
  /// detail::committable (see the file comment): the Stepper steps the memory in place.
  bool writes_memory_on_success = false;
  /// The scheme defines `SchemeTraits refined() const`: these traits for its parameters.
  bool refined = false;
  /// The scheme defines `void validate() const`, which throws invalid_input for a bad parameter.
  bool validated = false;
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

/// S states its traits: a constant `S::traits` of type SchemeTraits.
template <class S>
concept states_traits = requires {
  S::traits;
  typename std::integral_constant<int, S::traits.order>;  // a constant expression
} && std::same_as<std::remove_cvref_t<decltype(S::traits)>, SchemeTraits>;

/// S's members agree with what its traits declare (each optional member iff its flag).
template <class S, class Scene>
concept members_as_declared =
    (S::traits.memory != MemoryUse::none) == requires { typename S::template Memory<Scene>; } &&
    (S::traits.memory != MemoryUse::none || !S::traits.writes_memory_on_success) &&
    S::traits.refined == requires(const S& s) {
      { s.refined() } -> std::same_as<SchemeTraits>;
    } && S::traits.validated == requires(const S& s) { s.validate(); } && S::traits.keeps != nullptr;
}  // namespace detail

/// The per-trajectory memory type of scheme S on Scene (NoMemory unless S declares one).
template <class S, class Scene>
using scheme_memory_t = typename detail::memory_of<S, Scene>::type;

/// Whether scheme S carries memory between steps on Scene.
template <class S, class Scene>
inline constexpr bool has_memory_v = S::traits.memory != MemoryUse::none;

/// Whether S's memory is only a hint (a history predictor): a step from fresh memory is a
/// correct step, so a plain State may be stepped, each step from fresh memory
/// (MemoryUse::hint); memoryless schemes count.
template <class S, class Scene>
inline constexpr bool memory_is_hint_v = S::traits.memory != MemoryUse::carried;

/// Whether S's step changes its memory only on success, after checking `out` itself
/// (traits.writes_memory_on_success, see the file comment): the Stepper then steps the
/// memory in place.
template <class S, class Scene>
inline constexpr bool writes_memory_on_success_v = S::traits.writes_memory_on_success;

/// What scheme S keeps exactly on Scene by its static traits (at its default parameters).
template <class S, class Scene>
inline constexpr Keeps scheme_keeps_v = S::traits.keeps(scene_kind_v<Scene>);

/// S models a scheme that can step Scene (see the file comment).
template <class S, class Scene>
concept SchemeFor =
    std::copy_constructible<S> && detail::states_traits<S> && detail::members_as_declared<S, Scene> &&
    (!Scene::has_wheels || S::traits.carries_wheels) &&
    std::default_initializable<scheme_memory_t<S, Scene>> && std::copyable<scheme_memory_t<S, Scene>> &&
    requires(const S& s, const Scene& scene, const State<typename Scene::Scalar>& in, typename Scene::Scalar h,
             const NewtonOptions<typename Scene::Scalar>& options, State<typename Scene::Scalar>& out,
             scheme_memory_t<S, Scene>& memory) {
      { S::name } -> std::convertible_to<const char*>;
      { s.step(scene, in, h, options, out, memory) } -> std::same_as<StepReport<typename Scene::Scalar>>;
    };

/// The traits of `scheme` with its parameters: its refined() if it has one, else S::traits.
template <class S>
constexpr SchemeTraits traits_of(const S& scheme) {
  if constexpr (S::traits.refined) return scheme.refined();
  else return S::traits;
}

/// Whether `scheme`, with its parameters, is symmetric (Φ_{−h} = Φ_h⁻¹): composable.
template <class S>
constexpr bool symmetric(const S& scheme) {
  if constexpr (!S::traits.symmetric) return false;
  else return traits_of(scheme).symmetric;
}

/// The order of accuracy of `scheme` with its parameters.
template <class S>
constexpr int order_of_accuracy(const S& scheme) {
  return traits_of(scheme).order;
}

/// What `scheme`, with its parameters, keeps exactly on Scene.
/// On a scene with a time-dependent potential (gravity gradient) the energy is the Jacobi
/// integral E_J [G4]; a scheme keeps it only if its traits say `keeps_jacobi_integral`
/// (the energy-projected splitting): the implicit schemes freeze t at the mid time.
template <class Scene, class S>
constexpr Keeps keeps(const S& scheme) {
  const SchemeTraits t = traits_of(scheme);
  Keeps k = t.keeps(scene_kind_v<Scene>);
  if (scene_kind_v<Scene>.has_time_dependent_potential && !t.keeps_jacobi_integral) k.energy = false;
  return k;
}

/// Throws invalid_input if a parameter of `scheme` is out of range (its validate(), when
/// its traits say it has one). Stepper's constructor calls it.
template <class S>
void validate_scheme(const S& scheme) {
  if constexpr (S::traits.validated) scheme.validate();
}

namespace detail {
/// The h check of every stepper: a step of size zero or not finite is refused with
/// invalid_step before any scheme is called; a negative h integrates backward. ok otherwise.
template <class Scalar>
StepReport<Scalar> check_step_size(Scalar h) {
  StepReport<Scalar> rep;
  if (!std::isfinite(static_cast<double>(h)) || h == Scalar(0)) rep.status = StepStatus::invalid_step;
  return rep;
}
}  // namespace detail

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
