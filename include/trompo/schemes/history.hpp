#pragma once
// The memory of the implicit energy-momentum schemes: the last accepted increments and
// the inverse tangent of the last step, for the history predictor (docs/theory.md §13,
// [P1]–[P3]).
//
// The increment x_n of step n (Θ for the Simo family, e for Géradin–Bauchau) is, at a
// fixed h, a smooth function of t_n: x_n = h·Ω(t_n + h/2) + O(h³) with smooth
// coefficients. The polynomial of degree p through the last p + 1 increments therefore
// predicts the next one with an error O(h·(hν)^{p+1}), ν the rate at which Ω turns in the
// body frame [P1]; today's predictor, hΩ_n + (h²/2)Ω̇_n, is O(h·(hν)²). The prediction is
// only a starting point: Newton's acceptance is unchanged, so the step's exactness does
// not depend on it.
//
// Fresh memory (count 0), a different h, or too short a history: the scheme uses its
// own predictor and a fresh tangent, exactly as a memoryless step. A failed step leaves
// the memory as it was (the Stepper commits memory on success only), and the step that
// used the history retries once without it before it reports failure.
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <limits>

namespace trompo {

/// The per-trajectory memory of SimoKappa, SimoCollocation and GeradinBauchau (with
/// their history predictor on): the last accepted increments of one step size h, newest
/// first, and the inverse Newton tangent of the last step. Default-constructed: fresh.
template <class Scalar>
struct IncrementHistory {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// Increments kept: the predictor is the polynomial of degree depth − 1 through them.
  static constexpr int depth = 6;

  std::array<Vector3, depth> increment = zeros();  ///< x_{n−1}, x_{n−2}, … (newest first)
  Matrix3 tangent_inverse = Matrix3::Zero();       ///< K⁻¹ of the last accepted step
  Scalar h = Scalar(0);  ///< the step size the increments were taken with
  /// ‖x − x_extrapolated‖/‖x‖ at the last step (infinite until measured): how well the
  /// extrapolation predicted it, whether or not the step started from it [P2].
  Scalar miss = std::numeric_limits<Scalar>::infinity();
  int count = 0;         ///< valid entries of `increment` (0: fresh)
  /// The largest `miss` at which the next step starts from the history. Above it (h too
  /// large for the motion: the extrapolation's error grows like (hν)⁶) the step starts
  /// memoryless, as before this memory existed. Conservative: with the 10⁴× chord rule of
  /// newton.hpp, 1e-4 and 1e-2 were measured as safe too (HT2 triple jump, anisotropic
  /// top) and slightly cheaper there; see docs/theory.md §13.2.
  static constexpr double trust = 1e-6;

  /// depth zero vectors (a fresh memory is all zeros: copies of it are well defined).
  static std::array<Vector3, depth> zeros() {
    std::array<Vector3, depth> z;
    for (auto& x : z) x.setZero();
    return z;
  }

  /// Whether two step sizes count as one h (relative 1e-9): the steps t_{n+1} − t_n of a
  /// run held at one h differ by the rounding of t (relative ulp(t)/h; an adaptive run's
  /// steps are such differences), and an h off by δh/h shifts the extrapolation by as much,
  /// far below the trust gate.
  static bool same_step(Scalar a, Scalar b) {
    using std::abs;
    return a == b || abs(a - b) <= Scalar(1e-9) * abs(b);
  }

  /// Whether a step of size `h_now` may extrapolate: the history is full and of that h.
  bool ready(Scalar h_now) const { return count == depth && same_step(h, h_now); }

  /// Whether a step of size `h_now` starts from the history (extrapolated increment and
  /// carried tangent): ready, and the extrapolation predicted the last step to `trust`.
  bool trusted(Scalar h_now) const { return ready(h_now) && miss <= Scalar(trust); }

  /// The next increment: the quintic through the last six at equal spacing [P1] (the
  /// sixth difference set to zero),
  ///   x_n ≈ 6x_{n−1} − 15x_{n−2} + 20x_{n−3} − 15x_{n−4} + 6x_{n−5} − x_{n−6}.
  /// Degree 5 rather than 3 or 4: measured on HT1 at h = 1e-3, Simo-κ needs 2.91 (cubic),
  /// 2.39 (quartic) and 2.00 (quintic) residual evaluations per step.
  Vector3 extrapolate() const {
    static_assert(depth == 6, "IncrementHistory::extrapolate: the weights are those of depth 6");
    return Scalar(6) * (increment[0] + increment[4]) - Scalar(15) * (increment[1] + increment[3]) +
           Scalar(20) * increment[2] - increment[5];
  }

  /// Records the accepted increment `x` of a step of size `h_step` and the inverse
  /// tangent it was solved with; a different h starts the history afresh [P2].
  /// `extrapolated`, if given, is extrapolate() as the step computed it (for its
  /// predictor), so that it is not computed twice.
  void record(const Vector3& x, Scalar h_step, const Matrix3& K_inv, const Vector3* extrapolated = nullptr) {
    if (ready(h_step)) {
      const Scalar size = x.norm(), off = (x - (extrapolated ? *extrapolated : extrapolate())).norm();
      miss = size > Scalar(0) ? off / size : (off == Scalar(0) ? Scalar(0) : std::numeric_limits<Scalar>::infinity());
    } else {
      miss = std::numeric_limits<Scalar>::infinity();
    }
    if (!same_step(h_step, h)) count = 0;
    for (int i = depth - 1; i > 0; --i) increment[static_cast<std::size_t>(i)] = increment[static_cast<std::size_t>(i - 1)];
    increment[0] = x;
    tangent_inverse = K_inv;
    h = h_step;
    if (count < depth) ++count;
  }

  /// Forgets everything (the next step predicts as a memoryless one).
  void clear() {
    count = 0;
    miss = std::numeric_limits<Scalar>::infinity();
  }
};

}  // namespace trompo
