// Scenes and effects (docs/theory.md §1, §3, §5): one test per row of the invariants table in
// docs/scenes.md, run for every scheme; the effects' Jacobians and every
// scheme's tangent against central differences.
//
// Each row prints its measured figure per scheme as
//   [effects-table] <row> | <scheme> | <quantity> = <value>
// (run `test_effects -s` or just the binary: the lines go to stdout).
#include <Eigen/Core>
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "support/show.hpp"
#include "support/trompo_test.hpp"
#include "trompo/trompo.hpp"

namespace {

using namespace trompo;
using trompo_test::central_jacobian;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
constexpr double eps = std::numeric_limits<double>::epsilon();

// ---- which scheme keeps what: read from the schemes' traits (scheme.hpp) ----------------
template <class S, class Scene>
constexpr Keeps kept = scheme_keeps_v<S, Scene>;
/// H exact on the free body (every energy-momentum scheme; not RK4).
template <class S>
constexpr bool is_implicit = kept<S, FreeScene<double>>.energy;
/// H exact for potentials linear in Λ (uniform gravity), docs/theory.md §3–4.
template <class S>
constexpr bool energy_exact_linear = kept<S, HeavyTop<double>>.energy;
/// π (free body) and μ (gravity) exact: the Simo family and GB [T4], not [T5] (docs/theory.md §4).
template <class S>
constexpr bool momentum_exact = kept<S, HeavyTop<double>>.momentum_map && kept<S, FreeScene<double>>.spatial_momentum;

/// A row's figure for a scheme whose traits admit none of its checks (RK4 keeps nothing):
/// the row asserts the other way, that the figure lies well above the bound an exact scheme
/// is held to, so that the row can tell a scheme that does not keep its property (it used to
/// be reported as skipped, asserting only that the steps succeed).
void not_kept(const char* scheme, const char* what, double figure, double bound) {
  INFO(scheme << " keeps nothing by its traits: " << what << " = " << figure << " must exceed 10 x " << bound);
  CHECK(figure > 10 * bound);
}

void report(const char* row, const char* scheme, const char* quantity, double value) {
  std::printf("[effects-table] %s | %s | %s = %.2e\n", row, scheme, quantity, value);
}

// ---- the scenes ------------------------------------------------------------------------------
RigidBody<double> free_body() { return RigidBody<double>(Vec3(1, 2, 3)); }
RigidBody<double> top_body() { return RigidBody<double>(Vec3(4, 5, 2)); }
UniformGravity<double> gravity() { return UniformGravity<double>(15.0, Vec3(0.2, 0.1, 1.0), Vec3::UnitZ()); }

State<double> free_state() {
  State<double> s;
  s.omega = Vec3(0.4, 1.5, -0.7);
  return s;
}
State<double> top_state() {
  State<double> s;
  s.rotation = SO3d::exp(Vec3(0.4, -0.2, 0.1));
  s.omega = Vec3(0.5, -1.0, 6.0);
  s.time = 0.3;
  return s;
}

/// T(t): a body-fixed torque (a thruster programme).
struct ThrusterProgramme {
  Vec3 operator()(double t) const { return Vec3(0.3 * std::sin(2 * t), -0.4 * std::cos(t), 0.2 + 0.1 * std::sin(3 * t)); }
};
/// S(t): a space-fixed torque.
struct SpaceProgramme {
  Vec3 operator()(double t) const { return Vec3(0.2 * std::cos(t), 0.3, -0.25 * std::sin(2 * t)); }
};
using Thruster = BodyTorque<double, ThrusterProgramme>;
using SpaceLoad = SpaceTorque<double, SpaceProgramme>;

/// The test potential: V = k (γ·ΛE)² + c (B·Λa)³, not linear in Λ. With s₁ = γ·ΛE,
/// u₁ = E × Λᵀγ, s₂ = B·Λa, u₂ = a × ΛᵀB (ds = u·w for Λ exp(ŵ)):
///   g = 2k s₁ u₁ + 3c s₂² u₂,
///   H = ∂g/∂w = 2k (u₁u₁ᵀ + s₁ Ê (Λᵀγ)^) + 3c (2 s₂ u₂u₂ᵀ + s₂² â (ΛᵀB)^).
template <class S>
struct TestField {
  using V3 = Eigen::Matrix<S, 3, 1>;
  using M3 = Eigen::Matrix<S, 3, 3>;
  S k = S(8), c = S(3);
  V3 up = V3::UnitZ(), E = V3(0, S(0.6), S(0.8)), B = V3(1, 0, S(0.5)), a = V3::UnitX();
};
template <class S>
struct TestV {
  TestField<S> p;
  S operator()(const typename TestField<S>::M3& L) const {
    const S s1 = p.up.dot(L * p.E), s2 = p.B.dot(L * p.a);
    return p.k * s1 * s1 + p.c * s2 * s2 * s2;
  }
};
template <class S>
struct TestGradient {
  TestField<S> p;
  typename TestField<S>::V3 operator()(const typename TestField<S>::M3& L) const {
    const S s1 = p.up.dot(L * p.E), s2 = p.B.dot(L * p.a);
    return S(2) * p.k * s1 * p.E.cross(L.transpose() * p.up) + S(3) * p.c * s2 * s2 * p.a.cross(L.transpose() * p.B);
  }
};
template <class S>
struct TestHessian {
  TestField<S> p;
  typename TestField<S>::M3 operator()(const typename TestField<S>::M3& L) const {
    using G = SO3<S>;
    const typename TestField<S>::V3 c1 = L.transpose() * p.up, c2 = L.transpose() * p.B;
    const typename TestField<S>::V3 u1 = p.E.cross(c1), u2 = p.a.cross(c2);
    const S s1 = p.up.dot(L * p.E), s2 = p.B.dot(L * p.a);
    return S(2) * p.k * (u1 * u1.transpose() + s1 * G::hat(p.E) * G::hat(c1)) +
           S(3) * p.c * (S(2) * s2 * u2 * u2.transpose() + s2 * s2 * G::hat(p.a) * G::hat(c2));
  }
};
template <class S>
using TestPotential = Potential<S, TestV<S>, TestGradient<S>>;
template <class S>
using TestPotentialH = Potential<S, TestV<S>, TestGradient<S>, TestHessian<S>>;
TestPotential<double> test_potential() { return {TestV<double>{}, TestGradient<double>{}}; }
TestPotentialH<double> test_potential_h() { return {TestV<double>{}, TestGradient<double>{}, TestHessian<double>{}}; }
/// H exact for a general potential: the two projections of docs/theory.md §3.
template <class S>
constexpr bool energy_exact_general = kept<S, Scene<double, TestPotential<double>>>.energy;

// ---- runs --------------------------------------------------------------------------------------
/// n steps of h; `each(before, after)` after every step. Fails the test on a failed step.
template <class Scheme, class SceneT, class F>
void run(const SceneT& scene, State<double> s, double h, int n, F&& each) {
  const Stepper<Scheme, SceneT> stepper(Scheme{}, scene);
  for (int k = 0; k < n; ++k) {
    const State<double> before = s;
    const StepReport<double> rep = stepper.step(s, h);
    INFO(Scheme::name << " step " << k << ": " << rep.reason());
    REQUIRE(rep.ok());
    each(before, s);
  }
}

/// Ω_m = (Ω_n + Ω_{n+1})/2: Θ/h in the Simo family, 2e/h in GB (docs/theory.md §3–5).
Vec3 mid_omega(const State<double>& a, const State<double>& b) { return (a.omega + b.omega) / 2; }

/// Power identity on one scene: max_n |ΔH − h Ω_m·T_m| / max H-scale, and whether
/// H decreased at every step. `power(before, after)` returns h Ω_m·T_m.
struct PowerStats {
  double max_error = 0;  ///< relative to the energy scale max(K + |V|)
  bool monotone_decay = true;
};
template <class Scheme, class SceneT, class P>
PowerStats power_identity(const SceneT& scene, const State<double>& s0, double h, int n, P&& power) {
  PowerStats st;
  double scale = 0, err = 0;
  run<Scheme>(scene, s0, h, n, [&](const State<double>& a, const State<double>& b) {
    const double Ha = scene.energy(a), Hb = scene.energy(b);
    scale = std::max(scale, scene.kinetic_energy(a.omega) + std::abs(scene.potential_energy(a.rotation)));
    err = std::max(err, std::abs((Hb - Ha) - power(a, b)));
    if (!(Hb < Ha)) st.monotone_decay = false;
  });
  st.max_error = err / scale;
  return st;
}

/// Invariant drift over a run: max |H − H0|/|H0|, |μ − μ0|/|μ0|, |π − π0|/|π0|.
struct Drift {
  double H = 0, mu = 0, pi = 0;
};
template <class Scheme, class SceneT>
Drift drift(const SceneT& scene, const State<double>& s0, double h, int n) {
  Drift d;
  const double H0 = scene.energy(s0), mu0 = scene.momentum_map(s0);
  const Vec3 pi0 = scene.spatial_momentum(s0);
  run<Scheme>(scene, s0, h, n, [&](const State<double>&, const State<double>& b) {
    d.H = std::max(d.H, std::abs(scene.energy(b) - H0) / std::abs(H0));
    d.mu = std::max(d.mu, std::abs(scene.momentum_map(b) - mu0) / std::abs(mu0));
    d.pi = std::max(d.pi, (scene.spatial_momentum(b) - pi0).norm() / pi0.norm());
  });
  return d;
}

// Tolerances. A per-step identity compares H values each rounded to ~ε·scale; an
// invariant over a run is a random walk of such errors (√N·ε).
constexpr double step_tol = 64 * eps;   // per-step identity, relative to the energy scale
constexpr double run_tol = 2e-13;       // invariant over ≤ 1000 steps

constexpr double h = 0.01;
constexpr int n_steps = 1000;

}  // namespace

#define TROMPO_ALL_SCHEMES SimoAlpha, SimoCollocation, SimoKappa, GeradinBauchau, GeradinBauchauPaper, RK4

// ==== rows of the table ===================================================================

TEMPLATE_TEST_CASE("row free body: H and pi exact", "[effects][table]", TROMPO_ALL_SCHEMES) {
  const FreeScene<double> scene(free_body());
  const Drift d = drift<TestType>(scene, free_state(), h, n_steps);
  report("free body", TestType::name, "max dH/H", d.H);
  report("free body", TestType::name, "max dpi/pi", d.pi);
  if constexpr (is_implicit<TestType>) CHECK(d.H < run_tol);
  if constexpr (momentum_exact<TestType>) CHECK(d.pi < run_tol);
  if constexpr (!is_implicit<TestType> && !momentum_exact<TestType>) {
    not_kept(TestType::name, "free body, max dH/H", d.H, run_tol);
    not_kept(TestType::name, "free body, max dpi/pi", d.pi, run_tol);
  }
}

TEMPLATE_TEST_CASE("row uniform gravity: H and mu", "[effects][table]", TROMPO_ALL_SCHEMES) {
  const HeavyTop<double> scene(top_body(), gravity());
  const Drift d = drift<TestType>(scene, top_state(), h, n_steps);
  report("gravity", TestType::name, "max dH/H", d.H);
  report("gravity", TestType::name, "max dmu/mu", d.mu);
  if constexpr (energy_exact_linear<TestType>) CHECK(d.H < run_tol);
  if constexpr (momentum_exact<TestType>) CHECK(d.mu < run_tol);
  if constexpr (!energy_exact_linear<TestType> && !momentum_exact<TestType>) {
    not_kept(TestType::name, "gravity, max dH/H", d.H, run_tol);
    not_kept(TestType::name, "gravity, max dmu/mu", d.mu, run_tol);
  }
}

TEMPLATE_TEST_CASE("row viscous damping: H_{n+1} - H_n = -c h |Omega_m|^2, monotone decay", "[effects][table][damping]",
                   TROMPO_ALL_SCHEMES) {
  const double c = 0.3;
  const auto power = [&](const State<double>& a, const State<double>& b) {
    return -c * h * mid_omega(a, b).squaredNorm();
  };
  SECTION("free body") {
    const Scene<double, ViscousDamping<double>> scene(free_body(), ViscousDamping<double>(c));
    const PowerStats st = power_identity<TestType>(scene, free_state(), h, n_steps, power);
    report("damping, free", TestType::name, "max |dH + c h |Om|^2| / E", st.max_error);
    if constexpr (is_implicit<TestType>) {
      CHECK(st.max_error < step_tol);
      CHECK(st.monotone_decay);
    } else {
      not_kept(TestType::name, "damping, free: power identity", st.max_error, step_tol);
    }
  }
  SECTION("heavy top") {
    const Scene<double, UniformGravity<double>, ViscousDamping<double>> scene(top_body(), gravity(),
                                                                              ViscousDamping<double>(c));
    const PowerStats st = power_identity<TestType>(scene, top_state(), h, n_steps, power);
    report("damping, gravity", TestType::name, "max |dH + c h |Om|^2| / E", st.max_error);
    report("damping, gravity", TestType::name, "monotone", st.monotone_decay ? 1.0 : 0.0);
    if constexpr (energy_exact_linear<TestType>) {
      CHECK(st.max_error < step_tol);
      CHECK(st.monotone_decay);
    } else if constexpr (!is_implicit<TestType>) {
      not_kept(TestType::name, "damping, gravity: power identity", st.max_error, step_tol);
    }
  }
}

TEMPLATE_TEST_CASE("row body torque T(t): H_{n+1} - H_n = h Omega_m . T(t_{n+1/2})", "[effects][table][torque]",
                   TROMPO_ALL_SCHEMES) {
  const ThrusterProgramme T;
  const auto power = [&](const State<double>& a, const State<double>& b) {
    return h * mid_omega(a, b).dot(T(a.time + h / 2));
  };
  SECTION("free body") {
    const Scene<double, Thruster> scene(free_body(), Thruster(T));
    const PowerStats st = power_identity<TestType>(scene, free_state(), h, n_steps, power);
    report("body torque, free", TestType::name, "max |dH - h Om.T| / E", st.max_error);
    if constexpr (is_implicit<TestType>) CHECK(st.max_error < step_tol);
    else not_kept(TestType::name, "body torque, free: power identity", st.max_error, step_tol);
  }
  SECTION("heavy top") {
    const Scene<double, UniformGravity<double>, Thruster> scene(top_body(), gravity(), Thruster(T));
    const PowerStats st = power_identity<TestType>(scene, top_state(), h, n_steps, power);
    report("body torque, gravity", TestType::name, "max |dH - h Om.T| / E", st.max_error);
    if constexpr (energy_exact_linear<TestType>) CHECK(st.max_error < step_tol);
    else if constexpr (!is_implicit<TestType>) not_kept(TestType::name, "body torque, gravity: power identity", st.max_error, step_tol);
  }
}

TEMPLATE_TEST_CASE("row space torque S(t): power identity and pi_{n+1} - pi_n = h S(t_{n+1/2})",
                   "[effects][table][torque]", TROMPO_ALL_SCHEMES) {
  const SpaceProgramme S;
  // h Ω_m·T_m with T_m = Λ_{n+½}ᵀS: Λ_{n+½}Ω_m = Λ_nΩ_m (Ω_m is the increment's axis).
  const auto power = [&](const State<double>& a, const State<double>& b) {
    return h * (a.rotation * mid_omega(a, b)).dot(S(a.time + h / 2));
  };
  SECTION("free body") {
    const Scene<double, SpaceLoad> scene(free_body(), SpaceLoad(S));
    const PowerStats st = power_identity<TestType>(scene, free_state(), h, n_steps, power);
    double pi_err = 0, pi_scale = 0;
    run<TestType>(scene, free_state(), h, n_steps, [&](const State<double>& a, const State<double>& b) {
      const Vec3 dpi = scene.spatial_momentum(b) - scene.spatial_momentum(a);
      pi_err = std::max(pi_err, (dpi - h * S(a.time + h / 2)).norm());
      pi_scale = std::max(pi_scale, scene.spatial_momentum(a).norm());
    });
    report("space torque, free", TestType::name, "max |dH - h om.S| / E", st.max_error);
    report("space torque, free", TestType::name, "max |dpi - h S| / |pi|", pi_err / pi_scale);
    if constexpr (is_implicit<TestType>) CHECK(st.max_error < step_tol);
    if constexpr (momentum_exact<TestType>) CHECK(pi_err / pi_scale < step_tol);
    if constexpr (!is_implicit<TestType> && !momentum_exact<TestType>) {
      not_kept(TestType::name, "space torque, free: power identity", st.max_error, step_tol);
      not_kept(TestType::name, "space torque, free: dpi - h S", pi_err / pi_scale, step_tol);
    }
  }
  SECTION("heavy top") {
    const Scene<double, UniformGravity<double>, SpaceLoad> scene(top_body(), gravity(), SpaceLoad(S));
    const PowerStats st = power_identity<TestType>(scene, top_state(), h, n_steps, power);
    report("space torque, gravity", TestType::name, "max |dH - h om.S| / E", st.max_error);
    if constexpr (energy_exact_linear<TestType>) CHECK(st.max_error < step_tol);
    else if constexpr (!is_implicit<TestType>) not_kept(TestType::name, "space torque, gravity: power identity", st.max_error, step_tol);
  }
}

TEMPLATE_TEST_CASE("row gyrostat rotor: H and pi = Lambda (J Omega + h_r) exact — with gravity H and mu",
                   "[effects][table][rotor]", TROMPO_ALL_SCHEMES) {
  const Rotor<double> rotor(Vec3(0.5, 2.0, -1.0));
  SECTION("free body with rotor") {
    const Scene<double, Rotor<double>> scene(free_body(), rotor);
    const Drift d = drift<TestType>(scene, free_state(), h, n_steps);
    report("rotor, free", TestType::name, "max dH/H", d.H);
    report("rotor, free", TestType::name, "max dpi/pi", d.pi);
    if constexpr (is_implicit<TestType>) CHECK(d.H < run_tol);
    if constexpr (momentum_exact<TestType>) CHECK(d.pi < run_tol);
  }
  SECTION("heavy top with rotor") {
    const Scene<double, UniformGravity<double>, Rotor<double>> scene(top_body(), gravity(), rotor);
    const Drift d = drift<TestType>(scene, top_state(), h, n_steps);
    report("rotor, gravity", TestType::name, "max dH/H", d.H);
    report("rotor, gravity", TestType::name, "max dmu/mu", d.mu);
    if constexpr (energy_exact_linear<TestType>) CHECK(d.H < run_tol);
    if constexpr (momentum_exact<TestType>) CHECK(d.mu < run_tol);
  }
  SECTION("the rotor enters the momentum, not the energy") {
    const Scene<double, Rotor<double>> scene(free_body(), rotor);
    const State<double> s = free_state();
    CHECK((scene.momentum(s.omega) - (free_body().momentum(s.omega) + rotor.rotor_momentum())).norm() == 0.0);
    CHECK(scene.energy(s) == free_body().kinetic_energy(s.omega));
  }
}

TEMPLATE_TEST_CASE("row general potential V(Lambda): H exact for Simo-kappa and collocation, measured otherwise",
                   "[effects][table][potential]", TROMPO_ALL_SCHEMES) {
  State<double> s0 = top_state();
  s0.omega = Vec3(1.0, -0.5, 2.0);
  SECTION("V = k (up.Lambda E)^2 + c (B.Lambda a)^3") {
    const Scene<double, TestPotential<double>> scene(top_body(), test_potential());
    const Drift d = drift<TestType>(scene, s0, h, n_steps);
    report("general potential", TestType::name, "max dH/H", d.H);
    if constexpr (energy_exact_general<TestType>) {
      CHECK(d.H < run_tol);
    } else {
      // Not exact, and visibly so: the figure in the table is this measurement.
      CHECK(d.H > 1e-10);
      CHECK(d.H < 1e-2);
    }
  }
  SECTION("the same potential with gravity and the user's Hessian") {
    const Scene<double, UniformGravity<double>, TestPotentialH<double>> scene(top_body(), gravity(), test_potential_h());
    const Drift d = drift<TestType>(scene, s0, h, n_steps);
    report("general potential + gravity", TestType::name, "max dH/H", d.H);
    if constexpr (energy_exact_general<TestType>) CHECK(d.H < run_tol);
  }
  SECTION("a long run with integrate(): exact H; singular steps recovered by sub-steps") {
    // Simo-κ's projection has a pole where a step's midpoint sits at an extremum of V
    // along the path; on this trajectory Newton fails there at a few steps, which
    // integrate() retries as half steps (each exact). Collocation follows one root α
    // through the Newton iterations and needs no recovery here.
    if constexpr (energy_exact_general<TestType>) {
      const Scene<double, TestPotential<double>> scene(top_body(), test_potential());
      const Stepper<TestType, Scene<double, TestPotential<double>>> stepper(TestType{}, scene);
      State<double> s = s0;
      const double H0 = scene.energy(s);
      double max_dH = 0;
      const auto sum = integrate(stepper, s, s0.time + 200.0, h, [&](const State<double>& x) {
        max_dH = std::max(max_dH, std::abs(scene.energy(x) - H0) / std::abs(H0));
      });
      REQUIRE(sum.ok());
      report("general potential, 2e4 steps", TestType::name, "max dH/H", max_dH);
      report("general potential, 2e4 steps", TestType::name, "recovered steps", static_cast<double>(sum.recovered));
      CHECK(max_dH < 1e-12);
    }
  }
  SECTION("from rest, and at rest in an equilibrium (tiny increments)") {
    const Scene<double, TestPotential<double>> scene(top_body(), test_potential());
    State<double> rest = s0;
    rest.omega.setZero();
    const Drift d = drift<TestType>(scene, rest, h, 300);
    report("general potential, from rest", TestType::name, "max dH/H", d.H);
    if constexpr (energy_exact_general<TestType>) CHECK(d.H < run_tol);
    // An equilibrium: up·ΛE = 0 and B·Λa = 0 make g = 0. Λ = R_z(π/2) R_x(φ) with
    // tan φ = −4/3 (so .6 sin φ + .8 cos φ = 0) and Λa = e2 ⟂ B. Θ stays at round-off.
    State<double> eq;
    eq.rotation = SO3d::exp(Vec3(0, 0, std::acos(-1.0) / 2)) * SO3d::exp(Vec3(std::atan2(-4.0, 3.0), 0, 0));
    CHECK(std::abs(scene.energy(eq)) < 1e-15);
    const State<double> eq0 = eq;
    run<TestType>(scene, eq, h, 100, [&](const State<double>&, const State<double>& b) {
      CHECK(std::abs(scene.energy(b)) < 1e-15);
      eq = b;
    });
    CHECK((eq.rotation.matrix() - eq0.rotation.matrix()).norm() < 1e-12);
  }
}

// ==== time sampling, composition, zero effects ===============================================

TEST_CASE("external torques are sampled at t_{n+1/2} by the implicit schemes", "[effects][torque]") {
  std::vector<double> times;
  times.reserve(64);
  const auto f = [&times](double t) {
    times.push_back(t);
    return Vec3(0.1, 0.0, 0.0);
  };
  using SceneT = Scene<double, BodyTorque<double, std::decay_t<decltype(f)>>>;
  const SceneT scene(free_body(), body_torque<double>(f));
  State<double> s = free_state();
  s.time = 1.0;
  const Stepper<SimoKappa, SceneT> stepper(SimoKappa{}, scene);
  REQUIRE(stepper.step(s, 0.1).ok());
  REQUIRE(!times.empty());
  for (double t : times) CHECK(t == Approx(1.05).epsilon(1e-15));
  CHECK(s.time == Approx(1.1));
}

TEST_CASE("constant torques and the damping coefficient as the CLI builds them", "[effects][torque]") {
  const ConstantBodyTorque<double> T(Vec3(1, 2, 3));
  const ConstantSpaceTorque<double> S(Vec3(-1, 0, 2));
  const ViscousDamping<double> D(0.5);
  const Rotor<double> W(Vec3(0, 4, 0));
  const Scene<double, ViscousDamping<double>, ConstantBodyTorque<double>, ConstantSpaceTorque<double>, Rotor<double>>
      scene(free_body(), D, T, S, W);
  // The total body torque at (Λ, Ω): −cΩ + T + ΛᵀS.
  const Mat3 L = SO3d::exp(Vec3(0.3, 0.1, -0.2)).matrix();
  const Vec3 w(0.1, -0.2, 0.3);
  CHECK((scene.body_torque(L, w, 0.0) - (-0.5 * w + Vec3(1, 2, 3) + L.transpose() * Vec3(-1, 0, 2))).norm() < 1e-15);
  CHECK(T.function()(7.0) == Vec3(1, 2, 3));
  CHECK(D.coefficient() == 0.5);
  CHECK_THROWS_AS(ViscousDamping<double>(std::nan("")), invalid_input);
  CHECK_THROWS_AS(Rotor<double>(Vec3(0, std::numeric_limits<double>::infinity(), 0)), invalid_input);
  CHECK_THROWS_AS(ConstantBodyTorque<double>(Vec3(0, std::nan(""), 0)), invalid_input);
  // A power identity with all four together (Simo-κ): ΔH = h Ω_m·(−cΩ_m + T + Λ_nᵀS).
  const double hh = 0.02;
  double err = 0;
  run<SimoKappa>(scene, free_state(), hh, 200, [&](const State<double>& a, const State<double>& b) {
    const Vec3 wm = mid_omega(a, b);
    const double P = hh * (wm.dot(-0.5 * wm + Vec3(1, 2, 3)) + (a.rotation * wm).dot(Vec3(-1, 0, 2)));
    err = std::max(err, std::abs(scene.energy(b) - scene.energy(a) - P) / scene.energy(a));
  });
  CHECK(err < step_tol);
}

TEST_CASE("effects listed with zero weight give the free body's step exactly", "[effects][zero]") {
  static_assert(FreeScene<double>::is_free);
  static_assert(!FreeScene<double>::has_potential && !FreeScene<double>::has_applied_torque &&
                !FreeScene<double>::has_rotor);
  const FreeScene<double> free_scene(free_body());
  const Scene<double, ViscousDamping<double>, ConstantBodyTorque<double>, Rotor<double>> zero_scene(
      free_body(), ViscousDamping<double>(0.0), ConstantBodyTorque<double>(Vec3::Zero()), Rotor<double>(Vec3::Zero()));
  State<double> a = free_state(), b = free_state();
  const Stepper<SimoKappa, FreeScene<double>> sa(SimoKappa{}, free_scene);
  const Stepper<SimoKappa, decltype(zero_scene)> sb(SimoKappa{}, zero_scene);
  for (int k = 0; k < 100; ++k) {
    REQUIRE(sa.step(a, h).ok());
    REQUIRE(sb.step(b, h).ok());
  }
  CHECK((a.omega - b.omega).norm() == 0.0);
  CHECK((a.rotation.matrix() - b.rotation.matrix()).norm() == 0.0);
}

// ==== Jacobians against central differences ==================================================

TEST_CASE("effect Jacobians against central differences", "[effects][tangent]") {
  trompo_test::Rng rng(20240611);
  const Mat3 Ln = rng.rotation().matrix();
  const Mat3 R = rng.rotation().matrix();
  const Vec3 wm = rng.vector(0.5, 2.0);
  const double d = 1e-5;
  const auto perturbed = [&](const Vec3& w) { return Mat3(R * SO3d::exp_matrix(w)); };

  SECTION("viscous damping: dT/dOmega_m = -cI, no attitude dependence") {
    const ViscousDamping<double> e(0.7);
    const auto c = e.cache(Ln, 0.0);
    const Mat3 fd = central_jacobian<double>([&](const Vec3& w) { return e.torque(c, R, w); }, wm, d);
    CHECK((e.torque_jacobian_omega(c, R, wm) - fd).norm() < 1e-9);
    const Mat3 fr = central_jacobian<double>([&](const Vec3& w) { return e.torque(c, perturbed(w), wm); }, Vec3::Zero(), d);
    CHECK(fr.norm() == 0.0);
    CHECK(e.torque_jacobian_rotation(c, R, wm).norm() == 0.0);
  }
  SECTION("body torque: d(R exp(w) T)/dw = -R T^") {
    const Thruster e{ThrusterProgramme{}};
    const auto c = e.cache(Ln, 0.8);
    CHECK((c.T - ThrusterProgramme{}(0.8)).norm() == 0.0);
    const Mat3 fd =
        central_jacobian<double>([&](const Vec3& w) { return e.torque(c, perturbed(w), wm); }, Vec3::Zero(), d);
    CHECK((e.torque_jacobian_rotation(c, R, wm) - fd).norm() < 1e-9);
    CHECK(e.torque_jacobian_omega(c, R, wm).norm() == 0.0);
  }
  SECTION("space torque: Lambda_n^T S in frame n, whatever the mid rotation") {
    const SpaceLoad e{SpaceProgramme{}};
    const auto c = e.cache(Ln, 0.8);
    CHECK((c.s - Ln.transpose() * SpaceProgramme{}(0.8)).norm() < 1e-15);
    // The torque in frame n of the body torque (Λ_n R)ᵀS at Λ_n R is R (Λ_n R)ᵀ S.
    CHECK((e.torque(c, R, wm) - R * (Ln * R).transpose() * SpaceProgramme{}(0.8)).norm() < 1e-14);
    CHECK(e.torque_jacobian_rotation(c, R, wm).norm() == 0.0);
  }
  SECTION("general potential: gradient, Hessian and torque Jacobian") {
    const TestPotential<double> fdH = test_potential();
    const TestPotentialH<double> exH = test_potential_h();
    const Mat3 L = Ln * R;
    // dV = g·w for Λ exp(ŵ)
    Vec3 gfd;
    for (int j = 0; j < 3; ++j) {
      const Vec3 w = d * Vec3::Unit(j);
      gfd(j) = (TestV<double>{}(Mat3(L * SO3d::exp_matrix(w))) - TestV<double>{}(Mat3(L * SO3d::exp_matrix(Vec3(-w))))) /
               (2 * d);
    }
    CHECK((fdH.gradient(L) - gfd).norm() < 1e-8 * (1 + gfd.norm()));
    // H = ∂g/∂w: the user's analytic one against central differences of g (4th order).
    const Mat3 Hfd = central_jacobian<double>(
        [&](const Vec3& w) { return fdH.gradient(Mat3(L * SO3d::exp_matrix(w))); }, Vec3::Zero(), 1e-4);
    CHECK((exH.gradient_jacobian(L) - Hfd).norm() < 1e-8 * Hfd.norm());
    // the built-in central differences (step ε^(1/3)) are good to ~ε^(2/3)
    CHECK((fdH.gradient_jacobian(L) - Hfd).norm() < 1e-8 * Hfd.norm());
    // torque Jacobian R(ĝ − H) against differences of the torque, both variants
    for (int variant = 0; variant < 2; ++variant) {
      const auto c = fdH.cache(Ln, 0.0);
      const Mat3 Tfd = central_jacobian<double>(
          [&](const Vec3& w) { return fdH.torque(c, perturbed(w)); }, Vec3::Zero(), 1e-4);
      const Mat3 Jt = variant == 0 ? fdH.torque_jacobian(c, R) : exH.torque_jacobian(exH.cache(Ln, 0.0), R);
      CHECK((Jt - Tfd).norm() < 1e-8 * Tfd.norm());
    }
    // and the potential V(Λ_n R) itself
    CHECK(fdH.potential(fdH.cache(Ln, 0.0), R) == TestV<double>{}(L));
  }
}

namespace {

/// max ‖K − K_fd‖ / ‖K‖ for a scheme's residual on a scene, at a state and a Newton
/// iterate away from the solution.
template <class Scheme, class SceneT>
double tangent_error(const SceneT& scene, const State<double>& s, double hh, const Vec3& offset) {
  const detail::StepData<SceneT> data(scene, s, hh);
  Vec3 R;
  Mat3 K;
  double scale;
  const auto residual = [&](const Vec3& y) {
    Vec3 r;
    Mat3 k;
    double sc;
    Scheme{}.residual(data)(y, r, k, sc);
    return r;
  };
  const Vec3 y = (hh * hh / 2) * data.omega_rate() + offset;  // departure from the rigid rotation
  if constexpr (std::is_same_v<Scheme, GeradinBauchau> || std::is_same_v<Scheme, GeradinBauchauPaper>) {
    Scheme{}.residual(data)(Vec3(y / 2), R, K, scale);
    const Mat3 fd = central_jacobian<double>(residual, Vec3(y / 2), 1e-6);
    return (K - fd).norm() / K.norm();
  } else {
    Scheme{}.residual(data)(y, R, K, scale);
    const Mat3 fd = central_jacobian<double>(residual, y, 1e-6);
    return (K - fd).norm() / K.norm();
  }
}

}  // namespace

TEMPLATE_TEST_CASE("scheme tangents with every effect against central differences", "[effects][tangent]", SimoAlpha,
                   SimoCollocation, SimoKappa, GeradinBauchau, GeradinBauchauPaper) {
  trompo_test::Rng rng(77);
  for (int trial = 0; trial < 4; ++trial) {
    State<double> s;
    s.rotation = rng.rotation();
    s.omega = rng.vector(0.5, 4.0);
    s.time = rng.uniform(0, 5);
    const double hh = 0.05;
    const Vec3 offset = rng.vector(0.0, 0.01);
    const ViscousDamping<double> D(0.4);
    const Thruster T{ThrusterProgramme{}};
    const SpaceLoad S{SpaceProgramme{}};
    const Rotor<double> W(Vec3(0.5, 2.0, -1.0));
    INFO("trial " << trial << " " << TestType::name);
    const double tol = 1e-7;
    CHECK(tangent_error<TestType>(Scene<double, ViscousDamping<double>>(top_body(), D), s, hh, offset) < tol);
    CHECK(tangent_error<TestType>(Scene<double, UniformGravity<double>, ViscousDamping<double>>(top_body(), gravity(), D),
                                  s, hh, offset) < tol);
    CHECK(tangent_error<TestType>(Scene<double, Thruster>(top_body(), T), s, hh, offset) < tol);
    CHECK(tangent_error<TestType>(Scene<double, SpaceLoad>(top_body(), S), s, hh, offset) < tol);
    CHECK(tangent_error<TestType>(Scene<double, Rotor<double>>(top_body(), W), s, hh, offset) < tol);
    CHECK(tangent_error<TestType>(Scene<double, UniformGravity<double>, Rotor<double>>(top_body(), gravity(), W), s, hh,
                                  offset) < tol);
    CHECK(tangent_error<TestType>(Scene<double, TestPotentialH<double>>(top_body(), test_potential_h()), s, hh, offset) <
          tol);
    CHECK(tangent_error<TestType>(Scene<double, TestPotential<double>>(top_body(), test_potential()), s, hh, offset) <
          1e-6);
    CHECK(tangent_error<TestType>(Scene<double, UniformGravity<double>, TestPotentialH<double>, ViscousDamping<double>,
                                            Thruster, Rotor<double>>(top_body(), gravity(), test_potential_h(), D, T, W),
                                  s, hh, offset) < tol);
  }
}

// ==== other scalars ===========================================================================

TEMPLATE_TEST_CASE("effects in float and long double: power identity at the scalar's epsilon", "[effects][scalar]",
                   float, long double) {
  using S = TestType;
  using V = Eigen::Matrix<S, 3, 1>;
  const RigidBody<S> body(V(4, 5, 2));
  const Scene<S, UniformGravity<S>, ViscousDamping<S>, ConstantBodyTorque<S>, Rotor<S>, TestPotentialH<S>> scene(
      body, UniformGravity<S>(S(15), V(S(0.2), S(0.1), 1)), ViscousDamping<S>(S(0.3)), ConstantBodyTorque<S>(V(S(0.1), 0, S(0.2))),
      Rotor<S>(V(S(0.5), 2, -1)), TestPotentialH<S>{TestV<S>{}, TestGradient<S>{}, TestHessian<S>{}});
  State<S> s;
  s.rotation = SO3<S>::exp(V(S(0.4), S(-0.2), S(0.1)));
  s.omega = V(S(0.5), -1, 6);
  const S hh = S(0.01);
  const Stepper<SimoKappa, decltype(scene)> stepper(SimoKappa{}, scene);
  S worst(0);
  for (int k = 0; k < 100; ++k) {
    const State<S> a = s;
    REQUIRE(stepper.step(s, hh).ok());
    const V wm = (a.omega + s.omega) / S(2);
    const S P = hh * wm.dot(S(-0.3) * wm + V(S(0.1), 0, S(0.2)));
    worst = std::max(worst, std::abs(scene.energy(s) - scene.energy(a) - P) / scene.energy(a));
  }
  CHECK(worst < S(64) * std::numeric_limits<S>::epsilon());
}

// ==== long runs (registered: 3 s for Simo-κ, 8 s for collocation at -O1; docs/scenes.md quotes their figures) ==

TEMPLATE_TEST_CASE("general potential, 1e5 steps with integrate(): exactness and recovery", "[long][potential]",
                   SimoKappa, SimoCollocation) {
  const Scene<double, TestPotential<double>> scene(top_body(), test_potential());
  const Stepper<TestType, Scene<double, TestPotential<double>>> stepper(TestType{}, scene);
  for (const double hh : {0.01, 0.05, 0.1}) {
    for (const Vec3& w0 : {Vec3(1, -0.5, 2), Vec3(0, 0, 0), Vec3(0.3, 3, 0)}) {
      State<double> s = top_state();
      s.omega = w0;
      s.time = 0;
      const double H0 = scene.energy(s);
      double max_dH = 0;
      const auto sum = integrate(stepper, s, 1e5 * hh, hh, [&](const State<double>& x) {
        max_dH = std::max(max_dH, std::abs(scene.energy(x) - H0) / std::abs(H0));
      });
      std::printf("[effects-long] %s h = %.2f Omega0 = (%g, %g, %g): %s at t = %.1f, %lld intervals recovered "
                  "(deepest halving %d), max dH/H = %.2e\n",
                  TestType::name, hh, w0.x(), w0.y(), w0.z(), sum.ok() ? "completed" : sum.reason(),
                  static_cast<double>(s.time), static_cast<long long>(sum.recovered), sum.max_depth, max_dH);
      CHECK(max_dH < 1e-11);  // exact on every accepted step, completed or not
      if (std::is_same_v<TestType, SimoCollocation> || hh <= 0.01) CHECK(sum.ok());
    }
  }
}
