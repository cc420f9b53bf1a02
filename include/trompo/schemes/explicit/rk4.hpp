#pragma once
// The baseline most users would write instead: classical explicit RK4 on
// (unit quaternion q, Ω) with q̇ = ½ q ⊗ (0, Ω), J Ω̇ = Π × Ω + τ(Λ, Ω, t),
// renormalising q at the end of each step. Conserves nothing exactly; order 4.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "trompo/solvers/newton.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

namespace detail {

template <class Scene>
StepReport<typename Scene::Scalar> rk4_step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                            typename Scene::Scalar h,
                                            State<typename Scene::Scalar>& out) {
  using Scalar = typename Scene::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Vector4 = Eigen::Matrix<Scalar, 4, 1>;
  using Quaternion = Eigen::Quaternion<Scalar>;
  const auto& Jinv = scene.body().inertia_inverse();
  // f(q, Ω, t): returns q̇ (coeffs x,y,z,w) and Ω̇.
  auto f = [&](const Vector4& qc, const Vector3& w, Scalar t, Vector4& dq, Vector3& dw) {
    const Quaternion q(qc);
    const Quaternion qd = q * Quaternion(Scalar(0), w.x(), w.y(), w.z());
    dq = qd.coeffs() / Scalar(2);
    Vector3 rhs;
    if constexpr (Scene::has_wheels)
      rhs = scene.momentum(w, t).cross(w) - scene.wheel_momentum_rate();  // Π(t) × Ω − ḣ_w  [W1]
    else
      rhs = scene.momentum(w).cross(w);
    if constexpr (Scene::has_potential || Scene::has_applied_torque)
      // The stage quaternions drift off |q| = 1, and Eigen's toRotationMatrix() of a
      // non-unit q is not a rotation: normalise before taking Λ(q).
      rhs += scene.body_torque(q.normalized().toRotationMatrix(), w, t);
    dw = Jinv * rhs;
  };
  const Vector4 q0 = in.rotation.unit_quaternion().coeffs();
  const Vector3 w0 = in.omega;
  const Scalar t0 = in.time;
  Vector4 k1q, k2q, k3q, k4q;
  Vector3 k1w, k2w, k3w, k4w;
  f(q0, w0, t0, k1q, k1w);
  f(q0 + h / 2 * k1q, w0 + h / 2 * k1w, t0 + h / 2, k2q, k2w);
  f(q0 + h / 2 * k2q, w0 + h / 2 * k2w, t0 + h / 2, k3q, k3w);
  f(q0 + h * k3q, w0 + h * k3w, t0 + h, k4q, k4w);
  const Vector4 q1 = q0 + h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q);
  StepReport<Scalar> rep;
  out.omega = w0 + h / 6 * (k1w + 2 * k2w + 2 * k3w + k4w);
  out.time = t0 + h;
  if (!all_finite(q1) || !all_finite(out.omega) || !(q1.norm() > 0)) {
    rep.status = StepStatus::non_finite;
    return rep;
  }
  // Scale by the largest component first: after a wild step |q1|² can overflow while q1
  // is finite, and normalising by an infinite norm would give the zero quaternion.
  out.rotation = SO3<Scalar>::renormalized(Quaternion(Vector4(q1 / q1.cwiseAbs().maxCoeff())));
  return rep;
}

}  // namespace detail

/// Classical RK4 on (q, Ω): order 4, keeps nothing exactly, not symmetric (not composable).
struct RK4 {
  /// "rk4".
  static constexpr const char* name = "rk4";
  /// Order 4; not symmetric (may not be composed); keeps nothing exactly; memoryless.
  static constexpr SchemeTraits traits{.order = 4, .carries_wheels = true};

  /// One explicit step (the scheme contract of scheme.hpp; the Newton options are unused).
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h, const NewtonOptions<typename Scene::Scalar>&,
                                          State<typename Scene::Scalar>& out, NoMemory&) const {
    return detail::rk4_step(scene, in, h, out);
  }
};

}  // namespace trompo
