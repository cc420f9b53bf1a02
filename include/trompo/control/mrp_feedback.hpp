#pragma once
// Modified Rodrigues parameters and the MRP proportional–derivative law of Basilisk's
// mrpFeedback without its integral term (docs/theory.md [W11]–[W12]; docs/control.md).
//
// Convention [W11]. σ_BR is the MRP of the direction-cosine matrix [BR] = ΛᵀR (target axes →
// body axes), Schaub & Junkins' convention: [BR] = I + (8σ̂² − 4(1 − σᵀσ)σ̂)/(1 + σᵀσ)², from
// the quaternion (β0, β) of [BR] with β0 ≥ 0 as σ = β/(1 + β0), so |σ| ≤ 1 (the short way
// round; the shadow set is never needed). Their β is minus the vector part of Eigen's
// quaternion of the same matrix (Eigen's rotation matrix has +2β0β̂): we take Eigen's
// quaternion of [BR]ᵀ = RᵀΛ.
//
// The law [W12]: L_r = −K σ_BR − P Ω (target at rest, ω_R = 0), the body torque wanted. With
// wheels it is produced by the minimum-norm motor torques u = −G_sᵀ(G_sG_sᵀ)⁻¹ L_r (the body
// feels −G_s u = L_r), then saturated by the wheels [W5]; without wheels it is applied as a
// body torque.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "trompo/control/command.hpp"
#include "trompo/errors.hpp"

namespace trompo {

/// σ of [BR] = ΛᵀR (Schaub's convention, |σ| ≤ 1) [W11].
template <class Scalar>
Eigen::Matrix<Scalar, 3, 1> mrp_of_relative(const Eigen::Matrix<Scalar, 3, 3>& Lambda, const Eigen::Matrix<Scalar, 3, 3>& target) {
  Eigen::Quaternion<Scalar> q(Eigen::Matrix<Scalar, 3, 3>(target.transpose() * Lambda));
  if (q.w() < Scalar(0)) q.coeffs() = -q.coeffs();
  return q.vec() / (Scalar(1) + q.w());
}

/// The rotation Λ whose σ_BN (target = identity) is σ: Λ = [BN]ᵀ [W11].
template <class Scalar>
Eigen::Matrix<Scalar, 3, 3> rotation_of_mrp(const Eigen::Matrix<Scalar, 3, 1>& sigma) {
  const Scalar s2 = sigma.squaredNorm();
  Eigen::Matrix<Scalar, 3, 3> S;
  S << Scalar(0), -sigma.z(), sigma.y(), sigma.z(), Scalar(0), -sigma.x(), -sigma.y(), sigma.x(), Scalar(0);
  const Eigen::Matrix<Scalar, 3, 3> BN =
      Eigen::Matrix<Scalar, 3, 3>::Identity() + (Scalar(8) * S * S - Scalar(4) * (Scalar(1) - s2) * S) / ((Scalar(1) + s2) * (Scalar(1) + s2));
  return BN.transpose();
}

/// mrp-pd:K,P — L_r = −Kσ_BR − PΩ to an inertial target R, on the wheels by the
/// minimum-norm inverse, else as a body torque [W12].
template <class Scalar>
struct MrpPd {
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  Scalar K = Scalar(3.5);                     ///< attitude gain (N m)
  Scalar P = Scalar(30);                      ///< rate gain (N m s)
  Matrix3 target = Matrix3::Identity();       ///< R, target → inertial

  /// Throws invalid_input unless K, P ≥ 0 finite and the target a rotation.
  void validate() const {
    if (!std::isfinite(static_cast<double>(K)) || !(K >= Scalar(0))) detail::fail("mrp-pd: K must be finite and >= 0, got ", K);
    if (!std::isfinite(static_cast<double>(P)) || !(P >= Scalar(0))) detail::fail("mrp-pd: P must be finite and >= 0, got ", P);
    if (!((target.transpose() * target - Matrix3::Identity()).norm() <= Scalar(1e-9)) || !(target.determinant() > Scalar(0)))
      detail::fail("mrp-pd: target-rotation must be a rotation matrix (orthonormal, det +1)");
  }

  /// L_r = −Kσ − PΩ at the sample.
  Eigen::Matrix<Scalar, 3, 1> requested_torque(const Sample<Scalar>& s) const {
    return -K * mrp_of_relative<Scalar>(s.state.rotation.matrix(), target) - P * s.state.omega;
  }

  /// The command: u = −G_sᵀ(G_sG_sᵀ)⁻¹L_r with wheels, else L_r as a body torque.
  Command<Scalar> operator()(const Sample<Scalar>& s) const {
    Command<Scalar> c;
    const Eigen::Matrix<Scalar, 3, 1> L = requested_torque(s);
    if (s.wheel_axes.cols() > 0) {
      const Matrix3 GGt = s.wheel_axes * s.wheel_axes.transpose();
      c.wheel_torques = -(s.wheel_axes.transpose() * GGt.inverse() * L);
    } else {
      c.body_torque = L;
    }
    return c;
  }
};

}  // namespace trompo
