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
  kahan_li_9         ///< order 6: Kahan–Li's composition of Strang, kicks merged
};

/// The CLI name of a splitting method ("strang", "chin-4a", …).
inline const char* to_string(SplittingMethod m) {
  switch (m) {
    case SplittingMethod::strang: return "strang";
    case SplittingMethod::chin_4a: return "chin-4a";
    case SplittingMethod::chin_triple_jump: return "chin-triple-jump";
    case SplittingMethod::suzuki_5: return "suzuki-5";
    case SplittingMethod::kahan_li_9: return "kahan-li-9";
  }
  return "unknown";
}

/// The order of a splitting method: 2, 4 or 6.
constexpr int order_of(SplittingMethod m) {
  switch (m) {
    case SplittingMethod::strang: return 2;
    case SplittingMethod::chin_4a:
    case SplittingMethod::suzuki_5: return 4;
    case SplittingMethod::chin_triple_jump:
    case SplittingMethod::kahan_li_9: return 6;
  }
  return 2;
}

/// Chin's methods: they need a scene whose effects are potentials and rotors only.
constexpr bool is_chin(SplittingMethod m) {
  return m == SplittingMethod::chin_4a || m == SplittingMethod::chin_triple_jump;
}

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
  /// band). Its memory (the working frame, the first energy) is part of the trajectory.
  static constexpr SchemeTraits traits{
      .order = 2,
      .symmetric = !EnergyProjection,
      .keeps =
          [](SceneKind s) {
            return Keeps{.energy = EnergyProjection,
                         .momentum_map = true,
                         .spatial_momentum = !s.has_potential && !s.has_applied_torque};
          },
      .keeps_jacobi_integral = EnergyProjection,
      .memory = MemoryUse::carried,
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

  /// Throws invalid_input if the method is not offered on this scene (a Chin method with an
  /// applied torque or damping, whose force-gradient term [S7] does not apply).
  template <class Scene>
  void check(const Scene&) const {
    if (is_chin(method) && !detail::splitting_effects_of<Scene>::conservative)
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
    const bool chin = detail::splitting_effects_of<Scene>::conservative && frame.free_flow_exact();
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
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    StepReport<Scalar> rep;
    if (is_chin(method) && !Effects::conservative) {
      rep.status = StepStatus::invalid_step;  // check() says why
      return rep;
    }
    const bool fresh = !memory.ready;
    if (fresh) memory = detail::SplittingFrame<Scalar>::of(scene).compact();
    const detail::SplittingFrame<Scalar> f = detail::SplittingFrame<Scalar>::expand(memory);

    // To the working frame: Λ_w = Λ Q, Ω_w = Qᵀ Ω, Π_w = J Ω_w + h_r.
    detail::SplitState<Scalar> x;
    x.q = f.identity ? in.rotation.unit_quaternion() : in.rotation.unit_quaternion() * f.Q;
    const Vector3 omega_w = f.identity ? in.omega : Vector3(f.Qt * in.omega);
    x.P = f.J.cwiseProduct(omega_w);
    if constexpr (Scene::has_rotor) x.P += f.h_r;
    x.t = in.time;
    // The projection aims at the trajectory's first energy (kept in the memory), not at
    // each step's: the one-update residuals (~ε) then do not accumulate as a random walk.
    if constexpr (EnergyProjection)
      if (fresh) memory.energy = detail::working_energy(scene, f, x);

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
    }
    if constexpr (EnergyProjection) detail::project_energy(scene, f, x, memory.energy);

    if (!detail::all_finite(x.q.coeffs()) || !detail::all_finite(x.P) || !(x.q.coeffs().cwiseAbs().maxCoeff() > 0)) {
      rep.status = StepStatus::non_finite;
      return rep;
    }
    // Back to the user's frame: Λ = Λ_w Qᵀ, Ω = Q J⁻¹(Π_w − h_r).
    const Eigen::Quaternion<Scalar> q = f.identity ? x.q : x.q * f.Q.conjugate();
    out.rotation = SO3<Scalar>::renormalized(q);
    Vector3 m = x.P;
    if constexpr (Scene::has_rotor) m -= f.h_r;
    // Divided, not multiplied by the rounded 1/J: a rounded reciprocal biases every step the
    // same way (π would drift like N·ε, as in [S5]).
    const Vector3 omega = m.cwiseQuotient(f.J);
    out.omega = f.identity ? omega : Vector3(f.Qm * omega);
    out.time = in.time + h;
    return rep;
  }

 private:
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
    if constexpr (Scene::has_rotor)
      if (f.rotor_rate > Scalar(0)) ids[m++] = rotor_flow;
    if (f.k_b != Scalar(0)) ids[m++] = asymmetric_flow;
    return m;
  }

  template <class Scene, class Scalar>
  static void apply(FlowId id, const Scene& scene, const detail::SplittingFrame<Scalar>& f,
                    detail::SplitState<Scalar>& x, Scalar t) {
    using Effects = detail::splitting_effects_of<Scene>;
    switch (id) {
      case damping_flow:
        if constexpr (Effects::has_damping) detail::flow_damping(f, x, t);
        break;
      case kick_flow:
        if constexpr (Effects::has_kick) detail::flow_kick(scene, f, x, t);
        break;
      case rotor_flow:
        if constexpr (Scene::has_rotor) detail::flow_rotor(f, x, t);
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
};

/// The spin-exact splitting; H bounded without drift, μ and π exact.
using Splitting = SplittingScheme<false>;
/// The spin-exact splitting with the π-keeping energy projection [S12]: H exact too.
using SplittingProjected = SplittingScheme<true>;

}  // namespace trompo
