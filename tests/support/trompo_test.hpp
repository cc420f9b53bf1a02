#pragma once
// Shared helpers of the trompo test suite: a portable seeded RNG, runs that record the
// invariants, error measures, independent reference solutions (rows of the project's
// reference set, tests/data/reference_cases.hpp, docs/theory.md §8) and finite-difference
// Jacobians.
//
// Every number below that is a fact about the physics (reference attitudes, published
// figures) is written out here; nothing is computed by the library under test.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include "data/reference_cases.hpp"
#include "trompo/trompo.hpp"

namespace trompo_test {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
/// Reaction wheels of double and their per-wheel vector (the control and friction tests).
using Wheels = trompo::ReactionWheels<double>;
using WheelVector = Wheels::WheelVector;
/// One revolution per minute, in rad/s.
inline constexpr double rpm = 2.0 * 3.14159265358979323846 / 60.0;

// ---- deterministic random numbers ---------------------------------------------------
/// std::mt19937_64 is fully specified by the standard; the distributions are not, so the
/// mapping to [0, 1) is done here (53 random bits), identical on every platform.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : g_(seed) {}
  double uniform() { return static_cast<double>(g_() >> 11) * 0x1.0p-53; }
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  /// A point uniformly distributed on the unit sphere (rejection from the cube).
  Vec3 unit() {
    for (;;) {
      const Vec3 v(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
      const double n = v.norm();
      if (n > 0.1 && n <= 1.0) return v / n;
    }
  }
  /// A vector of random direction and norm in [a, b].
  Vec3 vector(double a, double b) { return unit() * uniform(a, b); }
  /// A random rotation (uniform angle in [0, π), uniform axis).
  trompo::SO3d rotation() { return trompo::SO3d::exp(vector(0.0, 3.14)); }

 private:
  std::mt19937_64 g_;
};

/// A random symmetric positive-definite inertia with principal moments in [lo, hi]
/// (lo ≥ hi/2 keeps the triangle inequality) along random principal axes.
inline Mat3 random_inertia(Rng& rng, double lo = 1.0, double hi = 2.0) {
  const Mat3 P = rng.rotation().matrix();
  const Vec3 m(rng.uniform(lo, hi), rng.uniform(lo, hi), rng.uniform(lo, hi));
  Mat3 J = P * m.asDiagonal() * P.transpose();
  return (J + J.transpose()) / 2;  // exactly symmetric
}

// ---- error measures -------------------------------------------------------------------
template <class Derived>
double frobenius(const Eigen::MatrixBase<Derived>& m) {
  return static_cast<double>(m.norm());
}
template <class Derived>
double spectral(const Eigen::MatrixBase<Derived>& m) {
  const Mat3 d = m.template cast<double>();
  return Eigen::JacobiSVD<Mat3>(d).singularValues()(0);
}
template <class Derived>
double max_abs(const Eigen::MatrixBase<Derived>& m) {
  return static_cast<double>(m.cwiseAbs().maxCoeff());
}
/// log2 of the ratio of two errors: the observed order of a halving of h.
inline double observed_order(double coarse, double fine) { return std::log2(coarse / fine); }

// ---- runs that record the invariants -----------------------------------------------------
template <class Scalar>
struct RunStats {
  trompo::State<Scalar> final;
  double max_dH = 0;        ///< max_n |H_n − H_0| / |H_0|
  double max_dmu = 0;       ///< max_n |μ_n − μ_0| / |μ_0|
  double max_dpi = 0;       ///< max_n |π_n − π_0| / |π_0|   (the whole spatial momentum)
  double max_orth = 0;      ///< max_n max|ΛᵀΛ − I|
  long steps = 0;           ///< steps taken
  long iterations = 0;      ///< total Newton iterations
  int max_iterations = 0;   ///< most Newton iterations in one step
  long failures = 0;        ///< steps with a status other than ok (the run stops there)
  long recovered = 0;       ///< failed steps retaken as two halves (run(..., recover = true))
  trompo::StepStatus first_failure = trompo::StepStatus::ok;
  double mean_iterations() const { return steps ? static_cast<double>(iterations) / static_cast<double>(steps) : 0.0; }
};

/// n steps of h from s0 with `stepper`, recording the invariants after every step. `s` is a
/// State, or a Trajectory (stepper.start(s0)) to carry a scheme's memory from step to step.
/// With `recover`, a failed step is retaken once as two steps of h/2 (integrate()'s first
/// halving) and counted in `recovered`; only a failed half ends the run as a failure.
template <class Stepper, class StateT = trompo::State<typename Stepper::Scalar>>
RunStats<typename Stepper::Scalar> run(const Stepper& stepper, StateT s, typename Stepper::Scalar h, long n,
                                       bool recover = false) {
  using Scalar = typename Stepper::Scalar;
  using std::abs;
  const auto& scene = stepper.scene();
  RunStats<Scalar> st;
  const Scalar H0 = scene.energy(s);
  const Scalar mu0 = scene.momentum_map(s);
  const auto pi0 = scene.spatial_momentum(s);
  for (long k = 0; k < n; ++k) {
    trompo::StepReport<Scalar> rep = stepper.step(s, h);
    if (!rep.ok() && recover) {
      if (st.first_failure == trompo::StepStatus::ok) st.first_failure = rep.status;
      trompo::StepReport<Scalar> whole = rep;  // the work of every attempt, as integrate() counts it
      rep = stepper.step(s, h / 2);
      whole.add_work(rep);
      if (rep.ok()) {
        const trompo::StepReport<Scalar> second = stepper.step(s, h / 2);
        whole.add_work(second);
        rep.status = second.status;
      }
      if (rep.ok()) ++st.recovered;
      rep.iterations = whole.iterations;
    }
    if (!rep.ok()) {
      ++st.failures;
      st.first_failure = rep.status;
      break;
    }
    ++st.steps;
    st.iterations += rep.iterations;
    st.max_iterations = std::max(st.max_iterations, rep.iterations);
    st.max_dH = std::max(st.max_dH, static_cast<double>(abs((scene.energy(s) - H0) / H0)));
    st.max_dmu = std::max(st.max_dmu, static_cast<double>(abs((scene.momentum_map(s) - mu0) / mu0)));
    st.max_dpi = std::max(st.max_dpi, static_cast<double>((scene.spatial_momentum(s) - pi0).norm() / pi0.norm()));
    const auto R = s.rotation.matrix();
    st.max_orth = std::max(st.max_orth, max_abs(R.transpose() * R - decltype(R)::Identity()));
  }
  st.final = s;
  return st;
}

/// n steps without bookkeeping (for reference runs); returns the final state.
template <class Stepper>
trompo::State<typename Stepper::Scalar> advance(const Stepper& stepper, trompo::State<typename Stepper::Scalar> s,
                                                typename Stepper::Scalar h, long n, long* failures = nullptr) {
  for (long k = 0; k < n; ++k) {
    if (!stepper.step(s, h).ok()) {
      if (failures) ++*failures;
      break;
    }
  }
  return s;
}

// ---- test problems ---------------------------------------------------------------------
/// An anisotropic heavy top, J = diag(4, 5, 2), the centre of mass off every axis: the top
/// on which accepting a first chord step by the Newton rate drifted H by 4e-12 in 1000
/// steps (the chord rate was 30x the Newton rate there; docs/design.md, Design notes).
/// tests/test_newton.cpp and tests/test_predictor.cpp run it 2e4 steps for H and μ.
inline trompo::cases::Case<trompo::HeavyTop<double>> anisotropic_top() {
  using namespace trompo;
  State<double> s;
  s.rotation = SO3d::exp(Vec3(0.4, -0.2, 0.1));
  s.omega = Vec3(0.5, -1.0, 6.0);
  return {"anisotropic", HeavyTop<double>(RigidBody<double>(Vec3(4, 5, 2)), UniformGravity<double>(15.0, Vec3(0.2, 0.1, 1.0))),
          s, 200.0};
}

// ---- independent reference solutions (docs/theory.md §8, the project's reference set) -----------
/// One row of a reference solution: Λ (row-major) and Ω at time t.
struct Reference {
  double t;
  double R[9];
  double omega[3];
  Mat3 rotation() const {
    Mat3 m;
    m << R[0], R[1], R[2], R[3], R[4], R[5], R[6], R[7], R[8];
    return m;
  }
  Vec3 angular_velocity() const { return Vec3(omega[0], omega[1], omega[2]); }
};

/// A row of tests/data/reference_cases.hpp as a Reference.
inline Reference reference_row(const double* row) {
  Reference r{row[0], {}, {}};
  std::copy(reference::rotation_of(row), reference::rotation_of(row) + 9, r.R);
  std::copy(reference::omega_of(row), reference::omega_of(row) + 3, r.omega);
  return r;
}
/// HT0 (Mgl = 196.2, tilt 0.3), closed-form Lagrange top.
inline const Reference ht0_t1 = reference_row(reference::ht0[2]);
/// HT1 (Mgl = 20, tilt 0.05), closed-form Lagrange top.
inline const Reference ht1_t1 = reference_row(reference::ht1[2]);
/// HT2 (Brüls–Cardona fast top), Runge–Kutta–Fehlberg 7(8) in 128-bit floats, tol 1e-26.
inline const Reference ht2_t05 = reference_row(reference::ht2[0]);
/// FB1 (J = diag(1,2,3), Ω0 = (0.01, 2, 0.01), Λ0 = I), closed-form free body.
inline const Reference fb1_t5 = reference_row(reference::fb1[1]);
/// Exact invariants of the reference set (H, μ), for checking the case definitions.
inline constexpr double ht0_H = reference::ht0[0][13], ht0_mu = reference::ht0[0][14];
inline constexpr double ht1_H = reference::ht1[0][13], ht1_mu = reference::ht1[0][14];
inline constexpr double ht2_H = reference::ht2[0][13], ht2_mu = reference::ht2[0][14];
inline constexpr double fb1_H = reference::fb1[0][13];

// ---- finite differences --------------------------------------------------------------------
/// Fourth-order central difference (Richardson on steps δ and 2δ) of a vector function
/// f: R³ → R³ at x, column by column: (8(f(x+δ) − f(x−δ)) − (f(x+2δ) − f(x−2δ))) / 12δ.
template <class Scalar, class F>
Eigen::Matrix<Scalar, 3, 3> central_jacobian(F&& f, const Eigen::Matrix<Scalar, 3, 1>& x, Scalar delta) {
  using V = Eigen::Matrix<Scalar, 3, 1>;
  Eigen::Matrix<Scalar, 3, 3> J;
  for (int i = 0; i < 3; ++i) {
    V d = V::Zero();
    d(i) = delta;
    const V f1 = f(V(x + d)) - f(V(x - d));
    const V f2 = f(V(x + 2 * d)) - f(V(x - 2 * d));
    J.col(i) = (Scalar(8) * f1 - f2) / (Scalar(12) * delta);
  }
  return J;
}

}  // namespace trompo_test
