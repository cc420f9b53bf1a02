#pragma once
// The SO(3) kit of the families of docs/theory.md §11 ([T6]): the left Jacobian J_l,
// the right-trivialised tangent T and the derivative D(x, w) = ∂[J_l(x) w]/∂x, all
// written with coefficients that have no 0/0 (series below small_angle, series.hpp).
//
//   J_l(x)   = ∫₀¹ exp(s x̂) ds = a I + b x̂ + c x xᵀ               [T6]
//   T(x)     = J_l(−x) = I − b x̂ + c x̂²                            [T6]
//   D(x, w)  = (a₁ w + b₁ x×w + c₁ (x·w) x) xᵀ − b ŵ + c ((x·w) I + x wᵀ)
// with φ = |x|, a = sin φ/φ, b = (1 − cos φ)/φ², c = (φ − sin φ)/φ³ and
//   a₁ = (φ cos φ − sin φ)/φ³,  b₁ = (φ sin φ − 2(1 − cos φ))/φ⁴,
//   c₁ = ((1 − cos φ)φ − 3(φ − sin φ))/φ⁵   (a₁ = a′/φ, b₁ = b′/φ, c₁ = c′/φ).
// Derivatives used by the tangents: ∂[T(x)ᵀ w]/∂x = D(x, w), ∂[T(x) w]/∂x = −D(−x, w).
#include <Eigen/Core>
#include <array>
#include <cmath>

#include "trompo/lie/series.hpp"
#include "trompo/lie/so3.hpp"

namespace trompo::detail {

/// (φ cos φ − sin φ)/φ³ = a′(φ)/φ, about −1/3 near 0 ([T6]).
template <class Scalar>
Scalar sinc_prime_over_theta(Scalar phi) {
  using std::cos;
  using std::sin;
  if (std::abs(phi) < small_angle<Scalar>::theta)
    return polynomial(phi * phi, sinc_prime_over_theta_series);
  return (phi * cos(phi) - sin(phi)) / (phi * phi * phi);
}

/// (φ sin φ − 2(1 − cos φ))/φ⁴ = b′(φ)/φ, about −1/12 near 0 ([T6]).
template <class Scalar>
Scalar one_minus_cos_prime_over_theta(Scalar phi) {
  using std::cos;
  using std::sin;
  if (std::abs(phi) < small_angle<Scalar>::theta)
    return polynomial(phi * phi, std::array<long double, 7>{-1.0L / 12.0L, 1.0L / 180.0L, -1.0L / 6720.0L,
                                                            1.0L / 453600.0L, -1.0L / 47900160.0L,
                                                            1.0L / 7264857600.0L, -1.0L / 1494484992000.0L});
  const Scalar p2 = phi * phi;
  return (phi * sin(phi) - Scalar(2) * (Scalar(1) - cos(phi))) / (p2 * p2);
}

/// ((1 − cos φ)φ − 3(φ − sin φ))/φ⁵ = c′(φ)/φ, about −1/60 near 0 ([T6]).
template <class Scalar>
Scalar theta_minus_sin_prime_over_theta(Scalar phi) {
  using std::cos;
  using std::sin;
  if (std::abs(phi) < small_angle<Scalar>::theta)
    return polynomial(phi * phi, std::array<long double, 7>{-1.0L / 60.0L, 1.0L / 1260.0L, -1.0L / 60480.0L,
                                                            1.0L / 4989600.0L, -1.0L / 622702080.0L,
                                                            1.0L / 108972864000.0L, -1.0L / 25406244864000.0L});
  const Scalar p2 = phi * phi;
  return ((Scalar(1) - cos(phi)) * phi - Scalar(3) * (phi - sin(phi))) / (p2 * p2 * phi);
}

/// The left Jacobian J_l(x) = ∫₀¹ exp(s x̂) ds = a I + b x̂ + c x xᵀ ([T6]), an entire
/// function: exp(x̂) − I = x̂ J_l(x), and J_l(x) x = x.
template <class Scalar>
Eigen::Matrix<Scalar, 3, 3> left_jacobian(const Eigen::Matrix<Scalar, 3, 1>& x) {
  const Scalar phi = x.norm();
  return sinc(phi) * Eigen::Matrix<Scalar, 3, 3>::Identity() + one_minus_cos_over_sq(phi) * SO3<Scalar>::hat(x) +
         theta_minus_sin_over_cube(phi) * (x * x.transpose());
}

/// D(x, w) = ∂[J_l(x) w]/∂x ([T6]); also ∂[T(x)ᵀ w]/∂x, since T(x)ᵀ = J_l(x).
template <class Scalar>
Eigen::Matrix<Scalar, 3, 3> left_jacobian_derivative(const Eigen::Matrix<Scalar, 3, 1>& x,
                                                     const Eigen::Matrix<Scalar, 3, 1>& w) {
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  const Scalar phi = x.norm();
  const Scalar b = one_minus_cos_over_sq(phi);
  const Scalar c = theta_minus_sin_over_cube(phi);
  const Scalar xw = x.dot(w);
  const Vector3 u = sinc_prime_over_theta(phi) * w + one_minus_cos_prime_over_theta(phi) * x.cross(w) +
                    (theta_minus_sin_prime_over_theta(phi) * xw) * x;
  return u * x.transpose() - b * SO3<Scalar>::hat(w) + c * (xw * Matrix3::Identity() + x * w.transpose());
}

}  // namespace trompo::detail
