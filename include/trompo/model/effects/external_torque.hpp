#pragma once
// External torques given as functions of time, taken at the mid time t_{n+½} (docs/theory.md §5).
//
//   auto f = [](double t) { return Eigen::Vector3d(0.1 * std::sin(t), 0, 0); };
//   Scene<double, BodyTorque<double, decltype(f)>> scene(body, BodyTorque<double, decltype(f)>(f));
//   auto g = body_torque<double>(f);                       // the same, deduced
//   ConstantSpaceTorque<double> s(Eigen::Vector3d(0, 0, 0.5));  // a constant spatial torque
//
// BodyTorque: T(t) is fixed in the body (a thruster); it acts at the mid configuration
//   Λ_n R_mid, so in the frame of step n it is R_mid T(t_{n+½}).
// SpaceTorque: S(t) is fixed in space; in the body at Λ_n R it is (Λ_n R)ᵀS, i.e. Λ_nᵀS
//   in the frame of step n whatever R: it is computed once per step, in the cache.
//
// Both obey the discrete power identity of §5, H_{n+1} − H_n = h Ω_m·T_m, where
// Ω_m·R_mid T = Ω_m·T (R_midᵀΩ_m = Ω_m) and Ω_m·Λ_nᵀS = ω_m·S with ω_m = Λ_nΩ_m the mid
// spatial velocity. A space torque also gives the exact momentum balance
// π_{n+1} − π_n = h S(t_{n+½}) in the Simo family and GB [T4] (left-multiply [T1] by Λ_n).
//
// The callable is a template parameter, stored by value and called once per step (no
// std::function, no allocation). It takes the time and returns a 3-vector; a non-finite
// value makes the step report non_finite.
#include <Eigen/Core>
#include <type_traits>
#include <utility>

#include "trompo/model/effects/effect.hpp"
#include "trompo/errors.hpp"
#include "trompo/lie/so3.hpp"

namespace trompo {

/// A constant vector as a function of time: the callable of the constant torques.
template <class Scalar>
struct ConstantVector {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// The constant value.
  Vector3 value;
  /// Implicit on purpose, from any 3-vector expression: ConstantBodyTorque<double>(v)
  /// reads naturally. Throws invalid_input on a non-finite vector.
  template <class Derived>
  ConstantVector(const Eigen::MatrixBase<Derived>& v) : value(v) {  // NOLINT(google-explicit-constructor)
    if (!detail::all_finite(value)) detail::fail("torque: non-finite constant torque ", detail::to_text(value));
  }
  /// The value at any time t.
  const Vector3& operator()(Scalar /*t*/) const { return value; }
};

/// A body-fixed torque T(t), sampled at t_{n+½}.
template <class Scalar_, class F>
class BodyTorque {
 public:
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// An applied torque, taken at the step's mid configuration and mid time (effect.hpp).
  using kind = torque_kind;
  static_assert(std::is_invocable_v<const F&, Scalar>, "BodyTorque: F must be callable as f(t)");

  /// From a callable f(t) returning the body torque as an Eigen::Vector3 (a value, not an expression).
  explicit BodyTorque(F f) : f_(std::move(f)) {}

  /// The callable T(t).
  const F& function() const { return f_; }
  /// The callable, to change between steps (the sampled driver sets a held torque's value).
  F& function() { return f_; }

  /// T = T(t_{n+½}) in the body.
  struct Cache {
    /// T(t_{n+½}), body axes.
    Vector3 T;
  };
  /// Samples T at the mid time of the step.
  Cache cache(const Matrix3& /*Lambda_n*/, Scalar t_mid) const { return {Vector3(f_(t_mid))}; }

  /// R_mid T: the body torque at Λ_n R_mid, expressed in the frame of step n.
  Vector3 torque(const Cache& c, const Matrix3& R_mid, const Vector3& /*omega_mid*/) const { return R_mid * c.T; }
  /// ∂/∂w of R exp(ŵ) T = R ŵ T = −R T̂ w.
  Matrix3 torque_jacobian_rotation(const Cache& c, const Matrix3& R_mid, const Vector3&) const {
    return -R_mid * SO3<Scalar>::hat(c.T);
  }
  /// Zero: the torque does not depend on Ω.
  Matrix3 torque_jacobian_omega(const Cache&, const Matrix3&, const Vector3&) const { return Matrix3::Zero(); }

 private:
  F f_;
};

/// A space-fixed torque S(t), sampled at t_{n+½}.
template <class Scalar_, class F>
class SpaceTorque {
 public:
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// An applied torque, taken at the step's mid configuration and mid time (effect.hpp).
  using kind = torque_kind;
  static_assert(std::is_invocable_v<const F&, Scalar>, "SpaceTorque: F must be callable as f(t)");

  /// From a callable f(t) returning the space torque as an Eigen::Vector3 (a value, not an expression).
  explicit SpaceTorque(F f) : f_(std::move(f)) {}

  /// The callable S(t).
  const F& function() const { return f_; }

  /// s = Λ_nᵀ S(t_{n+½}): the spatial torque in the frame of step n.
  struct Cache {
    /// Λ_nᵀ S(t_{n+½}), the space torque in the body frame of step n.
    Vector3 s;
  };
  /// Samples S at the mid time of the step and pulls it back to frame n.
  Cache cache(const Matrix3& Lambda_n, Scalar t_mid) const { return {Lambda_n.transpose() * Vector3(f_(t_mid))}; }

  /// (Λ_n R)ᵀS seen from frame n is R (Λ_n R)ᵀ S = Λ_nᵀ S = s, whatever R.
  Vector3 torque(const Cache& c, const Matrix3& /*R_mid*/, const Vector3& /*omega_mid*/) const { return c.s; }
  /// Zero: seen from frame n the torque does not depend on the rotation.
  Matrix3 torque_jacobian_rotation(const Cache&, const Matrix3&, const Vector3&) const { return Matrix3::Zero(); }
  /// Zero: the torque does not depend on Ω.
  Matrix3 torque_jacobian_omega(const Cache&, const Matrix3&, const Vector3&) const { return Matrix3::Zero(); }

 private:
  F f_;
};

/// A constant body torque (a fixed thruster; trompo-simulate --torque).
template <class Scalar>
using ConstantBodyTorque = BodyTorque<Scalar, ConstantVector<Scalar>>;
/// A constant spatial torque (trompo-simulate --space-torque).
template <class Scalar>
using ConstantSpaceTorque = SpaceTorque<Scalar, ConstantVector<Scalar>>;

/// body_torque<double>(f): a BodyTorque with the callable's type deduced.
template <class Scalar, class F>
BodyTorque<Scalar, std::decay_t<F>> body_torque(F&& f) {
  return BodyTorque<Scalar, std::decay_t<F>>(std::forward<F>(f));
}
/// space_torque<double>(f): a SpaceTorque with the callable's type deduced.
template <class Scalar, class F>
SpaceTorque<Scalar, std::decay_t<F>> space_torque(F&& f) {
  return SpaceTorque<Scalar, std::decay_t<F>>(std::forward<F>(f));
}

}  // namespace trompo
