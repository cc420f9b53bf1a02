#pragma once
// The skeleton that ComposedStepper (composition.hpp) and ProcessedStepper
// (processed_composition.hpp) share: a step of either is a sequence of base steps of sizes
// w_k·h, each a Stepper<Scheme, Scene> step (commit-on-success, its own h check), of a
// base scheme that must be symmetric (compile time: its traits; run time: its parameters).
// What differs between the two is the schedule (coefficients.hpp) and how a failed
// sequence is undone, which stay in each stepper.
#include <cstddef>
#include <utility>

#include "trompo/errors.hpp"
#include "trompo/model/state.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/solvers/newton.hpp"
#include "trompo/steppers/stepper.hpp"

namespace trompo::detail {

/// The base stepper of a composition, its accessors, and the loop over its base steps.
template <class Scheme, class Scene_>
  requires SchemeFor<Scheme, Scene_>
class CompositionCore {
  static_assert(Scheme::traits.symmetric,
                "composition: this scheme is not symmetric (its traits say `.symmetric = false`), so composing "
                "it does not raise its order; step it with Stepper<Scheme, Scene> instead");

 public:
  /// The scene type.
  using Scene = Scene_;
  /// The scalar type of the scene.
  using Scalar = typename Scene::Scalar;
  /// The stepper of one sub-step.
  using Base = Stepper<Scheme, Scene>;
  /// The memory of the base scheme (NoMemory for a memoryless one such as Simo-α).
  using BaseMemory = typename Base::Memory;

  /// What the composition keeps exactly: what its base scheme keeps (every sub-step is a
  /// base step).
  Keeps keeps() const { return base_.keeps(); }
  /// The stepper of one sub-step.
  const Base& base() const { return base_; }
  /// The base scheme.
  const Scheme& scheme() const { return base_.scheme(); }
  /// The scene.
  const Scene& scene() const { return base_.scene(); }
  /// The scene, to change between steps (drivers/sampled.hpp).
  Scene& scene() { return base_.scene(); }
  /// The Newton options of every sub-step.
  const NewtonOptions<Scalar>& options() const { return base_.options(); }
  /// The Newton options of every sub-step, to modify.
  NewtonOptions<Scalar>& options() { return base_.options(); }

 protected:
  /// The base stepper (its constructor validates the scheme's parameters).
  CompositionCore(Scheme scheme, Scene scene, NewtonOptions<Scalar> options)
      : base_(std::move(scheme), std::move(scene), options) {}

  /// Throws invalid_input, the message starting with `what`, if the base scheme with its
  /// parameters is not symmetric (Simo-α with α ≠ ½).
  template <class... What>
  void require_symmetric(const What&... what) const {
    if (!base_.symmetric())
      fail(what..., " needs a symmetric base scheme; ", Scheme::name,
           " with these parameters is not symmetric (Simo-alpha needs alpha = 0.5)");
  }

  /// Base steps weight(0)·h, …, weight(n − 1)·h on `s`, sub-step k with memory memory_of(k),
  /// `before(k)` called first (to save what sub-step k may change). Stops at the first
  /// failure: the report sums the sub-steps' work (StepReport::absorb) and carries the
  /// failed one's status, `s` is then partly advanced and the caller restores. On success
  /// s.time = t_end exactly (Σw·h differs from the intended sum by round-off).
  template <class Weight, class MemoryOf, class Before>
  StepReport<Scalar> base_steps(State<Scalar>& s, std::size_t n, Weight&& weight, Scalar h, Scalar t_end,
                                MemoryOf&& memory_of, Before&& before) const {
    StepReport<Scalar> total;
    const Scalar t_start = s.time;
    [[maybe_unused]] Scalar c(0);  // Σ_{j<k} weight(j): sub-step k starts at t_start + c·h (with wheels)
    for (std::size_t k = 0; k < n; ++k) {
      before(k);
      // The compensated state's residue (docs/theory.md §18) belongs to the state, not to a
      // sub-step index: each sub-step starts from the one the sub-step before it left
      // (the first from the last sub-step of the previous step).
      if constexpr (requires(BaseMemory& m) { m.residue; })
        memory_of(k).residue = memory_of((k + n - 1) % n).residue;
      Scalar dt = weight(k) * h;
      [[maybe_unused]] Scalar t_next = t_end;  // where sub-step k ends (with wheels)
      if constexpr (Scene::has_wheels) {
        // With wheels, the clock of a composed step (docs/theory.md [W4]): sub-step k spans
        // t_{k+1} − t_k between times t_k = t_start + c_k·h rounded once each, the last ending
        // at t_end itself (as integrate.hpp's attempt() does for whole steps), so that the
        // sub-steps cover t_end − t_start exactly and h_w(t) telescopes from one to the next.
        c += weight(k);
        if (k + 1 < n) t_next = t_start + c * h;
        dt = t_next - s.time;
      }
      total.absorb(base_.step(s, memory_of(k), dt));
      if (!total.ok()) return total;
      if constexpr (Scene::has_wheels) s.time = t_next;
    }
    s.time = t_end;
    return total;
  }


  Base base_;
};

}  // namespace trompo::detail
