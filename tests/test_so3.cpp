// SO3 property suite: one generic suite over float, double and long double,
// hard inputs written out, fixed seeds, every series threshold probed at
// threshold·(1 ± 1e-3) against an independent high-precision reference.
#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "support/show.hpp"
#include "support/trompo_test.hpp"
#include "trompo/lie/series.hpp"
#include "trompo/lie/so3.hpp"

#ifdef TROMPO_HAVE_BOOST
#include <boost/multiprecision/cpp_bin_float.hpp>
#endif

using trompo::SO3;
using trompo_test::Rng;

namespace {

template <class S>
using V3 = Eigen::Matrix<S, 3, 1>;
template <class S>
using M3 = Eigen::Matrix<S, 3, 3>;
using LD = long double;

template <class S>
S eps() {
  return std::numeric_limits<S>::epsilon();
}

constexpr LD kPi = 3.141592653589793238462643383279502884L;

/// The hard angles of the suite, written out (docs/theory.md §9), as Scalar values.
template <class S>
std::vector<S> hard_angles() {
  const S th = trompo::detail::small_angle<S>::theta;  // 0.25: series switch of sinc, T, T⁻¹
  const S lo = S(1) - S(1e-3L), hi = S(1) + S(1e-3L);
  const S pi = S(kPi);
  return {S(0),      S(1e-8L),      S(1e-4L),      S(0.1L),  th * lo, th * hi, S(2) * th * lo, S(2) * th * hi,
          S(1),      S(2),          S(3),          pi - S(1e-6L), pi};
}

/// A random rotation built in Scalar S itself (a double matrix cast to long double would be
/// orthonormal to the double ε only).
template <class S>
M3<S> random_rotation(Rng& rng) {
  return SO3<S>::exp(rng.vector(0.0, 3.1).cast<S>()).matrix();
}

/// Fixed axes: the coordinate axes, a diagonal, and seeded random ones.
template <class S>
std::vector<V3<S>> axes(std::uint64_t seed, int n_random) {
  std::vector<V3<S>> a{V3<S>::UnitX(), V3<S>::UnitY(), V3<S>::UnitZ(), V3<S>(S(1), S(-1), S(1)).normalized()};
  Rng rng(seed);
  for (int i = 0; i < n_random; ++i) a.push_back(rng.unit().cast<S>().normalized());
  return a;
}

// ---- high-precision references of the series coefficients -----------------------------
// Closed forms evaluated in 50 significant digits (Boost.Multiprecision), where the
// cancellation of 1 − cos θ etc. (at most ~35 digits at θ = 1e-8) still leaves ≥ 15 digits
// beyond long double. Without Boost: long double closed forms, whose own error is
// added to the tolerance (reference_error below).
#ifdef TROMPO_HAVE_BOOST
using Hi = boost::multiprecision::cpp_bin_float_50;
constexpr bool kExactReference = true;
#else
using Hi = long double;
constexpr bool kExactReference = false;
#endif

enum class Coef {
  sinc, one_minus_cos_over_sq, theta_minus_sin_over_cube, inverse_tangent, kappa, one_minus_kappa, kappa_prime_over_theta,
  // detail::half_angle and the coefficients derived from it (series switch at θ = ½)
  half_kappa, half_cos, half_sinc, half_one_minus_cos_over_sq, half_b_half
};

const char* name(Coef c) {
  switch (c) {
    case Coef::sinc: return "sinc";
    case Coef::one_minus_cos_over_sq: return "one_minus_cos_over_sq";
    case Coef::theta_minus_sin_over_cube: return "theta_minus_sin_over_cube";
    case Coef::inverse_tangent: return "inverse_tangent_coefficient";
    case Coef::kappa: return "kappa";
    case Coef::one_minus_kappa: return "one_minus_kappa";
    case Coef::kappa_prime_over_theta: return "kappa_prime_over_theta";
    case Coef::half_kappa: return "half_angle.kappa";
    case Coef::half_cos: return "half_angle.cos_half";
    case Coef::half_sinc: return "half_angle.sinc()";
    case Coef::half_one_minus_cos_over_sq: return "half_angle.one_minus_cos_over_sq()";
    case Coef::half_b_half: return "half_angle.half_one_minus_cos_over_sq()";
  }
  return "?";
}

/// The exact value at t (t ≥ 0), by the closed form, with the θ = 0 limits written out.
Hi reference(Coef c, Hi t) {
  using std::cos;
  using std::sin;
  if (t == 0) {
    switch (c) {
      case Coef::sinc: return Hi(1);
      case Coef::one_minus_cos_over_sq: return Hi(1) / 2;
      case Coef::theta_minus_sin_over_cube: return Hi(1) / 6;
      case Coef::inverse_tangent: return Hi(1) / 12;
      case Coef::kappa: return Hi(1);
      case Coef::one_minus_kappa: return Hi(0);
      case Coef::kappa_prime_over_theta: return Hi(-1) / 12;
      case Coef::half_kappa: return Hi(1);
      case Coef::half_cos: return Hi(1);
      case Coef::half_sinc: return Hi(1);
      case Coef::half_one_minus_cos_over_sq: return Hi(1) / 2;
      case Coef::half_b_half: return Hi(1) / 2;
    }
  }
  const Hi y = t / 2;
  switch (c) {
    case Coef::sinc: return sin(t) / t;
    case Coef::one_minus_cos_over_sq: return (1 - cos(t)) / (t * t);
    case Coef::theta_minus_sin_over_cube: return (t - sin(t)) / (t * t * t);
    case Coef::inverse_tangent: return (1 - y * cos(y) / sin(y)) / (t * t);
    case Coef::kappa: return sin(y) / y;
    case Coef::one_minus_kappa: return 1 - sin(y) / y;
    case Coef::kappa_prime_over_theta: return (y * cos(y) - sin(y)) / (t * t * t / 2);
    case Coef::half_kappa: return sin(y) / y;
    case Coef::half_cos: return cos(y);
    case Coef::half_sinc: return sin(t) / t;
    case Coef::half_one_minus_cos_over_sq: return (1 - cos(t)) / (t * t);
    case Coef::half_b_half: return (1 - cos(y)) / (y * y);
  }
  return Hi(0);
}

template <class S>
S evaluate(Coef c, S t) {
  namespace d = trompo::detail;
  switch (c) {
    case Coef::sinc: return d::sinc(t);
    case Coef::one_minus_cos_over_sq: return d::one_minus_cos_over_sq(t);
    case Coef::theta_minus_sin_over_cube: return d::theta_minus_sin_over_cube(t);
    case Coef::inverse_tangent: return d::inverse_tangent_coefficient(t);
    case Coef::kappa: return d::kappa(t);
    case Coef::one_minus_kappa: return d::one_minus_kappa(t);
    case Coef::kappa_prime_over_theta: return d::kappa_prime_over_theta(t);
    case Coef::half_kappa: return d::half_angle(t).kappa;
    case Coef::half_cos: return d::half_angle(t).cos_half;
    case Coef::half_sinc: return d::half_angle(t).sinc();
    case Coef::half_one_minus_cos_over_sq: return d::half_angle(t).one_minus_cos_over_sq();
    case Coef::half_b_half: return d::half_angle(t).half_one_minus_cos_over_sq();
  }
  return S(0);
}

/// Relative error bound of the long-double fallback reference (its own cancellation).
double reference_error(double t) {
  if (kExactReference) return 0.0;
  const double e = static_cast<double>(std::numeric_limits<long double>::epsilon());
  return t > 0 ? 64 * e / std::min(1.0, t * t * t) : 0.0;
}

/// Reference rotation matrix by Eigen's AngleAxis in long double (an implementation
/// independent of trompo's quaternion and Rodrigues code).
template <class S>
M3<LD> angle_axis_matrix(const V3<S>& x) {
  const V3<LD> xl = x.template cast<LD>();
  const LD th = xl.norm();
  if (th == 0) return M3<LD>::Identity();
  return Eigen::AngleAxis<LD>(th, xl / th).toRotationMatrix();
}

}  // namespace

// =====================================================================================
TEMPLATE_TEST_CASE("SO3 series coefficients: relative error vs high-precision closed form at every threshold*(1 +- 1e-3)",
                   "[so3][series]", float, double, long double) {
  using S = TestType;
  const S th = trompo::detail::small_angle<S>::theta;
  REQUIRE(th == S(0.25));  // the documented switch; the probes below are built on it
  const S lo = S(1) - S(1e-3L), hi = S(1) + S(1e-3L);
  // Probes: the hard angles, plus each coefficient's own switch (θ = ¼ for the first four;
  // θ = ½ for the κ family: one_minus_kappa switches at 2·¼ on θ, kappa_prime_over_theta
  // at ¼ on θ/2; κ = sinc(θ/2) switches at θ = ½ through sinc).
  std::vector<S> probes = hard_angles<S>();
  for (S f : {lo, hi}) {
    probes.push_back(th * f);
    probes.push_back(2 * th * f);
  }
  // Tolerance: 256 ε of the Scalar. The worst closed form right above a switch,
  // (1 − (θ/2)cot(θ/2))/θ², loses ~ε/(θ²/12) ≈ 200 ε at θ = ¼ in the last bit-rounding of
  // its cot; the series lose only a few ε. (1e-12 relative in double, is 4500 ε.)
  const double tol_ulps = 256;
  const Coef all[] = {Coef::sinc,       Coef::one_minus_cos_over_sq, Coef::theta_minus_sin_over_cube, Coef::inverse_tangent,
                      Coef::kappa,      Coef::one_minus_kappa,       Coef::kappa_prime_over_theta,    Coef::half_kappa,
                      Coef::half_cos,   Coef::half_sinc,             Coef::half_one_minus_cos_over_sq, Coef::half_b_half};
  using std::abs;
  double worst_ulps = 0;
  for (Coef c : all) {
    for (S t : probes) {
      const Hi ref = reference(c, Hi(static_cast<LD>(t)));
      const S got = evaluate(c, t);
      const double refd = static_cast<double>(ref);
      const double err = refd == 0.0 ? static_cast<double>(abs(Hi(static_cast<LD>(got))))
                                     : static_cast<double>(abs((Hi(static_cast<LD>(got)) - ref) / ref));
      const double ulps = err / static_cast<double>(eps<S>());
      worst_ulps = std::max(worst_ulps, ulps);
      INFO(name(c) << " at theta = " << static_cast<double>(t) << ": got " << static_cast<double>(got) << ", reference "
                   << refd << ", relative error " << err << " = " << ulps << " eps");
      CHECK(std::isfinite(static_cast<double>(got)));
      CHECK(err <= tol_ulps * static_cast<double>(eps<S>()) + reference_error(static_cast<double>(t)));
    }
  }
  SHOW("worst series-coefficient error over all probes: " << worst_ulps << " eps of " << sizeof(S) << "-byte Scalar");
}

TEMPLATE_TEST_CASE("SO3 series coefficients: both branches agree across each switch (jump <= 256 eps + slope)",
                   "[so3][series]", float, double, long double) {
  using S = TestType;
  // The value just below and just above a switch differ only by the slope over 2e-3·θ*:
  // compare the jump to the reference jump, so a branch with a wrong term shows up.
  const S th = trompo::detail::small_angle<S>::theta;
  const Coef all[] = {Coef::sinc,       Coef::one_minus_cos_over_sq, Coef::theta_minus_sin_over_cube, Coef::inverse_tangent,
                      Coef::kappa,      Coef::one_minus_kappa,       Coef::kappa_prime_over_theta,    Coef::half_kappa,
                      Coef::half_cos,   Coef::half_sinc,             Coef::half_one_minus_cos_over_sq, Coef::half_b_half};
  for (Coef c : all) {
    using std::abs;
    const bool kappa_family = c == Coef::kappa || c == Coef::one_minus_kappa || c == Coef::kappa_prime_over_theta ||
                              c >= Coef::half_kappa;  // the half-angle pair switches at θ/2 = ¼
    const S sw = kappa_family ? 2 * th : th;
    const S a = sw * (S(1) - S(1e-3L)), b = sw * (S(1) + S(1e-3L));
    const Hi ref_jump = reference(c, Hi(static_cast<LD>(b))) - reference(c, Hi(static_cast<LD>(a)));
    const Hi got_jump = Hi(static_cast<LD>(evaluate(c, b))) - Hi(static_cast<LD>(evaluate(c, a)));
    const double scale = std::abs(static_cast<double>(reference(c, Hi(static_cast<LD>(sw)))));
    const double err = static_cast<double>(abs(got_jump - ref_jump)) / scale;
    INFO(name(c) << " across theta = " << static_cast<double>(sw) << ": jump " << static_cast<double>(got_jump)
                 << " vs reference " << static_cast<double>(ref_jump) << ", error " << err / static_cast<double>(eps<S>())
                 << " eps");
    CHECK(err <= 256 * static_cast<double>(eps<S>()) + 2 * reference_error(static_cast<double>(sw)));
  }
}

// =====================================================================================
TEMPLATE_TEST_CASE("SO3 hat/vee: hat(x) a = x cross a, hat is skew, vee(hat(x)) = x exactly", "[so3]", float, double,
                   long double) {
  using S = TestType;
  Rng rng(11);
  for (int i = 0; i < 50; ++i) {
    const V3<S> x = rng.vector(0, 5).cast<S>();
    const V3<S> a = rng.vector(0, 5).cast<S>();
    const M3<S> X = SO3<S>::hat(x);
    CAPTURE(i);
    CHECK((X * a - x.cross(a)).cwiseAbs().maxCoeff() <= 8 * eps<S>() * S(25));
    CHECK((X + X.transpose()).cwiseAbs().maxCoeff() == S(0));
    CHECK(SO3<S>::vee(X) == x);
    // hat_squared(x) = x̂ x̂ = x xᵀ − |x|² I, symmetric, to a few ε of |x|².
    const M3<S> X2 = SO3<S>::hat_squared(x);
    CHECK((X2 - X * X).cwiseAbs().maxCoeff() <= 4 * eps<S>() * x.squaredNorm());
    CHECK((X2 - (x * x.transpose() - x.squaredNorm() * M3<S>::Identity())).cwiseAbs().maxCoeff() <=
          4 * eps<S>() * x.squaredNorm());
    CHECK(X2 == X2.transpose());
    // rodrigues(x, a, b) = I + a x̂ + b x̂², exp_matrix(x) with the coefficients of (8).
    CHECK((SO3<S>::rodrigues(x, S(0.3), S(-0.2)) - (M3<S>::Identity() + S(0.3) * X + S(-0.2) * X * X))
              .cwiseAbs()
              .maxCoeff() <= 8 * eps<S>() * (S(1) + x.squaredNorm()));
    // vee keeps the skew part only: vee(M) = vee((M − Mᵀ)/2) for a general M.
    const M3<S> M = M3<S>::Random();
    CHECK((SO3<S>::vee(M) - SO3<S>::vee(M3<S>((M - M.transpose()) / S(2)))).cwiseAbs().maxCoeff() <= 4 * eps<S>());
  }
}

TEMPLATE_TEST_CASE("SO3 exp vs Rodrigues: quaternion exp, exp_matrix and long-double AngleAxis agree to 16 eps", "[so3]",
                   float, double, long double) {
  using S = TestType;
  for (const V3<S>& n : axes<S>(21, 6)) {
    for (S t : hard_angles<S>()) {
      const V3<S> x = n * t;
      const M3<LD> ref = angle_axis_matrix(x);
      const M3<S> q = SO3<S>::exp(x).matrix();
      const M3<S> r = SO3<S>::exp_matrix(x);
      const double eq = trompo_test::max_abs(q.template cast<LD>() - ref);
      const double er = trompo_test::max_abs(r.template cast<LD>() - ref);
      INFO("theta = " << static_cast<double>(t) << " axis " << n.transpose().template cast<double>() << ": exp error "
                      << eq << ", exp_matrix error " << er << " (eps = " << static_cast<double>(eps<S>()) << ")");
      CHECK(eq <= 16 * static_cast<double>(eps<S>()));
      CHECK(er <= 16 * static_cast<double>(eps<S>()));
      // The stored quaternion is canonical (w ≥ 0) and unit.
      CHECK(SO3<S>::exp(x).unit_quaternion().w() >= S(0));
      CHECK(std::abs(static_cast<double>(SO3<S>::exp(x).unit_quaternion().norm()) - 1.0) <= 4 * static_cast<double>(eps<S>()));
    }
  }
}

TEMPLATE_TEST_CASE("SO3 exp/log round trip: log(exp(x)) = x for |x| < pi (abs error <= 32 eps), exp(log(R)) = R",
                   "[so3]", float, double, long double) {
  using S = TestType;
  const S pi = S(kPi);
  for (const V3<S>& n : axes<S>(31, 8)) {
    for (S t : hard_angles<S>()) {
      const V3<S> x = n * t;
      const SO3<S> R = SO3<S>::exp(x);
      const V3<S> w = R.log();
      INFO("theta = " << static_cast<double>(t) << ", log = " << w.transpose().template cast<double>());
      CHECK(static_cast<double>(w.norm()) <= static_cast<double>(pi) * (1 + 4 * static_cast<double>(eps<S>())));
      if (t < pi) {
        CHECK(static_cast<double>((w - x).norm()) <= 32 * static_cast<double>(eps<S>()) * std::max(1.0, static_cast<double>(t)));
      } else {
        // θ = π: x and −x are the same rotation; either is a correct logarithm.
        const double e = static_cast<double>(std::min((w - x).norm(), (w + x).norm()));
        CHECK(e <= 64 * static_cast<double>(eps<S>()));
      }
      const M3<S> back = SO3<S>::exp(w).matrix();
      CHECK(trompo_test::max_abs(back - R.matrix()) <= 16 * static_cast<double>(eps<S>()));
    }
  }
}

TEMPLATE_TEST_CASE("SO3 log near pi from a matrix: half turns and pi - 1e-6 recovered to 64 eps", "[so3]", float, double,
                   long double) {
  using S = TestType;
  const S pi = S(kPi);
  // Exact half turns written out: diag(1,−1,−1) is π about e1, etc.
  const M3<S> half_turns[] = {V3<S>(1, -1, -1).asDiagonal(), V3<S>(-1, 1, -1).asDiagonal(), V3<S>(-1, -1, 1).asDiagonal()};
  for (int k = 0; k < 3; ++k) {
    const V3<S> w = SO3<S>::from_matrix(half_turns[k]).log();
    V3<S> expected = V3<S>::Zero();
    expected(k) = pi;
    CAPTURE(k);
    CHECK(static_cast<double>(std::min((w - expected).norm(), (w + expected).norm())) <= 64 * static_cast<double>(eps<S>()));
  }
  // π − 1e-6 about seeded random axes, entered as an AngleAxis matrix (long double → S).
  for (const V3<S>& n : axes<S>(41, 6)) {
    const S t = pi - S(1e-6L);
    const M3<S> R = angle_axis_matrix(V3<S>(n * t)).template cast<S>();
    const V3<S> w = SO3<S>::from_matrix(R).log();
    INFO("axis " << n.transpose().template cast<double>() << ": log = " << w.transpose().template cast<double>());
    // The axis of a near-half-turn from a rounded matrix is determined to ~ε/(π − θ) only
    // (the matrix depends on the axis through sin θ there), so compare the rotations.
    CHECK(trompo_test::max_abs(SO3<S>::exp(w).matrix() - R) <= 16 * static_cast<double>(eps<S>()));
    CHECK(std::abs(static_cast<double>(w.norm() - t)) <= 64 * static_cast<double>(eps<S>()));
  }
}

TEMPLATE_TEST_CASE("SO3 right tangent: exp((x+d)^) = exp(x^) exp((T(x)d)^) + O(d^2), central differences in long double",
                   "[so3][tangent]", float, double, long double) {
  using S = TestType;
  // Reference: the derivative of w(δ) = log(exp(x̂)ᵀ exp((x+δ)^)) at δ = 0, by fourth-order
  // central differences in long double (δ = 1e-4: truncation ~1e-16, round-off ~1e-15).
  // The FD reference therefore limits the check to ~1e-13 for long double; the coefficient
  // test above pins T's coefficients to the long-double ε.
  const double tol = std::max(64 * static_cast<double>(eps<S>()), 1e-13);
  for (const V3<S>& n : axes<S>(51, 6)) {
    for (S t : hard_angles<S>()) {
      const V3<S> x = n * t;
      const V3<LD> xl = x.template cast<LD>();
      const SO3<LD> Rt = SO3<LD>::exp(xl).inverse();
      auto w = [&](const V3<LD>& d) { return V3<LD>((Rt * SO3<LD>::exp(V3<LD>(xl + d))).log()); };
      const M3<LD> fd = trompo_test::central_jacobian<LD>(w, V3<LD>::Zero(), LD(1e-4L));
      const M3<S> T = SO3<S>::right_tangent(x);
      const double err = trompo_test::max_abs(T.template cast<LD>() - fd);
      INFO("theta = " << static_cast<double>(t) << ": max|T - FD| = " << err);
      CHECK(err <= tol);
    }
  }
}

TEMPLATE_TEST_CASE("SO3 right tangent inverse: Tinv(x) T(x) = I to 32 eps (theta up to pi)", "[so3][tangent]", float,
                   double, long double) {
  using S = TestType;
  for (const V3<S>& n : axes<S>(61, 6)) {
    for (S t : hard_angles<S>()) {
      const V3<S> x = n * t;
      const M3<S> P = SO3<S>::right_tangent_inverse(x) * SO3<S>::right_tangent(x);
      const double err = trompo_test::max_abs(P - M3<S>::Identity());
      INFO("theta = " << static_cast<double>(t) << ": max|Tinv T - I| = " << err);
      CHECK(err <= 32 * static_cast<double>(eps<S>()));
      const M3<S> P2 = SO3<S>::right_tangent(x) * SO3<S>::right_tangent_inverse(x);
      CHECK(trompo_test::max_abs(P2 - M3<S>::Identity()) <= 32 * static_cast<double>(eps<S>()));
    }
  }
}

TEMPLATE_TEST_CASE("SO3 group operations: products and inverses match matrices to 16 eps, quaternion stays canonical",
                   "[so3]", float, double, long double) {
  using S = TestType;
  Rng rng(71);
  for (int i = 0; i < 50; ++i) {
    const SO3<S> a = SO3<S>::exp(rng.vector(0, 3.1).cast<S>());
    const SO3<S> b = SO3<S>::exp(rng.vector(0, 3.1).cast<S>());
    const V3<S> v = rng.vector(0, 2).cast<S>();
    CAPTURE(i);
    CHECK(trompo_test::max_abs((a * b).matrix() - a.matrix() * b.matrix()) <= 16 * static_cast<double>(eps<S>()));
    CHECK(trompo_test::max_abs((a * a.inverse()).matrix() - M3<S>::Identity()) <= 16 * static_cast<double>(eps<S>()));
    CHECK(trompo_test::max_abs(a * v - a.matrix() * v) <= 16 * static_cast<double>(eps<S>()));
    CHECK((a * b).unit_quaternion().w() >= S(0));
    CHECK(a.inverse().unit_quaternion().w() >= S(0));
  }
}

TEMPLATE_TEST_CASE("SO3 from_matrix: accepts rotations within tolerance, rejects non-orthonormal, reflections and NaN with a message",
                   "[so3][validation]", float, double, long double) {
  using S = TestType;
  const S tol = SO3<S>::default_tolerance();
  Rng rng(81);
  const M3<S> R = random_rotation<S>(rng);
  const M3<S> R_ok = SO3<S>::exp(rng.vector(0.5, 3).cast<S>()).matrix();

  // A rotation round-trips.
  CHECK(trompo_test::max_abs(SO3<S>::from_matrix(R_ok).matrix() - R_ok) <= 8 * static_cast<double>(eps<S>()));
  // A uniform drift of d scales RᵀR − I by ≈ 2d: accepted at d = tol/10, rejected at d = 10 tol.
  CHECK_NOTHROW(SO3<S>::from_matrix(R_ok * (S(1) + tol / 10)));
  auto message_of = [](auto&& f) -> std::string {
    try {
      f();
    } catch (const trompo::invalid_input& e) {
      return e.what();
    }
    return "";
  };
  const std::string drift = message_of([&] { (void)SO3<S>::from_matrix(R_ok * (S(1) + 10 * tol)); });
  INFO("drift message: " << drift);
  CHECK(drift.find("not orthonormal") != std::string::npos);
  // A larger tolerance accepts it.
  CHECK_NOTHROW(SO3<S>::from_matrix(R_ok * (S(1) + 10 * tol), 100 * tol));

  // A shear.
  M3<S> shear = R;
  shear(0, 1) += S(1e-2L);
  CHECK(message_of([&] { (void)SO3<S>::from_matrix(shear); }).find("not orthonormal") != std::string::npos);
  // Reflections: orthonormal, determinant −1.
  const std::string refl = message_of([&] { (void)SO3<S>::from_matrix(M3<S>(-R)); });
  INFO("reflection message: " << refl);
  CHECK(refl.find("reflection") != std::string::npos);
  CHECK(message_of([&] { (void)SO3<S>::from_matrix(M3<S>(V3<S>(1, 1, -1).asDiagonal())); }).find("reflection") !=
        std::string::npos);
  // Non-finite.
  M3<S> bad = R;
  bad(2, 2) = std::numeric_limits<S>::quiet_NaN();
  CHECK(message_of([&] { (void)SO3<S>::from_matrix(bad); }).find("non-finite") != std::string::npos);
  CHECK_THROWS_AS(SO3<S>::from_matrix(bad), trompo::invalid_input);
  // Quaternions: a norm off by 10·tol is rejected, renormalized() repairs it.
  const Eigen::Quaternion<S> q(S(1.1L), S(0.2L), S(-0.3L), S(0.1L));
  CHECK_THROWS_AS(SO3<S>::from_quaternion(q), trompo::invalid_input);
  CHECK(std::abs(static_cast<double>(SO3<S>::renormalized(q).unit_quaternion().norm()) - 1.0) <=
        4 * static_cast<double>(eps<S>()));
  // Far from |q| = 1, where |q|² overflows or underflows: rescaled first, never the zero
  // quaternion (which normalising by an infinite norm gave) and never a spurious throw.
  for (const S big : {std::numeric_limits<S>::max() / S(4), S(1) / std::numeric_limits<S>::min(),
                      std::numeric_limits<S>::min() * S(4), std::numeric_limits<S>::denorm_min()}) {
    const Eigen::Quaternion<S> far(big, -big, S(0), big);
    const auto u = SO3<S>::renormalized(far).unit_quaternion();
    CAPTURE(static_cast<double>(big));
    CHECK(std::abs(static_cast<double>(u.norm()) - 1.0) <= 4 * static_cast<double>(eps<S>()));
    CHECK(std::abs(static_cast<double>(u.w()) - 1.0 / std::sqrt(3.0)) <= 1e-6);
    CHECK(std::abs(static_cast<double>(u.x()) + 1.0 / std::sqrt(3.0)) <= 1e-6);
  }
  CHECK_THROWS_AS(SO3<S>::renormalized(Eigen::Quaternion<S>(S(0), S(0), S(0), S(0))), trompo::invalid_input);
}

TEMPLATE_TEST_CASE("SO3 renormalized: repairs a drifted matrix to its polar rotation (error <= 64 eps), rejects singular and reflecting input",
                   "[so3][validation]", float, double, long double) {
  using S = TestType;
  Rng rng(91);
  for (int i = 0; i < 20; ++i) {
    const M3<S> R = random_rotation<S>(rng);
    // M = R S with S symmetric positive definite: the polar (nearest) rotation is exactly R.
    const M3<S> P = random_rotation<S>(rng);
    const V3<S> s(S(rng.uniform(0.8, 1.2)), S(rng.uniform(0.8, 1.2)), S(rng.uniform(0.8, 1.2)));
    const M3<S> M = R * (P * s.asDiagonal() * P.transpose());
    const SO3<S> fixed = SO3<S>::renormalized(M);
    const M3<S> F = fixed.matrix();
    INFO("case " << i << ": max|F - R| = " << trompo_test::max_abs(F - R));
    CHECK(trompo_test::max_abs(F.transpose() * F - M3<S>::Identity()) <= 8 * static_cast<double>(eps<S>()));
    CHECK(trompo_test::max_abs(F - R) <= 64 * static_cast<double>(eps<S>()));
    CHECK_THROWS_AS(SO3<S>::from_matrix(M), trompo::invalid_input);  // the strict path refuses it
  }
  M3<S> singular = M3<S>::Identity();
  singular(2, 2) = S(0);
  CHECK_THROWS_AS(SO3<S>::renormalized(singular), trompo::invalid_input);
  CHECK_THROWS_AS(SO3<S>::renormalized(M3<S>(-M3<S>::Identity())), trompo::invalid_input);
}

// ---- sin_cos and small_sinc_cos (lie/series.hpp): three terms of each series below
// small_angle::tiny, seven below small_angle::theta, the library's sin and cos above; each
// within 2ε of the exact values on both sides of both switches, in every Scalar.
template <class S>
void check_sin_cos_tiers() {
  using trompo::detail::small_angle;
  const S tiny = small_angle<S>::tiny, th = small_angle<S>::theta;
  const S lo = S(1) - S(1e-4L), hi = S(1) + S(1e-4L);
  std::vector<S> ys{S(0), S(1e-12L), S(1e-6L), S(0.5) * tiny, tiny * lo, tiny, tiny * hi, S(2) * tiny,
                    S(0.1L), th * lo, th, th * hi, S(1), S(3)};
  const S tol = S(2) * eps<S>();
  for (const S y0 : ys) {
    for (const S y : {y0, -y0}) {
      S s, c;
      trompo::detail::sin_cos(y, s, c);
      const Hi exact_s = sin(Hi(y)), exact_c = cos(Hi(y));
      INFO(typeid(S).name() << " y = " << static_cast<double>(y));
      CHECK(std::abs(static_cast<LD>(Hi(s) - exact_s)) <= static_cast<LD>(tol) * std::abs(static_cast<LD>(exact_s)));
      CHECK(std::abs(static_cast<LD>(Hi(c) - exact_c)) <= static_cast<LD>(tol) * std::abs(static_cast<LD>(exact_c)));
      if (y * y < th * th) {  // small_sinc_cos takes y² below the switch
        S sinc_y, c2;
        trompo::detail::small_sinc_cos(y * y, sinc_y, c2);
        const Hi yy = Hi(y * y);  // the argument as given, rounded
        using std::sqrt;
        const Hi r = sqrt(yy), exact_sinc = r == 0 ? Hi(1) : Hi(sin(r) / r);
        CHECK(std::abs(static_cast<LD>(Hi(sinc_y) - exact_sinc)) <= static_cast<LD>(tol) * static_cast<LD>(exact_sinc));
        CHECK(std::abs(static_cast<LD>(Hi(c2) - cos(r))) <= static_cast<LD>(tol) * std::abs(static_cast<LD>(cos(r))));
      }
    }
  }
}

TEST_CASE("series: sin_cos and small_sinc_cos within 2 eps across both switches", "[so3][series]") {
  check_sin_cos_tiers<float>();
  check_sin_cos_tiers<double>();
  check_sin_cos_tiers<long double>();
}
