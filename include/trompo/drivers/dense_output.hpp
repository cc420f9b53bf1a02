#pragma once
// Dense output on SO(3) (docs/theory.md §16 [D1]–[D3]): the state between two accepted steps.
//
//   DenseNode<double> a = dense_node(scene, state_n), b = dense_node(scene, state_n1);
//   LieHermite<double> seg(a, b);            // the step [t_n, t_n + h]
//   State<double> s = seg.state(t);          // any t in the step
//
// On [t_n, t_n + h], θ = (t − t_n)/h, the attitude is Λ(θ) = Λ_n exp(ξ(θ)^) with ξ a
// polynomial in the Lie algebra: Λ(θ) is a rotation for every θ (a unit quaternion times
// the exponential of a vector), whatever ξ is: orthogonal by construction [D1]. ξ is the
// Hermite polynomial with ξ(0) = 0, ξ(1) = φ = log(Λ_nᵀΛ_{n+1}), its θ-derivatives
// ξ' = h T(ξ)⁻¹ Ω from the kinematics Λ̇ = ΛΩ̂ (T the right tangent of exp), and, for the
// quintic, its second derivatives ξ'' = h dT⁻¹(ξ)[ξ'] Ω + h² T(ξ)⁻¹ Ω̇ [D2]. Ω is the
// Hermite polynomial of the same degree through Ω, hΩ̇ (and h²Ω̈) at both ends [D3].
// Interpolation error: O(h⁴) (cubic) and O(h⁶) (quintic) per step, so the quintic does not
// spoil an order-6 solution. Interpolated states are not products of steps: H and μ there
// carry an O(h^q) error (the nodes keep them exactly).
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "trompo/errors.hpp"
#include "trompo/lie/series.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// A state with the rates the interpolant needs: Ω̇ and Ω̈ at (Λ, Ω, t).
template <class Scalar>
struct DenseNode {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// The state at this node.
  State<Scalar> state;
  Vector3 omega_dot = Vector3::Zero();   ///< Ω̇ = J⁻¹(Π × Ω + τ)       [D3]
  Vector3 omega_ddot = Vector3::Zero();  ///< Ω̈ = J⁻¹(JΩ̇ × Ω + Π × Ω̇ + τ̇), when `second`
  /// Whether omega_ddot holds Ω̈ (the quintic needs it, the cubic does not).
  bool second = false;
};

/// Ω̇ from the Euler equation J Ω̇ = Π × Ω + τ, Π = JΩ + h_r, given the body torque τ [D3];
/// with wheels Π = J_hubΩ + h_w(t) and the wheels' reaction −ḣ_w adds to τ [W1], ḣ_w with
/// their viscous friction (W17.a): the rate of the motion, which the split step follows.
template <class Scene>
Eigen::Matrix<typename Scene::Scalar, 3, 1> euler_rate(const Scene& scene,
                                                       const Eigen::Matrix<typename Scene::Scalar, 3, 1>& omega,
                                                       const Eigen::Matrix<typename Scene::Scalar, 3, 1>& torque,
                                                       typename Scene::Scalar t) {
  if constexpr (Scene::has_wheels)
    return scene.body().inertia_inverse() *
           (scene.momentum(omega, t).cross(omega) - scene.wheel_momentum_rate(t, omega) + torque);
  else
    return scene.body().inertia_inverse() * (scene.momentum(omega).cross(omega) + torque);
}

/// Ω̇ of the scene at (Λ, Ω, t), Λ as a matrix: euler_rate with the scene's body torque.
template <class Scene>
Eigen::Matrix<typename Scene::Scalar, 3, 1> omega_rate(const Scene& scene,
                                                       const Eigen::Matrix<typename Scene::Scalar, 3, 3>& rotation,
                                                       const Eigen::Matrix<typename Scene::Scalar, 3, 1>& omega,
                                                       typename Scene::Scalar t) {
  using Vector3 = Eigen::Matrix<typename Scene::Scalar, 3, 1>;
  if constexpr (Scene::has_potential || Scene::has_applied_torque)
    return euler_rate(scene, omega, scene.body_torque(rotation, omega, t), t);
  else {
    (void)rotation;
    return euler_rate(scene, omega, Vector3::Zero().eval(), t);  // no torque
  }
}
/// Ω̇ of the scene at the state s.
template <class Scene>
Eigen::Matrix<typename Scene::Scalar, 3, 1> omega_rate(const Scene& scene, const State<typename Scene::Scalar>& s) {
  if constexpr (Scene::has_potential || Scene::has_applied_torque)
    return omega_rate(scene, s.rotation.matrix(), s.omega, s.time);
  else
    return omega_rate(scene, Eigen::Matrix<typename Scene::Scalar, 3, 3>::Identity(), s.omega, s.time);
}

namespace detail {
/// Whether the scene's torques are time-independent potentials alone: their caches at Λ
/// give the torque and its exact rate, and serve points Λ exp(ξ̂) near Λ.
template <class Scene>
inline constexpr bool potential_only =
    Scene::has_potential && !Scene::has_applied_torque && !Scene::has_time_dependent_potential;

/// Ω̈ = J⁻¹(JΩ̇ × Ω + Π × Ω̇ + τ̇) of a node with Ω̇, the time derivative of the Euler
/// equation [D3], given the rate τ̇ of the body torque (node.second afterwards).
template <class Scene>
void set_second_rate(const Scene& scene, const Eigen::Matrix<typename Scene::Scalar, 3, 1>& torque_rate,
                     DenseNode<typename Scene::Scalar>& n) {
  using Vector3 = Eigen::Matrix<typename Scene::Scalar, 3, 1>;
  const State<typename Scene::Scalar>& s = n.state;
  Vector3 rhs;
  if constexpr (Scene::has_wheels)  // Π̇ = JΩ̇ + ḣ_w [W1], and −ḧ_w with friction (W17.b)
    rhs = (scene.body().inertia() * n.omega_dot + scene.wheel_momentum_rate(s.time, s.omega)).cross(s.omega) +
          scene.momentum(s.omega, s.time).cross(n.omega_dot) -
          scene.wheel_momentum_acceleration(s.time, s.omega, n.omega_dot);
  else
    rhs = (scene.body().inertia() * n.omega_dot).cross(s.omega) + scene.momentum(s.omega).cross(n.omega_dot);
  rhs += torque_rate;
  n.omega_ddot = scene.body().inertia_inverse() * rhs;
  n.second = true;
}

/// τ̇ of the body torque τ under time-independent potentials alone, from the caches at the
/// node's Λ [D3]: τ_body = Rᵀτ_n(R) at R = exp(tΩ̂), so τ̇_body = K Ω − Ω × τ (τ_n's rate,
/// the frame turning).
template <class Scene>
Eigen::Matrix<typename Scene::Scalar, 3, 1> potential_torque_rate(const Scene& scene, const typename Scene::Caches& c,
                                                                  const Eigen::Matrix<typename Scene::Scalar, 3, 1>& torque,
                                                                  const Eigen::Matrix<typename Scene::Scalar, 3, 1>& omega) {
  return scene.conservative_torque_rate(c, omega) - omega.cross(torque);
}
}  // namespace detail

/// Fills Ω̈ of a node that has Ω̇ (node.second afterwards): the time derivative of the
/// Euler equation [D3]. Its torque rate τ̇ (of the torque in the body frame, which turns
/// with Ω): for time-independent potentials alone, exact from the torque's tangent,
/// τ̇ = K Ω − Ω × τ, K = ∂τ_n(Λ exp(ŵ))/∂w at w = 0 the tangent of the torque held in the
/// node's frame (the implicit schemes' [T3]); for any other torque a central difference
/// along the flow (step δ ~ ε^{1/3}/rate, so τ̇ is accurate to ~1e-11 relative), whose
/// attitudes Λ(I ± δΩ̂) are first-order in δ: they differ from Λexp(±δΩ̂) by the same
/// Λδ²Ω̂²/2, which the central difference cancels, so no exponential is needed. No torque:
/// exact.
template <class Scene>
void add_second_rate(const Scene& scene, DenseNode<typename Scene::Scalar>& n) {
  using Scalar = typename Scene::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  if (n.second) return;
  const State<Scalar>& s = n.state;
  if constexpr (detail::potential_only<Scene>) {
    const typename Scene::Caches c = scene.caches(s.rotation.matrix(), s.time);
    const Vector3 torque = scene.conservative_torque(c, Matrix3::Identity());
    detail::set_second_rate(scene, detail::potential_torque_rate(scene, c, torque, s.omega), n);
  } else if constexpr (Scene::has_potential || Scene::has_applied_torque) {
    using std::sqrt;
    const Matrix3 R = s.rotation.matrix();
    const Scalar rate = Scalar(1) + s.omega.norm() + sqrt(n.omega_dot.norm());
    const Scalar delta = Scalar(6e-6) / rate;
    const Matrix3 dR = delta * (R * SO3<Scalar>::hat(s.omega));
    const Vector3 dW = delta * n.omega_dot;
    // τ is in the body frame, which turns with Ω: τ̇_body = (τ(+δ) − τ(−δ))/2δ.
    const Vector3 torque_rate = (scene.body_torque(R + dR, s.omega + dW, s.time + delta) -
                                 scene.body_torque(R - dR, s.omega - dW, s.time - delta)) /
                                (Scalar(2) * delta);
    detail::set_second_rate(scene, torque_rate, n);
  } else {
    detail::set_second_rate(scene, Vector3::Zero().eval(), n);  // no torque
  }
}

/// The node of a state: Ω̇ from the Euler equation and, with `second` (the quintic's
/// need), Ω̈ (add_second_rate). The cubic needs Ω̇ only. Under potentials alone one
/// rotation matrix and one set of caches serve both.
template <class Scene>
DenseNode<typename Scene::Scalar> dense_node(const Scene& scene, const State<typename Scene::Scalar>& s,
                                             bool second = true) {
  using Matrix3 = Eigen::Matrix<typename Scene::Scalar, 3, 3>;
  DenseNode<typename Scene::Scalar> n;
  n.state = s;
  if constexpr (detail::potential_only<Scene>) {
    const typename Scene::Caches c = scene.caches(s.rotation.matrix(), s.time);
    const Eigen::Matrix<typename Scene::Scalar, 3, 1> torque = scene.conservative_torque(c, Matrix3::Identity());
    n.omega_dot = euler_rate(scene, s.omega, torque, s.time);
    if (second) detail::set_second_rate(scene, detail::potential_torque_rate(scene, c, torque, s.omega), n);
  } else {
    n.omega_dot = omega_rate(scene, s);
    if (second) add_second_rate(scene, n);
  }
  return n;
}

namespace detail {
/// d/dθ of c(θ) = (1 − (θ/2)cot(θ/2))/θ², divided by θ (the x̂² coefficient of T⁻¹): from
/// c = Σ_k |B_2k| θ^(2k−2)/(2k)! (series.hpp), c′/θ = Σ_k (2k − 2)|B_2k| θ^(2k−4)/(2k)!, seven
/// terms below small_angle (θ < ¼: truncation < 1e-17 relative), else the closed form.
template <class Scalar>
Scalar inverse_tangent_coefficient_prime_over_theta(Scalar theta) {
  using std::cos;
  using std::sin;
  if (theta < small_angle<Scalar>::theta) {
    const Scalar x = theta * theta;
    return polynomial(x, std::array<long double, 7>{2.0L / 720, 4.0L / 30240, 6.0L / 1209600, 8.0L / 47900160,
                                                    10.0L * 691.0L / 1307674368000.0L, 12.0L / 74724249600.0L,
                                                    14.0L * 3617.0L / 10670622842880000.0L});
  }
  const Scalar half = theta / 2;
  const Scalar f = Scalar(1) - half * cos(half) / sin(half);
  const Scalar fp = -cos(half) / (Scalar(2) * sin(half)) + half / (Scalar(2) * sin(half) * sin(half));
  return (fp / (theta * theta) - Scalar(2) * f / (theta * theta * theta)) / theta;
}

/// T(x)⁻¹ w = w + ½ x × w + c x × (x × w), c = c(|x|) ([D2]).
template <class Scalar>
Eigen::Matrix<Scalar, 3, 1> apply_inverse_tangent(const Eigen::Matrix<Scalar, 3, 1>& x, Scalar c,
                                                  const Eigen::Matrix<Scalar, 3, 1>& w) {
  const Eigen::Matrix<Scalar, 3, 1> xw = x.cross(w);
  return w + xw / Scalar(2) + c * x.cross(xw);
}

/// The derivative of T(x)⁻¹ w along v: d/ds [T(x + s v)⁻¹ w] at s = 0, with
/// T⁻¹ = I + ½ x̂ + c(θ) x̂² ([D2]); θ = |x| and c = c(θ) given.
template <class Scalar>
Eigen::Matrix<Scalar, 3, 1> inverse_tangent_derivative(const Eigen::Matrix<Scalar, 3, 1>& x,
                                                       const Eigen::Matrix<Scalar, 3, 1>& v,
                                                       const Eigen::Matrix<Scalar, 3, 1>& w, Scalar theta, Scalar c) {
  const Scalar cp = inverse_tangent_coefficient_prime_over_theta(theta);  // c'(θ)/θ
  return v.cross(w) / Scalar(2) + cp * x.dot(v) * x.cross(x.cross(w)) +
         c * (v.cross(x.cross(w)) + x.cross(v.cross(w)));
}
}  // namespace detail

/// The Lie–Hermite interpolant of one step (file comment, [D1]–[D3]).
template <class Scalar>
class LieHermite {
 public:
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;

  LieHermite() = default;
  /// The step from node a to node b (h = t_b − t_a ≠ 0, either sign); `quintic` false: cubic
  /// (the quintic needs nodes with Ω̈, node.second).
  LieHermite(const DenseNode<Scalar>& a, const DenseNode<Scalar>& b, bool quintic = true)
      : t0_(a.state.time), h_(b.state.time - a.state.time), rotation0_(a.state.rotation), quintic_(quintic) {
    const Scalar h = h_;
    // log of Λ_aᵀΛ_b from the unnormalised product: the log is invariant to |q|
    const Eigen::Quaternion<Scalar> q = a.state.rotation.unit_quaternion().conjugate() * b.state.rotation.unit_quaternion();
    Vector3 phi = SO3<Scalar>::quaternion_log(q);
    // The branch of log nearest the mean rotation h(Ω_a + Ω_b)/2 when the step turns far [D1].
    const Vector3 guess = h * (a.state.omega + b.state.omega) / Scalar(2);
    Scalar angle = phi.norm();
    if (angle > Scalar(0)) {
      const Vector3 other = phi - (Scalar(2) * Scalar(EIGEN_PI) / angle) * phi;
      if ((other - guess).squaredNorm() < (phi - guess).squaredNorm()) {
        phi = other;
        angle = phi.norm();
      }
    }
    xi1_ = phi;
    d0_ = h * a.state.omega;                                                   // ξ'(0) = hΩ_a
    const Scalar c = detail::inverse_tangent_coefficient(angle);
    d1_ = h * detail::apply_inverse_tangent(phi, c, b.state.omega);               // ξ'(1) = h T(φ)⁻¹Ω_b
    w0_ = a.state.omega;
    w1_ = b.state.omega;
    wd0_ = h * a.omega_dot;
    wd1_ = h * b.omega_dot;
    if (quintic) {  // the second derivatives (the cubic has none: b2 = b3 = 0)
      eigen_assert(a.second && b.second && "LieHermite: the quintic needs nodes with omega_ddot (dense_node)");
      s0_ = h * h * a.omega_dot;                                                    // ξ''(0) = h²Ω̇_a
      s1_ = h * detail::inverse_tangent_derivative(phi, d1_, b.state.omega, angle, c) +  // ξ''(1)
            h * h * detail::apply_inverse_tangent(phi, c, b.omega_dot);
      wdd0_ = h * h * a.omega_ddot;
      wdd1_ = h * h * b.omega_ddot;
    }
    t1_ = b.state.time;
    rotation1_ = b.state.rotation;
  }

  /// The state at time t (t in the step; outside it the polynomial extrapolates).
  State<Scalar> state(Scalar t) const {
    State<Scalar> s;
    if (t == t1_) {
      s.rotation = rotation1_;  // the node itself
      s.omega = w1_;
      s.time = t1_;
      return s;
    }
    Vector3 xi;
    algebra((t - t0_) / h_, xi, s.omega);
    s.rotation = rotation_at(xi);
    s.time = t;
    return s;
  }

  /// Λ_n exp(ξ̂) [D1].
  SO3<Scalar> rotation_at(const Vector3& xi) const { return rotation0_.times_exp(xi, detail::half_angle(xi.norm())); }

  /// ξ(θ) and Ω(θ) at the fraction θ = (t − t_n)/h of the step: Λ(θ) = Λ_n exp(ξ(θ)^) [D1].
  void algebra(Scalar theta, Vector3& xi, Vector3& omega) const {
    Scalar b[6];
    basis(theta, b);
    xi = b[1] * d0_ + b[2] * s0_ + b[3] * s1_ + b[4] * d1_ + b[5] * xi1_;
    omega = b[0] * w0_ + b[1] * wd0_ + b[2] * wdd0_ + b[3] * wdd1_ + b[4] * wd1_ + b[5] * w1_;
  }
  /// φ = ξ(1) = log(Λ_nᵀΛ_{n+1}) on the branch of [D1].
  const Vector3& phi() const { return xi1_; }
  /// ξ'(1)/h = T(φ)⁻¹Ω_{n+1}: the end's rate in the algebra.
  Vector3 phi_rate() const { return d1_ / h_; }
  /// ξ''(1)/h² = d/dt T(ξ)⁻¹Ω at the end (the quintic's; zero for the cubic).
  Vector3 phi_rate_derivative() const { return s1_ / (h_ * h_); }
  /// The step h = t_{n+1} − t_n.
  Scalar step() const { return h_; }
  /// Whether the interpolant is the quintic (else the cubic).
  bool quintic() const { return quintic_; }
  /// The attitude at the step's start.
  const SO3<Scalar>& rotation_start() const { return rotation0_; }

  /// Start and end time of the step.
  Scalar t_start() const { return t0_; }
  /// The time of the interval's end.
  Scalar t_end() const { return t1_; }

 private:
  /// Hermite basis on [0, 1]: p = p0 b0 + p0' b1 + p0'' b2 + p1'' b3 + p1' b4 + p1 b5
  /// (quintic), or the cubic one with b2 = b3 = 0 [D2].
  void basis(Scalar x, Scalar b[6]) const {
    const Scalar x2 = x * x, x3 = x2 * x;
    if (quintic_) {
      const Scalar x4 = x3 * x, x5 = x4 * x;
      b[0] = 1 - 10 * x3 + 15 * x4 - 6 * x5;
      b[1] = x - 6 * x3 + 8 * x4 - 3 * x5;
      b[2] = (x2 - 3 * x3 + 3 * x4 - x5) / 2;
      b[3] = (x3 - 2 * x4 + x5) / 2;
      b[4] = -4 * x3 + 7 * x4 - 3 * x5;
      b[5] = 10 * x3 - 15 * x4 + 6 * x5;
    } else {
      b[0] = 1 - 3 * x2 + 2 * x3;
      b[1] = x - 2 * x2 + x3;
      b[2] = b[3] = Scalar(0);
      b[4] = x3 - x2;
      b[5] = 3 * x2 - 2 * x3;
    }
  }

  Scalar t0_ = Scalar(0), t1_ = Scalar(0), h_ = Scalar(1);
  SO3<Scalar> rotation0_, rotation1_;
  bool quintic_ = true;
  Vector3 xi1_ = Vector3::Zero(), d0_ = Vector3::Zero(), d1_ = Vector3::Zero(), s0_ = Vector3::Zero(),
          s1_ = Vector3::Zero();
  Vector3 w0_ = Vector3::Zero(), w1_ = Vector3::Zero(), wd0_ = Vector3::Zero(), wd1_ = Vector3::Zero(),
          wdd0_ = Vector3::Zero(), wdd1_ = Vector3::Zero();
};

/// The quadrature of the defect estimate [D4] on [0, 1], its ends the nodes' own rates.
enum class DefectRule {
  /// Simpson (Lobatto's 3 points, one interior evaluation): error O(h⁵), for order 2 on the
  /// cubic interpolant.
  simpson,
  /// Simpson's nodes with the rates' derivatives at the ends (Hermite's rule, exact for
  /// degree 5, error h⁷g⁽⁶⁾/604800): one interior evaluation, error O(h⁷), for orders 4 and 6
  /// on the quintic (the end derivatives, in t: Ω̇_n and ξ''(1)/h² of the quintic, and Ω̈).
  hermite,
  /// Lobatto's 4 points (two interior evaluations), error O(h⁷) (h⁷g⁽⁶⁾/1512000): the
  /// reference Hermite's rule is tested against (tests/test_adaptive.cpp).
  lobatto4,
};

/// The local error of the step a → b from the defect of its interpolant [D4]. With z the
/// exact solution from the start node and u the interpolant, d = u − z obeys
/// d' = (u' − f(u)) + J d, so the step's local error d(h) = ∫(u' − f(u)) dt + O(h·|d|):
///   e_ξ = φ − ∫₀ʰ T(ξ)⁻¹Ω dt,   e_Ω = Ω_{n+1} − Ω_n − ∫₀ʰ Ω̇(Λ, Ω, t) dt  along u,
/// by `rule`, whose end terms are the nodes' own rates (no new evaluation there) and, for
/// Hermite's rule, their derivatives along u, which the quintic has: d/dt T(ξ)⁻¹Ω = Ω̇_n
/// and ξ''(1)/h², and Ω̈ of the nodes. The interpolant's own error enters only as O(h·h⁶)
/// (quintic) or O(h·h⁴) (cubic), the rule's as its own: Simpson for order 2, Hermite's rule
/// for orders 4 and 6 (at order 6 both errors are O(h⁷), as the local error; measured,
/// Lobatto's 4 points estimate no better, at one more evaluation). Returns e_ξ (rad) and
/// e_Ω (rad/s).
template <class Scene>
void defect_estimate(const Scene& scene, const DenseNode<typename Scene::Scalar>& a,
                     const DenseNode<typename Scene::Scalar>& b, const LieHermite<typename Scene::Scalar>& seg,
                     DefectRule rule, Eigen::Matrix<typename Scene::Scalar, 3, 1>& e_rot,
                     Eigen::Matrix<typename Scene::Scalar, 3, 1>& e_omega) {
  using Scalar = typename Scene::Scalar;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  // interior nodes θ_i (the rules are symmetric), their weights and the ends' weight
  const Scalar s5 = Scalar(0.447213595499957939281834733746255L);  // 1/√5
  Scalar nodes[2], weights[2], w_end;
  int n_inner;
  switch (rule) {
    case DefectRule::simpson:
      nodes[0] = Scalar(0.5), weights[0] = Scalar(2) / Scalar(3), w_end = Scalar(1) / Scalar(6), n_inner = 1;
      break;
    case DefectRule::hermite:  // ∫₀¹g ≈ 7/30 (g₀ + g₁) + 8/15 g(½) + 1/60 (g₀' − g₁')
      nodes[0] = Scalar(0.5), weights[0] = Scalar(8) / Scalar(15), w_end = Scalar(7) / Scalar(30), n_inner = 1;
      break;
    default:
      nodes[0] = (1 - s5) / 2, nodes[1] = (1 + s5) / 2;
      weights[0] = weights[1] = Scalar(5) / Scalar(12), w_end = Scalar(1) / Scalar(12), n_inner = 2;
  }
  const Scalar h = seg.step();
  // the ends: T(0)⁻¹Ω_n = Ω_n, T(φ)⁻¹Ω_{n+1}; Ω̇ of the nodes
  Vector3 rate_xi = w_end * (a.state.omega + seg.phi_rate());
  Vector3 rate_omega = w_end * (a.omega_dot + b.omega_dot);
  if (rule == DefectRule::hermite) {  // + h/60 (g'(0) − g'(1)), g' = dg/dt along u
    eigen_assert(seg.quintic() && a.second && b.second && "defect_estimate: Hermite's rule needs the quintic");
    const Scalar w_rate = h / Scalar(60);
    rate_xi += w_rate * (a.omega_dot - seg.phi_rate_derivative());
    rate_omega += w_rate * (a.omega_ddot - b.omega_ddot);
  }
  // Time-independent potentials alone: their caches at Λ_n serve every node, whose torque
  // at Λ_n exp(ξ̂) comes from ξ and the coefficients of exp (eq. (8)) without forming Λ_i.
  constexpr bool potential_only = detail::potential_only<Scene>;
  [[maybe_unused]] typename Scene::Caches caches{};
  if constexpr (potential_only) caches = scene.caches(seg.rotation_start().matrix(), seg.t_start());
  for (int i = 0; i < n_inner; ++i) {
    Vector3 xi, omega;
    seg.algebra(nodes[i], xi, omega);
    const Scalar theta = xi.norm();
    rate_xi += weights[i] * detail::apply_inverse_tangent(xi, detail::inverse_tangent_coefficient(theta), omega);
    if constexpr (potential_only) {
      // the torque at Λ_n R, R = exp(ξ̂) = I + a ξ̂ + b ξ̂², in frame n, then in the node's
      // body frame: Rᵀτ = τ − a ξ × τ + b ξ × (ξ × τ)
      const detail::HalfAngle<Scalar> c = detail::half_angle(theta);
      const Scalar ca = c.sinc(), cb = c.one_minus_cos_over_sq();
      const Vector3 tau_n = scene.conservative_torque_rodrigues(caches, xi, ca, cb);
      const Vector3 xt = xi.cross(tau_n);
      const Vector3 tau = tau_n - ca * xt + cb * xi.cross(xt);
      rate_omega += weights[i] * euler_rate(scene, omega, tau, seg.t_start() + nodes[i] * h);
    } else if constexpr (Scene::has_potential || Scene::has_applied_torque) {
      rate_omega += weights[i] * omega_rate(scene, seg.rotation_at(xi).matrix(), omega, seg.t_start() + nodes[i] * h);
    } else {
      rate_omega += weights[i] * omega_rate(scene, Eigen::Matrix<Scalar, 3, 3>::Identity(), omega, seg.t_start() + nodes[i] * h);
    }
  }
  e_rot = seg.phi() - h * rate_xi;
  e_omega = b.state.omega - a.state.omega - h * rate_omega;
}

/// The dense solution of a run: the accepted steps' nodes, and the state anywhere in the
/// span by the interpolant of the step that holds t (solution(t)).
template <class Scalar>
class DenseSolution {
 public:
  /// Appends the node that ends the next accepted step (the first node is the start).
  void push(const DenseNode<Scalar>& node) { nodes_.push_back(node); }
  /// Whether the interpolant is quintic (else cubic).
  void set_quintic(bool q) { quintic_ = q; }
  /// The nodes (t_0, t_1, …, the end).
  const std::vector<DenseNode<Scalar>>& nodes() const { return nodes_; }
  /// The first and last time.
  Scalar t_start() const { return nodes_.empty() ? Scalar(0) : nodes_.front().state.time; }
  /// The time of the solution's end (the last node).
  Scalar t_end() const { return nodes_.empty() ? Scalar(0) : nodes_.back().state.time; }

  /// The state at t, which must lie in the span (throws invalid_input otherwise). At a node
  /// time, the node itself (bit for bit).
  State<Scalar> operator()(Scalar t) const {
    if (nodes_.empty()) detail::fail("solution: empty (no run stored)");
    const Scalar a = t_start(), b = t_end();
    const bool forward = b >= a;
    if (!std::isfinite(static_cast<double>(t)) || (forward ? (t < a || t > b) : (t > a || t < b)))
      detail::fail("solution: t = ", t, " is outside the span [", a, ", ", b, "]");
    if (nodes_.size() == 1) return nodes_.front().state;
    // First node at or beyond t in the direction of the run.
    const auto it = std::lower_bound(nodes_.begin(), nodes_.end(), t, [forward](const DenseNode<Scalar>& n, Scalar x) {
      return forward ? n.state.time < x : n.state.time > x;
    });
    if (it->state.time == t) return it->state;
    return LieHermite<Scalar>(*(it - 1), *it, quintic_).state(t);
  }

 private:
  std::vector<DenseNode<Scalar>> nodes_;
  bool quintic_ = true;
};

}  // namespace trompo
