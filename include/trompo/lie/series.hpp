#pragma once
// Small-angle coefficients of the rotation formulas (docs/theory.md §2), evaluated without 0/0.
//
// Every coefficient below is an even function of θ. Below `small_angle<Scalar>::theta`
// it is taken from its Taylor series in θ² (terms through θ¹², see polynomial()); above, from
// the closed form. The two branches are tied together as follows:
//   - truncation: the first omitted term is below θ¹⁴/14! ≈ 1e-21 relative at θ = 1/4,
//     under the epsilon of every Scalar we support (float, double, 80-bit long double);
//   - cancellation: the worst closed form, (θ − sin θ)/θ³, loses about 6ε/θ² relative,
//     i.e. ≤ 100ε just above θ = 1/4.
// So both branches agree to ~1e-14 relative in double at the switch, which keeps the
// Newton tangents ([T3]) smooth across it.
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>

namespace trompo::detail {

template <class Scalar>
struct small_angle {
  /// Below this angle the series are used (same for every Scalar: see above).
  static constexpr Scalar theta = Scalar(0.25);
  /// Below this angle small_sinc_cos takes three terms of each series: the first left out,
  /// y⁶/720, is below ε/4 (2⁻⁸ in double, 2⁻¹⁰ in 80-bit long double, 2⁻³ in float).
  static constexpr Scalar tiny = std::numeric_limits<Scalar>::digits > 53   ? Scalar(1.0 / 1024)
                                 : std::numeric_limits<Scalar>::digits > 24 ? Scalar(1.0 / 256)
                                                                            : Scalar(1.0 / 8);
};

/// c[0] + c[1] x + … + c[6] x⁶ for x = θ², by Estrin's scheme: the pairs c[2i] + c[2i+1] x
/// are summed with the powers x², x⁴. Same terms as Horner's rule, but a dependency
/// chain of 4 multiply-adds instead of 7, so the series of one residual evaluation
/// overlap in the pipeline (they are on the Newton loop's critical path). The leading
/// term dominates (|c[k] x^k| ≤ |c[0]|/6 for θ ≤ ½), so the rounding is ~ε·|c[0]| as
/// with Horner. The coefficients are exact rationals written in long double and
/// rounded once to Scalar.
template <class Scalar>
constexpr Scalar polynomial(Scalar x, const std::array<long double, 7>& c) {
  const Scalar x2 = x * x;
  const Scalar x4 = x2 * x2;
  const Scalar p01 = Scalar(c[0]) + Scalar(c[1]) * x;
  const Scalar p23 = Scalar(c[2]) + Scalar(c[3]) * x;
  const Scalar p45 = Scalar(c[4]) + Scalar(c[5]) * x;
  return (p01 + x2 * p23) + x4 * (p45 + x2 * Scalar(c[6]));
}

/// The Taylor coefficients in x = θ² of the four functions every other series here is built
/// from, exact rationals (each written once):
///   sin θ/θ = Σ (−x)^k/(2k + 1)!,   cos θ = Σ (−x)^k/(2k)!,
///   (1 − cos θ)/θ² = Σ (−x)^k/(2k + 2)!,   (θ − sin θ)/θ³ = Σ (−x)^k/(2k + 3)!.
inline constexpr std::array<long double, 7> sinc_series{1.0L, -1.0L / 6, 1.0L / 120, -1.0L / 5040, 1.0L / 362880,
                                                        -1.0L / 39916800, 1.0L / 6227020800.0L};
inline constexpr std::array<long double, 7> cos_series{1.0L, -1.0L / 2, 1.0L / 24, -1.0L / 720, 1.0L / 40320,
                                                       -1.0L / 3628800, 1.0L / 479001600.0L};
inline constexpr std::array<long double, 7> one_minus_cos_over_sq_series{
    1.0L / 2, -1.0L / 24, 1.0L / 720, -1.0L / 40320, 1.0L / 3628800, -1.0L / 479001600.0L, 1.0L / 87178291200.0L};
inline constexpr std::array<long double, 7> theta_minus_sin_over_cube_series{
    1.0L / 6, -1.0L / 120, 1.0L / 5040, -1.0L / 362880, 1.0L / 39916800, -1.0L / 6227020800.0L, 1.0L / 1307674368000.0L};
/// And of (θ cos θ − sin θ)/θ³ = sinc′(θ)/θ = Σ (−x)^{k+1}(2k + 2)/(2k + 3)!.
inline constexpr std::array<long double, 7> sinc_prime_over_theta_series{
    -1.0L / 3, 1.0L / 30, -1.0L / 840, 1.0L / 45360, -1.0L / 3991680, 1.0L / 518918400.0L, -1.0L / 93405312000.0L};

/// sin y/y and cos y from x = y² < small_angle::theta², by their series: seven terms each
/// (the truncation is below 1e-19 relative for |y| < ¼), three below small_angle::tiny. A
/// rotation by the length of a vector takes x from the squared norm: no root, no division.
template <class Scalar>
void small_sinc_cos(Scalar x, Scalar& sinc_y, Scalar& c) {
  constexpr Scalar tiny = small_angle<Scalar>::tiny;
  if (x < tiny * tiny) {
    sinc_y = Scalar(1) + x * (Scalar(sinc_series[1]) + x * Scalar(sinc_series[2]));
    c = Scalar(1) + x * (Scalar(cos_series[1]) + x * Scalar(cos_series[2]));
    return;
  }
  sinc_y = polynomial(x, sinc_series);
  c = polynomial(x, cos_series);
}

/// sin y and cos y: below small_angle by their series (small_sinc_cos), else the library's.
/// The splitting's flows turn by such small angles on ordinary steps, where the series cost
/// half of sin and cos (and a slowly turning body's, by the three-term ones, a sixth).
template <class Scalar>
void sin_cos(Scalar y, Scalar& s, Scalar& c) {
  using std::cos;
  using std::sin;
  if (std::abs(y) < small_angle<Scalar>::theta) {
    Scalar sinc_y;
    small_sinc_cos(y * y, sinc_y, c);
    s = y * sinc_y;
    return;
  }
  s = sin(y);
  c = cos(y);
}

/// sin θ / θ  (the "a" coefficient of exp, eq. (8)).
template <class Scalar>
Scalar sinc(Scalar theta) {
  using std::sin;
  if (std::abs(theta) < small_angle<Scalar>::theta) {
    const Scalar x = theta * theta;
    return polynomial(x, sinc_series);
  }
  return sin(theta) / theta;
}

/// (1 − cos θ) / θ²  (the "b" coefficient of exp, eq. (8), and of T, docs/theory.md §2).
template <class Scalar>
Scalar one_minus_cos_over_sq(Scalar theta) {
  using std::cos;
  if (std::abs(theta) < small_angle<Scalar>::theta) {
    const Scalar x = theta * theta;
    return polynomial(x, one_minus_cos_over_sq_series);
  }
  return (Scalar(1) - cos(theta)) / (theta * theta);
}

/// (θ − sin θ) / θ³  (the "c" coefficient of the right tangent T, docs/theory.md §2).
template <class Scalar>
Scalar theta_minus_sin_over_cube(Scalar theta) {
  using std::sin;
  if (std::abs(theta) < small_angle<Scalar>::theta) {
    const Scalar x = theta * theta;
    return polynomial(x, theta_minus_sin_over_cube_series);
  }
  return (theta - sin(theta)) / (theta * theta * theta);
}

/// (1 − (θ/2) cot(θ/2)) / θ²  (the x̂² coefficient of the inverse tangent T⁻¹).
/// Series: Σ |B_2k| θ^(2k−2) / (2k)!, Bernoulli numbers.
template <class Scalar>
Scalar inverse_tangent_coefficient(Scalar theta) {
  using std::cos;
  using std::sin;
  if (std::abs(theta) < small_angle<Scalar>::theta) {
    const Scalar x = theta * theta;
    return polynomial(x, std::array<long double, 7>{1.0L / 12, 1.0L / 720, 1.0L / 30240, 1.0L / 1209600, 1.0L / 47900160, 691.0L / 1307674368000.0L, 1.0L / 74724249600.0L});
  }
  const Scalar half = theta / 2;
  return (Scalar(1) - half * cos(half) / sin(half)) / (theta * theta);
}

/// κ = sin(θ/2)/(θ/2) and cos(θ/2), from which the coefficients of exp(Θ̂) and of the
/// half-step rotation exp(Θ̂/2) follow without cancellation (half-angle identities):
///   sin θ/θ = κ cos(θ/2),            (1 − cos θ)/θ² = κ²/2,
///   sin(θ/2)/(θ/2) = κ,              (1 − cos(θ/2))/(θ/2)² = κ²/(1 + cos(θ/2)).
/// One sin/cos pair above the switch (θ/2 ≥ ¼), three short series below it: the Newton
/// residual of the Simo schemes needs all four, which cost five series before.
template <class Scalar>
struct HalfAngle {
  Scalar kappa;     ///< sin(θ/2)/(θ/2), the κ of (19)
  Scalar cos_half;  ///< cos(θ/2)
  /// (1 − cos(θ/2))/(θ/2)², the b coefficient of exp(Θ̂/2): below the switch from its own
  /// series, evaluated alongside κ's (κ²/(1 + cos(θ/2)) put a division after them on
  /// the Newton chain of the Simo residual, whose midpoint torque needs it); above it,
  /// κ²/(1 + cos(θ/2)), with 1 + cos(θ/2) > 0 for |θ| < 2π.
  Scalar b_half;
  bool series;  ///< whether θ/2 was below the switch (the series were used)
  Scalar sinc() const { return kappa * cos_half; }                    ///< sin θ / θ
  Scalar one_minus_cos_over_sq() const { return kappa * kappa / 2; }  ///< (1 − cos θ)/θ²
  /// (1 − cos(θ/2))/(θ/2)², the b coefficient of exp(Θ̂/2) (b_half).
  Scalar half_one_minus_cos_over_sq() const { return b_half; }
  /// cos(θ/2) − 1 given x = (θ/2)², without cancellation: −x·b_half where the series were
  /// used (the difference would cancel), the difference above the switch (exact for
  /// θ ≤ 2π/3; b_half's closed form cancels near θ = 2π).
  Scalar cos_half_minus_one(Scalar x) const { return series ? -x * b_half : cos_half - Scalar(1); }
};

template <class Scalar>
HalfAngle<Scalar> half_angle_series(Scalar x) {  // x = (θ/2)², below the switch
  return {polynomial(x, sinc_series),
          polynomial(x, cos_series),
          polynomial(x, one_minus_cos_over_sq_series),
          true};
}

template <class Scalar>
HalfAngle<Scalar> half_angle(Scalar theta) {
  using std::cos;
  using std::sin;
  const Scalar y = theta / 2;
  if (std::abs(y) < small_angle<Scalar>::theta) return half_angle_series(y * y);
  const Scalar k = sin(y) / y, c = cos(y);
  return {k, c, k * k / (Scalar(1) + c), false};
}

/// half_angle(θ) from θ² = |Θ|²: below the switch the series need only θ², so no square
/// root is taken there. For the Newton residual of the Simo schemes and the update
/// exp(Θ̂), where the square root of |Θ|² sat on the iteration's critical path (one
/// per evaluation and one per update: ~20 cycles each of latency). Agrees with
/// half_angle(|Θ|) to round-off (the series' argument is rounded once instead of twice).
template <class Scalar>
HalfAngle<Scalar> half_angle_from_squared(Scalar theta_sq) {
  using std::sqrt;
  const Scalar x = theta_sq / 4;  // (θ/2)²
  if (x < small_angle<Scalar>::theta * small_angle<Scalar>::theta) return half_angle_series(x);
  return half_angle(sqrt(theta_sq));
}

/// κ(θ) = sin(θ/2)/(θ/2), the Simo-κ projection factor, eq. (19).
template <class Scalar>
Scalar kappa(Scalar theta) {
  return sinc(theta / 2);
}

/// 1 − κ(θ), without cancellation (needed by the collocation root, [T2]).
template <class Scalar>
Scalar one_minus_kappa(Scalar theta) {
  const Scalar x = theta * theta / 4;  // (θ/2)²
  if (std::abs(theta) < 2 * small_angle<Scalar>::theta) {
    // 1 − sinc(y) = y²/3! − y⁴/5! + … = y²·(y − sin y)/y³,  y = θ/2
    return x * polynomial(x, theta_minus_sin_over_cube_series);
  }
  return Scalar(1) - kappa(theta);
}

/// κ′(θ) / θ = ((θ/2) cos(θ/2) − sin(θ/2)) / (θ³/2), about −1/12 near 0 ([T3]).
/// Returned divided by θ so that ∇κ = (κ′/θ) Θ has no 0/0.
template <class Scalar>
Scalar kappa_prime_over_theta(Scalar theta) {
  using std::cos;
  using std::sin;
  const Scalar y = theta / 2;
  if (std::abs(y) < small_angle<Scalar>::theta) {
    // d/dθ sinc(θ/2) = ½ sinc′(y);  sinc′(y)/y = −1/3 + y²/30 − y⁴/840 + …;  /θ = /(2y)
    const Scalar x = y * y;
    return polynomial(x, sinc_prime_over_theta_series) / 4;
  }
  return (y * cos(y) - sin(y)) / (theta * theta * theta / 2);
}

}  // namespace trompo::detail
