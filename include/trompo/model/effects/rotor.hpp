#pragma once
// A gyrostat rotor: a wheel spinning at constant rate relative to the body, which adds a
// constant internal angular momentum h_r (body frame) to the body's: Π = JΩ + h_r.
//
//   Scene<double, Rotor<double>> satellite(body, Rotor<double>(Eigen::Vector3d(0, 4, 0)));
//
// Euler's equations become d(JΩ + h_r)/dt + Ω × (JΩ + h_r) = T. Dotting with Ω, the rotor
// drops out: H = ½ Ω·JΩ + V is conserved (the wheel's own spin energy is constant and
// left out), and so are π = Λ(JΩ + h_r) without load and μ = γ·π under gravity.
// Discretely: [T1] dotted with Θ gives Θ·(Π_{n+1} − Π_n) = Θ·J(Ω_{n+1} − Ω_n) since
// Θ·exp(Θ̂)v = Θ·v and h_r cancels, so H stays exact in Simo-κ, collocation and GB [T4]
// (and [T5]); Λ_n·[T1] is the exact balance of π, as without the rotor. The scene adds
// h_r in Scene::momentum(), which every scheme uses for Π.
#include <Eigen/Core>

#include "trompo/model/effects/effect.hpp"
#include "trompo/errors.hpp"

namespace trompo {

/// A gyrostat rotor: a constant internal angular momentum h_r in body axes, so that
/// Π = JΩ + h_r (docs/theory.md §5). H and π = Λ(JΩ + h_r) are kept by the exact schemes.
template <class Scalar_>
class Rotor {
 public:
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// An internal momentum (effect.hpp).
  using kind = rotor_kind;

  /// h_r: the rotor's angular momentum relative to the body, in body axes (finite).
  explicit Rotor(const Vector3& h_r) : h_(h_r) {
    if (!detail::all_finite(h_r)) detail::fail("rotor: non-finite angular momentum ", detail::to_text(h_r));
  }

  /// h_r, added to JΩ in Π = JΩ + h_r.
  const Vector3& rotor_momentum() const { return h_; }

  /// Nothing to keep per step. One initialised byte all the same: GCC 12 at -O1 takes an
  /// empty object passed by reference for "may be used uninitialized" (-Wmaybe-uninitialized).
  struct Cache {
    char unused = 0;  ///< the initialised byte
  };
  /// Nothing to prepare per step.
  Cache cache(const Matrix3& /*Lambda_n*/, Scalar /*t_mid*/) const { return {}; }

 private:
  Vector3 h_;
};

}  // namespace trompo
