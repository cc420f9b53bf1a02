#pragma once
// Lie-group generalised-α (Chung & Hulbert 1993; Arnold & Brüls 2007; Brüls & Cardona
// 2010), docs/theory.md §11 [T7]–[T11]: numerical dissipation of the unresolved high
// frequencies, set by the spectral radius at infinity ρ∞ ∈ [0, 1].
//
// Unknown w = Ω̇_{n+1}, the true acceleration. The per-trajectory memory holds Ω̇_n and the
// acceleration-like variable a_n (and the h they were built with):
//   (1 − α_m) a_{n+1} + α_m a_n = (1 − α_f) w + α_f Ω̇_n                    [T8]
//   Ω_{n+1} = Ω_n + h(1 − γ) a_n + hγ a_{n+1}
//   Λ_{n+1} = Λ_n exp(h Δq̂),  Δq = Ω_n + h(½ − β) a_n + hβ a_{n+1}
//   r(w) = J w − Π_{n+1} × Ω_{n+1} − τ(Λ_{n+1}, Ω_{n+1}, t_{n+1}) = 0           [T9]
// Any scene: it needs the torque at the end of the step and its Jacobian
// (detail/end_torque.hpp). Order 2 for every ρ∞; ρ∞ = 1 with the plain start is the
// Lie-group trapezoid [T11], [T17]. Keeps nothing exactly in general (its energy is not
// monotone: [T11]), but on a symmetric top Ω₃ exactly (the third row of r is J₃w₃).
#include <Eigen/Core>
#include <cmath>

#include "trompo/solvers/damped_newton.hpp"
#include "trompo/model/end_torque.hpp"
#include "trompo/errors.hpp"
#include "trompo/schemes/implicit_step.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// The per-trajectory memory of LieGenAlpha: Ω̇_n and a_n, valid for step size h.
/// Default-constructed: fresh (the next step starts from the equations of motion).
template <class Scalar>
struct GenAlphaMemory {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  Vector3 omega_rate = Vector3::Zero();  ///< Ω̇_n, the true acceleration
  Vector3 a = Vector3::Zero();           ///< a_n, the acceleration-like variable [T8]
  Scalar h = Scalar(0);                  ///< the step size a_n was built with
  bool started = false;                  ///< false: fresh
};

/// Lie-group generalised-α on SO(3) ([T7]–[T11]).
struct LieGenAlpha {
  static constexpr const char* name = "lie-gen-alpha";  ///< CLI and report name
  /// Order 2 for every ρ∞ and both starts; not symmetric (not composable); keeps nothing
  /// exactly, neither H nor μ ([T11]; measured in tests/test_families.cpp); its memory
  /// (Ω̇_n, a_n) is part of the trajectory; ρ∞ is checked by validate().
  static constexpr SchemeTraits traits{.order = 2, .memory = MemoryUse::carried, .validated = true};
  /// The per-trajectory memory: Ω̇_n and a_n (scheme.hpp).
  template <class Scene>
  using Memory = GenAlphaMemory<typename Scene::Scalar>;

  /// How a_0 is chosen at a fresh start [T10].
  enum class Start {
    plain,     ///< a_0 = Ω̇_0
    perturbed  ///< a_0 = Ω̇_0 + (α_m − α_f) h Ω̈_0 (Arnold–Brüls)
  };

  double rho_inf = 0.8;  ///< spectral radius at infinity ρ∞ ∈ [0, 1]
  /// How the first step of a trajectory starts (plain or perturbed, docs/theory.md §11).
  Start start = Start::plain;

  LieGenAlpha() = default;
  /// Throws invalid_input unless 0 ≤ ρ∞ ≤ 1.
  explicit LieGenAlpha(double rho, Start s = Start::plain) : rho_inf(rho), start(s) { validate(); }

  /// Throws invalid_input unless 0 ≤ ρ∞ ≤ 1 (Stepper calls it: rho_inf is a public field).
  void validate() const {
    if (!(rho_inf >= 0.0 && rho_inf <= 1.0)) detail::fail("lie-gen-alpha: rho_inf must be in [0, 1], got ", rho_inf);
  }

  /// The coefficients of [T7] (Chung–Hulbert convention).
  struct Coefficients {
    double alpha_m;  ///< α_m, the weight of a_n
    double alpha_f;  ///< α_f, the weight of Ω̇_n
    double beta;     ///< β, of the rotation increment
    double gamma;    ///< γ, of the velocity update
  };
  /// α_m = (2ρ∞ − 1)/(ρ∞ + 1), α_f = ρ∞/(ρ∞ + 1), γ = ½ + α_f − α_m, β = ¼(γ + ½)² [T7].
  Coefficients coefficients() const {
    const double am = (2 * rho_inf - 1) / (rho_inf + 1), af = rho_inf / (rho_inf + 1);
    const double g = 0.5 + af - am;
    return {am, af, 0.25 * (g + 0.5) * (g + 0.5), g};
  }

  /// The residual [T9] and its tangent as functions of w, for one step from (in, memory).
  template <class Scene>
  class Residual {
   public:
    /// The floating-point type.
    using Scalar = typename Scene::Scalar;
    /// A 3-vector of Scalar.
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    /// A 3×3 matrix of Scalar.
    using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
    /// The memory must be started (LieGenAlpha::started_memory) for step size h.
    Residual(const LieGenAlpha& s, const Scene& scene, const State<Scalar>& in, Scalar h,
             const GenAlphaMemory<Scalar>& m)
        : scene_(scene), in_(in), m_(m), h_(h), caches_(scene.caches(in.rotation.matrix(), in.time + h)) {
      const Coefficients c = s.coefficients();
      am_ = Scalar(c.alpha_m);
      af_ = Scalar(c.alpha_f);
      beta_ = Scalar(c.beta);
      gamma_ = Scalar(c.gamma);
      gamma_p_ = h * gamma_ * (Scalar(1) - af_) / (Scalar(1) - am_);       // dΩ_{n+1}/dw [T8]
      beta_p_ = h * h * beta_ * (Scalar(1) - af_) / (Scalar(1) - am_);     // d(hΔq)/dw [T8]
    }

    /// a_{n+1} [T8]
    Vector3 a_next(const Vector3& w) const {
      return (af_ * m_.omega_rate - am_ * m_.a + (Scalar(1) - af_) * w) / (Scalar(1) - am_);
    }
    /// Ω_{n+1} [T8]
    Vector3 omega_next(const Vector3& a1) const {
      return in_.omega + h_ * (Scalar(1) - gamma_) * m_.a + h_ * gamma_ * a1;
    }
    /// hΔq, the body-frame rotation increment [T8]
    Vector3 increment(const Vector3& a1) const {
      return h_ * (in_.omega + h_ * (Scalar(0.5) - beta_) * m_.a + h_ * beta_ * a1);
    }
    /// dΩ_{n+1}/dw = γ′ I [T8]
    Scalar gamma_prime() const { return gamma_p_; }
    /// d(hΔq)/dw = β′ I [T8]
    Scalar beta_prime() const { return beta_p_; }

    /// r(w) [T9]; with K, S(w) = J + γ′(Ω̂J − Π̂) − γ′ ∂τ/∂Ω − β′ ∂τ/∂w T(hΔq).
    bool operator()(const Vector3& w, Vector3& r, Matrix3* K) const {
      const Matrix3& J = scene_.body().inertia();
      const Vector3 a1 = a_next(w);
      const Vector3 omega1 = omega_next(a1);
      const Vector3 q = increment(a1);
      const Matrix3 Q = SO3<Scalar>::exp_matrix(q);
      const Vector3 Pi1 = scene_.momentum(omega1);
      Matrix3 d_rot, d_om;
      const Vector3 tau = detail::end_torque(scene_, caches_, Q, omega1, K ? &d_rot : nullptr, K ? &d_om : nullptr);
      r = J * w - Pi1.cross(omega1) - tau;  // [T9]
      if (K) {
        using G = SO3<Scalar>;
        *K = J + gamma_p_ * (G::hat(omega1) * J - G::hat(Pi1)) - gamma_p_ * d_om -
             beta_p_ * d_rot * G::right_tangent(q);
      }
      return true;
    }

   private:
    const Scene& scene_;
    const State<Scalar>& in_;
    const GenAlphaMemory<Scalar>& m_;
    Scalar h_;
    typename Scene::Caches caches_;
    Scalar am_, af_, beta_, gamma_, gamma_p_, beta_p_;
  };

  /// The memory to step from: `m` if it was built for h, else a fresh start at `in` [T10]:
  /// Ω̇_0 from the equations of motion, a_0 = Ω̇_0 (plain) or Ω̇_0 + (α_m − α_f)hΩ̈_0.
  template <class Scene>
  GenAlphaMemory<typename Scene::Scalar> started_memory(const Scene& scene, const State<typename Scene::Scalar>& in,
                                                        typename Scene::Scalar h,
                                                        const GenAlphaMemory<typename Scene::Scalar>& m) const {
    using Scalar = typename Scene::Scalar;
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
    if (m.started && m.h == h) return m;
    GenAlphaMemory<Scalar> fresh;
    const auto caches = scene.caches(in.rotation.matrix(), in.time);
    const Matrix3& J_inv = scene.body().inertia_inverse();
    const Vector3 Pi = scene.momentum(in.omega);
    Matrix3 d_rot, d_om;
    const bool pert = start == Start::perturbed;
    const Vector3 tau = detail::end_torque(scene, caches, Matrix3::Identity(), in.omega, pert ? &d_rot : nullptr,
                                           pert ? &d_om : nullptr);
    fresh.omega_rate = J_inv * (Pi.cross(in.omega) + tau);  // J Ω̇ = Π × Ω + τ
    fresh.a = fresh.omega_rate;
    if (pert) {
      // Ω̈_0 = J⁻¹[JΩ̇ × Ω + Π × Ω̇ + ∂τ/∂w Ω + ∂τ/∂Ω Ω̇]  [T10] (Λ̇ = Λ Ω̂)
      const Vector3& wd = fresh.omega_rate;
      const Matrix3& J = scene.body().inertia();
      const Vector3 jerk = J_inv * ((J * wd).cross(in.omega) + Pi.cross(wd) + d_rot * in.omega + d_om * wd);
      const Coefficients c = coefficients();
      fresh.a += (Scalar(c.alpha_m) - Scalar(c.alpha_f)) * h * jerk;
    }
    fresh.h = h;
    fresh.started = true;
    return fresh;
  }

  /// One step: Newton (with backtracking) on [T9] from w⁰ = Ω̇_n, then [T8].
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h,
                                          const NewtonOptions<typename Scene::Scalar>& options,
                                          State<typename Scene::Scalar>& out,
                                          GenAlphaMemory<typename Scene::Scalar>& memory) const {
    using Scalar = typename Scene::Scalar;
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
    const Scalar tiny = detail::tiny_scale<Scalar>();
    StepReport<Scalar> rep;
    const GenAlphaMemory<Scalar> m = started_memory(scene, in, h, memory);
    if (!detail::all_finite(m.omega_rate) || !detail::all_finite(m.a)) {
      rep.status = StepStatus::non_finite;
      return rep;
    }
    const Residual<Scene> res(*this, scene, in, h, m);
    // Row weights: the sizes of the terms of [T9] at step n (caveat 5 of §11).
    const Matrix3& J = scene.body().inertia();
    const Vector3 Pi = scene.momentum(in.omega);
    const Scalar weight = J.norm() * (m.omega_rate.norm() + m.a.norm()) + Pi.norm() * in.omega.norm() +
                          (Pi.cross(in.omega) - J * m.omega_rate).norm() + tiny;
    const Vector3 W = Vector3::Constant(weight);
    Vector3 w = m.omega_rate;  // predictor w⁰ = Ω̇_n [T9]
    const Vector3 w0 = w;
    Matrix3 K;
    rep = detail::damped_newton<3>(res, w, options,
                                   DampedNewtonSolve<3, Scalar>{.weights = W, .x_scale = weight / J.norm(), .tangent = &K});
    if (!rep.ok()) return rep;
    const Vector3 a1 = res.a_next(w);
    const Vector3 q = res.increment(a1);
    // Branch rule (NewtonOptions): the rotation increment below max_increment, its
    // Newton correction β′|w − w⁰| below max_correction, and det S > 0 (S → J as h → 0).
    if (!detail::on_branch(options, q.norm(), Scalar(std::abs(res.beta_prime()) * (w - w0).norm()),
                           Scalar(K.determinant()))) {
      rep.status = StepStatus::wrong_branch;
      return rep;
    }
    out.rotation = in.rotation * SO3<Scalar>::exp(q);  // Λ_{n+1} = Λ_n exp(hΔq̂)
    out.omega = res.omega_next(a1);
    out.time = in.time + h;
    memory = m;
    memory.omega_rate = w;
    memory.a = a1;
    if (!detail::all_finite(out.omega) || !detail::all_finite(a1)) rep.status = StepStatus::non_finite;
    return rep;
  }
};

}  // namespace trompo
