#pragma once
// Error-free transformations (docs/theory.md §18 [K1]): a sum or a square written as the
// rounded result plus its exact rounding error, the building blocks of the compensated
// state (schemes/state_residue.hpp).
#include <limits>

namespace trompo::detail {

/// A value carried as hi + lo, |lo| ≤ ulp(hi)/2 after a two_sum.
template <class Scalar>
struct Carried {
  Scalar hi;  ///< the rounded value
  Scalar lo;  ///< what rounding left out
};

/// a + b = s + e exactly, s = fl(a + b) (Knuth's TwoSum, any order of magnitude) [K1].
template <class Scalar>
Carried<Scalar> two_sum(Scalar a, Scalar b) {
  const Scalar s = a + b;
  const Scalar bb = s - a;
  const Scalar e = (a - (s - bb)) + (b - bb);
  return {s, e};
}

/// a² = p + e exactly, p = fl(a²) (Dekker's product, a split into two halves of its
/// significand) [K1]. Not std::fma: without -mfma it is a call into libm (measured: two of
/// them were a third of the compensated step's overhead).
template <class Scalar>
Carried<Scalar> two_square(Scalar a) {
  constexpr int half = (std::numeric_limits<Scalar>::digits + 1) / 2;
  const Scalar splitter = Scalar((1ULL << half) + 1);  // 2^⌈p/2⌉ + 1
  const Scalar c = splitter * a;
  const Scalar a_hi = c - (c - a);
  const Scalar a_lo = a - a_hi;
  const Scalar p = a * a;
  return {p, ((a_hi * a_hi - p) + Scalar(2) * a_hi * a_lo) + a_lo * a_lo};
}

}  // namespace trompo::detail
