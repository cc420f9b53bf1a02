#pragma once
// ProcessedStepper<Scheme, Scene>: order 6 from a symmetric second-order scheme by a
// processed composition, the s = 13 method of Blanes, Casas and Murua (docs/theory.md §13.5
// [P5]).
//
//   ProcessedStepper<SimoKappa, HeavyTop<double>> stepper(SimoKappa{}, scene);
//   auto traj = stepper.start(c.initial);
//   integrate(stepper, traj, 10.0, 0.01);   // 13 base steps per step, 24 more in all
//
// The method. A kernel K_h (13 base steps, weights a_i, symmetric, Σa_i = 1) is conjugated
// by a processor P_h (12 base steps, weights p_j, Σp_j = 0):
//
//   x_n = P_h ∘ K_h^n ∘ P_h⁻¹ (x_0)                                                 [P5]
//
// K_h alone is of order 4 (measured: tests/test_processed.cpp); with the processor the
// outputs x_n are of order 6. The processor removes the error terms that a change of
// variables near the identity can remove, so the kernel need only kill the rest and
// spends its freedom on a small error constant: at equal work per unit time the error is
// 15× below Kahan–Li's order-6 composition on HT1 (measured, tests/test_processed.cpp). The pre-processor P_h⁻¹ is paid once per trajectory (and after a change of h), the
// post-processor P_h once per output: n steps to t_end cost 13n + 24 base steps when
// only the end state is wanted.
//
// Outputs. `step(traj, h)` advances the kernel and post-processes, so traj.state() is the
// order-6 output after every step (25 base steps per step). integrate() without an
// observer uses the deferred interface instead (`advance` the kernel, `output` once at
// the end: integrate.hpp), and so pays for one post-processing per call. The kernel state
// y_n = P_h⁻¹(x_n) lives in the trajectory's memory; a user who edits traj.state() by hand
// calls traj.reset(), as for any scheme with memory.
//
// What is kept. Every output is a product of base steps (P_h⁻¹, K_h^n, P_h) from the
// initial state, so it keeps exactly whatever the base scheme keeps (H and μ for Simo-κ and
// Géradin–Bauchau; π on the free body). The method is not symmetric (P_{−h} ≠ P_h), so it
// is not composed further. Only symmetric bases are accepted (as for ComposedStepper).
//
// A base scheme with memory (the history predictor) gets one memory per kernel sub-step
// index. The processors start every sub-step from fresh memory: an output is then a function
// of the kernel state and h alone, so integrate()'s single deferred output is bit for bit
// the output that step() gives after every step (and an ensemble member, run without an
// observer, is bit for bit its single run with one).
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>

#include "trompo/errors.hpp"
#include "trompo/model/state.hpp"
#include "trompo/schemes/coefficients.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/solvers/newton.hpp"
#include "trompo/steppers/composition_core.hpp"
#include "trompo/steppers/stepper.hpp"

namespace trompo {

/// The trajectory memory of a ProcessedStepper: the kernel state and the base schemes'
/// memories.
template <class Scalar, class BaseMemory>
struct ProcessedMemory {
  /// y = P_h⁻¹(x) at the kernel's time (kernel.time); meaningful when h ≠ 0.
  State<Scalar> kernel{};
  /// The h of the processor that produced `kernel`; 0 for a fresh memory (not primed).
  Scalar h = Scalar(0);
  /// True when the kernel is ahead of the trajectory's state (after advance(), before
  /// output()).
  bool pending = false;
  /// One base memory per kernel sub-step index.
  std::array<BaseMemory, ProcessedCoefficients<Scalar>::kernel_stages> kernel_memory{};
};

/// The processed order-6 composition of a symmetric order-2 scheme (docs/theory.md §13.5
/// [P5]): outputs P_h K_h^n P_h⁻¹ x_0. Keeps whatever the base keeps. The base stepper,
/// its accessors and the loop over the sub-steps are the composition core's
/// (composition_core.hpp), shared with ComposedStepper.
template <class Scheme, class Scene_>
  requires SchemeFor<Scheme, Scene_>
class ProcessedStepper : public detail::CompositionCore<Scheme, Scene_> {
  using Core = detail::CompositionCore<Scheme, Scene_>;

 public:
  /// The scene type.
  using Scene = Scene_;
  /// The scalar type of the scene.
  using Scalar = typename Scene::Scalar;
  /// The stepper of one sub-step.
  using Base = typename Core::Base;
  /// The memory of the base scheme.
  using BaseMemory = typename Core::BaseMemory;
  /// The kernel state and the base memories.
  using Memory = ProcessedMemory<Scalar, BaseMemory>;
  /// A state with its kernel state and memories.
  using TrajectoryType = Trajectory<Scalar, Memory>;
  /// The weights.
  using Coefficients = ProcessedCoefficients<Scalar>;

  /// Throws invalid_input if the base scheme, with its parameters, is not symmetric
  /// (Simo-α with α ≠ ½).
  explicit ProcessedStepper(Scheme scheme, Scene scene, NewtonOptions<Scalar> options = {})
      : Core(std::move(scheme), std::move(scene), options), coefficients_(Coefficients::bcm13()) {
    this->require_symmetric("processed composition:");
  }

  /// A trajectory starting at `s`, with fresh memory (the kernel is primed by the first step).
  TrajectoryType start(const State<Scalar>& s) const { return TrajectoryType(s); }

  /// Advances a trajectory by h and post-processes: traj.state() is the order-6 output at
  /// t + h. On failure of any sub-step, state and memory are untouched and the report
  /// carries that sub-step's status.
  StepReport<Scalar> step(TrajectoryType& traj, Scalar h) const {
    Memory m = traj.memory;
    State<Scalar> x = traj.state();
    StepReport<Scalar> total = advance_kernel(x, m, h);
    if (total.ok()) total.absorb(post_process(m, x));
    if (!total.ok()) return total;
    traj.state() = x;
    traj.memory = m;
    return total;
  }

  /// Deferred output, kernel part: advances the kernel by h and leaves traj.state() behind
  /// (memory.pending); output() brings it up to date. integrate() uses this pair when no
  /// observer wants the intermediate states. On failure nothing changes.
  StepReport<Scalar> advance(TrajectoryType& traj, Scalar h) const {
    Memory& mem = traj.memory;
    const Scalar span = h;  // the time to cover: h as asked (integrate()'s t_b − t_a)
    h = primed_step(mem, h);
    if (mem.h == h && h != Scalar(0)) {  // primed for this h (a fresh memory has h = 0)
      // The common case: the kernel alone moves. It steps in place, with a backup of what
      // it changes (the kernel state and its 13 sub-step memories), restored on failure:
      // one copy per step instead of the whole memory in and out.
      const State<Scalar> kernel = mem.kernel;
      const auto kernel_memory = mem.kernel_memory;
      const StepReport<Scalar> rep = kernel_step(mem, h, span);
      if (!rep.ok()) {
        mem.kernel = kernel;
        mem.kernel_memory = kernel_memory;
        return rep;
      }
      mem.pending = true;
      return rep;
    }
    Memory m = traj.memory;
    State<Scalar> x = traj.state();
    const StepReport<Scalar> rep = advance_kernel(x, m, h);
    if (!rep.ok()) return rep;
    traj.state() = x;  // unchanged, or the old kernel's output if h changed
    m.pending = true;
    traj.memory = m;
    return rep;
  }

  /// Deferred output, output part: traj.state() = P_h(kernel), at the kernel's time. A
  /// no-op when nothing is pending. On failure (a post-processor sub-step), traj.state()
  /// stays the last output, with its own time, and the kernel is kept.
  StepReport<Scalar> output(TrajectoryType& traj) const {
    if (!traj.memory.pending) return {};
    Memory m = traj.memory;
    State<Scalar> x;
    const StepReport<Scalar> rep = post_process(m, x);
    if (!rep.ok()) return rep;
    traj.state() = x;
    traj.memory = m;
    return rep;
  }

  /// The time the trajectory has reached: the kernel's when an output is pending.
  Scalar time(const TrajectoryType& traj) const { return traj.memory.pending ? traj.memory.kernel.time : traj.time; }
  /// Sets the time the trajectory has reached (integrate() snaps it to its grid).
  void set_time(TrajectoryType& traj, Scalar t) const {
    if (traj.memory.pending) traj.memory.kernel.time = t;
    else traj.time = t;
  }

  /// The order of the outputs: 6.
  int order() const { return Coefficients::order; }
  /// Base steps per kernel step (13): the cost factor over the base scheme, processing apart.
  int stages() const { return Coefficients::kernel_stages; }
  /// Base steps per processing (12): once per output, and once more to start.
  int processor_stages() const { return Coefficients::processor_stages; }
  /// The weights.
  const Coefficients& coefficients() const { return coefficients_; }
  /// Not symmetric: P_{−h} ≠ P_h.
  bool symmetric() const { return false; }

 private:
  /// In which order sequence() takes the weights.
  enum class Order { as_listed, reversed };

  /// Base steps w_0 h, w_1 h, … (or from the last weight, Order::reversed) on s, sub-step
  /// i with memory mem(i); s ends at its start time + (sum of weights)·h, given exactly as
  /// `t_end`. Reports summed as for a composition. On failure `s` is partly advanced: the
  /// callers work on copies.
  template <std::size_t N, class MemoryOf>
  StepReport<Scalar> sequence(State<Scalar>& s, const std::array<Scalar, N>& w, Order order, Scalar h, Scalar t_end,
                              MemoryOf&& mem) const {
    const auto weight = [&](std::size_t k) { return w[order == Order::reversed ? N - 1 - k : k]; };
    return this->base_steps(s, N, weight, h, t_end, mem, [](std::size_t) {});
  }

  /// The kernel's h for a step of size h: the primed one if h differs from it by the
  /// rounding of the time grid only (integrate()'s last step, t_end − t_{n−1}, is h up to a
  /// few ulps of t), so that such a step neither re-processes nor changes the output's bits;
  /// else h itself.
  static Scalar primed_step(const Memory& m, Scalar h) {
    using std::abs;
    const Scalar grid_rounding = Scalar(8) * std::numeric_limits<Scalar>::epsilon() * (abs(m.h) + abs(m.kernel.time));
    return m.h != Scalar(0) && abs(h - m.h) <= grid_rounding ? m.h : h;
  }

  /// Primes the kernel from the output x for step size h: y = P_h⁻¹(x) (fresh memories).
  StepReport<Scalar> pre_process(const State<Scalar>& x, Memory& m, Scalar h) const {
    // P_h⁻¹ = Φ_{−p_12 h} ∘ … ∘ Φ_{−p_1 h}: the steps −p_1 h, …, −p_12 h in turn [P5].
    std::array<Scalar, Coefficients::processor_stages> minus_p;
    for (std::size_t j = 0; j < minus_p.size(); ++j) minus_p[j] = -coefficients_.processor[j];
    std::array<BaseMemory, Coefficients::processor_stages> fresh{};
    State<Scalar> y = x;
    const StepReport<Scalar> rep = sequence(y, minus_p, Order::as_listed, h, x.time, [&](std::size_t k) -> BaseMemory& { return fresh[k]; });
    if (!rep.ok()) return rep;
    m.kernel = y;
    m.h = h;
    m.kernel_memory = {};
    return rep;
  }

  /// x = P_h(kernel) at the kernel's time, from fresh memories (see the file comment).
  StepReport<Scalar> post_process(Memory& m, State<Scalar>& x) const {
    // P_h = Φ_{p_1 h} ∘ … ∘ Φ_{p_12 h}: the steps p_12 h, …, p_1 h in turn [P5].
    x = m.kernel;
    std::array<BaseMemory, Coefficients::processor_stages> fresh{};
    const StepReport<Scalar> rep = sequence(x, coefficients_.processor, Order::reversed, m.h, m.kernel.time,
                                            [&](std::size_t k) -> BaseMemory& { return fresh[k]; });
    if (rep.ok()) m.pending = false;
    return rep;
  }

  /// One kernel step of size h on the memory m, from the output x (which it updates if the
  /// processor must change: a new h, or a fresh memory).
  StepReport<Scalar> advance_kernel(State<Scalar>& x, Memory& m, Scalar h) const {
    const Scalar span = h;
    h = primed_step(m, h);
    StepReport<Scalar> total = detail::check_step_size(h);
    if (!total.ok()) return total;
    if (m.h != h) {
      // Fresh memory, or another h: the kernel must be P_h⁻¹ of the current output.
      if (m.h != Scalar(0) && m.pending) {
        total.absorb(post_process(m, x));
        if (!total.ok()) return total;
      }
      total.absorb(pre_process(x, m, h));
      if (!total.ok()) return total;
    }
    total.absorb(kernel_step(m, h, span));
    return total;
  }

  /// K_h = Φ_{a_13 h} ∘ … ∘ Φ_{a_1 h} on m.kernel, with the kernel's memories [P5], ending at
  /// the kernel's time + `span`: the step as asked, which the primed h may differ from by the
  /// grid's rounding (primed_step). The kernel's clock is then integrate()'s grid itself, not
  /// a running sum of h, and with wheels its sub-steps cover the span exactly (theory [W4]).
  StepReport<Scalar> kernel_step(Memory& m, Scalar h, Scalar span) const {
    const Scalar t_end = m.kernel.time + span;
    return sequence(m.kernel, coefficients_.kernel, Order::as_listed, h, t_end,
                    [&](std::size_t k) -> BaseMemory& { return m.kernel_memory[k]; });
  }

  Coefficients coefficients_;
};

}  // namespace trompo
