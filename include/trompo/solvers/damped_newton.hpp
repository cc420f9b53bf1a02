#pragma once
// Newton's method with Armijo backtracking, for the families of docs/theory.md §11
// (caveat 5 of that section: at large steps the plain iteration from a poor predictor
// diverged; the predictor from the previous increment plus backtracking on the weighted
// residual fixed every case measured).
//
// Fixed size N (3 for gen-α and the energy-decaying scheme, 4 for the constrained
// trapezoid): fixed-size Eigen matrices and a fixed-size LU (small_lu.hpp), no heap.
//
// The residual is judged in the weighted max-norm r = max_i |R_i|/W_i, with weights W
// fixed for the step (the natural scale of each row, so that every row is resolved to
// round-off of its own terms).
//
// Acceptance (as detail::newton in newton.hpp): r ≤ residual_tolerance
// after a full Newton correction δ with ‖δ‖ ≤ step_tolerance·x_scale, *and* the error
// left after it, estimated as ρ‖δ‖ with ρ = r_k/r_{k−1} the contraction of that Newton
// step, below ε·x_scale/1024. The last condition matters: a remainder near ε·x_scale is
// smooth and of one sign from step to step, and the invariants then drift like N·ε
// (measured in float: the constrained trapezoid drifted H by 10⁻⁶ per step with it left
// out). Or stalled at round-off: a correction ≤ 8ε·x_scale with r ≤ min(√ε, 10³·tol).
//
// Backtracking (Armijo, on the weighted 2-norm): δ is scaled by t = 1, ½, ¼, … down to
// 2⁻¹⁰ until ‖R(x + tδ)‖ ≤ (1 − 10⁻⁴ t)‖R(x)‖. If no t decreases it, the shortest
// correction is taken anyway and the iteration goes on (on the cases of docs/theory.md §11
// this never failed); the iteration cap ends a hopeless solve.
// Nothing throws.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>

#include "trompo/solvers/newton.hpp"
#include "trompo/solvers/small_lu.hpp"

namespace trompo::detail {

/// min/ε: added to a row weight or a scale that may be zero (a body at rest, a zero
/// increment) so that nothing divides by zero, yet far below any scale a step has.
template <class Scalar>
constexpr Scalar tiny_scale() {
  return std::numeric_limits<Scalar>::min() / std::numeric_limits<Scalar>::epsilon();
}

}  // namespace trompo::detail

namespace trompo {

/// One damped solve's own inputs and outputs besides the residual and the controls
/// (NewtonOptions), by name (see detail::damped_newton).
template <int N, class Scalar>
struct DampedNewtonSolve {
  /// An N-vector of Scalar.
  using VectorN = Eigen::Matrix<Scalar, N, 1>;
  /// An N×N matrix of Scalar.
  using MatrixN = Eigen::Matrix<Scalar, N, N>;
  /// The row weights W (positive): the natural scale of each row of R.
  VectorN weights = VectorN::Ones();
  /// The size against which a correction is judged.
  Scalar x_scale = Scalar(0);
  /// If given, receives the tangent at the last full evaluation on success.
  MatrixN* tangent = nullptr;
};

}  // namespace trompo

namespace trompo::detail {

/// Solves R(x) = 0 from x. `eval(x, R, K)` fills R and, if K is not null, the tangent
/// ∂R/∂x; it returns false if x is outside the scheme's domain. `solve` names the rest:
/// the row weights W, the size x_scale against which a correction is judged, and the
/// tangent output.
template <int N, class Scalar, class Eval>
StepReport<Scalar> damped_newton(Eval&& eval, Eigen::Matrix<Scalar, N, 1>& x, const NewtonOptions<Scalar>& opt,
                                 const DampedNewtonSolve<N, Scalar>& solve) {
  using VectorN = Eigen::Matrix<Scalar, N, 1>;
  using MatrixN = Eigen::Matrix<Scalar, N, N>;
  constexpr Scalar eps = std::numeric_limits<Scalar>::epsilon();
  const VectorN& W = solve.weights;
  const VectorN W_inv = W.cwiseInverse();  // the row scaling of the linear solves
  MatrixN* const tangent = solve.tangent;
  const Scalar size = solve.x_scale + tiny_scale<Scalar>();
  StepReport<Scalar> rep;
  VectorN R, R_trial, x_trial;
  MatrixN K, K_trial;
  const auto norm = [&](const VectorN& r) { return (r.cwiseAbs().cwiseQuotient(W)).maxCoeff(); };
  // Full evaluation at y into (Ry, Ky); false with rep.status set on trouble.
  const auto evaluate = [&](const VectorN& y, VectorN& Ry, MatrixN& Ky, Scalar& ry) {
    if (!eval(y, Ry, &Ky)) {
      rep.status = StepStatus::out_of_domain;
      return false;
    }
    ry = norm(Ry);
    if (!std::isfinite(static_cast<double>(ry)) || !std::isfinite(static_cast<double>(Ky.sum()))) {
      rep.status = StepStatus::non_finite;
      return false;
    }
    return true;
  };
  Scalar r(0);
  if (!evaluate(x, R, K, r)) return rep;
  const auto norm2 = [&](const VectorN& v) { return v.cwiseQuotient(W).norm(); };
  Scalar last_step = std::numeric_limits<Scalar>::infinity();
  Scalar r_prev = std::numeric_limits<Scalar>::infinity();
  bool last_full = false;  // the last correction was a full (undamped) Newton step
  const Scalar stall_residual = std::min(std::sqrt(eps), Scalar(1000) * opt.residual_tolerance);
  for (int k = 0;; ++k) {
    rep.residual = r;
    const bool small_residual = r <= opt.residual_tolerance;
    // The predictor is accepted only with a zero residual (its error is smooth and of one
    // sign from step to step: accepting it below tolerance would drift the invariants).
    const bool small_step = k == 0 ? r == Scalar(0)
                                   : last_full && last_step <= opt.step_tolerance * size &&
                                         (r / r_prev) * last_step <= eps * size / Scalar(1024);
    const bool stalled = k > 0 && last_step <= Scalar(8) * eps * size && r <= stall_residual;
    if ((small_residual && small_step) || stalled) {
      if (tangent) *tangent = K;
      return rep;
    }
    if (rep.iterations >= opt.max_iterations) {
      rep.status = StepStatus::not_converged;
      return rep;
    }
    // δ from the rows scaled by their weights, (W⁻¹K) δ = −W⁻¹R: the same δ in exact
    // arithmetic, but pivots chosen among rows of one scale. Unscaled, a body with
    // J₃ = 10⁻³ J₁ stalled 8–17 ε·x_scale from the root and missed the stall test below.
    const SmallLU<N, Scalar> lu(W_inv.asDiagonal() * K);
    if (!(lu.rcond() > Scalar(16) * eps)) {
      rep.status = StepStatus::singular_tangent;
      return rep;
    }
    const VectorN dx = -lu.solve(R.cwiseQuotient(W));
    ++rep.iterations;
    // Armijo backtracking on the weighted 2-norm.
    const Scalar n0 = norm2(R);
    Scalar t(1), r_trial(0);
    bool have_trial = false;
    for (int halving = 0; halving <= 10; ++halving, t /= Scalar(2)) {
      x_trial = x + t * dx;
      if (!evaluate(x_trial, R_trial, K_trial, r_trial)) {
        rep.status = StepStatus::ok;  // outside the domain or not finite: shorter
        have_trial = false;
        continue;
      }
      have_trial = true;
      if (norm2(R_trial) <= (Scalar(1) - Scalar(1e-4) * t) * n0 || r_trial <= opt.residual_tolerance) break;
    }
    if (!have_trial) {
      rep.status = StepStatus::out_of_domain;
      return rep;
    }
    if (t < Scalar(1) / Scalar(1024)) t = Scalar(1) / Scalar(1024);  // the loop's last t
    last_full = t == Scalar(1);
    last_step = t * dx.norm();
    r_prev = r;
    x = x_trial;
    R = R_trial;
    K = K_trial;
    r = r_trial;
  }
}

}  // namespace trompo::detail
