#pragma once
// Viscous damping: the body torque T = −c Ω, taken at the step's mid velocity (docs/theory.md §5).
//
//   Scene<double, ViscousDamping<double>> scene(body, ViscousDamping<double>(0.1));
//
// With Ω_m = Θ/h (Simo) or 2e/h (Géradin–Bauchau), both equal to (Ω_n + Ω_{n+1})/2, the
// discrete power identity of §5 gives H_{n+1} − H_n = h Ω_m·T_m = −c h |Ω_m|² ≤ 0 for
// every energy-exact scheme: the energy decays monotonically, to round-off, per step.
// Ω_m is an eigenvector of the mid rotation (exp(½Θ̂)Θ = Θ), so −cΩ_m is the same vector
// in the frame of step n and in the mid frame: no rotation enters, and the torque depends
// on the velocity only.
#include <Eigen/Core>
#include <cmath>

#include "trompo/model/effects/effect.hpp"
#include "trompo/errors.hpp"

namespace trompo {

/// Viscous damping: the body torque T = −cΩ, taken at the step's mid velocity, so that
/// H_{n+1} − H_n = −c h |Ω_m|² (docs/theory.md §5).
template <class Scalar_>
class ViscousDamping {
 public:
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// An applied torque (effect.hpp).
  using kind = torque_kind;

  /// c: the damping coefficient (torque per angular velocity). Any finite value; c ≥ 0
  /// dissipates, c < 0 pumps energy in at the same rate.
  explicit ViscousDamping(Scalar c) : c_(c) {
    if (!std::isfinite(static_cast<double>(c))) detail::fail("damping: non-finite coefficient c = ", c);
  }

  /// c.
  Scalar coefficient() const { return c_; }

  /// Nothing to keep per step. One initialised byte all the same: GCC 12 at -O1 takes an
  /// empty object passed by reference for "may be used uninitialized" (-Wmaybe-uninitialized).
  struct Cache {
    char unused = 0;  ///< the initialised byte
  };
  /// Nothing to prepare per step.
  Cache cache(const Matrix3& /*Lambda_n*/, Scalar /*t_mid*/) const { return {}; }

  /// T_m = −c Ω_m (§5)
  Vector3 torque(const Cache&, const Matrix3& /*R_mid*/, const Vector3& omega_mid) const { return -c_ * omega_mid; }
  /// ∂T_m/∂w = 0: the torque does not depend on the attitude.
  Matrix3 torque_jacobian_rotation(const Cache&, const Matrix3&, const Vector3&) const { return Matrix3::Zero(); }
  /// ∂T_m/∂Ω_m = −c I
  Matrix3 torque_jacobian_omega(const Cache&, const Matrix3&, const Vector3&) const {
    return -c_ * Matrix3::Identity();
  }

 private:
  Scalar c_;
};

}  // namespace trompo
