#pragma once
// Simo collocation: [T1] with κ = 1 and α solved at every step so that the energy
// balance is exact, (17)/[T2] (closed form for potentials linear in Λ, a safeguarded
// root search for a general V). Keeps H, μ and, on the free body, π; symmetric, order 2.
// Composed, it reaches orders 4 and 6 only where α(Θ) is smooth (composition.hpp).
#include "trompo/schemes/simo/simo_step.hpp"
#include "trompo/schemes/scheme.hpp"

namespace trompo {

/// Simo collocation: α solved each step so that the energy balance is exact, [T2].
struct SimoCollocation {
  /// "simo-collocation".
  static constexpr const char* name = "simo-collocation";
  /// Order 2, symmetric; keeps H, μ and π (free body); the history predictor's memory
  /// (detail::energy_exact_simo_traits).
  static constexpr SchemeTraits traits = detail::energy_exact_simo_traits;

  /// Whether the steps of a Trajectory start from the history predictor and the carried
  /// tangent (detail/history.hpp, docs/theory.md §13 [P1]–[P3]). Off: every step is solved
  /// as a memoryless one. Either way the step's acceptance, hence its exactness, is the same.
  bool history_predictor = true;
  /// Whether a Trajectory's state is compensated: its rounding residue is carried in the
  /// memory, so that H and μ stay within a few ε of their start over any number of steps
  /// instead of walking like √N·ε (docs/theory.md §18). A plain State stepped alone starts
  /// from a zero residue each step, as if off. Off by default: it costs 26–33 ns a step
  /// (4 % of a Simo-κ step of HT0 at h = 1e-2, 8 % at 1e-3, 16 % below 1e-4, where Newton
  /// takes one iteration; docs/robustness.md "Long runs").
  bool compensated = false;
  /// The last increments and tangent, and the state's residue (SimoMemory), per trajectory.
  template <class Scene>
  using Memory = detail::SimoMemory<typename Scene::Scalar>;

  /// One step: Newton on [T1] with α(Θ) from [T2], then (9)–(10).
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h,
                                          const NewtonOptions<typename Scene::Scalar>& options,
                                          State<typename Scene::Scalar>& out, Memory<Scene>& memory) const {
    return detail::simo_step<detail::SimoVariant::collocation>(0.5, scene, in, h, options, out,
                                                          history_predictor ? &memory : nullptr,
                                                          compensated ? &memory.residue : nullptr);
  }

  /// The residual [T1] and tangent [T3] of a step (for tests and tools).
  template <class Scene>
  detail::SimoResidual<detail::SimoVariant::collocation, Scene> residual(const detail::StepData<Scene>& d) const {
    return {0.5, d};
  }
};

}  // namespace trompo
