#pragma once
// Géradin–Bauchau, momentum-consistent half-rotation form, [T4]: Newton on the
// vector part e of the increment's quaternion, the torques at Λ_{n+½} in the mid frame.
// Keeps μ, and π on the free body; H exactly for potentials linear in Λ (uniform
// gravity), not for a general V (the mid-point torque is not its discrete gradient).
// Symmetric, order 2; an increment must stay below π (else out_of_domain).
#include "trompo/schemes/geradin_bauchau/gb_step.hpp"
#include "trompo/schemes/scheme.hpp"

namespace trompo {

/// Géradin–Bauchau, momentum-consistent half-rotation form [T4].
struct GeradinBauchau {
  /// "geradin-bauchau".
  static constexpr const char* name = "geradin-bauchau";
  /// Order 2, symmetric (may be composed); keeps H (potentials linear in Λ), μ and π (free
  /// body). Its memory, the history predictor's, is only a hint: a plain State may be
  /// stepped (with fresh memory). The step writes the memory only when it succeeds, after
  /// checking its result (scheme.hpp): the Stepper steps the memory in place, without copies.
  static constexpr SchemeTraits traits{
      .order = 2,
      .symmetric = true,
      .keeps =
          [](SceneKind s) {
            return Keeps{.energy = s.potentials_linear, .momentum_map = true, .spatial_momentum = s.is_free};
          },
      .memory = MemoryUse::hint,
      .writes_memory_on_success = true};

  /// Whether the steps of a Trajectory start from the history predictor and the carried
  /// tangent (detail/history.hpp, docs/theory.md §13 [P1]–[P3]), extrapolating e. Off:
  /// every step is solved as a memoryless one. Either way the acceptance is the same.
  bool history_predictor = true;
  /// The last increments e and tangent (IncrementHistory), per trajectory.
  template <class Scene>
  using Memory = IncrementHistory<typename Scene::Scalar>;

  /// One step: Newton on [T4] from the predictor, then Λ_{n+1} = Λ_n ⊗ (e0, e).
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h,
                                          const NewtonOptions<typename Scene::Scalar>& options,
                                          State<typename Scene::Scalar>& out, Memory<Scene>& memory) const {
    return detail::gb_step<detail::GBForm::momentum_consistent>(scene, in, h, options, out,
                                                                history_predictor ? &memory : nullptr);
  }

  /// The residual [T4] and its tangent (for tests and tools).
  template <class Scene>
  detail::GBResidual<detail::GBForm::momentum_consistent, Scene> residual(const detail::StepData<Scene>& d) const {
    return detail::GBResidual<detail::GBForm::momentum_consistent, Scene>(d);
  }
};

}  // namespace trompo
