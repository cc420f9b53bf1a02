// Analytic Newton tangents ([T3], [T4]/[T5] tangents, the half-rotation Jacobian)
// against central differences, and the collocation root of [T2] against an independent
// root finder.
//
// The finite-difference reference is computed in long double on the same scene and state
// (fourth-order central differences), so its own error (≤ ~1e-11 relative) stays well
// below the tolerances; the analytic tangent is the library's double instantiation.
#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "support/show.hpp"
#include "support/trompo_test.hpp"
#include "trompo/schemes/geradin_bauchau/geradin_bauchau.hpp"
#include "trompo/schemes/geradin_bauchau/geradin_bauchau_paper.hpp"
#include "trompo/schemes/simo/simo.hpp"

#ifdef TROMPO_HAVE_BOOST
#include <boost/multiprecision/cpp_bin_float.hpp>
#endif

using namespace trompo;
using trompo_test::Mat3;
using trompo_test::Rng;
using trompo_test::Vec3;
using LD = long double;
using Vec3L = Eigen::Matrix<LD, 3, 1>;
using Mat3L = Eigen::Matrix<LD, 3, 3>;

namespace {

/// A scene in double and the same scene in long double (for the FD reference).
struct TopPair {
  HeavyTop<double> d;
  HeavyTop<LD> l;
};
struct FreePair {
  FreeScene<double> d;
  FreeScene<LD> l;
};

TopPair make_top(const Mat3& J, double Mgl, const Vec3& E, const Vec3& up) {
  return {HeavyTop<double>(RigidBody<double>(J), UniformGravity<double>(Mgl, E, up)),
          HeavyTop<LD>(RigidBody<LD>(Mat3L(J.cast<LD>())), UniformGravity<LD>(LD(Mgl), E.cast<LD>(), up.cast<LD>()))};
}
FreePair make_free(const Mat3& J) { return {FreeScene<double>(RigidBody<double>(J)), FreeScene<LD>(RigidBody<LD>(Mat3L(J.cast<LD>())))}; }

template <class Scheme>
constexpr bool is_gb = std::is_same_v<Scheme, GeradinBauchau> || std::is_same_v<Scheme, GeradinBauchauPaper>;

/// Evaluates the scheme's residual and tangent at the unknown x (y = Θ − hΩ_n for Simo,
/// z = e − hΩ_n/2 for GB).
template <class Scheme, class Scene>
void residual(const Scheme& scheme, const detail::StepData<Scene>& data, const Eigen::Matrix<typename Scene::Scalar, 3, 1>& x,
              Eigen::Matrix<typename Scene::Scalar, 3, 1>& R, Eigen::Matrix<typename Scene::Scalar, 3, 3>& K) {
  typename Scene::Scalar scale;
  bool in_domain = true;
  in_domain = scheme.residual(data)(x, R, K, scale);
  REQUIRE(in_domain);
}

struct TangentCheck {
  double error = 0;     ///< max|K − K_fd| / max|K_fd|
  double k_norm = 0;    ///< max|K_fd|
  double increment = 0; ///< |Θ| (Simo) or the rotation angle 2 asin|e| (GB)
};

/// Analytic K (double) against the long-double fourth-order central difference of R.
template <class Scheme, class Pair>
TangentCheck check_tangent(const Scheme& scheme, const Pair& scenes, const State<double>& s, double h, const Vec3& x,
                           LD delta) {
  using SD = decltype(scenes.d);
  using SL = decltype(scenes.l);
  const detail::StepData<SD> dd(scenes.d, s, h);
  Vec3 R;
  Mat3 K;
  residual(scheme, dd, x, R, K);

  State<LD> sl;
  sl.rotation = s.rotation.template cast<LD>();
  sl.omega = s.omega.cast<LD>();
  sl.time = s.time;
  const detail::StepData<SL> dl(scenes.l, sl, LD(h));
  auto f = [&](const Vec3L& xl) {
    Vec3L r;
    Mat3L k;
    residual(scheme, dl, xl, r, k);
    return r;
  };
  const Mat3L fd = trompo_test::central_jacobian<LD>(f, x.cast<LD>(), delta);
  TangentCheck c;
  c.k_norm = static_cast<double>(fd.cwiseAbs().maxCoeff());
  c.error = static_cast<double>((K.cast<LD>() - fd).cwiseAbs().maxCoeff()) / c.k_norm;
  if constexpr (is_gb<Scheme>) {
    const Vec3 e = h / 2 * s.omega + x;
    c.increment = 2 * std::asin(e.norm());
  } else {
    c.increment = (h * s.omega + x).norm();
  }
  return c;
}

/// The schemes whose tangents are checked (α ≠ ½ too: the tangent must hold for any α).
template <class F>
void for_each_scheme(F&& f) {
  f(SimoAlpha(0.5), "simo-alpha 0.5");
  f(SimoAlpha(0.3), "simo-alpha 0.3");
  f(SimoAlpha(1.0), "simo-alpha 1.0");
  f(SimoCollocation{}, "simo-collocation");
  f(SimoKappa{}, "simo-kappa");
  f(GeradinBauchau{}, "geradin-bauchau [T4]");
  f(GeradinBauchauPaper{}, "geradin-bauchau paper [T5]");
}

/// A random state whose increment has size `size`: for Simo |hΩ_n| = size (Θ = hΩ_n + x,
/// x a perturbation of relative size `rel`); for GB |hΩ_n/2| = sin(size/2).
template <class Scheme>
void random_point(Rng& rng, double h, double size, double rel, State<double>& s, Vec3& x) {
  s.rotation = rng.rotation();
  s.time = rng.uniform(0, 10);
  const Vec3 dir = rng.unit();
  if constexpr (is_gb<Scheme>) {
    s.omega = dir * (2 * std::sin(size / 2) / std::abs(h));
    x = rng.unit() * (rel * std::sin(size / 2));
  } else {
    s.omega = dir * (size / std::abs(h));
    x = rng.unit() * (rel * size);
  }
}

struct Worst {
  double error = 0;
  std::string where;
  void update(double e, const std::string& w) {
    if (e > error) {
      error = e;
      where = w;
    }
  }
};

/// Runs the tangent check of every scheme over `n` seeded random points of increment
/// size drawn by `size_of`, with and without gravity; returns the worst relative error.
template <class SizeOf>
void sweep(const char* label, std::uint64_t seed, int n, SizeOf&& size_of, double rel, LD delta_rel, double tol) {
  for_each_scheme([&](const auto& scheme, const char* name) {
    using Scheme = std::decay_t<decltype(scheme)>;
    Rng rng(seed);
    Worst worst_top, worst_free;
    int skipped = 0;
    for (int i = 0; i < n; ++i) {
      const double h = (i % 3 == 2 ? -1.0 : 1.0) * 0.2;  // every third point steps backward
      const Mat3 J = i % 4 == 0 ? Mat3(Vec3(rng.uniform(1, 2), rng.uniform(1, 2), rng.uniform(1, 2)).asDiagonal())
                                : trompo_test::random_inertia(rng);
      const double Mgl = rng.uniform(20, 60);
      const Vec3 E = rng.unit(), up = rng.unit();
      const double size = size_of(i);
      State<double> s;
      Vec3 x;
      random_point<Scheme>(rng, h, size, rel, s, x);
      const LD delta = size > 0 ? LD(size) * delta_rel : LD(1e-7L);
      const TopPair top = make_top(J, Mgl, E, up);
      if constexpr (std::is_same_v<Scheme, SimoCollocation>) {
        // α(Θ) of [T2] is discontinuous where the midpoint curvature B′ = n·J_c n changes
        // sign (the two roots ½ ± acos(κ)/θ are then equidistant from ½; see the
        // collocation test below). A finite difference that straddles that surface
        // measures the jump, not the tangent: skip points closer to it than the FD
        // stencil can move B′ (|∂B′/∂n| ≤ 2·Mgl; the stencil turns n by ≤ 2δ/θ).
        const Vec3 Theta = h * s.omega + x;
        const double theta = Theta.norm();
        if (theta > 0) {
          const auto caches = top.d.caches(s.rotation.matrix(), s.time + h / 2);
          Mat3 Jh;
          (void)top.d.conservative_torque(caches, SO3<double>::exp_matrix(Theta / 2), &Jh);
          const Vec3 axis = Theta / theta;
          const double B = axis.dot(Jh * axis);
          if (std::abs(B) < 2 * Mgl * 4 * static_cast<double>(delta) / theta * 10) {
            ++skipped;
            continue;
          }
        }
      }
      const TangentCheck ct = check_tangent(scheme, top, s, h, x, delta);
      const TangentCheck cf = check_tangent(scheme, make_free(J), s, h, x, delta);
      const std::string where = std::to_string(i) + " (increment " + std::to_string(ct.increment) + ")";
      worst_top.update(ct.error, where);
      worst_free.update(cf.error, where);
      INFO(label << ", " << name << ", point " << i << ": increment " << ct.increment << ", h " << h
                 << "; relative tangent error with gravity " << ct.error << ", free " << cf.error);
      CHECK(ct.error <= tol);
      CHECK(cf.error <= tol);
    }
    SHOW(label << " " << name << ": worst relative tangent error with gravity " << worst_top.error << " at point "
               << worst_top.where << ", free " << worst_free.error << " at point " << worst_free.where << " ("
               << n - skipped << " of " << n << " points)");
    CHECK(skipped <= n / 4);  // the skip rule must leave most points tested
  });
}

}  // namespace

// =====================================================================================
TEST_CASE("Tangents, moderate increments: relative error vs central differences <= 1e-12 at |Theta| in [0.5, 1.5]",
          "[tangent]") {
  sweep("moderate", 1001, 64, [](int i) { return 0.5 + 1.0 * (i % 8) / 7.0; }, 0.1, LD(1e-5L), 1e-12);
}

TEST_CASE("Tangents, tiny increments: relative error vs central differences <= 1e-9 at |Theta| ~ 1e-6", "[tangent]") {
  // δ = 1e-3·|Θ| ~ 1e-9 keeps the stencil's direction change small (α of collocation
  // depends on Θ's direction); the long-double round-off ε·|R|/δ then limits the
  // reference to ~1e-10 relative, hence 1e-9.
  sweep("tiny", 2002, 32, [](int i) { return 1e-6 * (1 + 0.05 * i); }, 0.3, LD(1e-3L), 1e-9);
}

TEST_CASE("Tangents, body at rest: relative error vs central differences <= 1e-11 at Theta = 0 exactly", "[tangent]") {
  // Ω_n = 0 and a zero Newton unknown: Θ = 0 (e = 0) exactly, every coefficient at θ = 0.
  sweep("at rest", 3003, 16, [](int) { return 0.0; }, 0.0, LD(0), 1e-11);
}

TEST_CASE("Tangents, series switches: relative error <= 1e-12 at |Theta| = 0.25 and 0.5 times (1 +- 1e-3)", "[tangent]") {
  // Simo: exp and T switch at |Θ| = ¼; κ, 1 − κ, κ′/θ and T(Θ/2) (collocation at α = ½)
  // at |Θ| = ½. GB: sinc(β), κ′(2β)/(2β) and T(φ) of the half rotation at β = ¼ (the
  // increment angle 2β = ½); the sizes below give both.
  const double sizes[] = {0.25 * (1 - 1e-3), 0.25 * (1 + 1e-3), 0.5 * (1 - 1e-3), 0.5 * (1 + 1e-3)};
  sweep("switch", 4004, 16, [&](int i) { return sizes[i % 4]; }, 0.0, LD(1e-5L), 1e-12);
}

// =====================================================================================
TEST_CASE("Half rotation F(e) of (40): F = exp(asin|e| e/|e|), F^2 = quaternion (e0, e), Jacobian G vs central differences <= 1e-12",
          "[tangent][gb]") {
  Rng rng(5005);
  const double s_sw = std::sin(0.25);
  const double norms[] = {0.0, 1e-8, 1e-6, 0.1, s_sw * (1 - 1e-3), s_sw * (1 + 1e-3), 0.3, 0.7, 0.95};
  double worst = 0;
  for (double en : norms) {
    for (int k = 0; k < 4; ++k) {
      const Vec3 e = rng.unit() * en;
      detail::HalfRotation<double> hr;
      REQUIRE(hr.set(e));
      // F against an independent construction: AngleAxis by β = asin|e| about e/|e|.
      const double beta = std::asin(en);
      const Mat3 F_ref = en > 0 ? Mat3(Eigen::AngleAxisd(beta, e / en).toRotationMatrix()) : Mat3(Mat3::Identity());
      CHECK(trompo_test::max_abs(hr.F - F_ref) <= 1e-14);
      CHECK(std::abs(hr.e0 - std::sqrt(1 - en * en)) <= 1e-15);
      const Eigen::Quaterniond q(std::sqrt(1 - en * en), e.x(), e.y(), e.z());
      CHECK(trompo_test::max_abs(hr.F * hr.F - q.toRotationMatrix()) <= 1e-14);
      // G: F(e + δ) = F(e) exp((G δ)^) + O(δ²); reference by central differences in long double.
      const Vec3L el = e.cast<LD>();
      detail::HalfRotation<LD> h0;
      REQUIRE(h0.set(el));
      auto w = [&](const Vec3L& d) {
        detail::HalfRotation<LD> h1;
        REQUIRE(h1.set(Vec3L(el + d)));
        return Vec3L(SO3<LD>::from_matrix(Mat3L(h0.F.transpose() * h1.F), LD(1e-15L)).log());
      };
      const LD delta = LD(1e-5L) * std::min(LD(1), LD(1 - en));
      const Mat3L fd = trompo_test::central_jacobian<LD>(w, Vec3L::Zero(), delta);
      const double err = static_cast<double>((hr.G.cast<LD>() - fd).cwiseAbs().maxCoeff() / fd.cwiseAbs().maxCoeff());
      worst = std::max(worst, err);
      INFO("|e| = " << en << ": relative error of G " << err);
      CHECK(err <= 1e-12);
    }
  }
  // |e| ≥ 1 is outside the domain (a half rotation of π/2 or more, an increment ≥ π).
  detail::HalfRotation<double> hr;
  CHECK_FALSE(hr.set(Vec3(1.0, 0.0, 0.0)));
  CHECK_FALSE(hr.set(Vec3(0.8, 0.8, 0.0)));
  SHOW("half rotation: worst relative error of G " << worst);
}

// =====================================================================================
namespace {
#ifdef TROMPO_HAVE_BOOST
using Hi = boost::multiprecision::cpp_bin_float_50;
#else
using Hi = long double;
#endif

/// The collocation root of [T2] in its original form, by scanning [0, 1] for sign
/// changes of g(α) = f′(α) − (f(1) − f(0)) and bisecting each in high precision, with
/// f(ξ) = B cos ξθ + C sin ξθ. Returns the root nearest ½ (−1 if none).
double reference_alpha(double theta, double B, double C) {
  using std::cos;
  using std::sin;
  const Hi t(theta), b(B), c(C);
  const Hi rhs = b * (cos(t) - 1) + c * sin(t);
  auto g = [&](const Hi& a) { return t * (c * cos(a * t) - b * sin(a * t)) - rhs; };
  double best = -1;
  const int n = 400;
  Hi a0(0), g0 = g(a0);
  for (int k = 1; k <= n; ++k) {
    Hi a1 = Hi(k) / n, g1 = g(a1);
    if ((g0 <= 0 && g1 >= 0) || (g0 >= 0 && g1 <= 0)) {
      Hi lo = a0, hi = a1, glo = g0;
      for (int it = 0; it < 64; ++it) {
        const Hi mid = (lo + hi) / 2;
        const Hi gm = g(mid);
        if ((gm <= 0) == (glo <= 0)) {
          lo = mid;
          glo = gm;
        } else {
          hi = mid;
        }
      }
      const double r = static_cast<double>((lo + hi) / 2);
      if (best < 0 || std::abs(r - 0.5) < std::abs(best - 0.5)) best = r;
    }
    a0 = a1;
    g0 = g1;
  }
  return best;
}
}  // namespace

TEST_CASE("Collocation alpha of [T2]: matches an independent high-precision root nearest 1/2 to 1e-12", "[tangent][collocation]") {
  // collocation_alpha takes the midpoint-form coefficients (B′, C′) of
  // f(ξ) = A + B′ cos((ξ−½)θ) + C′ sin((ξ−½)θ); from [T2]'s f(ξ) = A + B cos ξθ + C sin ξθ:
  // B′ = B cos(θ/2) + C sin(θ/2), C′ = C cos(θ/2) − B sin(θ/2).
  Rng rng(6006);
  const double thetas[] = {1e-3, 0.01, 0.25 * (1 - 1e-3), 0.25 * (1 + 1e-3), 0.5 * (1 - 1e-3), 0.5 * (1 + 1e-3), 1.0, 2.0, 3.0};
  double worst = 0;
  for (double theta : thetas) {
    for (int k = 0; k < 6; ++k) {
      const double B = rng.uniform(-1, 1), C = rng.uniform(-1, 1);
      const double Bp = B * std::cos(theta / 2) + C * std::sin(theta / 2);
      const double Cp = C * std::cos(theta / 2) - B * std::sin(theta / 2);
      const double alpha = detail::collocation_alpha(theta, Bp, Cp);
      const double ref = reference_alpha(theta, B, C);
      // α is determined to ~ε/θ by a condition whose α-slope is O(θ²) against values O(θ).
      const double tol = 1e-12 + 1e-14 / theta;
      worst = std::max(worst, std::abs(alpha - ref));
      INFO("theta " << theta << ", B " << B << ", C " << C << ": alpha " << alpha << ", reference " << ref);
      CHECK(ref >= 0.0);
      CHECK(std::abs(alpha - ref) <= tol);
    }
  }
  SHOW("collocation alpha: worst |alpha - reference| " << worst);
}

TEST_CASE("Collocation alpha of [T2]: degenerate limits (theta = 0, 1e-8 — sleeping top B = C = 0) give alpha -> 1/2 without 0/0",
          "[tangent][collocation]") {
  CHECK(detail::collocation_alpha(0.0, 0.3, -0.2) == 0.5);
  CHECK(detail::collocation_alpha(0.7, 0.0, 0.0) == 0.5);
  CHECK(detail::collocation_alpha(0.0, 0.0, 0.0) == 0.5);
  // Small θ: α − ½ ≈ C′θ/(24B′) (expand the quadratic of collocation_alpha), so |α − ½| = O(θ).
  for (double theta : {1e-8, 1e-6, 1e-4}) {
    const double a = detail::collocation_alpha(theta, 0.5, 0.3);
    INFO("theta " << theta << ": alpha " << a << ", expected " << 0.5 + 0.3 * theta / (24 * 0.5));
    CHECK(std::isfinite(a));
    CHECK(std::abs(a - (0.5 + 0.3 * theta / (24 * 0.5))) <= 1e-3 * theta);
  }
  // B′ = 0 (torque-free direction of the curvature): still finite and in [0, 1].
  const double a = detail::collocation_alpha(1.0, 0.0, 0.4);
  CHECK(std::isfinite(a));
  CHECK(a >= 0.0);
  CHECK(a <= 1.0);
}

TEST_CASE("Collocation alpha of [T2]: where B' changes sign, alpha jumps between the two roots 1/2 +- acos(kappa)/theta, both satisfying [T2]",
          "[tangent][collocation]") {
  // With B′ = 0 the condition C′(cos sθ − κ) = B′ sin sθ has the two roots s = ±acos(κ)/θ,
  // equidistant from ½: "the root nearest ½" ([T2]) must jump there. This is a
  // property of the scheme (no continuous choice stays near ½ for both signs of B′), and it
  // makes the Simo-collocation residual discontinuous across the surface B′(Θ) = 0.
  for (double theta : {1e-6, 0.1, 0.5, 2.0}) {
    const double C = 0.7;
    const double kappa = std::sin(theta / 2) / (theta / 2);
    // 1 − κ without cancellation at small θ (two series terms suffice below 0.01).
    const double omk = theta < 0.01 ? theta * theta / 24 - std::pow(theta, 4) / 1920 : 1 - kappa;
    const double s_root = 2 * std::atan(std::sqrt(omk / (2 - omk))) / theta;  // cos sθ = κ
    const double above = detail::collocation_alpha(theta, 1e-300, C);
    const double below = detail::collocation_alpha(theta, -1e-300, C);
    INFO("theta " << theta << ": alpha(B'=+0) " << above << ", alpha(B'=-0) " << below << ", roots 0.5 +- " << s_root);
    CHECK(std::abs(above - (0.5 + s_root)) <= 1e-12);
    CHECK(std::abs(below - (0.5 - s_root)) <= 1e-12);
    for (double a : {above, below}) {
      const double s = a - 0.5;
      CHECK(std::abs(C * (std::cos(s * theta) - kappa)) <= 1e-15);
    }
  }
}
