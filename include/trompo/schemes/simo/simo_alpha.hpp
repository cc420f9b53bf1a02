#pragma once
// Simo-α: the midpoint family with the conservative torque at Λ_{n+α}, [T1] with
// κ = 1 and α fixed in [0, 1]. α = ½ is Simo–Wong's midpoint rule: symmetric, order 2.
// Keeps μ exactly (the torque of an axisymmetric load has no γ component at any α), and
// on the free body H and π too (the load term vanishes and every α is the midpoint).
// H drifts at O(h²) under a load; α ≠ ½ is of first order and not symmetric.
#include "trompo/schemes/simo/simo_step.hpp"
#include "trompo/schemes/scheme.hpp"

namespace trompo {

/// Simo-α: midpoint family with the torque at Λ_{n+α}; μ exact, H to O(h²).
struct SimoAlpha {
  /// α ∈ [0, 1]: the conservative torque is taken at Λ_{n+α}.
  double alpha = 0.5;
  SimoAlpha() = default;
  /// Throws invalid_input unless α ∈ [0, 1].
  explicit SimoAlpha(double a) : alpha(a) { validate(); }

  /// Order 2 and symmetric at α = ½ (refined(): order 1 and not symmetric otherwise); keeps
  /// μ, and H and π on the free body. Memoryless.
  static constexpr SchemeTraits traits{
      .order = 2,
      .symmetric = true,
      .keeps =
          [](SceneKind s) {
            return Keeps{.energy = s.is_free || s.wheels_only(), .momentum_map = true,
                         .spatial_momentum = s.is_free || s.wheels_only()};
          },
      .carries_wheels = true,
      .refined = true,
      .validated = true};

  /// Throws invalid_input unless α ∈ [0, 1] (Stepper calls it: alpha is a public field).
  void validate() const {
    if (!(alpha >= 0.0 && alpha <= 1.0)) detail::fail("simo-alpha: alpha must be in [0, 1], got ", alpha);
  }

  /// "simo-alpha".
  static constexpr const char* name = "simo-alpha";

  /// The traits at this α: symmetric and of order 2 for α = ½ only, order 1 otherwise.
  constexpr SchemeTraits refined() const {
    SchemeTraits t = traits;
    t.symmetric = alpha == 0.5;
    t.order = alpha == 0.5 ? 2 : 1;
    return t;
  }

  /// One step: Newton on [T1] from the predictor, then (9)–(10).
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h,
                                          const NewtonOptions<typename Scene::Scalar>& options,
                                          State<typename Scene::Scalar>& out, NoMemory&) const {
    return detail::simo_step<detail::SimoVariant::fixed_alpha>(alpha, scene, in, h, options, out);
  }

  /// The residual [T1] and tangent [T3] of a step (for tests and tools).
  template <class Scene>
  detail::SimoResidual<detail::SimoVariant::fixed_alpha, Scene> residual(const detail::StepData<Scene>& d) const {
    return {alpha, d};
  }
};

}  // namespace trompo
