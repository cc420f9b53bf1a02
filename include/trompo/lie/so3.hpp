#pragma once
// SO3<Scalar>: rotations of 3-space (docs/theory.md §2), stored as a unit quaternion.
//
// Names follow Sophus: static exp/hat/vee, member log/inverse/matrix. Added for the
// integrators: the right tangent T(x) of exp and its inverse, and exp_matrix(), the
// Rodrigues matrix used directly inside Newton iterations.
//
// Storage: a unit quaternion with non-negative scalar part is renormalised after every
// product, so a long run stays orthonormal to round-off (no N·ε drift).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <limits>

#include "trompo/lie/compensated.hpp"
#include "trompo/lie/series.hpp"
#include "trompo/errors.hpp"

namespace trompo {

namespace detail {
/// One Newton step for 1/|q| given n2 = |q|² = 1 + δ: q ← q − (δ/2) q, which leaves
/// |q|² − 1 = O(δ²) + round-off, as normalising by √n2 does, without a square root or a
/// division on a stepper's critical path. For products of unit quaternions (δ = O(ε)).
/// Written as a correction (δ = n2 − 1 is exact, (δ/2)q is tiny, so each component is
/// rounded once), not as the factor (3 − n2)/2: that factor, rounded to the spacing of
/// numbers just above 2 when n2 < 1, under-corrects by up to ε/2 with one sign, which left
/// |q| short on every step and drifted μ linearly (HT0, Simo-κ, h = 1/1024: 1.9e-13
/// after 120 s; written as the correction, 2.9e-14, of either sign).
template <class Scalar>
inline void newton_unit(Eigen::Quaternion<Scalar>& q, Scalar n2) {
  const Scalar half_delta = (n2 - Scalar(1)) / Scalar(2);
  q.coeffs() -= half_delta * q.coeffs();
}
}  // namespace detail

/// A rotation of 3-space, stored as a unit quaternion with non-negative scalar part
/// (docs/theory.md §2). SO3d and SO3f are the double and float instances.
template <class Scalar_>
class SO3 {
 public:
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// A quaternion of Scalar.
  using Quaternion = Eigen::Quaternion<Scalar>;

  /// Default tolerance on ‖RᵀR − I‖ (max norm) for accepting a matrix as a rotation.
  static Scalar default_tolerance() {
    return Scalar(1e3) * Eigen::NumTraits<Scalar>::epsilon();
  }

  SO3() : q_(Quaternion::Identity()) {}

  /// x̂: the skew matrix with x̂ a = x × a.
  static Matrix3 hat(const Vector3& x) {
    Matrix3 m;
    m << Scalar(0), -x.z(), x.y(),  //
        x.z(), Scalar(0), -x.x(),   //
        -x.y(), x.x(), Scalar(0);
    return m;
  }

  /// x̂² = x xᵀ − |x|² I, its diagonal written as −(y² + z²), … (no cancellation).
  static Matrix3 hat_squared(const Vector3& x) {
    const Scalar xx = x.x() * x.x(), yy = x.y() * x.y(), zz = x.z() * x.z();
    const Scalar xy = x.x() * x.y(), xz = x.x() * x.z(), yz = x.y() * x.z();
    Matrix3 m;
    m << -(yy + zz), xy, xz,  //
        xy, -(xx + zz), yz,   //
        xz, yz, -(xx + yy);
    return m;
  }

  /// vee: the vector of the skew part of m, (m − mᵀ)/2.
  static Vector3 vee(const Matrix3& m) {
    return Vector3(m(2, 1) - m(1, 2), m(0, 2) - m(2, 0), m(1, 0) - m(0, 1)) / Scalar(2);
  }

  /// exp(x̂), eq. (8), as a rotation: quaternion (cos θ/2, sin(θ/2)/θ x).
  static SO3 exp(const Vector3& x) {
    const detail::HalfAngle<Scalar> c = detail::half_angle(x.norm());
    const Vector3 v = x * (c.kappa / 2);  // sin(θ/2)/θ = ½ sinc(θ/2)
    return SO3(Quaternion(c.cos_half, v.x(), v.y(), v.z()), NoCheck{});
  }

  /// *this · exp(x̂), with c the half-angle pair of |x| (detail::half_angle or
  /// half_angle_from_squared): a step's update Λ_{n+1} = Λ_n exp(Θ̂). The product of two
  /// unit quaternions has |q|² = 1 + δ, δ = O(ε); it is renormalised by one Newton step
  /// for 1/|q| (detail::newton_unit). (For input quaternions use renormalized(), which also rescales.)
  ///
  /// The product is formed as an increment, q (cos(θ/2), v) = q + q (cos(θ/2) − 1, v), so
  /// that its rounding is that of the small increment. Formed directly, the rounding of
  /// q·cos(θ/2) (cos(θ/2) within θ²/8 of 1) leaned to one side and moved μ by a fixed
  /// fraction of ε every step: Simo-κ on HT0 at h = 1.16e-5, 8.6·10⁵ steps, drifted μ by
  /// 6.3e-13 that way, at most 5.6e-14 (a random walk) in increments (cos(θ/2) − 1 from
  /// HalfAngle::cos_half_minus_one, without cancellation).
  SO3 times_exp(const Vector3& x, const detail::HalfAngle<Scalar>& c) const {
    const Vector3 v = x * (c.kappa / 2);  // sin(θ/2)/θ = ½ sinc(θ/2)
    const Scalar cos_half_minus_1 = c.cos_half_minus_one(x.squaredNorm() / 4);  // x = (θ/2)²
    const Quaternion increment = q_ * Quaternion(cos_half_minus_1, v.x(), v.y(), v.z());
    Quaternion q;
    q.coeffs() = q_.coeffs() + increment.coeffs();
    detail::newton_unit(q, q.squaredNorm());
    return SO3(q, NoCheck{});
  }

  /// The quaternion's coefficients as a 4-vector (Eigen's order x, y, z, w).
  using Coefficients = Eigen::Matrix<Scalar, 4, 1>;

  /// times_exp with the rounding carried (docs/theory.md §18 [K2], [K3]): the rotation is
  /// q + lo, lo the residue the product that made it left (zero for a rotation set by
  /// hand). The result is the rounding of the product (q + lo)·(cos θ/2, v), formed
  /// as times_exp forms it, as an increment, and renormalised in the same carried
  /// arithmetic; `lo` is overwritten with its residue. The unit norm is kept to O(ε²), so
  /// the quaternion does not walk off the sphere like √N·ε over N products.
  SO3 times_exp_carried(const Vector3& x, const detail::HalfAngle<Scalar>& c, Coefficients& lo) const {
    const Vector3 v = x * (c.kappa / 2);  // sin(θ/2)/θ = ½ sinc(θ/2)
    const Scalar cos_half_minus_1 = c.cos_half_minus_one(x.squaredNorm() / 4);
    const Quaternion e_minus_1(cos_half_minus_1, v.x(), v.y(), v.z());
    // [K2] q' = q + (lo + q(e − 1)): the bracket is small, summed first, then two_sum with q.
    // (lo(e − 1) is O(ε·θ), below the rounding of q(e − 1) itself.)
    const Coefficients small = lo + (q_ * e_minus_1).coeffs();
    Coefficients hi;
    for (int i = 0; i < 4; ++i) {
      const detail::Carried<Scalar> s = detail::two_sum(q_.coeffs()(i), small(i));
      hi(i) = s.hi;
      lo(i) = s.lo;
    }
    // [K3] δ = |hi + lo|² − 1 to O(ε²): the squares and their sum error-free, then the
    // Newton step for 1/|q| (detail::newton_unit) applied to hi + lo, its rounding carried.
    detail::Carried<Scalar> norm2 = detail::two_square(hi(0));
    Scalar err = norm2.lo + Scalar(2) * hi.dot(lo);
    for (int i = 1; i < 4; ++i) {
      const detail::Carried<Scalar> sq = detail::two_square(hi(i));
      const detail::Carried<Scalar> sum = detail::two_sum(norm2.hi, sq.hi);
      norm2.hi = sum.hi;
      err += sum.lo + sq.lo;
    }
    const Scalar half_delta = ((norm2.hi - Scalar(1)) + err) / Scalar(2);  // norm2.hi − 1 exact (Sterbenz)
    for (int i = 0; i < 4; ++i) {
      const detail::Carried<Scalar> s = detail::two_sum(hi(i), lo(i) - half_delta * hi(i));
      hi(i) = s.hi;
      lo(i) = s.lo;
    }
    if (hi(3) < Scalar(0)) {  // the canonical sign, for both parts
      hi = -hi;
      lo = -lo;
    }
    Quaternion q;
    q.coeffs() = hi;
    return SO3(q, NoCheck{});
  }

  /// exp(x̂) = I + (sin θ/θ) x̂ + ((1−cos θ)/θ²) x̂², eq. (8), as a matrix (Rodrigues).
  static Matrix3 exp_matrix(const Vector3& x) {
    const detail::HalfAngle<Scalar> c = detail::half_angle(x.norm());
    return rodrigues(x, c.sinc(), c.one_minus_cos_over_sq());
  }

  /// I + a x̂ + b x̂²: exp(x̂) from its coefficients a = sin θ/θ, b = (1 − cos θ)/θ² (8),
  /// for callers that already have them (detail::HalfAngle).
  static Matrix3 rodrigues(const Vector3& x, Scalar a, Scalar b) {
    return Matrix3::Identity() + a * hat(x) + b * hat_squared(x);
  }

  /// Right tangent T(x) = I − ((1−cos θ)/θ²) x̂ + ((θ − sin θ)/θ³) x̂² (docs/theory.md §2):
  /// exp((x+δ)^) = exp(x̂) exp((T(x)δ)^) + O(δ²). Singular at θ = 2π.
  static Matrix3 right_tangent(const Vector3& x) {
    const Scalar theta = x.norm();
    const Matrix3 X = hat(x);
    return Matrix3::Identity() - detail::one_minus_cos_over_sq(theta) * X +
           detail::theta_minus_sin_over_cube(theta) * hat_squared(x);
  }

  /// T(x)⁻¹ = I + ½ x̂ + ((1 − (θ/2) cot(θ/2))/θ²) x̂², for θ < 2π.
  static Matrix3 right_tangent_inverse(const Vector3& x) {
    const Scalar theta = x.norm();
    const Matrix3 X = hat(x);
    return Matrix3::Identity() + X / Scalar(2) +
           detail::inverse_tangent_coefficient(theta) * hat_squared(x);
  }

  /// The rotation of a matrix, which must be orthonormal with det +1 to `tolerance`
  /// (max-norm of RᵀR − I); throws invalid_input otherwise. The stored rotation is the
  /// nearest one (quaternion of R, normalised).
  static SO3 from_matrix(const Matrix3& R, Scalar tolerance = default_tolerance()) {
    if (!detail::all_finite(R)) detail::fail("rotation: non-finite matrix ", detail::to_text(R));
    const Scalar err = (R.transpose() * R - Matrix3::Identity()).cwiseAbs().maxCoeff();
    if (!(err <= tolerance))
      detail::fail("rotation: matrix is not orthonormal, max|RᵀR − I| = ", err,
                   " > tolerance ", tolerance, "; use SO3::renormalized() to project it");
    if (!(R.determinant() > 0))
      detail::fail("rotation: matrix has determinant ", R.determinant(), " (a reflection)");
    return SO3(Quaternion(R), Normalize{});
  }

  /// The rotation nearest to a matrix (polar projection via SVD); for drifted input
  /// that the caller knowingly wants repaired. Throws on non-finite or singular input.
  static SO3 renormalized(const Matrix3& M) {
    if (!detail::all_finite(M)) detail::fail("rotation: non-finite matrix ", detail::to_text(M));
    Eigen::JacobiSVD<Matrix3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Matrix3 R = svd.matrixU() * svd.matrixV().transpose();
    if (R.determinant() < 0 || !(svd.singularValues()(2) > 0))
      detail::fail("rotation: cannot renormalise a singular or reflecting matrix ",
                   detail::to_text(M));
    return SO3(Quaternion(R), Normalize{});
  }

  /// The rotation of a quaternion, whose norm must be 1 to `tolerance`; throws otherwise.
  static SO3 from_quaternion(const Quaternion& q, Scalar tolerance = default_tolerance()) {
    if (!detail::all_finite(q.coeffs()))
      detail::fail("rotation: non-finite quaternion ", detail::to_text(q.coeffs()));
    using std::abs;
    if (!(abs(q.norm() - Scalar(1)) <= tolerance))
      detail::fail("rotation: quaternion norm ", q.norm(), " differs from 1 by more than ",
                   tolerance, "; use SO3::renormalized(q)");
    return SO3(q, Normalize{});
  }

  /// The rotation of any non-zero finite quaternion, normalised (also when |q|² would
  /// overflow or underflow: 1e200 or 1e-200 per coefficient in double).
  static SO3 renormalized(const Quaternion& q) {
    if (!detail::all_finite(q.coeffs()) || !(q.coeffs().cwiseAbs().maxCoeff() > 0))
      detail::fail("rotation: cannot normalise quaternion ", detail::to_text(q.coeffs()));
    return SO3(q, Normalize{});
  }

  /// log: the rotation vector x with exp(x̂) = *this, |x| ≤ π.
  Vector3 log() const { return quaternion_log(q_); }

  /// The rotation vector of the rotation of a quaternion of any norm and sign (|x| ≤ π):
  /// θ = 2 atan2(|v|, w) with w ≥ 0, accurate near 0 and near π, and invariant to |q|, so a
  /// product of unit quaternions needs no normalising first (the dense output's log).
  static Vector3 quaternion_log(const Quaternion& q) {
    using std::atan2;
    const Scalar sign = q.w() < 0 ? Scalar(-1) : Scalar(1);  // the branch |x| ≤ π
    const Vector3 v = sign * q.vec();
    const Scalar s = v.norm();
    const Scalar w = sign * q.w();
    // 2 atan2(s, w)/s; for s/w = x ≤ 0.08 (a turn of up to 0.16 rad, an ordinary step) its
    // series (2/w)·atan(x)/x = (2/w) Σ_k (−x²)^k/(2k + 1), seven terms (the eighth is below
    // 3e-17 relative), which is cheaper than atan2.
    const Scalar factor =
        s <= Scalar(0.08) * w
            ? Scalar(2) / w *
                  detail::polynomial((s / w) * (s / w), std::array<long double, 7>{1.0L, -1.0L / 3, 1.0L / 5, -1.0L / 7,
                                                                                  1.0L / 9, -1.0L / 11, 1.0L / 13})
            : Scalar(2) * atan2(s, w) / s;
    return factor * v;
  }

  /// The composition of two rotations (renormalised).
  SO3 operator*(const SO3& other) const { return SO3(q_ * other.q_, Normalize{}); }
  /// Composes with `other` on the right.
  SO3& operator*=(const SO3& other) { return *this = *this * other; }
  /// The rotated vector.
  Vector3 operator*(const Vector3& a) const { return q_ * a; }
  /// The inverse rotation.
  SO3 inverse() const { return SO3(q_.conjugate(), NoCheck{}); }
  /// The rotation matrix Λ.
  Matrix3 matrix() const { return q_.toRotationMatrix(); }
  /// The unit quaternion.
  const Quaternion& unit_quaternion() const { return q_; }

  /// The same rotation in another scalar type.
  template <class NewScalar>
  SO3<NewScalar> cast() const {
    return SO3<NewScalar>::renormalized(q_.template cast<NewScalar>());
  }

 private:
  struct NoCheck {};
  struct Normalize {};
  SO3(const Quaternion& q, NoCheck) : q_(q) { canonical(); }
  SO3(const Quaternion& q, Normalize) : q_(q) {
    // |q|² overflows to inf (and normalising then gives the zero quaternion) or
    // underflows to 0 far from |q| = 1: rescale by the largest coefficient first there.
    // Products of unit quaternions never come near; this is for input.
    using std::sqrt;
    Scalar n2 = q_.squaredNorm();
    if (!(n2 > sqrt(std::numeric_limits<Scalar>::min()) && n2 < sqrt(std::numeric_limits<Scalar>::max()))) {
      q_.coeffs() /= q_.coeffs().cwiseAbs().maxCoeff();
      n2 = q_.squaredNorm();
    }
    // Near |q| = 1 (products of unit quaternions: the schemes' outputs) the Newton step of
    // times_exp, exact to 3δ²/8 ≤ ε/40 for |δ| = ||q|² − 1| ≤ √ε/4. Elsewhere (input) the quotient.
    using std::abs;
    if (abs(n2 - Scalar(1)) <= sqrt(std::numeric_limits<Scalar>::epsilon()) / Scalar(4)) {
      detail::newton_unit(q_, n2);
    } else if (n2 > Scalar(0)) {
      q_.coeffs() /= sqrt(n2);  // as Quaternion::normalize(), one |q|² only
    }
    canonical();
  }
  // Keep w ≥ 0 so that log() returns |x| ≤ π.
  void canonical() {
    if (q_.w() < 0) q_.coeffs() = -q_.coeffs();
  }

  Quaternion q_;
};

/// Rotations in double.
using SO3d = SO3<double>;
/// Rotations in float.
using SO3f = SO3<float>;

}  // namespace trompo
