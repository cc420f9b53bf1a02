#pragma once
// The torque of a scene at the end of a step, in the body frame there, with its
// Jacobians: what the schemes of docs/theory.md §11 that balance forces at t_{n+1}
// (gen-α [T9], the trapezoid [T17]) need from the effects.
//
// The effects give their torques in the frame of step n at Λ = Λ_n R (effect.hpp). In
// the body frame of Λ_n R the torque is τ = Rᵀ τ_n(R); an applied torque is called with
// the velocity seen in frame n, R Ω. For the right perturbation Λ_n R exp(ŵ):
//   ∂τ/∂w = τ̂ + Rᵀ (J_c + J_a,rot − J_a,Ω R Ω̂),     ∂τ/∂Ω = Rᵀ J_a,Ω R,
// J_c the conservative torques' Jacobian, J_a,· the applied torques' (frame n).
#include <Eigen/Core>

#include "trompo/lie/so3.hpp"

namespace trompo::detail {

/// τ at Λ_n R and body velocity Ω, in the body frame of Λ_n R; with d_rotation (∂/∂w,
/// right perturbation) and d_omega (∂/∂Ω) if not null. `caches` are the scene's for Λ_n
/// (and the time at which time-dependent torques are to be sampled).
template <class Scene>
Eigen::Matrix<typename Scene::Scalar, 3, 1> end_torque(const Scene& scene, const typename Scene::Caches& caches,
                                                       const Eigen::Matrix<typename Scene::Scalar, 3, 3>& R,
                                                       const Eigen::Matrix<typename Scene::Scalar, 3, 1>& omega,
                                                       Eigen::Matrix<typename Scene::Scalar, 3, 3>* d_rotation,
                                                       Eigen::Matrix<typename Scene::Scalar, 3, 3>* d_omega) {
  using Scalar = typename Scene::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  Vector3 tau_n = Vector3::Zero();  // frame n
  Matrix3 J_n = Matrix3::Zero();    // ∂τ_n/∂w (frame n)
  if (d_omega) d_omega->setZero();
  if constexpr (Scene::has_potential) {
    Matrix3 J_c;
    tau_n += scene.conservative_torque(caches, R, d_rotation ? &J_c : nullptr);
    if (d_rotation) J_n += J_c;
  }
  if constexpr (Scene::has_applied_torque) {
    Matrix3 J_rot, J_om;
    const Vector3 omega_n = R * omega;
    tau_n += scene.applied_torque(caches, R, omega_n, d_rotation ? &J_rot : nullptr, &J_om);
    if (d_rotation) J_n += J_rot - J_om * R * SO3<Scalar>::hat(omega);
    if (d_omega) *d_omega = R.transpose() * J_om * R;
  }
  const Vector3 tau = R.transpose() * tau_n;
  if (d_rotation) *d_rotation = SO3<Scalar>::hat(tau) + R.transpose() * J_n;
  return tau;
}

}  // namespace trompo::detail
