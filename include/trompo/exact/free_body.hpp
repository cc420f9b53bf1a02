#pragma once
// Exact solution of the torque-free rigid body (docs/theory.md §1, §8: FB1, FB2).
//
//   dΛ/dt = Λ Ω̂,   J dΩ/dt + Ω × JΩ = 0,   J = diag(J1, J2, J3) about the centre of mass
//   (or a fixed point). Conserved: π = ΛJΩ (spatial momentum), 2T = Ω·JΩ, G = |π|.
//
// Ω(t): Jacobi elliptic functions (Landau & Lifshitz §37). Name the principal axes
//   c = the axis the momentum circulates around (max inertia if G² > 2T J_mid, min if
//       G² < 2T J_mid), m = the intermediate axis, o = the other extreme. In a right-handed
//   body frame (o, m, c) with Π_c > 0:
//     Π_o = A_o cn τ,   Π_m = ε A_m sn τ,   Π_c = A_c dn τ,   τ = λ t + τ0,
//     A_o² = J_o S_c/(J_c − J_o),  A_m² = J_m S_c/(J_c − J_m),  A_c² = J_c S_o/(J_c − J_o),
//     λ² = (J_c − J_m) S_o/(J_o J_m J_c),
//     k² = (J_m − J_o) S_c / ((J_c − J_m) S_o),  k'² = (J_c − J_o)(G² − 2T J_m) / ((J_c − J_m) S_o),
//   with S_c = 2T J_c − G², S_o = G² − 2T J_o, ε = sign(J_c − J_m). S_c and S_o are
//   evaluated as sums of same-signed terms in Π (no cancellation); the separatrix distance
//   G² − 2T J_m = Σ_{i≠m} J_i Ω_i² (J_i − J_m), whose two terms do cancel, in double-double;
//   k'² is carried separately from k², so the period stays accurate next to the
//   separatrix (FB1: k'² = 5e-5).
//
// Λ(t): in a spatial frame whose third axis is π/G, write Λ = R_π Rz(φ) Rx(θ) Rz(ψ) Q
//   (Q: the body-axis relabelling onto (o, m, c)). The last row of Rz(φ)Rx(θ)Rz(ψ) is
//   Π/G, which gives θ and ψ from Π(t) explicitly; the one remaining angle obeys
//     dφ/dt = G (Π_o²/J_o + Π_m²/J_m) / (Π_o² + Π_m²)
//   (between G/J_o and G/J_m, never singular), integrated in closed form by an
//   incomplete elliptic integral of the third kind (Carlson R_J). The rotation is
//   assembled as the unit quaternion (cos θ/2 e^{iσ}, sin θ/2 e^{iδ}), σ, δ = (φ ± ψ)/2,
//   which stays regular when Π passes close to the c axis. Because Π_c > 0, θ < π/2.
//
// Degenerate inputs, all exact:
//   * Ω0 = 0 or JΩ0 ∥ Ω0 (rotation about a principal axis, including the unstable
//     intermediate one, and every Ω0 of a spherical body): Λ = Λ0 exp(t Ω̂0), Ω = Ω0.
//   * two equal moments J_a = J_b ≠ J_s (symmetric body): Λ = exp(t π̂/J_a) Λ0 exp(t ν ê_s),
//     Ω = exp(−t ν ê_s) Ω0, ν = (J_a − J_s) Ω0_s / J_a.
//   * exactly on the separatrix (G² − 2T J_mid evaluates to 0 with Π0 off the axis): k = 1,
//     sn = tanh, cn = dn = sech; Π tends to ±G e_mid as t → ±∞ (no period). This is the
//     exact solution for those inputs; any nearby input gives k < 1 and a finite period.
// The elliptic functions and integrals are in elliptic.hpp (needs Boost.Math headers).
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "trompo/exact/elliptic.hpp"
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "trompo/errors.hpp"
#include "trompo/lie/euler_poinsot.hpp"

namespace trompo::exact {

namespace detail {
/// The input checks of both free-body solutions (the messages name "FreeBody").
inline void check_free_body(const Eigen::Vector3d& J, const Eigen::Matrix3d& Lambda0, const Eigen::Vector3d& Omega0) {
    if (!J.allFinite() || !(J.minCoeff() > 0.0))
      trompo::detail::fail("FreeBody: the moments of inertia J must be finite and > 0, got ",
                           trompo::detail::to_text(J));
    if (!trompo::detail::all_finite(Omega0))
      trompo::detail::fail("FreeBody: Omega0 must be finite, got ", trompo::detail::to_text(Omega0));
    detail::check_rotation(Lambda0, "FreeBody");
}
}  // namespace detail

/// Torque-free rigid body with inertia diag(J1, J2, J3) (any order, equal moments allowed):
/// the published closed form above (Landau & Lifshitz; Carlson R_J for the precession angle).
/// Building it costs ~10 µs (complete integrals); FreeBody below evaluates the same solution
/// by the Euler–Poinsot flow [F1]–[F7] and is checked against this one in tests.
class FreeBodyClosedForm {
 public:
  /// J: principal moments (all > 0); Lambda0: initial rotation body → space;
  /// Omega0: initial body angular velocity. Throws trompo::invalid_input (naming the field and
  /// the value) on J ≤ 0,
  /// non-finite input or a Lambda0 that is not a rotation.
  FreeBodyClosedForm(const Eigen::Vector3d& J, const Eigen::Matrix3d& Lambda0, const Eigen::Vector3d& Omega0)
      : J_(J), L0_(Lambda0), W0_(Omega0) {
    detail::check_free_body(J, Lambda0, Omega0);

    const Eigen::Vector3d Pi0 = J.cwiseProduct(Omega0);  // Π0 = J Ω0
    if (Pi0.cross(Omega0).isZero(0.0)) {                 // JΩ0 ∥ Ω0: steady rotation
      kind_ = Kind::steady;
      return;
    }
    for (int s = 0; s < 3; ++s) {  // two equal moments J_a = J_b ≠ J_s: symmetric body
      const int a = (s + 1) % 3, b = (s + 2) % 3;
      if (J(a) == J(b)) {
        kind_ = Kind::symmetric;
        axis_ = s;
        pi_ = Lambda0 * Pi0;                      // π = Λ0 Π0
        Ja_ = J(a);                               // transverse moment
        nu_ = (J(a) - J(s)) * Omega0(s) / J(a);   // ν = (J_a − J_s) Ω_s / J_a
        return;
      }
    }
    kind_ = Kind::general;
    setup_general(Pi0);
  }

  /// Λ(t), body → space.
  Eigen::Matrix3d rotation(double t) const {
    switch (kind_) {
      case Kind::steady: {  // Λ = Λ0 exp(t Ω̂0)
        const double w = W0_.norm();
        if (w == 0.0) return L0_;
        return L0_ * Eigen::AngleAxisd(t * w, W0_ / w).toRotationMatrix();
      }
      case Kind::symmetric: {  // Λ = exp(t π̂/J_a) Λ0 exp(t ν ê_s)
        const double G = pi_.norm();
        return Eigen::AngleAxisd(t * G / Ja_, pi_ / G).toRotationMatrix() * L0_ *
               Eigen::AngleAxisd(t * nu_, Eigen::Vector3d::Unit(axis_)).toRotationMatrix();
      }
      case Kind::general:
      default: {
        const Local s = local(t, true);
        // Λ = R_π · R(α, β) · Q, (α, β) = (cos θ/2 e^{iσ}, sin θ/2 e^{iδ})
        return Rpi_ * detail::rotation_from_pair(s.alpha, s.beta) * Q_;
      }
    }
  }

  /// Ω(t), body angular velocity.
  Eigen::Vector3d omega(double t) const {
    switch (kind_) {
      case Kind::steady:
        return W0_;
      case Kind::symmetric:  // Ω = exp(−t ν ê_s) Ω0
        return Eigen::AngleAxisd(-t * nu_, Eigen::Vector3d::Unit(axis_)) * W0_;
      case Kind::general:
      default: {
        const Local s = local(t, false);
        return Q_.transpose() * s.Pi.cwiseQuotient(I_);  // Ω = Qᵀ J'⁻¹ Π'
      }
    }
  }

 private:
  enum class Kind { steady, symmetric, general };

  struct Local {
    Eigen::Vector3d Pi;  // Π' in the (o, m, c) frame
    std::complex<double> alpha, beta;
  };

  void setup_general(const Eigen::Vector3d& Pi0) {
    const Eigen::Vector3d& J = J_;
    Eigen::Index imin = 0, imax = 0;
    J.minCoeff(&imin);
    J.maxCoeff(&imax);
    const Eigen::Index imid = 3 - imin - imax;
    // G² − 2T J_mid = J_min Ω_min² (J_min − J_mid) + J_max Ω_max² (J_max − J_mid)
    const double sep = detail::separatrix_distance(J(imin), W0_(imin), J(imax), W0_(imax), J(imid));
    const Eigen::Index c = (sep >= 0.0) ? imax : imin;  // circulated axis (separatrix: take max)
    const Eigen::Index o = (sep >= 0.0) ? imin : imax;
    const double sc = (Pi0(c) < 0.0) ? -1.0 : 1.0;
    const double so = (Pi0(o) < 0.0) ? -1.0 : 1.0;
    // Q: rows f1 = s_o e_o, f2 = f3 × f1, f3 = s_c e_c (proper rotation); x' = Q x.
    const Eigen::Vector3d f1 = so * Eigen::Vector3d::Unit(o);
    const Eigen::Vector3d f3 = sc * Eigen::Vector3d::Unit(c);
    Q_.row(0) = f1.transpose();
    Q_.row(1) = f3.cross(f1).transpose();
    Q_.row(2) = f3.transpose();
    I_ = Eigen::Vector3d(J(o), J(imid), J(c));  // J' = diag(J_o, J_m, J_c)
    const double Io = I_(0), Im = I_(1), Ic = I_(2);
    const Eigen::Vector3d P = Q_ * Pi0;  // Π'(0): P(0) ≥ 0, P(2) > 0
    epsI_ = (Ic > Im) ? 1.0 : -1.0;      // ε = sign(J_c − J_m)
    G_ = Pi0.norm();

    // Differences of the quadratic invariants, each a sum of terms of one sign (ε):
    const double Sc = P(0) * P(0) * ((Ic - Io) / Io) + P(1) * P(1) * ((Ic - Im) / Im);  // 2T J_c − G²
    const double So = P(1) * P(1) * ((Im - Io) / Im) + P(2) * P(2) * ((Ic - Io) / Ic);  // G² − 2T J_o
    // amplitudes A_o² = J_o S_c/(J_c − J_o), A_m² = J_m S_c/(J_c − J_m), A_c² = J_c S_o/(J_c − J_o)
    const double Ao2 = P(0) * P(0) + P(1) * P(1) * (Io * (Ic - Im)) / (Im * (Ic - Io));
    const double Am2 = P(1) * P(1) + P(0) * P(0) * (Im * (Ic - Io)) / (Io * (Ic - Im));
    const double Ac2 = P(2) * P(2) + P(1) * P(1) * (Ic * (Im - Io)) / (Im * (Ic - Io));
    Ao_ = std::sqrt(Ao2);
    Am_ = std::sqrt(Am2);
    Ac_ = std::sqrt(Ac2);
    lambda_ = std::sqrt((Ic - Im) * So / (Io * Im * Ic));  // λ² = (J_c − J_m) S_o/(J_o J_m J_c)
    const double m = (Im - Io) * Sc / ((Ic - Im) * So);     // k²
    const double mc = (Ic - Io) * sep / ((Ic - Im) * So);   // k'² = 1 − k²
    ell_ = detail::Elliptic(m, mc);

    // τ0: cn τ0 = Π'_1/A_o ≥ 0, sn τ0 = ε Π'_2/A_m, τ0 = F(am τ0).
    {
      const double x = P(0) / Ao_, y = epsI_ * P(1) / Am_, h = std::hypot(x, y);
      ell_.phase_of_amplitude(y / h, x / h, tau0_, n0_);  // τ0 = n0 K + tau0_
    }
    // dφ/dt = G/J_o + G (1/J_m − 1/J_o) A_m² sn²/(A_o² cn² + A_m² sn²)
    //       = G/J_o + G (J_o − J_m)/(J_o J_m) ρ sn²/(1 − (1 − ρ) sn²),  ρ = A_m²/A_o²
    rho_ = Am2 / Ao2;
    Wc_ = ell_.complete_sn2_third_kind(rho_);
    rate_ = G_ / Io;
    coef_ = G_ * ((Io - Im) / (Io * Im)) * rho_ / lambda_;
    const detail::EllipticPhase ph0 = ell_.phase(tau0_, n0_);
    Wint0_ = w_integral(ph0);

    // e^{iφ0/2} = e^{iσ0} e^{−iψ0/2}; σ0 from the quaternion of Λ''(0) = R_πᵀ Λ0 Qᵀ,
    // well conditioned because cos θ/2 ≥ cos π/4.
    Rpi_ = detail::frame_with_third_axis((L0_ * Pi0) / G_);
    const Eigen::Quaterniond q0(Eigen::Matrix3d(Rpi_.transpose() * L0_ * Q_.transpose()));
    const std::complex<double> e_sigma0 = std::polar(1.0, std::atan2(q0.z(), q0.w()));
    half_phi0_ = e_sigma0 * std::conj(half_psi(ph0));
  }

  // e^{iψ/2} at a phase: ψ = π/2 − ε χ, χ the continuous angle of (A_o cn τ, A_m sn τ):
  // χ = am τ + atan2((A_m − A_o) sn cn, A_o cn² + A_m sn²), am τ = jπ + am r.
  std::complex<double> half_psi(const detail::EllipticPhase& ph) const {
    const double s = ph.sn, c = ph.cn;
    const double chi_r = std::atan2(s, c) + std::atan2((Am_ - Ao_) * s * c, Ao_ * c * c + Am_ * s * s);
    static const std::complex<double> ipow[4] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
    const long jm = ((ph.j % 4) + 4) % 4;
    const std::complex<double> half_chi = ipow[jm] * std::polar(1.0, 0.5 * chi_r);  // e^{iχ/2} = i^j e^{iχ_r/2}
    const std::complex<double> e_quarter_pi = std::polar(1.0, 0.25 * std::numbers::pi);
    return e_quarter_pi * (epsI_ > 0.0 ? std::conj(half_chi) : half_chi);
  }

  // W(τ) = ∫_0^τ sn²/(1 − n sn²) dτ', 1 − n sn² = cn² + ρ sn², 1 − n = ρ.
  double w_integral(const detail::EllipticPhase& ph) const {
    return ell_.sn2_third_kind(ph, ph.cn * ph.cn + rho_ * ph.sn * ph.sn, Wc_);
  }

  Local local(double t, bool attitude) const {
    const detail::EllipticPhase ph = ell_.phase(lambda_ * t + tau0_, n0_);  // τ = λ t + τ0
    const double sg = ph.sign();
    Local out;
    // Π' = (A_o cn τ, ε A_m sn τ, A_c dn τ)
    out.Pi = Eigen::Vector3d(Ao_ * sg * ph.cn, epsI_ * Am_ * sg * ph.sn, Ac_ * ph.dn);
    if (!attitude) return out;
    const double perp2 = Ao_ * Ao_ * ph.cn * ph.cn + Am_ * Am_ * ph.sn * ph.sn;  // Π'_1² + Π'_2²
    const double ch = std::sqrt((G_ + out.Pi(2)) / (2.0 * G_));                  // cos θ/2, cos θ = Π'_3/G
    const double sh = std::sqrt(perp2 / (2.0 * G_ * (G_ + out.Pi(2))));          // sin θ/2
    const double dphi = rate_ * t + coef_ * (w_integral(ph) - Wint0_);            // φ − φ0
    const std::complex<double> half_phi = half_phi0_ * std::polar(1.0, 0.5 * dphi);  // e^{iφ/2}
    const std::complex<double> hpsi = half_psi(ph);                                // e^{iψ/2}
    out.alpha = ch * half_phi * hpsi;             // cos θ/2 e^{i(φ+ψ)/2}
    out.beta = sh * half_phi * std::conj(hpsi);   // sin θ/2 e^{i(φ−ψ)/2}
    return out;
  }

  Eigen::Vector3d J_;
  Eigen::Matrix3d L0_;
  Eigen::Vector3d W0_;
  Kind kind_ = Kind::steady;
  // symmetric body
  int axis_ = 2;
  Eigen::Vector3d pi_ = Eigen::Vector3d::Zero();
  double Ja_ = 1.0, nu_ = 0.0;
  // general body
  Eigen::Matrix3d Q_ = Eigen::Matrix3d::Identity(), Rpi_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d I_ = Eigen::Vector3d::Ones();
  double G_ = 0, Ao_ = 0, Am_ = 0, Ac_ = 0, epsI_ = 1, lambda_ = 0, tau0_ = 0;  // τ0 = n0 K + tau0_
  long n0_ = 0;
  double rho_ = 1, rate_ = 0, coef_ = 0, Wint0_ = 0, Wc_ = 0;
  std::complex<double> half_phi0_{1.0, 0.0};
  detail::Elliptic ell_;
};

/// Torque-free rigid body with inertia diag(J1, J2, J3) (any order, equal moments allowed),
/// evaluated by the exact Euler–Poinsot flow (lie/euler_poinsot.hpp, docs/theory.md §14):
/// Λ(t), Ω(t) is one call of the flow from the initial state over the remainder of t modulo
/// the period of Π, turned about π by the precession of the whole periods (found once, at
/// construction, by one call over a period: the flow's closed form [F9]). An evaluation costs
/// one call over less than a period, which the flow itself reduces by its half periods to at
/// most a quarter period: ≤ K/0.5 quadrature panels (FB1: ≤ 13), whatever t. A spin about a principal axis
/// is the closed form exp(tΩ̂0); on the separatrix itself (no period) the flow runs over t up to
/// |λt| = 80, where Π has reached the middle axis, and the steady spin about it from there.
/// Throws trompo::invalid_input (naming the field and the value) on J ≤ 0, non-finite input
/// or a Lambda0 that is not a rotation.
class FreeBody {
 public:
  /// The free body of principal moments J (diagonal inertia) from Λ0 and Ω0 (body frame).
  FreeBody(const Eigen::Vector3d& J, const Eigen::Matrix3d& Lambda0, const Eigen::Vector3d& Omega0)
      : L0_(Lambda0), W0_(Omega0) {
    detail::check_free_body(J, Lambda0, Omega0);
    flow_ = trompo::EulerPoinsot<double>(J);
    J_ = J;
    q0_ = Eigen::Quaterniond(Lambda0);
    q0_.normalize();
    P0_ = J.cwiseProduct(Omega0);
    steady_ = P0_.cross(Omega0).isZero(0.0);  // JΩ0 ∥ Ω0: a steady spin
    if (steady_) return;
    period_ = flow_.period(P0_);
    if (!std::isfinite(period_)) {
      // The separatrix (no period): the time after which Π lies on the middle axis (advance).
      t_axis_ = 80.0 / std::abs(flow_.invariants(P0_).lambda);
      Eigen::Index imin = 0, imax = 0;
      J_.minCoeff(&imin);
      J_.maxCoeff(&imax);
      mid_ = 3 - imin - imax;
      return;
    }
    // After one period Π returns and Λ(t + T) = R Λ(t), R a rotation about π by ψ_T.
    Eigen::Quaterniond q = q0_;
    Eigen::Vector3d P = P0_;
    flow_.advance(q, P, period_);
    const Eigen::Quaterniond R = q * q0_.conjugate();
    const Eigen::Vector3d pi_hat = (q0_ * P0_).normalized();
    axis_ = pi_hat;
    psi_T_ = 2.0 * std::atan2(R.vec().dot(pi_hat), R.w());
  }

  /// Λ(t), body → space.
  Eigen::Matrix3d rotation(double t) const {
    if (steady_) {  // Λ = Λ0 exp(t Ω̂0)
      const double w = W0_.norm();
      if (w == 0.0) return L0_;
      return L0_ * Eigen::AngleAxisd(t * w, W0_ / w).toRotationMatrix();
    }
    Eigen::Quaterniond q;
    Eigen::Vector3d P;
    const double turns = advance(t, q, P);
    if (turns != 0.0) q = Eigen::Quaterniond(Eigen::AngleAxisd(turns * psi_T_, axis_)) * q;
    return q.normalized().toRotationMatrix();
  }

  /// Ω(t), body angular velocity.
  Eigen::Vector3d omega(double t) const {
    if (steady_) return W0_;
    Eigen::Quaterniond q;
    Eigen::Vector3d P;
    advance(t, q, P);
    return P.cwiseQuotient(J_);
  }

 private:
  // The flow from t = 0 over t − nT, n = ⌊t/T⌋ (0 without a period); returns n.
  double advance(double t, Eigen::Quaterniond& q, Eigen::Vector3d& P) const {
    double n = 0.0, r = t;
    if (std::isfinite(period_)) {
      n = std::floor(t / period_);
      r = t - n * period_;
    }
    q = q0_;
    P = P0_;
    if (std::isfinite(period_)) {
      flow_.advance(q, P, r);
      return n;
    }
    // On the separatrix there is no period to reduce t by. Π reaches the middle axis as
    // sech(u), u = u₀ + λt: past |λt| = 80 (more than |u₀| + 40 for any start, since
    // tanh u₀ < 1 in double needs |u₀| < 19) Π lies on that axis to round-off, and the motion
    // is the steady spin about it, Π = ±G e_mid. One call of the flow takes it there (160
    // panels at most): running it further, or in several calls, would feed round-off into
    // the unstable equilibrium, where it grows as e^{|λ|t}.
    if (!(std::abs(r) > t_axis_)) {
      flow_.advance(q, P, r);
      return n;
    }
    const double dt = std::copysign(t_axis_, r);
    flow_.advance(q, P, dt);
    const Eigen::Index mid = mid_;
    const double Pmid = std::copysign(P0_.norm(), P(mid));  // Π = ±G e_mid
    P = Eigen::Vector3d::Zero();
    P(mid) = Pmid;
    // Λ ← Λ exp((r − dt) Ω̂), Ω = Π/J_mid
    q = q * Eigen::Quaterniond(Eigen::AngleAxisd((r - dt) * Pmid / J_(mid), Eigen::Vector3d::Unit(mid)));
    return n;
  }

  trompo::EulerPoinsot<double> flow_;
  Eigen::Vector3d J_ = Eigen::Vector3d::Ones();
  Eigen::Matrix3d L0_;
  Eigen::Vector3d W0_;
  Eigen::Quaterniond q0_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d P0_ = Eigen::Vector3d::Zero();
  bool steady_ = false;
  double period_ = std::numeric_limits<double>::infinity();
  double t_axis_ = 0;     // separatrix: 80/|λ|, past which Π is on the middle axis
  Eigen::Index mid_ = 1;  // separatrix: the middle axis of J
  double psi_T_ = 0.0;
  Eigen::Vector3d axis_ = Eigen::Vector3d::UnitZ();
};

}  // namespace trompo::exact
