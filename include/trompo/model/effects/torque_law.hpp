#pragma once
// A torque law of the user's own, τ(t, Λ, Ω), with its Jacobians by forward-mode automatic
// differentiation (docs/theory.md §16, [W7]–[W8]; docs/control.md).
//
//   // a generic callable: Λ and Ω arrive as Eigen matrices of double, or of AutoDiff scalars
//   auto drag = [](double t, const auto& Lambda, const auto& omega) {
//     using T = typename std::decay_t<decltype(omega)>::Scalar;
//     return Eigen::Matrix<T, 3, 1>(-0.02 * omega + Lambda.transpose() * Eigen::Vector3d(0, 0, 1e-3).cast<T>());
//   };
//   auto law = torque_law<double>(drag);                          // body axes
//   auto law_s = torque_law<double, Axes::space>(some_space_law); // space axes
//   Scene<double, decltype(law)> scene(body, law);
//
// The law is an applied torque (effect.hpp, torque_kind): the implicit schemes take it at the
// step's mid configuration Λ_n R_mid and mid velocity Ω_m, so the discrete power balance of
// §5, H_{n+1} − H_n = h Ω_m·τ_m, holds exactly for any law [W7]. Their Newton tangent needs
// ∂τ/∂w (the right perturbation Λ exp(ŵ)) and ∂τ/∂Ω; unless the callable gives them itself
// (a member jacobians(t, Λ, Ω, D_w, D_Ω), in the law's own axes), they are found by calling
// the law once more with Eigen's AutoDiffScalar: Λ(w) = Λ (I + ŵ) and Ω + v, each with three
// derivative directions, at w = v = 0 [W8]. (I + ŵ) is exp(ŵ) to first order, which is all a
// first derivative sees.
//
// Frames. A body-axes law's torque τ_b acts at Λ_n R_mid: in frame n it is R_mid τ_b, and
// ∂/∂w of R exp(ŵ) τ_b(Λ exp(ŵ)) = R(D_w − τ̂_b). A space-axes law's torque τ_s is Λ_nᵀτ_s in
// frame n, with ∂/∂w = Λ_nᵀ D_w.
//
// The callable is stored by value and called with (t, Λ, Ω): t a Scalar, Λ a 3×3 and Ω a
// 3-vector of Scalar or of Eigen::AutoDiffScalar<Vector3>. It returns a 3-vector of the same
// scalar (write it generically, as above). A non-finite torque makes the step report
// non_finite; RK4, the dense output and the explicit predictor call it at their own points.
//
// A law of the wheels' state ([W15]; wheel_torque_law<double>(f)) is called with
// (t, Λ, Ω, speeds), speeds the wheels' speeds relative to the body (an Eigen vector of up to
// 8 entries, of Ω's scalar). Inside a hold the wheels' absolute momenta h_i(t) are a known
// linear law [W2], so Ω_i = h_i(t)/J_s,i − g_i·Ω is a function of (t, Ω), and such a law is a
// law of (t, Λ, Ω) like any other: the scene hands it its ReactionWheels in the step's cache,
// the speeds are formed from the AutoDiff Ω, and ∂τ/∂Ω takes in the −g_i terms by itself. Its
// Jacobians are always by AutoDiff (a `jacobians` member is not read).
#include <Eigen/Core>
#include <type_traits>
#include <unsupported/Eigen/AutoDiff>
#include <utility>

#include "trompo/errors.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/model/effects/effect.hpp"
#include "trompo/model/effects/reaction_wheels.hpp"

namespace trompo {

/// The axes a torque law's value is given in.
enum class Axes {
  body,  ///< body axes: a thruster, a controller's command
  space  ///< inertial axes: a disturbance fixed in space
};

/// A torque law τ(t, Λ, Ω) of the user's own, in body or space axes, with Jacobians by
/// automatic differentiation unless the callable has jacobians() [W7]–[W8]; with
/// `of_wheels`, τ(t, Λ, Ω, speeds) of the scene's reaction wheels' speeds as well [W15].
template <class Scalar_, class F, Axes A = Axes::body, bool of_wheels = false>
class TorqueLaw {
 public:
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// An applied torque, taken at the step's mid configuration and mid velocity (effect.hpp).
  using kind = torque_kind;
  /// The axes of the law's value.
  static constexpr Axes axes = A;
  /// The forward-mode scalar of the Jacobians: three derivative directions.
  using Dual = Eigen::AutoDiffScalar<Vector3>;
  /// The wheels a law of their state reads (the scene's ReactionWheels effect) [W15].
  using Wheels = ReactionWheels<Scalar>;
  /// Whether the law reads the wheels' speeds: the scene then hands it its wheels (scene.hpp).
  static constexpr bool reads_wheels = of_wheels;
  /// Whether the callable gives its own Jacobians (then no AutoDiff pass; not for a law of
  /// the wheels' state).
  static constexpr bool user_jacobians =
      !of_wheels &&
      requires(const F& f, Scalar t, const Matrix3& L, const Vector3& w, Matrix3& Dw, Matrix3& Dv) {
        f.jacobians(t, L, w, Dw, Dv);
      };

  /// From the callable (see the file comment).
  explicit TorqueLaw(F f) : f_(std::move(f)) {}

  /// The callable.
  const F& function() const { return f_; }

  /// The law at (t, Λ, Ω) in its own axes (a law of (t, Λ, Ω) only).
  Vector3 operator()(Scalar t, const Matrix3& Lambda, const Vector3& omega) const
    requires(!of_wheels)
  {
    return Vector3(f_(t, Lambda, omega));
  }

  /// Λ_n, the mid time and, for a law of the wheels' state, the scene's wheels.
  struct Cache {
    Matrix3 Lambda_n;               ///< Λ_n, the attitude at the start of the step
    Scalar t;                       ///< t_{n+½}
    const Wheels* wheels = nullptr;  ///< the scene's wheels (a law of their state only)
  };
  /// Keeps Λ_n and t_{n+½}.
  Cache cache(const Matrix3& Lambda_n, Scalar t_mid) const
    requires(!of_wheels)
  {
    return {Lambda_n, t_mid};
  }
  /// Keeps Λ_n, t_{n+½} and the scene's wheels (the scene calls this one, scene.hpp) [W15].
  Cache cache(const Matrix3& Lambda_n, Scalar t_mid, const Wheels& wheels) const
    requires(of_wheels)
  {
    return {Lambda_n, t_mid, &wheels};
  }

  /// The torque at Λ_n R_mid, Ω_m, in frame n.
  Vector3 torque(const Cache& c, const Matrix3& R_mid, const Vector3& omega_mid) const {
    const Vector3 tau = call(c, c.Lambda_n * R_mid, omega_mid);
    if constexpr (A == Axes::body) return R_mid * tau;
    else return c.Lambda_n.transpose() * tau;
  }

  /// ∂/∂w of the frame-n torque at Λ_n R_mid exp(ŵ), w = 0 [W8].
  Matrix3 torque_jacobian_rotation(const Cache& c, const Matrix3& R_mid, const Vector3& omega_mid) const {
    const Matrix3 Lambda = c.Lambda_n * R_mid;
    Matrix3 D_w;
    Vector3 tau;
    if constexpr (user_jacobians) {
      Matrix3 D_v;
      f_.jacobians(c.t, Lambda, omega_mid, D_w, D_v);
      if constexpr (A == Axes::body) tau = call(c, Lambda, omega_mid);
    } else {
      // Λ(w) = Λ (I + ŵ), w the three derivative directions at 0.
      Eigen::Matrix<Dual, 3, 3> L = Lambda.template cast<Dual>();
      Eigen::Matrix<Dual, 3, 3> W = Eigen::Matrix<Dual, 3, 3>::Identity();
      const Dual w0(Scalar(0), 3, 0), w1(Scalar(0), 3, 1), w2(Scalar(0), 3, 2);
      W(0, 1) = -w2, W(0, 2) = w1, W(1, 0) = w2, W(1, 2) = -w0, W(2, 0) = -w1, W(2, 1) = w0;
      L = (L * W).eval();
      const Eigen::Matrix<Dual, 3, 1> t_ad = call(c, L, omega_mid.template cast<Dual>().eval());
      for (int i = 0; i < 3; ++i) {
        tau(i) = t_ad(i).value();
        D_w.row(i) = t_ad(i).derivatives().transpose();
      }
    }
    if constexpr (A == Axes::body) return R_mid * (D_w - SO3<Scalar>::hat(tau));  // R(D_w − τ̂)
    else return c.Lambda_n.transpose() * D_w;
  }

  /// ∂/∂Ω_m of the frame-n torque [W8].
  Matrix3 torque_jacobian_omega(const Cache& c, const Matrix3& R_mid, const Vector3& omega_mid) const {
    const Matrix3 Lambda = c.Lambda_n * R_mid;
    Matrix3 D_v;
    if constexpr (user_jacobians) {
      Matrix3 D_w;
      f_.jacobians(c.t, Lambda, omega_mid, D_w, D_v);
    } else {
      Eigen::Matrix<Dual, 3, 1> v;
      for (int k = 0; k < 3; ++k) v(k) = Dual(omega_mid(k), 3, k);
      const Eigen::Matrix<Dual, 3, 1> t_ad = call(c, Lambda.template cast<Dual>().eval(), v);
      for (int i = 0; i < 3; ++i) D_v.row(i) = t_ad(i).derivatives().transpose();
    }
    if constexpr (A == Axes::body) return R_mid * D_v;
    else return c.Lambda_n.transpose() * D_v;
  }

 private:
  /// The callable at (t, Λ, Ω) of the cache's time, with the wheels' speeds relative to the
  /// body Ω_i = h_i(t)/J_s,i − g_i·Ω for a law of their state [W15] (of Ω's scalar, so that
  /// AutoDiff sees the −g_i).
  template <class LambdaM, class OmegaV>
  auto call(const Cache& c, const LambdaM& Lambda, const OmegaV& omega) const {
    using T = typename OmegaV::Scalar;
    if constexpr (of_wheels) {
      return Eigen::Matrix<T, 3, 1>(f_(c.t, Lambda, omega, c.wheels->speeds(c.t, Eigen::Matrix<T, 3, 1>(omega))));
    } else {
      return Eigen::Matrix<T, 3, 1>(f_(c.t, Lambda, omega));
    }
  }

  F f_;
};

/// torque_law<double>(f) (body axes) or torque_law<double, Axes::space>(f): a TorqueLaw with
/// the callable's type deduced.
template <class Scalar, Axes A = Axes::body, class F>
TorqueLaw<Scalar, std::decay_t<F>, A> torque_law(F&& f) {
  return TorqueLaw<Scalar, std::decay_t<F>, A>(std::forward<F>(f));
}

/// wheel_torque_law<double>(f): a law τ(t, Λ, Ω, speeds) of the scene's reaction wheels'
/// speeds (relative to the body) as well [W15]; the scene must have a ReactionWheels effect.
template <class Scalar, Axes A = Axes::body, class F>
TorqueLaw<Scalar, std::decay_t<F>, A, true> wheel_torque_law(F&& f) {
  return TorqueLaw<Scalar, std::decay_t<F>, A, true>(std::forward<F>(f));
}

}  // namespace trompo
