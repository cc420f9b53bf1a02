#pragma once
// Uniform gravity on a body with a fixed point: V(Λ) = Mgl γ·ΛE, eq. (6).
#include <Eigen/Core>

#include "trompo/model/effects/effect.hpp"
#include "trompo/errors.hpp"
#include "trompo/lie/so3.hpp"

namespace trompo {

/// Uniform gravity: V(Λ) = Mgl γ·ΛE, the heavy top's potential (docs/theory.md §1).
template <class Scalar_>
class UniformGravity {
 public:
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// A conservative effect: enters H (effect.hpp).
  using kind = potential_kind;
  /// V is linear in Λ, so f(ξ) = V(Λ_n exp(ξΘ̂)) = A + B cos ξθ + C sin ξθ ([T2]).
  static constexpr bool linear_in_rotation = true;

  /// Mgl = M g l (any finite value; 0 still costs the arithmetic: a free body is a scene
  /// without gravity), E = body direction from O to the centre of mass, up =
  /// spatial unit vector γ pointing up. E and up are normalised; zero or non-finite
  /// vectors are rejected.
  UniformGravity(Scalar Mgl, const Vector3& E, const Vector3& up = Vector3::UnitZ())
      : Mgl_(Mgl), E_(unit(E, "gravity: centre-of-mass direction E")), up_(unit(up, "gravity: up vector")) {
    if (!std::isfinite(static_cast<double>(Mgl))) detail::fail("gravity: non-finite Mgl ", Mgl);
    load_ = -Mgl_ * up_;  // 𝐠 = −Mgl γ, the paper's load vector
  }

  /// M g l.
  Scalar Mgl() const { return Mgl_; }
  /// E, the unit body vector from O towards the centre of mass.
  const Vector3& com_direction() const { return E_; }
  /// γ, the spatial unit vector pointing up.
  const Vector3& up() const { return up_; }

  /// b = Λ_nᵀ𝐠, the load in the body frame of step n ([T1]).
  struct Cache {
    /// Λ_nᵀ𝐠.
    Vector3 b;
  };
  /// b = Λ_nᵀ𝐠 for the step.
  Cache cache(const Matrix3& Lambda_n, Scalar /*t_mid*/) const { return {Lambda_n.transpose() * load_}; }

  /// V(Λ_n R) = Mgl γ·Λ_n R E = −b·(R E)
  Scalar potential(const Cache& c, const Matrix3& R) const { return -c.b.dot(R * E_); }
  /// (R E) × b: the torque E × Λᵀ𝐠 at Λ_n R, expressed in frame n ([T1]).
  Vector3 torque(const Cache& c, const Matrix3& R) const { return (R * E_).cross(c.b); }
  /// d/dt torque(c, exp(tΩ̂)) at t = 0: (Ω × E) × b, i.e. torque_jacobian(c, I)·Ω.
  Vector3 torque_rate(const Cache& c, const Vector3& omega) const { return omega.cross(E_).cross(c.b); }
  /// torque(c, R) for R = I + a x̂ + b x̂² (8), without forming R:
  /// R E = E + a x×E + b x×(x×E). The Simo residual's torque at exp(Θ̂/2) (simo.hpp).
  Vector3 torque_rodrigues(const Cache& c, const Vector3& x, Scalar a, Scalar b) const {
    const Vector3 xE = x.cross(E_);
    return (E_ + a * xE + b * x.cross(xE)).cross(c.b);
  }
  /// ∂/∂w of (R exp(ŵ) E) × b = b̂ R Ê  (the gravity block of [T3]).
  Matrix3 torque_jacobian(const Cache& c, const Matrix3& R) const {
    return SO3<Scalar>::hat(c.b) * R * SO3<Scalar>::hat(E_);
  }

 private:
  static Vector3 unit(const Vector3& v, const char* what) {
    if (!detail::all_finite(v) || !(v.norm() > 0)) detail::fail(what, " must be finite and non-zero, got ", detail::to_text(v));
    return v.normalized();
  }
  Scalar Mgl_;
  Vector3 E_;
  Vector3 up_;
  Vector3 load_;
};

}  // namespace trompo
