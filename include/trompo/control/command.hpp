#pragma once
// What flight software sees at a sample and what it returns (docs/control.md).
//
// A controller is any copyable callable `Command<Scalar> c(const Sample<Scalar>&)`; it may
// keep a memory of its own in its members (the last field for B-dot). The sampled driver
// (drivers/sampled.hpp) calls a copy and keeps that copy only when its command is valid,
// so a rejected command leaves the controller's memory as it was.
#include <Eigen/Core>
#include <cmath>

#include "trompo/model/effects/reaction_wheels.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// The commands a controller returns at a sample, held constant until the next (zero-order
/// hold, [W5]). An empty wheel_torques means "no wheel command" (u = 0).
template <class Scalar>
struct Command {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// Motor torques u_i on the wheels (N m), one per wheel of the scene, or empty.
  typename ReactionWheels<Scalar>::WheelVector wheel_torques;
  /// A body-axes torque (N m): needs a held body torque in the scene (HeldBodyTorque).
  Vector3 body_torque = Vector3::Zero();
  /// A magnetic dipole (A m², body axes): needs a Magnetorquer in the scene.
  Vector3 dipole = Vector3::Zero();

  /// The name of the first non-finite command ("wheel_torques", "body_torque", "dipole"), or null.
  const char* non_finite() const {
    for (Eigen::Index i = 0; i < wheel_torques.size(); ++i)
      if (!std::isfinite(static_cast<double>(wheel_torques(i)))) return "wheel_torques";
    if (!detail::all_finite(body_torque)) return "body_torque";
    if (!detail::all_finite(dipole)) return "dipole";
    return nullptr;
  }
};

/// What a controller reads at a sample t_k: the state after the step that ends at t_k, the
/// wheels' relative speeds and, with magnetorquers, the field in body axes.
template <class Scalar>
struct Sample {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// The sample's index k (t_k = t_0 + kT).
  long long index = 0;
  /// t_k.
  Scalar time = Scalar(0);
  /// The state at t_k (Λ, Ω).
  State<Scalar> state;
  /// Ω_i(t_k), the wheels' speeds relative to the body (empty without wheels).
  typename ReactionWheels<Scalar>::WheelVector wheel_speeds;
  /// The wheels' spin axes as columns (3×N; empty without wheels).
  Eigen::Matrix<Scalar, 3, Eigen::Dynamic, 0, 3, ReactionWheels<Scalar>::max_wheels> wheel_axes;
  /// B(t_k) in body axes (tesla), when the scene has magnetorquers; else zero.
  Vector3 field = Vector3::Zero();
  /// Whether `field` holds the field.
  bool has_field = false;
};

}  // namespace trompo
