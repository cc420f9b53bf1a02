#pragma once
// The exact torque-free rotation of any rigid body (Euler–Poinsot), docs/theory.md §14
// [F1]–[F7]: the free sub-flow of the splittings on asymmetric bodies (schemes/splitting/),
// a step of its own, and the machinery of exact::FreeBody. Pure rotation-group maths on
// (q, Π), hence in lie/.
//
//   EulerPoinsot<double> flow(Eigen::Vector3d(1, 2, 3));   // principal moments, any order
//   flow.advance(q, Pi, h);   // (Λ, Π) ← exact free flow over h, in the principal body frame
//
// One call reads the phase (sn, cn, dn)(u₀) off Π [F4] (no complete elliptic integral, no
// amplitude), advances it by the addition theorems with (sn, cn, dn) of the increment only
// [F5] (a Maclaurin series for small increments, the Landen ladder otherwise), writes
// Π' = Π + B·Δ in increment form (the round trip Π → phase → Π would bias |Π| by about an
// ulp per step), and turns the attitude by the minimal rotations a(Π) and the
// precession angle ψ, integrated by 3-, 5- or 7-point Gauss–Legendre (by the panel's span and k²)
// on panels |λ|h_p ≤ ½ [F6]; after
// each panel of a multi-panel call the phase is projected back onto sn² + cn² = 1,
// dn² = m' + m cn² (chained additions are unstable next to the separatrix). A long step
// first takes out the half periods of Π nearest to it in closed form (a turn about π by the
// precession of a half period, Bulirsch's complete integral) and integrates the remainder,
// at most a quarter period [F9]. The quaternion
// is a product of unit factors, kept unit by a Newton step at the end (q must come in unit).
//
// Branches [F7]: two equal moments (|ΔJ| ≤ 8ε·max J) take the exact symmetric flow [S2];
// a pure spin about any principal axis, k² → 0 and k² → 1 (including exactly on the
// separatrix, m' = 0: tanh, sech) go through the general formulas, which stay finite
// there; both senses of rotation (σ = sgn Π₁). Π = 0: nothing moves.
// No allocation, no virtual call; Scalar = float, double or long double.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include "trompo/errors.hpp"
#include "trompo/lie/jacobi.hpp"
#include "trompo/lie/so3.hpp"

namespace trompo {

namespace detail {
/// Gauss–Legendre on [−1, 1] with N = 2·pairs + 1 points: the centre and symmetric pairs.
template <class Scalar, int N>
struct GaussLegendre;
template <class Scalar>
struct GaussLegendre<Scalar, 3> {
  static constexpr int pairs = 1;
  static constexpr Scalar w0 = Scalar(0.888888888888888888888888888888888889L);
  static constexpr Scalar x[1] = {Scalar(0.774596669241483377035853079956479922L)};
  static constexpr Scalar w[1] = {Scalar(0.555555555555555555555555555555555556L)};
};
template <class Scalar>
struct GaussLegendre<Scalar, 5> {
  static constexpr int pairs = 2;
  static constexpr Scalar w0 = Scalar(0.568888888888888888888888888888888889L);
  static constexpr Scalar x[2] = {Scalar(0.538469310105683091036314420700208805L),
                                  Scalar(0.906179845938663992797626878299392965L)};
  static constexpr Scalar w[2] = {Scalar(0.478628670499366468041291514835638192L),
                                  Scalar(0.236926885056189087514264040719917363L)};
};
template <class Scalar>
struct GaussLegendre<Scalar, 7> {
  static constexpr int pairs = 3;
  static constexpr Scalar w0 = Scalar(0.417959183673469387755102040816326531L);
  static constexpr Scalar x[3] = {Scalar(0.405845151377397166906606412076961463L),
                                  Scalar(0.741531185599394439863864773280788407L),
                                  Scalar(0.949107912342758524526189684047851262L)};
  static constexpr Scalar w[3] = {Scalar(0.381830050505118944950369775488975134L),
                                  Scalar(0.279705391489276667901467771423779582L),
                                  Scalar(0.129484966168869693270611432679082018L)};
};

/// q ← q ⊗ (c, sn e_K): right product with a rotation about principal axis K, written out.
template <int K, class Scalar>
inline void multiply_axis(Eigen::Quaternion<Scalar>& q, Scalar c, Scalar sn) {
  const Scalar w = q.w(), x = q.x(), y = q.y(), z = q.z();
  if constexpr (K == 0) {
    q.w() = w * c - x * sn, q.x() = x * c + w * sn, q.y() = y * c + z * sn, q.z() = z * c - y * sn;
  } else if constexpr (K == 1) {
    q.w() = w * c - y * sn, q.x() = x * c - z * sn, q.y() = y * c + w * sn, q.z() = z * c + x * sn;
  } else {
    q.w() = w * c - z * sn, q.x() = x * c + y * sn, q.y() = y * c - x * sn, q.z() = z * c + w * sn;
  }
}

/// Π ← exp(−φ ê_K) Π given c = cos(φ/2), sn = sin(φ/2), in increment form [S5]:
/// x' = x + ((cos φ − 1) x + sin φ y) with cos φ − 1 = −2 sin²(φ/2). The direct form
/// cos φ·x + sin φ·y rounds cos φ ≈ 1 the same way on every step when the angle repeats
/// (HT0/HT1: Π_s and h constant), a systematic scale error growing like N·ε.
template <int K, class Vector3, class Scalar>
inline void rotate_back_axis(Vector3& P, Scalar c, Scalar sn) {
  constexpr int i1 = (K + 1) % 3, i2 = (K + 2) % 3;
  const Scalar cm1 = Scalar(-2) * sn * sn, s2 = Scalar(2) * sn * c;
  const Scalar x = P(i1), y = P(i2);
  P(i1) = x + (cm1 * x + s2 * y);
  P(i2) = y + (cm1 * y - s2 * x);
}

/// [S2] the exact free flow of a body symmetric about principal axis K for a time t,
/// T = ½|Π|²/J_a + ½ c Π_K² with c = 1/J_K − 1/J_a:
///   Λ ← Λ exp(t Π̂/J_a) exp(t ν ê_K),  Π ← exp(−t ν ê_K) Π,  ν = c Π_K.
/// The splittings' symmetric sub-flow (axis 3 of their working frame) and EulerPoinsot's
/// symmetric branch [F7].
template <int K, class Scalar, class Vector3>
inline void symmetric_free_flow(Eigen::Quaternion<Scalar>& q, Vector3& Pi, Scalar t, Scalar Ja_inv, Scalar c) {
  // The first factor turns by 2·half, half = a|Π|: its quaternion is (cos half, k Π) with
  // k = sin(half)/|Π| = a·sinc(half), from half² = a²|Π|² below the series' switch (no root,
  // no division); above it (or if a²|Π|² overflows) from |Π| itself.
  const Scalar a = Scalar(0.5) * t * Ja_inv;
  const Scalar half_sq = a * a * Pi.squaredNorm();
  constexpr Scalar switch_sq = small_angle<Scalar>::theta * small_angle<Scalar>::theta;
  Scalar k, ch, sp, cp;
  if (half_sq < switch_sq) {
    Scalar sinc_half;
    small_sinc_cos(half_sq, sinc_half, ch);
    k = a * sinc_half;
  } else {
    const Scalar pn = Pi.norm();
    Scalar sh;
    sin_cos(a * pn, sh, ch);
    k = pn > Scalar(0) ? sh / pn : Scalar(0);  // Π = 0: no rotation
  }
  q = q * Eigen::Quaternion<Scalar>(ch, k * Pi.x(), k * Pi.y(), k * Pi.z());
  const Scalar phi_half = Scalar(0.5) * t * c * Pi(K);
  sin_cos(phi_half, sp, cp);
  multiply_axis<K>(q, cp, sp);
  rotate_back_axis<K>(Pi, cp, sp);
}
}  // namespace detail

/// The exact free rotation of a rigid body with principal moments J (in the frame where Π is
/// given): constants computed once from J, then advance() at any (q, Π, h).
template <class Scalar>
class EulerPoinsot {
 public:
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A quaternion of Scalar (kept unit).
  using Quaternion = Eigen::Quaternion<Scalar>;

  /// Largest |λ|·h of one quadrature panel [F6] (7 points hold round-off up to here).
  static constexpr Scalar panel_max = Scalar(0.5);
  /// Most panels one step may take after its half periods are taken out [F9] (|λ|h ≤ 2¹⁵);
  /// only a step next to the separatrix, whose period exceeds that, can need more, and is
  /// refused as failed.
  static constexpr Scalar max_panels = Scalar(65536);

  EulerPoinsot() : EulerPoinsot(Vector3::Ones()) {}
  /// Principal moments J (all finite and > 0, any order). Throws invalid_input otherwise.
  explicit EulerPoinsot(const Vector3& J) : J_(J) {
    using std::abs;
    using std::sqrt;
    for (int i = 0; i < 3; ++i)
      if (!(std::isfinite(J(i)) && J(i) > Scalar(0)))
        detail::fail("EulerPoinsot: the principal moments J must be finite and > 0, got ", detail::to_text(J));
    const Scalar tol = Scalar(8) * std::numeric_limits<Scalar>::epsilon() * J.maxCoeff();
    for (int s = 0; s < 3; ++s) {  // two equal moments J_a = J_b: symmetric about s [S2]
      const int a = (s + 1) % 3, b = (s + 2) % 3;
      if (abs(J(a) - J(b)) <= tol) {
        symmetric_ = true;
        s_axis_ = s;
        Ja_inv_ = Scalar(1) / J(a);
        c_s_ = Scalar(1) / J(s) - Ja_inv_;
        return;
      }
    }
    Eigen::Index lo = 0, hi = 0;
    J.minCoeff(&lo);
    J.maxCoeff(&hi);
    imin_ = int(lo), imax_ = int(hi), imid_ = 3 - imin_ - imax_;
    c_max_ = (J(imax_) - J(imid_)) / J(imax_);
    c_min_ = (J(imin_) - J(imid_)) / J(imin_);
    slots_[0] = make_slots(imax_, imid_, imin_);  // G² ≥ 2T J_mid: the polhode circles the max axis
    slots_[1] = make_slots(imin_, imid_, imax_);  // else the min axis [F2]
  }

  /// The principal moments.
  const Vector3& inertia() const { return J_; }
  /// Whether two moments are equal (the symmetric flow [S2] is used).
  bool symmetric() const { return symmetric_; }

  /// The invariants of a momentum, as the flow reads them [F1]–[F3]: k² (m), 1 − k² (mc),
  /// the rate λ of the phase u, and the slot-1 axis (the one the polhode circles).
  struct Invariants {
    Scalar m = Scalar(0);       ///< k², the modulus
    Scalar mc = Scalar(1);      ///< 1 − k²
    Scalar lambda = Scalar(0);  ///< the rate λ of the phase u = u₀ + λt
    /// The principal axis in slot 1 (the one the polhode circles).
    int circled_axis = 0;
  };
  /// The invariants of Π (a symmetric body: m = 0, λ = 0).
  Invariants invariants(const Vector3& Pi) const {
    Invariants inv;
    if (symmetric_) return inv;
    const Phase ph = phase(Pi);
    inv.m = ph.m, inv.mc = ph.mc, inv.lambda = ph.lambda, inv.circled_axis = slots_[ph.cfg].p[0];
    return inv;
  }

  /// The period of Π(t) from Π, 4K(k)/|λ| [F3]: after it Π returns and Λ has turned about
  /// π by a fixed angle. +∞ where there is none to use: a symmetric body (its flow is a
  /// closed form), Π = 0, the separatrix.
  Scalar period(const Vector3& Pi) const {
    using std::abs;
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    if (symmetric_) return inf;
    const Phase ph = phase(Pi);
    if (!(abs(ph.lambda) > Scalar(0))) return inf;
    return Scalar(4) * JacobiModulus<Scalar>(ph.m, ph.mc).quarter_period() / abs(ph.lambda);
  }

  /// (q, Π) ← the exact free flow over h [F3]–[F6]; q (body → space, unit) and Π (body
  /// momentum) in the frame of J. Non-finite input or h gives non-finite output.
  void advance(Quaternion& q, Vector3& Pi, Scalar h) const {
    if (symmetric_) {
      advance_symmetric(q, Pi, h);
    } else {
      advance_general(q, Pi, h);
    }
    detail::newton_unit(q, q.squaredNorm());  // a product of unit factors: |q|² = 1 + O(ε)
  }

 private:
  // One slot configuration [F2]: slot i holds body axis p[i] with sign sg[i] (det +1), and
  // the constants of [F3] that depend on the moments only.
  struct Slots {
    int p[3] = {0, 1, 2};
    Scalar sg3 = Scalar(1);                 // sign of slot 3 (slots 1, 2 keep theirs)
    Scalar iI1 = 0, iI2 = 0, iI3 = 0;       // 1/I_i
    Scalar c21 = 0, c31 = 0, c13 = 0, c23 = 0;  // I_ij/I_i: Δ1 = Π2² c21 + Π3² c31, Δ3 = Π1² c13 + Π2² c23
    Scalar km = 0, kmc = 0;                 // m = |Δ1 km/Δ3|, m' = |Δ2 kmc/Δ3|
    Scalar rb1 = 0, rb2 = 0, rb3 = 0;       // √|I1/I13|, √|I2/I21|, √|I3/I31|: B1 = rb1√|Δ3|, B2,3 = rb2,3√|Δ1|
    Scalar irb1 = 0, irb2 = 0, irb3 = 0;    // their inverses (the phase [F4] without division)
    Scalar rlam = 0, lam_sign = 0;          // |λ| = rlam √|Δ3|, λ = σ·lam_sign·|λ|
  };

  Slots make_slots(int p1, int p2, int p3) const {
    using std::abs;
    using std::sqrt;
    Slots s;
    s.p[0] = p1, s.p[1] = p2, s.p[2] = p3;
    const bool even = (p2 == (p1 + 1) % 3);
    s.sg3 = even ? Scalar(1) : Scalar(-1);
    const Scalar I1 = J_(p1), I2 = J_(p2), I3 = J_(p3);
    s.iI1 = Scalar(1) / I1, s.iI2 = Scalar(1) / I2, s.iI3 = Scalar(1) / I3;
    s.c21 = (I2 - I1) / I2, s.c31 = (I3 - I1) / I3;
    s.c13 = (I1 - I3) / I1, s.c23 = (I2 - I3) / I2;
    s.km = (I3 - I2) / (I1 - I2);
    s.kmc = (I1 - I3) / (I1 - I2);
    s.rb1 = sqrt(abs(I1 / (I1 - I3)));
    s.rb2 = sqrt(abs(I2 / (I2 - I1)));
    s.rb3 = sqrt(abs(I3 / (I3 - I1)));
    s.irb1 = Scalar(1) / s.rb1, s.irb2 = Scalar(1) / s.rb2, s.irb3 = Scalar(1) / s.rb3;
    s.rlam = sqrt(abs((I1 - I2) / (I1 * I2 * I3)));
    s.lam_sign = (I2 - I1) > Scalar(0) ? Scalar(-1) : Scalar(1);  // λ = −σ sgn(I21)|λ| [F3]
    return s;
  }

  // The state of the polhode read off Π [F3], [F4].
  struct Phase {
    int cfg = 0;
    Scalar P1 = 0, P2 = 0, P3 = 0;      // Π in slots
    Scalar G = 0, iG = 0, T2 = 0, D1 = 0;  // |Π|, 1/|Π|, 2T, Δ1
    Scalar m = 0, mc = 1, lambda = 0, sigma = 1;
    Scalar B1 = 0, B2 = 0, B3 = 0;
    Scalar s = 0, c = 1, d = 1;         // (sn, cn, dn)(u₀)
  };

  Phase phase(const Vector3& Pi) const {
    using std::abs;
    using std::sqrt;
    Phase ph;
    const Scalar Pmax = Pi(imax_), Pmin = Pi(imin_);
    const Scalar D2 = Pmax * Pmax * c_max_ + Pmin * Pmin * c_min_;  // Δ_mid = G² − 2T J_mid [F2]
    ph.cfg = D2 >= Scalar(0) ? 0 : 1;
    const Slots& C = slots_[ph.cfg];
    ph.P1 = Pi(C.p[0]), ph.P2 = Pi(C.p[1]), ph.P3 = C.sg3 * Pi(C.p[2]);
    const Scalar P1s = ph.P1 * ph.P1, P2s = ph.P2 * ph.P2, P3s = ph.P3 * ph.P3;
    const Scalar G2 = P1s + P2s + P3s;
    ph.G = sqrt(G2);
    ph.T2 = P1s * C.iI1 + P2s * C.iI2 + P3s * C.iI3;
    // [F3] Δ1 = G² − 2T I1, Δ3 = G² − 2T I3 as sums of same-signed terms
    ph.D1 = P2s * C.c21 + P3s * C.c31;
    const Scalar D3 = P1s * C.c13 + P2s * C.c23;
    if (!(G2 > Scalar(0)) || !(D3 != Scalar(0))) return ph;  // Π = 0 (D3 = 0 only then)
    ph.sigma = ph.P1 >= Scalar(0) ? Scalar(1) : Scalar(-1);
    ph.iG = Scalar(1) / ph.G;
    // Two divisions for the whole phase: 1/√|Δ3| and 1/√|Δ1| (1/|Δ3| is the first squared).
    const Scalar r3 = sqrt(abs(D3)), r1 = sqrt(abs(ph.D1));
    const Scalar ir3 = Scalar(1) / r3;
    const Scalar aD3 = ir3 * ir3;  // 1/|Δ3|
    ph.m = abs(ph.D1 * C.km) * aD3;
    ph.mc = abs(D2 * C.kmc) * aD3;
    if (ph.m > Scalar(1)) ph.m = Scalar(1);
    if (ph.mc > Scalar(1)) ph.mc = Scalar(1);
    ph.lambda = ph.sigma * C.lam_sign * C.rlam * r3;
    ph.B1 = C.rb1 * r3, ph.B2 = C.rb2 * r1, ph.B3 = C.rb3 * r1;
    // [F4] sn u₀ = −Π2/B2, cn u₀ = Π3/B3, dn u₀ = |Π1|/B1 (Δ1 = 0: pure spin about slot 1, u₀ = 0)
    if (r1 > Scalar(0)) {
      const Scalar ir1 = Scalar(1) / r1;
      ph.s = -ph.P2 * (C.irb2 * ir1), ph.c = ph.P3 * (C.irb3 * ir1);
    }
    ph.d = abs(ph.P1) * (C.irb1 * ir3);
    return ph;
  }

  // [F5] in increment form: (Δs, Δc, Δd) = (sn, cn, dn)(u + v) − (s, c, d) for the increment
  // v given by its values w, each a sum of small terms.
  static void add_increment(Scalar m, Scalar s, Scalar c, Scalar d, const JacobiValues<Scalar>& w, Scalar& ds,
                            Scalar& dc, Scalar& dd) {
    const Scalar msw = m * s * s * w.sn * w.sn;
    const Scalar r = Scalar(1) / (Scalar(1) - msw);
    const Scalar e = w.one_minus_cn + w.one_minus_dn * w.cn;  // 1 − cn v dn v
    ds = (w.sn * c * d - s * e + s * msw) * r;
    dc = (c * msw - c * w.one_minus_cn - s * d * w.sn * w.dn) * r;
    dd = (d * msw - d * w.one_minus_dn - m * s * c * w.sn * w.cn) * r;
  }

  // The panels of one step [F5], [F6] with the Gauss–Legendre rule GL: Π advanced in
  // increment form (Q, in slots), and the return value Σ over panels of the rule's sum of
  // p/(G + p), p = B1 dn.
  template <class GL>
  Scalar sweep(const Phase& ph, long panels, Scalar hp, Scalar& Q1, Scalar& Q2, Scalar& Q3) const {
    using std::abs;
    using std::sqrt;
    const Scalar m = ph.m;
    const Scalar v = Scalar(0.5) * ph.lambda * hp;  // the half-panel increment of u
    // (sn, cn, dn) of the half-panel and of the Gauss nodes' offsets: by the Maclaurin
    // series in m where the increment is small (ordinary steps), else by the Landen ladder.
    JacobiValues<Scalar> half, node[GL::pairs];
    if (abs(v) <= JacobiSeries<Scalar>::max_argument) {
      const JacobiSeries<Scalar> series(m, abs(v));  // as many rows as |v| needs
      half = series(v);
      for (int i = 0; i < GL::pairs; ++i) node[i] = series(v * GL::x[i]);
    } else {
      const JacobiModulus<Scalar> ladder(m, ph.mc);
      half = jacobi_sncndn(ladder, v);
      for (int i = 0; i < GL::pairs; ++i) node[i] = jacobi_sncndn(ladder, v * GL::x[i]);
    }

    Scalar s = ph.s, c = ph.c, d = ph.d;
    const Scalar sB1 = ph.sigma * ph.B1;
    const Scalar Gb = ph.G / ph.B1;  // p/(G + p) = dn/(G/B1 + dn), p = B1 dn
    Scalar sum = Scalar(0);  // Σ over panels of the GL sum of p/(G + p)
    for (long k = 0; k < panels; ++k) {
      Scalar ds, dc, dd;
      add_increment(m, s, c, d, half, ds, dc, dd);  // to the panel's midpoint
      // Π(u) = (σB1 dn, −B2 sn, B3 cn) [F3], in increment form
      Q1 += sB1 * dd, Q2 -= ph.B2 * ds, Q3 += ph.B3 * dc;
      const Scalar sm = s + ds, cm = c + dc, dm = d + dd;
      Scalar panel = GL::w0 * dm / (Gb + dm);
      const Scalar msc = m * sm * cm, ms2 = m * sm * sm;
      for (int i = 0; i < GL::pairs; ++i) {
        // dn(u_m ± w) = (a ∓ b)/δ, a = d_m dn w, b = m s_m c_m sn w cn w, δ = 1 − m s_m² sn² w [F5],
        // so p/(G + p) = (a ∓ b)/(g + a ∓ b) with g = δ G/B1; the pair over one division
        // (a ∓ b > 0: dn > 0, no cancellation in the sum).
        const JacobiValues<Scalar>& w = node[i];
        const Scalar g = Gb * (Scalar(1) - ms2 * w.sn * w.sn);
        const Scalar a = dm - dm * w.one_minus_dn, b = msc * w.sn * w.cn;
        const Scalar lo = a - b, hi = a + b;
        panel += GL::w[i] * (lo * (g + hi) + hi * (g + lo)) / ((g + lo) * (g + hi));
      }
      sum += panel;
      add_increment(m, sm, cm, dm, half, ds, dc, dd);  // to the panel's end
      Q1 += sB1 * dd, Q2 -= ph.B2 * ds, Q3 += ph.B3 * dc;
      s = sm + ds, c = cm + dc, d = dm + dd;
      if (panels > 1) {  // back onto sn² + cn² = 1, dn² = m' + m cn² [F6]
        const Scalar rn = Scalar(1) / sqrt(s * s + c * c);
        s *= rn, c *= rn;
        d = sqrt(ph.mc + m * c * c);
      }
    }
    return sum;
  }

  void advance_general(Quaternion& q, Vector3& Pi, Scalar h) const {
    using std::abs;
    using std::ceil;
    using std::sqrt;
    Phase ph = phase(Pi);
    if (!(ph.G > Scalar(0))) {
      if (!std::isfinite(ph.G) || !std::isfinite(h)) Pi.setConstant(std::numeric_limits<Scalar>::quiet_NaN());
      return;  // at rest: nothing moves
    }
    if (!std::isfinite(h) || !std::isfinite(ph.G)) {
      Pi.setConstant(std::numeric_limits<Scalar>::quiet_NaN());
      return;
    }
    const Slots& C = slots_[ph.cfg];
    // [F9] A long step (|λh| ≥ 2π): after each half period P/2 = 2K/|λ| of Π, Π comes back
    // reflected and Λ has turned about π by ψ_P/2, so the n half periods nearest to h are
    // one turn in closed form and only the remainder, |r| ≤ P/4, is integrated: a step
    // costs at most a quarter period's panels whatever h.
    if (abs(ph.lambda * h) >= Scalar(6.283185307179586476925286766559L)) half_periods(ph, Pi, q, h);
    // panels with |λ| h_p ≤ ½ [F6]
    const Scalar span = abs(ph.lambda * h) / panel_max;
    if (span > max_panels) {
      // A step over thousands of periods of Π would cost a panel per ½/|λ|: refused, as a
      // failed step (the caller's state is untouched; integrate() recovers by sub-steps).
      Pi.setConstant(std::numeric_limits<Scalar>::quiet_NaN());
      return;
    }
    const long panels = span > Scalar(1) ? long(ceil(span)) : 1L;
    const Scalar hp = h / Scalar(panels);
    // The quadrature rule by the panel's span of u and by k² [F6]: 7 points hold round-off up
    // to |λ|h_p = ½ at any k² (next to the separatrix too); 5 or 3 serve shorter panels, and
    // longer ones as k² falls (at L = ½: 5 points below k² ≈ 4e-5, 3 below ≈ 1e-9).
    Scalar Q1 = ph.P1, Q2 = ph.P2, Q3 = ph.P3;  // Π in slots, advanced by increments
    // The rule's error on a panel of span L = |λ|h_p, in the attitude: ≤ A_n·m·L^{2n}, with
    // A₃ = 6e-6 and A₅ = 3e-9, the largest ratios measured over 30,000 random bodies
    // (moments over two decades, Π near each principal axis down to k² = 1e-11 and at
    // random, L from 0.1 to 0.5) against the 7-point rule. The factor m: the integrand
    // p/(G + p) varies only through dn, whose swing is m, so a nearly symmetric body needs
    // fewer points at a given L (HTA, k² ≈ 2e-5, L = 0.2: 5 points instead of 7). n points
    // serve while 2·A_n·m·L^{2n} ≤ ε (m = 1, double: L ≤ 0.0163 and 0.181; 0.0168 and 0.184
    // from the earlier k²-blind fit).
    const Scalar eps = std::numeric_limits<Scalar>::epsilon();
    const Scalar L = abs(ph.lambda * hp), L2 = L * L, mL6 = ph.m * L2 * L2 * L2;
    const Scalar sum = Scalar(1.2e-5) * mL6 <= eps        ? sweep<detail::GaussLegendre<Scalar, 3>>(ph, panels, hp, Q1, Q2, Q3)
                       : Scalar(6e-9) * mL6 * L2 * L2 <= eps ? sweep<detail::GaussLegendre<Scalar, 5>>(ph, panels, hp, Q1, Q2, Q3)
                                                          : sweep<detail::GaussLegendre<Scalar, 7>>(ph, panels, hp, Q1, Q2, Q3);
    // [F6] Δψ = h·2T/G + κ ∫ p/(G + p) dt, κ = Δ1/(G I1); each panel's GL sum times h_p/2
    const Scalar dpsi = h * ph.T2 * ph.iG + (ph.D1 * ph.iG * C.iI1) * (Scalar(0.5) * hp) * sum;

    const Vector3 n0 = Pi * ph.iG;
    Pi(C.p[0]) = Q1, Pi(C.p[1]) = Q2, Pi(C.p[2]) = C.sg3 * Q3;
    turn(ph, n0, Pi * ph.iG, dpsi, q);
  }

  // [F6] q ← q ⊗ r(n0, Δψ) ⊗ a(n0)* ⊗ a(n1): the body turned by Δψ about the momentum
  // direction n0 = Π₀/G, then carried from n0 to n1 = Π₁/G through the frame in which π is
  // fixed; a(n) = (1 + n·e, n × e) (unnormalised) is the minimal rotation of n onto e = σ e_{slot 1},
  // 1 + n·e ≥ 1 since σ = sgn Π₁.
  void turn(const Phase& ph, const Vector3& n0, const Vector3& n1, Scalar dpsi, Quaternion& q) const {
    using std::sqrt;
    const int ax = slots_[ph.cfg].p[0];
    auto n_cross_e = [&](const Vector3& n) {  // σ n × e_ax
      const Vector3 r = ax == 0 ? Vector3(0, n.z(), -n.y()) : ax == 1 ? Vector3(-n.z(), 0, n.x()) : Vector3(n.y(), -n.x(), 0);
      return Vector3(ph.sigma * r);
    };
    const Scalar w0 = Scalar(1) + ph.sigma * n0(ax), w1 = Scalar(1) + ph.sigma * n1(ax);
    const Vector3 v0 = n_cross_e(n0), v1 = n_cross_e(n1);
    // |a(n)|² = 2(1 + n·e) = 2w, so the product's norm is 2√(w0 w1): divided out here, off
    // the critical path (w0, w1 are known before the quadrature's sum).
    const Scalar ka = Scalar(0.5) / sqrt(w0 * w1);
    const Vector3 pv = ka * (w0 * v1 - w1 * v0 - v0.cross(v1));
    const Quaternion pa(ka * (w0 * w1 + v0.dot(v1)), pv.x(), pv.y(), pv.z());
    Scalar sp, cp;
    detail::sin_cos(Scalar(0.5) * dpsi, sp, cp);
    const Quaternion r(cp, sp * n0.x(), sp * n0.y(), sp * n0.z());
    q = q * (r * pa);
  }

  // [F9] Takes the half periods nearest to h out of it: after n half periods of Π (u advanced
  // by 2nK), dn returns and sn, cn change sign n times, so Π is Π₀ reflected in slots 2 and 3
  // when n is odd, and Λ has turned by n·ψ_P/2 about n0 = Π₀/G ([F6] over whole windows of
  // dn). h is left with the remainder r = h − n·P/2, |r| ≤ P/4 (either sign: the flow runs
  // backward as well as forward), and the phase is moved with Π. Nothing on the separatrix.
  void half_periods(Phase& ph, Vector3& Pi, Quaternion& q, Scalar& h) const {
    using std::abs;
    using std::floor;
    using std::sqrt;
    const JacobiModulus<Scalar> ladder(ph.m, ph.mc);
    const Scalar K = ladder.quarter_period();
    if (!std::isfinite(K)) return;
    const Scalar rate = abs(ph.lambda);
    const Scalar half_P = Scalar(2) * K / rate;
    const Scalar n = floor(abs(h) / half_P + Scalar(0.5));
    if (n < Scalar(1)) return;
    const Scalar sign = h > Scalar(0) ? Scalar(1) : Scalar(-1);
    // ψ_P/2 = (P/2)·2T/G + κ (1/|λ|) ∫_0^{2K} f du,  f = dn/(a + dn),  a = G/B1 ≥ 1 [F6].
    // With φ = am u (dn du = dφ), 1/(a + dn) = (a − dn)/(α + m sin²φ), α = a² − 1, and
    // α + m sin²φ = α (cos²φ + p sin²φ), p = 1 + m/α:
    //   ∫_0^{2K} f du = 2∫_0^{π/2} dφ/(a + dn) = 2[(π/2) a/√p − cel(k′, p, 1, k′²)] / α,
    // Bulirsch's cel (jacobi.hpp). In the slots α = (I3/I1)|Δ1|/|Δ3| and m/α = |k_m| I1/I3:
    // p is the body's, and κ/α = sgn(Δ1)|Δ3|/(G I3), so nothing is divided by α (0 on a pure
    // spin about slot 1, where κ = 0 too). The bracket's two terms are O(1); their difference
    // vanishes with α as κ does, and its round-off is ε of the O(1) terms.
    const Slots& C = slots_[ph.cfg];
    const Scalar D3 = ph.B1 * ph.B1 * C.irb1 * C.irb1;  // |Δ3| = B1²/rb1²
    const Scalar p = Scalar(1) + abs(C.km) * C.iI3 / C.iI1;
    const Scalar bracket = Scalar(1.57079632679489661923132169163975144L) * (ph.G / ph.B1) / sqrt(p) -
                           complete_elliptic_cel(sqrt(ph.mc), p, Scalar(1), ph.mc);
    const Scalar kappa_over_alpha = (ph.D1 >= Scalar(0) ? D3 : -D3) * ph.iG * C.iI3;
    const Scalar psi_half = half_P * ph.T2 * ph.iG + kappa_over_alpha * (Scalar(2) / rate) * bracket;
    const Vector3 n0 = Pi * ph.iG;
    const Scalar dpsi = sign * n * psi_half;
    if (floor(n / Scalar(2)) * Scalar(2) == n) {
      // even: Π is back; q ← q ⊗ r(n0, Δψ)
      const Scalar sp = std::sin(Scalar(0.5) * dpsi), cp = std::cos(Scalar(0.5) * dpsi);
      q = q * Quaternion(cp, sp * n0.x(), sp * n0.y(), sp * n0.z());
    } else {
      // odd: Π reflected in slots 2, 3 (sn, cn of the phase negated), q carried by [F6]
      Pi(C.p[1]) = -Pi(C.p[1]), Pi(C.p[2]) = -Pi(C.p[2]);
      ph.P2 = -ph.P2, ph.P3 = -ph.P3, ph.s = -ph.s, ph.c = -ph.c;
      turn(ph, n0, Pi * ph.iG, dpsi, q);
    }
    h -= sign * n * half_P;
  }

  // [S2] the symmetric free flow about axis s (detail::symmetric_free_flow).
  void advance_symmetric(Quaternion& q, Vector3& Pi, Scalar t) const {
    if (s_axis_ == 0) detail::symmetric_free_flow<0>(q, Pi, t, Ja_inv_, c_s_);
    else if (s_axis_ == 1) detail::symmetric_free_flow<1>(q, Pi, t, Ja_inv_, c_s_);
    else detail::symmetric_free_flow<2>(q, Pi, t, Ja_inv_, c_s_);
  }

  Vector3 J_;
  bool symmetric_ = false;
  int s_axis_ = 2;
  Scalar Ja_inv_ = 0, c_s_ = 0;
  int imin_ = 0, imid_ = 1, imax_ = 2;
  Scalar c_max_ = 0, c_min_ = 0;  // Δ_mid = Π_max² c_max + Π_min² c_min
  Slots slots_[2];
};

}  // namespace trompo
