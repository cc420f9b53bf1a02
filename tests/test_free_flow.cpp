// The exact free rotation of any rigid body (trompo::EulerPoinsot, docs/theory.md §14
// [F1]–[F7]) and its Jacobi functions (trompo/lie/jacobi.hpp):
//   1. sn, cn, dn and the complements 1 − cn, 1 − dn against Boost.Math in long double, and
//      their identities in float, double and long double;
//   2. one step against a long-double RK4 with tiny steps on seeded random bodies: generic,
//      nearly symmetric (k² < 1e-6), next to the separatrix (k² > 0.999), both senses of
//      rotation, λh from 0.1 to 5; pure spin about each principal axis; exactly symmetric;
//   3. chained steps against exact::FreeBody (FB1, FB2);
//   4. π and H of the free body over 10⁶ steps; h then −h; float and long double; bad input.
// Each case prints what it measured.
#include <catch2/catch.hpp>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include "trompo/errors.hpp"
#include "trompo/lie/jacobi.hpp"
#include "trompo/lie/euler_poinsot.hpp"

#ifdef TROMPO_HAVE_BOOST
#include <boost/math/special_functions/ellint_1.hpp>
#include <boost/math/special_functions/ellint_2.hpp>
#include <boost/math/special_functions/ellint_3.hpp>
#include <boost/math/special_functions/jacobi_elliptic.hpp>

#include "trompo/exact/free_body.hpp"
#endif

namespace {

using trompo::EulerPoinsot;
using trompo::JacobiModulus;
using trompo::JacobiSeries;
using ld = long double;
template <class S>
using V3 = Eigen::Matrix<S, 3, 1>;
template <class S>
using Quat = Eigen::Quaternion<S>;

// Long-double RK4 on q̇ = ½ q ⊗ (0, Ω), Π̇ = Π × Ω, Ω = J⁻¹Π (the reference).
void rk4_plain(const V3<ld>& J, Quat<ld>& q, V3<ld>& P, ld T, long n) {
  const ld h = T / ld(n);
  auto f = [&](const Quat<ld>& qq, const V3<ld>& PP, V3<ld>& dq_vec, ld& dq_w, V3<ld>& dP) {
    const V3<ld> w = PP.cwiseQuotient(J);
    dP = PP.cross(w);
    const Quat<ld> r = qq * Quat<ld>(0, w.x(), w.y(), w.z());
    dq_w = r.w() / 2;
    dq_vec = r.vec() / 2;
  };
  using C4 = Eigen::Matrix<ld, 4, 1>;
  auto pack = [](const V3<ld>& v, ld w) { return C4(v.x(), v.y(), v.z(), w); };
  for (long i = 0; i < n; ++i) {
    V3<ld> a1, a2, a3, a4, l1, l2, l3, l4;
    ld w1, w2, w3, w4;
    const C4 q0 = q.coeffs();
    f(q, P, a1, w1, l1);
    const C4 k1 = pack(a1, w1);
    f(Quat<ld>(C4(q0 + h / 2 * k1)), P + h / 2 * l1, a2, w2, l2);
    const C4 k2 = pack(a2, w2);
    f(Quat<ld>(C4(q0 + h / 2 * k2)), P + h / 2 * l2, a3, w3, l3);
    const C4 k3 = pack(a3, w3);
    f(Quat<ld>(C4(q0 + h * k3)), P + h * l3, a4, w4, l4);
    const C4 k4 = pack(a4, w4);
    q.coeffs() = q0 + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    q.normalize();
    P += h / 6 * (l1 + 2 * l2 + 2 * l3 + l4);
  }
}

// The reference: two long-double RK4 runs (n and 2n steps) combined by Richardson
// extrapolation, (16 y_2n − y_n)/15: error O(h⁶), ~1e-19 at |Ω|h = 1e-3.
void rk4_free(const V3<ld>& J, Quat<ld>& q, V3<ld>& P, ld T, long n) {
  Quat<ld> q1 = q, q2 = q;
  V3<ld> P1 = P, P2 = P;
  rk4_plain(J, q1, P1, T, n);
  rk4_plain(J, q2, P2, T, 2 * n);
  if (q1.coeffs().dot(q2.coeffs()) < 0) q1.coeffs() = -q1.coeffs();
  q.coeffs() = (16 * q2.coeffs() - q1.coeffs()) / 15;
  q.normalize();
  P = (16 * P2 - P1) / 15;
}

struct Body {
  const char* what;
  V3<double> J;
  V3<double> Pi;
};

// Seeded random bodies of every branch [F7].
std::vector<Body> random_bodies() {
  std::mt19937_64 rng(20261125);
  std::uniform_real_distribution<double> U(-1.0, 1.0), M(1.0, 3.0);
  std::vector<Body> out;
  for (int k = 0; k < 3; ++k) {  // generic, both senses (signs random)
    V3<double> J(M(rng), M(rng), M(rng));
    out.push_back({"generic", J, V3<double>(U(rng), U(rng), U(rng)) * 2.0});
  }
  for (int k = 0; k < 2; ++k) {  // nearly symmetric (oblate about the max axis): k² ~ δ
    const double a = M(rng);
    V3<double> J(a, a * (1 + 1e-8), 2.0 * a);
    out.push_back({"nearly symmetric", J, V3<double>(U(rng), U(rng), 1.0 + 0.5 * U(rng))});
  }
  for (int k = 0; k < 3; ++k) {  // next to the separatrix: Π about the intermediate axis
    V3<double> J(1.0, 1.0 + M(rng), 3.0 + M(rng));
    const double e = 1e-3 * (k + 1);
    V3<double> P(e * U(rng), (k == 1 ? -1.0 : 1.0) * 1.5, e * U(rng));
    out.push_back({"near separatrix", J, P});
  }
  const V3<double> J(1.0, 2.0, 3.0);
  for (int axis = 0; axis < 3; ++axis)
    for (double sgn : {1.0, -1.0}) out.push_back({"pure spin", J, sgn * 1.3 * V3<double>::Unit(axis)});
  out.push_back({"exactly symmetric", V3<double>(2.0, 1.0, 2.0), V3<double>(0.3, -1.0, 0.8)});
  for (int k = 0; k < 2; ++k) {  // HTA's body near a spin about its min axis: k² ~ 1e-5, 5 points at L = 0.2
    const V3<double> J_hta(5.0, 5.5, 1.0);
    out.push_back({"nearly a pure spin (HTA)", J_hta, V3<double>(0.06 * U(rng), 0.06 * U(rng), (k == 0 ? 2.0 : -2.0))});
  }
  return out;
}

double rotation_distance(const Quat<ld>& a, const Quat<ld>& b) {
  return double((a.toRotationMatrix() - b.toRotationMatrix()).norm());
}

}  // namespace

#ifdef TROMPO_HAVE_BOOST
// [F9] Bulirsch's cel against Boost.Math's K, E and Π in long double:
//   cel(k', p, A, B) = A K + (B − A p)(Π(n) − K)/n, n = 1 − p ≠ 0;  at p = 1: A K + (B − A)(K − E)/m
// ((K − E)/m = π/4 at m = 0). Boost takes k, not k': below k' ≈ 1e-3 its m = 1 − k'² loses the
// digits of k', so there K from the Landen ladder (built from k'² itself) is the reference.
TEST_CASE("free flow: Bulirsch's complete integral cel against Boost.Math (long double)", "[free_flow][jacobi]") {
  double worst = 0;
  for (const ld kc : {1.0L, 0.5L, 0.1L, 7.07e-3L, 1e-3L}) {
    const ld m = 1 - kc * kc, k = std::sqrt(m);
    const ld K = boost::math::ellint_1(k), E = boost::math::ellint_2(k);
    for (const ld p : {0.2L, 1.0L, 1.5L, 3.0L, 50.0L, 1e4L}) {
      for (const auto& [A, B] : {std::pair<ld, ld>{1, 1}, {1, kc * kc}, {0.3L, -2}}) {
        ld ref;
        if (p == 1) ref = A * K + (B - A) * (m > 0 ? (K - E) / m : ld(0.785398163397448309615660845819875721L));
        else ref = A * K + (B - A * p) * (boost::math::ellint_3(k, 1 - p) - K) / (1 - p);
        const double got = trompo::complete_elliptic_cel(double(kc), double(p), double(A), double(B));
        const double e = double(std::fabs(ld(got) - ref) / std::max(std::fabs(ref), ld(K)));
        INFO("k' " << double(kc) << ", p " << double(p) << ", A " << double(A) << ", B " << double(B) << ": " << e);
        CHECK(e <= 4e-15);  // measured ≤ 1.9e-15; the reference's m = 1 − k'² alone is 3e-15 off in K at k' = 1e-3
        worst = std::max(worst, e);
      }
    }
  }
  double worst_K = 0;
  for (const double kc : {1e-3, 1e-5, 1e-8, 1e-12, 1e-16}) {
    const double K = JacobiModulus<double>(1 - kc * kc, kc * kc).quarter_period();
    const double e = std::fabs(trompo::complete_elliptic_cel(kc, 1.0, 1.0, 1.0) - K) / K;
    INFO("k' " << kc << ": K " << K << ", relative difference " << e);
    CHECK(e <= 4e-15);  // measured ≤ 3.0e-15: each a few ε (the ladder's product of up to 6 levels)
    worst_K = std::max(worst_K, e);
  }
  std::printf("cel vs Boost (long double): largest error %.2e relative to max(|cel|, K); K(k' down to 1e-16) vs the Landen ladder %.2e\n",
              worst, worst_K);
}

TEST_CASE("free flow: sn, cn, dn and 1 − cn, 1 − dn against Boost.Math (long double)", "[free_flow][jacobi]") {
  double worst_small = 0, worst_comp = 0, worst_large = 0;
  for (ld mc : {1.0L, 0.9L, 0.5L, 0.1L, 1e-3L, 1e-6L, 1e-9L, 1e-12L, 1e-15L, 1e-18L, 0.0L}) {
    const ld m = 1 - mc;
    const JacobiModulus<double> L{double(m), double(mc)};
    for (ld u = -12; u <= 12; u += 0.0371L) {
      const auto r = trompo::jacobi_sncndn(L, double(u));
      ld cn, dn, sn;
      if (mc == 0) {
        sn = std::tanh(u), cn = dn = 1 / std::cosh(u);
      } else {
        sn = boost::math::jacobi_elliptic(std::sqrt(ld(double(m))), ld(double(u)), &cn, &dn);
      }
      const double e = double(std::max({std::fabs(sn - ld(r.sn)), std::fabs(cn - ld(r.cn)), std::fabs(dn - ld(r.dn))}));
      if (std::fabs(u) <= 1) {
        worst_small = std::max(worst_small, e);
        if (1 - cn > 1e-300L)
          worst_comp = std::max(worst_comp, double(std::fabs((1 - cn) - ld(r.one_minus_cn)) / (1 - cn)));
        if (1 - dn > 1e-300L)
          worst_comp = std::max(worst_comp, double(std::fabs((1 - dn) - ld(r.one_minus_dn)) / (1 - dn)));
      } else {
        worst_large = std::max(worst_large, e);
      }
    }
  }
  std::printf("sncndn vs Boost (long double): |u| <= 1 abs %.2e, complements rel %.2e; |u| <= 12 abs %.2e\n",
              worst_small, worst_comp, worst_large);
  CHECK(worst_small <= 6e-16);  // a few ulp: what the flow uses (|v| ≤ ¼)
  CHECK(worst_comp <= 2e-14);   // relative, including 1 − dn ~ m·v² for m = 1e-18
  CHECK(worst_large <= 1e-12);  // |u| up to 12: the direct ascent near m → 1 amplifies
}
#endif

#ifdef TROMPO_HAVE_BOOST
TEST_CASE("free flow: the Maclaurin series of sn, cn, dn (small increments) against Boost.Math (long double)",
          "[free_flow][jacobi]") {
  // Where the flow uses it, |u| ≤ 1/8, at every m from 0 to the separatrix: sn, cn, dn to a
  // few ulp, 1 − cn and 1 − dn to a few ulp relative; in long double, to its own ε.
  const double umax = double(JacobiSeries<double>::max_argument);
  double worst = 0, worst_comp = 0, worst_ld = 0;
  for (ld mc : {1.0L, 0.9L, 0.5L, 0.1L, 1e-3L, 1e-9L, 1e-18L, 0.0L}) {
    const ld m = 1 - mc;
    const JacobiSeries<double> series{double(m)};
    const JacobiSeries<ld> series_ld{m};
    for (ld u = -umax; u <= umax; u += ld(umax) / 37) {
      const auto r = series(double(u));
      const auto rl = series_ld(u);
      ld cn, dn, sn;
      if (mc == 0) {
        sn = std::tanh(u), cn = dn = 1 / std::cosh(u);
      } else {
        sn = boost::math::jacobi_elliptic(std::sqrt(ld(double(m))), ld(double(u)), &cn, &dn);
      }
      worst = std::max(worst, double(std::max({std::fabs(sn - ld(r.sn)), std::fabs(cn - ld(r.cn)), std::fabs(dn - ld(r.dn))})));
      // 1 − cn = sn²/(1 + cn) and 1 − dn = m sn²/(1 + dn): no cancellation in the reference
      // (1 − cn in long double would lose relative digits at small u)
      const ld cbar = sn * sn / (1 + cn), dbar = ld(double(m)) * sn * sn / (1 + dn);
      if (cbar > 1e-300L) worst_comp = std::max(worst_comp, double(std::fabs(cbar - ld(r.one_minus_cn)) / cbar));
      if (dbar > 1e-300L) worst_comp = std::max(worst_comp, double(std::fabs(dbar - ld(r.one_minus_dn)) / dbar));
      ld cl, dl, sl;  // long double: at m itself, not rounded to double
      if (mc == 0) {
        sl = std::tanh(u), cl = dl = 1 / std::cosh(u);
      } else {
        sl = boost::math::jacobi_elliptic(std::sqrt(m), u, &cl, &dl);
      }
      worst_ld = std::max(worst_ld, double(std::max({std::fabs(sl - rl.sn), std::fabs(cl - rl.cn), std::fabs(dl - rl.dn)})));
    }
  }
  std::printf("sncndn series vs Boost, |u| <= %g: double abs %.2e, complements rel %.2e; long double abs %.2e\n", umax,
              worst, worst_comp, worst_ld);
  CHECK(worst <= 4 * std::numeric_limits<double>::epsilon());
  CHECK(worst_comp <= 8 * std::numeric_limits<double>::epsilon());
  CHECK(worst_ld <= 8 * double(std::numeric_limits<ld>::epsilon()));
}
#endif

TEST_CASE("free flow: the Maclaurin series and the Landen ladder agree where both apply", "[free_flow][jacobi]") {
  double worst = 0;
  for (double mc : {1.0, 0.7, 0.3, 1e-4, 1e-12, 0.0}) {
    const JacobiModulus<double> L(1 - mc, mc);
    const JacobiSeries<double> series(1 - mc);
    for (double u = -0.125; u <= 0.125; u += 0.125 / 29) {
      const auto a = series(u);
      const auto b = trompo::jacobi_sncndn(L, u);
      worst = std::max({worst, std::abs(a.sn - b.sn), std::abs(a.cn - b.cn), std::abs(a.dn - b.dn)});
    }
  }
  INFO("largest difference " << worst);
  CHECK(worst <= 4 * std::numeric_limits<double>::epsilon());
}

TEST_CASE("free flow: the series cut to the largest argument agrees with the full series", "[free_flow][jacobi]") {
  // [F5]: rows whose bound at the largest argument is below ε/16 are dropped; the result
  // must not move by more than round-off, and small arguments must drop rows (the cost).
  double worst = 0, worst_comp = 0;
  int last_rows = 0;
  for (double umax : {1e-4, 1e-3, 0.006, 0.02, 0.05, 0.125}) {
    for (double mc : {1.0, 0.5, 1e-4, 0.0}) {
      const JacobiSeries<double> full(1 - mc);
      const JacobiSeries<double> cut(1 - mc, umax);
      CHECK(cut.rows() >= last_rows);  // more rows for larger arguments, never fewer
      for (double u = -umax; u <= umax; u += umax / 17) {
        const auto a = full(u), b = cut(u);
        worst = std::max({worst, std::abs(a.sn - b.sn), std::abs(a.cn - b.cn), std::abs(a.dn - b.dn)});
        if (a.one_minus_cn > 0) worst_comp = std::max(worst_comp, std::abs(a.one_minus_cn - b.one_minus_cn) / a.one_minus_cn);
        if (a.one_minus_dn > 0) worst_comp = std::max(worst_comp, std::abs(a.one_minus_dn - b.one_minus_dn) / a.one_minus_dn);
      }
    }
    last_rows = JacobiSeries<double>(0.5, umax).rows();
    if (umax == 0.006) CHECK(last_rows == 4);  // FB1 at h = 0.01: |v| = 0.0058
  }
  CHECK(last_rows == 8);                                                // double at |u| = 1/8
  // The bound at this m (row_bound0 + m·row_bound): a nearly symmetric body needs fewer rows.
  CHECK(JacobiSeries<double>(2e-5, 0.1).rows() == 6);  // HTA's k², |v| = 0.1 (8 by the m = 1 bound)
  CHECK(JacobiSeries<double>(1.0, 0.1).rows() == 8);
  for (double m : {1e-12, 2e-5, 1e-3}) {
    const JacobiSeries<double> full(m);
    for (double umax : {0.02, 0.1, 0.125}) {
      const JacobiSeries<double> cut(m, umax);
      for (double u = -umax; u <= umax; u += umax / 17) {
        const auto a = full(u), b = cut(u);
        worst = std::max({worst, std::abs(a.sn - b.sn), std::abs(a.cn - b.cn), std::abs(a.dn - b.dn)});
        if (a.one_minus_cn > 0) worst_comp = std::max(worst_comp, std::abs(a.one_minus_cn - b.one_minus_cn) / a.one_minus_cn);
        if (a.one_minus_dn > 0) worst_comp = std::max(worst_comp, std::abs(a.one_minus_dn - b.one_minus_dn) / a.one_minus_dn);
      }
    }
  }
  CHECK(JacobiSeries<ld>(0.5L).rows() == JacobiSeries<ld>::terms);  // long double needs all 9 there
  INFO("abs " << worst << ", complements rel " << worst_comp);
  CHECK(worst <= 2 * std::numeric_limits<double>::epsilon());
  CHECK(worst_comp <= 2 * std::numeric_limits<double>::epsilon());
}

TEMPLATE_TEST_CASE("free flow: the Jacobi identities hold to round-off", "[free_flow][jacobi]", float, double,
                   long double) {
  using S = TestType;
  const S eps = std::numeric_limits<S>::epsilon();
  S worst = 0;
  for (S mc : {S(1), S(0.5), S(1e-3), S(1e-7), S(0)}) {
    const JacobiModulus<S> L(S(1) - mc, mc);
    for (S u = -1; u <= 1; u += S(0.05)) {
      const auto r = trompo::jacobi_sncndn(L, u);
      worst = std::max({worst, std::abs(r.sn * r.sn + r.cn * r.cn - S(1)),
                        std::abs(r.dn * r.dn + L.m * r.sn * r.sn - S(1)), std::abs(S(1) - r.cn - r.one_minus_cn),
                        std::abs(S(1) - r.dn - r.one_minus_dn)});
    }
  }
  std::printf("Jacobi identities (%zu-byte scalar): worst %.2e = %.1f eps\n", sizeof(S), double(worst),
              double(worst / eps));
  CHECK(worst <= 8 * eps);
}

TEST_CASE("free flow: one step against a long-double RK4, every branch, lambda*h up to 5", "[free_flow]") {
  double worst_P = 0, worst_L = 0;
  bool saw_small_m = false, saw_large_m = false;
  for (const Body& b : random_bodies()) {
    const EulerPoinsot<double> flow(b.J);
    const auto inv = flow.invariants(b.Pi);
    if (!flow.symmetric() && inv.m < 1e-6 && std::string(b.what) == "nearly symmetric") saw_small_m = true;
    if (std::string(b.what) == "near separatrix") {
      CHECK(inv.m > 0.999);
      saw_large_m = true;
    }
    const double rate = std::abs(inv.lambda) > 0 ? std::abs(inv.lambda) : b.Pi.norm() / b.J.minCoeff();
    for (double lh : {0.1, 0.5, 1.0, 2.0, 5.0}) {
      const double h = lh / rate;
      Quat<double> q(Eigen::AngleAxisd(0.7, V3<double>(1, -2, 0.5).normalized()));
      V3<double> P = b.Pi;
      Quat<ld> ql = q.cast<ld>();
      V3<ld> Pl = P.cast<ld>();
      flow.advance(q, P, h);
      // RK4 steps: |Ω|h_rk ≤ 2e-3 before the extrapolation
      const double wmax = (b.Pi.cwiseQuotient(b.J)).norm() + rate;
      const long n = std::max(1000L, long(std::ceil(wmax * h / 2e-3)));
      rk4_free(b.J.cast<ld>(), ql, Pl, ld(h), n);
      const double eP = double((P.cast<ld>() - Pl).norm() / Pl.norm());
      const double eL = rotation_distance(q.cast<ld>(), ql);
      worst_P = std::max(worst_P, eP);
      worst_L = std::max(worst_L, eL);
      INFO(b.what << " J = " << b.J.transpose() << " Pi = " << b.Pi.transpose() << " lambda*h = " << lh
                  << " m = " << inv.m << " 1-m = " << inv.mc);
      CHECK(eP <= 2e-15);
      CHECK(eL <= 5e-15);
    }
  }
  CHECK(saw_small_m);
  CHECK(saw_large_m);
  std::printf("one step vs long-double RK4 (%zu bodies x 5 lambda*h): |dPi|/|Pi| %.2e, |dLambda| %.2e\n",
              random_bodies().size(), worst_P, worst_L);
}

TEST_CASE("free flow: each Gauss-Legendre rule holds round-off up to the end of its span", "[free_flow]") {
  // [F6]: 3 points while 1.2e-5·k²L⁶ ≤ ε, 5 while 6e-9·k²L¹⁰ ≤ ε, 7 above (double, k² = 1:
  // L ≈ 0.0163 and 0.181; the switches move out as k² falls). One step on either side of each
  // switch at the body's k² (where it lies below ½), and at the extremes, against the
  // long-double flow (whose own switches sit elsewhere: ε is smaller), on every branch of
  // random_bodies().
  double worst_P = 0, worst_L = 0;
  const double eps = std::numeric_limits<double>::epsilon();
  for (const Body& b : random_bodies()) {
    const EulerPoinsot<double> flow(b.J);
    const EulerPoinsot<ld> flow_ld(b.J.cast<ld>());
    const auto inv = flow.invariants(b.Pi);
    if (flow.symmetric() || !(std::abs(inv.lambda) > 0)) continue;
    const double m = std::max(double(inv.m), 1e-300);
    const double L3 = std::pow(eps / (1.2e-5 * m), 1.0 / 6), L5 = std::pow(eps / (6e-9 * m), 1.0 / 10);
    std::vector<double> spans{1e-3, 0.5};
    for (double edge : {L3, L5})
      if (1.03 * edge < 0.5) spans.insert(spans.end(), {0.97 * edge, 1.03 * edge});
    for (double L : spans) {
      const double h = L / std::abs(inv.lambda);
      Quat<double> q(Eigen::AngleAxisd(0.4, V3<double>(2, 1, -0.5).normalized()));
      V3<double> P = b.Pi;
      Quat<ld> ql = q.cast<ld>();
      V3<ld> Pl = P.cast<ld>();
      flow.advance(q, P, h);
      for (int k = 0; k < 4; ++k) flow_ld.advance(ql, Pl, ld(h) / 4);
      const double eP = double((P.cast<ld>() - Pl).norm() / Pl.norm());
      const double eL = rotation_distance(q.cast<ld>(), ql);
      worst_P = std::max(worst_P, eP);
      worst_L = std::max(worst_L, eL);
      INFO(b.what << " |lambda|h = " << L << " m = " << inv.m << " 1-m = " << inv.mc);
      if (L == 0.5 && inv.m > 0) std::printf("  %s: k^2 = %.2e, rule switches at L = %.3g and %.3g\n", b.what, m, L3, L5);
      CHECK(eP <= 2e-15);
      CHECK(eL <= 4e-15);
    }
  }
  std::printf("quadrature rules at their edges vs the long-double flow: |dPi|/|Pi| %.2e, |dLambda| %.2e\n", worst_P,
              worst_L);
}

TEST_CASE("free flow: a pure spin about each principal axis stays exactly a spin", "[free_flow]") {
  const V3<double> J(1.0, 2.0, 3.0);
  const EulerPoinsot<double> flow(J);
  for (int axis = 0; axis < 3; ++axis) {
    const V3<double> P0 = 2.0 * V3<double>::Unit(axis);
    Quat<double> q = Quat<double>::Identity();
    V3<double> P = P0;
    const double h = 0.37;
    const int n = 1000;
    for (int i = 0; i < n; ++i) flow.advance(q, P, h);
    // Λ(t) = exp(t Ω̂0), Ω0 = P0/J_axis: the intermediate axis too (unstable, kept exactly)
    const Quat<double> exact(Eigen::AngleAxisd(n * h * 2.0 / J(axis), V3<double>::Unit(axis)));
    const double eL = (q.toRotationMatrix() - exact.toRotationMatrix()).norm();
    const double eP = (P - P0).norm();
    std::printf("pure spin about axis %d, 1000 steps: |dPi| %.2e, |dLambda| %.2e\n", axis, eP, eL);
    CHECK(eP <= 1e-15);
    CHECK(eL <= 1e-12);  // 1000 steps, angle 740 rad: ~ε per step of the angle
  }
}

#ifdef TROMPO_HAVE_BOOST
TEST_CASE("free flow: chained steps agree with exact::FreeBody on FB1 and FB2", "[free_flow]") {
  // FB1 passes the separatrix region every flip, where the exact solution itself amplifies
  // a 1-ulp change of Ω0 by ~5e4 (printed below): chained steps, each rounding to ~ε, are
  // compared at t = 100 (between flips) and, over the whole run, at that conditioning.
  struct Case {
    const char* name;
    V3<double> J, W0;
    double h, tol_end, tol_max;
  };
  const Case cases[] = {{"FB1 h=0.1", V3<double>(1, 2, 3), V3<double>(0.01, 2, 0.01), 0.1, 2e-11, 1e-9},
                        {"FB1 h=2", V3<double>(1, 2, 3), V3<double>(0.01, 2, 0.01), 2.0, 2e-11, 1e-9},
                        {"FB1 h=100 (one step)", V3<double>(1, 2, 3), V3<double>(0.01, 2, 0.01), 100.0, 2e-13, 2e-13},
                        {"FB2 h=0.5", V3<double>(2, 1, 2.0 / 3), V3<double>(0, 0.1, 0.9), 0.5, 2e-12, 2e-12}};
  {
    V3<double> W2(0.01, 2, 0.01);
    W2(0) = std::nextafter(W2(0), 1.0);
    const trompo::exact::FreeBody a(V3<double>(1, 2, 3), Eigen::Matrix3d::Identity(), V3<double>(0.01, 2, 0.01));
    const trompo::exact::FreeBody b(V3<double>(1, 2, 3), Eigen::Matrix3d::Identity(), W2);
    double mx = 0;
    for (int i = 1; i <= 1000; ++i) mx = std::max(mx, (a.rotation(0.1 * i) - b.rotation(0.1 * i)).norm());
    std::printf("FB1 conditioning: 1 ulp on Omega0_1 (1.7e-18) moves Lambda by up to %.2e over [0, 100]\n", mx);
  }
  for (const Case& c : cases) {
    const Eigen::Matrix3d L0 = Eigen::Matrix3d::Identity();
    const trompo::exact::FreeBody ref(c.J, L0, c.W0);
    const EulerPoinsot<double> flow(c.J);
    Quat<double> q = Quat<double>::Identity();
    V3<double> P = c.J.cwiseProduct(c.W0);
    const int n = int(std::lround(100.0 / c.h));
    double worst = 0, end = 0;
    for (int i = 1; i <= n; ++i) {
      flow.advance(q, P, c.h);
      const double t = i * c.h;
      end = std::max((q.toRotationMatrix() - ref.rotation(t)).norm(), (P.cwiseQuotient(c.J) - ref.omega(t)).norm());
      worst = std::max(worst, end);
    }
    std::printf("%s vs FreeBody: at t = 100 %.2e, max over the run %.2e\n", c.name, end, worst);
    INFO(c.name);
    CHECK(end <= c.tol_end);
    CHECK(worst <= c.tol_max);
  }
}
#endif

TEST_CASE("free flow: pi and H of the free body to round-off over 10^6 steps", "[free_flow]") {
  // FB1 (next to the separatrix) at h = 0.1: 10⁶ steps, t = 10⁵.
  const V3<double> J(1, 2, 3);
  const EulerPoinsot<double> flow(J);
  Quat<double> q = Quat<double>::Identity();
  V3<double> P = J.cwiseProduct(V3<double>(0.01, 2, 0.01));
  const V3<double> pi0 = q * P;
  const double H0 = P.dot(P.cwiseQuotient(J)) / 2;
  double dpi = 0, dH = 0;
  for (int i = 0; i < 1000000; ++i) {
    flow.advance(q, P, 0.1);
    if (i % 1000 == 999) {
      dpi = std::max(dpi, (q * P - pi0).norm() / pi0.norm());
      dH = std::max(dH, std::abs(P.dot(P.cwiseQuotient(J)) / 2 - H0) / H0);
    }
  }
  std::printf("FB1, 10^6 steps of h = 0.1: max |dpi|/|pi| %.2e, max |dH|/H %.2e\n", dpi, dH);
  CHECK(dpi <= 1e-12);  // a random walk of ~ε per step: √10⁶ ε ≈ 2e-13
  CHECK(dH <= 1e-12);
}

// [F9] A long step takes out the half periods of Π nearest to it in closed form (a turn about
// π by n·ψ_P/2, Π reflected when n is odd; ψ_P by Bulirsch's complete integral), then
// integrates the remainder: it must agree with the same span in long-double steps of an eighth
// of a period (which never take the reduction: |λh| = K/2 < 2π), to the period's rounding
// times the periods. (A chain of double steps is no reference: it drifts by 2.4e-9 over
// 40.6 periods of FB1, where the one step is within 8e-13.)
TEST_CASE("free flow: a step of any length takes out its half periods", "[free_flow]") {
  struct Case {
    const char* name;
    V3<double> J, W0;
    double tol;
  };
  // FB1 next to the separatrix (k'² = 5e-5), FB2, and a body far from it.
  const Case cases[] = {{"FB1", V3<double>(1, 2, 3), V3<double>(0.01, 2, 0.01), 1e-13},
                        {"FB2", V3<double>(2, 1, 2.0 / 3), V3<double>(0, 0.1, 0.9), 1e-14},
                        {"far", V3<double>(1, 2, 3), V3<double>(0.3, 0.2, 1.5), 1e-14}};
  double worst = 0;
  for (const Case& c : cases) {
    const EulerPoinsot<double> flow(c.J);
    const EulerPoinsot<ld> flow_ld(c.J.cast<ld>());
    const V3<double> P0 = c.J.cwiseProduct(c.W0);
    const double period = flow.period(P0);
    REQUIRE(std::isfinite(period));
    for (const double periods : {0.5, 1.0, 1.5, 3.37, -3.37, 2.9, 40.6, -40.6}) {  // n even and odd, r of both signs
      const double h = periods * period;
      Quat<double> q = Quat<double>::Identity();
      Quat<ld> q_ref = Quat<ld>::Identity();
      V3<double> P = P0;
      V3<ld> P_ref = P0.cast<ld>();
      flow.advance(q, P, h);
      const int n = int(std::ceil(std::abs(periods) * 8));  // steps of an eighth of a period
      for (int i = 0; i < n; ++i) flow_ld.advance(q_ref, P_ref, ld(h) / n);
      const double eL = rotation_distance(q.cast<ld>(), q_ref), eP = double((P.cast<ld>() - P_ref).norm()) / P0.norm();
      worst = std::max(worst, eL / std::max(1.0, std::abs(periods)));
      INFO(c.name << ": h = " << periods << " periods; ‖ΔΛ‖ " << eL << ", ‖ΔΠ‖/‖Π‖ " << eP);
      CHECK(eL <= c.tol * std::max(1.0, std::abs(periods)));
      CHECK(eP <= c.tol * std::max(1.0, std::abs(periods)));
    }
  }
  std::printf("steps of 0.5 to 40.6 periods against long-double chains: ‖ΔΛ‖ up to %.2e a period\n", worst);
#ifdef TROMPO_HAVE_BOOST
  // FB1 over h = 10⁶ (45,000 periods; refused before the reduction: it needed 6·10⁵ panels)
  // against exact::FreeBody, which reduces t by its own ψ_T (found by Gauss–Legendre panels).
  const V3<double> J(1, 2, 3), W0(0.01, 2, 0.01);
  const EulerPoinsot<double> flow(J);
  const trompo::exact::FreeBody ref(J, Eigen::Matrix3d::Identity(), W0);
  Quat<double> q = Quat<double>::Identity();
  V3<double> P = J.cwiseProduct(W0);
  flow.advance(q, P, 1e6);
  REQUIRE(P.allFinite());
  const double eL = (q.toRotationMatrix() - ref.rotation(1e6)).norm();
  const double eW = (P.cwiseQuotient(J) - ref.omega(1e6)).norm() / W0.norm();
  std::printf("FB1, one step of h = 1e6 against exact::FreeBody: ‖ΔΛ‖ %.2e, ‖ΔΩ‖/‖Ω‖ %.2e\n", eL, eW);
  CHECK(eL <= 1e-9);  // measured 2.8e-10 (FreeBody's ψ_T is a flow call over a period, [F9] too)
  CHECK(eW <= 1e-9);
  // Against the independent closed form (Jacobi functions, Carlson's R_J), itself ~4e-10
  // from a long-double flow at t = 1e6 (the period's rounding, times 45,000 periods).
  const trompo::exact::FreeBodyClosedForm closed(J, Eigen::Matrix3d::Identity(), W0);
  const double eC = (q.toRotationMatrix() - closed.rotation(1e6)).norm();
  std::printf("FB1, one step of h = 1e6 against exact::FreeBodyClosedForm: ‖ΔΛ‖ %.2e\n", eC);
  CHECK(eC <= 2e-9);
#endif
}

TEST_CASE("free flow: h then -h returns to the start", "[free_flow]") {
  for (const Body& b : random_bodies()) {
    const EulerPoinsot<double> flow(b.J);
    Quat<double> q(Eigen::AngleAxisd(1.1, V3<double>(0.2, 1, -0.4).normalized()));
    V3<double> P = b.Pi;
    const Quat<double> q0 = q;
    const double h = 1.7;
    flow.advance(q, P, h);
    flow.advance(q, P, -h);
    INFO(b.what << " J = " << b.J.transpose());
    CHECK((P - b.Pi).norm() <= 1e-15 * (1 + b.Pi.norm()));
    CHECK((q.toRotationMatrix() - q0.toRotationMatrix()).norm() <= 1e-14);
  }
}

TEMPLATE_TEST_CASE("free flow: float and long double against the long-double RK4", "[free_flow]", float,
                   long double) {
  using S = TestType;
  const S eps = std::numeric_limits<S>::epsilon();
  for (const Body& b : random_bodies()) {
    const EulerPoinsot<S> flow(b.J.cast<S>());
    Quat<S> q(Eigen::AngleAxis<S>(S(0.7), V3<S>(1, -2, S(0.5)).normalized()));
    V3<S> P = b.Pi.cast<S>();
    Quat<ld> ql = q.template cast<ld>();
    V3<ld> Pl = P.template cast<ld>();
    const double h = 1.3;
    flow.advance(q, P, S(h));
    rk4_free(b.J.cast<ld>(), ql, Pl, ld(h), 3000);
    const double eP = double((P.template cast<ld>() - Pl).norm() / Pl.norm());
    const double eL = rotation_distance(q.template cast<ld>(), ql);
    INFO(b.what << " J = " << b.J.transpose() << " eP = " << eP << " eL = " << eL);
    CHECK(eP <= 40 * double(eps) + 1e-16);
    CHECK(eL <= 100 * double(eps) + 1e-16);
  }
}

TEST_CASE("free flow: bad input", "[free_flow]") {
  CHECK_THROWS_AS(EulerPoinsot<double>(V3<double>(1, 0, 2)), trompo::invalid_input);
  CHECK_THROWS_AS(EulerPoinsot<double>(V3<double>(1, -2, 3)), trompo::invalid_input);
  CHECK_THROWS_AS(EulerPoinsot<double>(V3<double>(1, std::nan(""), 3)), trompo::invalid_input);
  CHECK_THROWS_WITH(EulerPoinsot<double>(V3<double>(1, 0, 2)), Catch::Contains("principal moments J"));
  const EulerPoinsot<double> flow(V3<double>(1, 2, 3));
  Quat<double> q = Quat<double>::Identity();
  V3<double> P(0.1, 2, 0.3);
  flow.advance(q, P, std::numeric_limits<double>::infinity());
  CHECK(!P.allFinite());  // non-finite h: non-finite output, which a stepper reports
  V3<double> zero = V3<double>::Zero();
  Quat<double> q0 = Quat<double>::Identity();
  flow.advance(q0, zero, 3.0);  // at rest: nothing moves
  CHECK(zero == V3<double>::Zero());
  CHECK(q0.coeffs() == Quat<double>::Identity().coeffs());
}
