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
//
// Inside a hold [W16]. hold(t, m) keeps the field's Taylor expansion about t (DipoleField::
// expansion): the kicks and stages of the hold read B from a polynomial of low degree, with
// the first term left out below 2⁻⁵⁶|B|, instead of four trigonometric calls each.
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "trompo/errors.hpp"
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
  /// by their cosines and sines: the four trigonometric values from which the expansion about
  /// t₀ is formed (a magnetorquer keeps it for its hold, [W16]).
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

  /// The highest degree of the field's Taylor polynomial about a hold's start [W16].
  static constexpr int max_degree = 8;
  /// x_D for D = 1 … max_degree: the polynomial of degree D serves while ω_max|t − t₀| ≤ x_D,
  /// where the first term it leaves out, 2|m₀|x^{D+1}/(D+1)!, is below 2⁻⁵⁶|m₀| ≤ 2⁻⁵⁶|B|
  /// ([W16]: x_D = ((D+1)!·2⁻⁵⁷)^{1/(D+1)}, rounded down).
  static constexpr std::array<double, max_degree + 1> degree_reach{
      0.0, 3.72e-9, 3.46e-6, 1.13e-4, 9.64e-4, 4.13e-3, 1.19e-2, 2.69e-2, 5.14e-2};

  /// B about a time t₀ as its Taylor polynomial B(t₀ + s) = Σ_{j ≤ D} B_j s^j [W16], the
  /// coefficients exact from the phase at t₀; beyond its reach B is evaluated afresh.
  struct Expansion {
    Phase phase;                                  ///< the angles at t₀
    int degree = 0;                               ///< D
    Scalar reach = Scalar(0);                     ///< x_D/ω_max: the largest |s| it serves (< 0: none)
    std::array<Vector3, max_degree + 1> B{};      ///< B_j, inertial axes (tesla/s^j)
  };

  /// The expansion about t that serves |s| ≤ span, of the lowest degree that does (at most
  /// max_degree; span = 0: max_degree) [W16]. With a = u(t) or θ(t) and ω = n or ω_E, the j-th
  /// Taylor coefficient of cos(a + ωs) is ω^j/j! cos(a + jπ/2) (and of sin alike), so r̂(t + s)
  /// and the dipole axis m(t + s) come as series from the four trigonometric values of
  /// phase(t); d = m·r̂ and B = 3 d r̂ − m are their Cauchy products truncated at degree D.
  Expansion expansion(Scalar t, Scalar span = Scalar(0)) const {
    using std::abs;
    // ω_max = 2n + ω_E, the highest frequency of B (r̂ r̂ doubles n; m turns at ω_E).
    const Scalar w_max = Scalar(2) * orbit_.rate() + Scalar(earth_rate);
    Expansion e;
    e.phase = phase(t);
    e.degree = max_degree;
    if (span != Scalar(0))
      while (e.degree > 1 && abs(span) * w_max <= Scalar(degree_reach[e.degree - 1])) --e.degree;
    e.reach = Scalar(degree_reach[e.degree]) / w_max;
    const int D = e.degree;
    const Phase& p = e.phase;
    std::array<Vector3, max_degree + 1> m, r;
    Scalar fn(1), fw(1);  // n^j/j!, ω_E^j/j!
    for (int j = 0; j <= D; ++j) {
      const auto [cu, su] = quarter_turns(p.cos_u, p.sin_u, j);          // cos, sin of u + jπ/2
      const auto [ct, st] = quarter_turns(p.cos_theta, p.sin_theta, j);  // of θ + jπ/2
      r[j] = fn * orbit_.radial_of(cu, su);
      m[j] = fw * dipole_axis(ct, st);
      if (j > 0) m[j].z() = Scalar(0);  // the axis's z, fixed in the Earth, is constant
      fn *= orbit_.rate() * Scalar(inverse_of[j + 1]);
      fw *= Scalar(earth_rate) * Scalar(inverse_of[j + 1]);
    }
    std::array<Scalar, max_degree + 1> d3;  // 3 d_k
    for (int k = 0; k <= D; ++k) {
      Scalar d(0);  // d_k = Σ_{i ≤ k} m_i·r_{k−i}
      for (int i = 0; i <= k; ++i) d += m[i].dot(r[k - i]);
      d3[k] = Scalar(3) * d;
    }
    for (int k = 0; k <= D; ++k) {
      Vector3 b = Vector3::Zero();  // (3 d r̂)_k
      for (int i = 0; i <= k; ++i) b += d3[i] * r[k - i];
      e.B[k] = b - m[k];
    }
    // An orbit so fast that n^j/j! overflows: no polynomial (every B afresh, as without one).
    for (int k = 0; k <= D; ++k)
      if (!detail::all_finite(e.B[k])) e.reach = Scalar(-1);
    return e;
  }

  /// B at time t from the expansion e: Horner's rule within its reach, else afresh.
  Vector3 inertial(Scalar t, const Expansion& e) const {
    using std::abs;
    const Scalar s = t - e.phase.t;
    if (!e.phase.valid || !(abs(s) <= e.reach)) return inertial(t);
    Vector3 b = e.B[e.degree];
    for (int j = e.degree - 1; j >= 0; --j) b = b * s + e.B[j];
    return b;
  }

 private:
  /// 1/j for j = 1 … max_degree + 1 (entry 0 unused).
  static constexpr std::array<long double, max_degree + 2> inverse_of{
      0.0L, 1.0L, 1.0L / 2, 1.0L / 3, 1.0L / 4, 1.0L / 5, 1.0L / 6, 1.0L / 7, 1.0L / 8, 1.0L / 9};
  /// cos(a + jπ/2), sin(a + jπ/2) from cos a, sin a.
  static std::pair<Scalar, Scalar> quarter_turns(Scalar c, Scalar s, int j) {
    switch (j % 4) {
      case 0: return {c, s};
      case 1: return {-s, c};
      case 2: return {-c, -s};
      default: return {s, -c};
    }
  }
  /// The dipole axis at the Greenwich angle θ, from cos θ and sin θ: Earth-fixed → inertial, a
  /// rotation by θ about z.
  Vector3 dipole_axis(Scalar cos_theta, Scalar sin_theta) const {
    return Vector3(cos_theta * m0_.x() - sin_theta * m0_.y(), sin_theta * m0_.x() + cos_theta * m0_.y(), m0_.z());
  }
  /// B from the angles' cosines and sines [W10].
  Vector3 inertial_of(const Phase& p) const {
    const Vector3 m = dipole_axis(p.cos_theta, p.sin_theta);
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

  /// Holds the dipole m from the sample time t on, and keeps the field's expansion about t
  /// [W16]: the steps of the hold evaluate B from its polynomial instead of four trigonometric
  /// calls (the same B to round-off; setting `dipole` alone is as correct, B is then
  /// evaluated afresh).
  void hold(Scalar t, const Vector3& m) { hold(m, field_.expansion(t)); }
  /// The same with the expansion about the sample time already at hand (the sampled driver
  /// forms it once for the sample's field and the hold).
  void hold(const Vector3& m, const typename DipoleField<Scalar>::Expansion& e) {
    dipole = m;
    expansion_ = e;
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
    return {Lambda_n.transpose() * field_.inertial(t_mid, expansion_)};
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
  typename DipoleField<Scalar>::Expansion expansion_{};  ///< the field about the hold's start
};

}  // namespace trompo
