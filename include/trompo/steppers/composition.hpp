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
#include "trompo/solvers/newton.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/model/state.hpp"
#include "trompo/steppers/stepper.hpp"

namespace trompo {

/// The symmetric compositions on offer.
enum class Composition {
  base,         ///< order 2: one step of the base scheme
  triple_jump,  ///< order 4, 3 steps
  suzuki5,      ///< order 4, 5 steps (Suzuki 1990)
  kahan_li9,    ///< order 6, 9 steps (Kahan & Li 1997)
  mclachlan15,  ///< order 8, 15 steps (McLachlan 1995)
  kahan_li17    ///< order 8, 17 steps (Kahan & Li 1997)
};

/// The name of a composition, as the CLI spells it ("triple-jump", "suzuki-5", …).
inline const char* to_string(Composition c) {
  switch (c) {
    case Composition::base: return "base";
    case Composition::triple_jump: return "triple-jump";
    case Composition::suzuki5: return "suzuki-5";
    case Composition::kahan_li9: return "kahan-li-9";
    case Composition::mclachlan15: return "mclachlan-15";
    case Composition::kahan_li17: return "kahan-li-17";
  }
  return "unknown";
}

/// The default composition of each order: 2 → base, 4 → triple jump, 6 → Kahan–Li.
/// Throws invalid_input for any other order (the order-8 sets are chosen by name:
/// Composition::kahan_li17, Composition::mclachlan15).
inline Composition composition_of_order(int order) {
  switch (order) {
    case 2: return Composition::base;
    case 4: return Composition::triple_jump;
    case 6: return Composition::kahan_li9;
    default: detail::fail("composition: order must be 2, 4 or 6, got ", order);
  }
}

/// The weights γ_1 … γ_s of a symmetric composition of order 2, 4, 6 or 8.
template <class Scalar>
struct CompositionCoefficients {
  /// The largest number of sub-steps of the compositions on offer (Kahan–Li's 17).
  static constexpr int max_stages = 17;
  /// Which composition.
  Composition method = Composition::base;
  /// Its order: 2, 4, 6 or 8.
  int order = 2;
  /// The number of sub-steps s.
  int stages = 1;
  /// The weights γ_1 … γ_s (the rest are zero).
  std::array<Scalar, max_stages> gamma{};

  /// Throws invalid_input unless order is 2, 4 or 6 (composition_of_order).
  static CompositionCoefficients of_order(int order) { return of(composition_of_order(order)); }

  /// The weights of a named composition. Throws invalid_input for an unknown one.
  static CompositionCoefficients of(Composition method) {
    CompositionCoefficients c;
    c.method = method;
    switch (method) {
      case Composition::base:
        c.order = 2;
        c.stages = 1;
        c.gamma[0] = Scalar(1);
        break;
      case Composition::triple_jump: {
        // Triple jump (Creutz & Gocksch 1989, Forest 1989, Suzuki 1990, Yoshida 1990;
        // Hairer–Lubich–Wanner, Geometric Numerical Integration, 2nd ed., §II.4 (4.4)):
        //   γ1 = γ3 = 1/(2 − 2^{1/3}),  γ2 = −2^{1/3}/(2 − 2^{1/3}).
        // Written out in long double (rounded once to Scalar) rather than computed, so that
        // every Scalar gets the correctly rounded value.
        c.order = 4;
        c.stages = 3;
        c.gamma[0] = c.gamma[2] = Scalar(1.35120719195965763404768780897146083L);
        c.gamma[1] = Scalar(-1.70241438391931526809537561794292165L);
        break;
      }
      case Composition::suzuki5:
        // Suzuki, "Fractal decomposition of exponential operators", Phys. Lett. A 146
        // (1990) 319–323; Hairer–Lubich–Wanner, §II.4 (4.5), §V.3.2:
        //   γ1 = γ2 = γ4 = γ5 = 1/(4 − 4^{1/3}),  γ3 = −4^{1/3}/(4 − 4^{1/3}).
        c.order = 4;
        c.stages = 5;
        c.gamma[0] = c.gamma[1] = c.gamma[3] = c.gamma[4] = Scalar(0.41449077179437573714235406286076373L);
        c.gamma[2] = Scalar(-0.65796308717750294856941625144305492L);
        break;
      case Composition::kahan_li9:
        // Kahan & Li, "Composition constants for raising the orders of unconventional
        // schemes for ordinary differential equations", Math. Comp. 66 (1997) 1089–1099:
        // the s = 9 order-6 set, as printed in Hairer–Lubich–Wanner, Geometric Numerical
        // Integration, 2nd ed., §V.3.2, eq. (3.11). Its error constant is much smaller
        // than that of Yoshida's s = 7 set (ibid. (3.10)).
        c.order = 6;
        c.stages = 9;
        c.gamma[0] = c.gamma[8] = Scalar(0.39216144400731413927925056L);
        c.gamma[1] = c.gamma[7] = Scalar(0.33259913678935943859974864L);
        c.gamma[2] = c.gamma[6] = Scalar(-0.70624617255763935980996482L);
        c.gamma[3] = c.gamma[5] = Scalar(0.08221359629355080023149045L);
        c.gamma[4] = Scalar(0.79854399093482996339895035L);
        break;
      case Composition::mclachlan15: {
        // McLachlan, "On the numerical integration of ordinary differential equations by
        // symmetric composition methods", SIAM J. Sci. Comput. 16 (1995) 151–168: the
        // s = 15 order-8 set, as printed in Hairer–Lubich–Wanner, §V.3.2 ([P4]). Checked
        // in tests/test_composition.cpp: Σγ = 1, Σγ³ = Σγ⁵ = Σγ⁷ = 0, observed order 8.
        c.order = 8;
        c.stages = 15;
        const Scalar g[8] = {Scalar(0.74167036435061295344822780L), Scalar(-0.40910082580003159399730010L),
                             Scalar(0.19075471029623837995387626L), Scalar(-0.57386247111608226665638773L),
                             Scalar(0.29906418130365592384446354L), Scalar(0.33462491824529818378495798L),
                             Scalar(0.31529309239676659663205666L), Scalar(-0.79688793935291635401978884L)};
        for (int i = 0; i < 8; ++i) c.gamma[std::size_t(i)] = c.gamma[std::size_t(14 - i)] = g[i];
        break;
      }
      case Composition::kahan_li17: {
        // Kahan & Li (1997), as above: the s = 17 order-8 set (Hairer–Lubich–Wanner,
        // §V.3.2), whose error constant is smaller than McLachlan's s = 15 ([P4]).
        c.order = 8;
        c.stages = 17;
        const Scalar g[9] = {Scalar(0.13020248308889008087881763L), Scalar(0.56116298177510838456196441L),
                             Scalar(-0.38947496264484728640807860L), Scalar(0.15884190655515560089621075L),
                             Scalar(-0.39590389413323757733623154L), Scalar(0.18453964097831570709183254L),
                             Scalar(0.25837438768632204729397911L), Scalar(0.29501172360931029887096624L),
                             Scalar(-0.60550853383003451169892108L)};
        for (int i = 0; i < 9; ++i) c.gamma[std::size_t(i)] = c.gamma[std::size_t(16 - i)] = g[i];
        break;
      }
      default:
        detail::fail("composition: unknown method ", static_cast<int>(method));
    }
    return c;
  }
};

namespace detail {
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
template <class Scheme, class Scene_>
  requires SchemeFor<Scheme, Scene_>
class ComposedStepper {
  static_assert(Scheme::symmetric,
                "ComposedStepper: this scheme is not symmetric (its trait `symmetric` is false), so "
                "composing it does not raise its order; step it with Stepper<Scheme, Scene> instead");

 public:
  /// The scene type.
  using Scene = Scene_;
  /// The scalar type of the scene.
  using Scalar = typename Scene::Scalar;
  /// The stepper of one sub-step.
  using Base = Stepper<Scheme, Scene>;
  /// The memory of the base scheme (NoMemory for a memoryless one such as RK4 or Simo-α).
  using BaseMemory = typename Base::Memory;
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
      : base_(std::move(scheme), std::move(scene), options),
        coefficients_(CompositionCoefficients<Scalar>::of(method)) {
    if (coefficients_.order > 2 && !base_.symmetric())
      detail::fail("composition: order ", coefficients_.order, " (", to_string(method),
                   ") needs a symmetric base scheme; ", Scheme::name,
                   " with these parameters is not symmetric (Simo-alpha needs alpha = 0.5)");
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
    if (coefficients_.stages == 1) return base_.step(state, base_memory(memory, 0), h);
    StepReport<Scalar> total;
    if (!std::isfinite(static_cast<double>(h)) || h == Scalar(0)) {
      total.status = StepStatus::invalid_step;
      return total;
    }
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
    int filled = 0;
    const auto release = [&] {
      for (int i = 0; i < filled; ++i) std::destroy_at(&saved[std::size_t(i)].memory);
    };
    for (int i = 0; i < coefficients_.stages; ++i) {
      if constexpr (!std::is_same_v<Memory, NoMemory>) {
        std::construct_at(&saved[std::size_t(i)].memory, memory[std::size_t(i)]);
        filled = i + 1;
      }
      const StepReport<Scalar> rep =
          base_.step(s, base_memory(memory, i), coefficients_.gamma[static_cast<std::size_t>(i)] * h);
      total.iterations += rep.iterations;
      total.evaluations += rep.evaluations;
      total.tangents += rep.tangents;
      if (rep.residual > total.residual) total.residual = rep.residual;
      if (!rep.ok()) {
        copy_used(saved, i, memory);
        release();
        total.status = rep.status;
        return total;
      }
    }
    release();
    // Σγ_i h differs from h by round-off; end the step exactly at t_n + h, as Stepper does.
    s.time = state.time + h;
    state = s;
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
  bool symmetric() const { return base_.symmetric(); }
  /// What the composition keeps exactly: what its base scheme keeps (every sub-step is
  /// a base step).
  Keeps keeps() const { return base_.keeps(); }

  /// The stepper of one sub-step.
  const Base& base() const { return base_; }
  /// The base scheme.
  const Scheme& scheme() const { return base_.scheme(); }
  /// The scene.
  const Scene& scene() const { return base_.scene(); }
  /// The Newton options of every sub-step.
  const NewtonOptions<Scalar>& options() const { return base_.options(); }
  /// The Newton options of every sub-step, to modify.
  NewtonOptions<Scalar>& options() { return base_.options(); }

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

  Base base_;
  CompositionCoefficients<Scalar> coefficients_;
};

}  // namespace trompo
