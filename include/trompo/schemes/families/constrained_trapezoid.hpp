#pragma once
// The constrained trapezoid (Hughes, Caughey & Liu 1978; Kuhl & Ramm 1996),
// docs/theory.md §11 [T17]–[T20]: the Lie-group trapezoid with the energy imposed by a
// Lagrange multiplier λ along the energy's gradient ("enforced conservation").
//
//   Λ_{n+1} = Λ_n exp(Θ̂),   Ω_{n+1} = 2Θ/h − Ω_n                                  [T17]
//   R₁(Θ, λ) = J(Ω_{n+1} − Ω_n) − (h/2)(f_n + f_{n+1}) + λ g(Θ) = 0              [T18]
//   R₂(Θ)    = H(Λ_{n+1}, Ω_{n+1}) − H(Λ_n, Ω_n) = 0
//   f = Π × Ω + τ (= J Ω̇),   g = ∂H_{n+1}/∂Θ = (2/h) J Ω_{n+1} − T(Θ)ᵀ τ_{n+1}
// solved by a 4×4 Newton with the analytic tangent [T19]. H is exact to round-off; μ is
// not: it drifts exactly as the plain trapezoid's [T20] (the multiplier repairs H only).
// The multiplier is O(h⁴).
//
// Scenes: any conservative scene (potentials, rotors); no applied torques (with them H
// is not an invariant to enforce).
#include <Eigen/Core>
#include <cmath>

#include "trompo/solvers/damped_newton.hpp"
#include "trompo/model/end_torque.hpp"
#include "trompo/lie/lie_kit.hpp"
#include "trompo/schemes/implicit_step.hpp"
#include "trompo/schemes/step_data.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// The per-trajectory memory of ConstrainedTrapezoid: the last increment (the predictor
/// of [T19]) and multiplier, valid for step size h. Default-constructed: fresh.
template <class Scalar>
struct ConstrainedTrapezoidMemory {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  Vector3 theta = Vector3::Zero();  ///< Θ_{n−1}
  Scalar lambda = Scalar(0);        ///< λ of the last step (O(h⁴), [T19])
  Scalar h = Scalar(0);             ///< the step size of the last step
  bool started = false;             ///< false: fresh
};

/// Constrained trapezoid [T17]–[T20]: energy exact by a Lagrange multiplier.
struct ConstrainedTrapezoid {
  static constexpr const char* name = "constrained-trapezoid";  ///< CLI and report name
  /// Order 2; not symmetric (the multiplier acts along the gradient at t_{n+1} only); H
  /// exactly, μ and π drift as the plain trapezoid's [T20]; its memory (the last increment
  /// and multiplier) is the predictor of [T19], carried along the trajectory.
  static constexpr SchemeTraits traits{
      .order = 2, .keeps = [](SceneKind) { return Keeps{.energy = true}; }, .memory = MemoryUse::carried};
  /// The per-trajectory memory: the last increment and multiplier (scheme.hpp).
  template <class Scene>
  using Memory = ConstrainedTrapezoidMemory<typename Scene::Scalar>;

  /// R = (R₁, R₂) of [T18] and the 4×4 tangent [T19] as functions of x = (y, λ), with
  /// y = Θ − hΩ_n (Ω_{n+1} = Ω_n + 2y/h: no cancellation).
  template <class Scene>
  class Residual {
   public:
    /// The floating-point type.
    using Scalar = typename Scene::Scalar;
    /// A 3-vector of Scalar.
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    /// A 4-vector of Scalar.
    using Vector4 = Eigen::Matrix<Scalar, 4, 1>;
    /// A 3×3 matrix of Scalar.
    using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
    /// A 4×4 matrix of Scalar.
    using Matrix4 = Eigen::Matrix<Scalar, 4, 4>;
    static_assert(!Scene::has_applied_torque,
                  "ConstrainedTrapezoid: enforces H, an invariant of conservative scenes only (no applied torques)");

    /// The residual and its tangent at the step's data d.
    explicit Residual(const detail::StepData<Scene>& d) : d_(d) {
      const Scene& scene = d.scene;
      f_n_ = d.Pi_n.cross(d.omega_n);  // f_n = Π_n × Ω_n + τ_n
      if constexpr (Scene::has_potential) {
        f_n_ += scene.conservative_torque(d.caches, Matrix3::Identity());
        V_n_ = scene.potential(d.caches, Matrix3::Identity());
      }
    }

    /// Θ = hΩ_n + y
    Vector3 increment(const Vector4& x) const { return d_.h * d_.omega_n + x.template head<3>(); }
    /// Ω_{n+1} = Ω_n + 2y/h
    Vector3 omega_next(const Vector4& x) const { return d_.omega_n + (Scalar(2) / d_.h) * x.template head<3>(); }
    /// f_n, J Ω̇ at the start of the step
    const Vector3& f_n() const { return f_n_; }
    /// V(Λ_n)
    Scalar potential_n() const { return V_n_; }

    /// R [T18]; with K the tangent [T19]:
    ///   [ K + λG  g ]   K = (2/h)J + Ω̂J − Π̂ − (h/2) ∂τ/∂w T(Θ)
    ///   [ gᵀ      0 ]   G = (4/h²)J − D(Θ, τ) − T(Θ)ᵀ ∂τ/∂w T(Θ)
    bool operator()(const Vector4& x, Vector4& R, Matrix4* K) const {
      using G3 = SO3<Scalar>;
      const Scene& scene = d_.scene;
      const Scalar h = d_.h;
      const Matrix3& J = scene.body().inertia();
      const Vector3 y = x.template head<3>();
      const Scalar lambda = x(3);
      const Vector3 Theta = increment(x);
      const Vector3 dOmega = (Scalar(2) / h) * y;
      const Vector3 omega1 = d_.omega_n + dOmega;
      const Vector3 Pi1 = scene.momentum(omega1);
      const Scalar theta = Theta.norm();
      const Matrix3 T = Matrix3::Identity() - detail::one_minus_cos_over_sq(theta) * G3::hat(Theta) +
                        detail::theta_minus_sin_over_cube(theta) * G3::hat_squared(Theta);
      Vector3 tau = Vector3::Zero();
      Matrix3 d_rot = Matrix3::Zero();
      Scalar dV(0);
      if constexpr (Scene::has_potential) {
        const Matrix3 Q = G3::exp_matrix(Theta);
        tau = detail::end_torque(scene, d_.caches, Q, omega1, K ? &d_rot : nullptr, nullptr);
        dV = scene.potential(d_.caches, Q) - V_n_;
      }
      const Vector3 f1 = Pi1.cross(omega1) + tau;
      const Vector3 g = (Scalar(2) / h) * (J * omega1) - T.transpose() * tau;  // ∂H_{n+1}/∂Θ
      R.template head<3>() = J * dOmega - (h / Scalar(2)) * (f_n_ + f1) + lambda * g;
      // H_{n+1} − H_n = ΔΩ·J Ω̄ + ΔV, Ω̄ = Ω_n + ΔΩ/2 (no cancellation of the kinetic parts)
      R(3) = dOmega.dot(J * (d_.omega_n + dOmega / Scalar(2))) + dV;
      if (K) {
        Matrix3 Kt = (Scalar(2) / h) * J + G3::hat(omega1) * J - G3::hat(Pi1) - (h / Scalar(2)) * d_rot * T;
        Matrix3 Gm = (Scalar(4) / (h * h)) * J;
        if constexpr (Scene::has_potential)
          Gm -= detail::left_jacobian_derivative(Theta, tau) + T.transpose() * d_rot * T;
        K->template topLeftCorner<3, 3>() = Kt + lambda * Gm;
        K->template topRightCorner<3, 1>() = g;
        K->template bottomLeftCorner<1, 3>() = g.transpose();
        (*K)(3, 3) = Scalar(0);
      }
      return true;
    }

   private:
    const detail::StepData<Scene>& d_;
    Vector3 f_n_;
    Scalar V_n_ = Scalar(0);
  };

  /// One step: 4×4 Newton (with backtracking) on [T18] from (Θ_{n−1}, 0), or from the
  /// Taylor predictor on a fresh start.
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h,
                                          const NewtonOptions<typename Scene::Scalar>& options,
                                          State<typename Scene::Scalar>& out,
                                          ConstrainedTrapezoidMemory<typename Scene::Scalar>& memory) const {
    using Scalar = typename Scene::Scalar;
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    using Vector4 = Eigen::Matrix<Scalar, 4, 1>;
    using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
    using Matrix4 = Eigen::Matrix<Scalar, 4, 4>;
    const Scalar tiny = detail::tiny_scale<Scalar>();
    const detail::StepData<Scene> d(scene, in, h);
    const Residual<Scene> res(d);
    const bool resume = memory.started && memory.h == h;
    const Vector3 Theta0 = resume ? memory.theta : d.predicted_increment();
    const Matrix3& J = scene.body().inertia();
    // Row weights [T19]: the momentum and torque impulse for R₁, the energy's summands
    // (and the potential's curvature) for R₂.
    Scalar w_momentum = d.Pi_n_norm + J.norm() * Theta0.norm() / std::abs(h) + tiny;
    Scalar w_energy = scene.kinetic_energy(in.omega) + std::abs(res.potential_n()) + tiny;
    if constexpr (Scene::has_potential) {
      Matrix3 Jt;
      const Scalar t = scene.conservative_torque(d.caches, Matrix3::Identity(), &Jt).norm();
      w_momentum += std::abs(h) * (t + Jt.norm());
      w_energy += t + Jt.norm();
    }
    const Vector4 W(w_momentum, w_momentum, w_momentum, w_energy);
    Vector4 x;
    x.template head<3>() = Theta0 - h * in.omega;
    x(3) = Scalar(0);
    Matrix4 K;
    StepReport<Scalar> rep =
        detail::damped_newton<4>(res, x, options, DampedNewtonSolve<4, Scalar>{.weights = W, .x_scale = Theta0.norm() + tiny, .tangent = &K});
    if (!rep.ok()) return rep;
    const Vector3 Theta = res.increment(x);
    // Branch rule (NewtonOptions) on the 3×3 block K + λG (→ (2/h)J as h → 0).
    const Matrix3 K3 = K.template topLeftCorner<3, 3>();
    if (!detail::on_branch(options, Theta.norm(), Scalar((Theta - Theta0).norm()), Scalar(K3.determinant() * h))) {
      rep.status = StepStatus::wrong_branch;
      return rep;
    }
    out.rotation = in.rotation * SO3<Scalar>::exp(Theta);
    out.omega = res.omega_next(x);
    out.time = in.time + h;
    memory.theta = Theta;
    memory.lambda = x(3);
    memory.h = h;
    memory.started = true;
    if (!detail::all_finite(out.omega) || !std::isfinite(static_cast<double>(x(3)))) rep.status = StepStatus::non_finite;
    return rep;
  }
};

}  // namespace trompo
