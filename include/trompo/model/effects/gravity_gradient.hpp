#pragma once
// Gravity gradient on a circular orbit: the attitude potential of a rigid satellite
// (docs/theory.md §15, [G1]–[G6]; docs/spacecraft.md).
//
//   RigidBody<double> body(Eigen::Vector3d(100, 120, 80));
//   GravityGradient<double> gg(body, 0.0011, Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX());
//   Scene<double, GravityGradient<double>> scene(body, gg);     // = cases::Satellite<double>
//
// The orbit (rate n, normal ô, radial direction r̂₀ ⟂ ô at t = 0) turns the radial
// direction r̂(t) = cos(nt) r̂₀ + sin(nt) ô×r̂₀ [G1]; the body sees it as c = Λᵀr̂(t), and
// MacCullagh's formula gives the potential and body torque [G2]
//
//   V(Λ, t) = (3n²/2) cᵀJc,     τ = 3n² c × (Jc).
//
// V depends on t: H is not conserved, the Jacobi integral E_J = H − n ô·π is [G4]. The
// effect supplies the term −n ô·π (rotating_frame_energy) and the scene adds it to
// energy(), so every report of "H" for a satellite scene is E_J.
//
// Time. Like the other time-dependent effects, the time enters through the per-step cache:
// the implicit schemes freeze it at the step's mid time t_{n+½} (their energy statements then
// hold for the frozen V, not for E_J), RK4 and dopri5 sample it at their stages, and the
// splittings at the split clock, which advances in the free flow only [S13], [G5].
#include <Eigen/Core>
#include <cmath>

#include "trompo/model/body.hpp"
#include "trompo/model/effects/effect.hpp"
#include "trompo/errors.hpp"
#include "trompo/lie/so3.hpp"

namespace trompo {

/// Gravity gradient of a circular orbit on a rigid body: V = (3n²/2) cᵀJc, c = Λᵀr̂(t)
/// (docs/theory.md [G1]–[G4]).
template <class Scalar_>
class GravityGradient {
 public:
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// A conservative effect (enters the energy; a kick of the splittings).
  using kind = potential_kind;
  /// V is quadratic in Λ: the closed forms of Simo-κ (19) and [T2] do not hold.
  static constexpr bool linear_in_rotation = false;
  /// V depends on time: the scene's energy is the Jacobi integral, not H (scene.hpp).
  static constexpr bool time_dependent = true;

  /// The body's inertia J (about the centre of mass), the orbit rate n ≥ 0 (rad/s), the
  /// orbit normal ô and the radial direction r̂₀ at t = 0. ô and r̂₀ are normalised and
  /// must then be orthogonal (|ô·r̂₀| ≤ 1e-9); throws invalid_input naming the field.
  GravityGradient(const Matrix3& inertia, Scalar n, const Vector3& orbit_normal, const Vector3& radial)
      : J_(inertia),
        n_(n),
        normal_(unit(orbit_normal, "gravity gradient: orbit normal")),
        radial_(unit(radial, "gravity gradient: radial direction")) {
    using std::abs;
    if (!std::isfinite(static_cast<double>(n)) || !(n >= Scalar(0)))
      detail::fail("gravity gradient: orbit rate n must be finite and >= 0, got ", n);
    if (!detail::all_finite(J_)) detail::fail("gravity gradient: non-finite inertia ", detail::to_text(J_));
    if (!(abs(normal_.dot(radial_)) <= Scalar(1e-9)))
      detail::fail("gravity gradient: radial direction must be orthogonal to the orbit normal, got n.r = ",
                   normal_.dot(radial_));
    along_ = normal_.cross(radial_);  // ô × r̂₀ [G1]
    k_ = Scalar(3) * n_ * n_;
  }
  /// From the body: its inertia J.
  GravityGradient(const RigidBody<Scalar>& body, Scalar n, const Vector3& orbit_normal, const Vector3& radial)
      : GravityGradient(body.inertia(), n, orbit_normal, radial) {}

  /// The orbit rate n (rad/s).
  Scalar orbit_rate() const { return n_; }
  /// ô, the unit orbit normal.
  const Vector3& orbit_normal() const { return normal_; }
  /// r̂₀, the unit radial direction at t = 0.
  const Vector3& radial() const { return radial_; }
  /// J, the inertia the potential is built from.
  const Matrix3& inertia() const { return J_; }

  /// r̂(t) = cos(nt) r̂₀ + sin(nt) ô×r̂₀ [G1].
  Vector3 radial_at(Scalar t) const {
    using std::cos;
    using std::sin;
    const Scalar a = n_ * t;
    return cos(a) * radial_ + sin(a) * along_;
  }

  /// c_n = Λ_nᵀ r̂(t): the radial direction in the body frame of step n.
  struct Cache {
    /// Λ_nᵀ r̂(t).
    Vector3 c;
  };
  /// c_n = Λ_nᵀ r̂(t_mid) for the step (t_mid: the time at which the kick or step samples V).
  Cache cache(const Matrix3& Lambda_n, Scalar t_mid) const { return {Lambda_n.transpose() * radial_at(t_mid)}; }

  /// V(Λ_n R) = (3n²/2) cᵀJc with c = Rᵀc_n [G2].
  Scalar potential(const Cache& cc, const Matrix3& R) const {
    const Vector3 c = R.transpose() * cc.c;
    return k_ / Scalar(2) * c.dot(J_ * c);
  }
  /// R τ, τ = 3n² c × (Jc) at c = Rᵀc_n: the body torque at Λ_n R in frame n [G2].
  Vector3 torque(const Cache& cc, const Matrix3& R) const {
    const Vector3 c = R.transpose() * cc.c;
    return R * Vector3(k_ * c.cross(J_ * c));
  }
  /// ∂/∂w of R exp(ŵ) τ(c(w)), c(w) = exp(−ŵ)c: R(−τ̂ + 3n²(ĉJ − (Jc)^)ĉ) [G3].
  Matrix3 torque_jacobian(const Cache& cc, const Matrix3& R) const {
    const Vector3 c = R.transpose() * cc.c;
    const Vector3 Jc = J_ * c;
    const Matrix3 ch = SO3<Scalar>::hat(c);
    const Vector3 tau = k_ * c.cross(Jc);
    return R * Matrix3(-SO3<Scalar>::hat(tau) + k_ * (ch * J_ - SO3<Scalar>::hat(Jc)) * ch);
  }

  /// −n ô·π: what turns H into the Jacobi integral E_J = H − n ô·π [G4] (scene.hpp adds it
  /// to energy()).
  Scalar rotating_frame_energy(const Vector3& pi) const { return -n_ * normal_.dot(pi); }

 private:
  static Vector3 unit(const Vector3& v, const char* what) {
    if (!detail::all_finite(v) || !(v.norm() > 0)) detail::fail(what, " must be finite and non-zero, got ", detail::to_text(v));
    return v.normalized();
  }
  Matrix3 J_;
  Scalar n_;
  Vector3 normal_;
  Vector3 radial_;
  Vector3 along_;
  Scalar k_ = Scalar(0);  // 3n²
};

}  // namespace trompo
