#pragma once
// A rigid body about its fixed point O (docs/theory.md §1): the inertia J in body axes.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "trompo/errors.hpp"

namespace trompo {

/// Tag: accept a positive-definite inertia that breaks the triangle inequality of
/// principal moments. No rigid body has one, but some test problems of the literature
/// do (FB2, Hairer–Lubich–Wanner's J = diag(2, 1, 2/3)); the schemes do not need it.
struct allow_unphysical_inertia_t {
  explicit allow_unphysical_inertia_t() = default;
};
/// The tag that lets RigidBody accept principal moments breaking J1 + J2 ≥ J3.
inline constexpr allow_unphysical_inertia_t allow_unphysical_inertia{};

/// A rigid body about its fixed point O (or its centre of mass): the inertia J in body axes,
/// validated on construction (docs/theory.md §1).
template <class Scalar_>
class RigidBody {
 public:
  /// The scalar type (float, double, long double).
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;

  /// Principal moments (J1, J2, J3) along the body axes.
  explicit RigidBody(const Vector3& principal) : RigidBody(Matrix3(principal.asDiagonal()), true) {}
  /// Principal moments (J1, J2, J3) without the triangle inequality (see allow_unphysical_inertia_t).
  RigidBody(const Vector3& principal, allow_unphysical_inertia_t)
      : RigidBody(Matrix3(principal.asDiagonal()), false) {}

  /// A full inertia tensor about O in body axes. It must be finite, symmetric (to 64ε,
  /// then symmetrised), positive definite and obey the triangle inequality of principal
  /// moments (J1 + J2 ≥ J3 and permutations; the disk limit J1 + J2 = J3 is allowed).
  /// Throws invalid_input naming the violation.
  explicit RigidBody(const Matrix3& inertia) : RigidBody(inertia, true) {}
  /// As above, without the triangle inequality (see allow_unphysical_inertia_t).
  RigidBody(const Matrix3& inertia, allow_unphysical_inertia_t) : RigidBody(inertia, false) {}

  /// J, the inertia about O in body axes.
  const Matrix3& inertia() const { return J_; }
  /// J⁻¹.
  const Matrix3& inertia_inverse() const { return J_inv_; }
  /// True when J is diagonal (then products with J are three multiplications).
  bool is_diagonal() const { return diagonal_; }
  /// False when the principal moments break the triangle inequality (allowed only by tag).
  bool is_physical() const { return physical_; }

  /// Π = J Ω, the body momentum.
  Vector3 momentum(const Vector3& omega) const {
    if (diagonal_) return J_.diagonal().cwiseProduct(omega);
    return J_ * omega;
  }
  /// ½ Ω·JΩ
  Scalar kinetic_energy(const Vector3& omega) const { return omega.dot(momentum(omega)) / 2; }

  /// The same body in another scalar type.
  template <class NewScalar>
  RigidBody<NewScalar> cast() const {
    return RigidBody<NewScalar>(Eigen::Matrix<NewScalar, 3, 3>(J_.template cast<NewScalar>()),
                                allow_unphysical_inertia);
  }

 private:
  RigidBody(const Matrix3& inertia, bool require_physical) : J_(inertia) {
    if (!detail::all_finite(J_)) detail::fail("inertia: non-finite entry in ", detail::to_text(J_));
    const Scalar scale = J_.cwiseAbs().maxCoeff();
    const Scalar tol = Scalar(64) * Eigen::NumTraits<Scalar>::epsilon() * scale;
    if (!((J_ - J_.transpose()).cwiseAbs().maxCoeff() <= tol))
      detail::fail("inertia: not symmetric, ", detail::to_text(J_));
    J_ = (J_ + J_.transpose()).eval() / Scalar(2);
    const Vector3 m = Eigen::SelfAdjointEigenSolver<Matrix3>(J_, Eigen::EigenvaluesOnly).eigenvalues();
    if (!(m.minCoeff() > 0))
      detail::fail("inertia: not positive definite, principal moments ", detail::to_text(m));
    // m is sorted ascending: the binding inequality is m0 + m1 ≥ m2.
    physical_ = m(0) + m(1) >= m(2) - tol;
    if (require_physical && !physical_)
      detail::fail("inertia: principal moments ", detail::to_text(m),
                   " break the triangle inequality J1 + J2 >= J3");
    J_inv_ = J_.inverse();
    diagonal_ = J_.isDiagonal(Scalar(0));
  }

  Matrix3 J_;
  Matrix3 J_inv_;
  bool diagonal_ = false;
  bool physical_ = true;
};

}  // namespace trompo
