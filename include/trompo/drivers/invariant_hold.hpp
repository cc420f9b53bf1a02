#pragma once
// Holding H, μ and π at their first values against round-off (docs/theory.md §16, [A7]).
//
// An energy-momentum step keeps H and μ (π on the free body) exactly in exact arithmetic;
// in floating point each step adds a rounding of a few ε that no step removes, so the
// invariants walk like √N·ε over N steps (Brouwer's law: 2.7e-13 after 2.7·10⁶ steps of
// Simo-κ on HT0 at h = 3.7e-6, fixed h, double). The adaptive driver's tight tolerances at
// order 2 make such runs ordinary. It therefore corrects the state (after every 8th accepted
// attempt, drivers/adaptive.hpp), to first order, back onto the first values — only what the
// stepper keeps on this scene, only where the scene has these invariants (H: no applied
// torque, no time-dependent potential; μ about γ: every potential a uniform gravity about the
// one axis γ, rotors allowed — a general potential has no such μ), and only a correction of
// round-off size (on a top Ω moved by at most 64ε|Ω|, on the free body Λ by at most 64ε rad: a
// larger one would hide a deviation that is not round-off, and is left for the caller to
// see). So it changes no digit that the scheme's truncation error leaves.
//
//   heavy top (μ = Γ·(JΩ + h_r), Γ = Λᵀγ; H = ½Ω·JΩ + V(Λ)): Ω only, Λ untouched,
//     Ω ← Ω + β Γ,  β = (μ₀ − μ)/(Γ·JΓ)                      (μ; ∂μ/∂Ω = JΓ)
//     Ω ← Ω + α v,  v = Ω − ((Ω·JΓ)/(Γ·JΓ)) Γ,  α = (H₀ − H)/(v·Jv)   (H; v·JΓ = 0 keeps μ)
//   free body (no effect at all; π = ΛJΩ, H = ½Ω·JΩ):
//     Ω ← J⁻¹Λᵀπ₀                                             (π)
//     (Λ, Π) ← (Λ exp(λn̂), Π − λ n × Π),  n = Π̇/|Π̇|, Π̇ = Π × Ω,  λ = (H − H₀)/|Π̇|
//                                          (H; the flow of n·Π keeps π, dH/dλ = −|Π̇|, [S12])
// The H step is skipped where it has no direction (v = 0: a sleeping top, Ω ∥ Γ; Π̇ = 0: a
// steady spin about a principal axis) or would need more than round-off's nudge (near
// them, where H moves little with the state anyway).
//
// The Lagrange top's third integral [A9] (opt-in, `third_integral`): on a body symmetric
// about a principal axis s (J_a = J_b) whose only effect is a uniform gravity with the centre
// of mass on that axis, Ω_s is a third invariant of the flow, and the nutation frequency
// depends on it as on H and μ. An energy-momentum scheme keeps H and μ but Ω_s only to its
// truncation error (Simo-κ on HT0: 1e-14 … 7e-14 over 100 periods, a drift that moves the
// nutation phase like t²). With it the hold solves for the one δΩ that restores all three
// to first order,
//     [ (JΓ)ᵀ ; (JΩ)ᵀ ; e_sᵀ ] δΩ = (μ₀ − μ, H₀ − H, Ω_s,0 − Ω_s),
// under the same cap of 64ε|Ω|; where the system is singular (Ω⊥ ∥ Γ⊥, a cusp of the
// nutation) or the cap is exceeded, the μ and H steps above are taken instead.
#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <limits>
#include <tuple>

#include "trompo/model/effects/effect.hpp"
#include "trompo/model/state.hpp"
#include "trompo/schemes/scheme.hpp"

namespace trompo {

/// The invariants a run holds at their first values ([A7]): built from the first state and
/// what the stepper keeps on the scene; `apply` corrects a state after a step.
template <class Scene>
class InvariantHold {
 public:
  /// The scalar type.
  using Scalar = typename Scene::Scalar;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;

  /// Holds nothing.
  InvariantHold() = default;

  /// Holds, at their values in `first`, the invariants of `scene` that `keeps` names:
  /// H without applied torques or a time-dependent potential, μ where every potential is a
  /// uniform gravity about the scene's momentum axis γ (rotors allowed), π on the free body.
  /// With `third_integral`, also Ω_s of a Lagrange top where H and μ are held [A9].
  InvariantHold(const Scene& scene, const State<Scalar>& first, const Keeps& keeps, bool third_integral = false) {
    // Wheels: H changes by the motors' work, so nothing is held (the schemes keep π exactly).
    if constexpr (!Scene::has_applied_torque && !Scene::has_time_dependent_potential && !Scene::has_wheels) {
      energy_ = keeps.energy;
      momentum_map_ = keeps.momentum_map && !Scene::is_free && symmetric_about_axis(scene);
      spatial_momentum_ = keeps.spatial_momentum && Scene::is_free;
      if (third_integral && energy_ && momentum_map_) lagrange_axis_ = lagrange_axis(scene);
    }
    if (lagrange_axis_ >= 0) omega_s0_ = first.omega(lagrange_axis_);
    H0_ = scene.energy(first);
    mu0_ = scene.momentum_map(first);
    pi0_ = scene.spatial_momentum(first);
  }

  /// Whether anything is held.
  bool active() const { return energy_ || momentum_map_ || spatial_momentum_; }
  /// What is held (energy, momentum_map, spatial_momentum).
  Keeps holds() const { return Keeps{.energy = energy_, .momentum_map = momentum_map_, .spatial_momentum = spatial_momentum_}; }

  /// Corrects `s` onto the first values ([A7]); a correction that would move Ω by more than
  /// 64ε|Ω| (or Λ by more than 64ε rad) is not round-off's, and is not made.
  void apply(const Scene& scene, State<Scalar>& s) const {
    if constexpr (!Scene::has_applied_torque && !Scene::has_time_dependent_potential) {
      if (!active()) return;
      if constexpr (Scene::is_free) hold_free(scene, s);
      else hold_top(scene, s);
    }
  }

 private:
  /// The largest correction made: 64ε, of |Ω| or in rad.
  static constexpr Scalar nudge = Scalar(64) * std::numeric_limits<Scalar>::epsilon();

  /// Whether μ = γ·π is an invariant of the scene's flow: every effect a rotor or a uniform
  /// gravity (an effect with up()) about γ = momentum_axis(); a general potential's torque
  /// has a component along γ.
  static bool symmetric_about_axis(const Scene& scene) {
    const Vector3 axis = scene.momentum_axis();
    bool symmetric = true;
    std::apply([&](const auto&... e) { ((symmetric = symmetric && about(e, axis)), ...); }, scene.effects());
    return symmetric;
  }
  template <class E>
  static bool about(const E& e, const Vector3& axis) {
    if constexpr (Scene::template is_kind<E, rotor_kind>) return true;
    else if constexpr (requires { e.up(); }) return (e.up().normalized() - axis.normalized()).norm() <= nudge;
    else return false;
  }

  /// The axis s of a Lagrange top: J diagonal with J_a = J_b (s the third), every effect a
  /// uniform gravity whose centre of mass lies on e_s; else −1.
  static int lagrange_axis(const Scene& scene) {
    const auto& J = scene.body().inertia();
    if (!J.isDiagonal(Scalar(0))) return -1;
    int axis = -1;
    for (int k = 0; k < 3; ++k) {
      const int a = (k + 1) % 3, b = (k + 2) % 3;
      if (J(a, a) == J(b, b)) axis = k;
    }
    if (axis < 0) return -1;
    bool on_axis = true;
    std::apply([&](const auto&... e) { ((on_axis = on_axis && com_on(e, axis)), ...); }, scene.effects());
    return on_axis ? axis : -1;
  }
  template <class E>
  static bool com_on(const E& e, int axis) {
    if constexpr (requires { e.com_direction(); }) {
      const Vector3& c = e.com_direction();
      return c((axis + 1) % 3) == Scalar(0) && c((axis + 2) % 3) == Scalar(0);
    } else {
      return false;
    }
  }

  /// [A9]: the one δΩ that restores μ, H and Ω_s to first order; false where the system is
  /// singular or the nudge would exceed the cap (the caller then takes the μ and H steps).
  bool hold_three(const Scene& scene, State<Scalar>& s, const Vector3& Gamma, Scalar limit) const {
    const auto& J = scene.body().inertia();
    Eigen::Matrix<Scalar, 3, 3> A;
    A.row(0) = (J * Gamma).transpose();    // ∂μ/∂Ω
    A.row(1) = (J * s.omega).transpose();  // ∂H/∂Ω
    A.row(2) = Vector3::Unit(lagrange_axis_).transpose();
    const Scalar det = A.determinant();
    if (!(std::abs(det) > Scalar(1e-8) * A.row(0).norm() * A.row(1).norm())) return false;  // Ω⊥ ∥ Γ⊥
    const Vector3 r(mu0_ - Gamma.dot(scene.momentum(s.omega, s.time)), H0_ - scene.energy(s),
                    omega_s0_ - s.omega(lagrange_axis_));
    const Vector3 d = A.inverse() * r;
    if (!(d.squaredNorm() <= limit)) return false;
    s.omega += d;
    return true;
  }

  void hold_top(const Scene& scene, State<Scalar>& s) const {
    const auto& J = scene.body().inertia();
    const Scalar limit = nudge * nudge * s.omega.squaredNorm();  // |δΩ|² ≤ (64ε|Ω|)²
    const Vector3 Gamma = s.rotation.inverse() * scene.momentum_axis();  // Γ = Λᵀγ
    if (lagrange_axis_ >= 0 && hold_three(scene, s, Gamma, limit)) return;  // [A9]
    const Vector3 JGamma = J * Gamma;
    const Scalar GJG = Gamma.dot(JGamma);
    if (momentum_map_) {
      const Scalar beta = (mu0_ - Gamma.dot(scene.momentum(s.omega, s.time))) / GJG;  // β = (μ₀ − μ)/(Γ·JΓ)
      if (beta * beta * Gamma.squaredNorm() <= limit) s.omega += beta * Gamma;
    }
    if (energy_) {
      const Vector3 v = momentum_map_ ? Vector3(s.omega - (s.omega.dot(JGamma) / GJG) * Gamma) : s.omega;
      const Scalar vJv = v.dot(J * v);
      if (!(vJv > Scalar(0))) return;  // v = 0: a sleeping top, no direction that keeps μ
      const Scalar alpha = (H0_ - scene.energy(s)) / vJv;  // α = (H₀ − H)/(v·Jv)
      if (alpha * alpha * v.squaredNorm() <= limit) s.omega += alpha * v;
    }
  }

  void hold_free(const Scene& scene, State<Scalar>& s) const {
    using std::abs;
    const auto& J_inv = scene.body().inertia_inverse();
    if (spatial_momentum_) {
      const Vector3 omega = J_inv * (s.rotation.inverse() * pi0_);  // Ω = J⁻¹Λᵀπ₀
      if ((omega - s.omega).squaredNorm() <= nudge * nudge * s.omega.squaredNorm()) s.omega = omega;
    }
    if (energy_) {
      const Vector3 Pi = scene.momentum(s.omega, s.time);
      const Vector3 Pi_dot = Pi.cross(s.omega);
      const Scalar rate = Pi_dot.norm();
      if (!(rate > Scalar(0))) return;  // a steady spin about a principal axis
      const Scalar lambda = (scene.energy(s) - H0_) / rate;  // λ = (H − H₀)/|Π̇|
      if (!(abs(lambda) <= nudge)) return;
      const Vector3 n = Pi_dot / rate;
      s.rotation = s.rotation.times_exp(lambda * n, detail::half_angle(abs(lambda)));
      s.omega = J_inv * (Pi - lambda * n.cross(Pi));
    }
  }

  bool energy_ = false, momentum_map_ = false, spatial_momentum_ = false;
  int lagrange_axis_ = -1;  ///< the Lagrange top's axis s whose Ω_s is held [A9] (−1: none)
  Scalar omega_s0_ = Scalar(0);
  Scalar H0_ = Scalar(0), mu0_ = Scalar(0);
  Vector3 pi0_ = Vector3::Zero();
};

}  // namespace trompo
