#pragma once
// The Simo family's shared machinery, eqs. (9)–(11), (17)–(19), restated as [T1]–[T3].
// The schemes themselves (their parameters and traits) are in schemes/simo_alpha.hpp,
// schemes/simo_collocation.hpp and schemes/simo_kappa.hpp; each picks its SimoVariant.
//
// Unknown: Θ, the incremental rotation vector in the body frame of step n, with
//   Ω_{n+1} = 2Θ/h − Ω_n,   Λ_{n+1} = Λ_n exp(Θ̂),   Λ_{n+ξ} = Λ_n exp(ξΘ̂).
// Residual [T1], with the effects of the scene (docs/theory.md §5):
//   R(Θ) = exp(Θ̂) Π_{n+1} − Π_n − h κ τ_c(Λ_{n+α}) − h τ_a(Λ_{n+½}, Θ/h)
// where τ_c is the conservative torque (gravity), τ_a the applied torques, both in frame
// n, and Π = JΩ + h_r. The three schemes differ only in α and κ:
//   SimoAlpha        α fixed in [0,1], κ = 1          (α = ½: Simo–Wong)
//   SimoCollocation  κ = 1, α = α(Θ) from (17)/[T2]    (energy exact)
//   SimoKappa        α = ½, κ = sin(θ/2)/(θ/2), (19)   (energy exact)
// For potentials linear in Λ (uniform gravity) α of collocation and κ have closed forms;
// for a general V (effects/potential.hpp) collocation solves (17) for α numerically and
// Simo-κ projects with κ = (V(Λ_{n+1}) − V(Λ_n))/f′(½) (docs/theory.md §3): both stay exact.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

#include "trompo/errors.hpp"
#include "trompo/solvers/newton.hpp"
#include "trompo/schemes/history.hpp"
#include "trompo/schemes/implicit_step.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/schemes/state_residue.hpp"
#include "trompo/schemes/step_data.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"

namespace trompo {
namespace detail {

/// The traits of the energy-exact Simo schemes (Simo-κ, collocation): order 2, symmetric
/// (may be composed); keep H, μ and π (free body). Their memory, the history predictor's,
/// is only a hint: a plain State may be stepped (with fresh memory). The step writes the
/// memory only when it succeeds, after checking its result (scheme.hpp): the Stepper
/// steps the memory in place, without copies.
inline constexpr SchemeTraits energy_exact_simo_traits{
    .order = 2,
    .symmetric = true,
    .keeps =
        [](SceneKind s) {
          return Keeps{.energy = true, .momentum_map = true, .spatial_momentum = s.is_free || s.wheels_only()};
        },
    .carries_wheels = true,
    .memory = MemoryUse::hint,
    .writes_memory_on_success = true};

/// Which member of the Simo family: how α and κ of [T1] are chosen.
enum class SimoVariant {
  fixed_alpha,  ///< Simo-α: α given, κ = 1
  collocation,  ///< α(Θ) from (17)/[T2], κ = 1
  kappa         ///< α = ½, κ = sin(θ/2)/(θ/2) (19) or its projection
};

/// The collocation root of [T2] for potentials linear in Λ, written about the midpoint:
/// with s = α − ½ and f(ξ) = A + B′ cos sθ + C′ sin sθ, the condition f(1) − f(0) = f′(α)
/// reads C′(cos sθ − κ) = B′ sin sθ. With t = tan(sθ/2) it is the quadratic
///   C′(1+κ) t² + 2B′ t − C′(1−κ) = 0,
/// whose small root (the α nearest ½) we take in the cancellation-free form.
/// B′ = n·J_c n and C′ = −n·τ_c come from the torque at the midpoint (f″(½) = −θ²B′,
/// f′(½) = θC′). θ = 0 or B′ = C′ = 0 (sleeping top) give α = ½.
/// Where B′ changes sign the two roots are ½ ± ~0.29, equally near ½, and α(Θ) jumps
/// between them (no continuous choice exists: one root leaves [0,1] on each side). Newton
/// can then fail to settle (measured: 1 step in 10⁴ on random tops at |Θ| ≈ 0.1); the
/// step is reported and integrate() recovers it by sub-steps, each energy-exact.
template <class Scalar>
Scalar collocation_alpha(Scalar theta, Scalar B, Scalar C) {
  using std::atan;
  using std::sqrt;
  if (theta == Scalar(0) || (B == Scalar(0) && C == Scalar(0))) return Scalar(0.5);
  const Scalar omk = one_minus_kappa(theta);       // 1 − κ, no cancellation
  const Scalar opk = Scalar(2) - omk;              // 1 + κ
  const Scalar root = sqrt(B * B + C * C * omk * opk);
  const Scalar t = C * omk / (B + (B >= Scalar(0) ? root : -root));
  Scalar s = Scalar(2) * atan(t) / theta;
  // The mean-value theorem puts a root in (0,1); guard the last ulp.
  if (s > Scalar(0.5)) s = Scalar(0.5);
  if (s < Scalar(-0.5)) s = Scalar(-0.5);
  return Scalar(0.5) + s;
}

/// The collocation root for a general potential (docs/theory.md §3): an α ∈ [0,1] with
/// φ(α) = f′(α) − (f(1) − f(0)) = 0, the one nearest `center`. `phi(ξ, dphi)` returns φ(ξ)
/// and, if dphi is not null, sets *dphi = φ′(ξ) = f″(ξ); |φ| ≤ tol counts as 0 (round-off).
/// The mean-value theorem puts a root in (0,1); there may be two or more. A bracket is
/// sought first between `center` and twice the Newton step from it, then by scanning
/// outward from `center` in steps of 1/32 (the Newton step's side first); inside the
/// bracket, a safeguarded Newton iteration (bisection whenever a Newton step leaves the
/// bracket or does not halve the previous step). Returns false if no sign change of φ is
/// found (φ only touches 0 where two roots merge, or both lie within one 1/32 cell): the
/// step has no energy-exact α that can be followed.
template <class Scalar, class Phi>
bool collocation_alpha_general(Phi& phi, Scalar center, Scalar tol, Scalar& alpha) {
  using std::abs;
  constexpr Scalar eps = std::numeric_limits<Scalar>::epsilon();
  const Scalar zero(0), one(1);
  Scalar d_c(0);
  const Scalar p_c = phi(center, &d_c);
  if (!(abs(p_c) > tol)) {
    alpha = center;
    return true;
  }
  const auto opposite = [&](Scalar p) { return (p > zero) != (p_c > zero) || abs(p) <= tol; };
  const auto clamp01 = [&](Scalar x) { return x < zero ? zero : (x > one ? one : x); };

  // Safeguarded Newton on a bracket: φ(a) = pa, φ′(a) = da (0: unknown), φ(b) opposite.
  const auto solve = [&](Scalar a, Scalar pa, Scalar da, Scalar b, Scalar pb) {
    Scalar x = a, px = pa, dx = da;
    Scalar lo = a < b ? a : b, hi = a < b ? b : a;
    Scalar p_lo = a < b ? pa : pb;
    Scalar last = hi - lo;
    for (int it = 0; it < 200; ++it) {
      Scalar next = x;
      bool newton_step = dx != zero;
      if (newton_step) {
        next = x - px / dx;
        newton_step = next > lo && next < hi && abs(next - x) <= last / Scalar(2);
      }
      if (!newton_step) next = (lo + hi) / Scalar(2);
      last = abs(next - x);
      x = next;
      px = phi(x, &dx);
      if (abs(px) <= tol) return x;
      if ((px > zero) == (p_lo > zero)) {
        lo = x;
        p_lo = px;
      } else {
        hi = x;
      }
      if (hi - lo <= Scalar(4) * eps) return x;
    }
    return x;
  };

  // 1. Newton's guess c + s: the root is most likely in [c, c + 2s].
  bool right_first = true;
  if (d_c != zero) {
    const Scalar s = -p_c / d_c;
    right_first = s > zero;
    const Scalar b = clamp01(center + Scalar(2) * s);
    if (b != center) {
      const Scalar p_b = phi(b, nullptr);
      if (opposite(p_b)) {
        alpha = solve(center, p_c, d_c, b, p_b);
        return true;
      }
    }
  }
  // 2. Scan outward from the center, alternating sides, the Newton step's side first.
  Scalar prev[2] = {center, center}, p_prev[2] = {p_c, p_c}, d_prev[2] = {d_c, d_c};
  for (int k = 1; k <= 32; ++k) {
    for (int side = 0; side < 2; ++side) {
      const Scalar dir = (side == 0) == right_first ? one : -one;
      const Scalar x = clamp01(center + dir * Scalar(k) / Scalar(32));
      if (x == prev[side]) continue;  // this side's end already reached
      const Scalar p = phi(x, nullptr);
      if (opposite(p)) {
        alpha = solve(prev[side], p_prev[side], d_prev[side], x, p);
        return true;
      }
      prev[side] = x;
      p_prev[side] = p;
      d_prev[side] = zero;
    }
  }
  return false;
}

template <SimoVariant V, class Scene>
class SimoResidual {
 public:
  using Scalar = typename Scene::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  using G = SO3<Scalar>;
  /// Simo-κ and collocation project a potential that is not linear in Λ numerically.
  static constexpr bool general_projection =
      Scene::has_potential && !Scene::potentials_linear &&
      (V == SimoVariant::kappa || V == SimoVariant::collocation);

  /// `alpha` is Simo-α's parameter (ignored by the other variants).
  SimoResidual(double alpha, const StepData<Scene>& d) : alpha_(alpha), d_(d), V_n_(start_potential(d)) {}

  /// [T1] and its tangent [T3] at Θ = hΩ_n + y. Newton's unknown is y, the departure
  /// from the rigid rotation, so that Ω_{n+1} = Ω_n + 2y/h adds a small correction to
  /// Ω_n instead of subtracting two large numbers (2Θ/h − Ω_n): the latter leaves a
  /// biased round-off in the spin that makes H and μ drift like N·ε over long runs.
  /// With K null only R and scale are computed (bit-identical to a full evaluation; the
  /// simplified Newton of detail::newton). Always in the domain for uniform gravity
  /// (T is singular only at 2π, which the branch rule excludes).
  bool operator()(const Vector3& y, Vector3& R, Matrix3* K, Scalar& scale) const {
    const Scene& scene = d_.scene;
    const Scalar h = d_.h;
    const Matrix3& J = scene.body().inertia();
    const Vector3 Theta = h * d_.omega_n + y;
    // exp(Θ̂) = I + aΘ̂ + bΘ̂² (8), T(Θ) = I − bΘ̂ + cΘ̂² (docs/theory.md §2), κ (19) and the half
    // rotation exp(Θ̂/2) share θ and the half-angle pair (κ, cos θ/2): computed once
    // here (SO3::exp_matrix, right_tangent and kappa would each redo them).
    // κ and cos(θ/2) from |Θ|², so that the square root θ (used only by the tangent and
    // some variants) is not on the chain from y to R (half_angle_from_squared).
    const Scalar theta_sq = Theta.squaredNorm();
    const detail::HalfAngle<Scalar> ha = detail::half_angle_from_squared(theta_sq);
    const Scalar theta = std::sqrt(theta_sq);
    const Scalar a = ha.sinc();
    const Scalar b = ha.one_minus_cos_over_sq();
    Vector3 dPi = (Scalar(2) / h) * scene.body().momentum(y);  // Π_{n+1} − Π_n = (2/h) J y
    if constexpr (Scene::has_wheels) dPi += d_.dh_w;                  // + h_w(t_{n+1}) − h_w(t_n)  [W4]
    const Vector3 Pi_next = d_.Pi_n + dPi;
    // [T1] momentum part, exp(Θ̂)Π_{n+1} − Π_n, written without the matrix Q:
    //   (Π_{n+1} − Π_n) + a Θ×Π_{n+1} + b Θ×(Θ×Π_{n+1}),  Π_{n+1} − Π_n = (2/h) J y,
    // with a, b the coefficients of (8). The product Q Π_{n+1} would round the diagonal
    // 1 − b|Θ⊥|² of Q once per step with a bias that persists while the motion is
    // near-steady (HT1: Θ almost along the spin axis), and H, μ drifted like N·ε
    // (−4e-12 after 1e6 steps of Simo-κ on HT1). Every term here is small.
    const Vector3 c1 = Theta.cross(Pi_next);
    R = dPi + a * c1 + b * Theta.cross(c1);
    scale = d_.Pi_n_norm + Pi_next.norm();
    // Q = exp(Θ̂) and T(Θ): needed by the tangent, and by the general potentials' and
    // collocation's energy terms (V and τ at Λ_{n+1}); not by R otherwise.
    constexpr bool need_Q = general_projection;
    Matrix3 Q, T;
    if (K || need_Q) {
      const Matrix3 X = G::hat(Theta);
      const Matrix3 X2 = G::hat_squared(Theta);
      Q = Matrix3::Identity() + a * X + b * X2;
      T = Matrix3::Identity() - b * X + detail::theta_minus_sin_over_cube(theta) * X2;
    }
    if (K) *K = Q * ((Scalar(2) / h) * J - G::hat(Pi_next) * T);  // [T3] first line

    if constexpr (Scene::has_potential) {
      if (!add_conservative(Theta, theta, ha, Q, T, R, K, scale)) return false;  // general V: no projection
    }
    if constexpr (Scene::has_applied_torque) {
      // τ_a at Λ_{n+½}, Ω_m = Θ/h (docs/theory.md §5); ∂/∂Θ through w = ½T(Θ/2)δΘ and Ω_m.
      const Vector3 half = Theta / Scalar(2);
      Matrix3 d_rot, d_omega;
      const Vector3 tau = scene.applied_torque(d_.caches, half_rotation(Theta, ha), Theta / h,
                                               K ? &d_rot : nullptr, K ? &d_omega : nullptr);
      R -= h * tau;
      if (K) *K -= (h / Scalar(2)) * d_rot * G::right_tangent(half) + d_omega;
      scale += std::abs(h) * tau.norm();
    }
    return true;
  }
  /// Residual and tangent (the full evaluation).
  bool operator()(const Vector3& y, Vector3& R, Matrix3& K, Scalar& scale) const {
    return (*this)(y, R, &K, scale);
  }

 private:
  /// V(Λ_n), needed only by the general-potential projections of Simo-κ and collocation.
  static Scalar start_potential(const StepData<Scene>& d) {
    if constexpr (general_projection) return d.scene.potential(d.caches, Matrix3::Identity());
    else return Scalar(0);
  }

  /// The potentials' terms of [T1] and [T3]. False when the projection of a general V
  /// does not exist at this Θ (see below): Newton then reports out_of_domain, and
  /// integrate() retries the interval as sub-steps.
  /// exp(Θ̂/2) = I + κ Θ̂/2 + (κ²/(1 + cos θ/2)) (Θ̂/2)² (8), from the half-angle pair.
  static Matrix3 half_rotation(const Vector3& Theta, const detail::HalfAngle<Scalar>& ha) {
    return G::rodrigues(Theta / Scalar(2), ha.kappa, ha.half_one_minus_cos_over_sq());
  }

  /// `theta` = ‖Θ‖, as the caller computed it (not recomputed: GCC does not share the
  /// square root between the two).
  bool add_conservative(const Vector3& Theta, Scalar theta, const detail::HalfAngle<Scalar>& ha, const Matrix3& Q,
                        const Matrix3& T, Vector3& R, Matrix3* K, Scalar& scale) const {
    const Scene& scene = d_.scene;
    const Scalar h = d_.h;
    constexpr Scalar eps = std::numeric_limits<Scalar>::epsilon();
    Scalar alpha(0.5);
    Scalar kappa(1);
    if constexpr (V == SimoVariant::fixed_alpha) {
      alpha = Scalar(alpha_);
    } else if constexpr (V == SimoVariant::kappa && Scene::potentials_linear) {
      kappa = ha.kappa;                                                // (19)
    }

    // General potential (docs/theory.md §3): f(ξ) = V(Λ_n exp(ξΘ̂)), f′(ξ) = −Θ·τ(ξΘ), and the
    // energy change f(1) − f(0) that the projections must reproduce.
    [[maybe_unused]] Scalar dV(0);          // f(1) − f(0)
    [[maybe_unused]] Scalar V_scale(0);     // |V_n| + |V_{n+1}|: the round-off of dV is ~ε·V_scale
    [[maybe_unused]] Vector3 tau_1;         // τ at Λ_{n+1}
    if constexpr (general_projection) {
      const Scalar V_1 = scene.potential(d_.caches, Q);
      dV = V_1 - V_n_;
      V_scale = std::abs(V_n_) + std::abs(V_1);
      tau_1 = scene.conservative_torque(d_.caches, Q);
    }

    if constexpr (V == SimoVariant::collocation) {
      if constexpr (Scene::potentials_linear) {
        // α(Θ) from [T2], via the midpoint torque and its Jacobian.
        const Matrix3 R_half = half_rotation(Theta, ha);
        Matrix3 J_half;
        const Vector3 tau_half = scene.conservative_torque(d_.caches, R_half, &J_half);
        Scalar B(0), C(0);
        if (theta > Scalar(0)) {
          const Vector3 n = Theta / theta;
          B = n.dot(J_half * n);   // f″(½) = −θ²B′
          C = -n.dot(tau_half);    // f′(½) = θC′
        }
        alpha = collocation_alpha(theta, B, C);
      } else if (theta > Scalar(0)) {
        // α: a root of φ(ξ) = f′(ξ) − (f(1) − f(0)) on [0,1] (17), with
        // φ′(ξ) = f″(ξ) = −Θ·J_ξ Θ.
        // φ's round-off: V's, and V's response to the attitude's (see Simo-κ below).
        const Scalar tol = Scalar(16) * eps * (V_scale + (Scalar(1) + theta) * Scalar(2) * tau_1.norm());
        auto phi = [&](Scalar xi, Scalar* dphi) {
          const Matrix3 R_xi = G::exp_matrix(xi * Theta);
          if (!dphi) return -Theta.dot(scene.conservative_torque(d_.caches, R_xi)) - dV;
          Matrix3 J_xi;
          const Vector3 tau_xi = scene.conservative_torque(d_.caches, R_xi, &J_xi);
          *dphi = -Theta.dot(J_xi * Theta);
          return -Theta.dot(tau_xi) - dV;
        };
        // Of several roots, the one nearest the previous iterate's α (½ at the first):
        // "nearest ½" alone jumps between two roots ½ ± 0.29 where f″(½) changes sign,
        // and Newton then cycles; following one root keeps α(Θ) continuous.
        // No sign change of φ anywhere (two roots merged): no exact α at this Θ.
        if (!collocation_alpha_general(phi, alpha_last_, tol, alpha)) return false;
        alpha_last_ = alpha;
      }
    }

    const Vector3 a_Theta = alpha * Theta;
    // J_α = ∂τ/∂w at Λ_{n+α}: the tangent's, and (general V) the projections' scales.
    const bool need_J = K || general_projection;
    Matrix3 J_alpha, T_alpha;
    Vector3 tau;
    if (alpha == Scalar(0.5)) {
      // τ at exp(Θ̂/2) from Θ/2 and the half-angle pair's Rodrigues coefficients: gravity
      // rotates its body vector by two cross products instead of forming the half
      // rotation as a 3×3 matrix (measured: ~80 of ~1,990 instructions per Simo-κ step
      // on HT1). τ is computed this way with or without the tangent, so that R stays
      // bit-identical between the two kinds of evaluation; the Jacobian needs the matrix.
      tau = scene.conservative_torque_rodrigues(d_.caches, Theta / Scalar(2), ha.kappa,
                                                ha.half_one_minus_cos_over_sq());
      if (need_J) scene.conservative_torque(d_.caches, half_rotation(Theta, ha), &J_alpha);
    } else {
      tau = scene.conservative_torque(d_.caches, G::exp_matrix(a_Theta), need_J ? &J_alpha : nullptr);
    }
    if (K) {
      // T(Θ/2) = I − b_½ Θ̂/2 + c_½ (Θ̂/2)² (docs/theory.md §2), b_½ from the half-angle pair.
      const Vector3 x = Theta / Scalar(2);
      T_alpha = alpha == Scalar(0.5) ? Matrix3(Matrix3::Identity() - ha.half_one_minus_cos_over_sq() * G::hat(x) +
                                               detail::theta_minus_sin_over_cube(theta / Scalar(2)) * G::hat_squared(x))
                                     : G::right_tangent(a_Theta);
    }

    [[maybe_unused]] Vector3 grad_f_1 = Vector3::Zero();  // ∇_Θ f(1) = −T(Θ)ᵀ Qᵀ τ_1
    if constexpr (general_projection) {
      if (K) grad_f_1 = -T.transpose() * (Q.transpose() * tau_1);
    }

    [[maybe_unused]] Vector3 grad_kappa = Vector3::Zero();
    if constexpr (V == SimoVariant::kappa && !Scene::potentials_linear) {
      // κ = (f(1) − f(0)) / f′(½), f′(½) = −Θ·τ(½) (docs/theory.md §3). κ = 1 when that already
      // balances the energy to round-off (θ → 0, or f‴ negligible), which also keeps the
      // ratio of two round-off-level numbers out of κ. The projection is singular where
      // f′(½) → 0 while f(1) − f(0) − f′(½) = f‴/24 + … does not (a step whose midpoint
      // sits at an extremum of V along the path): there is no κ (return false) once
      // |κ − 1| would exceed 4, and near that κ(Θ) is steep and Newton may fail. Either
      // way the step is reported, and integrate() recovers it by sub-steps: their
      // midpoints lie elsewhere, and κ − 1 = O(θ) on them. H stays exact.
      // The round-off of f(1) − f(0) and f′(½) is ~ε·f_scale: V's own, and the response
      // ‖g‖δ + ½‖H‖δ² of V to the round-off δ ~ ε of the attitude (near an equilibrium V
      // and g vanish, and only the last term is left).
      const Scalar fp = -Theta.dot(tau);
      const Scalar f_scale = V_scale + (Scalar(1) + theta) * tau.norm() + eps * J_alpha.norm();
      const Scalar noise = Scalar(16) * eps * f_scale;
      if (std::abs(dV - fp) > noise) {
        if (!(Scalar(4) * std::abs(fp) >= std::abs(dV - fp))) return false;  // |κ − 1| > 4
        kappa = dV / fp;
        if (K) {
          // ∇κ = (∇f(1) − κ ∇f′(½)) / f′(½),  ∇f′(½) = −τ_½ − ½ T(½Θ)ᵀ J_½ᵀ Θ
          const Vector3 grad_fp = -tau - (alpha * T_alpha.transpose()) * (J_alpha.transpose() * Theta);
          grad_kappa = (grad_f_1 - kappa * grad_fp) / fp;
        }
        // The residual's scale counts the summands V_{n+1}/f′ and V_n/f′ of κ before
        // they cancel: at small θ their round-off, ε·f_scale/|f′(½)| relative, is what
        // the residual can be resolved to (a step from rest would otherwise stall). The
        // allowance stops at |f′(½)| = θ‖τ‖/8, so that the energy error it admits,
        // Θ·δR/h ≤ 64ε·f_scale·θ‖τ‖/|f′(½)|, stays below 512ε·f_scale; closer to the
        // pole Newton fails instead and the step is recovered.
        scale += std::abs(h) * tau.norm() * f_scale / std::max(std::abs(fp), theta * tau.norm() / Scalar(8));
      }
    }

    R -= h * kappa * tau;                                                 // [T1] load term
    scale += std::abs(h) * tau.norm();
    if constexpr (general_projection && V == SimoVariant::collocation) {
      if (!K) {
        // The residual's scale term of the tangent block below (same value).
        add_collocation_scale(Theta, theta, tau, J_alpha, V_scale, scale);
        return true;
      }
    }
    if (!K) return true;
    *K -= (h * kappa * alpha) * J_alpha * T_alpha;                        // [T3] second line

    if constexpr (V == SimoVariant::kappa) {
      if constexpr (Scene::potentials_linear) {
        // [T3] third line: −h τ ⊗ ∇κ, ∇κ = (κ′(θ)/θ) Θ.
        *K -= (h * detail::kappa_prime_over_theta(theta)) * tau * Theta.transpose();
      } else {
        *K -= h * tau * grad_kappa.transpose();                            // [T3] third line
      }
    }
    if constexpr (V == SimoVariant::collocation) {
      // [T3] fourth line: −hκ (∂τ/∂α) ⊗ ∇α with ∂τ/∂α = J_α Θ. ∇α by implicit
      // differentiation of g(α, Θ) = f′(α) − f(1) + f(0) = 0, f(ξ) = V(Λ_n exp(ξΘ̂)):
      //   ∂g/∂α = f″(α) = −Θ·J_α Θ
      //   ∇_Θ f′(α) = −τ_α − α T(αΘ)ᵀ J_αᵀ Θ,   ∇_Θ f(1) = −T(Θ)ᵀ Qᵀ τ_1
      const Vector3 dtau_dalpha = J_alpha * Theta;
      const Scalar f2 = -Theta.dot(dtau_dalpha);
      const Scalar f2_floor = std::numeric_limits<Scalar>::epsilon() * J_alpha.norm() * theta * theta;
      if (theta > Scalar(0) && std::abs(f2) > f2_floor) {
        if constexpr (Scene::potentials_linear) {
          const Vector3 tau_one = scene.conservative_torque(d_.caches, Q);
          grad_f_1 = -T.transpose() * (Q.transpose() * tau_one);
        }
        const Vector3 grad_f1_alpha =
            -tau - alpha * T_alpha.transpose() * (J_alpha.transpose() * Theta);
        const Vector3 grad_alpha = -(grad_f1_alpha - grad_f_1) / f2;
        *K -= h * dtau_dalpha * grad_alpha.transpose();
      }
      if constexpr (!Scene::potentials_linear) add_collocation_scale(Theta, theta, tau, J_alpha, V_scale, scale);
    }
    return true;
  }

  /// Collocation, general V: α carries the round-off of f(1) − f(0) divided by f″(α),
  /// and the residual that of h J_α Θ δα; count it in the residual's scale (capped as
  /// for Simo-κ: at |f″(α)| = θ²‖J_α‖/8).
  void add_collocation_scale(const Vector3& Theta, Scalar theta, const Vector3& tau, const Matrix3& J_alpha,
                             Scalar V_scale, Scalar& scale) const {
    const Vector3 dtau_dalpha = J_alpha * Theta;
    const Scalar f2 = -Theta.dot(dtau_dalpha);
    const Scalar f2_floor = std::numeric_limits<Scalar>::epsilon() * J_alpha.norm() * theta * theta;
    if (theta > Scalar(0) && std::abs(f2) > f2_floor)
      scale += std::abs(d_.h) * dtau_dalpha.norm() * (V_scale + (Scalar(1) + theta) * tau.norm()) /
               std::max(std::abs(f2), theta * theta * J_alpha.norm() / Scalar(8));
  }

  double alpha_;  ///< Simo-α's α (fixed_alpha only)
  const StepData<Scene>& d_;
  Scalar V_n_;  ///< V(Λ_n) (general_projection only; 0 otherwise)
  /// Collocation, general V: the root α of the previous evaluation (see add_conservative).
  mutable Scalar alpha_last_ = Scalar(0.5);
};

/// A Simo step as the problem of detail::implicit_step: Newton's unknown is y = Θ − hΩ_n
/// (see SimoResidual), the history extrapolates Θ.
template <SimoVariant V, class Scene>
class SimoProblem {
 public:
  using Scalar = typename Scene::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;

  /// `residue`: the compensated state's residue at the start (null: not compensated).
  SimoProblem(double alpha, const StepData<Scene>& d, const State<Scalar>& in, const StateResidue<Scalar>* residue = nullptr)
      : alpha_(alpha), d_(d), in_(in), base_(d.h * in.omega), residue_(residue) {}

  /// [T1] and [T3] (a fresh one per solve: collocation's general α follows its iterates).
  SimoResidual<V, Scene> residual() const { return SimoResidual<V, Scene>(alpha_, d_); }
  /// [P1]: Θ⁰ the extrapolated increment.
  ImplicitStart<Scalar> from_history(const Vector3& Theta0) const { return start(Theta0); }
  /// Θ⁰ = hΩ_n + (h²/2)Ω̇_n.
  ImplicitStart<Scalar> memoryless() const { return start(d_.predicted_increment()); }
  /// Θ = hΩ_n + y and |Θ|.
  ImplicitRoot<Scalar> root(const Vector3& y) const {
    const Vector3 Theta = base_ + y;
    return {Theta, Theta.norm()};
  }
  /// The fold rule det(K J⁻¹)·h > 0 (K → (2/h)J as h → 0 on the continued branch); J is
  /// positive definite, so the sign is that of det(K)·h.
  Scalar orientation(const Matrix3& K) const { return K.determinant() * d_.h; }
  /// The same from K⁻¹ (det K⁻¹ has the sign of det K).
  Scalar orientation_inverse(const Matrix3& K_inv) const { return K_inv.determinant() * d_.h; }
  /// (9)–(10) from the root y; compensated, the residue of the result goes to next_residue().
  void advance(const Vector3& y, State<Scalar>& out) const {
    const Scalar h = d_.h;
    const Vector3 Theta = base_ + y;
    const HalfAngle<Scalar> c = half_angle_from_squared(Theta.squaredNorm());
    if (residue_) {
      residue_->advance(in_, Scalar(2) * y / h, Theta, c, h, out, next_residue_);  // (9)–(10), [K2]–[K3]
      return;
    }
    // Λ_{n+1} = Λ_n exp(Θ̂), with no square root or division on the way (SO3::times_exp).
    out.rotation = in_.rotation.times_exp(Theta, c);
    out.omega = in_.omega + Scalar(2) * y / h;                // Ω_{n+1} = 2Θ/h − Ω_n  (9)
    out.time = in_.time + h;
  }
  /// The residue of advance()'s result (compensated steps only).
  const StateResidue<Scalar>& next_residue() const { return next_residue_; }
  /// The history records Θ.
  Vector3 recorded(const Vector3& y) const { return base_ + y; }

 private:
  ImplicitStart<Scalar> start(const Vector3& Theta0) const { return {Theta0 - base_, Theta0, Theta0.norm()}; }

  double alpha_;
  const StepData<Scene>& d_;
  const State<Scalar>& in_;
  Vector3 base_;  ///< hΩ_n
  const StateResidue<Scalar>* residue_;  ///< the start's residue (null: not compensated)
  mutable StateResidue<Scalar> next_residue_;  ///< the result's, written by advance()
};

/// The per-trajectory memory of Simo-κ and collocation: the history predictor's
/// increments and tangent, and the compensated state's residue (docs/theory.md §18).
template <class Scalar>
using SimoMemory = CompensatedMemory<Scalar>;

/// One step of a Simo scheme: Newton on [T1] from the predictor, then (9)–(10), by the
/// implicit-step sequence (implicit_step.hpp). With `history` (the scheme's memory, null
/// for none) the predictor is the extrapolation of the last increments and the first
/// tangent the carried one, when the history allows (IncrementHistory, [P1]–[P3]); if that
/// solve fails, the step is solved once more from the memoryless start before it reports
/// failure. On success the accepted Θ is recorded. With `residue` (null: none) the state is
/// compensated (docs/theory.md §18) and, on success, the residue of `out` replaces it.
template <SimoVariant V, class Scene>
StepReport<typename Scene::Scalar> simo_step(double alpha, const Scene& scene,
                                             const State<typename Scene::Scalar>& in,
                                             typename Scene::Scalar h,
                                             const NewtonOptions<typename Scene::Scalar>& opt,
                                             State<typename Scene::Scalar>& out,
                                             IncrementHistory<typename Scene::Scalar>* history = nullptr,
                                             StateResidue<typename Scene::Scalar>* residue = nullptr) {
  using Scalar = typename Scene::Scalar;
  const StepData<Scene> d(scene, in, h);
  // The numerically projected α or κ of a general potential is resolved only to a
  // tolerance, so R is smooth only down to that level and the contraction estimates of
  // the simplified Newton are not reliable there (measured: 8× the energy error with
  // them): plain Newton for those.
  NewtonOptions<Scalar> options = opt;
  if constexpr (SimoResidual<V, Scene>::general_projection) options.reuse_tangent = Scalar(0);
  const SimoProblem<V, Scene> problem(alpha, d, in, residue);
  const StepReport<Scalar> rep = implicit_step(problem, options, h, out, history);
  if (rep.ok() && residue) *residue = problem.next_residue();  // written on success only
  return rep;
}

}  // namespace detail
}  // namespace trompo
