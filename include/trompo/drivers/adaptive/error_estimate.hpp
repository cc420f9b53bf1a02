#pragma once
// The adaptive driver's error estimates (docs/adaptive.md; docs/theory.md §16, [A2], [A8], [D4]).
//
// An estimate turns what an attempt produced into r², r the RMS error norm per unit step
// [A2] (ErrorNorm): the attempt is accepted when r ≤ 1, and r drives the step controller
// (drivers/adaptive/step_controller.hpp). Each estimate is a small type satisfying the
// concept ErrorEstimator: its `Attempt` names what it reads, `squared_error` measures it.
//  - DefectEstimate [D4]: one step Ψ_h(y); the integral of the defect u' − f(u) of the
//    step's Lie–Hermite interpolant u (drivers/dense_output.hpp), Simpson's rule at order 2,
//    Hermite's at orders 4 and 6;
//  - RichardsonEstimate [A8]: m steps of h/m (the run advances with them) against one of h,
//    e = (Ψ_{h/m}^m − Ψ_h)/(m^p − 1); doubling is m = 2.
// Which attempt to take (one step, or m + 1) is the driver's; choose_estimate() reads
// AdaptiveOptions::estimate. Squares throughout: no square root lies between the estimate
// and the controller.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <concepts>
#include <limits>

#include "trompo/drivers/dense_output.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// How tolerance mode estimates the error of a step [A3].
enum class ErrorEstimate {
  automatic,   ///< richardson where the error scales with the load (the splitting); else defect up to order 6, doubling above
  defect,      ///< the defect of the step's Lie–Hermite interpolant [D4]: the step plus 1–2 evaluations of Ω̇
  doubling,    ///< richardson with m = 2: Ψ_{2h} against Ψ_h∘Ψ_h, three steps per two
  richardson   ///< Ψ_{mh} against Ψ_h^m, advancing with the m steps [A8]: m + 1 steps per m
};

/// The RMS error norm per unit step [A2], squared: for an estimate (e_ξ, e_Ω) of a step
/// a → b of span h, r = RMS(|e_ξ|/(s_Λ|h|/T + 8ε), |e_Ω|/(s_Ω|h|/T + 8ε|Ω|)) with
/// s_Λ = atol + rtol, s_Ω = atol + rtol·|Ω|, |Ω| the larger of |Ω_a| and |Ω_b|, T the span the
/// tolerances are spread over; accepted when r ≤ 1. The 8ε terms are the estimate's
/// round-off (measured ≤ 5ε and ≤ 2ε|Ω| on the standard cases): a step is never refused for
/// its rounding, which does not shrink with h.
template <class Scalar>
struct ErrorNorm {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  Scalar atol = Scalar(0);  ///< absolute tolerance (rad and rad/s)
  Scalar rtol = Scalar(0);  ///< relative tolerance
  Scalar span = Scalar(1);  ///< T: the end error is held to tol (1: the error per unit time)
  /// r² of the estimate (e_rot, e_om) of a step of span h, given |Ω_a|² and |Ω_b|².
  Scalar squared(const Vector3& e_rot, const Vector3& e_om, Scalar omega2_a, Scalar omega2_b, Scalar h) const {
    using std::abs;
    using std::sqrt;
    constexpr Scalar noise = Scalar(8) * std::numeric_limits<Scalar>::epsilon();
    const Scalar w = sqrt(std::max(omega2_a, omega2_b));
    const Scalar per_step = abs(h) / span;  // error per unit step against tol/T
    const Scalar s_rot = (atol + rtol) * per_step + noise;
    const Scalar s_om = (atol + rtol * w) * per_step + noise * w;
    return (e_rot.squaredNorm() / (s_rot * s_rot) + e_om.squaredNorm() / (s_om * s_om)) / Scalar(2);
  }
};

/// An error estimate of the adaptive driver: from what an attempt produced (its `Attempt`),
/// r² in the norm of [A2] (`squared_error`).
template <class E>
concept ErrorEstimator = requires(const E& e, const typename E::Attempt& attempt,
                                  const ErrorNorm<typename E::Scalar>& norm) {
  typename E::Scalar;
  typename E::Attempt;
  { e.squared_error(norm, attempt) } -> std::same_as<typename E::Scalar>;
};

/// The defect estimate [D4]: the local error of one step Ψ_h(y) as the integral of the
/// defect of its Lie–Hermite interpolant (defect_estimate(), drivers/dense_output.hpp).
template <class Scene>
struct DefectEstimate {
  /// The scene's scalar.
  using Scalar = typename Scene::Scalar;
  /// What the attempt produced: the nodes at the step's ends and its interpolant.
  struct Attempt {
    const DenseNode<Scalar>& a;        ///< the start node (Ω̇, and Ω̈ for Hermite's rule)
    const DenseNode<Scalar>& b;        ///< the end node, the step's state
    const LieHermite<Scalar>& segment; ///< the interpolant between them
    Scalar h;                          ///< the step
  };
  const Scene* scene = nullptr;           ///< the scene whose Ω̇ the defect evaluates
  DefectRule rule = DefectRule::simpson;  ///< Simpson's (order 2) or Hermite's (orders 4, 6)
  /// The rule for a scheme of order p: Simpson's at order 2 (the cubic interpolant, no Ω̈),
  /// Hermite's above (the quintic).
  static DefectRule rule_for(int p) { return p <= 2 ? DefectRule::simpson : DefectRule::hermite; }
  /// Whether the estimate's interpolant is the quintic (it needs the nodes' Ω̈).
  bool quintic() const { return rule != DefectRule::simpson; }
  /// r² of the step's defect [D4] in the norm of [A2].
  Scalar squared_error(const ErrorNorm<Scalar>& norm, const Attempt& at) const {
    Eigen::Matrix<Scalar, 3, 1> e_rot, e_om;
    defect_estimate(*scene, at.a, at.b, at.segment, rule, e_rot, e_om);
    return norm.squared(e_rot, e_om, at.a.state.omega.squaredNorm(), at.b.state.omega.squaredNorm(), at.h);
  }
};

namespace detail {
/// x^n for n ≥ 0 by squarings.
template <class Scalar>
Scalar integer_power(Scalar x, int n) {
  Scalar result(1);
  for (; n > 0; n >>= 1, x *= x)
    if (n & 1) result *= x;
  return result;
}
}  // namespace detail

/// Richardson's estimate [A8] of an attempt of span h: m steps of h/m (`fine`, the run
/// advances with them) against one step of h (`coarse`), both from `start`:
/// e = (Ψ_{h/m}^m − Ψ_h)/(m^p − 1), the m steps' error. Doubling is m = 2.
template <class ScalarType>
struct RichardsonEstimate {
  /// The scalar.
  using Scalar = ScalarType;
  /// What the attempt produced.
  struct Attempt {
    const State<Scalar>& start;   ///< the state the attempt started from
    const State<Scalar>& coarse;  ///< Ψ_h(start)
    const State<Scalar>& fine;    ///< Ψ_{h/m}^m(start)
    Scalar h;                     ///< the attempt's span
    int steps;                    ///< m (1: an attempt of a few ulp of t, nothing to estimate)
  };
  int order = 2;  ///< the scheme's order p
  /// r² of (fine − coarse)/(m^p − 1) in the norm of [A2], the error per unit step.
  Scalar squared_error(const ErrorNorm<Scalar>& norm, const Attempt& at) const {
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    if (at.steps == 1) return Scalar(0);  // a few ulp of t: nothing to estimate
    const Scalar k = detail::integer_power(Scalar(at.steps), order) - Scalar(1);  // m^p − 1
    const Vector3 e_rot = (at.coarse.rotation.inverse() * at.fine.rotation).log() / k;
    const Vector3 e_om = (at.fine.omega - at.coarse.omega) / k;
    return norm.squared(e_rot, e_om, at.start.omega.squaredNorm(), at.fine.omega.squaredNorm(), at.h);
  }
};

namespace detail {
/// The estimate a run takes: the defect, or Richardson's with m steps per attempt.
struct EstimateChoice {
  bool defect = false;  ///< the defect estimate [D4] (m = 1)
  int m = 1;            ///< steps per attempt
};
/// AdaptiveOptions::estimate resolved for a scheme of order p (automatic: Richardson's where
/// the error scales with the load, the defect up to order 6, above it doubling, or
/// Richardson's with the m given); m from `substeps` (0: 8, doubling 2) [A8].
inline EstimateChoice choose_estimate(ErrorEstimate e, int p, bool error_scales_with_load, int substeps) {
  if (e == ErrorEstimate::automatic)  // above order 6: doubling, or Richardson's with the m given
    e = error_scales_with_load ? ErrorEstimate::richardson
        : p <= 6               ? ErrorEstimate::defect
        : substeps != 0        ? ErrorEstimate::richardson
                               : ErrorEstimate::doubling;
  EstimateChoice c;
  c.defect = e == ErrorEstimate::defect;
  c.m = c.defect ? 1 : substeps != 0 ? substeps : e == ErrorEstimate::doubling ? 2 : 8;
  return c;
}
}  // namespace detail

static_assert(ErrorEstimator<RichardsonEstimate<double>>);

}  // namespace trompo
