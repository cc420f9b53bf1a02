#pragma once
// The compensated state (docs/theory.md §18): what rounding left out of a trajectory's
// Ω and quaternion, carried from one step to the next in the scheme's memory.
//
// An exact scheme keeps H and μ to the round-off of its own equations, but the stored
// state is rounded once a step, and those roundings walk: H and μ drift like √N·ε
// (6.9e-13 after 2.7·10⁶ steps of HT0). A step whose update is written as a small
// increment (the Simo schemes: Ω_{n+1} = Ω_n + 2y/h, Λ_{n+1} = Λ_n + Λ_n(exp Θ̂ − I))
// can add that increment to Ω_n + r_n instead of Ω_n, r_n the residue the last step left,
// and keep the new residue: the state is then carried to O(ε²), and what is left per step
// is the increment's own rounding, O(ε·hΩ) [K4]. Simo-κ, collocation and the LGVI carry it
// (their option `compensated`); their memory is CompensatedMemory.
#include <Eigen/Core>

#include "trompo/lie/compensated.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"
#include "trompo/schemes/history.hpp"

namespace trompo {

/// The residue of a trajectory's state: Ω + `omega` and q + `rotation` are its values to
/// O(ε²). It belongs to the state the step that wrote it produced (`omega_at`,
/// `rotation_at`); handed any other state (set by hand, or a first step), a step starts
/// from a zero residue. Default-constructed: zero.
template <class Scalar>
struct StateResidue {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A quaternion's coefficients (Eigen's order x, y, z, w).
  using Coefficients = typename SO3<Scalar>::Coefficients;

  Vector3 omega = Vector3::Zero();               ///< Ω's residue
  Coefficients rotation = Coefficients::Zero();  ///< the unit quaternion's residue
  Vector3 omega_at = Vector3::Zero();            ///< the Ω it belongs to
  Coefficients rotation_at = Coefficients::Zero();  ///< the quaternion it belongs to

  /// Whether this residue was left by the step that produced `s` (bit for bit).
  bool belongs_to(const State<Scalar>& s) const {
    return omega_at == s.omega && rotation_at == s.rotation.unit_quaternion().coeffs();
  }

  /// The state at the end of a step from `in` with Ω's increment `d_omega` and the rotation
  /// increment Θ (c its half-angle pair), with the residue carried [K2]–[K3]; `next` is set
  /// to the residue of `out`. `*this` is the residue of the step's start (read only).
  void advance(const State<Scalar>& in, const Vector3& d_omega, const Vector3& Theta,
               const detail::HalfAngle<Scalar>& c, Scalar h, State<Scalar>& out, StateResidue& next) const {
    const bool carried = belongs_to(in);
    next.rotation = carried ? rotation : Coefficients::Zero();
    out.rotation = in.rotation.times_exp_carried(Theta, c, next.rotation);
    const Vector3 small = carried ? Vector3(omega + d_omega) : d_omega;
    for (int i = 0; i < 3; ++i) {
      const detail::Carried<Scalar> s = detail::two_sum(in.omega(i), small(i));
      out.omega(i) = s.hi;
      next.omega(i) = s.lo;
    }
    out.time = in.time + h;
    next.omega_at = out.omega;
    next.rotation_at = out.rotation.unit_quaternion().coeffs();
  }
};

/// The per-trajectory memory of Simo-κ, collocation and the LGVI: the history predictor's
/// increments and tangent (IncrementHistory), and the compensated state's residue.
template <class Scalar>
struct CompensatedMemory : IncrementHistory<Scalar> {
  StateResidue<Scalar> residue;  ///< what rounding left out of the state (compensated steps)
};

}  // namespace trompo
