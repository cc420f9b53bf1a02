#pragma once
// The adaptive driver's step-size controllers (docs/adaptive.md; docs/theory.md §16, [A3], [A5]).
//
// A controller proposes the next step h and learns from each step the driver takes; the
// driver clips h to t_end and caps it (max_step, the rotation cap) before it steps, and
// the controller sees the step actually taken. Each controller is a small type satisfying
// the concept StepController:
//  - ToleranceController [A3]: Söderlind's H211b filter on the error per unit step r (from
//    an error estimate, drivers/adaptive/error_estimate.hpp),
//      h_{n+1} = h_n (1/r_n)^{1/4p} (1/r_{n−1})^{1/4p} (h_n/h_{n−1})^{−1/4};
//    a rejected step retries with the elementary controller h·(1/r)^{1/p}, a failed step
//    (Newton) with h/4 and the next growth capped at 1.5×;
//  - ReversibleController [A5] (Hairer & Söderlind 2005): no estimate, no rejection;
//    h = ε/ρ with the step density ρ updated explicitly and symmetrically from the
//    control function Q(y) = √(|Ω|² + ω₀²), G = d/dt log Q = Ω·Ω̇/Q²:
//      ρ_{1/2} = Q(y₀) + ½εG(y₀),  ρ_{n+3/2} = ρ_{n+1/2} + εG(y_{n+1})   (backward: −G).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <concepts>

#include "trompo/drivers/adaptive/error_estimate.hpp"
#include "trompo/drivers/dense_output.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// How the adaptive driver picks h.
enum class StepControl {
  tolerance,  ///< an error estimate per step, H211b on the error per unit step [A2], [A3]
  reversible  ///< Hairer–Söderlind step density, explicit and time-reversible [A5]
};

/// A step-size controller of the adaptive driver: proposal() is the next step h (signed,
/// before the driver clips it to t_end and caps it); accept(h, x, last) follows an accepted
/// step of h, x its measure (r² of the error per unit step for tolerance control, G at the
/// step's end for reversible control), `last` when the step was shortened to land on t_end.
/// A controller that refuses steps (`rejects`) also takes reject(h, r²) after a failed
/// error test and fail(h) after a step that failed (Newton, …).
template <class C>
concept StepController = requires(const C& c, C& m, typename C::Scalar h, typename C::Scalar x, bool last) {
  typename C::Scalar;
  { C::rejects } -> std::convertible_to<bool>;
  { c.proposal() } -> std::same_as<typename C::Scalar>;
  m.accept(h, x, last);
} && (!C::rejects || requires(C& m, typename C::Scalar h, typename C::Scalar r2) {
  m.reject(h, r2);
  m.fail(h);
});

/// Tolerance control [A3]: H211b on r (the error per unit step [A2]) after an accepted
/// step, the elementary controller after a rejected one, h/4 after a failed one.
template <class ScalarType>
struct ToleranceController {
  /// The scalar.
  using Scalar = ScalarType;
  /// It refuses steps whose error test fails.
  static constexpr bool rejects = true;
  Scalar h;                 ///< the next step (signed); the driver caps it in place
  int order;                ///< the scheme's order p
  Scalar safety;            ///< safety factor
  Scalar min_factor;        ///< smallest h_{n+1}/h_n
  Scalar max_factor;        ///< largest h_{n+1}/h_n
  Scalar r2_prev = Scalar(1);  ///< r²_{n−1}, floored at 1e-20
  Scalar h_prev;               ///< h_{n−1}
  bool have_prev = false;      ///< whether a step was accepted before
  Scalar growth_cap;           ///< largest factor of the next accepted step
  /// Starts from the first step h0 for a scheme of order p.
  ToleranceController(Scalar h0, int p, Scalar safety_factor, Scalar min_f, Scalar max_f)
      : h(h0), order(p), safety(safety_factor), min_factor(min_f), max_factor(max_f), h_prev(h0), growth_cap(max_f) {}
  /// The next step.
  Scalar proposal() const { return h; }
  /// After an accepted step of h_taken with error r² (the next h from H211b; after a last
  /// step shortened to land on t_end, the controller's own h grown, for a continuation).
  void accept(Scalar h_taken, Scalar r2, bool last) {
    using std::pow;
    // H211b (Söderlind 2003): h_{n+1} = h_n (1/r_n)^{1/4p} (1/r_{n−1})^{1/4p} (h_n/h_{n−1})^{−1/4}
    // = h_n (r_n² r_{n−1}² ρ^{2p})^{−1/8p}, ρ = h_n/h_{n−1}: one pow, ρ^{2p} by squarings.
    const int p = order;
    const Scalar rr2 = std::max(r2, Scalar(1e-20));
    Scalar f;
    if (have_prev)
      f = safety * pow(rr2 * r2_prev * detail::integer_power(h_taken / h_prev, 2 * p), -Scalar(1) / Scalar(8 * p));
    else
      f = safety * pow(rr2, -Scalar(1) / Scalar(2 * p));
    f = std::clamp(f, min_factor, std::min(max_factor, growth_cap));
    growth_cap = max_factor;
    r2_prev = rr2;
    h_prev = h_taken;
    have_prev = true;
    h = (last ? h : h_taken) * f;
  }
  /// After a rejected step of h_taken with error r² > 1: the elementary controller, h
  /// shrinks: (1/r)^{1/p}, at most 0.9×, and no growth on the next acceptance.
  void reject(Scalar h_taken, Scalar r2) {
    using std::pow;
    const int p = order;
    const Scalar f = std::isfinite(static_cast<double>(r2))
                         ? std::max(min_factor, safety * pow(r2, -Scalar(1) / Scalar(2 * p)))
                         : min_factor;
    h = h_taken * std::min(f, Scalar(0.9));
    growth_cap = Scalar(1);
  }
  /// After a step of h_taken that failed (Newton, …): a quarter of it, then growth ≤ 1.5×.
  void fail(Scalar h_taken) {
    h = h_taken / Scalar(4);
    growth_cap = Scalar(1.5);
  }

  /// The first step |h| for a scheme of order p from y0 (Hairer–Nørsett–Wanner II.4, in the
  /// norm of [A2]): with s_Λ = atol + rtol, s_Ω = atol + rtol·|Ω₀|, d₀ = rms(1/s_Λ, |Ω₀|/s_Ω),
  /// d₁ = rms(|Ω₀|/s_Λ, |Ω̇₀|/s_Ω), h₀ = 0.01·d₀/d₁ (1e-6 when either is below 1e-5, then
  /// `cap`ped); one explicit Euler step of h₀ (along `dir`) gives d₂, the rate's change per
  /// unit time; h₁ = (0.01/max(d₁, d₂))^{1/(p+1)}; the step is min(100·h₀, h₁).
  template <class Scene, class Cap>
  static Scalar first_step(const Scene& scene, const State<Scalar>& y0, Scalar atol, Scalar rtol, int p, Scalar dir,
                           Cap&& cap) {
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    using std::pow;
    using std::sqrt;
    const Vector3 w0 = y0.omega, wd0 = omega_rate(scene, y0);
    const Scalar s_rot = atol + rtol, s_om = atol + rtol * w0.norm();
    const auto rms = [](Scalar a, Scalar b) { return sqrt((a * a + b * b) / 2); };
    const Scalar d0 = rms(Scalar(1) / s_rot, w0.norm() / s_om);
    const Scalar d1 = rms(w0.norm() / s_rot, wd0.norm() / s_om);
    Scalar h0 = (d0 < Scalar(1e-5) || d1 < Scalar(1e-5)) ? Scalar(1e-6) : Scalar(0.01) * d0 / d1;
    h0 = cap(h0);
    State<Scalar> y1 = y0;  // explicit Euler
    y1.rotation = y0.rotation * SO3<Scalar>::exp(dir * h0 * w0);
    y1.omega = w0 + dir * h0 * wd0;
    y1.time = y0.time + dir * h0;
    const Vector3 wd1 = omega_rate(scene, y1);
    const Scalar d2 = rms((y1.omega - w0).norm() / s_rot, (wd1 - wd0).norm() / s_om) / h0;
    const Scalar dm = std::max(d1, d2);
    const Scalar h1 = dm <= Scalar(1e-15) ? std::max(Scalar(1e-6), h0 * Scalar(1e-3))
                                          : pow(Scalar(0.01) / dm, Scalar(1) / Scalar(p + 1));
    return std::min(Scalar(100) * h0, h1);
  }
};

/// Reversible control [A5]: h = ε/ρ, the step density ρ updated explicitly and
/// symmetrically with G = d/dt log Q, Q = √(|Ω|² + ω₀²); it refuses no step.
template <class ScalarType>
struct ReversibleController {
  /// The scalar.
  using Scalar = ScalarType;
  /// It refuses no step.
  static constexpr bool rejects = false;
  Scalar epsilon;    ///< ε, the rotation per step
  Scalar dir;        ///< +1 forward, −1 backward
  Scalar rho;        ///< ρ_{n+1/2}
  Scalar rho_floor;  ///< 1e-3·Q(y₀): ρ below it is taken as it
  /// Starts from Q(y₀) and G(y₀): ρ_{1/2} = Q + ½εG (backward: −G).
  ReversibleController(Scalar eps, Scalar direction, Scalar Q, Scalar G)
      : epsilon(eps), dir(direction), rho(Q + direction * eps * G / Scalar(2)), rho_floor(Scalar(1e-3) * Q) {}
  /// The next step ε/ρ (signed).
  Scalar proposal() const { return dir * epsilon / std::max(rho, rho_floor); }
  /// After a step, G at its end: ρ += εG (backward: −G).
  void accept(Scalar, Scalar G, bool) { rho += dir * epsilon * G; }

  /// The floor ω₀ of Q: `given` if > 0, else max(1e-3|Ω₀|, √|Ω̇₀|, 1e-8).
  template <class Scene>
  static Scalar omega_floor(const Scene& scene, const State<Scalar>& s, Scalar given) {
    using std::sqrt;
    if (given > 0) return given;
    const Eigen::Matrix<Scalar, 3, 1> wd = omega_rate(scene, s);
    return std::max({Scalar(1e-3) * s.omega.norm(), sqrt(wd.norm()), Scalar(1e-8)});
  }
  /// Q = √(|Ω|² + ω₀²) and G = d/dt log Q = Ω·Ω̇/Q² at s.
  template <class Scene>
  static void control(const Scene& scene, const State<Scalar>& s, Scalar w0, Scalar& Q, Scalar& G) {
    using std::sqrt;
    const Scalar q2 = s.omega.squaredNorm() + w0 * w0;
    Q = sqrt(q2);
    G = s.omega.dot(omega_rate(scene, s)) / q2;
  }
};

static_assert(StepController<ToleranceController<double>> && StepController<ReversibleController<double>>);

}  // namespace trompo
