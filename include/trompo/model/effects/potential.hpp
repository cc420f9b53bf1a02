#pragma once
// A general conservative potential V(Λ) given by the user (docs/theory.md §1, §3).
//
//   // V = k (γ·ΛE)², with body gradient g = 2k (γ·ΛE) E × Λᵀγ
//   auto V = [=](const Eigen::Matrix3d& L) { const double s = up.dot(L * E); return k * s * s; };
//   auto g = [=](const Eigen::Matrix3d& L) -> Eigen::Vector3d {
//     return 2 * k * up.dot(L * E) * E.cross(L.transpose() * up); };
//   auto effect = make_potential<double>(V, g);              // Hessian by central differences
//   auto exact  = make_potential<double>(V, g, hessian);     // or the user's ∂g/∂w
//
// The body gradient g(Λ) is defined by dV = g·w for the right perturbation Λ exp(ŵ), so
// the body torque is −g(Λ) (uniform gravity: g = Mgl E × Λᵀγ, the torque −Mgl E × Λᵀγ of
// §1). The Hessian callable, if given, returns H(Λ) = ∂g/∂w for the same perturbation
// (not symmetric in general); without it, H is taken by central differences of g, with the
// step ε^(1/3) that balances truncation and round-off (relative error ~ε^(2/3), enough for
// a Newton tangent).
//
// Such a V is not linear in Λ, so the closed forms of Simo-κ (19) and of the collocation
// root [T2] do not apply: SimoKappa projects with κ = (V(Λ_{n+1}) − V(Λ_n))/f′(½) and
// SimoCollocation solves f′(α) = f(1) − f(0) for α numerically (schemes/simo.hpp); both
// keep H exact. Géradin–Bauchau's mid-point torque does not: its energy error is O(h³)
// per step (measured in tests/test_effects.cpp, docs/scenes.md).
//
// The callables are template parameters stored by value: no std::function, no allocation.
#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <type_traits>
#include <utility>

#include "trompo/model/effects/effect.hpp"
#include "trompo/lie/so3.hpp"

namespace trompo {

/// Marks a Potential without a Hessian callable (central differences of g are used).
struct NoHessian {};

/// A general conservative potential V(Λ), given by callables: V(Λ), its body gradient g(Λ)
/// (dV = g·w for Λ exp(ŵ)) and optionally its Hessian ∂g/∂w (else central differences of g).
/// Build it with make_potential(); docs/theory.md §3, §5.
template <class Scalar_, class V, class G, class H = NoHessian>
class Potential {
 public:
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// A conservative effect: enters H (effect.hpp).
  using kind = potential_kind;
  /// A general V: the closed forms of (19) and [T2] do not hold (schemes/simo.hpp).
  static constexpr bool linear_in_rotation = false;
  /// Whether a Hessian callable was given.
  static constexpr bool has_hessian = !std::is_same_v<H, NoHessian>;

  static_assert(std::is_invocable_v<const V&, const Matrix3&>, "Potential: V must be callable as V(Λ)");
  static_assert(std::is_invocable_v<const G&, const Matrix3&>, "Potential: g must be callable as g(Λ)");

  /// From the callables V(Λ), g(Λ) and, optionally, the Hessian.
  Potential(V v, G g, H hess = H{}) : v_(std::move(v)), g_(std::move(g)), h_(std::move(hess)) {}

  /// Λ_n, the start of the step; the potential is evaluated at Λ_n R.
  struct Cache {
    /// Λ_n.
    Matrix3 Lambda_n;
  };
  /// Keeps Λ_n for the step.
  Cache cache(const Matrix3& Lambda_n, Scalar /*t_mid*/) const { return {Lambda_n}; }

  /// V(Λ_n R)
  Scalar potential(const Cache& c, const Matrix3& R) const { return Scalar(v_(Matrix3(c.Lambda_n * R))); }
  /// −R g(Λ_n R): the body torque −g at Λ_n R, expressed in the frame of step n.
  Vector3 torque(const Cache& c, const Matrix3& R) const { return -(R * gradient(Matrix3(c.Lambda_n * R))); }
  /// ∂/∂w of −R exp(ŵ) g(Λ_n R exp(ŵ)) = −R(ŵ g + H w) = R(ĝ − H) w.
  Matrix3 torque_jacobian(const Cache& c, const Matrix3& R) const {
    const Matrix3 L = c.Lambda_n * R;
    return R * (SO3<Scalar>::hat(gradient(L)) - gradient_jacobian(L));
  }

  /// g(Λ), dV = g·w for Λ exp(ŵ).
  Vector3 gradient(const Matrix3& Lambda) const { return Vector3(g_(Lambda)); }
  /// H(Λ) = ∂g/∂w: the user's, or central differences of g with step ε^(1/3).
  Matrix3 gradient_jacobian(const Matrix3& Lambda) const {
    if constexpr (has_hessian) {
      return Matrix3(h_(Lambda));
    } else {
      using std::cbrt;
      const Scalar d = cbrt(std::numeric_limits<Scalar>::epsilon());
      Matrix3 Hd;
      for (int j = 0; j < 3; ++j) {
        const Vector3 w = d * Vector3::Unit(j);
        Hd.col(j) = (gradient(Matrix3(Lambda * SO3<Scalar>::exp_matrix(w))) -
                     gradient(Matrix3(Lambda * SO3<Scalar>::exp_matrix(Vector3(-w))))) /
                    (Scalar(2) * d);
      }
      return Hd;
    }
  }

 private:
  V v_;
  G g_;
  [[no_unique_address]] H h_;
};

/// make_potential<double>(V, g): a Potential with the callables' types deduced and the
/// Hessian by central differences.
template <class Scalar, class V, class G>
Potential<Scalar, std::decay_t<V>, std::decay_t<G>> make_potential(V&& v, G&& g) {
  return {std::forward<V>(v), std::forward<G>(g)};
}
/// make_potential<double>(V, g, H): with the user's Hessian H(Λ) = ∂g/∂w.
template <class Scalar, class V, class G, class H>
Potential<Scalar, std::decay_t<V>, std::decay_t<G>, std::decay_t<H>> make_potential(V&& v, G&& g, H&& hess) {
  return {std::forward<V>(v), std::forward<G>(g), std::forward<H>(hess)};
}

}  // namespace trompo
