#pragma once
// The baseline a user would otherwise write: Boost.Odeint on the quaternion ODE
//   q̇ = ½ q ⊗ (0, Ω),   J Ω̇ = JΩ × Ω + τ(Λ(q), Ω, t)
// as a plain 7-vector (q w, x, y, z, Ω), with odeint's runge_kutta4 (fixed h) or
// runge_kutta_dopri5 in a controlled stepper (abs = rel tolerance). Nothing is
// renormalised during the run (the exact flow keeps |q| = 1, the integrators only
// approximately); the attitude is read as q/|q|, as a user would. The right-hand side
// normalises q before forming Λ, so the ODE is well defined off the unit sphere.
//
// Compiled only when Boost (1.74, header-only) was found: TROMPO_HAVE_BOOST.
#ifdef TROMPO_HAVE_BOOST
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <boost/numeric/odeint.hpp>
#include <cstddef>

#include "trompo/lie/so3.hpp"
#include "trompo/model/state.hpp"

namespace trompo::bench {

using OdeState = std::array<double, 7>;

inline OdeState to_ode(const State<double>& s) {
  const Eigen::Quaterniond& q = s.rotation.unit_quaternion();
  return {q.w(), q.x(), q.y(), q.z(), s.omega.x(), s.omega.y(), s.omega.z()};
}

/// The state a user would read back: Λ from q/|q|.
inline State<double> from_ode(const OdeState& x, double t) {
  State<double> s;
  s.rotation = SO3<double>::renormalized(Eigen::Quaterniond(x[0], x[1], x[2], x[3]));
  s.omega = Eigen::Vector3d(x[4], x[5], x[6]);
  s.time = t;
  return s;
}

/// The right-hand side; counts its evaluations (the cost unit of explicit methods).
template <class Scene>
struct QuaternionOde {
  const Scene* scene;
  mutable long evaluations = 0;

  void operator()(const OdeState& x, OdeState& dx, double t) const {
    ++evaluations;
    const Eigen::Quaterniond q(x[0], x[1], x[2], x[3]);
    const Eigen::Vector3d w(x[4], x[5], x[6]);
    // q̇ = ½ q ⊗ (0, Ω)
    const Eigen::Quaterniond qd = q * Eigen::Quaterniond(0.0, w.x(), w.y(), w.z());
    dx[0] = 0.5 * qd.w();
    dx[1] = 0.5 * qd.x();
    dx[2] = 0.5 * qd.y();
    dx[3] = 0.5 * qd.z();
    // J Ω̇ = JΩ × Ω + τ; with wheels Π = J_hubΩ + h_w(t) and the motors' reaction −ḣ_w [W1]
    Eigen::Vector3d rhs;
    if constexpr (Scene::has_wheels)
      rhs = scene->momentum(w, t).cross(w) - scene->wheel_momentum_rate();
    else
      rhs = scene->momentum(w).cross(w);
    if constexpr (Scene::has_potential || Scene::has_applied_torque)
      rhs += scene->body_torque(q.normalized().toRotationMatrix(), w, t);
    const Eigen::Vector3d wd = scene->body().inertia_inverse() * rhs;
    dx[4] = wd.x();
    dx[5] = wd.y();
    dx[6] = wd.z();
  }
};

/// n steps of odeint's classical runge_kutta4 from t0 with step h.
template <class Scene, class Observer>
void odeint_rk4(const QuaternionOde<Scene>& ode, OdeState& x, double t0, double h, long n, Observer&& observe) {
  namespace odeint = boost::numeric::odeint;
  odeint::runge_kutta4<OdeState> stepper;
  double t = t0;
  for (long i = 0; i < n; ++i) {
    stepper.do_step(std::cref(ode), x, t, h);
    t = t0 + double(i + 1) * h;  // no accumulated sum of h
    observe(x, t);
  }
}

/// Dormand–Prince 5(4) with odeint's standard error controller (abs = rel = tol), from
/// t0 to t1 (the last step is shortened to land on t1). Returns the number of accepted
/// steps.
template <class Scene, class Observer>
long odeint_dopri5(const QuaternionOde<Scene>& ode, OdeState& x, double t0, double t1, double tol,
                   Observer&& observe, double first_fraction = 1e-3) {
  namespace odeint = boost::numeric::odeint;
  auto stepper = odeint::make_controlled(tol, tol, odeint::runge_kutta_dopri5<OdeState>());
  long steps = 0;
  // A first guess of dt (a fraction of the span); the controller corrects it on the first step.
  const double dt0 = first_fraction * (t1 - t0);
  odeint::integrate_adaptive(stepper, std::cref(ode), x, t0, t1, dt0, [&](const OdeState& y, double t) {
    if (t > t0) {
      ++steps;
      observe(y, t);
    }
  });
  return steps;
}

}  // namespace trompo::bench
#endif  // TROMPO_HAVE_BOOST
