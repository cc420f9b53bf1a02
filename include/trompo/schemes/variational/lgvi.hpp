#pragma once
// The Lie group variational integrator (LGVI) of Lee, Leok & McClamroch (2005, 2007),
// docs/theory.md §19 [V1]–[V6]: the discrete Hamilton principle on SO(3) with the
// discrete Lagrangian
//   L_d(Λ_n, Λ_{n+1}) = (1/h) tr[(I − F_n) J_d] − (h/2)(V(Λ_n) + V(Λ_{n+1})),
//   F_n = Λ_nᵀ Λ_{n+1},  J_d = ½ tr(J) I − J                                          [V1]
// whose discrete Euler–Lagrange equations, with the applied torques entered by the
// discrete Lagrange–d'Alembert principle at the mid configuration, read
//   vee(F J_d − J_d Fᵀ) = a(θ) JΘ + b(θ) Θ × JΘ
//                       = h Π_n + (h²/2)(τ_c(Λ_n) + τ_a,m)                          [V2]
//   Λ_{n+1} = Λ_n F,   F = exp(Θ̂)                                                  [V3]
//   Π_{n+1} = Fᵀ (Π_n + (h/2) τ_c(Λ_n) + h τ_a,m + (h/2) τ_c(Λ_{n+1}))             [V4]
// (torques in the body frame of step n; a = sin θ/θ, b = (1 − cos θ)/θ²), Π = JΩ.
// [V2] is solved by Newton in Θ with the tangent [V5]
//   K = (tr(F J_d) I − F J_d) F T(Θ)  − (h²/2) ∂τ_a,m/∂Θ,
// which tends to J as h → 0: the conservative torques enter [V2] at Λ_n only, so no
// potential Jacobian is needed, and [V4] is explicit. The branch rule (NewtonOptions)
// takes the root with det K > 0, which ends at the fold det K = 0 ([V6]: for a spin
// about a principal axis sin θ = h|Ω|, no root beyond h|Ω| = 1, the continued one below
// θ = π/2).
//
// Symplectic and symmetric (L_d(Λ_n, Λ_{n+1}; h) = −L_d(Λ_{n+1}, Λ_n; −h)); order 2;
// π exact on the free body and μ = γ·π under potentials symmetric about γ (discrete
// Noether: L_d is invariant under Λ ↦ R Λ for R about γ); on the free body the map is
// the discrete Moser–Veselov algorithm, which also keeps H exactly; under a potential H
// is not exact but bounded (a modified energy is kept to O(h^N) over exponentially long
// times).
//
// Scenes: the free body, potentials (uniform gravity, general V, the gravity gradient with
// t frozen at the mid time as the other implicit schemes do), applied torques, and rotors
// of constant momentum h_r (the gyrostat): their gyroscopic term Ω·h_r enters L_d as
// h_r·vee(F − Fᵀ)/2, which adds (h/2)(tr F I − Fᵀ)h_r − h h_r to [V2] and keeps π = ΛΠ,
// Π = JΩ + h_r, exact. Reaction wheels ([W1]–[W2], docs/theory.md [V13]): the same
// gyrostat term with the wheels' momentum at the mid time, h_m = h_r + h_w(t_{n+½}) (the
// Lagrangian ½Ω·J_hubΩ + Ω·h_w(t) of a prescribed h_w(t) gives [W1], ḣ_w included), Π_n =
// J_hubΩ_n + h_r + h_w(t_n) the total momentum, Π_{n+1} = Fᵀ(Π_n + kick) by [V4] and Ω_{n+1}
// from Π_{n+1} − h_w(t_{n+1}): π = ΛΠ is kept whatever the motors do (ΛF·FᵀΠ = ΛΠ), the map
// stays symmetric (h_w read at the step's mid time), order 2.
#include <Eigen/Core>
#include <cmath>

#include "trompo/lie/so3.hpp"
#include "trompo/model/body.hpp"
#include "trompo/model/state.hpp"
#include "trompo/schemes/history.hpp"
#include "trompo/schemes/implicit_step.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/schemes/state_residue.hpp"
#include "trompo/schemes/step_data.hpp"
#include "trompo/solvers/newton.hpp"

namespace trompo {

namespace detail {

/// The LGVI's implicit equation [V2] and its tangent [V5] as a function of the increment Θ
/// (body frame of step n), for detail::newton.
template <class Scene>
class LgviResidual {
 public:
  /// The floating-point type.
  using Scalar = typename Scene::Scalar;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;

  /// At the step's data d from time t_n; `tau_n` the conservative torque at Λ_n (frame n,
  /// zero without).
  LgviResidual(const StepData<Scene>& d, Scalar t_n, const Vector3& tau_n)
      : d_(d), h_m_(rotor_at_mid(d, t_n)), rhs_(right_side(d, tau_n)), rhs_norm_(rhs_.norm()) {}

  /// Some rotor enters [V2]: a constant one (the gyrostat) or wheels [V13].
  static constexpr bool has_rotor_term = Scene::has_rotor || Scene::has_wheels;

  /// R(Θ) = a JΘ + b Θ × JΘ − h Π_n − (h²/2)(τ_c,n + τ_a,m) [V2]; with K, the tangent [V5].
  bool operator()(const Vector3& Theta, Vector3& R, Matrix3* K, Scalar& scale) const {
    using G = SO3<Scalar>;
    const Scene& scene = d_.scene;
    const Scalar h = d_.h;
    const Matrix3& J = scene.body().inertia();
    const HalfAngle<Scalar> ha = half_angle_from_squared(Theta.squaredNorm());
    const Scalar a = ha.sinc();                   // sin θ/θ
    const Scalar b = ha.one_minus_cos_over_sq();  // (1 − cos θ)/θ²
    const Vector3 JTheta = scene.body().momentum(Theta);  // JΘ (three products for a diagonal J)
    // vee(F J_d − J_d Fᵀ) = a JΘ + b Θ × JΘ  [V2]
    R = a * JTheta + b * Theta.cross(JTheta) - rhs_;
    scale = rhs_norm_ + JTheta.norm();
    [[maybe_unused]] Vector3 Ft_hr;  // Fᵀh_r
    if constexpr (has_rotor_term) {
      // The rotor's term [V1]/[V2]: (h/2)(tr F I − Fᵀ)h_r − h h_r, i.e. with tr F = 3 − 2bθ²
      // and Fᵀx = x − aΘ×x + bΘ×(Θ×x), (h/2)(aΘ×h_r − b(2θ²h_r + Θ×(Θ×h_r))): small terms
      // only (the h h_r of hΠ_n is taken out of rhs_ instead of cancelled here). With wheels
      // h_r is h_m, their momentum at the mid time [V13].
      const Vector3& h_r = h_m_;
      const Vector3 c = Theta.cross(h_r);
      R += (h / Scalar(2)) * (a * c - b * (Scalar(2) * Theta.squaredNorm() * h_r + Theta.cross(c)));
      Ft_hr = h_r - a * c + b * Theta.cross(c);
      scale += std::abs(h) * h_r.norm();
    }
    if (K) {
      const Matrix3 F = G::rodrigues(Theta, a, b);
      const Matrix3 J_d = Scalar(0.5) * J.trace() * Matrix3::Identity() - J;
      // ∂/∂Θ of vee(F J_d − J_d Fᵀ) along F exp((T(Θ)δ)^): (tr(F J_d) I − F J_d) F T(Θ)  [V5]
      const Matrix3 FJ_d = F * J_d;
      const Matrix3 T = G::right_tangent(Theta);
      *K = (FJ_d.trace() * Matrix3::Identity() - FJ_d) * F * T;
      // the rotor's: δ[(tr F I − Fᵀ)h_r] = (−2a h_r Θᵀ − (Fᵀh_r)^) η, η = T(Θ)δΘ  [V5]
      if constexpr (has_rotor_term)
        *K += (h / Scalar(2)) * (Scalar(-2) * a * h_m_ * Theta.transpose() - G::hat(Ft_hr)) * T;
    }
    if constexpr (Scene::has_applied_torque) {
      // τ_a at Λ_{n+½} = Λ_n exp(Θ̂/2), Ω_m = Θ/h (docs/theory.md §5), half of its impulse
      // at each end [V2]/[V4]; ∂/∂Θ through w = ½T(Θ/2)δΘ and Ω_m.
      const Vector3 half = Theta / Scalar(2);
      Matrix3 d_rot, d_omega;
      const Vector3 tau = applied_at_mid(Theta, ha, K ? &d_rot : nullptr, K ? &d_omega : nullptr);
      R -= (h * h / Scalar(2)) * tau;
      if (K) *K -= (h * h / Scalar(2)) * (Scalar(0.5) * d_rot * G::right_tangent(half) + d_omega / h);
      scale += Scalar(0.5) * h * h * tau.norm();
    }
    return true;
  }

  /// h_m = h_r + h_w(t_{n+½}): the constant rotors' momentum and the wheels' at the step's
  /// mid time (zero without either) [V13].
  static Vector3 rotor_at_mid(const StepData<Scene>& d, Scalar t_n) {
    Vector3 h = Vector3::Zero();
    if constexpr (Scene::has_rotor) h += d.scene.rotor_momentum();
    if constexpr (Scene::has_wheels) h += d.scene.wheel_momentum(t_n + d.h / Scalar(2));
    return h;
  }
  /// h JΩ_n + (h²/2) τ_c(Λ_n), and with wheels + h(h_w(t_n) − h_w(t_{n+½})) = −(h/2) Δh_w:
  /// hΠ_n less the h h_m that the rotor term of [V2] takes out [V13].
  static Vector3 right_side(const StepData<Scene>& d, const Vector3& tau_n) {
    Vector3 rhs = d.h * (d.scene.body().momentum(d.omega_n) + (d.h / Scalar(2)) * tau_n);
    if constexpr (Scene::has_wheels) rhs -= (d.h / Scalar(2)) * d.dh_w;
    return rhs;
  }

  /// τ_a,m: the applied torques at the mid configuration Λ_n exp(Θ̂/2) and Ω_m = Θ/h
  /// (frame n), with their Jacobians if asked.
  Vector3 applied_at_mid(const Vector3& Theta, const HalfAngle<Scalar>& ha, Matrix3* d_rot = nullptr,
                         Matrix3* d_omega = nullptr) const {
    const Matrix3 R_half = SO3<Scalar>::rodrigues(Theta / Scalar(2), ha.kappa, ha.half_one_minus_cos_over_sq());
    return d_.scene.applied_torque(d_.caches, R_half, Theta / d_.h, d_rot, d_omega);
  }

 private:
  const StepData<Scene>& d_;
  Vector3 h_m_;  ///< h_r + h_w(t_{n+½}) (zero without rotors or wheels)
  Vector3 rhs_;  ///< h JΩ_n + (h²/2) τ_c(Λ_n) (h Π_n less the rotor's h h_m)
  Scalar rhs_norm_;
};

/// J⁻¹v (three products for a diagonal J).
template <class Scalar>
Eigen::Matrix<Scalar, 3, 1> inverse_inertia_times(const RigidBody<Scalar>& body, const Eigen::Matrix<Scalar, 3, 1>& v) {
  if (body.is_diagonal()) return body.inertia_inverse().diagonal().cwiseProduct(v);
  return body.inertia_inverse() * v;
}

/// An LGVI step as the problem of detail::implicit_step: Newton's unknown is Θ itself,
/// the history extrapolates Θ ([P1]–[P3] of docs/theory.md §13, as for Simo-κ).
template <class Scene>
class LgviProblem {
 public:
  /// The floating-point type.
  using Scalar = typename Scene::Scalar;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;

  /// At the step's data d from the state `in`; `residue`: the compensated state's residue at
  /// the start (null: not compensated).
  LgviProblem(const StepData<Scene>& d, const State<Scalar>& in, const StateResidue<Scalar>* residue = nullptr)
      : d_(d), in_(in), tau_n_(start_torque(d)), residual_(d, in.time, tau_n_), residue_(residue) {}

  /// [V2] and [V5].
  const LgviResidual<Scene>& residual() const { return residual_; }
  /// [P1]: Θ⁰ the extrapolated increment.
  ImplicitStart<Scalar> from_history(const Vector3& Theta0) const { return {Theta0, Theta0, Scalar(Theta0.norm())}; }
  /// Θ⁰ = hΩ_n + (h²/2)Ω̇_n: [V2] to O(h³).
  ImplicitStart<Scalar> memoryless() const { return from_history(d_.predicted_increment()); }
  /// The root is Θ.
  ImplicitRoot<Scalar> root(const Vector3& Theta) const { return {Theta, Scalar(Theta.norm())}; }
  /// The fold rule [V6]: K → J as h → 0 (either sign of h), so det K > 0 on the continued root.
  Scalar orientation(const Matrix3& K) const { return K.determinant(); }
  /// The same from K⁻¹ (det K⁻¹ has the sign of det K).
  Scalar orientation_inverse(const Matrix3& K_inv) const { return K_inv.determinant(); }
  /// [V3]–[V4] from the root Θ.
  void advance(const Vector3& Theta, State<Scalar>& out) const {
    const Scene& scene = d_.scene;
    const Scalar h = d_.h;
    const HalfAngle<Scalar> ha = half_angle_from_squared(Theta.squaredNorm());
    const Scalar a = ha.sinc(), b = ha.one_minus_cos_over_sq();
    // [V4] in frame n: impulse = Π_n + kick, kick = (h/2)(τ_c(Λ_n) + τ_c(Λ_{n+1})) + hτ_a,m;
    // then turned into frame n+1 by Fᵀ.
    Vector3 kick = Vector3::Zero();
    if constexpr (Scene::has_potential)  // τ_c at Λ_n and Λ_{n+1} = Λ_n F
      kick += (h / Scalar(2)) * (tau_n_ + scene.conservative_torque_rodrigues(d_.caches, Theta, a, b));
    if constexpr (Scene::has_applied_torque) kick += h * residual_.applied_at_mid(Theta, ha);
    const Vector3 impulse = d_.Pi_n + kick;
    out.rotation = in_.rotation.times_exp(Theta, ha);  // [V3]
    // Π_{n+1} − Π_n = kick − aΘ × impulse + bΘ × (Θ × impulse)  (Fᵀx = x − aΘ×x + bΘ×(Θ×x)),
    // and Ω_{n+1} = Ω_n + J⁻¹(Π_{n+1} − Π_n): every term small, so the rounding of the
    // large parts (Fᵀ as a matrix, Ω = J⁻¹Π with a rounded J⁻¹) does not repeat itself from
    // step to step. Written as Π_{n+1} = Fᵀ·impulse, Ω = J⁻¹Π_{n+1}, |π| drifted like N·ε
    // while Θ is nearly steady (measured after 10⁶ steps on FB1: −2.7e-12 with Fᵀ as a
    // matrix, +3.2e-12 with these small terms but Ω from Π; 3.3e-14 now, Simo-κ's 3.5e-14).
    const Vector3 c1 = Theta.cross(impulse);
    Vector3 dPi = kick - a * c1 + b * Theta.cross(c1);
    // With wheels Π = J_hubΩ + h_r + h_w(t): Ω's change is J_hub⁻¹(ΔΠ − Δh_w) [V13].
    if constexpr (Scene::has_wheels) dPi -= d_.dh_w;
    if (residue_) {
      // Compensated (docs/theory.md §18, [K2]–[K3]): the increments J⁻¹ΔΠ and Θ added to the
      // state plus the residue the last step left, the new rounding kept in next_residue_.
      // [V2]–[V4] read Ω_n and Λ_n alone: every term that depends on them is of size hΩ.
      residue_->advance(in_, inverse_inertia_times(scene.body(), dPi), Theta, ha, h, out, next_residue_);
      return;
    }
    out.omega = in_.omega + inverse_inertia_times(scene.body(), dPi);
    out.time = in_.time + h;
  }
  /// The residue of advance()'s result (compensated steps only).
  const StateResidue<Scalar>& next_residue() const { return next_residue_; }
  /// The history records Θ.
  Vector3 recorded(const Vector3& Theta) const { return Theta; }

 private:
  /// τ_c(Λ_n) in frame n (zero without a potential).
  static Vector3 start_torque(const StepData<Scene>& d) {
    if constexpr (Scene::has_potential) return d.scene.conservative_torque(d.caches, Matrix3::Identity());
    else return Vector3::Zero();
  }

  const StepData<Scene>& d_;
  const State<Scalar>& in_;
  Vector3 tau_n_;                  ///< τ_c(Λ_n), frame n
  LgviResidual<Scene> residual_;  ///< [V2]
  const StateResidue<Scalar>* residue_;        ///< the start's residue (null: not compensated)
  mutable StateResidue<Scalar> next_residue_;  ///< the result's, written by advance()
};

}  // namespace detail

/// The Lie group variational integrator of Lee, Leok & McClamroch [V1]–[V6]: symplectic,
/// symmetric, order 2; π exact without external torque, μ under symmetric potentials; H
/// bounded (exact on the free body).
struct LGVI {
  /// "lgvi".
  static constexpr const char* name = "lgvi";
  /// Order 2; symmetric (composable to orders 4 and 6); keeps μ (wherever the scene's flow
  /// does), π without external torque (the free body, the gyrostat), and H on the free body
  /// (the map is then the DMV's, which keeps both integrals); H is otherwise not exact but
  /// bounded. Its memory, the history predictor's (as Simo-κ's), is only a hint: a plain
  /// State may be stepped; the step writes it only on success. Carries wheels (π kept) [V13].
  static constexpr SchemeTraits traits{
      .order = 2,
      .symmetric = true,
      .keeps =
          [](SceneKind s) {
            return Keeps{.energy = s.is_free,
                         .momentum_map = true,
                         .spatial_momentum = !s.has_potential && !s.has_applied_torque};
          },
      .carries_wheels = true,
      .memory = MemoryUse::hint,
      .writes_memory_on_success = true};

  /// Whether the steps of a Trajectory start from the history predictor and the carried
  /// tangent (schemes/history.hpp, docs/theory.md §13 [P1]–[P3]). Off: every step is solved
  /// from Θ⁰ = hΩ_n + (h²/2)Ω̇_n. Either way the step's acceptance, hence the map, is the same.
  bool history_predictor = true;
  /// Whether a Trajectory's state is compensated (docs/theory.md §18): its rounding residue
  /// is carried in the memory, so that π (and μ) stay within a few ε of their start over any
  /// number of steps instead of walking like √N·ε (FB1, 10⁶ steps of h = 0.01: 4.8e-14 → see
  /// docs/families.md). A plain State stepped alone starts from a zero residue each step.
  /// Off by default, as for Simo-κ.
  bool compensated = false;
  /// The last increments and tangent, and the state's residue (CompensatedMemory), per
  /// trajectory.
  template <class Scene>
  using Memory = CompensatedMemory<typename Scene::Scalar>;

  /// One step: Newton on [V2] from the history's extrapolation (or Θ⁰), the branch rule
  /// [V6], then [V3]–[V4], by the implicit-step sequence of implicit_step.hpp (wheels by
  /// [V13]).
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h,
                                          const NewtonOptions<typename Scene::Scalar>& options,
                                          State<typename Scene::Scalar>& out, Memory<Scene>& memory) const {
    const detail::StepData<Scene> d(scene, in, h);
    const detail::LgviProblem<Scene> problem(d, in, compensated ? &memory.residue : nullptr);
    const StepReport<typename Scene::Scalar> rep =
        detail::implicit_step(problem, options, h, out, history_predictor ? &memory : nullptr);
    if (rep.ok() && compensated) memory.residue = problem.next_residue();  // written on success only
    return rep;
  }
};

}  // namespace trompo
