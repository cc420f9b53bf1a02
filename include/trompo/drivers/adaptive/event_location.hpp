#pragma once
// Events of an adaptive run: what they are and where they occur (docs/adaptive.md; docs/theory.md
// §16, [A6]).
//
// An Event is g(t, Λ, Ω) with SciPy's `direction` and `terminal`; events:: builds the ones
// the CLI names. detail::EventLocator finds them on one accepted step: g is sampled at the
// step's ends and at three interior points of its dense interpolant (drivers/dense_output.hpp);
// a sign change (filtered by `direction`, taken in time) is located by Brent's method
// (detail::brent_root) on the interpolant to a few ulp in t, and the occurrences are sorted
// in the order of the run. What a terminal occurrence does (a real step to the event time)
// is the driver's (drivers/adaptive.hpp). The locator's scratch is reserved before the loop:
// locating allocates nothing.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <tuple>
#include <vector>

#include "trompo/drivers/dense_output.hpp"
#include "trompo/errors.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// An event function g(t, Λ, Ω) with SciPy's `direction` (+1: g rising through 0, −1:
/// falling, 0: both) and `terminal` (0: never; n ≥ 1: the n-th occurrence ends the run).
/// Rising and falling are with increasing t, also in a backward run (SciPy's follow the
/// order of integration): a tilt maximum is a maximum either way.
template <class Scalar>
struct Event {
  /// A 3-vector of Scalar.
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  /// The event's name (built-ins: nutation-max, nutation-min, axis-crossing, flip).
  std::string name;
  /// The event function g(t, Λ, Ω); an event is a zero of it.
  std::function<Scalar(Scalar, const SO3<Scalar>&, const Vector3&)> g;
  /// +1 rising, −1 falling, 0 both (with increasing t).
  int direction = 0;
  /// 0: never ends the run; n ≥ 1: the n-th occurrence ends it.
  int terminal = 0;
};

/// The built-in events [A6].
namespace events {
/// g = d/dt(γ·ΛE) = γ·Λ(Ω × E): the rate of the cosine of the tilt between the body point E
/// and the vertical γ. Its zeros rising (direction +1) are the tilt's maxima ("nutation-max",
/// γ·ΛE smallest), falling (−1) its minima ("nutation-min").
template <class Scalar>
Event<Scalar> nutation(const Eigen::Matrix<Scalar, 3, 1>& E, const Eigen::Matrix<Scalar, 3, 1>& up, bool maximum,
                       int terminal = 0) {
  Event<Scalar> e;
  e.name = maximum ? "nutation-max" : "nutation-min";
  e.g = [E, up](Scalar, const SO3<Scalar>& L, const Eigen::Matrix<Scalar, 3, 1>& W) { return up.dot(L * W.cross(E)); };
  e.direction = maximum ? 1 : -1;
  e.terminal = terminal;
  return e;
}
/// nutation() for a scene with gravity (E and γ of its gravity effect).
template <class Scene>
Event<typename Scene::Scalar> nutation(const Scene& scene, bool maximum, int terminal = 0) {
  using Scalar = typename Scene::Scalar;
  Eigen::Matrix<Scalar, 3, 1> E = Eigen::Matrix<Scalar, 3, 1>::Zero();
  bool found = false;
  std::apply([&](const auto&... eff) {
    ((found = found || [&](const auto& x) {
       if constexpr (requires { x.com_direction(); }) {
         E = x.com_direction();
         return true;
       } else {
         return false;
       }
     }(eff)),
     ...);
  }, scene.effects());
  if (!found) detail::fail("event nutation: the scene has no gravity (no body point E to follow)");
  return nutation<Scalar>(E, scene.momentum_axis(), maximum, terminal);
}
/// g = n·ΛA: the body axis A crossing the spatial plane of normal n ("axis-crossing").
template <class Scalar>
Event<Scalar> axis_crossing(const Eigen::Matrix<Scalar, 3, 1>& body_axis, const Eigen::Matrix<Scalar, 3, 1>& normal,
                            int direction = 0, int terminal = 0) {
  if (!detail::all_finite(body_axis) || !(body_axis.norm() > 0))
    detail::fail("event axis-crossing: body axis must be finite and non-zero, got ", detail::to_text(body_axis));
  if (!detail::all_finite(normal) || !(normal.norm() > 0))
    detail::fail("event axis-crossing: plane normal must be finite and non-zero, got ", detail::to_text(normal));
  Event<Scalar> e;
  e.name = "axis-crossing";
  const Eigen::Matrix<Scalar, 3, 1> A = body_axis.normalized(), n = normal.normalized();
  e.g = [A, n](Scalar, const SO3<Scalar>& L, const Eigen::Matrix<Scalar, 3, 1>&) { return n.dot(L * A); };
  e.direction = direction;
  e.terminal = terminal;
  return e;
}
/// g = u·JΩ, u the intermediate principal axis of J: a sign change is a flip of the body
/// about that axis ("flip", the Dzhanibekov effect). Throws invalid_input, naming the
/// principal moments, for a body with two of them equal (to 1e-12 of the largest): a
/// symmetric body has no intermediate axis, and the event would silently find nothing.
template <class Scene>
Event<typename Scene::Scalar> flip(const Scene& scene, int terminal = 0) {
  using Scalar = typename Scene::Scalar;
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
  Eigen::SelfAdjointEigenSolver<Matrix3> eig(scene.body().inertia());
  const auto& m = eig.eigenvalues();  // ascending
  if (!(m(1) - m(0) > Scalar(1e-12) * m(2) && m(2) - m(1) > Scalar(1e-12) * m(2)))
    detail::fail("event flip: the body's principal moments ", m(0), ", ", m(1), ", ", m(2),
                 " have two equal (a symmetric body): it has no intermediate axis to flip about");
  const Eigen::Matrix<Scalar, 3, 1> u = eig.eigenvectors().col(1);  // ascending: the middle one
  const Matrix3 J = scene.body().inertia();
  Event<Scalar> e;
  e.name = "flip";
  e.g = [u, J](Scalar, const SO3<Scalar>&, const Eigen::Matrix<Scalar, 3, 1>& W) { return u.dot(J * W); };
  e.direction = 0;
  e.terminal = terminal;
  return e;
}
/// A built-in event by its CLI name: nutation-max, nutation-min, flip, axis-crossing
/// (body axis e3 crossing the horizontal plane of the momentum axis). Throws invalid_input
/// for an unknown name or one the scene cannot have.
template <class Scene>
Event<typename Scene::Scalar> by_name(const Scene& scene, const std::string& name, int terminal = 0) {
  using V = Eigen::Matrix<typename Scene::Scalar, 3, 1>;
  if (name == "nutation-max") return nutation(scene, true, terminal);
  if (name == "nutation-min") return nutation(scene, false, terminal);
  if (name == "flip") return flip(scene, terminal);
  if (name == "axis-crossing") return axis_crossing<typename Scene::Scalar>(V::UnitZ(), scene.momentum_axis(), 0, terminal);
  detail::fail("event: unknown name '", name, "' (nutation-max, nutation-min, axis-crossing, flip)");
}
}  // namespace events

namespace detail {

/// Brent's root of f on [a, b] with f(a)·f(b) ≤ 0 (Brent 1973, "zeroin"), to |b − a| ≤
/// 2·tol: the root bracket shrinks to a few ulp of t when tol = 2ε|t|.
template <class Scalar, class F>
Scalar brent_root(F&& f, Scalar a, Scalar b, Scalar fa, Scalar fb) {
  using std::abs;
  const Scalar eps = std::numeric_limits<Scalar>::epsilon();
  if (fa == Scalar(0)) return a;
  if (fb == Scalar(0)) return b;
  Scalar c = a, fc = fa, d = b - a, e = d;
  for (int iter = 0; iter < 200; ++iter) {
    if ((fb > 0) == (fc > 0)) {
      c = a;
      fc = fa;
      d = e = b - a;
    }
    if (abs(fc) < abs(fb)) {
      a = b;
      b = c;
      c = a;
      fa = fb;
      fb = fc;
      fc = fa;
    }
    const Scalar tol = Scalar(2) * eps * abs(b) + std::numeric_limits<Scalar>::denorm_min();
    const Scalar m = (c - b) / 2;
    if (abs(m) <= tol || fb == Scalar(0)) return b;
    if (abs(e) >= tol && abs(fa) > abs(fb)) {
      Scalar p, q, r;
      const Scalar s = fb / fa;
      if (a == c) {
        p = 2 * m * s;
        q = 1 - s;
      } else {
        q = fa / fc;
        r = fb / fc;
        p = s * (2 * m * q * (q - r) - (b - a) * (r - 1));
        q = (q - 1) * (r - 1) * (s - 1);
      }
      if (p > 0) q = -q;
      else p = -p;
      if (2 * p < std::min(3 * m * q - abs(tol * q), abs(e * q))) {
        e = d;
        d = p / q;
      } else {
        d = m;
        e = m;
      }
    } else {
      d = m;
      e = m;
    }
    a = b;
    fa = fb;
    b += abs(d) > tol ? d : (m > 0 ? tol : -tol);
    fb = f(b);
  }
  return b;
}

/// One event occurrence inside a step.
template <class Scalar>
struct Occurrence {
  Scalar t;
  int index;
};

/// The events of a run, located step by step [A6]: g at the last node per event, the
/// occurrences left before each terminal one, and the occurrences of the current step.
template <class Scalar>
struct EventLocator {
  const std::vector<Event<Scalar>>* list = nullptr;
  // scratch, reserved by start()
  std::vector<Scalar> g_prev{};
  std::vector<int> remaining{};
  std::vector<Occurrence<Scalar>> found{};

  /// Whether there are events to locate.
  bool any() const { return list && !list->empty(); }

  /// Checks the events (throws invalid_input), reserves the scratch and samples g at the
  /// first state.
  void start(const std::vector<Event<Scalar>>* event_list, const State<Scalar>& s) {
    list = event_list;
    if (!list) return;
    const std::size_t n = list->size();
    g_prev.resize(n);
    remaining.resize(n);
    found.reserve(4 * n + 4);
    for (std::size_t k = 0; k < n; ++k) {
      const Event<Scalar>& e = (*list)[k];
      if (!e.g) detail::fail("event '", e.name, "': no function");
      if (e.direction < -1 || e.direction > 1) detail::fail("event '", e.name, "': direction must be -1, 0 or 1, got ", e.direction);
      if (e.terminal < 0) detail::fail("event '", e.name, "': terminal must be >= 0, got ", e.terminal);
      g_prev[k] = e.g(s.time, s.rotation, s.omega);
      remaining[k] = e.terminal;
    }
  }

  /// Whether g going from ga to gb crosses zero in the direction dir (0: either).
  static bool crosses(Scalar ga, Scalar gb, int dir) {
    const bool up = ga < 0 && gb >= 0, down = ga > 0 && gb <= 0;
    return dir > 0 ? up : dir < 0 ? down : (up || down);
  }

  /// The events of the step ta → tb on its interpolant `seg`, in the order of time
  /// (`found`), sorted along `dir` (+1 or −1, the run's direction).
  void locate(const LieHermite<Scalar>& seg, Scalar ta, Scalar tb, Scalar dir) {
    found.clear();
    constexpr int samples = 4;  // sub-intervals: ends plus three interior points
    for (std::size_t k = 0; k < list->size(); ++k) {
      const Event<Scalar>& e = (*list)[k];
      const auto g_at = [&](Scalar t) {
        const State<Scalar> s = seg.state(t);
        return e.g(t, s.rotation, s.omega);
      };
      Scalar t_lo = ta, g_lo = g_prev[k];
      for (int i = 1; i <= samples; ++i) {
        const Scalar t_hi = i == samples ? tb : ta + (tb - ta) * Scalar(i) / Scalar(samples);
        const Scalar g_hi = g_at(t_hi);
        // direction is the sign of dg/dt, in time (so nutation-max is a maximum backward too)
        if (crosses(g_lo, g_hi, ta <= tb ? e.direction : -e.direction)) {
          const Scalar root = brent_root<Scalar>(g_at, t_lo, t_hi, g_lo, g_hi);
          found.push_back({root, static_cast<int>(k)});
        }
        t_lo = t_hi;
        g_lo = g_hi;
      }
    }
    std::sort(found.begin(), found.end(), [dir](const Occurrence<Scalar>& x, const Occurrence<Scalar>& y) {
      return dir * x.t < dir * y.t;
    });
  }

  /// Counts an occurrence of event k: true when it is the terminal one.
  bool ends_run(std::size_t k) { return remaining[k] > 0 && --remaining[k] == 0; }

  /// After a committed step: g at its end state s, the next step's start.
  void passed(const State<Scalar>& s) {
    for (std::size_t k = 0; k < list->size(); ++k) g_prev[k] = (*list)[k].g(s.time, s.rotation, s.omega);
  }
};

}  // namespace detail
}  // namespace trompo
