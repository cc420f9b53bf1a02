#pragma once
// The state of a rotating body: attitude Λ (body → space), body angular velocity Ω, time.
#include <Eigen/Core>
#include <cmath>
#include <limits>

#include "trompo/errors.hpp"
#include "trompo/lie/so3.hpp"

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

namespace detail {
/// Whether a step's result may be committed: finite Ω, quaternion and time, and a unit
/// quaternion (to 16ε in |q|²). The last line of defence for "no NaN behind ok": the
/// Stepper applies it to every scheme's result, or, for a scheme that writes its memory
/// only on success (scheme.hpp, writes_memory_on_success), the scheme applies it itself
/// before it records anything, and it is the step's only finiteness check of the result.
template <class Scalar>
bool committable(const State<Scalar>& s) {
  using std::abs;
  // |q|² − 1 ≤ 16ε is false for a NaN or infinite coefficient too: no separate test of q.
  const Scalar q2 = s.rotation.unit_quaternion().squaredNorm();
  return all_finite(s.omega) && std::isfinite(static_cast<double>(s.time)) &&
         abs(q2 - Scalar(1)) <= Scalar(16) * std::numeric_limits<Scalar>::epsilon();
}
}  // namespace detail

}  // namespace trompo
