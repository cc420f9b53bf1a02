#pragma once
// The Crouch–Grossman method of order 3 (Crouch & Grossman 1993; the coefficients of Owren &
// Marthinsen 1999), docs/theory.md §19 [V10]: an explicit Runge–Kutta method whose stages
// move the attitude by products of exponentials of the frozen body velocities,
//   Λ_2 = Λ_n exp(h a21 Ω̂_1),   Λ_3 = Λ_n exp(h a31 Ω̂_1) exp(h a32 Ω̂_2),
//   Λ_{n+1} = Λ_n exp(h b1 Ω̂_1) exp(h b2 Ω̂_2) exp(h b3 Ω̂_3),                           [V10]
// and Ω by the same tableau as a plain RK method, Ω_i = Ω_n + h Σ a_ij Ω̇_j,
// Ω̇_j = J⁻¹(Π_j × Ω_j + τ(Λ_j, Ω_j, t_n + c_j h)), with
//   c = (0, 3/4, 17/24),  a21 = 3/4,  a31 = 119/216,  a32 = 17/108,
//   b = (13/51, −2/3, 24/17).
// No dexp⁻¹ (unlike RKMK): each stage only composes exponentials. Explicit, three torque
// evaluations; Λ on SO(3) by construction; keeps nothing exactly; not symmetric.
#include <Eigen/Core>

#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"
#include "trompo/schemes/lie_rk/body_rate.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/solvers/newton.hpp"

namespace trompo {

/// Crouch–Grossman, order 3 [V10]: explicit, products of exponentials on SO(3).
struct CrouchGrossman3 {
  /// "crouch-grossman".
  static constexpr const char* name = "crouch-grossman";
  /// Order 3; not symmetric (not composable); keeps nothing exactly; memoryless; no wheels.
  static constexpr SchemeTraits traits{.order = 3};

  /// One explicit step (the scheme contract of scheme.hpp; the Newton options are unused).
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h, const NewtonOptions<typename Scene::Scalar>&,
                                          State<typename Scene::Scalar>& out, NoMemory&) const {
    using Scalar = typename Scene::Scalar;
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
    using G = SO3<Scalar>;
    // The tableau of [V10].
    const Scalar a21 = Scalar(3) / Scalar(4), a31 = Scalar(119) / Scalar(216), a32 = Scalar(17) / Scalar(108);
    const Scalar b1 = Scalar(13) / Scalar(51), b2 = Scalar(-2) / Scalar(3), b3 = Scalar(24) / Scalar(17);
    const Scalar c2 = Scalar(3) / Scalar(4), c3 = Scalar(17) / Scalar(24);
    constexpr bool torqued = Scene::has_potential || Scene::has_applied_torque;
    const Scalar t = in.time;
    const Matrix3 Lambda_n = in.rotation.matrix();
    // Stage 1 at (Λ_n, Ω_n).
    const Vector3 w1 = in.omega;
    const Vector3 k1 = detail::body_rate(scene, Lambda_n, w1, t);
    // Stage 2: Λ_2 = Λ_n exp(h a21 Ω̂_1).
    const Vector3 w2 = in.omega + h * a21 * k1;
    Matrix3 Lambda_2 = Lambda_n;
    if constexpr (torqued) Lambda_2 = Lambda_n * G::exp_matrix(h * a21 * w1);
    const Vector3 k2 = detail::body_rate(scene, Lambda_2, w2, t + c2 * h);
    // Stage 3: Λ_3 = Λ_n exp(h a31 Ω̂_1) exp(h a32 Ω̂_2).
    const Vector3 w3 = in.omega + h * (a31 * k1 + a32 * k2);
    Matrix3 Lambda_3 = Lambda_n;
    if constexpr (torqued) Lambda_3 = Lambda_n * G::exp_matrix(h * a31 * w1) * G::exp_matrix(h * a32 * w2);
    const Vector3 k3 = detail::body_rate(scene, Lambda_3, w3, t + c3 * h);
    StepReport<Scalar> rep;
    out.omega = in.omega + h * (b1 * k1 + b2 * k2 + b3 * k3);
    out.time = t + h;
    const Vector3 x1 = h * b1 * w1, x2 = h * b2 * w2, x3 = h * b3 * w3;
    if (!detail::all_finite(x1) || !detail::all_finite(x2) || !detail::all_finite(x3) || !detail::all_finite(out.omega)) {
      rep.status = StepStatus::non_finite;
      return rep;
    }
    // Λ_{n+1} = Λ_n exp(h b1 Ω̂_1) exp(h b2 Ω̂_2) exp(h b3 Ω̂_3), as unit quaternions
    const auto ha = [](const Vector3& x) { return detail::half_angle(Scalar(x.norm())); };
    out.rotation = in.rotation.times_exp(x1, ha(x1)).times_exp(x2, ha(x2)).times_exp(x3, ha(x3));
    return rep;
  }
};

}  // namespace trompo
