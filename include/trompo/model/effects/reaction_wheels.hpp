#pragma once
// Reaction wheels: N balanced wheels whose motor torques are held constant over a sample
// interval (zero-order hold), with the total angular momentum of body plus wheels exact in
// the energy-momentum schemes (docs/theory.md §16, [W1]–[W6]; docs/control.md).
//
//   ReactionWheels<double> rw;                                 // up to max_wheels wheels
//   rw.add_wheel({.axis = V::UnitX(), .inertia = 0.0796, .speed0 = 10.47, .max_torque = 0.2});
//   RigidBody<double> hub = rw.hub_body(J);                    // J − Σ J_s g gᵀ  [W1]
//   Scene<double, ReactionWheels<double>> sc(hub, rw);
//   sc.effect<ReactionWheels<double>>().start(0.0, omega0);     // h_i(0) from the speeds
//
// The model [W1]. J is the whole spacecraft's inertia (wheels included), wheel i has unit
// spin axis g_i (body), axial inertia J_s,i and speed Ω_i relative to the body. With the
// wheels' absolute axial momenta h_i = J_s,i (Ω_i + g_i·Ω), the body momentum is
//   Π = J Ω + Σ J_s,i Ω_i g_i = J_hub Ω + Σ h_i g_i,   J_hub = J − Σ J_s,i g_i g_iᵀ,
// and the equations are Π̇ + Ω × Π = τ_ext, ḣ_i = u_i (u_i the motor torque on wheel i).
// So the scene's body is the hub, J_hub, and the wheels are a rotor whose momentum
// h_r(t) = Σ h_i(t) g_i changes with time.
//
// The hold [W2]. Flight software sets u at the samples t_k and holds it until t_{k+1}:
// inside a hold h_i(t) = h_i(t_k) + u_i (t − t_k) exactly, so the wheels need no state of
// their own in the schemes: h_r(t) is a known linear function of t, every step (fixed or
// adaptive, forward or backward, a sub-step of a composition or of a recovered interval,
// a dense-output node) reads it at its own times, and a failed step changes nothing. The
// sampled driver (drivers/sampled.hpp) moves the hold to the next sample with hold(),
// which carries h_i(t_{k+1}) over exactly as this line. Without a driver u = 0: the wheels
// spin at constant absolute momentum, a gyrostat.
//
// Energy [W3]: T = ½ ΩᵀJ_hubΩ + Σ h_i²/(2J_s,i), which equals ½ΩᵀJΩ + Σ(½J_s,iΩ_i² +
// J_s,iΩ_i g_iᵀΩ); Ṫ = Σ u_i Ω_i + Ω·τ_ext (the motors' power).
//
// Viscous friction [W17]: a wheel may have a coefficient c_i ≥ 0, the torque −c_i Ω_i between
// wheel and hub. It makes h_i depend on the body inside a hold, so it is not in the hold's
// line: the sampled driver splits it around each step, fixed or adaptive (Strang; around each sub-step of
// a ComposedStepper, which so keeps its order), as the exact flow of
// friction alone (friction_flow: Λ and Π fixed, the relative speeds decaying by a matrix
// exponential), which keeps π and dissipates exactly Σ c_i Ω_i² over its time. The schemes
// between see the linear line above. integrate() and integrate_adaptive() refuse a scene whose
// wheels have friction (they would leave it out).
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "trompo/errors.hpp"
#include "trompo/model/body.hpp"
#include "trompo/model/effects/effect.hpp"

namespace trompo {

/// One reaction wheel: spin axis (body; normalised), axial inertia J_s > 0, initial speed
/// relative to the body (rad/s), motor torque limit u_max > 0 (N m) and speed limit
/// Ω_max > 0 (rad/s); infinite limits mean none.
template <class Scalar>
struct Wheel {
  Eigen::Matrix<Scalar, 3, 1> axis = Eigen::Matrix<Scalar, 3, 1>::UnitZ();  ///< g, body axes
  Scalar inertia = Scalar(1);                                                ///< J_s
  Scalar speed0 = Scalar(0);                                                 ///< Ω_i(t_0), relative
  Scalar max_torque = std::numeric_limits<Scalar>::infinity();               ///< u_max
  Scalar max_speed = std::numeric_limits<Scalar>::infinity();                ///< Ω_max
  Scalar friction = Scalar(0);  ///< c ≥ 0 (N m s/rad): the viscous torque −c Ω_i on the wheel [W17]
};

/// N ≤ max_wheels reaction wheels with motor torques held over each sample interval; a
/// rotor whose momentum h_r(t) = Σ (h_i(t_k) + u_i (t − t_k)) g_i is linear in time [W2].
template <class Scalar_>
class ReactionWheels {
 public:
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// An internal momentum (effect.hpp).
  using kind = rotor_kind;
  /// The rotor momentum depends on time (scene.hpp: the schemes read h_r(t) at their times).
  static constexpr bool time_dependent_rotor = true;
  /// The most wheels one effect carries (fixed-size storage: no heap, a cheap copy).
  static constexpr int max_wheels = 8;
  /// Per-wheel values: the first size() entries are used.
  using WheelVector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1, 0, max_wheels, 1>;

  /// No wheels (add them with add_wheel).
  ReactionWheels() = default;

  /// Adds a wheel. Throws invalid_input naming the field: a zero or non-finite axis,
  /// J_s ≤ 0 or non-finite, a non-finite speed, a limit ≤ 0 or NaN, more than max_wheels.
  void add_wheel(Wheel<Scalar> w) {
    const int i = n_;
    const std::string name = "wheels: wheel " + std::to_string(i + 1) + ": ";
    if (i >= max_wheels) detail::fail(name, "at most ", max_wheels, " wheels");
    if (!detail::all_finite(w.axis) || !(w.axis.norm() > Scalar(0)))
      detail::fail(name, "axis must be finite and non-zero, got ", detail::to_text(w.axis));
    if (!std::isfinite(static_cast<double>(w.inertia)) || !(w.inertia > Scalar(0)))
      detail::fail(name, "Js (axial inertia) must be finite and > 0, got ", w.inertia);
    if (!std::isfinite(static_cast<double>(w.speed0))) detail::fail(name, "speed0 must be finite, got ", w.speed0);
    if (!(w.max_torque > Scalar(0))) detail::fail(name, "max_torque must be > 0, got ", w.max_torque);
    if (!(w.max_speed > Scalar(0))) detail::fail(name, "max_speed must be > 0, got ", w.max_speed);
    check_friction(name, w.friction);
    ++n_;
    axes_.conservativeResize(3, n_);
    axes_.col(i) = w.axis.normalized();
    resize_and_set(Js_, i, w.inertia);
    resize_and_set(speed0_, i, w.speed0);
    resize_and_set(u_max_, i, w.max_torque);
    resize_and_set(w_max_, i, w.max_speed);
    resize_and_set(c_, i, w.friction);
    friction_ready_ = false;  // prepare_friction again with this wheel
    resize_and_set(h_k_, i, w.inertia * w.speed0);  // absolute momentum for Ω = 0, until start()
    resize_and_set(u_, i, Scalar(0));
  }

  /// The number of wheels.
  int size() const { return n_; }
  /// Spin axis g_i (unit, body axes).
  Vector3 axis(int i) const { return axes_.col(i); }
  /// The 3×N matrix G_s = [g_1 … g_N].
  const Eigen::Matrix<Scalar, 3, Eigen::Dynamic, 0, 3, max_wheels>& axes() const { return axes_; }
  /// Axial inertias J_s,i.
  const WheelVector& inertias() const { return Js_; }
  /// Motor torque limits u_max,i.
  const WheelVector& max_torques() const { return u_max_; }
  /// Speed limits Ω_max,i.
  const WheelVector& max_speeds() const { return w_max_; }
  /// Viscous friction coefficients c_i [W17].
  const WheelVector& frictions() const { return c_; }
  /// Sets wheel i's viscous friction coefficient c ≥ 0 [W17] (per-member dispersion in an
  /// ensemble's setup; prepare_friction again before friction_flow). Throws invalid_input
  /// naming the wheel for a bad index or a c that is negative or not finite.
  void set_friction(int i, Scalar c) {
    const std::string name = "wheels: wheel " + std::to_string(i + 1) + ": ";
    if (i < 0 || i >= n_) detail::fail(name, "no such wheel (", n_, " wheels)");
    check_friction(name, c);
    c_(i) = c;
    friction_ready_ = false;
  }
  /// Whether some wheel has viscous friction (c_i > 0) [W17].
  bool has_friction() const {
    for (int i = 0; i < n_; ++i)
      if (c_(i) > Scalar(0)) return true;
    return false;
  }

  /// The hub's inertia J_hub = J − Σ J_s,i g_i g_iᵀ [W1], as the scene's body; J is the whole
  /// spacecraft's. Throws invalid_input if J_hub is not positive definite (the wheels'
  /// axial inertias exceed the spacecraft's about their axes).
  RigidBody<Scalar> hub_body(const Matrix3& J) const {
    Matrix3 hub = J;
    for (int i = 0; i < n_; ++i) hub -= Js_(i) * axes_.col(i) * axes_.col(i).transpose();
    const Eigen::SelfAdjointEigenSolver<Matrix3> eig(hub, Eigen::EigenvaluesOnly);
    if (!(eig.eigenvalues().minCoeff() > Scalar(0)))
      detail::fail("wheels: J - sum Js g g^T (the hub's inertia) must be positive definite; its smallest moment is ",
                   eig.eigenvalues().minCoeff());
    return RigidBody<Scalar>(hub, allow_unphysical_inertia);
  }

  /// Starts the hold at t_0 with the wheels at their initial relative speeds and the body
  /// at Ω_0: h_i = J_s,i (Ω_i(0) + g_i·Ω_0), u = 0.
  void start(Scalar t0, const Vector3& omega0) { set_speeds(t0, omega0, speed0_); }

  /// Sets the wheels' relative speeds at t (body at Ω), u = 0 from then on.
  void set_speeds(Scalar t, const Vector3& omega, const WheelVector& speeds) {
    t_k_ = t;
    for (int i = 0; i < n_; ++i) {
      h_k_(i) = Js_(i) * (speeds(i) + axes_.col(i).dot(omega));
      u_(i) = Scalar(0);
    }
  }

  /// Moves the hold to t (the next sample): h_i(t) carried over by the linear law [W2], and
  /// the new motor torques u held from t on. u is taken as given (saturate it first).
  void hold(Scalar t, const WheelVector& u) {
    for (int i = 0; i < n_; ++i) h_k_(i) += u_(i) * (t - t_k_);
    t_k_ = t;
    u_ = u;
  }

  /// [W5] saturation, as Basilisk's and 42's wheels do it: each u_i clipped to ±u_max,i, and
  /// 0 when the wheel is at or past its speed limit and u_i would speed it up further.
  WheelVector saturate(const WheelVector& u, const WheelVector& speeds) const {
    WheelVector s = u;
    for (int i = 0; i < n_; ++i) {
      s(i) = std::min(std::max(u(i), -u_max_(i)), u_max_(i));
      if (std::abs(speeds(i)) >= w_max_(i) && s(i) * speeds(i) > Scalar(0)) s(i) = Scalar(0);
    }
    return s;
  }

  /// The hold's line: h_i(t_k) and t_k, what hold() and friction_flow move (u aside).
  struct HoldLine {
    WheelVector momenta;  ///< h_i(t_k)
    Scalar time;          ///< t_k
  };
  /// The hold's line, to put back with set_hold_line (a driver's failed interval, [W17]).
  HoldLine hold_line() const { return {h_k_, t_k_}; }
  /// Puts a hold's line back (from hold_line(); the held u is unchanged).
  void set_hold_line(const HoldLine& line) {
    h_k_ = line.momenta;
    t_k_ = line.time;
  }

  /// The held motor torques u.
  const WheelVector& torques() const { return u_; }
  /// The start of the hold, t_k.
  Scalar hold_time() const { return t_k_; }

  /// h_i(t) = h_i(t_k) + u_i (t − t_k): the absolute axial momenta [W2].
  WheelVector momenta(Scalar t) const { return h_k_ + u_ * (t - t_k_); }
  /// Ω_i(t) = h_i(t)/J_s,i − g_i·Ω: the speeds relative to the body.
  WheelVector speeds(Scalar t, const Vector3& omega) const { return speeds<Scalar>(t, omega); }
  /// The same of Ω's scalar T (a torque law of the wheels' state calls it with AutoDiff
  /// scalars, torque_law.hpp [W15]).
  template <class T>
  Eigen::Matrix<T, Eigen::Dynamic, 1, 0, max_wheels, 1> speeds(Scalar t, const Eigen::Matrix<T, 3, 1>& omega) const {
    const WheelVector h = momenta(t);
    Eigen::Matrix<T, Eigen::Dynamic, 1, 0, max_wheels, 1> w(n_);
    for (int i = 0; i < n_; ++i) w(i) = T(h(i) / Js_(i)) - axes_.col(i).template cast<T>().dot(omega);
    return w;
  }
  /// h_r(t) = Σ h_i(t) g_i, body axes.
  Vector3 rotor_momentum(Scalar t) const {
    Vector3 h = Vector3::Zero();
    for (int i = 0; i < n_; ++i) h += (h_k_(i) + u_(i) * (t - t_k_)) * axes_.col(i);
    return h;
  }
  /// ḣ_r = Σ u_i g_i, constant over the hold: the motors' reaction on the body is −ḣ_r.
  Vector3 rotor_momentum_rate() const {
    Vector3 r = Vector3::Zero();
    for (int i = 0; i < n_; ++i) r += u_(i) * axes_.col(i);
    return r;
  }
  /// [W17] ḣ_r along the motion at (t, Ω), with the viscous friction: Σ (u_i − c_i Ω_i) g_i
  /// (W17.a), what the dense output's nodes read. The schemes' steps read rotor_momentum_rate(),
  /// the friction being split around them; without friction the two are equal.
  Vector3 rotor_momentum_rate(Scalar t, const Vector3& omega) const {
    const WheelVector rates = momentum_rates(t, omega);
    Vector3 r = Vector3::Zero();
    for (int i = 0; i < n_; ++i) r += rates(i) * axes_.col(i);
    return r;
  }
  /// [W17] ḧ_r along the motion: Σ ḧ_i g_i with ḧ_i = −c_i (ḣ_i/J_s,i − g_i·Ω̇) (W17.b), Ω̇ the
  /// body's rate with the friction; zero without friction (u is held).
  Vector3 rotor_momentum_acceleration(Scalar t, const Vector3& omega, const Vector3& omega_dot) const {
    const WheelVector rates = momentum_rates(t, omega);
    Vector3 r = Vector3::Zero();
    for (int i = 0; i < n_; ++i)
      if (c_(i) != Scalar(0)) r -= c_(i) * (rates(i) / Js_(i) - axes_.col(i).dot(omega_dot)) * axes_.col(i);
    return r;
  }
  /// [W17] The wheels' momentum rates along the motion at (t, Ω): ḣ_i = u_i − c_i Ω_i.
  WheelVector momentum_rates(Scalar t, const Vector3& omega) const {
    WheelVector rates = u_;
    if (has_friction()) {  // (a wheel without friction keeps u_i exactly, whatever its speed)
      const WheelVector w = speeds(t, omega);
      for (int i = 0; i < n_; ++i)
        if (c_(i) != Scalar(0)) rates(i) -= c_(i) * w(i);
    }
    return rates;
  }
  /// The wheels' share of the kinetic energy, Σ h_i(t)²/(2 J_s,i) [W3].
  Scalar rotor_energy(Scalar t) const {
    Scalar e(0);
    for (int i = 0; i < n_; ++i) {
      const Scalar hi = h_k_(i) + u_(i) * (t - t_k_);
      e += hi * hi / (Scalar(2) * Js_(i));
    }
    return e;
  }
  /// The motors' power Σ u_i Ω_i at (t, Ω) [W3].
  Scalar motor_power(Scalar t, const Vector3& omega) const { return u_.dot(speeds(t, omega)); }

  /// [W17] Prepares friction_flow for the hub whose inverse inertia is J_hub⁻¹ (the scene's
  /// body): the symmetric matrix M = C^½ S C^½ of the wheels with c_i > 0, S_ij = δ_ij/J_s,i +
  /// g_iᵀJ_hub⁻¹g_j, and its eigen-decomposition M = Q D Qᵀ. Once per run (the sampled driver
  /// calls it); it allocates nothing per step afterwards.
  void prepare_friction(const Matrix3& J_hub_inverse) {
    m_ = 0;
    for (int i = 0; i < n_; ++i) {
      Jinv_g_.col(i) = J_hub_inverse * axes_.col(i);
      if (c_(i) > Scalar(0)) fric_(m_++) = i;
    }
    sqrt_c_.resize(m_);
    SquareMatrix M(m_, m_);
    for (int a = 0; a < m_; ++a) sqrt_c_(a) = std::sqrt(c_(fric_(a)));
    for (int a = 0; a < m_; ++a)
      for (int b = 0; b < m_; ++b) {
        const int i = fric_(a), j = fric_(b);
        const Scalar S = (a == b ? Scalar(1) / Js_(i) : Scalar(0)) + axes_.col(i).dot(Jinv_g_.col(j));
        M(a, b) = sqrt_c_(a) * S * sqrt_c_(b);
      }
    if (m_ > 0) {
      const Eigen::SelfAdjointEigenSolver<SquareMatrix> eig(M);
      Q_ = eig.eigenvectors();
      d_ = eig.eigenvalues().cwiseMax(Scalar(0));  // M is positive definite; no rounding below 0
    }
    friction_ready_ = true;
  }

  /// [W17] The exact flow of the wheels' viscous friction alone, for a time tau from t: Λ and
  /// the body momentum Π = J_hubΩ + Σ h_i g_i stay, the relative speeds x_i = Ω_i of the wheels
  /// with friction decay as ẋ = −S C x, i.e. y = C^½x as y(σ) = Q e^{−Dσ} Qᵀ y(0), and
  ///   Δh_i = −c_i ∫₀^τ x_i dσ = −√c_i [Q diag((1 − e^{−d_a τ})/d_a) Qᵀ y(0)]_i,
  ///   ΔΩ = −J_hub⁻¹ Σ Δh_i g_i.
  /// Ω is updated in place and the hold moves to t with the new momenta (u as held). Returns
  /// the energy the friction dissipated, ∫₀^τ Σ c_i x_i² dσ = Σ_a z_a² (1 − e^{−2d_a τ})/(2d_a),
  /// z = Qᵀy(0): the kinetic energy [W3] falls by exactly that. tau < 0 runs it backward.
  /// Throws invalid_input if prepare_friction was not called.
  Scalar friction_flow(Scalar t, Scalar tau, Vector3& omega) {
    using std::expm1;
    if (!friction_ready_) detail::fail("wheels: friction_flow needs prepare_friction(J_hub^-1) first");
    WheelVector h = momenta(t);
    Scalar dissipated(0);
    if (m_ > 0) {
      WheelVector y(m_);
      for (int a = 0; a < m_; ++a) {
        const int i = fric_(a);
        y(a) = sqrt_c_(a) * (h(i) / Js_(i) - axes_.col(i).dot(omega));
      }
      WheelVector z = Q_.transpose() * y;
      for (int a = 0; a < m_; ++a) {
        const Scalar d = d_(a);
        // φ = (1 − e^{−dτ})/d by expm1 (τ for d = 0), and (1 − e^{−2dτ})/(2d) = φ(1 + e^{−dτ})/2
        // = φ − dφ²/2 from it (e^{−dτ} = 1 − dφ): one exponential a mode.
        const Scalar phi = d > Scalar(0) ? -expm1(-d * tau) / d : tau;
        const Scalar phi2 = phi - d * phi * phi / Scalar(2);
        dissipated += z(a) * z(a) * phi2;
        z(a) *= phi;
      }
      const WheelVector integral = Q_ * z;  // ∫₀^τ y dσ
      for (int a = 0; a < m_; ++a) {
        const int i = fric_(a);
        const Scalar dh = -sqrt_c_(a) * integral(a);
        h(i) += dh;
        omega -= dh * Jinv_g_.col(i);
      }
    }
    h_k_ = h;
    t_k_ = t;
    return dissipated;
  }
  /// The power the friction dissipates at (t, Ω), Σ c_i Ω_i² [W17].
  Scalar friction_power(Scalar t, const Vector3& omega) const {
    const WheelVector x = speeds(t, omega);
    Scalar p(0);
    for (int i = 0; i < n_; ++i) p += c_(i) * x(i) * x(i);
    return p;
  }

  /// Nothing to keep per step (one initialised byte: see Rotor::Cache).
  struct Cache {
    char unused = 0;  ///< the initialised byte
  };
  /// Nothing to prepare per step.
  Cache cache(const Matrix3& /*Lambda_n*/, Scalar /*t_mid*/) const { return {}; }

 private:
  /// A friction coefficient must be finite and ≥ 0 (add_wheel, set_friction).
  static void check_friction(const std::string& name, Scalar c) {
    if (!std::isfinite(static_cast<double>(c)) || !(c >= Scalar(0)))
      detail::fail(name, "friction must be finite and >= 0 (N m s/rad), got ", c);
  }
  static void resize_and_set(WheelVector& v, int i, Scalar x) {
    v.conservativeResize(i + 1);
    v(i) = x;
  }

  using SquareMatrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, 0, max_wheels, max_wheels>;

  int n_ = 0;
  Eigen::Matrix<Scalar, 3, Eigen::Dynamic, 0, 3, max_wheels> axes_;
  WheelVector Js_, speed0_, u_max_, w_max_, c_;
  // The friction flow's constants (prepare_friction) [W17]: the m_ wheels with c_i > 0, their
  // indices, √c_i, M = Q D Qᵀ, and J_hub⁻¹g_i of every wheel.
  bool friction_ready_ = false;
  int m_ = 0;
  Eigen::Matrix<int, max_wheels, 1> fric_ = Eigen::Matrix<int, max_wheels, 1>::Zero();
  WheelVector sqrt_c_, d_;
  SquareMatrix Q_;
  Eigen::Matrix<Scalar, 3, max_wheels> Jinv_g_ = Eigen::Matrix<Scalar, 3, max_wheels>::Zero();
  WheelVector h_k_;  ///< h_i(t_k)
  WheelVector u_;    ///< held motor torques
  Scalar t_k_ = Scalar(0);
};

}  // namespace trompo
