#pragma once
// Stepper<Scheme, Scene>: one time step of a scheme on a scene.
//
//   Stepper<SimoKappa, HeavyTop<double>> stepper(SimoKappa{}, scene);
//   StepReport<double> rep = stepper.step(state, h);   // h < 0 integrates backward
//
// A step that fails (Newton did not converge, left the domain, took a wrong branch,
// produced a NaN, or h is 0/non-finite) returns its status and leaves `state` exactly
// as it was. No heap allocation, no virtual call: everything is fixed-size Eigen.
#include <cmath>
#include <limits>
#include <type_traits>

#include "trompo/newton.hpp"
#include "trompo/schemes/geradin_bauchau.hpp"
#include "trompo/schemes/rk4.hpp"
#include "trompo/schemes/simo.hpp"
#include "trompo/state.hpp"

namespace trompo {

template <class Scheme, class Scene_>
class Stepper {
 public:
  using Scene = Scene_;
  using Scalar = typename Scene::Scalar;

  explicit Stepper(Scheme scheme, Scene scene, NewtonOptions<Scalar> options = {})
      : scheme_(scheme), scene_(std::move(scene)), options_(options) {}

  /// Advances `state` by h. On failure `state` is untouched and the report says why.
  StepReport<Scalar> step(State<Scalar>& state, Scalar h) const {
    StepReport<Scalar> rep;
    if (!std::isfinite(static_cast<double>(h)) || h == Scalar(0)) {
      rep.status = StepStatus::invalid_step;
      return rep;
    }
    State<Scalar> next;
    if constexpr (std::is_same_v<Scheme, RK4>) {
      rep = detail::rk4_step(scene_, state, h, next);
    } else if constexpr (std::is_same_v<Scheme, GeradinBauchau> || std::is_same_v<Scheme, GeradinBauchauPaper>) {
      rep = detail::gb_step<Scheme>(scene_, state, h, options_, next);
    } else {
      rep = detail::simo_step(scheme_, scene_, state, h, options_, next);
    }
    // Last line of defence for "no NaN behind ok": whatever a scheme returned, an ok step
    // must give a finite state with a unit quaternion (the fuzzer found RK4 overflowing
    // |q|² to a zero quaternion), else it is reported as non_finite and not committed.
    if (rep.ok() && !committable(next)) rep.status = StepStatus::non_finite;
    if (rep.ok()) state = next;
    return rep;
  }

  /// Whether one step of +h then −h returns to the start (all but RK4 and Simo-α ≠ ½).
  bool symmetric() const {
    if constexpr (std::is_same_v<Scheme, RK4>) return false;
    else if constexpr (std::is_same_v<Scheme, SimoAlpha>) return scheme_.alpha == 0.5;
    else return true;
  }

  const Scheme& scheme() const { return scheme_; }
  const Scene& scene() const { return scene_; }
  const NewtonOptions<Scalar>& options() const { return options_; }
  NewtonOptions<Scalar>& options() { return options_; }

 private:
  static bool committable(const State<Scalar>& s) {
    using std::abs;
    const auto& q = s.rotation.unit_quaternion();
    return detail::all_finite(s.omega) && detail::all_finite(q.coeffs()) &&
           std::isfinite(static_cast<double>(s.time)) &&
           abs(q.squaredNorm() - Scalar(1)) <= Scalar(16) * std::numeric_limits<Scalar>::epsilon();
  }

  Scheme scheme_;
  Scene scene_;
  NewtonOptions<Scalar> options_;
};

}  // namespace trompo
