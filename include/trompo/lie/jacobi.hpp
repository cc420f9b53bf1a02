#pragma once
// Jacobi elliptic functions sn, cn, dn (u | m) for a parameter m = k² ∈ [0, 1], with the
// complements 1 − cn and 1 − dn to relative accuracy (docs/theory.md [F5]). Eigen-free,
// Boost-free, no allocation; any floating Scalar (float, double, long double).
//
// Method: the descending Landen (Gauss) transformation [F5]. With k' = √(1 − m), the next
// modulus is k₁ = (1 − k')/(1 + k') = m/(1 + k')² and
//   sn(u|k) = (1 + k₁) s/(1 + k₁ s²),  cn(u|k) = c d/(1 + k₁ s²),  dn(u|k) = (1 − k₁ s²)/(1 + k₁ s²)
// with (s, c, d) = (sn, cn, dn)(u/(1 + k₁) | k₁). The moduli fall quadratically; below
// m_L ≤ √ε/16 the bottom level is sin, cos, 1 plus the O(m) terms (A&S 16.13), whose
// error is O(m_L²) < ε. The ladder (JacobiModulus) depends on m only: build it once per
// modulus, evaluate it at as many u as needed.
//
// Why complements. Near m = 1 every level has k₁ ≈ 1, and in the direct form an error off
// the manifold sn² + cn² = 1 doubles at each level. While cn > ½ the ascent therefore
// carries c̄ = 1 − cn and d̄ = 1 − dn instead [F5]:
//   1 − cn = (k₁ s² + c̄ + d̄ c)/(1 + k₁ s²),   1 − dn = 2 k₁ s²/(1 + k₁ s²),
// sums of positive terms with no cancellation (also for m → 0, where d̄ ~ m). Once c̄ > ½
// the direct form takes over for the remaining levels.
// m' = 0 exactly (the separatrix): sn = tanh u, cn = dn = sech u.
#include <cmath>
#include <limits>

namespace trompo {

/// The descending Landen ladder of a parameter m = k² (given with m' = 1 − m separately,
/// so that m' stays accurate next to the separatrix m → 1).
template <class Scalar>
struct JacobiModulus {
  static constexpr int max_levels = 40;  ///< far beyond need: m' = 1e-4900 takes ~16 levels
  Scalar m = Scalar(0);                  ///< k²
  Scalar mc = Scalar(1);                 ///< 1 − k²
  int levels = 0;                        ///< Landen levels
  bool separatrix = false;               ///< m' = 0: tanh, sech
  Scalar k[max_levels] = {};             ///< k_{j+1} of each level (the modulus, not squared)
  Scalar one_minus_k[max_levels] = {};   ///< 1 − k_{j+1} = 2k'_j/(1 + k'_j), without cancellation
  Scalar inv_scale = Scalar(1);          ///< 1/Π(1 + k_j): the bottom argument is u·inv_scale
  Scalar m_bottom = Scalar(0);           ///< the parameter left at the bottom (≤ √ε/16)

  JacobiModulus() = default;
  /// The ladder of (m, m'); m and m' are clamped to [0, 1] (callers pass computed values).
  JacobiModulus(Scalar m_in, Scalar mc_in) {
    using std::sqrt;
    m = m_in < Scalar(0) ? Scalar(0) : (m_in > Scalar(1) ? Scalar(1) : m_in);
    mc = mc_in < Scalar(0) ? Scalar(0) : (mc_in > Scalar(1) ? Scalar(1) : mc_in);
    separatrix = !(mc > Scalar(0));
    if (separatrix) return;
    const Scalar stop = sqrt(std::numeric_limits<Scalar>::epsilon()) / Scalar(16);
    Scalar kp = sqrt(mc), mj = m, scale = Scalar(1);
    while (mj > stop && levels < max_levels) {
      const Scalar r = Scalar(1) / (Scalar(1) + kp);
      const Scalar k1 = mj * r * r;  // (1 − k')/(1 + k') without cancellation
      k[levels] = k1;
      one_minus_k[levels] = Scalar(2) * kp * r;
      scale *= Scalar(1) + k1;
      kp = Scalar(2) * sqrt(kp) * r;  // k'₁ = 2√k'/(1 + k')
      mj = k1 * k1;
      ++levels;
    }
    inv_scale = Scalar(1) / scale;
    m_bottom = mj;
  }

  /// K(m), the quarter period: K = Π(1 + k_j)·K(m_L), K(m_L) = (π/2)(1 + m_L/4 + O(m_L²))
  /// (the Landen ladder is the AGM); +∞ on the separatrix.
  Scalar quarter_period() const {
    if (separatrix) return std::numeric_limits<Scalar>::infinity();
    return Scalar(1.57079632679489661923132169163975144L) / inv_scale * (Scalar(1) + m_bottom / Scalar(4));
  }
};

/// sn, cn, dn at one argument, with 1 − cn and 1 − dn to relative accuracy.
template <class Scalar>
struct JacobiValues {
  Scalar sn = Scalar(0);  ///< sn(u | m)
  Scalar cn = Scalar(1);  ///< cn(u | m)
  Scalar dn = Scalar(1);  ///< dn(u | m)
  Scalar one_minus_cn = Scalar(0);  ///< 1 − cn, carried without cancellation
  Scalar one_minus_dn = Scalar(0);  ///< 1 − dn, carried without cancellation
};

/// (sn, cn, dn)(u | m) by the ladder of m (see the file comment).
template <class Scalar>
JacobiValues<Scalar> jacobi_sncndn(const JacobiModulus<Scalar>& L, Scalar u) {
  using std::abs;
  using std::cos;
  using std::cosh;
  using std::sin;
  using std::sinh;
  using std::tanh;
  JacobiValues<Scalar> r;
  if (L.separatrix) {
    const Scalar ch = cosh(u), sh2 = sinh(u / Scalar(2));
    r.sn = tanh(u);
    r.cn = r.dn = Scalar(1) / ch;
    r.one_minus_cn = r.one_minus_dn = Scalar(2) * sh2 * sh2 / ch;  // 1 − sech u = 2 sinh²(u/2)/cosh u
    return r;
  }
  const Scalar v = u * L.inv_scale;
  // sin v and 1 − cos v: Taylor series for |v| ≤ ¼ (the flow's increments; terms to v¹⁷/v¹⁸,
  // truncation < 1e-24), else the library's, with 1 − cos v = sin²v/(1 + cos v) for cos v > 0.
  Scalar sv, cv, cb0;
  if (abs(v) <= Scalar(0.25)) {
    const Scalar w = v * v;
    sv = v * (Scalar(1) + w * (Scalar(-1.0L / 6) + w * (Scalar(1.0L / 120) + w * (Scalar(-1.0L / 5040) +
             w * (Scalar(1.0L / 362880) + w * (Scalar(-1.0L / 39916800) + w * (Scalar(1.0L / 6227020800.0L) +
             w * (Scalar(-1.0L / 1307674368000.0L) + w * Scalar(1.0L / 355687428096000.0L)))))))));
    cb0 = w * (Scalar(0.5L) + w * (Scalar(-1.0L / 24) + w * (Scalar(1.0L / 720) + w * (Scalar(-1.0L / 40320) +
              w * (Scalar(1.0L / 3628800) + w * (Scalar(-1.0L / 479001600.0L) + w * (Scalar(1.0L / 87178291200.0L) +
              w * (Scalar(-1.0L / 20922789888000.0L) + w * Scalar(1.0L / 6402373705728000.0L)))))))));
    cv = Scalar(1) - cb0;
  } else {
    sv = sin(v), cv = cos(v);
    cb0 = cv > Scalar(0) ? sv * sv / (Scalar(1) + cv) : Scalar(1) - cv;
  }
  // bottom level, A&S 16.13: sn ≈ sin v − t cos v, cn ≈ cos v + t sin v, dn ≈ 1 − ½ m sin² v,
  // t = ¼ m (v − sin v cos v)
  const Scalar t = Scalar(0.25) * L.m_bottom * (v - sv * cv);
  Scalar s = sv - t * cv;
  Scalar cb = cb0 - t * sv;  // 1 − cos v, then the O(m) term
  Scalar db = Scalar(0.5) * L.m_bottom * sv * sv;
  int j = L.levels - 1;
  if (cb < Scalar(0.5)) {
    for (; j >= 0; --j) {  // complement form [F5]
      const Scalar kj = L.k[j];
      const Scalar s2 = s * s;
      const Scalar q = Scalar(1) / (Scalar(1) + kj * s2);
      const Scalar c = Scalar(1) - cb;
      const Scalar cb1 = (kj * s2 + cb + db * c) * q;
      db = Scalar(2) * kj * s2 * q;
      s = (Scalar(1) + kj) * s * q;
      cb = cb1;
      if (cb > Scalar(0.5)) {
        --j;
        break;
      }
    }
  }
  Scalar c = Scalar(1) - cb, d = Scalar(1) - db;
  if (j < 0 && cb <= Scalar(0.5)) {
    r.sn = s, r.cn = c, r.dn = d, r.one_minus_cn = cb, r.one_minus_dn = db;
    return r;
  }
  if (j == L.levels - 1) {  // started in the direct form: cos v as such (no 1 − c̄ rounding)
    c = cv + t * sv;
  }
  for (; j >= 0; --j) {  // direct form
    const Scalar kj = L.k[j];
    const Scalar q = Scalar(1) / (Scalar(1) + kj * s * s);
    const Scalar s1 = (Scalar(1) + kj) * s * q;
    const Scalar c1 = c * d * q;
    d = (L.one_minus_k[j] + kj * c * c) * q;  // (1 − k₁ s²)/(1 + k₁ s²) with s² = 1 − c²
    s = s1;
    c = c1;
  }
  r.sn = s, r.cn = c, r.dn = d, r.one_minus_cn = Scalar(1) - c, r.one_minus_dn = Scalar(1) - d;
  return r;
}

}  // namespace trompo
