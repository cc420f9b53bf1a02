#pragma once
// The energy-decaying, momentum-map-exact scheme ("DEM"), docs/theory.md §11 [T12]–[T16]:
// the Simo–Wong energy-momentum step with the potential's torque averaged along the
// geodesic (a line-integral discrete gradient) and an off-centred kinematic relation.
//
//   Λ_{n+1} = Λ_n exp(Θ̂),   Θ = h[(1 + c_n)/2 Ω_{n+1} + (1 − c_n)/2 Ω_n]       [T12]
//   R(Θ) = exp(Θ̂) Π_{n+1} − Π_n − h τ̄(Θ) = 0,   τ̄(Θ) = ∫₀¹ τ_n(exp(sΘ̂)) ds
// τ_n the conservative torque in the frame of step n. For a potential linear in Λ the
// torque is linear in the rotation matrix, and τ̄(Θ) = τ_n(J_l(Θ)) exactly ([T6]).
// For every converged Θ ([T13]):
//   γ·π_{n+1} = γ·π_n   (μ exact),   H_{n+1} − H_n = −(c_n/2) ΔΩ·JΔΩ ≤ 0.
// c_n ∈ [0, 1] is the dissipation of the step [T15]: constant χ (first order), or the
// sensor χ s_n (second order, s_n = O(h) on smooth motion); c_n = 0 is a second-order,
// symmetric energy-momentum scheme.
//
// Caveat [T16]: with c > 0 a spin about the minor axis of inertia is amplified (the
// discrete Kelvin–Tait–Chetaev effect: energy drained at fixed momentum). That is the
// physics of a dissipative, momentum-exact scheme, not a bug; docs/families.md says what
// to use instead.
//
// Scenes: uniform gravity and rotors, no applied torques (the balance laws above are for
// conservative scenes), potentials linear in Λ (the closed form of τ̄).
#include <Eigen/Core>
#include <cmath>

#include "trompo/solvers/damped_newton.hpp"
#include "trompo/lie/lie_kit.hpp"
#include "trompo/schemes/implicit_step.hpp"
#include "trompo/schemes/step_data.hpp"
#include "trompo/errors.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// How the dissipation c_n of EnergyDecaying is scheduled [T15].
enum class ChiSchedule {
  constant,  ///< c_n = χ: first order for χ > 0
  sensor     ///< c_n = χ s_n, s_n = |δ_n − δ_{n−1}|_J / (|δ_n|_J + |δ_{n−1}|_J): second order
};

/// The per-trajectory memory of EnergyDecaying: the last increment (the predictor of
/// caveat 5, §11), the last velocity jump δ_n = Ω_n − Ω_{n−1} and the sensor's c for the
/// next step, valid for step size h. Default-constructed: fresh.
template <class Scalar>
struct EnergyDecayingMemory {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  Vector3 theta = Vector3::Zero();  ///< Θ_{n−1}
  Vector3 delta = Vector3::Zero();  ///< δ_n = Ω_n − Ω_{n−1}
  Scalar c_next = Scalar(0);        ///< the sensor's c_n for the next step (0 for the first two)
  Scalar h = Scalar(0);             ///< the step size of the remembered steps
  int steps = 0;                    ///< steps taken since the last fresh start (capped at 2)
};

/// Energy-decaying, momentum-map-exact scheme [T12]–[T16]; χ = 0: energy-momentum.
struct EnergyDecaying {
  static constexpr const char* name = "energy-decaying";  ///< CLI and report name
  /// Order 2 for χ = 0 and the sensor, symmetric for χ = 0 only (refined()); μ exactly, π on
  /// the free body, and H_{n+1} ≤ H_n at every step; H exactly for χ = 0 (refined()). Its
  /// memory (the last increment, the sensor's history) is part of the trajectory.
  static constexpr SchemeTraits traits{
      .order = 2,
      .symmetric = true,
      .keeps =
          [](SceneKind s) {
            return Keeps{.energy = false, .momentum_map = true, .spatial_momentum = s.is_free, .energy_decays = true};
          },
      .memory = MemoryUse::carried,
      .refined = true,
      .validated = true};
  /// The per-trajectory memory: the last increment and the sensor's history (scheme.hpp).
  template <class Scene>
  using Memory = EnergyDecayingMemory<typename Scene::Scalar>;

  double chi = 0.0;                             ///< dissipation χ ∈ [0, 1]
  ChiSchedule schedule = ChiSchedule::constant;  ///< c_n = χ or χ s_n [T15]

  EnergyDecaying() = default;
  /// Throws invalid_input unless 0 ≤ χ ≤ 1.
  explicit EnergyDecaying(double x, ChiSchedule s = ChiSchedule::constant) : chi(x), schedule(s) { validate(); }

  /// Throws invalid_input unless 0 ≤ χ ≤ 1 (Stepper calls it: chi is a public field).
  void validate() const {
    if (!(chi >= 0.0 && chi <= 1.0)) detail::fail("energy-decaying: chi must be in [0, 1], got ", chi);
  }

  /// The traits with these parameters: symmetric only without dissipation; order 1 for a
  /// constant χ > 0 [T15], else 2; H exactly when χ = 0.
  constexpr SchemeTraits refined() const {
    SchemeTraits t = traits;
    t.symmetric = chi == 0.0;
    t.order = chi > 0.0 && schedule == ChiSchedule::constant ? 1 : 2;
    if (chi == 0.0) {
      t.keeps = [](SceneKind s) {
        Keeps k = traits.keeps(s);
        k.energy = true;
        return k;
      };
    }
    return t;
  }

  /// The residual R of [T12] and its tangent [T14], as functions of y = Θ − hΩ_n (the
  /// departure from the rigid rotation, as in the Simo schemes: Ω_{n+1} = Ω_n +
  /// 2y/(h(1 + c)) adds a small correction instead of cancelling two large numbers).
  template <class Scene>
  class Residual {
   public:
    /// The floating-point type.
    using Scalar = typename Scene::Scalar;
    /// A 3-vector of Scalar.
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    /// A 3×3 matrix of Scalar.
    using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
    static_assert(!Scene::has_applied_torque,
                  "EnergyDecaying: the balance laws [T13] are for conservative scenes (no applied torques)");
    static_assert(Scene::potentials_linear,
                  "EnergyDecaying: the geodesic average of the torque [T12] is closed-form only for potentials "
                  "linear in the attitude (uniform gravity)");

    /// c is this step's dissipation c_n ∈ [0, 1].
    Residual(const detail::StepData<Scene>& d, Scalar c) : d_(d), c_(c) {}

    /// Θ = hΩ_n + y
    Vector3 increment(const Vector3& y) const { return d_.h * d_.omega_n + y; }
    /// Ω_{n+1} = Ω_n + 2y/(h(1 + c)) [T12]
    Vector3 omega_next(const Vector3& y) const { return d_.omega_n + (Scalar(2) / (d_.h * (Scalar(1) + c_))) * y; }

    /// R [T12]; with K: K_R = exp(Θ̂)[(2/(h(1+c)))J − Π̂_{n+1}T(Θ)] − h ∂τ̄/∂Θ [T14].
    bool operator()(const Vector3& y, Vector3& R, Matrix3* K) const {
      using G = SO3<Scalar>;
      const Scene& scene = d_.scene;
      const Scalar h = d_.h;
      const Matrix3& J = scene.body().inertia();
      const Vector3 Theta = increment(y);
      const Scalar theta = Theta.norm();
      const Scalar a = detail::sinc(theta), b = detail::one_minus_cos_over_sq(theta);
      const Scalar k = Scalar(2) / (h * (Scalar(1) + c_));
      const Vector3 dPi = k * (J * y);  // Π_{n+1} − Π_n
      const Vector3 Pi1 = d_.Pi_n + dPi;
      // exp(Θ̂)Π_{n+1} − Π_n = ΔΠ + aΘ×Π_{n+1} + bΘ×(Θ×Π_{n+1}) (every term small).
      const Vector3 c1 = Theta.cross(Pi1);
      R = dPi + a * c1 + b * Theta.cross(c1);
      if (K) {
        const Matrix3 Q = Matrix3::Identity() + a * G::hat(Theta) + b * G::hat_squared(Theta);
        const Matrix3 T = Matrix3::Identity() - b * G::hat(Theta) +
                          detail::theta_minus_sin_over_cube(theta) * G::hat_squared(Theta);
        *K = Q * (k * J - G::hat(Pi1) * T);
      }
      if constexpr (Scene::has_potential) {
        // τ̄ = τ_n(J_l(Θ)) [T12]; ∂τ̄/∂Θ_i = τ_n(∂J_l/∂Θ_i), (∂J_l/∂Θ_i) e_j = D(Θ, e_j) e_i [T6].
        const Matrix3 Jl = detail::left_jacobian(Theta);
        R -= h * scene.conservative_torque(d_.caches, Jl);
        if (K) {
          Matrix3 D[3];
          for (int j = 0; j < 3; ++j) D[j] = detail::left_jacobian_derivative(Theta, Vector3(Vector3::Unit(j)));
          for (int i = 0; i < 3; ++i) {
            Matrix3 dJl;
            for (int j = 0; j < 3; ++j) dJl.col(j) = D[j].col(i);
            K->col(i) -= h * scene.conservative_torque(d_.caches, dJl);
          }
        }
      }
      return true;
    }

   private:
    const detail::StepData<Scene>& d_;
    Scalar c_;
  };

  /// The dissipation c_n of the next step from `memory` (fresh if built for another h).
  template <class Scalar>
  Scalar dissipation(const EnergyDecayingMemory<Scalar>& memory, Scalar h) const {
    if (schedule == ChiSchedule::constant) return Scalar(chi);
    return memory.steps > 0 && memory.h == h ? memory.c_next : Scalar(0);
  }

  /// One step: Newton (with backtracking) on [T12] from Θ_{n−1} (or the Taylor predictor
  /// on a fresh start), then the sensor's update [T15].
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h,
                                          const NewtonOptions<typename Scene::Scalar>& options,
                                          State<typename Scene::Scalar>& out,
                                          EnergyDecayingMemory<typename Scene::Scalar>& memory) const {
    using Scalar = typename Scene::Scalar;
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
    const Scalar tiny = detail::tiny_scale<Scalar>();
    const bool resume = memory.steps > 0 && memory.h == h;
    const Scalar c = dissipation(memory, h);
    const detail::StepData<Scene> d(scene, in, h);
    const Residual<Scene> res(d, c);
    // Predictor: the previous increment (caveat 5 of §11), else Θ⁰ = hΩ_n + (h²/2)Ω̇_n.
    const Vector3 Theta0 = resume ? memory.theta : d.predicted_increment();
    const Matrix3& J = scene.body().inertia();
    // Row weights: the momentum and the torque impulse of the step.
    Scalar weight = d.Pi_n_norm + J.norm() * Theta0.norm() / std::abs(h) + tiny;
    if constexpr (Scene::has_potential) {
      Matrix3 Jt;
      weight += std::abs(h) * (scene.conservative_torque(d.caches, Matrix3::Identity(), &Jt).norm() + Jt.norm());
    }
    Vector3 y = Theta0 - h * in.omega;
    Matrix3 K;
    const Vector3 W = Vector3::Constant(weight);
    StepReport<Scalar> rep =
        detail::damped_newton<3>(res, y, options, DampedNewtonSolve<3, Scalar>{.weights = W, .x_scale = Theta0.norm() + tiny, .tangent = &K});
    if (!rep.ok()) return rep;
    const Vector3 Theta = res.increment(y);
    // Branch rule (NewtonOptions): |Θ| < max_increment, ‖Θ − Θ⁰‖ ≤ max_correction, and
    // det(K)·h > 0 (K → 2J/(h(1+c)) as h → 0).
    if (!detail::on_branch(options, Theta.norm(), Scalar((Theta - Theta0).norm()), Scalar(K.determinant() * h))) {
      rep.status = StepStatus::wrong_branch;
      return rep;
    }
    out.rotation = in.rotation * SO3<Scalar>::exp(Theta);  // Λ_{n+1} = Λ_n exp(Θ̂)
    out.omega = res.omega_next(y);
    out.time = in.time + h;
    // Memory: Θ_n, δ_{n+1} and the sensor s_{n+1} [T15] (s = 0 until two jumps are known).
    const Vector3 delta = out.omega - in.omega;
    Scalar c_next(0);
    if (schedule == ChiSchedule::sensor && resume) {
      const auto norm_J = [&](const Vector3& v) { return std::sqrt(v.dot(J * v)); };
      const Scalar den = norm_J(delta) + norm_J(memory.delta);
      if (den > Scalar(0)) c_next = Scalar(chi) * std::min(Scalar(1), norm_J(delta - memory.delta) / den);
    }
    memory.theta = Theta;
    memory.delta = delta;
    memory.c_next = c_next;
    memory.h = h;
    memory.steps = resume ? 2 : 1;
    if (!detail::all_finite(out.omega)) rep.status = StepStatus::non_finite;
    return rep;
  }
};

}  // namespace trompo
