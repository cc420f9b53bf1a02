#pragma once
// The discrete Moser–Veselov algorithm (Moser & Veselov 1991) for the free rigid body,
// docs/theory.md §19 [V7], in the quaternion form of Hairer & Vilmart (2006): with
// F = exp(Θ̂) written as the unit quaternion (e₀, e), e₀ = cos(θ/2), e = sin(θ/2) Θ/θ,
// the implicit equation of the step, h Π̂_n = F J_d − J_d Fᵀ (J_d = ½ tr(J) I − J), reads
//   2 e₀ J e + 2 e × J e = h Π_n,   e₀ = √(1 − |e|²)                                 [V7]
// and is solved by the fixed-point iteration
//   e ← J⁻¹((h/2) Π_n − e × J e) / e₀,
// which contracts by about h|Ω|·‖J‖‖J⁻¹‖/2 per sweep and needs no tangent; then
//   Λ_{n+1} = Λ_n F,   Π_{n+1} = Fᵀ Π_n.
// This is the same map as the LGVI [V1]–[V4] without torques (Moser–Veselov's discrete
// Lagrangian tr(Λ_n J_d Λ_{n+1}ᵀ)), solved another way: the two agree to round-off on the
// free body (tested). Symplectic, symmetric, order 2; keeps π and H exactly (the DMV map
// preserves both integrals of the free body). Free body only.
//
// Failure: the iteration stops when a sweep changes e by at most 4ε|e|, else after
// 4·max_iterations sweeps (not_converged), or when |e| ≥ 1 (out_of_domain); a converged
// root passes the branch rule of NewtonOptions ([V6]: angle, distance from the predictor,
// and the sign of det((tr(F J_d) I − F J_d) F), positive up to the fold).
#include <Eigen/Core>
#include <cmath>
#include <limits>

#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"
#include "trompo/schemes/implicit_step.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/solvers/newton.hpp"

namespace trompo {

/// The discrete Moser–Veselov algorithm [V7] for the free body: the LGVI's map, by the
/// quaternion fixed-point iteration; order 2, symmetric; π and H exact.
struct DMV {
  /// "dmv".
  static constexpr const char* name = "dmv";
  /// Order 2; symmetric (composable); on the free body keeps H and π exactly; memoryless.
  static constexpr SchemeTraits traits{.order = 2,
                                       .symmetric = true,
                                       .keeps = [](SceneKind s) {
                                         return Keeps{.energy = s.is_free, .spatial_momentum = s.is_free};
                                       }};

  /// One step: the fixed-point iteration on [V7] from e⁰ = Θ⁰/2, Θ⁰ = hΩ_n + (h²/2)Ω̇_n,
  /// the branch rule, then Λ_{n+1} = Λ_n F and Π_{n+1} = FᵀΠ_n. Free body only.
  template <class Scene>
    requires(Scene::is_free)
  StepReport<typename Scene::Scalar> step(const Scene& scene, const State<typename Scene::Scalar>& in,
                                          typename Scene::Scalar h,
                                          const NewtonOptions<typename Scene::Scalar>& options,
                                          State<typename Scene::Scalar>& out, NoMemory&) const {
    using Scalar = typename Scene::Scalar;
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
    using Quaternion = Eigen::Quaternion<Scalar>;
    constexpr Scalar eps = std::numeric_limits<Scalar>::epsilon();
    const Matrix3& J = scene.body().inertia();
    const Matrix3& J_inv = scene.body().inertia_inverse();
    const Vector3 Pi_n = J * in.omega;
    const Vector3 half_impulse = (h / Scalar(2)) * Pi_n;  // (h/2) Π_n
    // Θ⁰ = hΩ_n + (h²/2) J⁻¹(Π_n × Ω_n): [V7] to O(h³)
    const Vector3 predicted = h * in.omega + (h * h / Scalar(2)) * (J_inv * Pi_n.cross(in.omega));
    Vector3 e = predicted / Scalar(2);  // sin(θ/2) ≈ θ/2
    StepReport<Scalar> rep;
    const int max_sweeps = 4 * options.max_iterations;
    Scalar e0(1);
    bool converged = false;
    for (int k = 0; k < max_sweeps; ++k) {
      const Scalar s2 = e.squaredNorm();
      if (!(s2 < Scalar(1))) {
        rep.status = std::isfinite(static_cast<double>(s2)) ? StepStatus::out_of_domain : StepStatus::non_finite;
        return rep;
      }
      e0 = std::sqrt(Scalar(1) - s2);
      const Vector3 next = J_inv * (half_impulse - e.cross(J * e)) / e0;  // [V7]
      const Scalar change = (next - e).norm();
      e = next;
      ++rep.iterations;
      ++rep.evaluations;
      if (!std::isfinite(static_cast<double>(change))) {
        rep.status = StepStatus::non_finite;
        return rep;
      }
      if (change <= Scalar(4) * eps * e.norm()) {
        converged = true;
        break;
      }
    }
    if (!converged) {
      rep.status = StepStatus::not_converged;
      return rep;
    }
    const Scalar s2 = e.squaredNorm();
    if (!(s2 < Scalar(1))) {
      rep.status = StepStatus::out_of_domain;
      return rep;
    }
    e0 = std::sqrt(Scalar(1) - s2);
    const Vector3 residual = Scalar(2) * (e0 * (J * e) + e.cross(J * e)) - h * Pi_n;  // [V7], for the report
    rep.residual = residual.norm() / (std::abs(h) * Pi_n.norm() + std::numeric_limits<Scalar>::min());
    const Quaternion q(e0, e.x(), e.y(), e.z());
    const Matrix3 F = q.toRotationMatrix();
    // The branch rule [V6]: the angle 2 asin|e| (< π/2 on the continued root), the distance
    // from the predictor and the sign of det((tr(F J_d) I − F J_d) F) (→ det J as h → 0).
    const Scalar angle = Scalar(2) * std::asin(std::sqrt(s2));
    const Vector3 Theta = (s2 > Scalar(0)) ? Vector3(e * (angle / std::sqrt(s2))) : Vector3(Scalar(2) * e);
    const Matrix3 J_d = Scalar(0.5) * J.trace() * Matrix3::Identity() - J;
    const Matrix3 FJ_d = F * J_d;
    const Scalar orientation = ((FJ_d.trace() * Matrix3::Identity() - FJ_d) * F).determinant();
    if (!detail::on_branch(options, angle, Scalar((Theta - predicted).norm()), orientation)) {
      rep.status = StepStatus::wrong_branch;
      return rep;
    }
    // Λ_{n+1} = Λ_n F (q_n ⊗ (e₀, e), normalised), Π_{n+1} = Fᵀ Π_n
    out.rotation = in.rotation * SO3<Scalar>::renormalized(q);
    // Ω_{n+1} = Ω_n + J⁻¹(FᵀΠ_n − Π_n), FᵀΠ_n − Π_n = −2e₀ e × Π_n + 2 e × (e × Π_n): small
    // terms only, so that no rounding of a large part (Fᵀ as a matrix, a rounded J⁻¹ on Π)
    // repeats itself from step to step and drifts |π| like N·ε (lgvi.hpp, measured there).
    const Vector3 c1 = e.cross(Pi_n);
    out.omega = in.omega + J_inv * (Scalar(2) * (e.cross(c1) - e0 * c1));
    out.time = in.time + h;
    if (!detail::all_finite(out.omega)) rep.status = StepStatus::non_finite;
    return rep;
  }
};

}  // namespace trompo
