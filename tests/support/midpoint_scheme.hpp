#pragma once
// A scheme written outside include/, the way a user would add one: the implicit midpoint
// rule on (q, Ω) with a one-number memory (how many steps it has taken along the
// trajectory). It models trompo::SchemeFor, so Stepper, ComposedStepper and integrate()
// drive it without knowing it.
//
//   q_{n+1} = q_n + (h/2) q_m ⊗ (0, Ω_m),   J Ω_{n+1} = J Ω_n + h (Π_m × Ω_m + τ(Λ(q_m), Ω_m)),
//   q_m = (q_n + q_{n+1})/2,  Ω_m = (Ω_n + Ω_{n+1})/2,  Π_m = J Ω_m + h_r,
//
// solved by fixed-point iteration (it contracts for |hΩ| < 2 roughly, and fails beyond:
// that is how the tests make it fail). The midpoint rule keeps every quadratic invariant:
// |q|² and, on the free body, ½Ω·JΩ and |Π|². Order 2, symmetric.
#include <cmath>
#include <cstdint>
#include <limits>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "trompo/schemes/scheme.hpp"
#include "trompo/lie/so3.hpp"

namespace trompo_test {

struct MidpointQ {
  static constexpr const char* name = "test-midpoint-q";
  /// Order 2, symmetric; H is quadratic on the free body (kept), nothing is kept under a
  /// load; its memory (a step count) belongs to the trajectory.
  static constexpr trompo::SchemeTraits traits{
      .order = 2,
      .symmetric = true,
      .keeps = [](trompo::SceneKind s) { return trompo::Keeps{.energy = s.is_free}; },
      .memory = trompo::MemoryUse::carried};

  /// The memory: accepted steps since the trajectory started (or was reset).
  template <class Scene>
  struct Memory {
    std::int64_t steps = 0;
  };

  int max_iterations = 200;

  template <class Scene>
  trompo::StepReport<typename Scene::Scalar> step(const Scene& scene, const trompo::State<typename Scene::Scalar>& in,
                                                  typename Scene::Scalar h,
                                                  const trompo::NewtonOptions<typename Scene::Scalar>&,
                                                  trompo::State<typename Scene::Scalar>& out,
                                                  Memory<Scene>& memory) const {
    using Scalar = typename Scene::Scalar;
    using V3 = Eigen::Matrix<Scalar, 3, 1>;
    using V4 = Eigen::Matrix<Scalar, 4, 1>;
    using Q = Eigen::Quaternion<Scalar>;
    const Scalar eps = std::numeric_limits<Scalar>::epsilon();
    const V4 q0 = in.rotation.unit_quaternion().coeffs();
    const V3 w0 = in.omega;
    const V3 Pi0 = scene.momentum(w0);
    V4 q1 = q0;
    V3 w1 = w0;
    trompo::StepReport<Scalar> rep;
    rep.status = trompo::StepStatus::not_converged;
    for (int it = 1; it <= max_iterations; ++it) {
      const V4 qm = (q0 + q1) / 2;
      const V3 wm = (w0 + w1) / 2;
      const Q qd = Q(qm) * Q(Scalar(0), wm.x(), wm.y(), wm.z());
      V3 rhs = scene.momentum(wm).cross(wm);
      if constexpr (Scene::has_potential || Scene::has_applied_torque)
        rhs += scene.body_torque(Q(qm).normalized().toRotationMatrix(), wm, in.time + h / 2);
      const V4 q_new = q0 + (h / 2) * qd.coeffs();
      const V3 w_new = scene.body().inertia_inverse() * (Pi0 - scene.momentum(V3::Zero()) + h * rhs);
      const Scalar change = (q_new - q1).norm() + (w_new - w1).norm() / (w0.norm() + Scalar(1));
      q1 = q_new;
      w1 = w_new;
      rep.iterations = it;
      if (!std::isfinite(static_cast<double>(change)) || change > Scalar(1e6)) {
        rep.status = trompo::StepStatus::non_finite;
        return rep;
      }
      if (change <= Scalar(4) * eps) {
        rep.status = trompo::StepStatus::ok;
        break;
      }
    }
    if (!rep.ok()) return rep;
    out.rotation = trompo::SO3<Scalar>::renormalized(Q(q1));
    out.omega = w1;
    out.time = in.time + h;
    ++memory.steps;
    return rep;
  }
};

}  // namespace trompo_test
