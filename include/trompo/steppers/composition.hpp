#pragma once
// ComposedStepper<Scheme, Scene>: order 4, 6 or 8 from a symmetric second-order scheme by
// symmetric composition (docs/theory.md §6, §13 [P4]).
//
//   ComposedStepper<SimoKappa, HeavyTop<double>> stepper(SimoKappa{}, scene, 4);
//   StepReport<double> rep = stepper.step(state, h);   // three sub-steps γ_i h
//
// One composed step of size h is the product of base steps of sizes γ_1 h, …, γ_s h with
// Σγ_i = 1 and γ_i = γ_{s+1−i}. If the base step Φ_h is symmetric (Φ_{−h} = Φ_h⁻¹) and of
// order 2, the composition is symmetric and of order 4 (triple jump, s = 3, or Suzuki's
// s = 5), 6 (Kahan–Li, s = 9) or 8 (McLachlan, s = 15; Kahan–Li, s = 17):
//
//   ComposedStepper<SimoKappa, HeavyTop<double>> s5(SimoKappa{}, scene, Composition::suzuki5);
//
// Which order-4 set to use: the triple jump is the cheapest per step, but its middle
// step −1.70h is long and backward, and its error constant is large. Suzuki's five steps
// (four of 0.41h, one of −0.66h) cost 5/3 as much per step and, measured on HT1 to
// t = 10, had a 50–800× smaller attitude error at the same h (docs/accuracy.md):
// for a given accuracy it is the cheaper of the two.
// Every sub-step is a step of the base scheme, so whatever it conserves exactly (H and μ
// for Simo-κ, collocation and Géradin–Bauchau; μ for Simo-α ½; π for the free body) the
// composition conserves too. Negative γ_i are steps backward in time, which the base
// schemes support.
//
// Only symmetric bases may be composed to order 4/6/8: a scheme type whose trait says it is
// not symmetric (RK4) is rejected at compile time, a scheme whose parameters make it
// non-symmetric (Simo-α with α ≠ ½: order 1) at construction. Order 2 is the base scheme
// itself, one step, whatever the scheme.
//
// A base scheme with memory (scheme.hpp) gets one memory per sub-step index: sub-step i
// of a composed step sees what sub-step i of the previous composed step left, since the
// sub-steps differ in size and sign. The composed stepper's Memory is that array.
//
// The order proof also needs the base step to be a smooth function of h. Simo collocation
// with the closed-form α of [T2] is not, on fast tops: α is the root nearest ½, and where
// f″(½) changes sign (every nutation turn of HT0/HT1) the two roots ½ ± 1/√12 swap and α
// jumps. Each such step adds an O(h³) error that the weights do not cancel, so composed
// collocation is of order ≈ 3 there (orders 4 and 6 where f″ keeps its sign, e.g. a
// swinging body). H and μ stay exact either way. See tests/test_composition.cpp.
#include <array>
#include <cmath>
#include <memory>  // std::construct_at, std::destroy_at (ComposedStepper::step)
#include <type_traits>
#include <utility>

#include "trompo/errors.hpp"
#include "trompo/model/state.hpp"
#include "trompo/schemes/coefficients.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/solvers/newton.hpp"
#include "trompo/steppers/composition_core.hpp"
#include "trompo/steppers/stepper.hpp"

namespace trompo {

namespace detail {
/// No flow between the sub-steps (ComposedStepper::step's default).
struct NoFlow {};

/// The memory of a composed stepper: one base memory per sub-step index, or nothing.
template <class BaseMemory, int N>
struct composed_memory {
  using type = std::array<BaseMemory, N>;
};
template <int N>
struct composed_memory<NoMemory, N> {
  using type = NoMemory;
};
}  // namespace detail

/// Order 4, 6 or 8 from a symmetric order-2 scheme by symmetric composition (docs/theory.md §6, §13):
/// one step of size h is the base steps γ_1 h, …, γ_s h. Keeps whatever the base keeps.
/// The base stepper, its accessors and the loop over the sub-steps are the composition
/// core's (composition_core.hpp), shared with ProcessedStepper.
template <class Scheme, class Scene_>
  requires SchemeFor<Scheme, Scene_>
class ComposedStepper : public detail::CompositionCore<Scheme, Scene_> {
  using Core = detail::CompositionCore<Scheme, Scene_>;

 public:
  /// The scene type.
  using Scene = Scene_;
  /// The scalar type of the scene.
  using Scalar = typename Scene::Scalar;
  /// The stepper of one sub-step.
  using Base = typename Core::Base;
  /// The memory of the base scheme (NoMemory for a memoryless one such as RK4 or Simo-α).
  using BaseMemory = typename Core::BaseMemory;
  /// One base memory per sub-step index (NoMemory for a memoryless base).
  using Memory = typename detail::composed_memory<BaseMemory, CompositionCoefficients<Scalar>::max_stages>::type;
  /// A state with the composed memory (one base memory per sub-step index).
  using TrajectoryType = Trajectory<Scalar, Memory>;

  /// `order` is 2 (the base scheme, one step), 4 (triple jump, 3 sub-steps) or 6
  /// (Kahan–Li, 9 sub-steps); anything else throws invalid_input, as does order 4/6 on a
  /// non-symmetric base (Simo-α with α ≠ ½).
  ComposedStepper(Scheme scheme, Scene scene, int order, NewtonOptions<Scalar> options = {})
      : ComposedStepper(std::move(scheme), std::move(scene), composition_of_order(order), options) {}

  /// A named composition (Composition::suzuki5 for Suzuki's order-4 set,
  /// Composition::kahan_li17 or mclachlan15 for order 8).
  ComposedStepper(Scheme scheme, Scene scene, Composition method, NewtonOptions<Scalar> options = {})
      : Core(std::move(scheme), std::move(scene), options), coefficients_(CompositionCoefficients<Scalar>::of(method)) {
    if (coefficients_.order > 2) this->require_symmetric("composition: order ", coefficients_.order, " (", to_string(method), ")");
  }

  /// A trajectory starting at `s`, with fresh memory.
  TrajectoryType start(const State<Scalar>& s) const { return TrajectoryType(s); }

  /// Advances a trajectory by h; state and memory are committed on success only.
  StepReport<Scalar> step(TrajectoryType& traj, Scalar h) const { return step(traj.state(), traj.memory, h); }

  /// Advances `state` by h (memoryless base schemes, or memory that is only a hint:
  /// each such step starts from fresh memory).
  StepReport<Scalar> step(State<Scalar>& state, Scalar h) const {
    static_assert(memory_is_hint_v<Scheme, Scene>,
                  "ComposedStepper::step(State&, h): the base scheme carries memory between steps; step a "
                  "Trajectory instead (auto traj = stepper.start(state); stepper.step(traj, h))");
    Memory memory{};
    return step(state, memory, h);
  }

  /// Advances `state` by h through the sub-steps γ_i h. Same contract as Stepper::step:
  /// on failure of any sub-step, `state` and `memory` are untouched and the report carries
  /// that sub-step's status. `iterations` is the sum over the sub-steps taken, `residual`
  /// the largest sub-step residual.
  StepReport<Scalar> step(State<Scalar>& state, Memory& memory, Scalar h) const {
    return step(state, memory, h, detail::NoFlow{});
  }

  /// The step with an exact flow `flow(s, τ)` split around each sub-step (the sampled
  /// driver's wheel friction, docs/theory.md [W17]): the composition of the symmetric steps
  /// F(γ_ih/2) Φ_{γ_ih} F(γ_ih/2), adjacent flows merged, so that flow is called on the working
  /// state with τ = γ_1h/2 before the first sub-step, (γ_{i−1} + γ_i)h/2 before sub-step i and
  /// γ_sh/2 after the last; with a symmetric base and a flow with F_aF_b = F_{a+b} it is of the
  /// composition's order. The same contract; a flow that leaves Ω not finite fails the step as
  /// non_finite. (What else the flow changes, the wheels' hold, is the caller's to restore.)
  template <class Flow>
  StepReport<Scalar> step(TrajectoryType& traj, Scalar h, Flow&& flow) const {
    return step(traj.state(), traj.memory, h, flow);
  }
  /// The same on a plain State (memoryless base schemes, or memory that is only a hint).
  template <class Flow>
  StepReport<Scalar> step(State<Scalar>& state, Scalar h, Flow&& flow) const {
    static_assert(memory_is_hint_v<Scheme, Scene>,
                  "ComposedStepper::step(State&, h, flow): the base scheme carries memory between steps; step a "
                  "Trajectory instead");
    Memory memory{};
    return step(state, memory, h, flow);
  }
  /// The same on (state, memory).
  template <class Flow>
  StepReport<Scalar> step(State<Scalar>& state, Memory& memory, Scalar h, Flow&& flow) const {
    constexpr bool flows = !std::is_same_v<std::decay_t<Flow>, detail::NoFlow>;
    if (!flows && coefficients_.stages == 1) return this->base_.step(state, base_memory(memory, 0), h);
    if (StepReport<Scalar> refused = detail::check_step_size(h); !refused.ok()) return refused;
    State<Scalar> s = state;
    // Sub-step i steps its own entry memory[i] in place: the base Stepper changes it only
    // when that sub-step succeeds. Each entry is saved before its sub-step, and the saved
    // entries are put back if a later sub-step fails, so that a failed composed step
    // leaves the whole memory bit-identical. (Before: a copy of the whole memory, all
    // max_stages = 17 base memories, 4.2 kB for the history predictor, in and the used
    // entries out at every step: measured 10–17 % of a sub-step's time on HT1.) Only the
    // entries of this composition are saved: a slot is raw storage until its sub-step
    // copies the entry in (an array of std::optional was zero-filled whole, 4.2 kB, by
    // GCC 12 at every step), and the copies are destroyed at the end.
    union Slot {
      Slot() {}   // no initialisation: filled by construct_at before use
      ~Slot() {}  // destroyed by destroy_at below (only the filled ones)
      BaseMemory memory;
    };
    [[maybe_unused]] std::array<Slot, CompositionCoefficients<Scalar>::max_stages> saved;
    std::size_t filled = 0;
    const auto save = [&](std::size_t i) {
      if constexpr (!std::is_same_v<Memory, NoMemory>) {
        std::construct_at(&saved[i].memory, memory[i]);
        filled = i + 1;
      }
      if constexpr (flows)
        flow(s, (i == 0 ? coefficients_.gamma[0] : coefficients_.gamma[i - 1] + coefficients_.gamma[i]) * h / Scalar(2));
      else
        (void)i;
    };
    StepReport<Scalar> total = this->base_steps(
        s, static_cast<std::size_t>(coefficients_.stages), [&](std::size_t i) { return coefficients_.gamma[i]; }, h,
        state.time + h,  // Σγ_i h differs from h by round-off: end exactly at t_n + h, as Stepper does
        [&](std::size_t i) -> BaseMemory& { return base_memory(memory, static_cast<int>(i)); }, save);
    if constexpr (flows) {
      if (total.ok()) flow(s, coefficients_.gamma[static_cast<std::size_t>(coefficients_.stages - 1)] * h / Scalar(2));
      if (total.ok() && !detail::all_finite(s.omega)) total.status = StepStatus::non_finite;
    }
    // The sub-steps before the failed one (the last saved) changed their entries: undo them.
    if (!total.ok() && filled > 0) copy_used(saved, static_cast<int>(filled) - 1, memory);
    for (std::size_t i = 0; i < filled; ++i) std::destroy_at(&saved[i].memory);
    if (total.ok()) state = s;
    return total;
  }

  /// The order of the composition: 2, 4, 6 or 8.
  int order() const { return coefficients_.order; }
  /// Which composition.
  Composition method() const { return coefficients_.method; }
  /// Base steps per composed step (1, 3, 5, 9, 15 or 17): the cost factor over the base scheme.
  int stages() const { return coefficients_.stages; }
  /// The weights γ_i.
  const CompositionCoefficients<Scalar>& coefficients() const { return coefficients_; }
  /// A composition of a symmetric scheme by symmetric weights is symmetric.
  bool symmetric() const { return this->base_.symmetric(); }

 private:
  /// to[i] = saved[i] for the sub-steps before sub-step `failed` (those that changed
  /// their entry): undoes them after a failed sub-step.
  template <class Saved>
  static void copy_used(const Saved& saved, int failed, Memory& to) {
    if constexpr (std::is_same_v<Memory, NoMemory>) {
      (void)saved, (void)failed, (void)to;
    } else {
      for (int i = 0; i < failed; ++i) to[std::size_t(i)] = saved[std::size_t(i)].memory;
    }
  }

  /// Sub-step i's memory.
  static BaseMemory& base_memory(Memory& m, int i) {
    if constexpr (std::is_same_v<Memory, NoMemory>) {
      (void)i;
      return m;
    } else {
      return m[static_cast<std::size_t>(i)];
    }
  }

  CompositionCoefficients<Scalar> coefficients_;
};

}  // namespace trompo
