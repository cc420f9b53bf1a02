// The simplified Newton of newton.hpp (NewtonOptions::reuse_tangent): the residual-only
// evaluations it relies on are bit-identical to full ones, it reaches the same root as
// plain Newton, it costs what the design says (evaluations per step, asserted as counts),
// and a default run keeps the invariants as plain Newton does. And the small LU the damped
// Newton of the families solves with (small_lu.hpp), against Eigen's full-pivot LU.
#include <catch2/catch.hpp>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <cstring>
#include <type_traits>

#include "support/show.hpp"
#include "support/trompo_test.hpp"
#include "trompo/model/cases.hpp"
#include "trompo/model/effects/external_torque.hpp"
#include "trompo/model/effects/potential.hpp"
#include "trompo/model/effects/rotor.hpp"
#include "trompo/model/effects/viscous_damping.hpp"

using namespace trompo;
using trompo_test::Mat3;
using trompo_test::Rng;
using trompo_test::Vec3;

namespace {

/// V = k (up·ΛE)², with its body-frame gradient 2k (up·ΛE) E × Λᵀup: a potential that is
/// not linear in Λ, so Simo-κ and collocation project it numerically.
struct SquareV {
  double operator()(const Mat3& L) const {
    const double s = Vec3::UnitZ().dot(L * E());
    return 3.0 * s * s;
  }
  static Vec3 E() { return Vec3(0.3, -0.2, 0.9).normalized(); }
};
struct SquareGradient {
  Vec3 operator()(const Mat3& L) const {
    const double s = Vec3::UnitZ().dot(L * SquareV::E());
    return 6.0 * s * SquareV::E().cross(L.transpose() * Vec3::UnitZ());
  }
};

struct Drive {  // a body torque T(t)
  Vec3 operator()(double t) const { return Vec3(0.2 * std::sin(t), -0.1, 0.3 * std::cos(2 * t)); }
};

template <class Scheme>
constexpr bool is_gb = std::is_same_v<Scheme, GeradinBauchau> || std::is_same_v<Scheme, GeradinBauchauPaper>;

/// R and scale from a full evaluation and from a residual-only one, compared bit for bit,
/// at `n` random unknowns around the predictor of random states.
template <class Scheme, class SceneT>
void residual_only_is_bit_identical(const Scheme& scheme, const SceneT& scene, std::uint64_t seed, int n = 200) {
  Rng rng(seed);
  int compared = 0;
  for (int i = 0; i < n; ++i) {
    State<double> s;
    s.rotation = rng.rotation();
    s.omega = rng.vector(0.1, 8.0);
    s.time = rng.uniform(0, 3);
    const double h = rng.uniform(1e-4, 0.05) * (rng.uniform() < 0.2 ? -1 : 1);
    const detail::StepData<SceneT> d(scene, s, h);
    const Vec3 base = is_gb<Scheme> ? Vec3(h / 2 * s.omega) : Vec3(h * s.omega);
    const Vec3 x = (is_gb<Scheme> ? Vec3(d.predicted_increment() / 2) : d.predicted_increment()) - base +
                   rng.vector(0, 1e-3 * (1 + (h * s.omega).norm()));
    Vec3 R_full, R_only;
    Mat3 K;
    double scale_full = -1, scale_only = -2;
    bool in_full, in_only;
    in_full = scheme.residual(d)(x, R_full, &K, scale_full);
    in_only = scheme.residual(d)(x, R_only, nullptr, scale_only);
    REQUIRE(in_full == in_only);
    if (!in_full) continue;
    ++compared;
    CAPTURE(i, h);
    CHECK(std::memcmp(R_full.data(), R_only.data(), sizeof(double) * 3) == 0);
    CHECK(std::memcmp(&scale_full, &scale_only, sizeof(double)) == 0);
  }
  CHECK(compared > n / 2);
}

/// Evaluation counts of one solve: full (residual and tangent) and residual-only.
struct Counts {
  long full = 0, residual_only = 0, steps = 0;
};

/// Steps `c` n times with h, solving each step's equation through a counting wrapper of
/// SimoResidual (the stepper itself is used to advance, so the trajectory is the library's).
template <class Scheme, class SceneT>
Counts count_evaluations(const Scheme& scheme, const cases::Case<SceneT>& c, double h, int n, NewtonOptions<double> opt) {
  const Stepper<Scheme, SceneT> stepper(scheme, c.scene, opt);
  State<double> s = c.initial;
  Counts k;
  for (int i = 0; i < n; ++i) {
    const detail::StepData<SceneT> d(c.scene, s, h);
    const auto residual = scheme.residual(d);
    auto counted = [&](const Vec3& x, Vec3& R, Mat3* K, double& scale) {
      ++(K ? k.full : k.residual_only);
      return residual(x, R, K, scale);
    };
    const Vec3 Theta0 = d.predicted_increment();
    Vec3 y = Theta0 - h * s.omega;
    REQUIRE(detail::newton(counted, y, opt, NewtonSolve<double>{.x_scale = Theta0.norm()}).ok());
    REQUIRE(stepper.step(s, h).ok());
    ++k.steps;
  }
  return k;
}

}  // namespace

TEST_CASE("residual-only evaluations are bit-identical to full ones (R and scale), every scheme and kind of scene",
          "[newton]") {
  const RigidBody<double> body(Vec3(2.0, 3.0, 4.0));
  const FreeScene<double> free(body);
  const HeavyTop<double> top(body, UniformGravity<double>(9.0, Vec3(0.2, 0.1, 1.0)));
  const Scene<double, UniformGravity<double>, ViscousDamping<double>, BodyTorque<double, Drive>, Rotor<double>> loaded(
      body, UniformGravity<double>(9.0, Vec3(0.2, 0.1, 1.0)), ViscousDamping<double>(0.4),
      BodyTorque<double, Drive>(Drive{}), Rotor<double>(Vec3(0.0, 0.5, 1.0)));
  const Scene<double, Potential<double, SquareV, SquareGradient>> general(
      body, Potential<double, SquareV, SquareGradient>(SquareV{}, SquareGradient{}));
  residual_only_is_bit_identical(SimoAlpha{}, free, 1);
  residual_only_is_bit_identical(SimoAlpha(0.3), top, 2);
  residual_only_is_bit_identical(SimoKappa{}, top, 3);
  residual_only_is_bit_identical(SimoCollocation{}, top, 4);
  residual_only_is_bit_identical(GeradinBauchau{}, top, 5);
  residual_only_is_bit_identical(GeradinBauchauPaper{}, top, 6);
  residual_only_is_bit_identical(SimoKappa{}, loaded, 7);
  residual_only_is_bit_identical(SimoCollocation{}, loaded, 8);
  residual_only_is_bit_identical(GeradinBauchau{}, loaded, 9);
  residual_only_is_bit_identical(SimoAlpha{}, general, 10);
  residual_only_is_bit_identical(SimoKappa{}, general, 11);
  residual_only_is_bit_identical(SimoCollocation{}, general, 12);
  residual_only_is_bit_identical(GeradinBauchau{}, general, 13);
}

TEST_CASE("simplified and plain Newton reach the same root (random tops, h from 1e-3 to 2e-2)", "[newton]") {
  Rng rng(2026);
  NewtonOptions<double> plain;
  plain.reuse_tangent = 0;
  double worst_omega = 0, worst_rot = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const HeavyTop<double> scene(RigidBody<double>(trompo_test::random_inertia(rng, 1.0, 2.0)),
                                 UniformGravity<double>(rng.uniform(0, 20), rng.unit(), Vec3::UnitZ()));
    State<double> s;
    s.rotation = rng.rotation();
    s.omega = rng.vector(0.5, 20.0);
    const double h = std::exp(rng.uniform(std::log(1e-3), std::log(2e-2)));
    const auto compare = [&](auto scheme) {
      using Scheme = decltype(scheme);
      State<double> a = s, b = s;
      const auto ra = Stepper<Scheme, HeavyTop<double>>(scheme, scene).step(a, h);
      const auto rb = Stepper<Scheme, HeavyTop<double>>(scheme, scene, plain).step(b, h);
      CAPTURE(trial, h, Scheme::name, ra.reason(), rb.reason());
      REQUIRE(ra.ok());
      REQUIRE(rb.ok());
      worst_omega = std::max(worst_omega, (a.omega - b.omega).norm() / s.omega.norm());
      worst_rot = std::max(worst_rot, (a.rotation.matrix() - b.rotation.matrix()).norm());
    };
    compare(SimoKappa{});
    compare(SimoAlpha{});
    compare(SimoCollocation{});
    compare(GeradinBauchau{});
  }
  SHOW("worst difference simplified vs plain Newton: |dOmega|/|Omega| " << worst_omega << ", |dLambda| " << worst_rot);
  // Both stop at round-off of the same root; the unknown is resolved to ~ε·|Θ|, and
  // Ω = Ω_n + 2y/h carries that as ~ε·|Ω|·(a few): measured 1.8e-16 and 5.4e-16.
  CHECK(worst_omega < 4e-15);
  CHECK(worst_rot < 4e-15);
}

TEST_CASE("simplified Newton: evaluations per step as designed (HT1, Simo-kappa)", "[newton]") {
  const auto ht1 = cases::ht1<double>();
  SECTION("h = 1e-3: one tangent and one residual-only evaluation per step") {
    const Counts k = count_evaluations(SimoKappa{}, ht1, 1e-3, 2000, NewtonOptions<double>{});
    CHECK(k.full == k.steps);
    CHECK(k.residual_only == k.steps);
  }
  SECTION("h = 1e-2 (|Θ| = 0.5): one tangent, at most three residual-only evaluations per step") {
    const Counts k = count_evaluations(SimoKappa{}, ht1, 1e-2, 1000, NewtonOptions<double>{});
    CHECK(k.full == k.steps);
    CHECK(k.residual_only <= 3 * k.steps);  // measured 2.63
  }
  SECTION("plain Newton (reuse_tangent = 0): three full evaluations per step at h = 1e-3") {
    NewtonOptions<double> plain;
    plain.reuse_tangent = 0;
    const Counts k = count_evaluations(SimoKappa{}, ht1, 1e-3, 2000, plain);
    CHECK(k.full == 3 * k.steps);
    CHECK(k.residual_only == 0);
  }
}

TEST_CASE("simplified Newton keeps H and mu on an anisotropic top where a careless acceptance drifts (2e4 steps)",
          "[newton][invariants]") {
  // The top on which a careless acceptance drifted H (trompo_test::anisotropic_top).
  const auto top = trompo_test::anisotropic_top();
  const int n = 20000;
  const auto check_run = [&](auto scheme) {
    using Scheme = decltype(scheme);
    const Stepper<Scheme, HeavyTop<double>> stepper(scheme, top.scene);
    const auto st = trompo_test::run(stepper, top.initial, 0.01, n);
    INFO(Scheme::name << ": max dH/H " << st.max_dH << ", max dmu/mu " << st.max_dmu);
    REQUIRE(st.failures == 0);
    // 3·√N·ε: a random walk of round-off, not N·ε.
    CHECK(st.max_dH < 3 * std::sqrt(double(n)) * 2.2e-16);
    CHECK(st.max_dmu < 3 * std::sqrt(double(n)) * 2.2e-16);
  };
  check_run(SimoKappa{});
  check_run(GeradinBauchau{});
}

TEST_CASE("the damped Newton's small LU: solutions and reciprocal condition numbers against Eigen's full-pivot LU",
          "[newton][lu]") {
  using Mat4 = Eigen::Matrix4d;
  using Vec4 = Eigen::Vector4d;
  Rng rng(42);
  double worst_solution = 0, worst_rcond = 0;
  for (int i = 0; i < 200; ++i) {
    // Random matrices, a third of them with a row scaled by 1e-8 (badly scaled, still regular).
    Mat4 A;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) A(r, c) = rng.uniform(-1, 1);
    if (i % 3 == 0) A.row(i % 4) *= 1e-8;
    Vec4 b;
    for (int r = 0; r < 4; ++r) b(r) = rng.uniform(-1, 1);
    const Eigen::FullPivLU<Mat4> full(A);
    const Vec4 x_ref = full.solve(b);
    const Mat4 inverse = full.inverse();
    const auto norm1 = [](const Mat4& M) { return M.cwiseAbs().colwise().sum().maxCoeff(); };
    const double rcond_ref = 1 / (norm1(A) * norm1(inverse));
    const detail::SmallLU<4, double> lu(A);
    const Vec4 x = lu.solve(b);
    // Backward-stable solves of one system agree to about cond(A)·ε.
    worst_solution = std::max(worst_solution, (x - x_ref).norm() / x_ref.norm() * rcond_ref);
    worst_rcond = std::max(worst_rcond, std::abs(lu.rcond() - rcond_ref) / rcond_ref);
  }
  INFO("largest |x - x_ref|/|x_ref| * rcond " << worst_solution << ", largest relative error of rcond "
                                               << worst_rcond);
  CHECK(worst_solution <= 64 * std::numeric_limits<double>::epsilon());
  CHECK(worst_rcond <= 1e-8);
  // Singular (two equal rows) and zero matrices: rcond 0, so damped_newton reports
  // singular_tangent instead of solving.
  Mat4 S = Mat4::Identity();
  S.row(2) = S.row(1);
  CHECK(detail::SmallLU<4, double>(S).rcond() == 0.0);
  CHECK(detail::SmallLU<4, double>(Mat4::Zero()).rcond() == 0.0);
  // A 3×3 in float: the permuted identity is solved exactly.
  Eigen::Matrix3f P;
  P << 0, 1, 0, 0, 0, 1, 1, 0, 0;
  const Eigen::Vector3f y = detail::SmallLU<3, float>(P).solve(Eigen::Vector3f(1, 2, 3));
  CHECK(y == Eigen::Vector3f(3, 1, 2));
  CHECK(detail::SmallLU<3, float>(P).rcond() == 1.0f);
}
