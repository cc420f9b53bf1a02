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
//
// For small arguments JacobiSeries evaluates the Maclaurin series in u directly (no ladder).
#include <array>
#include <cmath>
#include <cstddef>
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

/// Bulirsch's complete elliptic integral of the general kind, for p > 0 and 0 < k' ≤ 1
/// (docs/theory.md [F9]):
///   cel(k', p, A, B) = ∫_0^{π/2} (A cos²φ + B sin²φ) / ((cos²φ + p sin²φ) √(cos²φ + k'² sin²φ)) dφ.
/// K(m) = cel(k', 1, 1, 1) and Π(n | m) = cel(k', 1 − n, 1, 1). Bulirsch's algorithm (Numer.
/// Math. 13, 1969): an arithmetic–geometric mean on (1, k') carrying A, B and p, converging
/// quadratically; each pass one square root and two divisions. It stops once the two means
/// agree to √ε relative: the next pass squares that error, below ε.
template <class Scalar>
Scalar complete_elliptic_cel(Scalar kc, Scalar p, Scalar A, Scalar B) {
  using std::abs;
  using std::sqrt;
  const Scalar tol = sqrt(std::numeric_limits<Scalar>::epsilon());
  Scalar qc = abs(kc), a = A, e = qc, em = Scalar(1);
  p = sqrt(p);
  Scalar b = B / p;
  for (int pass = 0; pass < 64; ++pass) {
    const Scalar f = a;
    a += b / p;
    const Scalar g = e / p;
    b += f * g;
    b += b;
    p += g;
    const Scalar mean = em;
    em += qc;
    if (abs(mean - qc) <= mean * tol) break;
    qc = sqrt(e);
    qc += qc;
    e = qc * em;
  }
  return Scalar(1.57079632679489661923132169163975144L) * (b + a * em) / (em * (em + p));
}

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

namespace detail {
/// The Maclaurin coefficients of JacobiSeries and the bound of each row.
template <class Scalar>
struct JacobiSeriesTables {
  static constexpr int terms = 9;
  // Row j: the coefficient of u^{2j+1} in sn, of u^{2j+2} in 1 − cn and in 1 − dn, as
  // polynomials in m (ascending powers; 1 − dn has the factor m): exact rationals, written
  // to 22 digits and rounded to Scalar at compile time.
  static constexpr Scalar sn[terms][9] = {
      {Scalar(1.000000000000000000000e+0L)},
      {Scalar(-1.666666666666666666667e-1L), Scalar(-1.666666666666666666667e-1L)},
      {Scalar(8.333333333333333333333e-3L), Scalar(1.166666666666666666667e-1L), Scalar(8.333333333333333333333e-3L)},
      {Scalar(-1.984126984126984126984e-4L), Scalar(-2.678571428571428571429e-2L), Scalar(-2.678571428571428571429e-2L), Scalar(-1.984126984126984126984e-4L)},
      {Scalar(2.755731922398589065256e-6L), Scalar(3.384038800705467372134e-3L), Scalar(1.509589947089947089947e-2L), Scalar(3.384038800705467372134e-3L), Scalar(2.755731922398589065256e-6L)},
      {Scalar(-2.505210838544171877505e-8L), Scalar(-2.773017877184543851211e-4L), Scalar(-4.154290925124258457592e-3L), Scalar(-4.154290925124258457592e-3L), Scalar(-2.773017877184543851211e-4L), Scalar(-2.505210838544171877505e-8L)},
      {Scalar(1.605904383682161459939e-10L), Scalar(1.600155245988579321913e-5L), Scalar(7.217497972706306039639e-4L), Scalar(2.116625015930571486127e-3L), Scalar(7.217497972706306039639e-4L), Scalar(1.600155245988579321913e-5L), Scalar(1.605904383682161459939e-10L)},
      {Scalar(-7.647163731819816475901e-13L), Scalar(-6.857999376187206875038e-7L), Scalar(-8.893244055694452519849e-5L), Scalar(-6.382989522663795150568e-4L), Scalar(-6.382989522663795150568e-4L), Scalar(-8.893244055694452519849e-5L), Scalar(-6.857999376187206875038e-7L), Scalar(-7.647163731819816475901e-13L)},
      {Scalar(2.811457254345520763199e-15L), Scalar(2.269199123287981053309e-8L), Scalar(8.293700555544529245121e-6L), Scalar(1.325661818198242490181e-4L), Scalar(3.082622922067597507218e-4L), Scalar(1.325661818198242490181e-4L), Scalar(8.293700555544529245121e-6L), Scalar(2.269199123287981053309e-8L), Scalar(2.811457254345520763199e-15L)},
  };
  static constexpr Scalar cn[terms][9] = {
      {Scalar(5.000000000000000000000e-1L)},
      {Scalar(-4.166666666666666666667e-2L), Scalar(-1.666666666666666666667e-1L)},
      {Scalar(1.388888888888888888889e-3L), Scalar(6.111111111111111111111e-2L), Scalar(2.222222222222222222222e-2L)},
      {Scalar(-2.480158730158730158730e-5L), Scalar(-1.011904761904761904762e-2L), Scalar(-2.261904761904761904762e-2L), Scalar(-1.587301587301587301587e-3L)},
      {Scalar(2.755731922398589065256e-7L), Scalar(1.016313932980599647266e-3L), Scalar(8.478835978835978835979e-3L), Scalar(4.356261022927689594356e-3L), Scalar(7.054673721340388007055e-5L)},
      {Scalar(-2.087675698786809897921e-9L), Scalar(-6.933588530810753032975e-5L), Scalar(-1.817613970391748169526e-3L), Scalar(-3.212014323125434236545e-3L), Scalar(-5.413927636149858372081e-4L), Scalar(-2.137779915557693335471e-6L)},
      {Scalar(1.147074559772972471385e-11L), Scalar(3.428972923020542068161e-6L), Scalar(2.631969001016620064239e-4L), Scalar(1.226486623312020137417e-3L), Scalar(7.457005076052695100314e-4L), Scalar(4.795909557814319719082e-5L), Scalar(4.698417396830095242794e-8L)},
      {Scalar(-4.779477332387385297438e-14L), Scalar(-1.285878228669233960239e-7L), Scalar(-2.803784711026774518838e-5L), Scalar(-3.029072693424545276397e-4L), Scalar(-4.712798102348366898631e-4L), Scalar(-1.212541133176053810974e-4L), Scalar(-3.204516432029659542887e-6L), Scalar(-7.830695661383492071323e-10L)},
      {Scalar(1.561920696858622646222e-16L), Scalar(3.781999788349859242414e-9L), Scalar(2.312315206898194414188e-6L), Scalar(5.397351574070718518621e-5L), Scalar(1.820158438270189143378e-4L), Scalar(1.222877654647893607675e-4L), Scalar(1.486223492309877481230e-5L), Scalar(1.676664539340473911833e-7L), Scalar(1.023620347893266937428e-11L)},
  };
  static constexpr Scalar dn[terms][10] = {
      {Scalar(0.000000000000000000000e+21L), Scalar(5.000000000000000000000e-1L)},
      {Scalar(0.000000000000000000000e+21L), Scalar(-1.666666666666666666667e-1L), Scalar(-4.166666666666666666667e-2L)},
      {Scalar(0.000000000000000000000e+21L), Scalar(2.222222222222222222222e-2L), Scalar(6.111111111111111111111e-2L), Scalar(1.388888888888888888889e-3L)},
      {Scalar(0.000000000000000000000e+21L), Scalar(-1.587301587301587301587e-3L), Scalar(-2.261904761904761904762e-2L), Scalar(-1.011904761904761904762e-2L), Scalar(-2.480158730158730158730e-5L)},
      {Scalar(0.000000000000000000000e+21L), Scalar(7.054673721340388007055e-5L), Scalar(4.356261022927689594356e-3L), Scalar(8.478835978835978835979e-3L), Scalar(1.016313932980599647266e-3L), Scalar(2.755731922398589065256e-7L)},
      {Scalar(0.000000000000000000000e+21L), Scalar(-2.137779915557693335471e-6L), Scalar(-5.413927636149858372081e-4L), Scalar(-3.212014323125434236545e-3L), Scalar(-1.817613970391748169526e-3L), Scalar(-6.933588530810753032975e-5L), Scalar(-2.087675698786809897921e-9L)},
      {Scalar(0.000000000000000000000e+21L), Scalar(4.698417396830095242794e-8L), Scalar(4.795909557814319719082e-5L), Scalar(7.457005076052695100314e-4L), Scalar(1.226486623312020137417e-3L), Scalar(2.631969001016620064239e-4L), Scalar(3.428972923020542068161e-6L), Scalar(1.147074559772972471385e-11L)},
      {Scalar(0.000000000000000000000e+21L), Scalar(-7.830695661383492071323e-10L), Scalar(-3.204516432029659542887e-6L), Scalar(-1.212541133176053810974e-4L), Scalar(-4.712798102348366898631e-4L), Scalar(-3.029072693424545276397e-4L), Scalar(-2.803784711026774518838e-5L), Scalar(-1.285878228669233960239e-7L), Scalar(-4.779477332387385297438e-14L)},
      {Scalar(0.000000000000000000000e+21L), Scalar(1.023620347893266937428e-11L), Scalar(1.676664539340473911833e-7L), Scalar(1.486223492309877481230e-5L), Scalar(1.222877654647893607675e-4L), Scalar(1.820158438270189143378e-4L), Scalar(5.397351574070718518621e-5L), Scalar(2.312315206898194414188e-6L), Scalar(3.781999788349859242414e-9L), Scalar(1.561920696858622646222e-16L)},
  };


  /// A bound of row j relative to the leading terms (sn: u; 1 − cn: u²/2; 1 − dn: m u²/2),
  /// per power u^{2j}: every coefficient polynomial has terms of one sign, so the sum of
  /// their magnitudes is its value at m = 1 (tanh, sech) and bounds it on [0, 1].
  static constexpr Scalar row_bound(int j) {
    Scalar bs = 0, bc = 0, bd = 0;
    for (int k = 0; k < 10; ++k) {
      if (k < 9) bs += sn[j][k] < 0 ? -sn[j][k] : sn[j][k];
      if (k < 9) bc += cn[j][k] < 0 ? -cn[j][k] : cn[j][k];
      bd += dn[j][k] < 0 ? -dn[j][k] : dn[j][k];
    }
    bc *= 2, bd *= 2;
    return bs > bc ? (bs > bd ? bs : bd) : (bc > bd ? bc : bd);
  }
  /// The same bound for the terms free of m (sin's and cos's coefficients, and 1 − dn's
  /// term in m¹, which is m·sin²u/2's): row j at parameter m is then at most
  /// row_bound0(j) + m·row_bound(j), the rest of each polynomial being of one sign.
  static constexpr Scalar row_bound0(int j) {
    const Scalar bs = sn[j][0] < 0 ? -sn[j][0] : sn[j][0];
    const Scalar bc = 2 * (cn[j][0] < 0 ? -cn[j][0] : cn[j][0]);
    const Scalar bd = 2 * (dn[j][1] < 0 ? -dn[j][1] : dn[j][1]);
    return bs > bc ? (bs > bd ? bs : bd) : (bc > bd ? bc : bd);
  }
  /// row_bound0 (m_free) or row_bound of every row.
  static constexpr std::array<Scalar, terms> row_bounds(bool m_free) {
    std::array<Scalar, terms> b{};
    for (int j = 0; j < terms; ++j) b[std::size_t(j)] = m_free ? row_bound0(j) : row_bound(j);
    return b;
  }
};
}  // namespace detail

/// (sn, cn, dn)(u | m) for small |u| by their Maclaurin series in u, whose coefficients are
/// polynomials in m (A&S 16.22, carried on to u¹⁸ by the equations sn' = cn dn,
/// cn' = −sn dn, dn' = −m sn cn; docs/theory.md [F5]): no Landen ladder, no square root,
/// no division. The flow's increments at ordinary steps are this small (FB1 at h = 0.01:
/// |λh| ≈ 0.01), and the series replaces four ladder evaluations per step. The coefficients
/// for one m are evaluated once (the constructor); operator() is three polynomials in u².
///
/// Accuracy for |u| ≤ max_argument: every coefficient polynomial has terms of one sign, so
/// the m = 1 series (tanh, sech, radius π/2) bounds them all; the first omitted term is then
/// below 1.7e-20 of the leading one (sn: u; 1 − cn: u²/2; 1 − dn: m u²/2), under long
/// double's ε. 1 − cn and 1 − dn come out as series of their own (relative accuracy).
///
/// Truncation: given m and the largest |u| it will be evaluated at, the series keeps the
/// rows whose bound at this m (row_bound0 + m·row_bound, JacobiSeriesTables) can reach ε/16
/// of the leading term there (the rest, a geometric tail of ratio ≤ (2/π)² u², adds less
/// than ε/8). At FB1's h = 0.01 that is 4 rows of 9: the coefficients and the evaluations
/// cost a third; on a nearly symmetric body (HTA, m ≈ 2e-5) at u = 0.1, 6 rows instead of
/// the 8 that the m = 1 bound alone keeps.
template <class Scalar>
class JacobiSeries {
 public:
  static constexpr int terms = 9;                         ///< powers u¹ … u¹⁷ (sn), u² … u¹⁸
  static constexpr Scalar max_argument = Scalar(0.125);  ///< the largest |u| it is used for

  /// The coefficients at parameter m = k² ∈ [0, 1], for arguments |u| ≤ largest_argument
  /// (≤ max_argument; fewer rows for smaller arguments, see the class comment).
  explicit JacobiSeries(Scalar m, Scalar largest_argument = max_argument) {
    using T = detail::JacobiSeriesTables<Scalar>;
    const Scalar w = largest_argument * largest_argument;
    const Scalar negligible = std::numeric_limits<Scalar>::epsilon() / Scalar(16);
    Scalar wj = w;
    for (rows_ = 1; rows_ < terms; ++rows_, wj *= w)
      if ((bound0_[rows_] + m * bound_[rows_]) * wj <= negligible) break;
    for (int j = 0; j < rows_; ++j) {
      s_[j] = horner(T::sn[j], j + 1, m);
      c_[j] = horner(T::cn[j], j + 1, m);
      d_[j] = horner(T::dn[j], j + 2, m);
    }
  }

  /// The number of rows kept (1 … terms).
  int rows() const { return rows_; }

  /// (sn, cn, dn)(u | m) and the complements, for |u| ≤ the constructor's largest_argument.
  JacobiValues<Scalar> operator()(Scalar u) const {
    const Scalar w = u * u;
    Scalar s = s_[rows_ - 1], c = c_[rows_ - 1], d = d_[rows_ - 1];
    for (int j = rows_ - 2; j >= 0; --j) {
      s = s * w + s_[j];
      c = c * w + c_[j];
      d = d * w + d_[j];
    }
    JacobiValues<Scalar> r;
    r.sn = u * s;
    r.one_minus_cn = w * c;
    r.one_minus_dn = w * d;
    r.cn = Scalar(1) - r.one_minus_cn;
    r.dn = Scalar(1) - r.one_minus_dn;
    return r;
  }

 private:
  static Scalar horner(const Scalar* p, int n, Scalar m) {
    Scalar v = p[n - 1];
    for (int k = n - 2; k >= 0; --k) v = v * m + p[k];
    return v;
  }
  static constexpr std::array<Scalar, terms> bound_ = detail::JacobiSeriesTables<Scalar>::row_bounds(false);
  static constexpr std::array<Scalar, terms> bound0_ = detail::JacobiSeriesTables<Scalar>::row_bounds(true);
  int rows_ = terms;
  Scalar s_[terms], c_[terms], d_[terms];
};

}  // namespace trompo
