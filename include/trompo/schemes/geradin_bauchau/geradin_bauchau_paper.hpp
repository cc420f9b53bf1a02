#pragma once
// Géradin–Bauchau as printed in the paper, eq. (44), [T5]: energy exact for
// potentials linear in Λ, but the momentum map μ (and π on the free body) is NOT kept
// (docs/theory.md §4). Kept to reproduce the paper; symmetric, order 2.
#include "trompo/schemes/geradin_bauchau/gb_step.hpp"
#include "trompo/schemes/scheme.hpp"

namespace trompo {

/// The paper's printed eq. (44), [T5]: energy exact, momentum map drifts.
struct GeradinBauchauPaper {
  /// "geradin-bauchau-paper".
  static constexpr const char* name = "geradin-bauchau-paper";
  /// Order 2, symmetric (may be composed); keeps H only (potentials linear in Λ): μ and
  /// π drift. Memoryless.
  static constexpr SchemeTraits traits{
      .order = 2, .symmetric = true, .keeps = [](SceneKind s) { return Keeps{.energy = s.potentials_linear}; }};

  /// One step: Newton on [T5] from the predictor, then Λ_{n+1} = Λ_n ⊗ (e0, e).
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h,
                                          const NewtonOptions<typename Scene::Scalar>& options,
                                          State<typename Scene::Scalar>& out, NoMemory&) const {
    return detail::gb_step<detail::GBForm::paper>(scene, in, h, options, out);
  }

  /// The residual [T5] and its tangent (for tests and tools).
  template <class Scene>
  detail::GBResidual<detail::GBForm::paper, Scene> residual(const detail::StepData<Scene>& d) const {
    return detail::GBResidual<detail::GBForm::paper, Scene>(d);
  }
};

}  // namespace trompo
