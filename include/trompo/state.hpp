#pragma once
// The state of a rotating body: attitude Λ (body → space), body angular velocity Ω, time.
#include <Eigen/Core>

#include "trompo/errors.hpp"
#include "trompo/so3.hpp"

namespace trompo {

/// The state of a rigid body: its attitude Λ, body angular velocity Ω and time t.
template <class Scalar_>
struct State {
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;

  SO3<Scalar> rotation;                  ///< Λ
  Vector3 omega = Vector3::Zero();       ///< Ω, body frame
  Scalar time = Scalar(0);               ///< t

  /// Throws invalid_input if Ω or t is not finite (the rotation is valid by construction).
  void validate() const {
    if (!detail::all_finite(omega)) detail::fail("state: non-finite omega ", detail::to_text(omega));
    if (!std::isfinite(static_cast<double>(time))) detail::fail("state: non-finite time ", time);
  }
};

}  // namespace trompo
