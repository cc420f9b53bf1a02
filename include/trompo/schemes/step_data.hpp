#pragma once
// What every scheme needs from the start of a step (frame of step n).
#include <Eigen/Core>

#include "trompo/model/state.hpp"

namespace trompo::detail {

template <class Scene>
struct StepData {
  using Scalar = typename Scene::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;

  const Scene& scene;
  Scalar h;
  Vector3 omega_n;                  ///< Ω_n
  Vector3 Pi_n;                     ///< Π_n = JΩ_n + h_r (+ h_w(t_n), wheels)
  Vector3 dh_w;                     ///< h_w(t_n + h) − h_w(t_n): the wheels' change over the step [W4] (0 without)
  Scalar Pi_n_norm;                 ///< ‖Π_n‖ (part of the residuals' scale)
  typename Scene::Caches caches;    ///< effects' per-step data (b = Λ_nᵀ𝐠 for gravity)

  StepData(const Scene& s, const State<Scalar>& st, Scalar step)
      : scene(s), h(step), omega_n(st.omega), Pi_n(s.momentum(st.omega, st.time)), dh_w(wheel_change(s, st.time, step)),
        Pi_n_norm(Pi_n.norm()), caches(s.caches(st.rotation.matrix(), st.time + step / 2)) {}

  /// h_w(t + h) − h_w(t) [W4]: both ends as the scene gives them, so that Π_{n+1} of this step
  /// and Π_n of the next agree to round-off.
  static Vector3 wheel_change(const Scene& s, Scalar t, Scalar step) {
    if constexpr (Scene::has_wheels) return s.wheel_momentum(t + step) - s.wheel_momentum(t);
    else return Vector3::Zero();
  }

  /// Ω̇_n from Euler's equations, J Ω̇ = Π × Ω + τ (explicit, for the predictor).
  Vector3 omega_rate() const {
    Vector3 rhs = Pi_n.cross(omega_n);
    if constexpr (Scene::has_wheels) rhs -= scene.wheel_momentum_rate();  // the motors' reaction [W1]
    if constexpr (Scene::has_potential || Scene::has_applied_torque) {
      // The caches hold t_{n+½}; a time-dependent torque is thus sampled at mid-step,
      // which only shifts the predictor by O(h²).
      const Matrix3 I = Matrix3::Identity();
      if constexpr (Scene::has_potential) rhs += scene.conservative_torque(caches, I);
      if constexpr (Scene::has_applied_torque) rhs += scene.applied_torque(caches, I, omega_n);
    }
    return scene.body().inertia_inverse() * rhs;
  }

  /// Θ⁰ = hΩ_n + (h²/2)Ω̇_n: the body-frame increment to O(h³).
  Vector3 predicted_increment() const { return h * omega_n + (h * h / 2) * omega_rate(); }
};

}  // namespace trompo::detail
