#pragma once
// Spin-exact splitting (docs/theory.md §12, [S1]–[S13]): explicit Lie–Poisson splittings
// whose free sub-flow is the exact rotation of a symmetric body [S2], so that their error
// scales with the load, not with the spin. Every sub-flow is an exact flow of a piece of the
// Hamiltonian that keeps π = ΛΠ (free flows) or μ = γ·π (kicks of a load symmetric about γ):
// the splittings keep μ and π exactly (to round-off) and H within a bounded, drift-free
// band; with SplittingProjected, H exactly too [S12].
//
//   Stepper<Splitting, HeavyTop<double>> stepper(Splitting(SplittingMethod::chin_4a), scene);
//   auto traj = stepper.start(c.initial);   // the memory holds the principal frame
//   stepper.step(traj, 0.01);
//
// Methods (SplittingMethod), each symmetric, with adjacent kicks merged across sub-steps:
//   strang            V(h/2) A(h/2) S(h) A(h/2) V(h/2)                 order 2   [S1]
//   suzuki_5          Suzuki's 5-stage composition of Strang            order 4   [S6]
//   kahan_li_9        Kahan–Li's 9-stage composition of Strang          order 6   [S6]
//   chin_4a           V(h/6) T(h/2) Ṽ(2h/3) T(h/2) V(h/6)               order 4   [S7]
//   chin_triple_jump  triple jump γ1 = 1/(2 − 2^{1/5}) of chin_4a       order 6   [S6]
// S is the free symmetric flow [S2], A the asymmetric remainder [S3], V the kick [S4],
// Ṽ Chin's modified kick [S7], T the free flow. For a symmetric body without rotor T = S is
// exact. Otherwise Chin's T is Suzuki's composition of A S A (order 4), which keeps Chin at
// order 4 (with a Strang T it would be only of order 2, [S7]); for asymmetric heavy bodies
// the Strang compositions are usually the cheaper choice of each order, see
// Splitting::default_for.
//
// Frame. The working frame is the principal frame relabelled (s = z, a = y, b = x), found
// once per trajectory, on the first step, and kept in the scheme's Memory (a
// detail::SplittingMemory): a full inertia is diagonalised there and not per step, and a
// diagonal inertia whose axes are already in place (HT0, HT1) costs no conversion at all.
// State in, state out stay in the user's body frame.
//
// Effects [S13]: potentials (uniform gravity, a user V) and velocity-independent applied
// torques (BodyTorque, SpaceTorque) are kicks sampled at the split clock (time advances in
// S, so time-dependent torques keep the order); a rotor adds the exact flow of its linear
// term; viscous damping its exact exponential decay. An effect with no sub-flow is a
// compile-time error. Chin's methods need the force gradient of a potential: they are
// offered on scenes whose effects are potentials and rotors only.
//
// What can fail: a non-finite value (input or overflow) makes the step report non_finite;
// a Chin method on a scene with applied torques reports invalid_step (check() throws
// invalid_input for it beforehand). No allocation, no virtual call, no Newton iteration.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <type_traits>

#include "trompo/schemes/coefficients.hpp"
#include "trompo/schemes/splitting/flows.hpp"
#include "trompo/errors.hpp"
#include "trompo/solvers/newton.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// The splitting methods on offer (see schemes/splitting.hpp).
enum class SplittingMethod {
  strang,            ///< order 2: V(h/2) A(h/2) S(h) A(h/2) V(h/2)
  chin_4a,           ///< order 4: Chin's 4A with the modified middle kick [S7]
  chin_triple_jump,  ///< order 6: triple jump of chin_4a
  suzuki_5,          ///< order 4: Suzuki's composition of Strang, kicks merged
  kahan_li_9,        ///< order 6: Kahan–Li's composition of Strang, kicks merged
  saba2c,            ///< Laskar–Robutel SABA2 with corrector: O(εh⁴ + ε²h⁴)   [F8]
  saba3c,            ///< SABA3 with corrector: O(εh⁶ + ε²h⁴)
  saba4c,            ///< SABA4 with corrector: O(εh⁸ + ε²h⁴)
  sbab2c,            ///< SBAB2 with corrector: O(εh⁴ + ε²h⁴)
  sbab3c             ///< SBAB3 with corrector: O(εh⁶ + ε²h⁴)
};

/// The CLI name of a splitting method ("strang", "chin-4a", …).
inline const char* to_string(SplittingMethod m) {
  switch (m) {
    case SplittingMethod::strang: return "strang";
    case SplittingMethod::chin_4a: return "chin-4a";
    case SplittingMethod::chin_triple_jump: return "chin-triple-jump";
    case SplittingMethod::suzuki_5: return "suzuki-5";
    case SplittingMethod::kahan_li_9: return "kahan-li-9";
    case SplittingMethod::saba2c: return "saba2c";
    case SplittingMethod::saba3c: return "saba3c";
    case SplittingMethod::saba4c: return "saba4c";
    case SplittingMethod::sbab2c: return "sbab2c";
    case SplittingMethod::sbab3c: return "sbab3c";
  }
  return "unknown";
}

/// The order of a splitting method: 2, 4 or 6. The corrected near-integrable compositions
/// count as order 4 (their ε²h⁴ term; the ε term is of order 2n, [F8]).
constexpr int order_of(SplittingMethod m) {
  switch (m) {
    case SplittingMethod::strang: return 2;
    case SplittingMethod::chin_4a:
    case SplittingMethod::suzuki_5:
    case SplittingMethod::saba2c:
    case SplittingMethod::saba3c:
    case SplittingMethod::saba4c:
    case SplittingMethod::sbab2c:
    case SplittingMethod::sbab3c: return 4;
    case SplittingMethod::chin_triple_jump:
    case SplittingMethod::kahan_li_9: return 6;
  }
  return 2;
}

/// Chin's methods: they need a scene whose effects are potentials and rotors only.
constexpr bool is_chin(SplittingMethod m) {
  return m == SplittingMethod::chin_4a || m == SplittingMethod::chin_triple_jump;
}

/// The corrected near-integrable compositions SABA_nC, SBAB_nC of Laskar & Robutel [F8]:
/// they need the exact free flow (no rotor) and a force gradient (potentials only); with
/// reaction wheels they run on the hub's exact flow without the corrector [W18].
constexpr bool is_near_integrable(SplittingMethod m) {
  return m == SplittingMethod::saba2c || m == SplittingMethod::saba3c || m == SplittingMethod::saba4c ||
         m == SplittingMethod::sbab2c || m == SplittingMethod::sbab3c;
}

/// The order of a splitting method on a scene with reaction wheels: order_of(m), except the
/// near-integrable methods, which run there without their corrector, O(εh^{2n} + ε²h²) [W18].
constexpr int order_with_wheels(SplittingMethod m) { return is_near_integrable(m) ? 2 : order_of(m); }

/// Every splitting method, in the order of the enum (CLI names by to_string).
inline constexpr SplittingMethod all_splitting_methods[] = {
    SplittingMethod::strang, SplittingMethod::chin_4a, SplittingMethod::chin_triple_jump,
    SplittingMethod::suzuki_5, SplittingMethod::kahan_li_9, SplittingMethod::saba2c,
    SplittingMethod::saba3c, SplittingMethod::saba4c, SplittingMethod::sbab2c, SplittingMethod::sbab3c};

namespace detail {
/// The coefficients of a near-integrable composition [F8] (Laskar & Robutel 2001, Tables 1–2):
/// SABA_n: A(c₁h) B(d₁h) A(c₂h) … B(d₁h) A(c₁h), kicks at the Gauss–Legendre nodes with their
/// weights; SBAB_n: B(d₁h) A(c₂h) B(d₂h) … A(c₂h) B(d₁h), kicks at the Lobatto nodes. The
/// corrector at each end is the force-gradient kick Π += g h³ KᵀJ⁻¹τ.
struct NearIntegrable {
  bool kick_first = false;  ///< SBAB (true) or SABA (false)
  int n_free = 0;           ///< free flows A in the whole step
  long double c[5] = {};    ///< the free-flow fractions, first half (palindromic)
  long double d[5] = {};    ///< the kick fractions, first half (palindromic)
  long double g = 0;        ///< the corrector's weight
  static NearIntegrable of(SplittingMethod m) {
    NearIntegrable r;
    switch (m) {
      case SplittingMethod::saba2c:  // c₁ = ½ − √3/6, c₂ = √3/3; d₁ = ½; g = (2 − √3)/24
        r = {false, 3, {0.211324865405187117745425609748929016L, 0.577350269189625764509148780501957456L}, {0.5L}, 0.0111645496846301127696897357705886514L};
        break;
      case SplittingMethod::saba3c:  // c₁ = ½ − √15/10, c₂ = √15/10; d = 5/18, 4/9; g = (54 − 13√15)/648
        r = {false, 4, {0.112701665379258311482073460021760038L, 0.387298334620741688517926539978239962L},
             {0.277777777777777777777777777777777778L, 0.444444444444444444444444444444444444L},
             0.00563459336312280940226782376979753867L};
        break;
      case SplittingMethod::saba4c:  // Gauss–Legendre 4 nodes and weights
        r = {false, 5,
             {0.0694318442029737123880267555535953352L, 0.260577634004598155210640364894782409L,
              0.339981043584856264802665759103244687L},
             {0.173927422568726928686531974610999704L, 0.326072577431273071313468025389000296L},
             0.003396775048208601331532157783492144L};
        break;
      case SplittingMethod::sbab2c:  // c₂ = ½; d = 1/6, 2/3; g = 1/72
        r = {true, 2, {0.0L, 0.5L}, {0.166666666666666666666666666666666667L, 0.666666666666666666666666666666666667L},
             0.0138888888888888888888888888888888889L};
        break;
      case SplittingMethod::sbab3c:  // c₂ = ½ − √5/10, c₃ = √5/5; d = 1/12, 5/12; g = (13 − 5√5)/288
        r = {true, 3, {0.0L, 0.276393202250021030359082633126872376L, 0.447213595499957939281834733746255248L},
             {0.0833333333333333333333333333333333333L, 0.416666666666666666666666666666666667L},
             0.00631826427951753999289629047341534313L};
        break;
      default: break;
    }
    return r;
  }
};
}  // namespace detail

namespace detail {
/// What the effects of a scene (a tuple of effects) need from the splitting.
template <class Tuple>
struct splitting_effects;
/// The tuple case.
template <class... E>
struct splitting_effects<std::tuple<E...>> {
  /// Every effect has an exact sub-flow ([S13]).
  static constexpr bool all_have_flows = ((sub_flow_of<E>() != SubFlowKind::none) && ...);
  /// Some effect is viscous damping.
  static constexpr bool has_damping = ((sub_flow_of<E>() == SubFlowKind::damping) || ...);
  /// Some effect is a kick (a potential or a velocity-independent torque).
  static constexpr bool has_kick = ((sub_flow_of<E>() == SubFlowKind::kick) || ...);
  /// Only potentials and rotors: Chin's force gradient applies, H is conserved.
  static constexpr bool conservative =
      ((std::is_same_v<typename E::kind, potential_kind> || std::is_same_v<typename E::kind, rotor_kind>) && ...);
};
/// splitting_effects of a scene's effects.
template <class Scene>
using splitting_effects_of = splitting_effects<std::decay_t<decltype(std::declval<const Scene&>().effects())>>;
}  // namespace detail

/// The spin-exact splitting scheme; with EnergyProjection, each composed step ends with the
/// π-keeping energy projection [S12] (conservative scenes only, checked at compile time).
template <bool EnergyProjection = false>
struct SplittingScheme {
  /// The method; Strang by default (valid on every scene).
  SplittingMethod method = SplittingMethod::strang;

  SplittingScheme() = default;
  /// A scheme running `m`.
  explicit SplittingScheme(SplittingMethod m) : method(m) {}

  /// The scheme's name, as the CLI and the reports spell it.
  static constexpr const char* name = EnergyProjection ? "splitting-projected" : "splitting";
  /// Order 2 for the default (Strang; refined(): the method's order). Every method is
  /// symmetric; the projected step is not (it pulls H back to the trajectory's first
  /// energy, which h then −h does not undo), so it is not composable. Keeps μ (under a load
  /// symmetric about γ) always; π where the scene's flow keeps it (no potential, no applied
  /// torque: the free body, with or without a rotor); H only projected (with a time-dependent
  /// potential, H is the Jacobi integral E_J [G4], [G5]: projected, kept; plain, a bounded
  /// band). Its memory: the working frame, a cache of the scene's constants that a step
  /// from fresh memory rebuilds (a hint), and with the projection the trajectory's first
  /// energy, which no later state can rebuild (carried).
  static constexpr SchemeTraits traits{
      .order = 2,
      .symmetric = !EnergyProjection,
      .keeps =
          [](SceneKind s) {
            return Keeps{.energy = EnergyProjection,
                         .momentum_map = true,
                         .spatial_momentum = !s.has_potential && !s.has_applied_torque};
          },
      .error_scales_with_load = true,
      .keeps_jacobi_integral = EnergyProjection,
      .carries_wheels = !EnergyProjection,
      .memory = EnergyProjection ? MemoryUse::carried : MemoryUse::hint,
      .writes_memory_on_success = true,
      .refined = true};
  /// Whether the energy projection [S12] runs after each step.
  static constexpr bool energy_projection = EnergyProjection;

  /// The per-trajectory memory: the working frame (principal axes, [S1]/[S8]).
  template <class Scene>
  using Memory = detail::SplittingMemory<typename Scene::Scalar>;

  /// The traits with the chosen method: its order (2, 4 or 6).
  constexpr SchemeTraits refined() const {
    SchemeTraits t = traits;
    t.order = order_of(method);
    return t;
  }

  /// The order on a scene: order_with_wheels(method) on a scene with wheels, else
  /// order_of(method). (Stepper::order() takes this one: the adaptive driver's error estimate
  /// needs it.)
  template <class Scene>
  constexpr int order_on(const Scene&) const {
    return Scene::has_wheels ? order_with_wheels(method) : order_of(method);
  }

  /// Whether the method can step this scene (check() throws the reason where it cannot):
  /// Chin's methods need a conservative scene without wheels; the near-integrable ones a
  /// conservative scene, or any scene with wheels [W18].
  template <class Scene>
  constexpr bool offered_on() const {
    using Effects = detail::splitting_effects_of<Scene>;
    if (is_chin(method)) return Effects::conservative && !Scene::has_wheels;
    if (is_near_integrable(method)) return Scene::has_wheels || Effects::conservative;
    return true;
  }

  /// Throws invalid_input if the method is not offered on this scene (a Chin method with an
  /// applied torque or damping, whose force-gradient term [S7] does not apply).
  template <class Scene>
  void check(const Scene& scene) const {
    using Effects = detail::splitting_effects_of<Scene>;
    if (is_near_integrable(method)) {
      if constexpr (!Scene::has_wheels) {
        if (!Effects::conservative)
          detail::fail("splitting: method ", to_string(method),
                       " needs a scene whose effects are potentials (its corrector is a force gradient [F8]); this "
                       "scene has applied torques or damping: use strang, suzuki-5 or kahan-li-9");
        if constexpr (Scene::has_rotor)
          if (scene.rotor_momentum() != Eigen::Matrix<typename Scene::Scalar, 3, 1>::Zero())
            detail::fail("splitting: method ", to_string(method),
                         " needs the exact free flow [F1]-[F7], which a rotor's gyrostat term does not have: use "
                         "chin-4a or the Strang compositions");
      }
    }
    if constexpr (Scene::has_wheels)
      if (is_chin(method))
        detail::fail("splitting: method ", to_string(method),
                     " needs an exact free flow or a conservative load, which a scene with wheels has not (their "
                     "held torques change h_w): use strang, suzuki-5, kahan-li-9 or the near-integrable saba/sbab "
                     "methods [W18]");
    if (is_chin(method) && !Effects::conservative)
      detail::fail("splitting: method ", to_string(method),
                   " needs a scene whose effects are potentials and rotors (its modified kick is a force "
                   "gradient [S7]); this scene has applied torques or damping: use strang, suzuki-5 or kahan-li-9");
  }

  /// The method recommended for a given order on a scene: Chin 4A and its triple jump where
  /// the free flow is exact (symmetric body, no rotor) and the effects are potentials,
  /// otherwise the Strang compositions Suzuki-5 and Kahan–Li-9 ([S7]: on an asymmetric heavy
  /// top Suzuki of the whole Strang step is the better order-4 choice). Throws
  /// invalid_input for an order other than 2, 4, 6.
  template <class Scene>
  static SplittingScheme default_for(const Scene& scene, int wanted_order) {
    if (wanted_order != 2 && wanted_order != 4 && wanted_order != 6) detail::fail("splitting: order must be 2, 4 or 6, got ", wanted_order);
    if (wanted_order == 2) return SplittingScheme(SplittingMethod::strang);
    const auto frame = detail::SplittingFrame<typename Scene::Scalar>::of(scene);
    // Chin wherever its free flow T is exact: S on a symmetric body, the Euler–Poinsot flow
    // [F1]–[F7] on an asymmetric one without rotor (measured, docs/splitting.md: on HTA at
    // 1e-8 Chin 4A on the exact flow beats Suzuki-5 and Kahan–Li-9).
    const bool chin = detail::splitting_effects_of<Scene>::conservative && !frame.wheels &&
                      (frame.free_flow_exact() || frame.rotor_rate == typename Scene::Scalar(0));
    if (wanted_order == 4) return SplittingScheme(chin ? SplittingMethod::chin_4a : SplittingMethod::suzuki_5);
    return SplittingScheme(chin ? SplittingMethod::chin_triple_jump : SplittingMethod::kahan_li_9);
  }

  /// One step (see the file comment); the memory holds the working frame.
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h, const NewtonOptions<typename Scene::Scalar>&,
                                          State<typename Scene::Scalar>& out,
                                          detail::SplittingMemory<typename Scene::Scalar>& memory) const {
    using Effects = detail::splitting_effects_of<Scene>;
    static_assert(Effects::all_have_flows,
                  "splitting: an effect of this scene has no exact sub-flow. Potentials, rotors, viscous "
                  "damping, BodyTorque and SpaceTorque have one (docs/theory.md [S13]); for another "
                  "velocity-independent torque specialise trompo::is_splitting_kick<Effect>");
    static_assert(!EnergyProjection || Effects::conservative,
                  "splitting: the energy projection [S12] needs a conservative scene (potentials and rotors "
                  "only): with applied torques or damping there is no conserved H to project on");
    using Scalar = typename Scene::Scalar;
    if (memory.ready) return step_in_frame(scene, memory.frame, in, h, out, memory.energy, false, memory);
    // A fresh memory: the frame is built here and committed with a successful step only
    // (writes_memory_on_success); afterwards every step reads it in place.
    const bool no_s_or_a = is_chin(method) || is_near_integrable(method) || (!Effects::has_kick && !Effects::has_damping);
    const detail::SplittingFrame<Scalar> f = detail::SplittingFrame<Scalar>::of(scene, no_s_or_a);
    Scalar H0 = Scalar(0);
    // (step_in_frame keeps the working state in `memory` on success only; fresh memory
    // carries none, so the step converts its input.)
    const StepReport<Scalar> rep = step_in_frame(scene, f, in, h, out, H0, true, memory);
    if (rep.ok()) {
      memory.frame = f;
      memory.energy = H0;
      memory.ready = true;
    }
    return rep;
  }

 private:
  /// The step in the working frame f; H0 is the trajectory's first energy, computed here
  /// when `fresh` (the energy projection aims at it). The step resumes from the working state
  /// in `memory` when `in` is its last output, and keeps its own there on success [S14].
  template <class Scene>
  StepReport<typename Scene::Scalar> step_in_frame(const Scene& scene,
                                                   const detail::SplittingFrame<typename Scene::Scalar>& f,
                                                   const State<typename Scene::Scalar>& in, typename Scene::Scalar h,
                                                   State<typename Scene::Scalar>& out, typename Scene::Scalar& H0,
                                                   bool fresh, detail::SplittingMemory<typename Scene::Scalar>& memory) const {
    using Effects = detail::splitting_effects_of<Scene>;
    using Scalar = typename Scene::Scalar;
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    StepReport<Scalar> rep;
    if (!offered_on<Scene>()) {
      rep.status = StepStatus::invalid_step;  // check() says why
      return rep;
    }
    if (is_near_integrable(method) && !Scene::has_wheels && !f.free_flow_exact() && !f.exact_free) {
      rep.status = StepStatus::invalid_step;  // a rotor: check() says why
      return rep;
    }

    detail::SplitState<Scalar> x;
    if (memory.resumes(in, Scene::has_wheels)) {
      // [S14] the last step's own working state: no round trip through the frame.
      x = memory.working;
      x.t = in.time;
    } else {
      // To the working frame: Λ_w = Λ Q, Ω_w = Qᵀ Ω, Π_w = J Ω_w + h_r.
      x.q = f.identity ? in.rotation.unit_quaternion() : in.rotation.unit_quaternion() * f.Q;
      const Vector3 omega_w = f.identity ? in.omega : Vector3(f.Qt * in.omega);
      x.P = f.J.cwiseProduct(omega_w);
      x.t = in.time;
      if constexpr (Scene::has_rotor || Scene::has_wheels) x.P += detail::internal_momentum(scene, f, x.t);
    }
    // The projection aims at the trajectory's first energy (kept in the memory), not at
    // each step's: the one-update residuals (~ε) then do not accumulate as a random walk.
    if constexpr (EnergyProjection)
      if (fresh) H0 = detail::working_energy(scene, f, x);

    switch (method) {
      case SplittingMethod::strang: {
        const Scalar w[1] = {Scalar(1)};
        composed_strang<Scene>(scene, f, x, h, w, 1);
        break;
      }
      case SplittingMethod::suzuki_5: {
        const auto c = CompositionCoefficients<Scalar>::of(Composition::suzuki5);
        composed_strang<Scene>(scene, f, x, h, c.gamma.data(), c.stages);
        break;
      }
      case SplittingMethod::kahan_li_9: {
        const auto c = CompositionCoefficients<Scalar>::of(Composition::kahan_li9);
        composed_strang<Scene>(scene, f, x, h, c.gamma.data(), c.stages);
        break;
      }
      case SplittingMethod::chin_4a:
      case SplittingMethod::chin_triple_jump:
        if constexpr (Effects::conservative) {
          if (method == SplittingMethod::chin_4a) {
            const Scalar g[1] = {Scalar(1)};
            chin<Scene>(scene, f, x, h, g, 1);
          } else {
            // Triple jump raising the symmetric order-4 Chin 4A to order 6:
            // γ1 = γ3 = 1/(2 − 2^{1/5}), γ2 = 1 − 2γ1.
            const Scalar g[3] = {Scalar(1.17467175808936338449506943655714546L),
                                 Scalar(-1.34934351617872676899013887311429093L),
                                 Scalar(1.17467175808936338449506943655714546L)};
            chin<Scene>(scene, f, x, h, g, 3);
          }
        }
        break;
      case SplittingMethod::saba2c:
      case SplittingMethod::saba3c:
      case SplittingMethod::saba4c:
      case SplittingMethod::sbab2c:
      case SplittingMethod::sbab3c:
        if constexpr (Scene::has_wheels)
          near_integrable_wheels<Scene>(scene, f, x, h, detail::NearIntegrable::of(method));
        else if constexpr (Effects::conservative)
          near_integrable<Scene>(scene, f, x, h, detail::NearIntegrable::of(method));
        break;
    }
    if constexpr (EnergyProjection) detail::project_energy(scene, f, x, H0);

    if (!detail::all_finite(x.q.coeffs()) || !detail::all_finite(x.P) || !(x.q.coeffs().cwiseAbs().maxCoeff() > 0)) {
      rep.status = StepStatus::non_finite;
      return rep;
    }
    // Back to the user's frame: Λ = Λ_w Qᵀ, Ω = Q J⁻¹(Π_w − h_r).
    const Eigen::Quaternion<Scalar> q = f.identity ? x.q : x.q * f.Q.conjugate();
    out.rotation = SO3<Scalar>::renormalized(q);
    Vector3 m = x.P;
    if constexpr (Scene::has_rotor || Scene::has_wheels) m -= detail::internal_momentum(scene, f, in.time + h);
    // Divided, not multiplied by the rounded 1/J: a rounded reciprocal biases every step the
    // same way (π would drift like N·ε, as in [S5]).
    const Vector3 omega = m.cwiseQuotient(f.J);
    out.omega = f.identity ? omega : Vector3(f.Qm * omega);
    out.time = in.time + h;
    if (!detail::committable(out)) {  // writes_memory_on_success: the one check of `out`
      rep.status = StepStatus::non_finite;
      return rep;
    }
    memory.keep(x, out);
    return rep;
  }

  /// With wheels on an asymmetric hub, the core of each Strang step is the exact free flow
  /// [F1]–[F7] and the rotor flow is split off [W14] (no S and A).
  template <class Scalar>
  static bool wheels_on_exact_free(const detail::SplittingFrame<Scalar>& f) {
    return f.wheels && f.exact_free;
  }

  using FlowId = int;
  static constexpr FlowId damping_flow = 0, kick_flow = 1, rotor_flow = 2, asymmetric_flow = 3;

  /// The flows around S in a Strang step, outermost first ([S1], [S13]).
  template <class Scene, class Scalar>
  static int outer_flows(const detail::SplittingFrame<Scalar>& f, FlowId (&ids)[4], bool with_loads) {
    using Effects = detail::splitting_effects_of<Scene>;
    int m = 0;
    if (with_loads) {
      if constexpr (Effects::has_damping) ids[m++] = damping_flow;
      if constexpr (Effects::has_kick) ids[m++] = kick_flow;
    }
    if constexpr (Scene::has_wheels)
      ids[m++] = rotor_flow;  // w(t) changes with the held commands: always a sub-flow [W14]
    else if constexpr (Scene::has_rotor)
      if (f.rotor_rate > Scalar(0)) ids[m++] = rotor_flow;
    if (f.k_b != Scalar(0) && !wheels_on_exact_free(f)) ids[m++] = asymmetric_flow;
    return m;
  }

  template <class Scene, class Scalar>
  static void apply(FlowId id, const Scene& scene, const detail::SplittingFrame<Scalar>& f,
                    detail::SplitState<Scalar>& x, Scalar t) {
    using Effects = detail::splitting_effects_of<Scene>;
    switch (id) {
      case damping_flow:
        if constexpr (Effects::has_damping) detail::flow_damping(scene, f, x, t);
        break;
      case kick_flow:
        if constexpr (Effects::has_kick) detail::flow_kick(scene, f, x, t);
        break;
      case rotor_flow:
        if constexpr (Scene::has_wheels) detail::flow_wheels(scene, f, x, t);
        else if constexpr (Scene::has_rotor) detail::flow_rotor(f, x, t);
        break;
      default: detail::flow_asymmetric(f, x, t);
    }
  }

  /// Π_i Strang(w_i h), Strang(τ) = X_1(τ/2)…X_m(τ/2) S(τ) X_m(τ/2)…X_1(τ/2), with the
  /// outermost flow X_1 (a one-parameter group) merged across adjacent sub-steps [S6].
  /// with_loads = false: the free flow alone (Chin's inner T).
  template <class Scene, class Scalar>
  static void composed_strang(const Scene& scene, const detail::SplittingFrame<Scalar>& f,
                              detail::SplitState<Scalar>& x, Scalar h, const Scalar* w, int n,
                              bool with_loads = true) {
    FlowId ids[4];
    const int m = outer_flows<Scene>(f, ids, with_loads);
    if (m == 0) {  // a free symmetric body: S is exact, and S(a)S(b) = S(a + b)
      detail::flow_symmetric(f, x, h);
      return;
    }
    if (m == 1 && ids[0] == asymmetric_flow && f.exact_free) {  // a free asymmetric body: exact [F8]
      detail::flow_exact_free(f, x, h);
      return;
    }
    if constexpr (detail::splitting_effects_of<Scene>::has_kick) {
      if (m == 1 && ids[0] == kick_flow) {  // the symmetric heavy top: K S K S … K
        detail::flow_kick(scene, f, x, w[0] * h / 2);
        for (int i = 0; i < n; ++i) {
          detail::flow_symmetric(f, x, w[i] * h);
          detail::flow_kick(scene, f, x, (i + 1 < n ? w[i] + w[i + 1] : w[i]) * h / 2);
        }
        return;
      }
    }
    for (int k = 0; k < m; ++k) apply(ids[k], scene, f, x, w[0] * h / 2);
    for (int i = 0; i < n; ++i) {
      if (wheels_on_exact_free(f))
        detail::flow_exact_free(f, x, w[i] * h);  // [W14]: the hub's exact free flow at the core
      else
        detail::flow_symmetric(f, x, w[i] * h);
      for (int k = m - 1; k >= 1; --k) apply(ids[k], scene, f, x, w[i] * h / 2);
      if (i + 1 < n) {
        apply(ids[0], scene, f, x, (w[i] + w[i + 1]) * h / 2);
        for (int k = 1; k < m; ++k) apply(ids[k], scene, f, x, w[i + 1] * h / 2);
      } else {
        apply(ids[0], scene, f, x, w[i] * h / 2);
      }
    }
  }

  /// Chin's free flow T(τ): S exact for a symmetric body without rotor, else Suzuki's
  /// composition of the free Strang step (order 4, which keeps Chin at order 4, [S7]).
  template <class Scene, class Scalar>
  static void free_flow(const Scene& scene, const detail::SplittingFrame<Scalar>& f, detail::SplitState<Scalar>& x,
                        Scalar tau) {
    if (f.free_flow_exact()) {
      detail::flow_symmetric(f, x, tau);
    } else if (f.exact_free) {  // asymmetric, no rotor: the Euler–Poinsot flow [F1]–[F7]
      detail::flow_exact_free(f, x, tau);
    } else {
      const auto c = CompositionCoefficients<Scalar>::of(Composition::suzuki5);
      composed_strang<Scene>(scene, f, x, tau, c.gamma.data(), c.stages, false);
    }
  }

  /// Π_j Chin4A(g_j h), Chin4A(τ) = V(τ/6) T(τ/2) Ṽ(2τ/3) T(τ/2) V(τ/6) [S7], the end kicks
  /// of adjacent sub-steps merged.
  template <class Scene, class Scalar>
  static void chin(const Scene& scene, const detail::SplittingFrame<Scalar>& f, detail::SplitState<Scalar>& x,
                   Scalar h, const Scalar* g, int n) {
    if constexpr (Scene::has_potential) detail::flow_kick(scene, f, x, g[0] * h / 6);
    for (int j = 0; j < n; ++j) {
      const Scalar tau = g[j] * h;
      free_flow<Scene>(scene, f, x, tau / 2);
      if constexpr (Scene::has_potential) detail::flow_chin_kick(scene, f, x, Scalar(2) * tau / 3, tau);
      free_flow<Scene>(scene, f, x, tau / 2);
      if constexpr (Scene::has_potential)
        detail::flow_kick(scene, f, x, (j + 1 < n ? g[j] + g[j + 1] : g[j]) * h / 6);
    }
  }

  /// A corrected near-integrable composition [F8] on the exact free flow T: SABA_nC is
  /// C A(c₁h) B(d₁h) A(c₂h) … A(c₁h) C, SBAB_nC is (B(d₁h) C) A(c₂h) B(d₂h) … A(c₂h) (B(d₁h) C)
  /// with C the corrector Π += g h³ KᵀJ⁻¹τ (merged into SBAB's end kicks: same Λ).
  template <class Scene, class Scalar>
  static void near_integrable(const Scene& scene, const detail::SplittingFrame<Scalar>& f,
                              detail::SplitState<Scalar>& x, Scalar h, const detail::NearIntegrable& c) {
    if constexpr (!Scene::has_potential) {  // torque-free: the exact flow itself
      free_flow<Scene>(scene, f, x, h);
    } else {
      const Scalar h3g = Scalar(c.g) * h * h * h;
      const Scalar d0 = Scalar(c.d[0]) * h;
      near_integrable_sequence(
          c, h, [&](Scalar tau) { free_flow<Scene>(scene, f, x, tau); },
          [&](Scalar tau) { detail::flow_kick(scene, f, x, tau); },
          [&] {
            if (c.kick_first) detail::flow_gradient_kick(scene, f, x, d0, h3g / d0, true);
            else detail::flow_gradient_kick(scene, f, x, Scalar(0), h3g, false);
          });
    }
  }

  /// [W18] The near-integrable composition with wheels: A the hub's exact free flow ([F1]–[F7],
  /// or S on a symmetric hub; the split clock advances in it), B the wheels' rotor flow at the
  /// split clock with the loads' flows around it, X_1(τ/2) … X_m(τ) … X_1(τ/2) (outer_flows:
  /// damping, kicks, then the rotor innermost); no corrector (SBAB's end pieces are its first
  /// and last B).
  template <class Scene, class Scalar>
  static void near_integrable_wheels(const Scene& scene, const detail::SplittingFrame<Scalar>& f,
                                     detail::SplitState<Scalar>& x, Scalar h, const detail::NearIntegrable& c) {
    FlowId ids[4];
    const int m = outer_flows<Scene>(f, ids, true);  // with wheels: no A flow, the rotor last
    auto perturbation = [&](Scalar tau) {
      for (int k = 0; k + 1 < m; ++k) apply(ids[k], scene, f, x, tau / 2);
      apply(ids[m - 1], scene, f, x, tau);
      for (int k = m - 2; k >= 0; --k) apply(ids[k], scene, f, x, tau / 2);
    };
    const Scalar d0 = Scalar(c.d[0]) * h;
    near_integrable_sequence(
        c, h,
        [&](Scalar tau) {
          if (f.exact_free) detail::flow_exact_free(f, x, tau);
          else detail::flow_symmetric(f, x, tau);
        },
        perturbation,
        [&] {
          if (c.kick_first) perturbation(d0);
        });
  }

  /// The sequence of a near-integrable composition [F8]: SABA_n is E A(c₁h) B(d₁h) A(c₂h) …
  /// B(d₁h) A(c₁h) E (n + 1 drifts A, n kicks B), SBAB_n is E A(c₂h) B(d₂h) … A(c₂h) E (n drifts,
  /// the n − 1 inner kicks), with E the end piece: SABA's corrector, SBAB's end kick (with its
  /// corrector). The fractions are palindromic: c[], d[] hold the first half.
  template <class Scalar, class Drift, class Kick, class End>
  static void near_integrable_sequence(const detail::NearIntegrable& c, Scalar h, Drift drift, Kick kick, End end) {
    const int nf = c.n_free;
    const int nk = c.kick_first ? nf + 1 : nf - 1;  // kicks in the step, the end ones included
    const int c0 = c.kick_first ? 1 : 0;            // SBAB's drift fractions start at c[1]
    end();
    for (int i = 0; i < nf; ++i) {
      drift(Scalar(c.c[c0 + (i < (nf + 1) / 2 ? i : nf - 1 - i)]) * h);
      const int k = c.kick_first ? i + 1 : i;  // the kick after this drift
      if (k < (c.kick_first ? nk - 1 : nk)) kick(Scalar(c.d[k < (nk + 1) / 2 ? k : nk - 1 - k]) * h);
    }
    end();
  }
};

/// The spin-exact splitting; H bounded without drift, μ and π exact.
using Splitting = SplittingScheme<false>;
/// The spin-exact splitting with the π-keeping energy projection [S12]: H exact too.
using SplittingProjected = SplittingScheme<true>;

}  // namespace trompo
