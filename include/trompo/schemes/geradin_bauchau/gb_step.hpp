#pragma once
// Géradin–Bauchau's shared machinery, eqs. (37)–(44), restated as [T4] and [T5].
// The schemes are schemes/geradin_bauchau.hpp ([T4]) and schemes/geradin_bauchau_paper.hpp
// ([T5]); each picks its GBForm.
//
// Unknown: e, the vector part of the unit quaternion of the increment Λ_nᵀΛ_{n+1} = F²,
// e = n sin(Δφ/2), e0 = cos(Δφ/2) = √(1 − |e|²) ≥ 0 (so |Δφ| < π: a step that needs
// more fails with out_of_domain). F = e0 I + e eᵀ/(1+e0) + ê (40) is the half rotation,
// Λ_{n+½} = Λ_n F, Ω_m = 2e/h (38), Ω_{n+1} = 4e/h − Ω_n.
//
//   GeradinBauchau       [T4]  R(e) = F Π_{n+1} − Fᵀ Π_n − h τ_m = 0
//                              τ_m: the torques at Λ_{n+½}, in the mid frame.
//                              Exact H, μ, and π when there is no load.
//   GeradinBauchauPaper  [T5]  the printed eq. (44) (JΩ̃_n read as JΩ_n), scaled by h²/8:
//                              R(e) = Je − (h/2)JΩ_n + e × (Je + (h/2)h_r) − (h²/4) τ_m
//                              Exact H, but μ is NOT conserved (docs/theory.md §4): kept to
//                              reproduce the paper.
#include <Eigen/Core>
#include <cmath>
#include <type_traits>

#include "trompo/errors.hpp"
#include "trompo/solvers/newton.hpp"
#include "trompo/schemes/history.hpp"
#include "trompo/schemes/step_data.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"

namespace trompo {
namespace detail {

/// Which residual: the momentum-consistent form [T4] or the paper's printed (44), [T5].
enum class GBForm { momentum_consistent, paper };

/// The half rotation F(e) of (40) and its right Jacobian G = ∂w/∂e, where
/// F(e + δe) = F(e) exp((G δe)^). With sin β = |e| (β = Δφ/2), F = exp(φ̂), φ = β e/|e|,
/// so G = T(φ) ∂φ/∂e with ∂φ/∂e = (1/sinc β) I + (q(β)/(e0 sinc³β)) e eᵀ,
/// q(β) = (sin β − β cos β)/β³ (series below the switch; = −4 κ′(2β)/(2β) exactly).
template <class Scalar>
struct HalfRotation {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  Scalar e0;
  Matrix3 F;
  Matrix3 G;

  /// False when |e| ≥ 1 (no half rotation below π). G only if `with_jacobian`.
  bool set(const Vector3& e, bool with_jacobian = true) {
    using std::asin;
    using std::sqrt;
    const Scalar s2 = e.squaredNorm();
    if (!(s2 < Scalar(1))) return false;
    e0 = sqrt(Scalar(1) - s2);
    const Matrix3 E = SO3<Scalar>::hat(e);
    F = e0 * Matrix3::Identity() + e * e.transpose() / (Scalar(1) + e0) + E;  // (40)
    if (!with_jacobian) return e0 > Scalar(0);
    const Scalar beta = asin(sqrt(s2));
    const Scalar sc = sinc(beta);                              // |e| / β
    const Scalar q = Scalar(-4) * kappa_prime_over_theta(Scalar(2) * beta);
    const Matrix3 dphi = Matrix3::Identity() / sc + (q / (e0 * sc * sc * sc)) * e * e.transpose();
    G = SO3<Scalar>::right_tangent(e / sc) * dphi;
    return e0 > Scalar(0);
  }
};

template <GBForm Form, class Scene>
class GBResidual {
 public:
  using Scalar = typename Scene::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  using G = SO3<Scalar>;
  static constexpr bool paper = Form == GBForm::paper;

  explicit GBResidual(const StepData<Scene>& d) : d_(d) {}

  /// [T4] or [T5] at e = hΩ_n/2 + z. Newton's unknown is z, the departure from the
  /// rigid rotation, so that Ω_{n+1} = 4e/h − Ω_n = Ω_n + 4z/h is a small correction
  /// (see SimoResidual: cancelling two large numbers biases the round-off).
  /// With K null only R and scale (bit-identical to a full evaluation; detail::newton).
  bool operator()(const Vector3& z, Vector3& R, Matrix3* K, Scalar& scale) const {
    const Scene& scene = d_.scene;
    const Scalar h = d_.h;
    const Vector3 e = (h / Scalar(2)) * d_.omega_n + z;
    const Matrix3& J = scene.body().inertia();
    HalfRotation<Scalar> half;
    if (!half.set(e, K != nullptr)) return false;
    const Matrix3& F = half.F;

    if constexpr (!paper) {
      // Ω_{n+1} = 4e/h − Ω_n = Ω_n + 4z/h, so ΔΠ = Π_{n+1} − Π_n = (4/h) J z.
      const Vector3 dPi = scene.body().momentum(Scalar(4) * z / h);
      const Vector3 Pi_next = d_.Pi_n + dPi;
      // [T4] momentum part F Π_{n+1} − Fᵀ Π_n, expanded with (40) so that no rounded
      // entry of F multiplies the large Π itself (see SimoResidual):
      //   e0 ΔΠ + e (e·ΔΠ)/(1+e0) + e × (Π_{n+1} + Π_n).
      // In float this cut GB's energy error on FB1 (2000 steps) from 100ε to 9ε.
      R = half.e0 * dPi + e * (e.dot(dPi) / (Scalar(1) + half.e0)) + e.cross(Pi_next + d_.Pi_n);
      // d(FΠ₁) = (4/h) F J δe − F Π̂₁ G δe;  d(FᵀΠ_n) = (FᵀΠ_n)^ G δe
      if (K) {
        const Vector3 FtPi_n = F.transpose() * d_.Pi_n;
        *K = (Scalar(4) / h) * F * J - (F * G::hat(Pi_next) + G::hat(FtPi_n)) * half.G;
      }
      scale = d_.Pi_n_norm + Pi_next.norm();
    } else {
      const Vector3 Je = J * e;
      Vector3 gyro = Je;
      if constexpr (Scene::has_rotor) gyro += (h / Scalar(2)) * scene.rotor_momentum();
      const Vector3 JOmega_n = scene.body().momentum(d_.omega_n);
      R = Je - (h / Scalar(2)) * JOmega_n + e.cross(gyro);                // [T5] · h²/8
      if (K) *K = J + G::hat(e) * J - G::hat(gyro);
      scale = Je.norm() + std::abs(h) / Scalar(2) * JOmega_n.norm() + e.norm() * gyro.norm();
    }

    if constexpr (Scene::has_potential || Scene::has_applied_torque) {
      // τ_m = Fᵀ τ(Λ_n F) (frame n → mid frame); d(Fᵀτ) = ((Fᵀτ)^ + Fᵀ ∂τ/∂w) G δe.
      Vector3 tau = Vector3::Zero();
      Matrix3 d_rot = Matrix3::Zero();
      Matrix3 d_omega = Matrix3::Zero();
      if constexpr (Scene::has_potential) {
        Matrix3 Jc;
        tau += scene.conservative_torque(d_.caches, F, K ? &Jc : nullptr);
        if (K) d_rot += Jc;
      }
      if constexpr (Scene::has_applied_torque) {
        Matrix3 Jr, Jw;
        tau += scene.applied_torque(d_.caches, F, Scalar(2) * e / h, K ? &Jr : nullptr,
                                    K ? &Jw : nullptr);  // Ω_m = 2e/h
        if (K) {
          d_rot += Jr;
          d_omega += Jw;
        }
      }
      const Vector3 tau_m = F.transpose() * tau;
      const Scalar w = paper ? h * h / Scalar(4) : h;                    // weight in [T5] / [T4]
      R -= w * tau_m;
      if (K) *K -= w * ((G::hat(tau_m) + F.transpose() * d_rot) * half.G + F.transpose() * d_omega * (Scalar(2) / h));
      scale += std::abs(w) * tau_m.norm();
    }
    return true;
  }
  /// Residual and tangent (the full evaluation).
  bool operator()(const Vector3& z, Vector3& R, Matrix3& K, Scalar& scale) const { return (*this)(z, R, &K, scale); }

 private:
  const StepData<Scene>& d_;
};

/// One Géradin–Bauchau step: Newton on [T4] or [T5] from e⁰ ≈ sin(|Θ⁰|/2) Θ⁰/|Θ⁰|,
/// then Λ_{n+1} = Λ_n ⊗ (e0, e), Ω_{n+1} = 4e/h − Ω_n. With `history` (the scheme's
/// memory, null for none) e⁰ is the extrapolation of the last accepted e and the first
/// tangent the carried one, when the history allows ([P1]–[P3], as simo_step); a failed
/// solve from there is retried once from the memoryless start.
template <GBForm Form, class Scene>
StepReport<typename Scene::Scalar> gb_step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                           typename Scene::Scalar h,
                                           const NewtonOptions<typename Scene::Scalar>& opt,
                                           State<typename Scene::Scalar>& out,
                                           IncrementHistory<typename Scene::Scalar>* history = nullptr) {
  using Scalar = typename Scene::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  using std::sin;
  const StepData<Scene> d(scene, in, h);
  const Vector3 base = (h / Scalar(2)) * in.omega;
  Vector3 Theta0, e0, z;
  Matrix3 K, K_inv;
  StepReport<Scalar> rep;
  Vector3 Theta;
  // Branch rule (NewtonOptions): the increment angle Δφ = 2 asin|e|, its distance to Θ⁰,
  // and the fold rule det(K J⁻¹)·h > 0 (K → (4/h)F J as h → 0; [T5]: K → J, h² > 0);
  // det K⁻¹ for the tangent a history solve corrected with last.
  const auto on_branch = [&](bool carried_tangent) {
    const Vector3 e = base + z;
    const Scalar s = e.norm();
    const Scalar dphi = Scalar(2) * std::asin(s);
    Theta = s > Scalar(0) ? Vector3(e * (dphi / s)) : Vector3(Scalar(2) * e);
    // (det J⁻¹ > 0: det K⁻¹ has the sign of det(K J⁻¹).)
    const Scalar orientation = (carried_tangent ? K_inv.determinant() : (K * scene.body().inertia_inverse()).determinant()) *
                               (Form == GBForm::paper ? Scalar(1) : h);
    if (!(dphi < opt.max_increment) || !((Theta - Theta0).norm() <= opt.max_correction) ||
        !(orientation > Scalar(0)))
      rep.status = StepStatus::wrong_branch;
    return rep.ok();
  };
  // [P2]: from the history only when it predicted the last step well (trusted).
  const bool from_history = history && history->trusted(h) && opt.reuse_tangent > Scalar(0);
  bool solved = false;
  Vector3 extrapolated = Vector3::Zero();  // [P1] (from_history only), kept for the history's record
  if (from_history) {
    // [P1] the extrapolated e, [P3] the carried tangent; Θ⁰ (for the branch rule) from e⁰.
    e0 = extrapolated = history->extrapolate();
    if (e0.norm() > Scalar(0.99)) e0 *= Scalar(0.99) / e0.norm();
    const Scalar s0 = e0.norm();
    Theta0 = s0 > Scalar(0) ? Vector3(e0 * (Scalar(2) * std::asin(s0) / s0)) : Vector3(Scalar(2) * e0);
    z = e0 - base;
    K_inv = history->tangent_inverse;
    rep = newton(GBResidual<Form, Scene>(d), z, opt, e0.norm(), &K, &K_inv, true);
    solved = rep.ok() && on_branch(true);
  }
  if (!solved) {
    const StepReport<Scalar> spent = rep;  // the history solve's work, if any
    Theta0 = d.predicted_increment();
    const Scalar theta0 = Theta0.norm();
    // e = n sin(θ/2) = Θ · ½ sinc(θ/2); capped inside the domain |e| < 1.
    e0 = Theta0 * (sinc(theta0 / 2) / 2);
    if (e0.norm() > Scalar(0.99)) e0 *= Scalar(0.99) / e0.norm();
    z = e0 - base;  // Newton's unknown (see GBResidual)
    rep = newton(GBResidual<Form, Scene>(d), z, opt, e0.norm(), &K, &K_inv);
    rep.iterations += spent.iterations;
    rep.evaluations += spent.evaluations;
    rep.tangents += spent.tangents;
    if (!rep.ok() || !on_branch(false)) return rep;
  }
  const Vector3 e = base + z;
  using std::sqrt;
  const Eigen::Quaternion<Scalar> q(sqrt(Scalar(1) - e.squaredNorm()), e.x(), e.y(), e.z());  // F²
  out.rotation = in.rotation * SO3<Scalar>::renormalized(q);
  out.omega = in.omega + Scalar(4) * z / h;                    // Ω_{n+1} = 4e/h − Ω_n (38)
  out.time = in.time + h;
  // The step's one check of its result (the Stepper leaves it to the scheme:
  // writes_memory_on_success, scheme.hpp), before the memory is written.
  if (!committable(out)) rep.status = StepStatus::non_finite;
  if (rep.ok() && history) history->record(e, h, K_inv, from_history ? &extrapolated : nullptr);
  return rep;
}

}  // namespace detail
}  // namespace trompo
