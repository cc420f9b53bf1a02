#pragma once
// The rules every implicit scheme applies to its Newton solve, written once:
//
//  - detail::on_branch, the branch rule (NewtonOptions, docs/theory.md §9): a converged
//    root is taken only if its increment angle is below max_increment, its distance from
//    the predictor at most max_correction, and the fold sign det(K J⁻¹)·h positive. The
//    Simo and Géradin–Bauchau steps (through implicit_step below) and the three family
//    schemes (schemes/families/) call it.
//  - detail::implicit_step, the step sequence of the schemes with a history predictor
//    (Simo-α/κ/collocation, Géradin–Bauchau, docs/theory.md §13 [P1]–[P3]):
//      history predictor → Newton → memoryless fallback → branch rule → committable → record.
//    A scheme supplies the problem (its residual, its two predictors, the branch rule's
//    numbers and the update of the state); the sequence is the same for all of them.
#include <Eigen/Core>

#include "trompo/model/state.hpp"
#include "trompo/schemes/history.hpp"
#include "trompo/solvers/newton.hpp"

namespace trompo::detail {

/// The branch rule (NewtonOptions): true when the root continues the h → 0 solution, i.e.
/// `angle` (the increment's rotation angle) < max_increment, `correction` (its distance
/// from the predictor, rad) ≤ max_correction, and `orientation` (det(K J⁻¹)·h, or what a
/// scheme's K tends to as h → 0) > 0. False for a NaN in any of them.
template <class Scalar>
bool on_branch(const NewtonOptions<Scalar>& opt, Scalar angle, Scalar correction, Scalar orientation) {
  return angle < opt.max_increment && correction <= opt.max_correction && orientation > Scalar(0);
}

/// Where a solve starts: Newton's unknown, the increment Θ⁰ it predicts (for the branch
/// rule's distance) and the size against which a correction is judged.
template <class Scalar>
struct ImplicitStart {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  Vector3 unknown;    ///< Newton's unknown at the predictor
  Vector3 predicted;  ///< Θ⁰, the predicted rotation increment (body frame of step n)
  Scalar size = Scalar(0);  ///< x_scale of the solve (NewtonSolve)
};

/// The branch rule's first two numbers at a root: the increment Θ and its angle.
template <class Scalar>
struct ImplicitRoot {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  Vector3 increment;  ///< Θ at the root
  Scalar angle;       ///< its rotation angle
};

/// One step of an implicit scheme with a 3-vector unknown and (optionally) a history
/// predictor. `problem` provides
///
///   residual()                 a fresh residual functor for detail::newton (one per solve)
///   from_history(x)            the ImplicitStart from the history's extrapolated increment x [P1]
///   memoryless()               the ImplicitStart of a step without history
///   root(y)                    the ImplicitRoot at Newton's root y
///   orientation(K)             det(K J⁻¹)·h (its h → 0 sign) from a tangent K evaluated in the solve
///   orientation_inverse(K⁻¹)   the same from the inverse tangent the solve corrected with last
///   advance(y, out)            the state at the end of the step from the root y
///   recorded(y)                what the history records (the increment the scheme extrapolates)
///
/// With `history` (the scheme's memory, null for none) the step starts from the
/// extrapolation and the carried tangent when the history is trusted ([P2]; not with
/// plain Newton, opt.reuse_tangent = 0); if that solve fails or its root is off the branch,
/// the step is solved once more from the memoryless start (its report counts both
/// solves' work). The result is checked with committable (the scheme's one check of it:
/// writes_memory_on_success) before the history records the accepted increment.
template <class Problem, class Scalar>
StepReport<Scalar> implicit_step(const Problem& problem, const NewtonOptions<Scalar>& opt, Scalar h,
                                 State<Scalar>& out, IncrementHistory<Scalar>* history) {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  // [P2]: from the history only when it predicted the last step well (trusted).
  const bool from_history = history && history->trusted(h) && opt.reuse_tangent > Scalar(0);
  ImplicitStart<Scalar> start;
  Matrix3 K, K_inv;
  StepReport<Scalar> rep;
  // The branch rule at the root y; `carried_tangent`: the fold sign from det K⁻¹ of the
  // tangent a history solve corrected with last (which may be the carried one).
  const auto branch = [&](bool carried_tangent) {
    const ImplicitRoot<Scalar> root = problem.root(start.unknown);
    const Scalar orientation = carried_tangent ? problem.orientation_inverse(K_inv) : problem.orientation(K);
    if (!on_branch(opt, root.angle, Scalar((root.increment - start.predicted).norm()), orientation))
      rep.status = StepStatus::wrong_branch;
    return rep.ok();
  };
  bool solved = false;
  Vector3 extrapolated = Vector3::Zero();  // [P1] (from_history only), kept for the history's record
  if (from_history) {
    // [P1] the extrapolated increment, [P3] the carried tangent.
    extrapolated = history->extrapolate();
    start = problem.from_history(extrapolated);
    K_inv = history->tangent_inverse;
    rep = newton(problem.residual(), start.unknown, opt,
                 NewtonSolve<Scalar>{.x_scale = start.size, .tangent = &K, .carried = &K_inv, .start_from_carried = true});
    solved = rep.ok() && branch(true);
  }
  if (!solved) {
    // The memoryless step (and the fallback [P2] when the history's solve failed).
    const StepReport<Scalar> spent = rep;  // the history solve's work, if any
    start = problem.memoryless();
    rep = newton(problem.residual(), start.unknown, opt,
                 NewtonSolve<Scalar>{.x_scale = start.size, .tangent = &K, .carried = &K_inv});
    rep.add_work(spent);
    if (!rep.ok() || !branch(false)) return rep;
  }
  problem.advance(start.unknown, out);
  // The step's one check of its result (the Stepper leaves it to the scheme:
  // writes_memory_on_success, scheme.hpp), before the memory is written.
  if (!committable(out)) rep.status = StepStatus::non_finite;
  if (rep.ok() && history) history->record(problem.recorded(start.unknown), h, K_inv, from_history ? &extrapolated : nullptr);
  return rep;
}

}  // namespace trompo::detail
