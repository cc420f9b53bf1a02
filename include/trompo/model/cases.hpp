#pragma once
// The standard cases of docs/theory.md §7–8, as ready-made scenes and initial states.
//
//   auto c = trompo::cases::ht1<double>();
//   Stepper<SimoKappa, HeavyTop<double>> stepper(SimoKappa{}, c.scene);
//   State<double> s = c.initial;          // then step to c.t_end
#include <Eigen/Core>
#include <cmath>

#include "trompo/model/body.hpp"
#include "trompo/model/effects/uniform_gravity.hpp"
#include "trompo/model/scene.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"

namespace trompo::cases {

/// A standard case: a scene, its initial state and its end time (docs/theory.md §7–8).
template <class SceneT_>
struct Case {
  /// The scene type (Top or Free).
  using SceneT = SceneT_;
  /// The scalar type of the scene.
  using Scalar = typename SceneT::Scalar;
  /// "ht0", "ht1", "ht2", "fb1" or "fb2".
  const char* name;
  /// The body and its effects.
  SceneT scene;
  /// The initial state at t = 0.
  State<Scalar> initial;
  /// The end time of the case.
  Scalar t_end;
};

/// The scene of the heavy-top cases: a body under uniform gravity.
template <class Scalar>
using Top = Scene<Scalar, UniformGravity<Scalar>>;
/// The scene of the free-body cases: no effects.
template <class Scalar>
using Free = Scene<Scalar>;

namespace detail {
template <class Scalar>
Case<Top<Scalar>> lagrange_top(const char* name, Scalar Mgl, Scalar tilt, Scalar t_end) {
  using V = Eigen::Matrix<Scalar, 3, 1>;
  State<Scalar> s;
  s.rotation = SO3<Scalar>::exp(V(tilt, 0, 0));
  s.omega = V(0, 0, 50);
  return {name, Top<Scalar>(RigidBody<Scalar>(V(5, 5, 1)), UniformGravity<Scalar>(Mgl, V::UnitZ(), V::UnitZ())), s,
          t_end};
}
}  // namespace detail

/// HT0, docs/theory.md §7: J = diag(5,5,1), Mgl = 196.2 (20·9.81), E = γ = e3,
/// Λ0 = exp(0.3 ê1), Ω0 = (0, 0, 50); t ∈ [0, 10] (the §7 table runs to t = 1).
template <class Scalar = double>
Case<Top<Scalar>> ht0() {
  return detail::lagrange_top<Scalar>("ht0", Scalar(196.2L), Scalar(0.3L), Scalar(10));
}

/// HT1, docs/theory.md §8: the symmetric heavy top of Simo & Wong (1991): Mgl = 20, tilt 0.05.
template <class Scalar = double>
Case<Top<Scalar>> ht1() {
  return detail::lagrange_top<Scalar>("ht1", Scalar(20), Scalar(0.05L), Scalar(10));
}

/// HT2, docs/theory.md §8: the fast asymmetric top of Brüls & Cardona (2010): M = 15, l = 1,
/// g = 9.81, E = e2, γ = e3, Λ0 = I, Ω0 = (0, 150, −4.61538), inertia about the fixed
/// point J = diag(15.234375, 0.46875, 15.234375); t ∈ [0, 2].
template <class Scalar = double>
Case<Top<Scalar>> ht2() {
  using V = Eigen::Matrix<Scalar, 3, 1>;
  State<Scalar> s;
  s.omega = V(0, 150, Scalar(-4.61538L));
  return {"ht2",
          Top<Scalar>(RigidBody<Scalar>(V(Scalar(15.234375L), Scalar(0.46875L), Scalar(15.234375L))),
                      UniformGravity<Scalar>(Scalar(15 * 9.81L), V::UnitY(), V::UnitZ())),
          s, Scalar(2)};
}

/// FB1, docs/theory.md §8: free body near the intermediate axis (Dzhanibekov):
/// J = diag(1, 2, 3), Ω0 = (0.01, 2, 0.01); t ∈ [0, 100].
template <class Scalar = double>
Case<Free<Scalar>> fb1() {
  using V = Eigen::Matrix<Scalar, 3, 1>;
  State<Scalar> s;
  s.omega = V(Scalar(0.01L), 2, Scalar(0.01L));
  return {"fb1", Free<Scalar>(RigidBody<Scalar>(V(1, 2, 3))), s, Scalar(100)};
}

/// FB2, docs/theory.md §8: the free body of Hairer–Lubich–Wanner: J = diag(2, 1, 2/3),
/// Π0 = (cos 1.1, 0, sin 1.1); t ∈ [0, 100] (their h = 0.1).
template <class Scalar = double>
Case<Free<Scalar>> fb2() {
  using V = Eigen::Matrix<Scalar, 3, 1>;
  using std::cos;
  using std::sin;
  const V J(2, 1, Scalar(2) / Scalar(3));
  State<Scalar> s;
  s.omega = V(cos(Scalar(1.1L)), 0, sin(Scalar(1.1L))).cwiseQuotient(J);
  // J breaks the triangle inequality (2/3 + 1 < 2): a test problem, not a rigid body.
  return {"fb2", Free<Scalar>(RigidBody<Scalar>(J, allow_unphysical_inertia)), s, Scalar(100)};
}

}  // namespace trompo::cases
