#pragma once
// The step report and the 3×3 Newton solver shared by the implicit schemes.
//
// Convergence is judged on both the correction and the residual:
// an iterate is accepted when ‖R‖ ≤ residual_tolerance·scale and the last correction
// ‖δ‖ ≤ step_tolerance·(size of the increment). Iterations are capped; the tangent is
// checked for singularity; non-finite values stop the solve. Nothing here throws.
#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <limits>

namespace trompo {

/// The outcome of a step: ok, or why it failed (the state is then unchanged).
enum class StepStatus {
  /// the step was taken
  ok,
  not_converged,     ///< the iteration cap was reached
  singular_tangent,  ///< the Newton tangent lost rank (e.g. the fold of docs/theory.md §9)
  out_of_domain,     ///< GB: |e| ≥ 1, an increment at or beyond π
  wrong_branch,      ///< converged to an implausible increment (see NewtonOptions)
  non_finite,        ///< a NaN or infinity appeared
  invalid_step       ///< Δt zero or non-finite
};

/// The status as text: "ok", or a short reason ("Newton tangent is singular", …).
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
  /// ok, or why the step failed.
  StepStatus status = StepStatus::ok;
  int iterations = 0;           ///< Newton iterations (linear solves); 0 for explicit schemes
  int evaluations = 0;          ///< residual evaluations, tangent or not (0 for explicit schemes)
  int tangents = 0;             ///< of which with the tangent (the dearer half of an evaluation)
  Scalar residual = Scalar(0);  ///< final ‖R‖ / scale
  /// True when the step succeeded.
  bool ok() const { return status == StepStatus::ok; }
  /// The status as text.
  const char* reason() const { return to_string(status); }
  /// Adds the work of `spent` (its counts) to this report's, and nothing else: an attempt
  /// whose outcome was discarded (a history solve before its memoryless retry).
  void add_work(const StepReport& spent) {
    iterations += spent.iterations;
    evaluations += spent.evaluations;
    tangents += spent.tangents;
  }
  /// Adds a sub-step's report to this step's (compositions): counts summed, the largest
  /// residual, and the sub-step's status if it failed.
  void absorb(const StepReport& sub) {
    add_work(sub);
    if (sub.residual > residual) residual = sub.residual;
    if (!sub.ok()) status = sub.status;
  }
};

/// Newton controls. The defaults reach round-off in 2–4 iterations at moderate h.
///
/// Branch rule (docs/theory.md §9): at large h the implicit equations have several roots; the
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
  /// Newton iterations before a step is reported not_converged.
  int max_iterations = 25;
  /// Acceptance: the residual, relative to its natural scale.
  Scalar residual_tolerance = Scalar(64) * std::numeric_limits<Scalar>::epsilon();
  /// Acceptance: the last correction, relative to the increment.
  Scalar step_tolerance = std::sqrt(std::numeric_limits<Scalar>::epsilon());
  /// Branch rule: the largest increment angle accepted (0.999π).
  Scalar max_increment = Scalar(0.999) * Scalar(3.14159265358979323846264338327950288L);
  /// Branch rule: the largest distance of the root from the predictor (rad).
  Scalar max_correction = Scalar(1);
  /// Simplified Newton: the tangent is reused while the last correction is at most this
  /// fraction of the increment's size, and re-evaluated when a reused one contracts the
  /// residual by less than 10× (see detail::newton). 0: a fresh tangent every iteration.
  Scalar reuse_tangent = Scalar(1e-3);
};

/// One solve's own inputs and outputs besides the residual and the controls (NewtonOptions),
/// by name: the size of the unknown, where the tangent goes, and the tangent carried from
/// an earlier solve (see detail::newton).
template <class Scalar>
struct NewtonSolve {
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// The size against which a correction is judged (the increment's size).
  Scalar x_scale = Scalar(0);
  /// If given, receives the last evaluated tangent K on success.
  Matrix3* tangent = nullptr;
  /// If given, the iteration's inverse tangent: on success the inverse of the tangent used
  /// last (for the next solve, [P3], and the fold rule).
  Matrix3* carried = nullptr;
  /// Start from *carried, the inverse tangent of a nearby solve: evaluation 0 is then
  /// residual-only and the first correction a chord step with it. Needs `carried`.
  bool start_from_carried = false;
};

namespace detail {

/// K⁻¹ = adj(K)/det K, the rows of adj(K) being the cross products of K's columns, so
/// that the determinant and the inverse share them. False (K_inv untouched) when K is
/// singular to working precision: |det K| ≤ 16ε‖k₀‖‖k₁‖‖k₂‖, k_i its columns.
template <class Scalar>
bool invert_unless_singular(const Eigen::Matrix<Scalar, 3, 3>& K, Eigen::Matrix<Scalar, 3, 3>& K_inv) {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  const Vector3 c0 = K.col(1).cross(K.col(2)), c1 = K.col(2).cross(K.col(0)), c2 = K.col(0).cross(K.col(1));
  const Scalar det = K.col(0).dot(c0);
  const Scalar bound = K.col(0).norm() * K.col(1).norm() * K.col(2).norm();
  if (!(std::abs(det) > Scalar(16) * std::numeric_limits<Scalar>::epsilon() * bound)) return false;
  K_inv.row(0) = c0.transpose() / det;
  K_inv.row(1) = c1.transpose() / det;
  K_inv.row(2) = c2.transpose() / det;
  return true;
}

/// Solves R(x) = 0 from x by Newton's method, reusing the tangent (simplified Newton)
/// once the iteration is in its contraction region.
///
/// `eval(x, R, K, scale)` fills the residual and its natural scale, and the tangent
/// ∂R/∂x into *K unless K is null (then only R, bit-identical: the schemes skip the
/// tangent's matrix products, about half of an evaluation); it returns false if x is
/// outside the domain. `solve` (NewtonSolve) names the rest: x_scale, the size against
/// which a correction is judged (the increment's size), written x_scale below, and the
/// optional tangent outputs and carried tangent.
///
/// Tangent reuse (opt.reuse_tangent > 0). From the second evaluation on, an iterate x_k
/// is evaluated residual-only when the last correction was at most
/// opt.reuse_tangent·x_scale, and corrected with the kept tangent K_j and its inverse
/// (a chord step). A chord step contracts the error by ρ ≈ ‖K_j⁻¹(K(x_k) − K_j)‖,
/// small near the root but only linearly; when the residual did not fall by 10× over a
/// chord step, the tangent is re-evaluated at x_k and the iteration is Newton again.
///
/// Acceptance. As before: ‖R‖ ≤ residual_tolerance·scale after a Newton
/// correction ≤ step_tolerance·x_scale (its remainder is quadratic, far below
/// round-off). And, without a confirming evaluation, by the contraction estimate: when
/// two successive corrections are of the same kind (Newton after Newton, or chord after
/// chord with the same K), ρ = ‖R_k‖/‖R_{k−1}‖ bounds the contraction of the second
/// (Newton: an overestimate; chord: the measured rate), and the error left after it is
/// about ρ‖δ_k‖. It is accepted when ρ ≤ 1/100 and ρ‖δ_k‖ ≤ ε·x_scale/1024. The margin
/// matters: the remainder is smooth and of one sign from step to step, and an error δx
/// in the increment moves H by ~4‖δx‖/x_scale relative, so accepting a remainder near
/// ε·x_scale drifted H like N·4ε (measured); at ε/1024 it stays below round-off's √N·ε
/// over the 10⁷-step runs of bench_long_run. A first chord step is not accepted by the
/// estimate, since the Newton step before it says nothing of its rate (measured: a
/// contraction factor 30× the Newton step's on an anisotropic top), unless it is already
/// at round-off (see the loop). opt.reuse_tangent = 0 gives plain Newton with the
/// confirming evaluation every time.
///
/// rep.residual is the last evaluated ‖R‖/scale (before the final correction when the
/// estimate accepted it). On success, solve.tangent (if given) receives the last evaluated
/// K: at the accepted x, or at an iterate that chord corrections (each ≤
/// opt.reuse_tangent·x_scale) separate from it, which is what the fold
/// rule needs (the sign of det K, which changes only across a fold, where K is
/// singular and the iteration fails).
///
/// Carried tangent ([P3]). With solve.carried non-null and solve.start_from_carried, it holds the
/// inverse of a tangent from a nearby solve (the previous step of the same size, kept in
/// the scheme's memory): evaluation 0 is then residual-only and the first correction a
/// chord step with it. Everything else is as above, except that a chord step with the
/// carried tangent must contract the residual by 10⁴× (not 10×), else a fresh tangent is
/// evaluated there; acceptance is by the same rules. On
/// success *solve.carried (when given) holds the inverse of the tangent used last, for the
/// next solve and for the fold rule (det K⁻¹ has the sign of det K); solve.tangent receives
/// the last evaluated K only if one was evaluated. *solve.carried is the iteration's own
/// inverse (not a copy), so on failure it may hold any inverse evaluated meanwhile; without
/// start_from_carried its value on entry is not read.
template <class Scalar, class Eval>
StepReport<Scalar> newton(Eval&& eval, Eigen::Matrix<Scalar, 3, 1>& x, const NewtonOptions<Scalar>& opt,
                          const NewtonSolve<Scalar>& solve) {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  constexpr Scalar eps = std::numeric_limits<Scalar>::epsilon();
  StepReport<Scalar> rep;
  const Scalar tiny = std::numeric_limits<Scalar>::min() / eps;
  const Scalar size = solve.x_scale + tiny;
  Matrix3* const tangent = solve.tangent;
  Matrix3* const carried = solve.carried;
  const bool reuse = opt.reuse_tangent > Scalar(0);
  Vector3 R;
  Matrix3 K = Matrix3::Zero();  // tangent of the last full evaluation
  // and its inverse: the caller's *carried itself when given (read as the carried tangent,
  // written by every inversion), which saves copying it in and out at every solve.
  Matrix3 own_inverse = Matrix3::Zero();
  Matrix3& K_inv = carried ? *carried : own_inverse;
  const bool start_carried = carried && solve.start_from_carried && reuse;
  bool evaluated_tangent = false;   // whether K holds a tangent evaluated in this solve
  Scalar scale(1);
  Scalar last_step = std::numeric_limits<Scalar>::infinity();
  Scalar r_prev = std::numeric_limits<Scalar>::infinity();
  bool last_fresh = true;  // the last correction used a tangent evaluated at its iterate
  Scalar r(0);  // ‖R‖
  // R, r (and K if `with_tangent`) at x; false with rep.status set if x is out of the
  // domain or a value is not finite.
  const auto evaluate = [&](bool with_tangent) {
    if (!eval(x, R, with_tangent ? &K : static_cast<Matrix3*>(nullptr), scale)) {
      rep.status = StepStatus::out_of_domain;
      return false;
    }
    r = R.norm();
    ++rep.evaluations;
    if (with_tangent) ++rep.tangents;
    evaluated_tangent = evaluated_tangent || with_tangent;
    if (!std::isfinite(static_cast<double>(r)) ||
        (with_tangent && !std::isfinite(static_cast<double>(K.sum())))) {
      rep.status = StepStatus::non_finite;
      return false;
    }
    return true;
  };
  // On success: the tangent used last, for the caller (*carried already holds its inverse).
  const auto finish = [&]() {
    if (tangent && evaluated_tangent) *tangent = K;
  };
  for (int k = 0;; ++k) {
    // Evaluation k; the correction it leads to is a chord step unless `fresh`.
    bool fresh = !reuse || (k == 0 && !start_carried) || (k > 0 && !(last_step <= opt.reuse_tangent * size));
    if (!evaluate(fresh)) return rep;
    rep.residual = r / (scale + tiny);
    const bool small_residual = r <= opt.residual_tolerance * scale;
    // The predictor itself is accepted only with a zero residual: its O(h³) error is
    // smooth and of one sign from step to step, so accepting it whenever it is below
    // residual_tolerance (which happens in float: h³ < 64ε) drifts H and μ like N·64ε.
    // After a chord step the remainder is linear in the correction, not quadratic:
    // only the contraction estimate below accepts it.
    const bool small_step = k == 0 ? r == Scalar(0) : last_fresh && last_step <= opt.step_tolerance * size;
    if (small_residual && small_step) {
      finish();
      return rep;
    }
    // Stalled at round-off: the correction no longer moves x, and the residual is as
    // small as the conditioning of K allows (√ε·scale at worst). Nothing more to gain.
    const bool stalled = k > 0 && last_step <= Scalar(8) * eps * size;
    if (stalled && r <= std::sqrt(eps) * scale) {
      finish();
      return rep;
    }
    if (rep.iterations >= opt.max_iterations) {
      rep.status = StepStatus::not_converged;
      return rep;
    }
    // A carried tangent (from an earlier solve) must contract by 10⁴× per chord step, a
    // tangent of this solve by 10×: the carried one ages from step to step, and a chord
    // rate near 1/10 would let the `stalled` rule accept a remainder ~ε·x_scale of one
    // sign, which drifts H (measured on the anisotropic top of tests/test_predictor.cpp).
    const Scalar chord_contraction = evaluated_tangent ? Scalar(10) : Scalar(10000);
    if (!fresh && !last_fresh && !(r <= r_prev / chord_contraction)) {
      // A chord step contracted too little: Newton again from here (same x, same R).
      fresh = true;
      if (!evaluate(true)) return rep;
    }
    if (fresh && !invert_unless_singular(K, K_inv)) {
      rep.status = StepStatus::singular_tangent;
      return rep;
    }
    const Vector3 dx = -(K_inv * R);
    x += dx;
    const Scalar step = dx.norm();
    ++rep.iterations;
    // Accepted by the contraction estimate (see above): two corrections of one kind.
    // Or a first chord correction already at round-off (≤ 8ε·x_scale, the size at which
    // the next evaluation would stop as stalled) after a Newton step that contracted by
    // 10⁶ or more: the chord rate is then ≤ 10⁻³ even at the 30× above, and the
    // confirming evaluation could only move x by ≤ 8·10⁻³ ε·x_scale.
    if (reuse && k > 0) {
      const Scalar rho = r / r_prev;
      const bool estimated = fresh == last_fresh && rho <= Scalar(0.01) && rho * step <= eps * size / Scalar(1024);
      const bool at_roundoff = !fresh && last_fresh && rho <= Scalar(1e-6) && step <= Scalar(8) * eps * size;
      if (estimated || at_roundoff) {
        finish();
        return rep;
      }
    }
    last_step = step;
    last_fresh = fresh;
    r_prev = r;
  }
}

}  // namespace detail
}  // namespace trompo
