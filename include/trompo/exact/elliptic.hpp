#pragma once
// Shared by the exact solutions (lagrange_top.hpp, free_body.hpp), namespace detail:
// Jacobi elliptic functions and Carlson-form elliptic integrals parametrised by m = k²
// together with its complement m' = 1 − m, plus small frame helpers. (Boost's
// jacobi_elliptic/ellint_* take the modulus k and would recompute 1 − k², losing digits
// as k → 1; only Boost's Carlson R_F and R_J are used.)
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <boost/math/special_functions/ellint_rf.hpp>
#include <boost/math/special_functions/ellint_rj.hpp>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "trompo/errors.hpp"

namespace trompo::exact {
namespace detail {

/// Carlson's R_F(x, y, z) (at most one argument zero).
inline double carlson_rf(double x, double y, double z) { return boost::math::ellint_rf(x, y, z); }
/// Carlson's R_J(x, y, z, p) (at most one of x, y, z zero, p > 0).
inline double carlson_rj(double x, double y, double z, double p) { return boost::math::ellint_rj(x, y, z, p); }

/// sn, cn, dn of (u | m), given the parameter m = k² and its complement mc = 1 − m.
/// Arithmetic–geometric mean with descending Landen transformation (Abramowitz & Stegun
/// 16.4): a0 = 1, b0 = √mc, c0 = √m; φ_N = 2^N a_N u; φ_{n−1} = (φ_n + asin(c_n/a_n sin φ_n))/2;
/// sn = sin φ0, cn = cos φ0, dn = √(cn² + mc sn²). Accurate for moderate |u| (callers
/// reduce u to [−K, K]).
inline void jacobi_sncndn(double u, double m, double mc, double& sn, double& cn, double& dn) {
  if (m <= 0.0) {  // k = 0: circular functions
    sn = std::sin(u);
    cn = std::cos(u);
    dn = 1.0;
    return;
  }
  if (mc <= 0.0) {  // k = 1: hyperbolic functions (separatrix)
    sn = std::tanh(u);
    cn = 1.0 / std::cosh(u);
    dn = cn;
    return;
  }
  constexpr int nmax = 24;
  double a[nmax + 1];
  double c[nmax + 1];
  a[0] = 1.0;
  c[0] = std::sqrt(m);
  double b = std::sqrt(mc);
  int n = 0;
  while (n < nmax && c[n] > std::numeric_limits<double>::epsilon() * a[n]) {
    a[n + 1] = 0.5 * (a[n] + b);              // a_{n+1} = (a_n + b_n)/2
    c[n + 1] = c[n] * c[n] / (4.0 * a[n + 1]);  // c_{n+1} = (a_n − b_n)/2 = c_n²/(4 a_{n+1})
    b = std::sqrt(a[n] * b);                    // b_{n+1} = √(a_n b_n)
    ++n;
  }
  double phi = std::ldexp(a[n] * u, n);  // φ_N = 2^N a_N u
  for (int i = n; i > 0; --i) phi = 0.5 * (phi + std::asin(c[i] / a[i] * std::sin(phi)));
  sn = std::sin(phi);
  cn = std::cos(phi);
  dn = std::sqrt(cn * cn + mc * sn * sn);  // dn² = 1 − m sn² = cn² + mc sn²
}

/// A point τ = 2K j + r of the elliptic phase, r ∈ [−K, K], with sn, cn, dn of r.
/// sn τ = (−1)^j sn r, cn τ = (−1)^j cn r, dn τ = dn r.
struct EllipticPhase {
  long j = 0;
  double r = 0, sn = 0, cn = 1, dn = 1;
  /// (−1)^j
  double sign() const { return (j % 2 == 0) ? 1.0 : -1.0; }
};

/// Elliptic functions and integrals for one parameter m = k² (and mc = 1 − m, given).
class Elliptic {
 public:
  /// m = 0 (circular functions).
  Elliptic() : Elliptic(0.0, 1.0) {}
  /// m = k² ∈ [0, 1], mc = 1 − m computed by the caller without cancellation.
  Elliptic(double m, double mc) : m_(std::clamp(m, 0.0, 1.0)), mc_(std::clamp(mc, 0.0, 1.0)) {
    K_ = (mc_ > 0.0) ? carlson_rf(0.0, mc_, 1.0) : std::numeric_limits<double>::infinity();  // K = R_F(0, m', 1)
    r_quarter_ = std::sqrt(0.5) * carlson_rf(0.5, 0.5 + 0.5 * mc_, 1.0);                     // F(π/4)
  }
  /// The parameter m = k².
  double m() const { return m_; }
  /// The complementary parameter m' = k'² = 1 − m.
  double mc() const { return mc_; }
  /// Complete integral of the first kind K(m) (+∞ when m = 1).
  double K() const { return K_; }

  /// The phase τ = n K + s, given as an integer number n of quarter periods and an offset s
  /// (so that a phase close to a quarter period, where cn is small, keeps its relative
  /// accuracy), reduced to τ = 2Kj + r, r ∈ [−K, K], with sn, cn, dn evaluated at r.
  /// No reduction when K = ∞ (m = 1; then n must be 0).
  ///
  /// When k' is small (a top passing close to the upright, a body next to the separatrix)
  /// cn r and dn r are small over most of the quarter period, and the AGM alone gives them
  /// only to an absolute ~ε/√k'. So for k'² < 0.05 the AGM value is polished by Newton on
  /// the amplitude, using Carlson's form of F, in the variable that is small:
  ///   |r| ≤ F(π/4):  φ = am |r|,       |r|     = sin φ R_F(cos²φ, cos²φ + m' sin²φ, 1);
  ///   |r| > F(π/4):  ψ = π/2 − am |r|, K − |r| = sin ψ R_F(m' cos²ψ, m' + m sin²ψ, m'),
  /// then sn = sin φ | cos ψ, cn = cos φ | sin ψ, dn = √(cn² + m' sn²) | √(m' + m sin²ψ),
  /// each with a relative accuracy of a few ε.
  EllipticPhase phase(double s, long n = 0) const {
    EllipticPhase p;
    if (!std::isfinite(K_) || m_ == 0.0) {  // m = 1 or m = 0: closed forms
      const double tau = (n == 0) ? s : s + static_cast<double>(n) * K_;
      if (std::isfinite(K_)) {
        p.j = std::lround(tau / (2.0 * K_));
        p.r = tau - 2.0 * K_ * static_cast<double>(p.j);
      } else {
        p.r = tau;
      }
      jacobi_sncndn(p.r, m_, mc_, p.sn, p.cn, p.dn);
      return p;
    }
    const long q = std::lround(s / K_);  // τ = (n + q) K + s', |s'| ≤ K/2
    const double sr = s - static_cast<double>(q) * K_;
    const long nq = n + q;
    double x = 0.0;  // distance of |r| from K, when |r| > F(π/4)
    bool near_quarter = false;
    if (nq % 2 == 0) {  // r = s'
      p.j = nq / 2;
      p.r = sr;
      if (std::abs(sr) > r_quarter_) {
        near_quarter = true;
        x = K_ - std::abs(sr);
      }
    } else {  // r = ±(K − |s'|)
      near_quarter = true;
      x = std::abs(sr);
      p.j = (sr <= 0.0) ? (nq - 1) / 2 : (nq + 1) / 2;
      p.r = (sr <= 0.0) ? K_ - x : -(K_ - x);
    }
    constexpr double eps = std::numeric_limits<double>::epsilon();
    const bool polish = mc_ < 0.05;  // for k' > 0.2 the AGM error is already ≲ 2ε
    if (!near_quarter && !polish) {
      jacobi_sncndn(p.r, m_, mc_, p.sn, p.cn, p.dn);
      return p;
    }
    if (near_quarter && !polish) {  // sn(K − x) = cn x/dn x, cn(K − x) = k' sn x/dn x, dn(K − x) = k'/dn x
      double sx, cx, dx;
      jacobi_sncndn(x, m_, mc_, sx, cx, dx);
      const double kc = std::sqrt(mc_);
      p.sn = std::copysign(cx / dx, p.r);
      p.cn = kc * sx / dx;
      p.dn = kc / dx;
      return p;
    }
    if (!near_quarter) {
      const double a = std::abs(p.r);
      double sn, cn, dn;
      jacobi_sncndn(a, m_, mc_, sn, cn, dn);
      double phi = std::atan2(sn, cn);
      for (int it = 0; it < 8; ++it) {  // Newton on F(φ) = a, dF/dφ = 1/dn
        const double si = std::sin(phi), co = std::cos(phi), d2 = co * co + mc_ * si * si;
        const double step = (si * carlson_rf(co * co, d2, 1.0) - a) * std::sqrt(d2);
        phi -= step;
        if (std::abs(step) <= 2.0 * eps * phi) break;
      }
      p.sn = std::sin(phi);
      p.cn = std::cos(phi);
      p.dn = std::sqrt(p.cn * p.cn + mc_ * p.sn * p.sn);
    } else {
      double sx, cx, dx;
      jacobi_sncndn(x, m_, mc_, sx, cx, dx);
      const double kc = std::sqrt(mc_);
      double psi = std::atan2(kc * sx, cx);  // tan ψ = cn r / sn r = k' sn x / cn x
      for (int it = 0; it < 12; ++it) {      // Newton on F_c(ψ) = x, dF_c/dψ = 1/dn
        const double si = std::sin(psi), co = std::cos(psi), d2 = mc_ + m_ * si * si;
        const double step = (si * carlson_rf(mc_ * co * co, d2, mc_) - x) * std::sqrt(d2);
        psi -= step;
        if (std::abs(step) <= 2.0 * eps * std::abs(psi)) break;
      }
      p.sn = std::cos(psi);
      p.cn = std::sin(psi);
      p.dn = std::sqrt(mc_ + m_ * p.cn * p.cn);
    }
    p.sn = std::copysign(p.sn, p.r);
    return p;
  }

  /// The phase τ = F(φ | m) of an amplitude φ ∈ [−π/2, π/2] given by s = sin φ, c = cos φ ≥ 0,
  /// as n K + offset (see phase()): n = 0 for |φ| ≤ π/4, else n = ±1 and
  /// offset = ∓F_c(π/2 − |φ|), F_c(ψ) = sin ψ R_F(m' cos²ψ, m' + m sin²ψ, m') (= K − F(π/2 − ψ)).
  void phase_of_amplitude(double s, double c, double& offset, long& n) const {
    if (!std::isfinite(K_) || std::abs(s) <= c) {
      offset = F(s, c);
      n = 0;
      return;
    }
    const double x = c * carlson_rf(mc_ * s * s, mc_ + m_ * c * c, mc_);  // F_c(ψ), sin ψ = c, cos ψ = |s|
    n = (s > 0.0) ? 1 : -1;
    offset = (s > 0.0) ? -x : x;
  }

  /// Incomplete F(φ | m) for φ ∈ [−π/2, π/2] given s = sin φ, c = cos φ ≥ 0:
  /// F = s R_F(c², 1 − m s², 1), with 1 − m s² = c² + mc s².
  double F(double s, double c) const {
    const double c2 = floor_sq(c);
    return s * carlson_rf(c2, c2 + mc_ * s * s, 1.0);
  }

  /// Complete integral of the third kind Π(n | m) = R_F(0, m', 1) + (n/3) R_J(0, m', 1, 1 − n),
  /// given p_complete = 1 − n (computed by the caller without cancellation); +∞ when m = 1.
  double complete_third_kind(double n, double p_complete) const {
    if (!std::isfinite(K_)) return std::numeric_limits<double>::infinity();
    return K_ + (n / 3.0) * carlson_rj(0.0, mc_, 1.0, p_complete);
  }

  /// ∫_0^τ dτ'/(1 − n sn² τ') (= Π(n; am τ | m), unwrapped across periods):
  ///   2j Π(n | m) + s R_F(c², dn², 1) + (n/3) s³ R_J(c², dn², 1, p),
  /// s, c, dn at r. p = 1 − n sn² r is supplied by the caller (computed without
  /// cancellation), complete = complete_third_kind(n, 1 − n); n ≤ 1, p > 0 except where
  /// the integral diverges.
  double third_kind(const EllipticPhase& ph, double n, double p, double complete) const {
    const double c2 = floor_sq(ph.cn);
    const double d2 = std::max(ph.dn * ph.dn, c2);
    const double s = ph.sn;
    double v = s * carlson_rf(c2, d2, 1.0) + (n / 3.0) * s * s * s * carlson_rj(c2, d2, 1.0, p);
    if (ph.j != 0) v += 2.0 * static_cast<double>(ph.j) * complete;
    return v;
  }

  /// ∫_0^K sn²/(1 − n sn²) dτ = R_J(0, m', 1, 1 − n)/3, given p_complete = 1 − n; +∞ when m = 1.
  double complete_sn2_third_kind(double p_complete) const {
    if (!std::isfinite(K_)) return std::numeric_limits<double>::infinity();
    return carlson_rj(0.0, mc_, 1.0, p_complete) / 3.0;
  }

  /// ∫_0^τ sn² τ' dτ'/(1 − n sn² τ') = (Π − F)/n, without the division by n:
  ///   2j complete + (s³/3) R_J(c², dn², 1, p),  p = 1 − n sn² r,
  /// complete = complete_sn2_third_kind(1 − n).
  double sn2_third_kind(const EllipticPhase& ph, double p, double complete) const {
    const double c2 = floor_sq(ph.cn);
    const double d2 = std::max(ph.dn * ph.dn, c2);
    const double s = ph.sn;
    double v = (s * s * s / 3.0) * carlson_rj(c2, d2, 1.0, p);
    if (ph.j != 0) v += 2.0 * static_cast<double>(ph.j) * complete;
    return v;
  }

 private:
  // c², kept ≥ the smallest normal number when m = 1 (sech τ underflows for |τ| ≳ 355,
  // and R_F, R_J accept at most one zero argument).
  double floor_sq(double c) const {
    const double c2 = c * c;
    return (mc_ > 0.0) ? c2 : std::max(c2, std::numeric_limits<double>::min());
  }

  double m_ = 0.0, mc_ = 1.0, K_ = 0.0, r_quarter_ = 0.0;  // K_, r_quarter_ set by the constructor
};

/// G² − 2T J_m restricted to the two other axes a, b (the separatrix distance):
///   Σ_{i = a, b} J_i Ω_i² (J_i − J_m),
/// evaluated in double-double arithmetic (error-free sums and fma products), because the
/// two terms cancel next to the separatrix and the period depends on their difference.
inline double separatrix_distance(double Ja, double Wa, double Jb, double Wb, double Jm) {
  struct DD {
    double hi, lo;
  };
  const auto two_sum = [](double a, double b) {  // a + b = hi + lo exactly
    const double s = a + b, bb = s - a;
    return DD{s, (a - (s - bb)) + (b - bb)};
  };
  const auto mul = [&](DD x, DD y) {  // (x.hi + x.lo)(y.hi + y.lo), to ~ε²
    const double p = x.hi * y.hi, e = std::fma(x.hi, y.hi, -p);
    return two_sum(p, e + (x.hi * y.lo + x.lo * y.hi));
  };
  const auto term = [&](double Ji, double Wi) {  // J_i Ω_i² (J_i − J_m)
    const double w2 = Wi * Wi;
    const DD W2{w2, std::fma(Wi, Wi, -w2)};
    return mul(mul(W2, DD{Ji, 0.0}), two_sum(Ji, -Jm));
  };
  const DD ta = term(Ja, Wa), tb = term(Jb, Wb);
  const DD hi = two_sum(ta.hi, tb.hi);
  return hi.hi + (hi.lo + ta.lo + tb.lo);
}

/// A rotation whose third column is the unit vector n (any completion).
inline Eigen::Matrix3d frame_with_third_axis(const Eigen::Vector3d& n) {
  Eigen::Index i = 0;
  n.cwiseAbs().minCoeff(&i);  // the coordinate axis least aligned with n
  const Eigen::Vector3d e1 = Eigen::Vector3d::Unit(i).cross(n).normalized();
  Eigen::Matrix3d R;
  R.col(0) = e1;
  R.col(1) = n.cross(e1);
  R.col(2) = n;
  return R;
}

/// Throws trompo::invalid_input unless Λ is finite and a proper rotation to 1e-10.
inline void check_rotation(const Eigen::Matrix3d& L, const char* who) {
  if (!trompo::detail::all_finite(L))
    trompo::detail::fail(who, ": Lambda0 must be finite, got ", trompo::detail::to_text(L));
  const double err = (L.transpose() * L - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (err > 1e-10)
    trompo::detail::fail(who, ": Lambda0 is not a rotation, |LambdaT Lambda - I| = ", err);
  if (L.determinant() <= 0.0)
    trompo::detail::fail(who, ": Lambda0 is not a rotation, determinant ", L.determinant());
}

/// Unit quaternion (w, x, y, z) = (Re α, Re β, Im β, Im α) as a rotation matrix.
inline Eigen::Matrix3d rotation_from_pair(std::complex<double> alpha, std::complex<double> beta) {
  Eigen::Quaterniond q(alpha.real(), beta.real(), beta.imag(), alpha.imag());
  q.normalize();
  return q.toRotationMatrix();
}

}  // namespace detail
}  // namespace trompo::exact
