#pragma once
// The step report and the 3×3 Newton solver shared by the implicit schemes.
//
// Convergence is judged on both the correction and the residual (STYLE item 8):
// an iterate is accepted when ‖R‖ ≤ residual_tolerance·scale and the last correction
// ‖δ‖ ≤ step_tolerance·(size of the increment). Iterations are capped; the tangent is
// checked for singularity; non-finite values stop the solve. Nothing here throws.
#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <limits>

namespace trompo {

enum class StepStatus {
  ok,
  not_converged,     ///< the iteration cap was reached
  singular_tangent,  ///< the Newton tangent lost rank (e.g. the fold of THEORY §9)
  out_of_domain,     ///< GB: |e| ≥ 1, an increment at or beyond π
  wrong_branch,      ///< converged to an implausible increment (see NewtonOptions)
  non_finite,        ///< a NaN or infinity appeared
  invalid_step       ///< Δt zero or non-finite
};

inline const char* to_string(StepStatus s) {
  switch (s) {
    case StepStatus::ok: return "ok";
    case StepStatus::not_converged: return "Newton iteration did not converge";
    case StepStatus::singular_tangent: return "Newton tangent is singular";
    case StepStatus::out_of_domain: return "increment left the scheme's domain (rotation >= pi)";
    case StepStatus::wrong_branch: return "Newton converged to an implausible increment (wrong branch)";
    case StepStatus::non_finite: return "non-finite value in the step";
    case StepStatus::invalid_step: return "time step is zero or not finite";
  }
  return "unknown";
}

/// What a step did. On any status but ok the state was left exactly as it was.
template <class Scalar>
struct StepReport {
  StepStatus status = StepStatus::ok;
  int iterations = 0;           ///< Newton iterations (linear solves); 0 for explicit schemes
  Scalar residual = Scalar(0);  ///< final ‖R‖ / scale
  bool ok() const { return status == StepStatus::ok; }
  const char* reason() const { return to_string(status); }
};

/// Newton controls. The defaults reach round-off in 2–4 iterations at moderate h.
///
/// Branch rule (THEORY §9): at large h the implicit equations have several roots; the
/// step must stay on the one that continues the h → 0 solution. A converged increment
/// is reported as wrong_branch rather than silently taken when
///  - its rotation angle is max_increment or more (near or past π), or
///  - it is farther than max_correction (radians) from the predictor, or
///  - (fold rule) det(K·J⁻¹)·h ≤ 0 at the solution, K the Newton tangent. As h → 0,
///    K → (2/h)J (Simo) or (4/h)F J (GB), so det(K J⁻¹)·h > 0 on the continued branch,
///    and it can change sign only through a fold, where K is singular. A root with the
///    other sign lies beyond a fold. (On 3000 random strongly loaded tops with |hΩ| up
///    to 3 rad, this sign alone separated every accepted step from every step that
///    disagreed with continuation in h, for Simo-α, Simo-κ and GB.)
template <class Scalar>
struct NewtonOptions {
  int max_iterations = 25;
  Scalar residual_tolerance = Scalar(64) * std::numeric_limits<Scalar>::epsilon();
  Scalar step_tolerance = std::sqrt(std::numeric_limits<Scalar>::epsilon());
  Scalar max_increment = Scalar(0.999) * Scalar(3.14159265358979323846264338327950288L);
  Scalar max_correction = Scalar(1);
};

namespace detail {

/// Solves R(x) = 0 from x. `eval(x, R, K, scale)` fills the residual, its tangent and
/// the residual's natural scale, and returns false if x is outside the domain.
/// `x_scale` is the size against which a correction is judged (the increment's size).
/// On success, `tangent` (if given) receives K at the accepted x (for the fold rule).
template <class Scalar, class Eval>
StepReport<Scalar> newton(Eval&& eval, Eigen::Matrix<Scalar, 3, 1>& x, const NewtonOptions<Scalar>& opt,
                          Scalar x_scale, Eigen::Matrix<Scalar, 3, 3>* tangent = nullptr) {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  StepReport<Scalar> rep;
  const Scalar tiny = std::numeric_limits<Scalar>::min() / std::numeric_limits<Scalar>::epsilon();
  Vector3 R;
  Matrix3 K;
  Scalar scale(1);
  Scalar last_step = std::numeric_limits<Scalar>::infinity();
  for (int k = 0;; ++k) {
    if (!eval(x, R, K, scale)) {
      rep.status = StepStatus::out_of_domain;
      return rep;
    }
    const Scalar r = R.norm();
    rep.residual = r / (scale + tiny);
    if (!std::isfinite(static_cast<double>(r)) || !std::isfinite(static_cast<double>(K.sum()))) {
      rep.status = StepStatus::non_finite;
      return rep;
    }
    const bool small_residual = r <= opt.residual_tolerance * scale;
    // The predictor itself is accepted only with a zero residual: its O(h³) error is
    // smooth and of one sign from step to step, so accepting it whenever it is below
    // residual_tolerance (which happens in float: h³ < 64ε) drifts H and μ like N·64ε.
    // One correction leaves only the quadratic remainder and round-off.
    const bool small_step = k == 0 ? r == Scalar(0) : last_step <= opt.step_tolerance * (x_scale + tiny);
    if (small_residual && small_step) {
      if (tangent) *tangent = K;
      return rep;
    }
    // Stalled at round-off: the correction no longer moves x, and the residual is as
    // small as the conditioning of K allows (√ε·scale at worst). Nothing more to gain.
    const bool stalled =
        k > 0 && last_step <= Scalar(8) * std::numeric_limits<Scalar>::epsilon() * (x_scale + tiny);
    if (stalled && r <= std::sqrt(std::numeric_limits<Scalar>::epsilon()) * scale) {
      if (tangent) *tangent = K;
      return rep;
    }
    if (rep.iterations >= opt.max_iterations) {
      rep.status = StepStatus::not_converged;
      return rep;
    }
    // Singular tangent: |det K| tiny against the product of its column norms.
    const Scalar det = K.determinant();
    const Scalar bound = K.col(0).norm() * K.col(1).norm() * K.col(2).norm();
    if (!(std::abs(det) > Scalar(16) * std::numeric_limits<Scalar>::epsilon() * bound)) {
      rep.status = StepStatus::singular_tangent;
      return rep;
    }
    const Vector3 dx = -(K.inverse() * R);  // cofactor inverse of a fixed 3×3
    x += dx;
    last_step = dx.norm();
    ++rep.iterations;
  }
}

}  // namespace detail
}  // namespace trompo
