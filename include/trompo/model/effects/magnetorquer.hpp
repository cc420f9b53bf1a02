#pragma once
// The Earth's magnetic field along a circular orbit (a centred tilted dipole), and
// magnetorquers: a commanded dipole m held over a sample interval, τ = m × B in body axes
// (docs/theory.md §16, [W9]–[W10]; docs/control.md).
//
//   CircularOrbit<double> orbit(6771e3, 51.6 * pi / 180);         // radius, inclination
//   DipoleField<double> field(orbit);                              // IGRF-13 at 2020.0
//   Magnetorquer<double> mtq(field);                               // m = 0 until commanded
//   Scene<double, Magnetorquer<double>> sc(body, mtq);
//   sc.effect<Magnetorquer<double>>().dipole = Eigen::Vector3d(0.1, 0, 0);   // A m², held
//
// Orbit [W9]. Radius r, inclination i, right ascension of the ascending node Ω_N and argument
// of latitude u_0 at t = 0; the rate n = √(μ_E/r³). In inertial (ECI) axes
//   r̂(t) = (cos u cos Ω_N − sin u cos i sin Ω_N, cos u sin Ω_N + sin u cos i cos Ω_N, sin u sin i),
// u = u_0 + n t. The same orbit gives the gravity gradient its normal ô and r̂(0)
// (normal(), radial0(), rate()).
//
// Field [W10]. The first-degree Gauss coefficients give the dipole m₀ = (g11, h11, g10) (nT, in
// Earth-fixed axes) and B(r) = (R_E/|r|)³ [3(m̂₀·r̂) r̂ − m̂₀] |m₀|. The default coefficients are
// IGRF-13 at epoch 2020.0 (g10 = −29404.8, g11 = −1450.9, h11 = 4652.5 nT), R_E = 6371.2 km. The
// Earth turns about ECI z at ω_E = 7.2921159e-5 rad/s, with Earth-fixed and inertial axes
// aligned at t = 0 (the Greenwich sidereal angle at t = 0 is a parameter, 0 by default).
//
// The torque. τ_b = m × Λᵀ B(t): in frame n at Λ_n R it is R(m × Rᵀb) = (Rm) × b with
// b = Λ_nᵀ B(t_{n+½}) (the cache); ∂/∂w of (R exp(ŵ) m) × b = b̂ R m̂. τ·Ω ≠ 0: magnetorquers do
// work and change π (an external torque); the schemes' power balance is exact [W7].
#include <Eigen/Core>
#include <cmath>
#include <limits>

#include "trompo/errors.hpp"
#include "trompo/lie/series.hpp"
#include "trompo/lie/so3.hpp"
#include "trompo/model/effects/effect.hpp"

namespace trompo {

/// A circular orbit about the Earth [W9].
template <class Scalar>
class CircularOrbit {
 public:
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// μ_E, the Earth's gravitational parameter (m³/s², EGM-96/WGS-84).
  static constexpr double mu_earth = 3.986004418e14;

  /// Radius (m, > 0), inclination, node and argument of latitude at t = 0 (rad). Throws
  /// invalid_input naming the field.
  explicit CircularOrbit(Scalar radius, Scalar inclination = Scalar(0), Scalar raan = Scalar(0),
                         Scalar latitude0 = Scalar(0))
      : r_(radius), i_(inclination), raan_(raan), u0_(latitude0) {
    if (!std::isfinite(static_cast<double>(radius)) || !(radius > Scalar(0)))
      detail::fail("orbit: radius must be finite and > 0 (m), got ", radius);
    if (!std::isfinite(static_cast<double>(inclination))) detail::fail("orbit: non-finite inclination ", inclination);
    if (!std::isfinite(static_cast<double>(raan))) detail::fail("orbit: non-finite node ", raan);
    if (!std::isfinite(static_cast<double>(latitude0))) detail::fail("orbit: non-finite argument of latitude ", latitude0);
    n_ = std::sqrt(Scalar(mu_earth) / (r_ * r_ * r_));
    using std::cos, std::sin;
    // The in-plane basis of [W9]: r̂ = cos u p̂ + sin u q̂ (node line and its normal in the plane).
    p_ = Vector3(cos(raan_), sin(raan_), Scalar(0));
    q_ = Vector3(-cos(i_) * sin(raan_), cos(i_) * cos(raan_), sin(i_));
  }
  /// The radius (m).
  Scalar radius() const { return r_; }
  /// The rate n = √(μ_E/r³) (rad/s).
  Scalar rate() const { return n_; }
  /// The argument of latitude u = u₀ + n t (rad).
  Scalar latitude(Scalar t) const { return u0_ + n_ * t; }
  /// r̂ at t, inertial axes [W9].
  Vector3 radial(Scalar t) const {
    using std::cos, std::sin;
    const Scalar u = latitude(t);
    return radial_of(cos(u), sin(u));
  }
  /// r̂ = cos u p̂ + sin u q̂ from cos u and sin u.
  Vector3 radial_of(Scalar cos_u, Scalar sin_u) const { return cos_u * p_ + sin_u * q_; }
  /// r̂(0).
  Vector3 radial0() const { return radial(Scalar(0)); }
  /// The orbit normal ô (along r × v), inertial axes.
  Vector3 normal() const {
    using std::cos, std::sin;
    return Vector3(sin(i_) * sin(raan_), -sin(i_) * cos(raan_), cos(i_));
  }

 private:
  Scalar r_, i_, raan_, u0_, n_ = Scalar(0);
  Vector3 p_ = Vector3::Zero(), q_ = Vector3::Zero();  ///< the in-plane basis
};

/// The geomagnetic field as a centred tilted dipole along a circular orbit [W10].
template <class Scalar>
class DipoleField {
 public:
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// The Earth's reference radius of the Gauss coefficients (m).
  static constexpr double earth_radius = 6371.2e3;
  /// The Earth's rotation rate (rad/s).
  static constexpr double earth_rate = 7.2921159e-5;

  /// The orbit and the first-degree Gauss coefficients (nT; IGRF-13, 2020.0 by default), and
  /// the Greenwich angle at t = 0.
  explicit DipoleField(CircularOrbit<Scalar> orbit, Scalar g10 = Scalar(-29404.8), Scalar g11 = Scalar(-1450.9),
                       Scalar h11 = Scalar(4652.5), Scalar greenwich0 = Scalar(0))
      : orbit_(orbit), m0_(Vector3(g11, h11, g10) * Scalar(1e-9)), theta0_(greenwich0) {
    if (!detail::all_finite(m0_) || !(m0_.norm() > Scalar(0)))
      detail::fail("field: the Gauss coefficients (g10, g11, h11) must be finite and not all zero");
    const Scalar k = Scalar(earth_radius) / orbit_.radius();
    m0_ *= k * k * k;  // the dipole at the orbit's radius: B = 3(m·r̂)r̂ − m
  }
  /// The orbit.
  const CircularOrbit<Scalar>& orbit() const { return orbit_; }

  /// The field's two angles at a time t₀, the Greenwich angle θ and the argument of latitude u,
  /// by their cosines and sines: from them B at a nearby time costs no trigonometric call
  /// (angle addition, [W10]). A magnetorquer keeps the phase of its hold's start.
  struct Phase {
    Scalar t = Scalar(0);          ///< t₀
    Scalar cos_theta = Scalar(1);  ///< cos θ(t₀)
    Scalar sin_theta = Scalar(0);  ///< sin θ(t₀)
    Scalar cos_u = Scalar(1);      ///< cos u(t₀)
    Scalar sin_u = Scalar(0);      ///< sin u(t₀)
    bool valid = false;            ///< set by phase()
  };
  /// The phase at t.
  Phase phase(Scalar t) const {
    using std::cos, std::sin;
    const Scalar th = theta0_ + Scalar(earth_rate) * t, u = orbit_.latitude(t);
    return {t, cos(th), sin(th), cos(u), sin(u), true};
  }

  /// B at time t in inertial axes (tesla) [W10].
  Vector3 inertial(Scalar t) const { return inertial_of(phase(t)); }

  /// B at time t from the phase p of a nearby time: cos(a + δ) = cos a cos δ − sin a sin δ with
  /// δ = rate·(t − p.t) and cos δ, sin δ by detail::sin_cos's series (lie/series.hpp, below
  /// small_angle = ¼, truncation below 1e-19). Farther from p.t (or without a phase) the
  /// angles are evaluated afresh.
  Vector3 inertial(Scalar t, const Phase& p) const {
    using std::abs;
    const Scalar dt = t - p.t;
    const Scalar du = orbit_.rate() * dt, dth = Scalar(earth_rate) * dt;
    const Scalar series = detail::small_angle<Scalar>::theta;
    if (!p.valid || !(abs(du) < series) || !(abs(dth) < series)) return inertial(t);
    Scalar cu, su, cth, sth;
    detail::sin_cos(du, su, cu);
    detail::sin_cos(dth, sth, cth);
    return inertial_of({t, p.cos_theta * cth - p.sin_theta * sth, p.sin_theta * cth + p.cos_theta * sth,
                        p.cos_u * cu - p.sin_u * su, p.sin_u * cu + p.cos_u * su, true});
  }

 private:
  /// B from the angles' cosines and sines [W10].
  Vector3 inertial_of(const Phase& p) const {
    // The dipole axis, Earth-fixed → inertial: a rotation by θ about z.
    const Vector3 m(p.cos_theta * m0_.x() - p.sin_theta * m0_.y(), p.sin_theta * m0_.x() + p.cos_theta * m0_.y(), m0_.z());
    const Vector3 r = orbit_.radial_of(p.cos_u, p.sin_u);
    return Scalar(3) * m.dot(r) * r - m;  // m₀ carries the factor (R_E/r)³
  }
  CircularOrbit<Scalar> orbit_;
  Vector3 m0_;  ///< (g11, h11, g10)(R_E/r)³ in tesla
  Scalar theta0_;
};

/// Magnetorquers: a dipole m (A m², body axes) held over each sample interval; τ = m × ΛᵀB(t).
template <class Scalar_>
class Magnetorquer {
 public:
  /// The scalar type.
  using Scalar = Scalar_;
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// A 3×3 matrix of Scalar.
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  /// An applied torque, taken at the step's mid configuration and mid time (effect.hpp).
  using kind = torque_kind;

  /// The field; the dipole starts at 0.
  explicit Magnetorquer(DipoleField<Scalar> field, Vector3 max_dipole = Vector3::Constant(
                                                       std::numeric_limits<Scalar>::infinity()))
      : field_(field), max_dipole_(max_dipole) {
    if (!(max_dipole_.minCoeff() > Scalar(0))) detail::fail("magnetorquer: max_dipole must be > 0 per axis");
  }

  /// The held dipole (A m², body axes): set between steps, by the sampled driver (hold()).
  Vector3 dipole = Vector3::Zero();

  /// Holds the dipole m from the sample time t on, and keeps the field's phase at t: the steps
  /// of the hold evaluate B by angle addition from it instead of four trigonometric calls (the
  /// same B to round-off; setting `dipole` alone is as correct, B is then evaluated afresh).
  void hold(Scalar t, const Vector3& m) {
    dipole = m;
    phase_ = field_.phase(t);
  }

  /// The field.
  const DipoleField<Scalar>& field() const { return field_; }
  /// The per-axis dipole limits (A m²).
  const Vector3& max_dipole() const { return max_dipole_; }
  /// The command clipped per axis to ±max_dipole.
  Vector3 saturate(const Vector3& m) const { return m.cwiseMax(-max_dipole_).cwiseMin(max_dipole_); }

  /// b = Λ_nᵀ B(t_{n+½}).
  struct Cache {
    Vector3 b;  ///< the field in frame n (tesla)
  };
  /// The field at the mid time, in frame n.
  Cache cache(const Matrix3& Lambda_n, Scalar t_mid) const {
    return {Lambda_n.transpose() * field_.inertial(t_mid, phase_)};
  }

  /// (R m) × b.
  Vector3 torque(const Cache& c, const Matrix3& R_mid, const Vector3& /*omega_mid*/) const {
    return (R_mid * dipole).cross(c.b);
  }
  /// b̂ R m̂.
  Matrix3 torque_jacobian_rotation(const Cache& c, const Matrix3& R_mid, const Vector3&) const {
    return SO3<Scalar>::hat(c.b) * R_mid * SO3<Scalar>::hat(dipole);
  }
  /// Zero: the torque does not depend on Ω.
  Matrix3 torque_jacobian_omega(const Cache&, const Matrix3&, const Vector3&) const { return Matrix3::Zero(); }

 private:
  DipoleField<Scalar> field_;
  Vector3 max_dipole_;
  typename DipoleField<Scalar>::Phase phase_{};  ///< the field's phase at the hold's start
};

}  // namespace trompo
