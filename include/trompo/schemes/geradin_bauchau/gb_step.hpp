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
#include "trompo/schemes/implicit_step.hpp"
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

/// A Géradin–Bauchau step as the problem of detail::implicit_step: Newton's unknown is
/// z = e − hΩ_n/2 (see GBResidual), the history extrapolates e.
template <GBForm Form, class Scene>
class GBProblem {
 public:
  using Scalar = typename Scene::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;

  GBProblem(const StepData<Scene>& d, const State<Scalar>& in)
      : d_(d), in_(in), base_((d.h / Scalar(2)) * in.omega) {}

  /// [T4] or [T5] and its tangent.
  GBResidual<Form, Scene> residual() const { return GBResidual<Form, Scene>(d_); }
  /// [P1]: e⁰ the extrapolated e (capped inside the domain |e| < 1); Θ⁰ from it.
  ImplicitStart<Scalar> from_history(const Vector3& extrapolated) const {
    Vector3 e0 = extrapolated;
    if (e0.norm() > Scalar(0.99)) e0 *= Scalar(0.99) / e0.norm();
    const Scalar s0 = e0.norm();
    const Vector3 Theta0 = s0 > Scalar(0) ? Vector3(e0 * (Scalar(2) * std::asin(s0) / s0)) : Vector3(Scalar(2) * e0);
    return {e0 - base_, Theta0, e0.norm()};
  }
  /// e⁰ ≈ sin(|Θ⁰|/2) Θ⁰/|Θ⁰| from the predicted Θ⁰ = hΩ_n + (h²/2)Ω̇_n.
  ImplicitStart<Scalar> memoryless() const {
    const Vector3 Theta0 = d_.predicted_increment();
    const Scalar theta0 = Theta0.norm();
    // e = n sin(θ/2) = Θ · ½ sinc(θ/2); capped inside the domain |e| < 1.
    Vector3 e0 = Theta0 * (sinc(theta0 / 2) / 2);
    if (e0.norm() > Scalar(0.99)) e0 *= Scalar(0.99) / e0.norm();
    return {e0 - base_, Theta0, e0.norm()};
  }
  /// The increment angle Δφ = 2 asin|e| and Θ = Δφ e/|e|.
  ImplicitRoot<Scalar> root(const Vector3& z) const {
    const Vector3 e = base_ + z;
    const Scalar s = e.norm();
    const Scalar dphi = Scalar(2) * std::asin(s);
    return {s > Scalar(0) ? Vector3(e * (dphi / s)) : Vector3(Scalar(2) * e), dphi};
  }
  /// The fold rule det(K J⁻¹)·h > 0 (K → (4/h)F J as h → 0; [T5]: K → J, h² > 0).
  Scalar orientation(const Matrix3& K) const {
    return (K * d_.scene.body().inertia_inverse()).determinant() * weight();
  }
  /// The same from K⁻¹ (det J⁻¹ > 0: det K⁻¹ has the sign of det(K J⁻¹)).
  Scalar orientation_inverse(const Matrix3& K_inv) const { return K_inv.determinant() * weight(); }
  /// Λ_{n+1} = Λ_n ⊗ (e0, e), Ω_{n+1} = 4e/h − Ω_n from the root z.
  void advance(const Vector3& z, State<Scalar>& out) const {
    using std::sqrt;
    const Scalar h = d_.h;
    const Vector3 e = base_ + z;
    const Eigen::Quaternion<Scalar> q(sqrt(Scalar(1) - e.squaredNorm()), e.x(), e.y(), e.z());  // F²
    out.rotation = in_.rotation * SO3<Scalar>::renormalized(q);
    out.omega = in_.omega + Scalar(4) * z / h;                    // Ω_{n+1} = 4e/h − Ω_n (38)
    out.time = in_.time + h;
  }
  /// The history records e.
  Vector3 recorded(const Vector3& z) const { return base_ + z; }

 private:
  /// The sign factor of the fold rule: h for [T4], 1 for [T5].
  Scalar weight() const { return Form == GBForm::paper ? Scalar(1) : d_.h; }

  const StepData<Scene>& d_;
  const State<Scalar>& in_;
  Vector3 base_;  ///< hΩ_n/2
};

/// One Géradin–Bauchau step: Newton on [T4] or [T5] from e⁰ ≈ sin(|Θ⁰|/2) Θ⁰/|Θ⁰|,
/// then Λ_{n+1} = Λ_n ⊗ (e0, e), Ω_{n+1} = 4e/h − Ω_n, by the implicit-step sequence
/// (implicit_step.hpp). With `history` (the scheme's memory, null for none) e⁰ is the
/// extrapolation of the last accepted e and the first tangent the carried one, when the
/// history allows ([P1]–[P3], as simo_step); a failed solve from there is retried once
/// from the memoryless start.
template <GBForm Form, class Scene>
StepReport<typename Scene::Scalar> gb_step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                           typename Scene::Scalar h,
                                           const NewtonOptions<typename Scene::Scalar>& opt,
                                           State<typename Scene::Scalar>& out,
                                           IncrementHistory<typename Scene::Scalar>* history = nullptr) {
  const StepData<Scene> d(scene, in, h);
  return implicit_step(GBProblem<Form, Scene>(d, in), opt, h, out, history);
}

}  // namespace detail
}  // namespace trompo
