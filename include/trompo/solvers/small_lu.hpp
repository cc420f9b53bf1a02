#pragma once
// LU factorisation with partial pivoting of a small fixed-size matrix (N = 3 or 4: the
// tangents of the family schemes, docs/theory.md §11), written out in plain loops.
//
// Why not Eigen::PartialPivLU: the arithmetic is the same Doolittle elimination with the
// largest pivot of each column, but Eigen's version and its rcond() estimator instantiate
// the general triangular-solve and block machinery, which costs g++ 12 about 10 s of compile
// time per (N, Scalar) pair (measured on a 2-core machine: 2.6 s for a file that only builds
// the matrices, 8.4 s with PartialPivLU::solve for N = 3 and 4, 12.4 s with rcond() too).
// Every translation unit that steps a family scheme paid it once per scalar type. Here it is
// a few dozen lines, no allocation, and rcond() is exact rather than estimated.
#include <Eigen/Core>
#include <cmath>
#include <utility>

namespace trompo::detail {

/// PA = LU of an N×N matrix A, L unit lower triangular, by Gaussian elimination with
/// partial pivoting (the first largest |a_ik| of column k below the diagonal).
template <int N, class Scalar>
class SmallLU {
 public:
  /// An N-vector of Scalar.
  using VectorN = Eigen::Matrix<Scalar, N, 1>;
  /// An N×N matrix of Scalar.
  using MatrixN = Eigen::Matrix<Scalar, N, N>;

  /// Factorises A (any A: a zero pivot marks it singular, and rcond() is then 0).
  explicit SmallLU(const MatrixN& A) : lu_(A) {
    using std::abs;
    for (int j = 0; j < N; ++j) {
      Scalar column = Scalar(0);
      for (int i = 0; i < N; ++i) column += abs(A(i, j));
      if (column > norm1_) norm1_ = column;  // ‖A‖₁, the largest column sum
    }
    for (int k = 0; k < N; ++k) {
      int p = k;
      for (int i = k + 1; i < N; ++i)
        if (abs(lu_(i, k)) > abs(lu_(p, k))) p = i;
      pivot_[k] = p;
      if (lu_(p, k) == Scalar(0)) {
        singular_ = true;
        continue;
      }
      if (p != k)
        for (int j = 0; j < N; ++j) std::swap(lu_(k, j), lu_(p, j));
      for (int i = k + 1; i < N; ++i) {
        lu_(i, k) /= lu_(k, k);  // l_ik
        for (int j = k + 1; j < N; ++j) lu_(i, j) -= lu_(i, k) * lu_(k, j);
      }
    }
  }

  /// x with A x = b (meaningless if A is singular: check rcond() first).
  VectorN solve(const VectorN& b) const {
    VectorN x = b;
    for (int k = 0; k < N; ++k) std::swap(x(k), x(pivot_[k]));  // P b
    for (int i = 1; i < N; ++i)                                   // L z = P b
      for (int j = 0; j < i; ++j) x(i) -= lu_(i, j) * x(j);
    for (int i = N - 1; i >= 0; --i) {  // U x = z
      for (int j = i + 1; j < N; ++j) x(i) -= lu_(i, j) * x(j);
      x(i) /= lu_(i, i);
    }
    return x;
  }

  /// The reciprocal condition number in the 1-norm, 1/(‖A‖₁‖A⁻¹‖₁), with A⁻¹ solved
  /// column by column (exact, where Eigen's rcond() estimates ‖A⁻¹‖₁ from below); 0 for
  /// a singular or zero A.
  Scalar rcond() const {
    if (singular_ || norm1_ == Scalar(0)) return Scalar(0);
    Scalar inverse_norm1(0);
    for (int j = 0; j < N; ++j) {
      const VectorN column = solve(VectorN::Unit(j));
      const Scalar sum = column.cwiseAbs().sum();
      if (sum > inverse_norm1) inverse_norm1 = sum;
    }
    return Scalar(1) / (norm1_ * inverse_norm1);
  }

 private:
  MatrixN lu_;
  int pivot_[N] = {};
  Scalar norm1_ = Scalar(0);
  bool singular_ = false;
};

}  // namespace trompo::detail
