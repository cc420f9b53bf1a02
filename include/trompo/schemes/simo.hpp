#pragma once
// The Simo family, eqs. (9)–(11), (17)–(19), restated as THEORY [T1]–[T3].
//
// Unknown: Θ, the incremental rotation vector in the body frame of step n, with
//   Ω_{n+1} = 2Θ/h − Ω_n,   Λ_{n+1} = Λ_n exp(Θ̂),   Λ_{n+ξ} = Λ_n exp(ξΘ̂).
// Residual [T1], with the effects of the scene (THEORY §5):
//   R(Θ) = exp(Θ̂) Π_{n+1} − Π_n − h κ τ_c(Λ_{n+α}) − h τ_a(Λ_{n+½}, Θ/h)
// where τ_c is the conservative torque (gravity), τ_a the applied torques, both in frame
// n, and Π = JΩ + h_r. The three schemes differ only in α and κ:
//   SimoAlpha        α fixed in [0,1], κ = 1          (α = ½: Simo–Wong)
//   SimoCollocation  κ = 1, α = α(Θ) from (17)/[T2]    (energy exact)
//   SimoKappa        α = ½, κ = sin(θ/2)/(θ/2), (19)   (energy exact)
#include <Eigen/Core>
#include <cmath>

#include "trompo/errors.hpp"
#include "trompo/newton.hpp"
#include "trompo/schemes/step_data.hpp"
#include "trompo/so3.hpp"
#include "trompo/state.hpp"

namespace trompo {

/// Simo-α: midpoint family with the torque at Λ_{n+α}; μ exact, H to O(h²).
struct SimoAlpha {
  double alpha = 0.5;
  SimoAlpha() = default;
  explicit SimoAlpha(double a) : alpha(a) {
    if (!(a >= 0.0 && a <= 1.0)) detail::fail("simo-alpha: alpha must be in [0, 1], got ", a);
  }
  static constexpr const char* name = "simo-alpha";
};

/// Simo collocation: α solved each step so that the energy balance is exact, [T2].
struct SimoCollocation {
  static constexpr const char* name = "simo-collocation";
};

/// Simo-κ: α = ½ and the conservative torque scaled by κ(θ), (19); energy exact.
struct SimoKappa {
  static constexpr const char* name = "simo-kappa";
};

namespace detail {

/// The collocation root of [T2] for potentials linear in Λ, written about the midpoint:
/// with s = α − ½ and f(ξ) = A + B′ cos sθ + C′ sin sθ, the condition f(1) − f(0) = f′(α)
/// reads C′(cos sθ − κ) = B′ sin sθ. With t = tan(sθ/2) it is the quadratic
///   C′(1+κ) t² + 2B′ t − C′(1−κ) = 0,
/// whose small root (the α nearest ½) we take in the cancellation-free form.
/// B′ = n·J_c n and C′ = −n·τ_c come from the torque at the midpoint (f″(½) = −θ²B′,
/// f′(½) = θC′). θ = 0 or B′ = C′ = 0 (sleeping top) give α = ½.
template <class Scalar>
Scalar collocation_alpha(Scalar theta, Scalar B, Scalar C) {
  using std::atan;
  using std::sqrt;
  if (theta == Scalar(0) || (B == Scalar(0) && C == Scalar(0))) return Scalar(0.5);
  const Scalar omk = one_minus_kappa(theta);       // 1 − κ, no cancellation
  const Scalar opk = Scalar(2) - omk;              // 1 + κ
  const Scalar root = sqrt(B * B + C * C * omk * opk);
  const Scalar t = C * omk / (B + (B >= Scalar(0) ? root : -root));
  Scalar s = Scalar(2) * atan(t) / theta;
  // The mean-value theorem puts a root in (0,1); guard the last ulp.
  if (s > Scalar(0.5)) s = Scalar(0.5);
  if (s < Scalar(-0.5)) s = Scalar(-0.5);
  return Scalar(0.5) + s;
}

template <class Scheme, class Scene>
class SimoResidual {
 public:
  using Scalar = typename Scene::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  using G = SO3<Scalar>;

  SimoResidual(const Scheme& scheme, const StepData<Scene>& d) : scheme_(scheme), d_(d) {}

  /// [T1] and its tangent [T3] at Θ = hΩ_n + y. Newton's unknown is y, the departure
  /// from the rigid rotation, so that Ω_{n+1} = Ω_n + 2y/h adds a small correction to
  /// Ω_n instead of subtracting two large numbers (2Θ/h − Ω_n): the latter leaves a
  /// biased round-off in the spin that makes H and μ drift like N·ε over long runs.
  /// Always in the domain (T is singular only at 2π, which the branch rule excludes).
  bool operator()(const Vector3& y, Vector3& R, Matrix3& K, Scalar& scale) const {
    const Scene& scene = d_.scene;
    const Scalar h = d_.h;
    const Matrix3& J = scene.body().inertia();
    const Vector3 Theta = h * d_.omega_n + y;
    const Matrix3 Q = G::exp_matrix(Theta);
    const Vector3 omega_next = d_.omega_n + Scalar(2) * y / h;  // (9): Ω_{n+1} = 2Θ/h − Ω_n
    const Vector3 Pi_next = scene.momentum(omega_next);
    const Vector3 QPi = Q * Pi_next;
    R = QPi - d_.Pi_n;                                                  // [T1] momentum part
    K = Q * ((Scalar(2) / h) * J - G::hat(Pi_next) * G::right_tangent(Theta));  // [T3] first line
    scale = d_.Pi_n.norm() + QPi.norm();

    if constexpr (Scene::has_potential) add_conservative(Theta, Q, R, K, scale);
    if constexpr (Scene::has_applied_torque) {
      // τ_a at Λ_{n+½}, Ω_m = Θ/h (THEORY §5); ∂/∂Θ through w = ½T(Θ/2)δΘ and Ω_m.
      const Vector3 half = Theta / Scalar(2);
      Matrix3 d_rot, d_omega;
      const Vector3 tau = scene.applied_torque(d_.caches, G::exp_matrix(half), Theta / h, &d_rot, &d_omega);
      R -= h * tau;
      K -= (h / Scalar(2)) * d_rot * G::right_tangent(half) + d_omega;
      scale += std::abs(h) * tau.norm();
    }
    return true;
  }

 private:
  void add_conservative(const Vector3& Theta, const Matrix3& Q, Vector3& R, Matrix3& K, Scalar& scale) const {
    static_assert(Scene::potentials_linear,
                  "the Simo schemes need potentials linear in the rotation (uniform gravity); "
                  "general potentials are not implemented yet");
    const Scene& scene = d_.scene;
    const Scalar h = d_.h;
    const Scalar theta = Theta.norm();
    Scalar alpha(0.5);
    Scalar kappa(1);
    if constexpr (std::is_same_v<Scheme, SimoAlpha>) {
      alpha = Scalar(scheme_.alpha);
    } else if constexpr (std::is_same_v<Scheme, SimoKappa>) {
      kappa = detail::kappa(theta);                                    // (19)
    }

    if constexpr (std::is_same_v<Scheme, SimoCollocation>) {
      // α(Θ) from [T2], via the midpoint torque and its Jacobian.
      const Matrix3 R_half = G::exp_matrix(Theta / Scalar(2));
      Matrix3 J_half;
      const Vector3 tau_half = scene.conservative_torque(d_.caches, R_half, &J_half);
      Scalar B(0), C(0);
      if (theta > Scalar(0)) {
        const Vector3 n = Theta / theta;
        B = n.dot(J_half * n);   // f″(½) = −θ²B′
        C = -n.dot(tau_half);    // f′(½) = θC′
      }
      alpha = collocation_alpha(theta, B, C);
    }

    const Vector3 a_Theta = alpha * Theta;
    const Matrix3 R_alpha = G::exp_matrix(a_Theta);
    Matrix3 J_alpha;
    const Vector3 tau = scene.conservative_torque(d_.caches, R_alpha, &J_alpha);
    R -= h * kappa * tau;                                                 // [T1] load term
    K -= (h * kappa * alpha) * J_alpha * G::right_tangent(a_Theta);       // [T3] second line
    scale += std::abs(h) * tau.norm();

    if constexpr (std::is_same_v<Scheme, SimoKappa>) {
      // [T3] third line: −h τ ⊗ ∇κ, ∇κ = (κ′(θ)/θ) Θ.
      K -= (h * detail::kappa_prime_over_theta(theta)) * tau * Theta.transpose();
    }
    if constexpr (std::is_same_v<Scheme, SimoCollocation>) {
      // [T3] fourth line: −hκ (∂τ/∂α) ⊗ ∇α with ∂τ/∂α = J_α Θ. ∇α by implicit
      // differentiation of g(α, Θ) = f′(α) − f(1) + f(0) = 0, f(ξ) = V(Λ_n exp(ξΘ̂)):
      //   ∂g/∂α = f″(α) = −Θ·J_α Θ
      //   ∇_Θ f′(α) = −τ_α − α T(αΘ)ᵀ J_αᵀ Θ,   ∇_Θ f(1) = −T(Θ)ᵀ Qᵀ τ_1
      const Vector3 dtau_dalpha = J_alpha * Theta;
      const Scalar f2 = -Theta.dot(dtau_dalpha);
      const Scalar f2_floor = std::numeric_limits<Scalar>::epsilon() * J_alpha.norm() * theta * theta;
      if (theta > Scalar(0) && std::abs(f2) > f2_floor) {
        const Vector3 tau_1 = scene.conservative_torque(d_.caches, Q);
        const Vector3 grad_f1_alpha =
            -tau - alpha * G::right_tangent(a_Theta).transpose() * (J_alpha.transpose() * Theta);
        const Vector3 grad_f_1 = -G::right_tangent(Theta).transpose() * (Q.transpose() * tau_1);
        const Vector3 grad_alpha = -(grad_f1_alpha - grad_f_1) / f2;
        K -= h * dtau_dalpha * grad_alpha.transpose();
      }
    }
  }

  const Scheme& scheme_;
  const StepData<Scene>& d_;
};

/// One step of a Simo scheme: Newton on [T1] from the predictor, then (9)–(10).
template <class Scheme, class Scene>
StepReport<typename Scene::Scalar> simo_step(const Scheme& scheme, const Scene& scene,
                                             const State<typename Scene::Scalar>& in,
                                             typename Scene::Scalar h,
                                             const NewtonOptions<typename Scene::Scalar>& opt,
                                             State<typename Scene::Scalar>& out) {
  using Scalar = typename Scene::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  const StepData<Scene> d(scene, in, h);
  const Vector3 Theta0 = d.predicted_increment();
  // Newton's unknown is y = Θ − hΩ_n (see SimoResidual).
  const Vector3 base = h * in.omega;
  Vector3 y = Theta0 - base;
  StepReport<Scalar> rep = newton(SimoResidual<Scheme, Scene>(scheme, d), y, opt, Theta0.norm());
  if (!rep.ok()) return rep;
  const Vector3 Theta = base + y;
  // Branch rule (NewtonOptions): |Θ| < max_increment, ‖Θ − Θ⁰‖ ≤ max_correction.
  if (!(Theta.norm() < opt.max_increment) || !((Theta - Theta0).norm() <= opt.max_correction)) {
    rep.status = StepStatus::wrong_branch;
    return rep;
  }
  out.rotation = in.rotation * SO3<Scalar>::exp(Theta);   // Λ_{n+1} = Λ_n exp(Θ̂)
  out.omega = in.omega + Scalar(2) * y / h;                // Ω_{n+1} = 2Θ/h − Ω_n  (9)
  out.time = in.time + h;
  if (!all_finite(out.omega) || !all_finite(out.rotation.unit_quaternion().coeffs()))
    rep.status = StepStatus::non_finite;
  return rep;
}

}  // namespace detail
}  // namespace trompo
