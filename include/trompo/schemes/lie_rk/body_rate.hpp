#pragma once
// The right-hand side of the explicit Lie group Runge–Kutta methods (RKMK4, Crouch–Grossman),
// docs/theory.md §19 [V8]: the rigid body as a differential equation on SO(3) × R³,
//   Λ̇ = Λ Ω̂,   J Ω̇ = Π × Ω + τ(Λ, Ω, t),   Π = JΩ + h_r,
// the first written in the right-trivialised form the Lie group methods integrate by
// exponentials, the second as a vector equation.
#include <Eigen/Core>

namespace trompo::detail {

/// Ω̇ = J⁻¹(Π × Ω + τ(Λ, Ω, t)) at attitude Λ (a rotation matrix), Ω and t [V8]. The
/// torques are the scene's: potentials and applied torques (scene.body_torque).
template <class Scene>
Eigen::Matrix<typename Scene::Scalar, 3, 1> body_rate(const Scene& scene,
                                                       const Eigen::Matrix<typename Scene::Scalar, 3, 3>& Lambda,
                                                       const Eigen::Matrix<typename Scene::Scalar, 3, 1>& omega,
                                                       typename Scene::Scalar t) {
  Eigen::Matrix<typename Scene::Scalar, 3, 1> rhs = scene.momentum(omega, t).cross(omega);  // Π × Ω
  if constexpr (Scene::has_potential || Scene::has_applied_torque) rhs += scene.body_torque(Lambda, omega, t);
  return scene.body().inertia_inverse() * rhs;
}

}  // namespace trompo::detail
