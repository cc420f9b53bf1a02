#pragma once
// The exact sub-flows of the spin-exact splitting (docs/theory.md §12, [S1]–[S5], [S13])
// and the principal frame they are written in. Used by schemes/splitting.hpp.
//
// Frames. The user's body frame (the one of State::omega and of the scene's effects) need
// not be principal. The splitting works in a *working frame*: the principal axes relabelled
// so that x = b (the remaining axis), y = a (the transverse axis whose moment J_a is used),
// z = s (the symmetry axis) [S1]/[S8]. Q (a rotation, det +1) has the working axes as its
// columns in user body coordinates:
//
//   Λ_w = Λ Q,   Π_w = Qᵀ Π,   Ω = Q Ω_w.
//
// Fixing s = z, a = y, b = x at compile time lets every axis rotation below be written out
// (8 multiplications for a quaternion times an axis quaternion) with no run-time axis index.
// On HT0/HT1 (J = diag(5, 5, 1)) Q is the identity and the conversions are skipped.
//
// The effects are evaluated in the user's frame through the scene's own interface: an
// effect's cache taken at Λ_n = Λ_w and its torque at R = Qᵀ is the torque at Λ_w Qᵀ = Λ,
// expressed in the frame of Λ_n, i.e. in the working frame (effects/effect.hpp). No effect
// needs to know about the relabelling.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <tuple>
#include <type_traits>

#include "trompo/model/effects/effect.hpp"
#include "trompo/model/effects/external_torque.hpp"
#include "trompo/model/effects/magnetorquer.hpp"
#include "trompo/model/effects/uniform_gravity.hpp"
#include "trompo/model/effects/viscous_damping.hpp"
#include "trompo/errors.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/lie/euler_poinsot.hpp"

namespace trompo {

/// Whether a torque-kind effect is a "kick" for the splitting: a torque that depends on the
/// attitude and the time but not on the angular velocity, so that Π ← Π + t·τ(Λ, t) with Λ
/// and t frozen is its exact flow ([S13]). BodyTorque and SpaceTorque are; specialise this
/// for a user effect of the same nature. Viscous damping has its own exact flow.
template <class Effect>
struct is_splitting_kick : std::false_type {};
/// A body-fixed torque T(t) is a kick.
template <class Scalar, class F>
struct is_splitting_kick<BodyTorque<Scalar, F>> : std::true_type {};
/// A space-fixed torque S(t) is a kick.
template <class Scalar, class F>
struct is_splitting_kick<SpaceTorque<Scalar, F>> : std::true_type {};
/// A magnetorquer's held dipole, τ = m × ΛᵀB(t), is a kick.
template <class Scalar>
struct is_splitting_kick<Magnetorquer<Scalar>> : std::true_type {};

namespace detail {

/// Whether E is viscous damping (its sub-flow is the exact decay, [S13]).
template <class E>
inline constexpr bool is_damping_v = false;
/// ViscousDamping is.
template <class Scalar>
inline constexpr bool is_damping_v<ViscousDamping<Scalar>> = true;

/// How an effect enters the splitting ([S13]); `none` fails to compile (splitting.hpp).
enum class SubFlowKind { kick, damping, rotor, none };

/// The sub-flow of effect E in the splitting.
template <class E>
constexpr SubFlowKind sub_flow_of() {
  if constexpr (std::is_same_v<typename E::kind, potential_kind>) return SubFlowKind::kick;
  else if constexpr (std::is_same_v<typename E::kind, rotor_kind>) return SubFlowKind::rotor;
  else if constexpr (is_damping_v<E>) return SubFlowKind::damping;
  else if constexpr (is_splitting_kick<E>::value) return SubFlowKind::kick;
  else return SubFlowKind::none;
}

/// The working frame of [S1]/[S8] and the constants of the sub-flows, computed once per
/// trajectory from the scene's inertia and rotor, on its first step (SplittingMemory).
template <class Scalar>
struct SplittingFrame {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  using Quaternion = Eigen::Quaternion<Scalar>;

  bool identity = true;        ///< Q = I: the user's body axes are the working axes
  Quaternion Q = Quaternion::Identity();  ///< working → user body frame (Λ_w = Λ Q)
  Matrix3 Qm = Matrix3::Identity();       ///< Q as a matrix
  Matrix3 Qt = Matrix3::Identity();       ///< Qᵀ: the R at which effects are evaluated
  Vector3 J = Vector3::Ones();            ///< principal moments (J_b, J_a, J_s)
  Vector3 J_inv = Vector3::Ones();        ///< their inverses
  Scalar Ja_inv = Scalar(1);              ///< 1/J_a           [S1]
  Scalar c_s = Scalar(0);                 ///< 1/J_s − 1/J_a   [S1]
  Scalar k_b = Scalar(0);                 ///< 1/J_b − 1/J_a   [S1]; 0: symmetric body
  Vector3 h_r = Vector3::Zero();          ///< rotor momentum in the working frame
  Vector3 rotor_axis = Vector3::UnitZ();  ///< unit axis of w = −J⁻¹h_r   [S13]
  Scalar rotor_rate = Scalar(0);          ///< |w|; 0: no rotor flow
  /// The scene has reaction wheels: the rotor flow's w(t) = −J⁻¹(h_r + h_w(t)) is formed at
  /// each rotor sub-flow from the split clock (flow_wheels, [W14]); no exact free flow.
  bool wheels = false;
  Scalar damping = Scalar(0);             ///< Σ c of the viscous-damping effects
  /// Whether `free` is the free flow: an asymmetric body without rotor, or with wheels (whose
  /// rotor term is split off, [W14]). A symmetric body has S exact instead; a constant
  /// rotor's gyrostat term is split as S, A and the rotor flow.
  bool exact_free = false;
  /// The exact free flow of an asymmetric body ([F1]–[F7]), its constants built once here.
  EulerPoinsot<Scalar> free;

  /// The free symmetric flow [S2] alone is the exact free flow (Chin's T): symmetric body
  /// and no rotor term.
  bool free_flow_exact() const { return k_b == Scalar(0) && rotor_rate == Scalar(0) && !wheels; }

  /// Builds the frame of a scene: principal axes, then s, a, b by [S1]/[S8].
  /// any_order: the step uses no S or A sub-flow on an asymmetric body (Chin's and the
  /// near-integrable methods, or a torque-free scene), whose exact free flow [F1]–[F7] takes
  /// the moments in any order; a diagonal inertia then keeps the user's axes (Q = I), and
  /// the step converts nothing (FB1: 15 % of its step).
  template <class Scene>
  static SplittingFrame of(const Scene& scene, bool any_order = false) {
    SplittingFrame f;
    const auto& body = scene.body();
    Vector3 m;
    Matrix3 V;
    if (body.is_diagonal()) {
      m = body.inertia().diagonal();
      V.setIdentity();
    } else {
      // Diagonalised once per trajectory, not per step (eigenvalues ascending).
      const Eigen::SelfAdjointEigenSolver<Matrix3> eig(body.inertia());
      m = eig.eigenvalues();
      V = eig.eigenvectors();
    }
    using std::abs;
    const Scalar tol = Scalar(8) * Eigen::NumTraits<Scalar>::epsilon() * m.cwiseAbs().maxCoeff();
    auto equal = [&](int i, int j) { return abs(m(i) - m(j)) <= tol; };
    int s = 2, a = 1, b = 0;
    if (equal(0, 1) && equal(1, 2)) {
      s = 2, a = 1, b = 0;  // spherical: every axis is a symmetry axis
    } else if (equal(0, 1)) {
      s = 2, a = 1, b = 0;  // the odd moment is the symmetry axis [S1]
    } else if (equal(0, 2)) {
      s = 1, a = 2, b = 0;
    } else if (equal(1, 2)) {
      s = 0, a = 2, b = 1;
    } else if (any_order && body.is_diagonal() && !has_rotor_momentum(scene)) {
      s = 2, a = 1, b = 0;  // the exact free flow and the kicks need no particular order
    } else {
      // Asymmetric [S8]: J_a the intermediate moment (smallest leading commutator); of the
      // two extremes, s is the one farther from J_a in 1/J, so that the asymmetric
      // remainder T_asym = ½ k_b Π_b² is the smaller part (a near-symmetric fast top keeps
      // its spin axis as s).
      int idx[3] = {0, 1, 2};
      for (int i = 0; i < 3; ++i)
        for (int j = i + 1; j < 3; ++j)
          if (m(idx[j]) < m(idx[i])) std::swap(idx[i], idx[j]);
      a = idx[1];
      const Scalar d0 = abs(Scalar(1) / m(idx[0]) - Scalar(1) / m(a));
      const Scalar d2 = abs(Scalar(1) / m(idx[2]) - Scalar(1) / m(a));
      s = d0 > d2 ? idx[0] : idx[2];
      b = d0 > d2 ? idx[2] : idx[0];
    }
    f.J = Vector3(m(b), m(a), m(s));
    if (abs(f.J(0) - f.J(1)) <= tol) f.J(0) = f.J(1);  // exactly symmetric: k_b = 0
    f.Qm.col(0) = V.col(b);
    f.Qm.col(1) = V.col(a);
    f.Qm.col(2) = V.col(s);
    if (f.Qm.determinant() < 0) f.Qm.col(0) = -f.Qm.col(0);  // a rotation, not a reflection
    f.Qt = f.Qm.transpose();
    f.identity = f.Qm == Matrix3::Identity();
    f.Q = Quaternion(f.Qm);
    f.Q.normalize();
    if (!f.identity) {  // Q as the rotation actually applied (unit quaternion)
      f.Qm = f.Q.toRotationMatrix();
      f.Qt = f.Qm.transpose();
    }
    f.J_inv = f.J.cwiseInverse();
    f.Ja_inv = f.J_inv(1);
    f.c_s = f.J_inv(2) - f.J_inv(1);
    f.k_b = f.J_inv(0) - f.J_inv(1);
    if constexpr (Scene::has_rotor) {
      f.h_r = f.Qt * scene.rotor_momentum();
      const Vector3 w = -f.J_inv.cwiseProduct(f.h_r);  // [S13] w = −J⁻¹h_r
      f.rotor_rate = w.norm();
      if (f.rotor_rate > Scalar(0)) f.rotor_axis = w / f.rotor_rate;
    }
    f.wheels = Scene::has_wheels;
    std::apply([&](const auto&... e) { ((f.add_damping(e)), ...); }, scene.effects());
    // With wheels the free flow of the hub is exact too: the rotor term is a sub-flow of its
    // own ([W14]), so the core of each Strang step is the Euler–Poinsot flow, not S with A.
    if (f.k_b != Scalar(0) && (f.rotor_rate == Scalar(0) || f.wheels)) {
      f.exact_free = true;
      f.free = EulerPoinsot<Scalar>(f.J);
    }
    return f;
  }

 private:
  template <class Scene>
  static bool has_rotor_momentum(const Scene& scene) {
    if constexpr (Scene::has_wheels) return true;
    else if constexpr (Scene::has_rotor) return scene.rotor_momentum() != Vector3::Zero();
    else return false;
  }
  template <class E>
  void add_damping(const E& e) {
    if constexpr (is_damping_v<E>) damping += e.coefficient();
  }
};

/// The working state of a splitting step: Λ_w as a quaternion (not renormalised between
/// sub-flows: each factor is unit to round-off), Π_w and the split clock t.
template <class Scalar>
struct SplitState {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  Eigen::Quaternion<Scalar> q = Eigen::Quaternion<Scalar>::Identity();
  Vector3 P = Vector3::Zero();
  Scalar t = Scalar(0);
};

/// What the splitting remembers per trajectory (its Memory): the working frame with the
/// constants of every sub-flow, and the first energy, found on the first step, and the
/// working state of the last output. The scheme writes it on a successful step only
/// (writes_memory_on_success), so the Stepper steps it in place: the frame is read per
/// step, never copied or rebuilt.
template <class Scalar>
struct SplittingMemory {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  bool ready = false;              ///< false in fresh memory: built on the first step
  SplittingFrame<Scalar> frame;    ///< the working frame and the sub-flows' constants
  Scalar energy = Scalar(0);       ///< H of the trajectory's first state (projection [S12])
  /// The working state (Λ_w, Π_w) of the last step's end, and that step's output in the
  /// user's frame, bit for bit: a step handed that output resumes from the working state
  /// instead of converting back (Ω_w = QᵀΩ, Π_w = JΩ_w), a round trip through two rounded
  /// matrices whose bias drifted π by ~4e-16 a step on a full inertia [S14].
  bool carried = false;
  SplitState<Scalar> working;      ///< Λ_w, Π_w at the last output
  Eigen::Matrix<Scalar, 4, 1> out_q = Eigen::Matrix<Scalar, 4, 1>::Zero();  ///< its quaternion's coefficients
  Vector3 out_omega = Vector3::Zero();  ///< its Ω
  Scalar out_time = Scalar(0);          ///< its time

  /// Whether `in` is the last output (with wheels or a time-dependent rotor, at its time too:
  /// Π_w holds h_w(t)).
  template <class State>
  bool resumes(const State& in, bool timed) const {
    return carried && in.omega == out_omega && in.rotation.unit_quaternion().coeffs() == out_q &&
           (!timed || in.time == out_time);
  }
  /// Keeps the working state x of the output `out` (x.q renormalised: it is carried on).
  template <class State>
  void keep(SplitState<Scalar> x, const State& out) {
    detail::newton_unit(x.q, x.q.squaredNorm());
    working = x;
    out_q = out.rotation.unit_quaternion().coeffs();
    out_omega = out.omega;
    out_time = out.time;
    carried = true;
  }
};

/// [S2] the exact flow of T_sym = ½|Π|²/J_a + ½ c_s Π_s² for a time t (working axis s = 3,
/// detail::symmetric_free_flow). The split clock advances here (time is a split variable, [S13]).
template <class Scalar>
inline void flow_symmetric(const SplittingFrame<Scalar>& f, SplitState<Scalar>& x, Scalar t) {
  symmetric_free_flow<2>(x.q, x.P, t, f.Ja_inv, f.c_s);
  x.t += t;
}

/// [S3] the exact flow of T_asym = ½ k_b Π_b²: φ = t k_b Π_b, Λ ← Λ exp(φ ê_b), Π ← exp(−φ ê_b)Π.
template <class Scalar>
inline void flow_asymmetric(const SplittingFrame<Scalar>& f, SplitState<Scalar>& x, Scalar t) {
  const Scalar phi_half = Scalar(0.5) * t * f.k_b * x.P.x();
  Scalar sp, cp;
  sin_cos(phi_half, sp, cp);
  multiply_axis<0>(x.q, cp, sp);
  rotate_back_axis<0>(x.P, cp, sp);
}

/// [F1]–[F7] the exact free flow of an asymmetric body (no rotor) for a time t; the split
/// clock advances here, as in S.
template <class Scalar>
inline void flow_exact_free(const SplittingFrame<Scalar>& f, SplitState<Scalar>& x, Scalar t) {
  f.free.advance(x.q, x.P, t);
  x.t += t;
}

/// [S13] the exact flow of the rotor's linear term −h_r·J⁻¹Π = w·Π: a rotation about the
/// body-fixed axis w at the rate |w|, Λ ← Λ exp(t ŵ), Π ← exp(−t ŵ)Π (keeps π).
template <class Scalar>
inline void flow_rotor(const SplittingFrame<Scalar>& f, SplitState<Scalar>& x, Scalar t) {
  rotate_body(x, f.rotor_axis, Scalar(0.5) * t * f.rotor_rate);
}

/// Λ ← Λ exp(φ n̂), Π ← exp(−φ n̂)Π for a unit body axis n and φ = 2·phi_half (keeps π = ΛΠ).
template <class Scalar>
inline void rotate_body(SplitState<Scalar>& x, const Eigen::Matrix<Scalar, 3, 1>& n, Scalar phi_half) {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  Scalar sp, cp;
  sin_cos(phi_half, sp, cp);
  x.q = x.q * Eigen::Quaternion<Scalar>(cp, sp * n.x(), sp * n.y(), sp * n.z());
  // exp(−φ n̂)Π = Π − sin φ n×Π + (1 − cos φ) n×(n×Π), increment form [S5]
  const Vector3 nxP = n.cross(x.P);
  x.P += (Scalar(-2) * sp * cp) * nxP + (Scalar(2) * sp * sp) * n.cross(nxP);
}

/// The internal momentum h_r + h_w(t) in the working frame: the rotors' and, at the split
/// clock t, the wheels' [W14].
template <class Scene, class Scalar = typename Scene::Scalar>
inline Eigen::Matrix<Scalar, 3, 1> internal_momentum(const Scene& scene, const SplittingFrame<Scalar>& f, Scalar t) {
  if constexpr (Scene::has_wheels) {
    const Eigen::Matrix<Scalar, 3, 1> hw = scene.wheel_momentum(t);
    return f.h_r + (f.identity ? hw : Eigen::Matrix<Scalar, 3, 1>(f.Qt * hw));
  } else {
    return f.h_r;
  }
}

/// [W14] the wheels' rotor flow: the flow of −(h_r + h_w(t))·J⁻¹Π with the split clock t
/// frozen, a rotation about w = −J⁻¹(h_r + h_w(t)) at the rate |w| (flow_rotor's, with w
/// formed from the clock: the held commands change h_w along the run).
template <class Scene, class Scalar = typename Scene::Scalar>
inline void flow_wheels(const Scene& scene, const SplittingFrame<Scalar>& f, SplitState<Scalar>& x, Scalar t) {
  const Eigen::Matrix<Scalar, 3, 1> w = -f.J_inv.cwiseProduct(internal_momentum(scene, f, x.t));
  const Scalar rate = w.norm();
  if (rate > Scalar(0)) rotate_body(x, Eigen::Matrix<Scalar, 3, 1>(w / rate), Scalar(0.5) * t * rate);
}

/// [S13] the exact flow of viscous damping −cΩ with Λ frozen: in principal axes
/// (Π − h_r)_i ← e^{−c t/J_i}(Π − h_r)_i, written as an increment with expm1.
template <class Scene, class Scalar = typename Scene::Scalar>
inline void flow_damping(const Scene& scene, const SplittingFrame<Scalar>& f, SplitState<Scalar>& x, Scalar t) {
  using std::expm1;
  const Eigen::Matrix<Scalar, 3, 1> h = internal_momentum(scene, f, x.t);
  for (int i = 0; i < 3; ++i) x.P(i) += expm1(-f.damping * t * f.J_inv(i)) * (x.P(i) - h(i));
}

/// The kick torque τ(Λ, t) in the working frame: the potentials' torques and the kicks'
/// (velocity-independent applied torques), at Λ = Λ_w Qᵀ and the split clock [S4], [S13].
template <class Scene, class Scalar = typename Scene::Scalar>
inline Eigen::Matrix<Scalar, 3, 1> kick_torque(const Scene& scene, const SplittingFrame<Scalar>& f,
                                               const Eigen::Matrix<Scalar, 3, 3>& Lambda_w, Scalar t) {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  Vector3 tau = Vector3::Zero();
  std::apply(
      [&](const auto&... e) {
        auto one = [&](const auto& effect) {
          using E = std::decay_t<decltype(effect)>;
          if constexpr (std::is_same_v<typename E::kind, potential_kind>) {
            tau += effect.torque(effect.cache(Lambda_w, t), f.Qt);
          } else if constexpr (sub_flow_of<E>() == SubFlowKind::kick) {
            tau += effect.torque(effect.cache(Lambda_w, t), f.Qt, Vector3::Zero());
          }
        };
        (one(e), ...);
      },
      scene.effects());
  return tau;
}

/// Σ V at Λ = Λ_w Qᵀ and time t (t matters to a time-dependent potential only).
template <class Scene, class Scalar = typename Scene::Scalar>
inline Scalar potential_at(const Scene& scene, const SplittingFrame<Scalar>& f,
                           const Eigen::Matrix<Scalar, 3, 3>& Lambda_w, Scalar t) {
  Scalar v(0);
  std::apply(
      [&](const auto&... e) {
        auto one = [&](const auto& effect) {
          using E = std::decay_t<decltype(effect)>;
          if constexpr (std::is_same_v<typename E::kind, potential_kind>)
            v += effect.potential(effect.cache(Lambda_w, t), f.Qt);
        };
        (one(e), ...);
      },
      scene.effects());
  return v;
}

/// Whether E is uniform gravity (its kick is written on the quaternion).
template <class E>
inline constexpr bool is_gravity_v = false;
/// UniformGravity is.
template <class Scalar>
inline constexpr bool is_gravity_v<UniformGravity<Scalar>> = true;

/// Whether every effect of a tuple is uniform gravity (and there is one).
template <class Tuple>
struct all_gravity;
/// The tuple case.
template <class... E>
struct all_gravity<std::tuple<E...>> : std::bool_constant<(sizeof...(E) > 0) && (is_gravity_v<E> && ...)> {};
/// Whether every effect of the scene is uniform gravity (the heavy top): then the kicks are
/// written on the quaternion directly, without forming Λ as a matrix.
template <class Scene>
inline constexpr bool gravity_only_v =
    all_gravity<std::decay_t<decltype(std::declval<const Scene&>().effects())>>::value;

/// Λᵀu for the unit quaternion q = (w, v) of Λ: u − 2w (v × u) + 2 v × (v × u).
template <class Scalar>
inline Eigen::Matrix<Scalar, 3, 1> rotate_inverse(const Eigen::Quaternion<Scalar>& q, const Eigen::Matrix<Scalar, 3, 1>& u) {
  const Eigen::Matrix<Scalar, 3, 1> v = q.vec();
  const Eigen::Matrix<Scalar, 3, 1> c = v.cross(u);
  return u + Scalar(2) * (v.cross(c) - q.w() * c);
}

/// Uniform gravity's body torque in the working frame, from the quaternion:
/// τ = −Mgl E_w × Λ_wᵀγ (docs/theory.md [S1]), E_w = QᵀE.
template <class Scalar>
inline Eigen::Matrix<Scalar, 3, 1> gravity_torque(const UniformGravity<Scalar>& g, const SplittingFrame<Scalar>& f,
                                                  const Eigen::Quaternion<Scalar>& q) {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  const Vector3 b = rotate_inverse(q, g.up());  // b = Λ_wᵀγ
  const Vector3 E = f.identity ? g.com_direction() : Vector3(f.Qt * g.com_direction());
  return (-g.Mgl()) * E.cross(b);
}

/// [S4] the kick Π ← Π + t τ(Λ, t) (Λ and the clock frozen: exact).
template <class Scene, class Scalar = typename Scene::Scalar>
inline void flow_kick(const Scene& scene, const SplittingFrame<Scalar>& f, SplitState<Scalar>& x, Scalar t) {
  if constexpr (gravity_only_v<Scene>) {
    std::apply([&](const auto&... g) { ((x.P += t * gravity_torque(g, f, x.q)), ...); }, scene.effects());
  } else {
    const Eigen::Matrix<Scalar, 3, 3> L = x.q.toRotationMatrix();
    x.P += t * kick_torque(scene, f, L, x.t);
  }
}

/// [S7] Chin's middle kick: Π ← Π + t τ̃ with the torque of Ṽ = V − (h²/48) W,
/// W = τ·J⁻¹τ:  τ̃ = τ + (h²/24) Kᵀ J⁻¹ τ, K = ∂τ/∂w the body-frame torque Jacobian for
/// Λ_w exp(ŵ). From the scene's frame-n Jacobian K_n (w.r.t. the user-frame perturbation
/// w_u = Q w): K = K_n Q + τ̂. Only potentials enter (Chin is offered on such scenes only).
/// flow_gradient_kick is the same kick with a general weight: Π ← Π + t(τ + w KᵀJ⁻¹τ), or
/// with with_tau = false the force gradient alone, Π ← Π + w KᵀJ⁻¹τ (the correctors of the
/// near-integrable compositions [F8]; both depend on Λ only, so they are exact flows).
template <class Scene, class Scalar = typename Scene::Scalar>
inline void flow_gradient_kick(const Scene& scene, const SplittingFrame<Scalar>& f, SplitState<Scalar>& x, Scalar t,
                               Scalar w_grad, bool with_tau) {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  if constexpr (gravity_only_v<Scene>) {
    // Gravity: K = Mgl((E·b) I − b Eᵀ), so Kᵀu = Mgl((E·b) u − E (b·u)) = Mgl b × (u × E), u = J⁻¹τ.
    std::apply(
        [&](const auto&... g) {
          auto one = [&](const auto& grav) {
            const Vector3 b = rotate_inverse(x.q, grav.up());
            const Vector3 E = f.identity ? grav.com_direction() : Vector3(f.Qt * grav.com_direction());
            const Vector3 tau = (-grav.Mgl()) * E.cross(b);
            const Vector3 u = f.J_inv.cwiseProduct(tau);
            const Vector3 grad = grav.Mgl() * b.cross(u.cross(E));
            if (with_tau) x.P += t * (tau + w_grad * grad);
            else x.P += w_grad * grad;
          };
          (one(g), ...);
        },
        scene.effects());
    return;
  }
  const Matrix3 L = x.q.toRotationMatrix();
  Vector3 tau = Vector3::Zero();
  Matrix3 Kn = Matrix3::Zero();
  std::apply(
      [&](const auto&... e) {
        auto one = [&](const auto& effect) {
          using E = std::decay_t<decltype(effect)>;
          if constexpr (std::is_same_v<typename E::kind, potential_kind>) {
            const auto c = effect.cache(L, x.t);
            tau += effect.torque(c, f.Qt);
            Kn += effect.torque_jacobian(c, f.Qt);
          }
        };
        (one(e), ...);
      },
      scene.effects());
  const Matrix3 K = (f.identity ? Kn : Matrix3(Kn * f.Qm)) + SO3<Scalar>::hat(tau);
  const Vector3 grad = K.transpose() * f.J_inv.cwiseProduct(tau);
  if (with_tau) x.P += t * (tau + w_grad * grad);
  else x.P += w_grad * grad;
}

/// Chin's middle kick [S7] (see above): t(τ + (h²/24) KᵀJ⁻¹τ).
template <class Scene, class Scalar = typename Scene::Scalar>
inline void flow_chin_kick(const Scene& scene, const SplittingFrame<Scalar>& f, SplitState<Scalar>& x, Scalar t,
                           Scalar h) {
  flow_gradient_kick(scene, f, x, t, h * h / Scalar(24), true);
}

/// H in the working frame: ½(Π − h_r)·J⁻¹(Π − h_r) + V(Λ, t); with a time-dependent
/// potential the Jacobi integral, H − n ô·π with π = Λ_w Π_w [G4].
template <class Scene, class Scalar = typename Scene::Scalar>
inline Scalar working_energy(const Scene& scene, const SplittingFrame<Scalar>& f, const SplitState<Scalar>& x) {
  const Eigen::Matrix<Scalar, 3, 1> m = x.P - f.h_r;
  Scalar H = m.dot(f.J_inv.cwiseProduct(m)) / Scalar(2);
  if constexpr (Scene::has_potential) {
    const Eigen::Matrix<Scalar, 3, 3> L = x.q.toRotationMatrix();
    H += potential_at(scene, f, L, x.t);
    if constexpr (Scene::has_time_dependent_potential) H += scene.rotating_frame_energy(Eigen::Matrix<Scalar, 3, 1>(L * x.P));
  }
  return H;
}

/// [S12] energy projection that keeps π: linearised updates
///   (Λ, Π) ← (Λ exp(λ n̂), exp(−λ n̂) Π),  n = Π̇/|Π̇|,  Π̇ = Π × Ω + τ(Λ),  λ = (H − H0)/|Π̇|,
/// the time-λ flow of n·Π (n fixed in the body), so π = ΛΠ is untouched and dH/dλ = −|Π̇|.
/// One update leaves a residual O(λ²) (1.5e-11 of H per step on a fast full-inertia top at
/// h = 0.004), so the update is repeated, from the new state, until |H − H0| is at round-off
/// (4ε(|T| + |V|)), at most 4 times. At a relative equilibrium (Π̇ = 0) there is nothing to
/// correct.
/// With a time-dependent potential (t frozen) H0 is the Jacobi integral E_J of the first
/// state and E_J is projected: the update keeps π, so dE_J/dλ = dH/dλ [G5].
template <class Scene, class Scalar = typename Scene::Scalar>
inline void project_energy(const Scene& scene, const SplittingFrame<Scalar>& f, SplitState<Scalar>& x, Scalar H0) {
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  using std::abs;
  using std::cos;
  using std::sin;
  constexpr int max_updates = 4;
  for (int k = 0;; ++k) {
    const Matrix3 L = x.q.toRotationMatrix();
    const Vector3 omega = f.J_inv.cwiseProduct(x.P - f.h_r);
    const Scalar kinetic = (x.P - f.h_r).dot(omega) / Scalar(2);
    Scalar H = kinetic, V = Scalar(0);
    Vector3 Pdot = x.P.cross(omega);
    if constexpr (Scene::has_potential) {
      V = potential_at(scene, f, L, x.t);
      // E_J = H − n ô·π [G4]: the rotating-frame term counts with the potential.
      if constexpr (Scene::has_time_dependent_potential) V += scene.rotating_frame_energy(Vector3(L * x.P));
      H += V;
      Pdot += kick_torque(scene, f, L, x.t);
    }
    if (k > 0 && !(abs(H - H0) > Scalar(4) * std::numeric_limits<Scalar>::epsilon() * (abs(kinetic) + abs(V))))
      return;  // at round-off (or not finite: the step reports it)
    if (k == max_updates) return;
    const Scalar norm = Pdot.norm();
    if (!(norm > Scalar(0))) return;
    const Vector3 n = Pdot / norm;
    const Scalar lambda = (H - H0) / norm;
    const Scalar sl = sin(lambda / 2), cl = cos(lambda / 2);
    x.q = x.q * Eigen::Quaternion<Scalar>(cl, sl * n.x(), sl * n.y(), sl * n.z());
    const Vector3 nxP = n.cross(x.P);
    x.P += (Scalar(-2) * sl * cl) * nxP + (Scalar(2) * sl * sl) * n.cross(nxP);
  }
}

}  // namespace detail
}  // namespace trompo
