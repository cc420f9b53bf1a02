#pragma once
// Scene<Scalar, Effects...>: a rigid body and the effects acting on it, fixed at compile
// time. The stepper's energy, torque and tangent are assembled from exactly the listed
// effects by fold expressions: an effect the scene does not name costs nothing.
#include <Eigen/Core>
#include <tuple>
#include <type_traits>
#include <utility>

#include "trompo/model/body.hpp"
#include "trompo/model/effects/effect.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

namespace detail {
/// True unless E is a potential that is not linear in Λ.
template <class E>
constexpr bool linear_or_not_potential() {
  if constexpr (std::is_same_v<typename E::kind, potential_kind>) return E::linear_in_rotation;
  else return true;
}
/// True for a rotor whose momentum depends on time (`time_dependent_rotor = true`: the
/// reaction wheels, whose held motor torques change it linearly, reaction_wheels.hpp).
template <class E>
constexpr bool time_dependent_rotor_effect() {
  if constexpr (requires { E::time_dependent_rotor; }) return static_cast<bool>(E::time_dependent_rotor);
  else return false;
}
/// True for an effect that reads the wheels' state (`reads_wheels = true`: a torque law of
/// the wheels' speeds, torque_law.hpp [W15]); its cache takes the scene's wheels.
template <class E>
constexpr bool reads_wheels_effect() {
  if constexpr (requires { E::reads_wheels; }) return static_cast<bool>(E::reads_wheels);
  else return false;
}
/// True for an effect that declares `static constexpr bool time_dependent = true`
/// (a potential V(Λ, t): the gravity gradient of an orbit).
template <class E>
constexpr bool time_dependent_effect() {
  if constexpr (requires { E::time_dependent; }) return static_cast<bool>(E::time_dependent);
  else return false;
}
}  // namespace detail

/// A rigid body and the effects acting on it, fixed at compile time: energy, momenta, torques
/// and their Jacobians are assembled from exactly the listed effects (docs/design.md).
template <class Scalar_, class... Effects>
class Scene {
 public:
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// The per-step caches of the effects, one per effect.
  using Caches = std::tuple<typename Effects::Cache...>;

  /// Whether effect E is of the given kind (potential_kind, torque_kind, rotor_kind).
  template <class E, class Kind>
  static constexpr bool is_kind = std::is_same_v<typename E::kind, Kind>;

  /// Some effect is a potential (enters H).
  static constexpr bool has_potential = (is_kind<Effects, potential_kind> || ...);
  /// Some effect is an applied torque.
  static constexpr bool has_applied_torque = (is_kind<Effects, torque_kind> || ...);
  /// Some effect is a rotor of constant momentum (Rotor).
  static constexpr bool has_rotor =
      ((is_kind<Effects, rotor_kind> && !detail::time_dependent_rotor_effect<Effects>()) || ...);
  /// Some effect is a rotor whose momentum h_r(t) depends on time: reaction wheels
  /// ([W1]–[W2]). Only schemes whose traits say `carries_wheels` step such a scene
  /// (SchemeFor, scheme.hpp): the others would miss ḣ_r.
  static constexpr bool has_wheels = (detail::time_dependent_rotor_effect<Effects>() || ...);
  /// Every potential is linear in Λ: the closed forms of Simo-κ (19) and [T2] apply.
  static constexpr bool potentials_linear = (detail::linear_or_not_potential<Effects>() && ...);
  /// Some potential depends on time (gravity gradient): energy() is then the Jacobi
  /// integral E_J = H − n ô·π [G4], and no scheme keeps it unless it says so (scheme.hpp).
  static constexpr bool has_time_dependent_potential = (detail::time_dependent_effect<Effects>() || ...);
  /// No effect at all: the free body; its step computes no torque.
  static constexpr bool is_free = sizeof...(Effects) == 0;

  /// The body and one value of each listed effect, in order.
  explicit Scene(RigidBody<Scalar> body, Effects... effects)
      : body_(std::move(body)), effects_(std::move(effects)...) {}

  /// The rigid body.
  const RigidBody<Scalar>& body() const { return body_; }
  /// The effects, in the order listed.
  const std::tuple<Effects...>& effects() const { return effects_; }
  /// The effect of type E.
  template <class E>
  const E& effect() const { return std::get<E>(effects_); }
  /// The effect of type E, to change between steps: the sampled driver moves the wheels'
  /// hold and sets held commands here (drivers/sampled.hpp). Never during a step.
  template <class E>
  E& effect() { return std::get<E>(effects_); }

  /// Axis of the momentum map μ = γ·Λ(JΩ + h_r): the up vector of the first effect
  /// that has one (gravity), else e3.
  Vector3 momentum_axis() const {
    Vector3 axis = Vector3::UnitZ();
    bool found = false;
    std::apply([&](const auto&... e) { ((found = found || take_up(e, axis)), ...); }, effects_);
    return axis;
  }

  // ---- invariants --------------------------------------------------------------------
  /// Π = JΩ + h_r (body momentum; the rotor term only with a rotor effect). A scene with
  /// wheels needs the time: momentum(Ω, t).
  Vector3 momentum(const Vector3& omega) const {
    static_assert(!has_wheels, "Scene::momentum(omega): a scene with wheels has Π(Ω, t); call momentum(omega, t)");
    Vector3 p = body_.momentum(omega);
    if constexpr (has_rotor) p += rotor_momentum();
    return p;
  }
  /// Π = JΩ + h_r + h_w(t) at time t (h_w the wheels' momentum [W1]; t is read only by wheels).
  Vector3 momentum(const Vector3& omega, Scalar t) const {
    Vector3 p = body_.momentum(omega);
    if constexpr (has_rotor) p += rotor_momentum();
    if constexpr (has_wheels) p += wheel_momentum(t);
    return p;
  }
  /// ½ Ω·JΩ (the rotor's own constant spin energy is left out; the wheels' is in energy()).
  Scalar kinetic_energy(const Vector3& omega) const { return body_.kinetic_energy(omega); }
  /// Σ h_w(t) over the wheel effects (body frame) [W2].
  Vector3 wheel_momentum(Scalar t) const {
    Vector3 h = Vector3::Zero();
    std::apply([&](const auto&... e) { ((add_wheels(e, t, h)), ...); }, effects_);
    return h;
  }
  /// Σ ḣ_w over the wheel effects: constant over a hold; −ḣ_w is the motors' torque on the body.
  Vector3 wheel_momentum_rate() const {
    Vector3 r = Vector3::Zero();
    std::apply([&](const auto&... e) { ((add_wheel_rate(e, r)), ...); }, effects_);
    return r;
  }
  /// [W17] Σ ḣ_w along the motion at (t, Ω): with the wheels' viscous friction (W17.a), which
  /// the dense output's nodes read (euler_rate); wheel_momentum_rate() without friction.
  Vector3 wheel_momentum_rate(Scalar t, const Vector3& omega) const {
    Vector3 r = Vector3::Zero();
    std::apply([&](const auto&... e) { ((add_wheel_rate(e, t, omega, r)), ...); }, effects_);
    return r;
  }
  /// [W17] Σ ḧ_w along the motion (W17.b), given the body's rate Ω̇; zero without friction.
  Vector3 wheel_momentum_acceleration(Scalar t, const Vector3& omega, const Vector3& omega_dot) const {
    Vector3 r = Vector3::Zero();
    std::apply([&](const auto&... e) { ((add_wheel_acceleration(e, t, omega, omega_dot, r)), ...); }, effects_);
    return r;
  }
  /// Whether some wheel effect has viscous friction [W17], which only integrate_sampled applies
  /// (split around each step, FixedSteps or AdaptiveSteps); integrate() and
  /// integrate_adaptive() refuse it.
  bool wheel_friction() const {
    bool f = false;
    if constexpr (has_wheels)
      std::apply([&](const auto&... e) { ((f = f || has_friction(e)), ...); }, effects_);
    return f;
  }
  /// The wheels' kinetic energy Σ h_i(t)²/(2J_s,i) [W3] (0 without wheels).
  Scalar wheel_energy(Scalar t) const {
    Scalar e(0);
    std::apply([&](const auto&... x) { ((add_wheel_energy(x, t, e)), ...); }, effects_);
    return e;
  }
  /// Σ V(Λ, t) over the potential effects (t matters only to a time-dependent potential).
  Scalar potential_energy(const SO3<Scalar>& rotation, Scalar t = Scalar(0)) const {
    if constexpr (has_potential) {
      const Caches c = caches(rotation.matrix(), t);
      return potential(c, Matrix3::Identity());
    } else {
      return Scalar(0);
    }
  }
  /// The scene's energy-like invariant: H = ½ Ω·JΩ + V(Λ); with a time-dependent potential
  /// (gravity gradient) the Jacobi integral E_J = ½ Ω·JΩ + V(Λ, t) − n ô·π [G4].
  Scalar energy(const State<Scalar>& s) const {
    Scalar wheels(0);
    if constexpr (has_wheels) wheels = wheel_energy(s.time);  // [W3]
    if constexpr (has_time_dependent_potential) {
      return kinetic_energy(s.omega) + wheels + potential_energy(s.rotation, s.time) +
             rotating_frame_energy(spatial_momentum(s));
    } else {
      return kinetic_energy(s.omega) + wheels + potential_energy(s.rotation);
    }
  }
  /// Σ of the effects' rotating-frame terms (−n ô·π for a gravity gradient [G4]; 0 for
  /// every other effect): the Jacobi integral is H plus this.
  Scalar rotating_frame_energy(const Vector3& pi) const {
    Scalar e(0);
    if constexpr (has_time_dependent_potential)
      std::apply([&](const auto&... x) { ((e += frame_term(x, pi)), ...); }, effects_);
    return e;
  }
  /// π = Λ(JΩ + h_r), the spatial angular momentum about O.
  Vector3 spatial_momentum(const State<Scalar>& s) const { return s.rotation * momentum(s.omega, s.time); }
  /// μ = γ·π, conserved under gravity about the up axis γ.
  Scalar momentum_map(const State<Scalar>& s) const { return momentum_axis().dot(spatial_momentum(s)); }

  // ---- assembly used by the schemes (frame of step n) ---------------------------------
  /// Each effect's cache for a step from Λ_n, with mid time t_mid (an effect that reads the
  /// wheels' state is handed the scene's wheels as well [W15]).
  Caches caches(const Matrix3& Lambda_n, Scalar t_mid) const {
    return std::apply([&](const auto&... e) { return Caches{cache_of(e, Lambda_n, t_mid)...}; }, effects_);
  }

  /// Σ V(Λ_n R)
  Scalar potential(const Caches& c, const Matrix3& R) const {
    Scalar v(0);
    for_each([&](const auto& e, const auto& ce) {
      if constexpr (is_kind<std::decay_t<decltype(e)>, potential_kind>) v += e.potential(ce, R);
    }, c);
    return v;
  }

  /// Σ conservative torques at Λ_n R, in frame n; with `jacobian`, also ∂/∂w.
  Vector3 conservative_torque(const Caches& c, const Matrix3& R, Matrix3* jacobian = nullptr) const {
    Vector3 tau = Vector3::Zero();
    if (jacobian) jacobian->setZero();
    for_each([&](const auto& e, const auto& ce) {
      if constexpr (is_kind<std::decay_t<decltype(e)>, potential_kind>) {
        tau += e.torque(ce, R);
        if (jacobian) *jacobian += e.torque_jacobian(ce, R);
      }
    }, c);
    return tau;
  }

  /// Σ of the rates of the conservative torques held in frame n (conservative_torque(c, R))
  /// along R = exp(tΩ̂) at t = 0: K Ω with K = ∂τ/∂w at R = I (an effect's
  /// torque_rate(c, Ω) where it has one, else its torque_jacobian(c, I)·Ω). The body-frame
  /// torque's rate is this minus Ω × τ (the dense output's Ω̈, drivers/dense_output.hpp).
  Vector3 conservative_torque_rate(const Caches& c, const Vector3& omega) const {
    Vector3 rate = Vector3::Zero();
    for_each([&](const auto& e, const auto& ce) {
      if constexpr (is_kind<std::decay_t<decltype(e)>, potential_kind>) {
        if constexpr (requires { e.torque_rate(ce, omega); })
          rate += e.torque_rate(ce, omega);
        else
          rate += e.torque_jacobian(ce, Matrix3::Identity()) * omega;
      }
    }, c);
    return rate;
  }

  /// Σ conservative torques at Λ_n R for R = I + a x̂ + b x̂² (8), given by x and its
  /// coefficients, in frame n. Effects with torque_rodrigues (gravity) rotate their body
  /// vector without forming R; for the others R is formed once. Same value as
  /// conservative_torque(c, SO3::rodrigues(x, a, b)) up to round-off.
  Vector3 conservative_torque_rodrigues(const Caches& c, const Vector3& x, Scalar a, Scalar b) const {
    Vector3 tau = Vector3::Zero();
    [[maybe_unused]] Matrix3 R;
    [[maybe_unused]] bool have_R = false;
    for_each([&](const auto& e, const auto& ce) {
      if constexpr (is_kind<std::decay_t<decltype(e)>, potential_kind>) {
        if constexpr (requires { e.torque_rodrigues(ce, x, a, b); }) {
          tau += e.torque_rodrigues(ce, x, a, b);
        } else {
          if (!have_R) R = SO3<Scalar>::rodrigues(x, a, b);
          have_R = true;
          tau += e.torque(ce, R);
        }
      }
    }, c);
    return tau;
  }

  /// Σ applied (non-conservative) torques at the mid configuration Λ_n R_mid and mid
  /// velocity, in frame n; optional Jacobians w.r.t. w (rotation) and Ω_m.
  Vector3 applied_torque(const Caches& c, const Matrix3& R_mid, const Vector3& omega_mid,
                         Matrix3* d_rotation = nullptr, Matrix3* d_omega = nullptr) const {
    Vector3 tau = Vector3::Zero();
    if (d_rotation) d_rotation->setZero();
    if (d_omega) d_omega->setZero();
    for_each([&](const auto& e, const auto& ce) {
      if constexpr (is_kind<std::decay_t<decltype(e)>, torque_kind>) {
        tau += e.torque(ce, R_mid, omega_mid);
        if (d_rotation) *d_rotation += e.torque_jacobian_rotation(ce, R_mid, omega_mid);
        if (d_omega) *d_omega += e.torque_jacobian_omega(ce, R_mid, omega_mid);
      }
    }, c);
    return tau;
  }

  /// Σ h_r over the rotor effects (body frame).
  Vector3 rotor_momentum() const {
    Vector3 h = Vector3::Zero();
    std::apply([&](const auto&... e) { ((add_rotor(e, h)), ...); }, effects_);
    return h;
  }

  /// Total body torque at state (Λ, Ω, t), for explicit schemes (RK4).
  Vector3 body_torque(const Matrix3& Lambda, const Vector3& omega, Scalar t) const {
    Vector3 tau = Vector3::Zero();
    if constexpr (has_potential || has_applied_torque) {
      const Caches c = caches(Lambda, t);
      const Matrix3 I = Matrix3::Identity();
      if constexpr (has_potential) tau += conservative_torque(c, I);
      if constexpr (has_applied_torque) tau += applied_torque(c, I, omega);
    }
    return tau;
  }

 private:
  template <class E>
  typename E::Cache cache_of(const E& e, const Matrix3& Lambda_n, Scalar t_mid) const {
    if constexpr (detail::reads_wheels_effect<E>()) {
      static_assert(has_wheels, "a torque law of the wheels' state needs a scene with ReactionWheels");
      return e.cache(Lambda_n, t_mid, std::get<typename E::Wheels>(effects_));
    } else {
      return e.cache(Lambda_n, t_mid);
    }
  }
  template <class E>
  static bool take_up(const E& e, Vector3& axis) {
    if constexpr (requires { e.up(); }) {
      axis = e.up();
      return true;
    } else {
      return false;
    }
  }
  template <class E>
  static Scalar frame_term(const E& e, const Vector3& pi) {
    if constexpr (requires { e.rotating_frame_energy(pi); }) return e.rotating_frame_energy(pi);
    else return Scalar(0);
  }
  template <class E>
  static void add_rotor(const E& e, Vector3& h) {
    if constexpr (is_kind<E, rotor_kind> && !detail::time_dependent_rotor_effect<E>()) h += e.rotor_momentum();
  }
  template <class E>
  static void add_wheels(const E& e, Scalar t, Vector3& h) {
    if constexpr (detail::time_dependent_rotor_effect<E>()) h += e.rotor_momentum(t);
  }
  template <class E>
  static void add_wheel_rate(const E& e, Vector3& r) {
    if constexpr (detail::time_dependent_rotor_effect<E>()) r += e.rotor_momentum_rate();
  }
  template <class E>
  static void add_wheel_rate(const E& e, Scalar t, const Vector3& omega, Vector3& r) {
    if constexpr (requires { e.rotor_momentum_rate(t, omega); }) r += e.rotor_momentum_rate(t, omega);
    else if constexpr (detail::time_dependent_rotor_effect<E>()) r += e.rotor_momentum_rate();
  }
  template <class E>
  static void add_wheel_acceleration(const E& e, Scalar t, const Vector3& omega, const Vector3& omega_dot, Vector3& r) {
    if constexpr (requires { e.rotor_momentum_acceleration(t, omega, omega_dot); })
      r += e.rotor_momentum_acceleration(t, omega, omega_dot);
  }
  template <class E>
  static bool has_friction(const E& e) {
    if constexpr (requires { e.has_friction(); }) return e.has_friction();
    else return false;
  }
  template <class E>
  static void add_wheel_energy(const E& e, Scalar t, Scalar& x) {
    if constexpr (detail::time_dependent_rotor_effect<E>()) x += e.rotor_energy(t);
  }
  template <class F>
  void for_each(F&& f, const Caches& c) const {
    for_each_impl(f, c, std::index_sequence_for<Effects...>{});
  }
  template <class F, std::size_t... I>
  void for_each_impl(F& f, const Caches& c, std::index_sequence<I...>) const {
    (f(std::get<I>(effects_), std::get<I>(c)), ...);
  }

  RigidBody<Scalar> body_;
  std::tuple<Effects...> effects_;
};

/// The torque-free body.
template <class Scalar>
using FreeScene = Scene<Scalar>;

}  // namespace trompo
