#pragma once
// Exact solution of the Lagrange top (docs/theory.md §1, §8: HT0, HT1).
//
// Symmetric heavy top about a fixed point O: J = diag(A, A, C) in body axes, centre of
// mass on body axis 3 (E = e3), V = Mgl γ·ΛE, γ the spatial unit "up" vector:
//   dΛ/dt = Λ Ω̂,   J dΩ/dt + Ω × JΩ = T,   T = −Mgl E × Λᵀγ.
// Conserved: H = ½ Ω·JΩ + Mgl γ·ΛE, μ = γ·ΛJΩ, Ω3.
//
// Method. A hanging top (Mgl < 0) is the top with Mgl → −Mgl, γ → −γ, so below Mgl ≥ 0.
// In a spatial frame with e3 = γ, Λ = Rz(φ) Rx(θ) Rz(ψ) (Euler z-x-z) and u = cos θ = γ·ΛE:
//   u̇² = f(u) = (e − βu)(1 − u²) − (a − bu)²,   β = 2Mgl/A, a = μ/A, b = CΩ3/A, e = 2(H − ½CΩ3²)/A,
//   φ̇ = (a − bu)/(1 − u²),   ψ̇ = Ω3 − u φ̇.
// f has roots u1 ≤ u0 ≤ u2 ≤ 1 ≤ u3 (u3 = +∞ if Mgl = 0) and
//   u = u1 + (u2 − u1) sn²(τ | m),  τ = λt + τ0,  m = k² = β(u2 − u1)/(4λ²),  4λ² = β(u3 − u1).
// The Euler angles are singular at u = ±1, so the attitude is assembled as the unit
// quaternion q = (cos θ/2 e^{iσ}, sin θ/2 e^{iδ}) (components (w, z) and (x, y)) with
//   2σ̇ = φ̇ + ψ̇ = Ω3 − b + D₊/y,   2δ̇ = φ̇ − ψ̇ = b − Ω3 + D₋/z,
//   z = 1 − u, y = 1 + u, D₋ = a − b, D₊ = a + b,
// each a single integral of the third kind: ∫dt/z with z = z1(1 − n sn²), n = (u2 − u1)/z1,
// and ∫dt/y (same form, or after τ → τ − K when y is small at τ = 0). D₋ → 0 exactly when
// the top passes through u = 1 (then sin θ/2 changes sign instead: s = ±√(z1/2) cn τ),
// likewise D₊ at u = −1. Every small quantity (z, y, u − u0, D±, the roots near ±1) is
// evaluated in a form without cancellation, so tilts down to the underflow threshold, steady
// precession (k → 0), the sleeping top, a top at rest upright or hanging and the plane
// pendulum are all handled by the same formulas. Ω is recovered from q and q̇ = ½ q ⊗ (0, Ω).
//
// Pitfalls handled (docs/theory.md §8): modulus vs parameter (we carry m = k² AND 1 − m), amplitude
// unwrapped across periods (2jK and 2j Π(n|m) added for τ = 2Kj + r), roots sorted by
// construction (bracketed, safeguarded Newton).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>
#include <string>

#include "trompo/errors.hpp"

#include "trompo/exact/elliptic.hpp"  // detail::Elliptic (Jacobi functions, Carlson integrals), frames

namespace trompo::exact {
namespace detail {

/// The root of g(x) = ((g3 x + g2) x + g1) x + g0 in [lo, hi], where g changes sign
/// (an endpoint is returned when rounding has already put the root there). Safeguarded
/// Newton with bisection, started from `guess`.
inline double bracketed_cubic_root(double g3, double g2, double g1, double g0, double lo, double hi,
                                   double guess) {
  const auto g = [&](double x) { return ((g3 * x + g2) * x + g1) * x + g0; };
  const auto dg = [&](double x) { return (3.0 * g3 * x + 2.0 * g2) * x + g1; };
  const double glo = g(lo), ghi = g(hi);
  if (glo == 0.0) return lo;
  if (ghi == 0.0) return hi;
  if ((glo > 0.0) == (ghi > 0.0)) return (std::abs(glo) <= std::abs(ghi)) ? lo : hi;
  double neg = (glo < 0.0) ? lo : hi;  // g(neg) < 0 < g(pos)
  double pos = (glo < 0.0) ? hi : lo;
  double x = (guess > std::min(lo, hi) && guess < std::max(lo, hi)) ? guess : 0.5 * (lo + hi);
  double step_old = std::abs(hi - lo);
  constexpr double eps = std::numeric_limits<double>::epsilon();
  for (int it = 0; it < 500; ++it) {
    const double gx = g(x);
    if (gx == 0.0) return x;
    (gx < 0.0 ? neg : pos) = x;
    const double a = std::min(neg, pos), b = std::max(neg, pos);
    double xn = x - gx / dg(x);  // Newton
    if (!(xn > a && xn < b) || 2.0 * std::abs(xn - x) > step_old) xn = 0.5 * (a + b);  // bisection
    step_old = std::abs(xn - x);
    if (step_old <= 2.0 * eps * std::abs(xn) || xn == a || xn == b) return xn;
    x = xn;
  }
  return x;
}

/// The root of the quadratic g2 x² + g1 x + g0 nearest 0, as a starting guess.
inline double small_quadratic_root(double g2, double g1, double g0) {
  if (g0 == 0.0) return 0.0;
  const double disc = g1 * g1 - 4.0 * g2 * g0;
  if (disc < 0.0 || (g1 == 0.0 && g2 == 0.0)) return 0.0;
  const double qq = -0.5 * (g1 + std::copysign(std::sqrt(disc), g1));  // stable form
  return (qq != 0.0) ? g0 / qq : 0.0;
}

}  // namespace detail

/// Symmetric heavy (Lagrange) top, closed form.
class LagrangeTop {
 public:
  /// Symmetric heavy top about a fixed point O: inertia diag(A, A, C) in body axes, centre
  /// of mass on body axis 3 (E = e3), V = Mgl γ·(ΛE), γ = spatial "up" direction
  /// (normalised here, as in UniformGravity). Mgl may be 0 (free symmetric body) or < 0
  /// (hanging top). Throws trompo::invalid_input (naming the field and the value) for A ≤ 0, C ≤ 0, non-finite input, γ = 0,
  /// or a Lambda0 that is not a rotation.
  LagrangeTop(double A, double C, double Mgl, const Eigen::Matrix3d& Lambda0, const Eigen::Vector3d& Omega0,
              const Eigen::Vector3d& gamma = Eigen::Vector3d::UnitZ())
      : Om3_(Omega0(2)) {
    if (!(std::isfinite(A) && A > 0.0)) trompo::detail::fail("LagrangeTop: A must be finite and > 0, got ", A);
    if (!(std::isfinite(C) && C > 0.0)) trompo::detail::fail("LagrangeTop: C must be finite and > 0, got ", C);
    if (!std::isfinite(Mgl)) trompo::detail::fail("LagrangeTop: Mgl must be finite, got ", Mgl);
    if (!trompo::detail::all_finite(Omega0))
      trompo::detail::fail("LagrangeTop: Omega0 must be finite, got ", trompo::detail::to_text(Omega0));
    if (!trompo::detail::all_finite(gamma) || !(gamma.norm() > 0.0))
      trompo::detail::fail("LagrangeTop: gamma must be finite and non-zero, got ", trompo::detail::to_text(gamma));
    detail::check_rotation(Lambda0, "LagrangeTop");
    setup(A, C, Mgl, Lambda0, Omega0, gamma.normalized());
  }

  /// Λ(t), body → space.
  Eigen::Matrix3d rotation(double t) const {
    const State s = state(t);
    return R0_ * detail::rotation_from_pair(std::polar(s.ch, s.sigma), std::polar(s.sh, s.delta));
  }

  /// Ω(t), body angular velocity (Ω3 is constant).
  Eigen::Vector3d omega(double t) const {
    const State s = state(t);
    const double cs = std::cos(s.sigma), ss = std::sin(s.sigma), cd = std::cos(s.delta), sd = std::sin(s.delta);
    // q = (ch cos σ, sh cos δ, sh sin δ, ch sin σ) and its time derivative
    const double w = s.ch * cs;
    const Eigen::Vector3d v(s.sh * cd, s.sh * sd, s.ch * ss);
    const double wd = s.dch * cs - s.ch_dsigma * ss;
    const Eigen::Vector3d vd(s.dsh * cd - s.sh_ddelta * sd, s.dsh * sd + s.sh_ddelta * cd,
                             s.dch * ss + s.ch_dsigma * cs);
    // q̇ = ½ q ⊗ (0, Ω)  ⇒  Ω = 2 vec(q̄ ⊗ q̇) / |q|² = 2 (w v̇ − ẇ v − v × v̇) / |q|²
    Eigen::Vector3d Om = 2.0 * (w * vd - wd * v - v.cross(vd)) / (w * w + v.squaredNorm());
    Om(2) = Om3_;  // Ω3 = const exactly
    return Om;
  }

  /// The nutation period 2K/λ: u = γ·ΛE repeats with it (infinite for a steady top).
  double nutation_period() const { return steady_ ? std::numeric_limits<double>::infinity() : 2.0 * ell_.K() / lambda_; }

  /// The time of the j-th turning point of the tilt, where λt + τ0 = jK (u = u1 + (u2 − u1)
  /// sn²(λt + τ0), so u̇ ∝ sn cn dn = 0 there): even j, the tilt is largest (u = u1); odd j,
  /// smallest (u = u2). NaN for a steady top.
  double tilt_turning_time(long j) const {
    if (steady_) return std::numeric_limits<double>::quiet_NaN();
    return (static_cast<double>(j - n0_) * ell_.K() - tau0_) / lambda_;
  }

 private:
  // Half-angle factors ch = cos θ/2, sh = sin θ/2 (signed where the top passes through
  // u = ±1), their rates, the angles σ, δ and ch σ̇, sh δ̇.
  struct State {
    double ch, sh, dch, dsh, sigma, delta, ch_dsigma, sh_ddelta;
  };

  void setup(double A, double C, double Mgl, const Eigen::Matrix3d& L0, const Eigen::Vector3d& W0,
             const Eigen::Vector3d& gamma) {
    const double sgn = (Mgl < 0.0) ? -1.0 : 1.0;
    R0_ = detail::frame_with_third_axis(sgn * gamma);  // γ-frame: e3' = sign(Mgl) γ, Mgl → |Mgl|
    const double beta = 2.0 * std::abs(Mgl) / A;         // β = 2Mgl/A
    b_ = C * Om3_ / A;                                    // b = CΩ3/A
    const Eigen::Matrix3d L = R0_.transpose() * L0;       // Λ' = R0ᵀ Λ0
    // Everything below is taken from one vector, g = Λ0ᵀγ (body components of γ), so that
    // the small quantities stay mutually consistent when the axis is near ±γ:
    // u0 = γ·ΛE = g3; z0 = 1 − u0 and y0 = 1 + u0 from g1² + g2² = z0 y0 (no cancellation).
    const Eigen::Vector3d g = L.row(2).transpose().normalized();
    const double u0 = g(2);
    const double h2 = g(0) * g(0) + g(1) * g(1);
    const double z0 = (u0 > 0.0) ? h2 / (1.0 + u0) : 1.0 - u0;
    const double y0 = (u0 > 0.0) ? 1.0 + u0 : h2 / (1.0 - u0);
    // transverse motion: q0 = |Ω⊥|² = e − βu0, w0 = γ·ΛΩ⊥ = a − b u0, u̇0 = γ·Λ(Ω × E) = g·(Ω2, −Ω1, 0)
    const double W1 = W0(0), W2 = W0(1);
    const double q0 = W1 * W1 + W2 * W2;
    const double w0 = g(0) * W1 + g(1) * W2;
    const double ud0 = g(0) * W2 - g(1) * W1;
    Dm_ = w0 - b_ * z0;  // D₋ = a − b
    Dp_ = w0 + b_ * y0;  // D₊ = a + b

    // f in three local variables, each free of cancellation near its own origin:
    //   v = u − u0:  f = βv³ + c2 v² + c1 v + c0,  c0 = u̇0² (from (q0 − βv)(z0 − v)(y0 + v) − (w0 − bv)²)
    //   z = 1 − u:   f = −βz³ + Qm z² + Lm z − D₋²,  Lm = 2P₋ − 2bD₋, Qm = 2β − P₋ − b², P₋ = e − β = q0 − βz0
    //   y = 1 + u:   f =  βy³ + Qp y² + Lp y − D₊²,  Lp = 2P₊ + 2bD₊, Qp = −(P₊ + 2β + b²), P₊ = e + β = q0 + βy0
    const double c0 = ud0 * ud0;
    const double c1 = 2.0 * b_ * w0 - 2.0 * u0 * q0 - beta * z0 * y0;
    const double c2 = 2.0 * beta * u0 - q0 - b_ * b_;
    const double Pm = q0 - beta * z0, Pp = q0 + beta * y0;
    const double Lm = 2.0 * Pm - 2.0 * b_ * Dm_, Qm = 2.0 * beta - Pm - b_ * b_;
    const double Lp = 2.0 * Pp + 2.0 * b_ * Dp_, Qp = -(Pp + 2.0 * beta + b_ * b_);
    const auto fz = [&](double z) { return ((-beta * z + Qm) * z + Lm) * z - Dm_ * Dm_; };
    const auto fy = [&](double y) { return ((beta * y + Qp) * y + Lp) * y - Dp_ * Dp_; };
    const double guess = detail::small_quadratic_root(c2, c1, c0);
    using detail::bracketed_cubic_root;

    // u2: the first root of f above u0 (u0 ≤ u2 ≤ 1), as v2 = u2 − u0 and z2 = 1 − u2.
    double v2 = 0.0, z2 = z0;
    if (z0 == 0.0 || (c0 == 0.0 && c1 <= 0.0)) {  // u0 = 1, or u0 = u2 (f = v(βv² + c2 v + c1))
    } else if (Dm_ == 0.0) {  // u = 1 is a root: f = z h(z), h(z) = −βz² + Qm z + Lm = h_v(v),
      // h_v(v) = −βv² + (q0 + b² − βy0) v + c0/z0 (f divided by z0 − v, in v)
      const double h1 = q0 + b_ * b_ - beta * y0, h0 = c0 / z0;
      if (Lm >= 0.0) {  // h ≥ 0 on [0, z0]: the top reaches the upright
        v2 = z0;
      } else if (c0 > 0.0) {
        v2 = bracketed_cubic_root(0.0, -beta, h1, h0, 0.0, z0, std::max(guess, 0.0));
      } else {  // u0 = u1: h_v = v(h1 − βv)
        v2 = (beta > 0.0 && h1 > 0.0 && h1 < beta * z0) ? h1 / beta : z0;
      }
      z2 = (v2 == z0) ? 0.0 : z0 - v2;
      if (z2 > 0.0 && z2 < 0.5 * z0) {  // polish in z: h(0) = Lm < 0 < h between u0 and u2
        const double hi = 0.5 * (z2 + z0);
        if (((-beta * hi + Qm) * hi + Lm) > 0.0) {
          z2 = bracketed_cubic_root(0.0, -beta, Qm, Lm, 0.0, hi, z2);
          v2 = z0 - z2;
        }
      }
    } else {
      v2 = (c0 > 0.0) ? bracketed_cubic_root(beta, c2, c1, c0, 0.0, z0, std::max(guess, 0.0))
                      : bracketed_cubic_root(0.0, beta, c2, c1, 0.0, z0, -c1 / c2);  // f/v
      z2 = z0 - v2;
      if (z2 < 0.5 * z0) {  // u2 near +1: polish in z (f(z = 0) = −D₋² < 0 exactly), bracketed by a
        // point strictly inside (u0, u2) where f > 0 is not lost in rounding (f(u0) = u̇0² may be)
        double hi = 0.5 * (z2 + z0);
        if (!(fz(hi) > 0.0) && c0 > 0.0) hi = z0;
        if (fz(hi) > 0.0) {
          z2 = bracketed_cubic_root(-beta, Qm, Lm, -Dm_ * Dm_, 0.0, hi, z2);
          v2 = z0 - z2;
        }
      }
    }
    // u1: the first root of f below u0 (−1 ≤ u1 ≤ u0), as v1 = u1 − u0 and y1 = 1 + u1.
    double v1 = 0.0, y1 = y0;
    if (y0 == 0.0 || (c0 == 0.0 && c1 >= 0.0)) {  // u0 = −1, or u0 = u1
    } else if (Dp_ == 0.0) {  // u = −1 is a root: f = y h(y), h(y) = βy² + Qp y + Lp = h_v(v),
      // h_v(v) = βv² − (βz0 + q0 + b²) v + c0/y0 (f divided by y0 + v, in v)
      const double h1 = -(beta * z0 + q0 + b_ * b_), h0 = c0 / y0;
      if (Lp >= 0.0 || c0 == 0.0) {  // h ≥ 0 on [0, y0] (for u0 = u2 the other root of h_v is > 0)
        v1 = -y0;
      } else {
        v1 = bracketed_cubic_root(0.0, beta, h1, h0, -y0, 0.0, std::min(guess, 0.0));
      }
      y1 = (v1 == -y0) ? 0.0 : y0 + v1;
      if (y1 > 0.0 && y1 < 0.5 * y0) {  // polish in y: h(0) = Lp < 0 < h between u1 and u0
        const double hi = 0.5 * (y1 + y0);
        if (((beta * hi + Qp) * hi + Lp) > 0.0) {
          y1 = bracketed_cubic_root(0.0, beta, Qp, Lp, 0.0, hi, y1);
          v1 = y1 - y0;
        }
      }
    } else {
      v1 = (c0 > 0.0) ? bracketed_cubic_root(beta, c2, c1, c0, -y0, 0.0, std::min(guess, 0.0))
                      : bracketed_cubic_root(0.0, beta, c2, c1, -y0, 0.0, -c1 / c2);
      y1 = y0 + v1;
      if (y1 < 0.5 * y0) {  // u1 near −1: polish in y (f(y = 0) = −D₊² < 0 exactly), as above
        double hi = 0.5 * (y1 + y0);
        if (!(fy(hi) > 0.0) && c0 > 0.0) hi = y0;
        if (fy(hi) > 0.0) {
          y1 = bracketed_cubic_root(beta, Qp, Lp, -Dp_ * Dp_, 0.0, hi, y1);
          v1 = y1 - y0;
        }
      }
    }
    y1_ = std::max(y1, 0.0);
    z2_ = std::max(z2, 0.0);
    z1_ = z0 - v1;  // z1 = 1 − u1 ≥ z0
    y2_ = y0 + v2;  // y2 = 1 + u2 ≥ y0
    d_ = v2 - v1;   // u2 − u1
    z0_ = z0;
    y0_ = y0;

    // Initial angles from the quaternion of Λ'(0) (or of q̇(0) where a half-angle factor is 0).
    const Eigen::Quaterniond qq(L);
    const Eigen::Quaterniond qd = qq * Eigen::Quaterniond(0.0, 0.5 * W0(0), 0.5 * W0(1), 0.5 * W0(2));  // q̇ = ½ q ⊗ (0, Ω)
    sigma0_ = (y0 > 0.0) ? std::atan2(qq.z(), qq.w()) : std::atan2(qd.z(), qd.w());
    delta0_ = (z0 > 0.0) ? std::atan2(qq.y(), qq.x()) : std::atan2(qd.y(), qd.x());
    // σ − δ = ψ, the spin angle, with g = (sin θ sin ψ, sin θ cos ψ, cos θ). Near u = ±1 the
    // angle of the small half of q is ill-conditioned in the rounded Λ0; take it from ψ of g,
    // consistent with w0 and u̇0 (otherwise Ω(0) is off by ~ε/sin θ).
    if (h2 > 0.0) {
      const double psi0 = std::atan2(g(0), g(1));
      if (u0 < 0.0) sigma0_ = delta0_ + psi0;  // cos θ/2 is the small factor
      else delta0_ = sigma0_ - psi0;           // sin θ/2 is the small factor
    }

    steady_ = !(d_ > 0.0);
    signed_s_ = (z2_ == 0.0);
    signed_c_ = (y1_ == 0.0);
    if (steady_) return;

    // 4λ² = β(u3 − u1) (u3 from u1 + u2 + u3 = −c2/β + 3u0), m = k² = β(u2 − u1)/(4λ²),
    // 1 − m = β(u3 − u2)/(4λ²). u3 − u2 is small when the top comes close to the upright
    // near the separatrix; with z3 = 1 − u3 from z1 z2 + (z1 + z2) z3 = −(2P₋ − 2bD₋)/β (roots of f in z):
    //   β(u3 − u2)(z1 + z2) = 2P₋ − 2bD₋ + β z2 (2 z1 + z2),  evaluated at the scale of z.
    const double four_lam2 = -c2 - 2.0 * beta * v1 - beta * v2;
    lambda_ = 0.5 * std::sqrt(four_lam2);
    const double m = beta * d_ / four_lam2;
    const double gap = (Lm + beta * z2_ * (2.0 * z1_ + z2_)) / (z1_ + z2_);
    const double mc = std::max(gap, 0.0) / four_lam2;
    ell_ = detail::Elliptic(m, mc);
    // τ0: sn² τ0 = (u0 − u1)/(u2 − u1), cn² τ0 = (u2 − u0)/(u2 − u1), sign of u̇0 = sign of sn cn
    {
      const double s = std::sqrt(-v1), c = std::sqrt(v2), h = std::hypot(s, c);
      ell_.phase_of_amplitude(s / h, c / h, tau0_, n0_);  // τ0 = n0 K + tau0_
      if (ud0 < 0.0) {
        tau0_ = -tau0_;
        n0_ = -n0_;
      }
    }
    const detail::EllipticPhase ph0 = ell_.phase(tau0_, n0_);
    const double S0 = ph0.sign() * ph0.sn, C0 = ph0.sign() * ph0.cn;
    eps_s_ = (z0 > 0.0) ? (C0 < 0.0 ? -1.0 : 1.0) : (S0 > 0.0 ? -1.0 : 1.0);  // sin θ/2 > 0, or growing, at t = 0
    eps_c_ = (y0 > 0.0) ? (S0 < 0.0 ? -1.0 : 1.0) : 1.0;                       // cos θ/2 > 0, or growing, at t = 0
    // ∫dt/z = (Π(n; τ) − Π(n; τ0))/(λ z1), z = z1 (1 − n sn²), n = (u2 − u1)/z1, 1 − n sn² = cn² + (z2/z1) sn²
    if (!signed_s_) {
      Pz_ = ell_.complete_third_kind(d_ / z1_, z2_ / z1_);  // Π(n | m), 1 − n = z2/z1
      Iz0_ = z_integral(ph0);
    }
    // ∫dt/y: y = y1 (1 − n sn²), n = −(u2 − u1)/y1 if y1 ≥ u2 − u1; else shifted by K (below)
    shifted_y_ = (y1_ < d_) && std::isfinite(ell_.K());
    if (!signed_c_) {
      Py_ = shifted_y_ ? ell_.complete_third_kind((y1_ * ell_.m() + d_) / y2_, (y1_ / y2_) * ell_.mc())  // Π(N | m), 1 − N = m' y1/y2
                       : ell_.complete_third_kind(-d_ / y1_, y2_ / y1_);                   // 1 − n = y2/y1
      Iy0_ = y_integral(tau0_, ph0);
    }
  }

  // Π(n; τ) for ∫dt/z, n = d/z1.
  double z_integral(const detail::EllipticPhase& ph) const {
    const double r = z2_ / z1_;
    return ell_.third_kind(ph, d_ / z1_, ph.cn * ph.cn + r * ph.sn * ph.sn, Pz_);
  }

  // ∫dt/y up to a constant, as λ ∫dt/y − (m/N) λt in the shifted form (the linear part
  // is added by the caller). s = λt + tau0_ is the offset of τ = n0 K + s.
  // Unshifted: (1/y1) Π(−d/y1; τ), 1 − n sn² = cn² + (y2/y1) sn².
  // Shifted (y1 < d), τ̃ = τ − K: 1/y = (1 − m sn²τ̃)/(y2 (1 − N sn²τ̃)), N = (y1 m + d)/y2,
  //   λ∫dt/y = [(m/N) τ + (1 − m/N) Π(N; τ̃)]/y2, 1 − m/N = d m'/(y1 m + d),
  //   1 − N sn²τ̃ = cn²τ̃ + (y1/y2) m' sn²τ̃, 1 − N = m' y1/y2.
  double y_integral(double s, const detail::EllipticPhase& ph) const {
    if (!shifted_y_) {
      const double r = y2_ / y1_;
      return ell_.third_kind(ph, -d_ / y1_, ph.cn * ph.cn + r * ph.sn * ph.sn, Py_) / y1_;
    }
    const double m = ell_.m(), mc = ell_.mc();
    const double N = (y1_ * m + d_) / y2_;
    const detail::EllipticPhase pt = ell_.phase(s, n0_ - 1);
    const double r = (y1_ / y2_) * mc;
    const double PN = ell_.third_kind(pt, N, pt.cn * pt.cn + r * pt.sn * pt.sn, Py_);
    return (d_ * mc / (y1_ * m + d_)) * PN / y2_;
  }

  State state(double t) const {
    State s{};
    const double half_c = 0.5 * (Om3_ - b_);  // σ̇ = ½(Ω3 − b) + ½ D₊/y
    const double half_s = 0.5 * (b_ - Om3_);  // δ̇ = ½(b − Ω3) + ½ D₋/z
    if (steady_) {                            // u ≡ u0
      s.ch = std::sqrt(0.5 * y0_);
      s.sh = std::sqrt(0.5 * z0_);
      s.dch = s.dsh = 0.0;
      const double gc = (y0_ > 0.0) ? 0.5 * Dp_ / y0_ : 0.0;
      const double gs = (z0_ > 0.0) ? 0.5 * Dm_ / z0_ : 0.0;
      s.sigma = sigma0_ + (half_c + gc) * t;
      s.delta = delta0_ + (half_s + gs) * t;
      s.ch_dsigma = (half_c + gc) * s.ch;
      s.sh_ddelta = (half_s + gs) * s.sh;
      return s;
    }
    const double s_tau = lambda_ * t + tau0_;  // τ = λt + τ0 = n0 K + s_tau
    const detail::EllipticPhase ph = ell_.phase(s_tau, n0_);
    const double sg = ph.sign();
    const double S = sg * ph.sn, Cn = sg * ph.cn, Dn = ph.dn;  // sn τ, cn τ, dn τ
    const double s2 = ph.sn * ph.sn, c2 = ph.cn * ph.cn;
    const double ud = 2.0 * d_ * lambda_ * S * Cn * Dn;  // u̇ = 2(u2 − u1) λ sn cn dn
    // sin θ/2 and δ
    if (!signed_s_) {
      const double z = z1_ * c2 + z2_ * s2;  // z = 1 − u = z1 cn² + z2 sn²
      s.sh = std::sqrt(0.5 * z);
      s.dsh = -ud / (4.0 * s.sh);  // d/dt √(z/2) = ż/(4 sh), ż = −u̇
      s.delta = delta0_ + half_s * t + 0.5 * Dm_ * (z_integral(ph) - Iz0_) / (lambda_ * z1_);
      s.sh_ddelta = half_s * s.sh + Dm_ / (4.0 * s.sh);  // sh · D₋/(2z) = D₋/(4 sh)
    } else {                                              // passes through u = 1: D₋ = 0, sin θ/2 = ±√(z1/2) cn τ
      const double a = eps_s_ * std::sqrt(0.5 * z1_);
      s.sh = a * Cn;
      s.dsh = -a * lambda_ * S * Dn;
      s.delta = delta0_ + half_s * t;
      s.sh_ddelta = half_s * s.sh;
    }
    // cos θ/2 and σ
    if (!signed_c_) {
      const double y = y1_ * c2 + y2_ * s2;  // y = 1 + u = y1 cn² + y2 sn²
      s.ch = std::sqrt(0.5 * y);
      s.dch = ud / (4.0 * s.ch);
      double Iy = (y_integral(s_tau, ph) - Iy0_) / lambda_;  // ∫_0^t dt/y
      if (shifted_y_) Iy += (ell_.m() / ((y1_ * ell_.m() + d_) / y2_)) * t / y2_;  // (m/N) t / y2
      s.sigma = sigma0_ + half_c * t + 0.5 * Dp_ * Iy;
      s.ch_dsigma = half_c * s.ch + Dp_ / (4.0 * s.ch);
    } else {  // passes through u = −1: D₊ = 0, cos θ/2 = ±√(y2/2) sn τ
      const double a = eps_c_ * std::sqrt(0.5 * y2_);
      s.ch = a * S;
      s.dch = a * lambda_ * Cn * Dn;
      s.sigma = sigma0_ + half_c * t;
      s.ch_dsigma = half_c * s.ch;
    }
    return s;
  }

  Eigen::Matrix3d R0_ = Eigen::Matrix3d::Identity();  // γ-frame → space
  double Om3_ = 0.0, b_ = 0.0, Dm_ = 0.0, Dp_ = 0.0;
  double z0_ = 0.0, y0_ = 2.0, z1_ = 0.0, z2_ = 0.0, y1_ = 2.0, y2_ = 2.0, d_ = 0.0;
  double sigma0_ = 0.0, delta0_ = 0.0, lambda_ = 0.0, tau0_ = 0.0, eps_s_ = 1.0, eps_c_ = 1.0;  // τ0 = n0 K + tau0_
  long n0_ = 0;
  double Iz0_ = 0.0, Iy0_ = 0.0, Pz_ = 0.0, Py_ = 0.0;  // integrals at t = 0, complete Π
  bool steady_ = true, signed_s_ = false, signed_c_ = false, shifted_y_ = false;
  detail::Elliptic ell_;
};

}  // namespace trompo::exact
