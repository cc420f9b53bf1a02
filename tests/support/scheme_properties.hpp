#pragma once
// The generic property suite over the scheme registry (include/trompo/schemes/registry.hpp):
// every registered scheme, and every composition of it the tools run (ComposedStepper with
// Suzuki-5 and ProcessedStepper, where the registry lets the tools compose it), is checked
// for what its traits declare. Two files, so that the two halves build in parallel and each
// in the build that needs it (tests/CMakeLists.txt):
//  - test_properties_numbers.cpp: its order, observed from a Δt sweep against the
//    closed-form references (HT1: the scheme; FB1: the scheme and its compositions); every
//    invariant it declares it keeps (keeps<Scene>: H, μ, π, or H decaying) on HT1 and FB1,
//    and an orthonormal attitude whatever it keeps; float and long double against the
//    double run;
//  - test_properties_contracts.cpp (a contract test: built under the sanitizers): the
//    failure contract (a failed step, h = NaN, a starved Newton, h far too large, leaves the
//    state and the memory bit for bit as they were); backward steps (h < 0: a run forward
//    and back returns to the start, exactly to round-off for a symmetric stepper, to its
//    order otherwise); no heap allocation in a step.
// A scheme added to the registry is tested by both with no other edit. Files per scheme keep
// only what is specific to it.
#include <array>
#include <cstring>
#include <string>

#include "support/trompo_test.hpp"
#include "trompo/trompo.hpp"

namespace trompo_test::properties {

using Entries = trompo::RegisteredSchemes::Tuple;

/// Calls f(stepper, order, label) for each stepper of registry entry Entry on `scene`: the
/// plain Stepper and, where the registry lets the tools compose it, ComposedStepper with
/// Suzuki-5 (order 4) and the ProcessedStepper (order 6).
template <class Entry, class SceneT, class F>
void for_each_stepper(const SceneT& scene, F&& f, trompo::NewtonOptions<typename SceneT::Scalar> options = {}) {
  using S = typename Entry::Scheme;
  const S scheme{};
  f(trompo::Stepper<S, SceneT>(scheme, scene, options), trompo::order_of_accuracy(scheme), "plain");
  if constexpr (Entry::compositions == trompo::Compositions::symmetric) {
    if (trompo::symmetric(scheme)) {
      f(trompo::ComposedStepper<S, SceneT>(scheme, scene, trompo::Composition::suzuki5, options), 4, "suzuki-5");
      f(trompo::ProcessedStepper<S, SceneT>(scheme, scene, options), 6, "blanes-casas-murua-13");
    }
  }
}

/// Whether a stepper is symmetric: a symmetric scheme, plain or composed by Suzuki-5 (the
/// processed stepper re-primes its processors when h changes sign, so h then −h is not the
/// identity there).
template <class St>
bool symmetric_stepper(const St& st, const char* label) {
  return trompo::symmetric(st.scheme()) && std::string(label) != "blanes-casas-murua-13";
}

/// ‖Λ − Λref‖_F + ‖Ω − Ωref‖/‖Ωref‖ against a reference row.
template <class StateT>
double error_to(const StateT& s, const trompo_test::Reference& ref) {
  return (s.rotation.matrix().template cast<double>() - ref.rotation()).norm() +
         (s.omega.template cast<double>() - ref.angular_velocity()).norm() / ref.angular_velocity().norm();
}

/// n steps of h along a trajectory from s0; false if a step failed.
template <class St>
bool advance(const St& st, typename St::TrajectoryType& traj, typename St::Scalar h, long n) {
  for (long k = 0; k < n; ++k)
    if (!st.step(traj, h).ok()) return false;
  return true;
}

/// The bytes of an object (its memory), to compare after a failed step.
template <class T>
std::array<unsigned char, sizeof(T)> bytes_of(const T& x) {
  std::array<unsigned char, sizeof(T)> b;
  std::memcpy(b.data(), &x, sizeof(T));
  return b;
}

}  // namespace trompo_test::properties
