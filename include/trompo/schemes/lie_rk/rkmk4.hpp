#pragma once
// Runge–Kutta–Munthe-Kaas of order 4 (Munthe-Kaas 1998), docs/theory.md §19 [V9]: the
// classical RK4 tableau applied, within one step, to the local coordinates Θ of
// Λ(t) = Λ_n exp(Θ̂(t)) and to Ω, which obey
//   Θ̇ = T(Θ)⁻¹ Ω,   Ω̇ = J⁻¹(Π × Ω + τ(Λ_n exp(Θ̂), Ω, t)),   Θ(t_n) = 0           [V9]
// (T the right tangent of exp, docs/theory.md §2; its inverse exactly, not truncated), then
// Λ_{n+1} = Λ_n exp(Θ̂_{n+1}). Explicit, four torque evaluations; Λ stays on SO(3) by
// construction (no renormalisation of a drifting quaternion, as RK4 needs); keeps
// nothing exactly; not symmetric. The robotics simulators' "SO(3)-aware RK4".
#include <Eigen/Core>

#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"
#include "trompo/schemes/lie_rk/body_rate.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/solvers/newton.hpp"

namespace trompo {

/// Runge–Kutta–Munthe-Kaas, order 4 [V9]: explicit, on SO(3) by construction.
struct RKMK4 {
  /// "rkmk4".
  static constexpr const char* name = "rkmk4";
  /// Order 4; not symmetric (not composable); keeps nothing exactly; memoryless; no wheels.
  static constexpr SchemeTraits traits{.order = 4};

  /// One explicit step (the scheme contract of scheme.hpp; the Newton options are unused).
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h, const NewtonOptions<typename Scene::Scalar>&,
                                          State<typename Scene::Scalar>& out, NoMemory&) const {
    using Scalar = typename Scene::Scalar;
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
    using G = SO3<Scalar>;
    const Matrix3 Lambda_n = in.rotation.matrix();
    const Scalar t = in.time;
    // The attitude Λ_n exp(Θ̂) of a stage, formed only when a torque reads it.
    const auto attitude = [&](const Vector3& Theta) -> Matrix3 {
      if constexpr (Scene::has_potential || Scene::has_applied_torque) return Lambda_n * G::exp_matrix(Theta);
      else return Lambda_n;
    };
    // Stage i: Θ_i, Ω_i → (Θ̇, Ω̇) of [V9]
    const Vector3 k1t = in.omega;  // T(0)⁻¹ = I
    const Vector3 k1w = detail::body_rate(scene, Lambda_n, in.omega, t);
    const Vector3 th2 = (h / 2) * k1t, w2 = in.omega + (h / 2) * k1w;
    const Vector3 k2t = G::right_tangent_inverse(th2) * w2;
    const Vector3 k2w = detail::body_rate(scene, attitude(th2), w2, t + h / 2);
    const Vector3 th3 = (h / 2) * k2t, w3 = in.omega + (h / 2) * k2w;
    const Vector3 k3t = G::right_tangent_inverse(th3) * w3;
    const Vector3 k3w = detail::body_rate(scene, attitude(th3), w3, t + h / 2);
    const Vector3 th4 = h * k3t, w4 = in.omega + h * k3w;
    const Vector3 k4t = G::right_tangent_inverse(th4) * w4;
    const Vector3 k4w = detail::body_rate(scene, attitude(th4), w4, t + h);
    const Vector3 Theta = (h / 6) * (k1t + 2 * k2t + 2 * k3t + k4t);
    StepReport<Scalar> rep;
    out.omega = in.omega + (h / 6) * (k1w + 2 * k2w + 2 * k3w + k4w);
    out.time = t + h;
    if (!detail::all_finite(Theta) || !detail::all_finite(out.omega)) {
      rep.status = StepStatus::non_finite;
      return rep;
    }
    out.rotation = in.rotation.times_exp(Theta, detail::half_angle(Scalar(Theta.norm())));  // Λ_n exp(Θ̂)
    return rep;
  }
};

}  // namespace trompo
