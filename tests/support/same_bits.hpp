#pragma once
// Bit-for-bit equality of two states (NaN-safe, -0 ≠ +0): the "a failed step loses
// nothing" check shared by the robustness and hard-case tests. (fuzz/fuzz_check.hpp keeps
// its own copy: the fuzz build sees include/ only.)
#include <cstring>

#include "trompo/model/state.hpp"

namespace trompo_test {

template <class Scalar>
bool same_bits(const trompo::State<Scalar>& a, const trompo::State<Scalar>& b) {
  return std::memcmp(a.omega.data(), b.omega.data(), sizeof(Scalar) * 3) == 0 &&
         std::memcmp(a.rotation.unit_quaternion().coeffs().data(), b.rotation.unit_quaternion().coeffs().data(),
                     sizeof(Scalar) * 4) == 0 &&
         std::memcmp(&a.time, &b.time, sizeof(Scalar)) == 0;
}

}  // namespace trompo_test
