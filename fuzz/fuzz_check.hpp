#pragma once
// The step contract, checked on a scene, state and h drawn from fuzzer bytes. Shared by
// the libFuzzer target (fuzz/fuzz_step.cpp) and the corpus replay test
// (tests/test_fuzz_corpus.cpp), which compiles it without libFuzzer.
//
// The contract (docs/robustness.md):
//  - constructors either build a valid object or throw trompo::invalid_input (no other
//    exception, no crash, no undefined behaviour);
//  - Stepper::step never throws; with status ok the new state is finite, its quaternion
//    is unit and its time is t + h; with any other status the state is bit-for-bit what
//    it was; h = 0 or non-finite is invalid_step;
//  - integrate either throws invalid_input before stepping, or returns a summary: ok and
//    state.time == t_end exactly, or a failure with the state finite at the summary's
//    time, between the start and t_end.
//
// The input is read as a stream of decisions (scheme, scene, inertia, loads, state, h,
// steps). Short inputs are padded with zeros, so every byte string is a valid input.
// Numbers are drawn either from a physical range (log-uniform magnitudes) or, when a
// "wild" bit is set, as raw IEEE doubles (NaN, ±inf, subnormals, 1e308).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <sstream>
#include <string>
#include <type_traits>

#include "trompo/trompo.hpp"

namespace trompo_fuzz {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

/// Reads decisions from the fuzzer's bytes; past the end, every read returns zeros.
class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  std::uint32_t u32() {
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v = (v << 8) | byte();
    return v;
  }
  /// One of n choices.
  unsigned choose(unsigned n) { return byte() % n; }
  /// A uniform number in [0, 1].
  double unit() { return static_cast<double>(u32()) / 4294967295.0; }
  /// Any double, bit pattern straight from the input.
  double raw() {
    std::uint64_t bits = 0;
    for (int i = 0; i < 8; ++i) bits = (bits << 8) | byte();
    double d;
    std::memcpy(&d, &bits, sizeof d);
    return d;
  }
  /// sign · 10^[lo, hi], log-uniform; or a raw double when the wild bit of `flags` is set.
  double magnitude(double lo, double hi, bool wild, bool allow_negative = true) {
    if (wild) return raw();
    const std::uint8_t b = byte();
    if (b == 255) return 0.0;  // exact zeros matter (rest, equilibrium)
    const double v = std::pow(10.0, lo + (hi - lo) * unit());
    return allow_negative && (b & 1) ? -v : v;
  }
  Vec3 vector(double lo, double hi, bool wild) {
    return Vec3(magnitude(lo, hi, wild), magnitude(lo, hi, wild), magnitude(lo, hi, wild));
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

/// Inputs that got past the constructors to a step or an integrate call (statistics
/// for the corpus test, which checks that the harness is not mostly rejecting input).
inline long& reached_stepper() {
  static long n = 0;
  return n;
}

template <class Scalar>
bool same_bits(const trompo::State<Scalar>& a, const trompo::State<Scalar>& b) {
  return std::memcmp(a.omega.data(), b.omega.data(), sizeof(Scalar) * 3) == 0 &&
         std::memcmp(a.rotation.unit_quaternion().coeffs().data(), b.rotation.unit_quaternion().coeffs().data(),
                     sizeof(Scalar) * 4) == 0 &&
         std::memcmp(&a.time, &b.time, sizeof(Scalar)) == 0;
}

inline bool finite_state(const trompo::State<double>& s) {
  return s.omega.allFinite() && s.rotation.unit_quaternion().coeffs().allFinite() && std::isfinite(s.time);
}

/// The decoded run: steps (or an integrate call) of one stepper from one state.
template <class St>
std::string exercise(const St& st, trompo::State<double> s, Reader& in, bool wild) {
  using namespace trompo;
  std::ostringstream why;
  why.precision(17);
  ++reached_stepper();
  const double h = in.byte() == 0 ? 0.0 : in.magnitude(-8, 0.5, wild);
  const unsigned mode = in.choose(4);
  if (mode < 3) {  // plain steps
    const int n = 1 + static_cast<int>(in.choose(8));
    for (int i = 0; i < n; ++i) {
      const State<double> before = s;
#ifdef TROMPO_FUZZ_DEBUG
      // Replay aid: tests/test_fuzz_corpus.cpp or a main() built with -DTROMPO_FUZZ_DEBUG.
      std::fprintf(stderr, "step %s h=%.17g omega=(%.17g %.17g %.17g) q=(%.17g %.17g %.17g %.17g) t=%.17g\n",
                   std::decay_t<decltype(st.scheme())>::name, h, s.omega.x(), s.omega.y(), s.omega.z(),
                   s.rotation.unit_quaternion().w(), s.rotation.unit_quaternion().x(),
                   s.rotation.unit_quaternion().y(), s.rotation.unit_quaternion().z(), s.time);
#endif
      StepReport<double> rep;
      try {
        rep = st.step(s, h);
      } catch (const std::exception& e) {
        why << "step threw: " << e.what();
        return why.str();
      }
      const bool bad_h = !std::isfinite(h) || h == 0.0;
      if (bad_h && rep.status != StepStatus::invalid_step) {
        why << "h = " << h << " gave status " << to_string(rep.status);
        return why.str();
      }
      if (rep.ok()) {
        if (!finite_state(s)) {
          why << "status ok with a non-finite state: omega " << s.omega.transpose() << ", q "
              << s.rotation.unit_quaternion().coeffs().transpose() << ", t " << s.time << " (h = " << h << ")";
          return why.str();
        }
        const double qn = s.rotation.unit_quaternion().norm();
        if (!(std::abs(qn - 1.0) <= 1e-12)) {
          why << "status ok with |q| = " << qn;
          return why.str();
        }
        if (!(s.time == before.time + h)) {
          why << "status ok but t = " << s.time << " != " << before.time << " + " << h;
          return why.str();
        }
      } else if (!same_bits(s, before)) {
        why << "failed step (" << to_string(rep.status) << ") changed the state (h = " << h << ")";
        return why.str();
      } else {
        break;  // a failed step: nothing more to learn from the same state and h
      }
    }
    return {};
  }
  // integrate over up to 8 steps, with recovery depth 0..6.
  const double span = h * static_cast<double>(in.choose(9)) * (in.byte() & 1 ? 1.0 : 0.75);
  const double t0 = s.time;
  const double t_end = in.byte() == 7 ? in.raw() : t0 + span;
  // A raw t_end can ask for 1e9 steps; that is valid but not this harness's business.
  // Non-finite or negative ratios stay in: integrate must reject them before stepping.
  const double ratio = (t_end - t0) / h;
  if (ratio > 64) return {};
  IntegrateOptions opt;
  opt.max_halvings = static_cast<int>(in.choose(7));
  IntegrationSummary<double> sum;
  try {
    sum = integrate(st, s, t_end, h, NoObserver{}, opt);
  } catch (const invalid_input&) {
    return {};  // rejected before any step
  } catch (const std::exception& e) {
    why << "integrate threw a non-trompo exception: " << e.what();
    return why.str();
  }
  if (sum.ok()) {
    if (!(s.time == t_end) || !finite_state(s)) {
      why << "integrate ok but t = " << s.time << " (t_end " << t_end << "), finite " << finite_state(s);
      return why.str();
    }
  } else {
    if (!finite_state(s) || !(s.time == sum.time)) {
      why << "integrate failed (" << sum.reason() << ") with state time " << s.time << ", summary time "
          << sum.time << ", finite " << finite_state(s);
      return why.str();
    }
    const double lo = std::min(t0, t_end), hi = std::max(t0, t_end);
    if (!(s.time >= lo && s.time <= hi)) {
      why << "integrate stopped at t = " << s.time << " outside [" << lo << ", " << hi << "]";
      return why.str();
    }
  }
  return {};
}

// ---- the registered schemes (include/trompo/schemes/registry.hpp) ------------------------
/// exercise() steps a plain State; a scheme with memory, a ComposedStepper of one and a
/// ProcessedStepper step a Trajectory. This stepper carries the trajectory of the states it
/// produced and starts a fresh one (fresh memory) for any other state; integrate() gets the
/// real Trajectory (start()), and so exercises a ProcessedStepper's deferred output.
template <class Base>
struct StateStepper : Base {
  using Base::Base;
  using Base::step;
  mutable typename Base::TrajectoryType traj{};
  trompo::StepReport<double> step(trompo::State<double>& s, double h) const {
    if (!same_bits(traj.state(), s)) traj = this->start(s);
    const trompo::StepReport<double> rep = Base::step(traj, h);
    if (rep.ok()) s = traj.state();
    return rep;
  }
};

/// A scheme's parameters drawn from the input: the defaults unless the scheme has
/// parameters, whose overload stands here.
template <class S>
S draw_scheme(std::type_identity<S>, Reader&, bool) {
  return S{};
}
inline trompo::SimoAlpha draw_scheme(std::type_identity<trompo::SimoAlpha>, Reader& in, bool wild) {
  if (in.byte() & 1) return trompo::SimoAlpha{};
  return trompo::SimoAlpha(wild ? in.raw() : in.unit());
}
inline trompo::LieGenAlpha draw_scheme(std::type_identity<trompo::LieGenAlpha>, Reader& in, bool wild) {
  return trompo::LieGenAlpha(wild ? in.raw() : in.unit());
}
inline trompo::EnergyDecaying draw_scheme(std::type_identity<trompo::EnergyDecaying>, Reader& in, bool wild) {
  const double chi = in.byte() & 1 ? 0.0 : wild ? in.raw() : in.unit();
  return trompo::EnergyDecaying(chi, in.byte() & 1 ? trompo::ChiSchedule::sensor : trompo::ChiSchedule::constant);
}
inline trompo::Splitting draw_scheme(std::type_identity<trompo::Splitting>, Reader& in, bool) {
  // every method, the near-integrable ones [F8] included
  using trompo::all_splitting_methods;
  return trompo::Splitting(all_splitting_methods[in.choose(static_cast<unsigned>(std::size(all_splitting_methods)))]);
}

/// Registry entry Entry on `scene`: plain, or (where the registry lets the tools compose it)
/// a ComposedStepper of a drawn composition or the ProcessedStepper; splitting also with
/// the energy projection on conservative scenes.
template <class Entry, class Scene>
std::string with_entry(const Scene& scene, const trompo::State<double>& s, Reader& in, bool wild,
                       const trompo::NewtonOptions<double>& opt) {
  using namespace trompo;
  using S = typename Entry::Scheme;
  const S scheme = draw_scheme(std::type_identity<S>{}, in, wild);
  const unsigned how = in.choose(4);
  if constexpr (Entry::compositions == Compositions::symmetric) {
    if (how == 1) {
      const auto method = static_cast<Composition>(in.choose(6));
      return exercise(StateStepper<ComposedStepper<S, Scene>>(scheme, scene, method, opt), s, in, wild);
    }
    if (how == 2) return exercise(StateStepper<ProcessedStepper<S, Scene>>(scheme, scene, opt), s, in, wild);
  }
  if constexpr (std::is_same_v<S, Splitting> && detail::splitting_effects_of<Scene>::conservative) {
    if (how == 1) return exercise(StateStepper<Stepper<SplittingProjected, Scene>>(SplittingProjected(scheme.method), scene, opt), s, in, wild);
  }
  return exercise(StateStepper<Stepper<S, Scene>>(scheme, scene, opt), s, in, wild);
}

/// The sampled driver on a control scene: a controller of drawn (possibly wild) commands
/// sampled every T, held, and fixed steps between the samples by a drawn wheel-carrying
/// scheme. Contract: integrate_sampled throws invalid_input or returns; ok means the state
/// is finite at t_end exactly; otherwise the state is finite at a time in [t0, t_end].
template <class Scene>
std::string exercise_sampled(const Scene& scene, trompo::State<double> s, Reader& in, bool wild) {
  using namespace trompo;
  std::ostringstream why;
  const double period = in.magnitude(-3, 0.5, wild, false);
  const double h = period / static_cast<double>(1 + in.choose(4));
  const double t0 = s.time;
  const double t_end = t0 + period * static_cast<double>(in.choose(6)) * (in.byte() & 1 ? 1.0 : 0.7);
  double values[4];
  for (double& v : values) v = in.magnitude(-3, 1, wild);
  const int n_wheels = scene.template effect<ReactionWheels<double>>().size();
  struct Replay {
    double v[4];
    int n;
    int k = 0;
    Command<double> operator()(const Sample<double>&) {
      Command<double> c;
      c.wheel_torques = ReactionWheels<double>::WheelVector::Constant(n, v[k % 4]);
      c.body_torque = Vec3(v[(k + 1) % 4], 0, 0);
      c.dipole = Vec3(0, v[(k + 2) % 4], 0);
      ++k;
      return c;
    }
  } ctrl{{values[0], values[1], values[2], values[3]}, n_wheels};
  SampledSummary<double> sum;
  try {
    switch (in.choose(3)) {
      case 0: {
        Stepper<SimoKappa, Scene> st(SimoKappa{}, scene);
        sum = integrate_sampled(st, s, t_end, period, ctrl, FixedSteps<double>{h});
        break;
      }
      case 1: {
        Stepper<RK4, Scene> st(RK4{}, scene);
        sum = integrate_sampled(st, s, t_end, period, ctrl, FixedSteps<double>{h});
        break;
      }
      default: {
        Stepper<Splitting, Scene> st(Splitting(), scene);
        sum = integrate_sampled(st, s, t_end, period, ctrl, FixedSteps<double>{h});
      }
    }
  } catch (const invalid_input&) {
    return {};
  }
  if (sum.ok() && !(s.time == t_end)) {
    why << "sampled: ok but t = " << s.time << " != t_end = " << t_end;
    return why.str();
  }
  if (!finite_state(s)) return "sampled: the state is not finite after the run (" + sum.reason() + ")";
  if (!(s.time >= std::min(t0, t_end) && s.time <= std::max(t0, t_end))) {
    why << "sampled: t = " << s.time << " outside [" << t0 << ", " << t_end << "]";
    return why.str();
  }
  return {};
}

/// One registered scheme that steps Scene, drawn from the input.
template <class Scene>
std::string with_scheme(const Scene& scene, const trompo::State<double>& s, Reader& in, bool wild) {
  using namespace trompo;
  NewtonOptions<double> opt;
  if (in.byte() == 3) opt.max_iterations = static_cast<int>(in.choose(4));  // starved Newton
  const unsigned pick = in.choose(static_cast<unsigned>(RegisteredSchemes::size));
  unsigned k = 0;
  std::string broken;
  RegisteredSchemes::for_each([&](auto entry) {
    using Entry = typename decltype(entry)::type;
    if (k++ != pick) return;
    if constexpr (Entry::template steps<Scene>) broken = with_entry<Entry>(scene, s, in, wild, opt);
  });
  return broken;
}

/// Checks the contract on one input; returns "" when it holds, else what broke.
inline std::string check(const std::uint8_t* data, std::size_t size) {
  using namespace trompo;
  Reader in(data, size);
  const std::uint8_t flags = in.byte();
  const bool wild = (flags & 0x0f) == 0x0f;  // raw doubles in 1 input of 16
  try {
    // Inertia: principal moments along principal axes P, or a raw matrix.
    Mat3 J;
    if (wild && (flags & 0x10)) {
      for (int i = 0; i < 9; ++i) J.data()[i] = in.raw();
    } else {
      Vec3 m(std::abs(in.magnitude(-3, 3, wild)), std::abs(in.magnitude(-3, 3, wild)),
             std::abs(in.magnitude(-3, 3, wild)));
      // Mostly keep the triangle inequality (J3 ≤ J1 + J2 after sorting), so that most
      // inputs reach the steppers; one in four is left as drawn, to exercise the check.
      std::sort(m.data(), m.data() + 3);
      if (in.byte() % 4 != 0 && m(2) > m(0) + m(1)) m(2) = m(0) + m(1);
      const Mat3 P = in.byte() & 1 ? SO3<double>::exp(in.vector(-2, 0.5, false)).matrix() : Mat3::Identity();
      J = P * m.asDiagonal() * P.transpose();
      J = ((J + J.transpose()) / 2).eval();
    }
    const bool physical = !(flags & 0x20);
    const RigidBody<double> body = physical ? RigidBody<double>(J) : RigidBody<double>(J, allow_unphysical_inertia);

    // State: a rotation from a quaternion (possibly rejected), Ω, t.
    State<double> s;
    {
      Eigen::Quaterniond q(in.magnitude(-3, 0, wild), in.magnitude(-3, 0, wild), in.magnitude(-3, 0, wild),
                           in.magnitude(-3, 0, wild));
      s.rotation = SO3<double>::renormalized(q);
    }
    s.omega = in.vector(-300, 4, wild);
    s.time = in.byte() & 1 ? in.magnitude(-3, 3, wild) : 0.0;
    if (in.byte() & 1) s.validate();  // else: a non-finite state goes straight to step()

    const double Mgl = in.magnitude(-3, 3, wild);
    const Vec3 E = in.vector(-3, 0, wild), up = in.vector(-3, 0, wild);
    switch (in.choose(5)) {
      case 0: return with_scheme(Scene<double>(body), s, in, wild);
      case 4: {
        // Control in the loop: 1..4 wheels with a held command, a held body torque and
        // magnetorquers with a held dipole (the CLI's control scene); only the schemes that
        // carry wheels step it (the registry's steps<Scene>). The body is then the hub.
        ReactionWheels<double> rw;
        const int n = 1 + static_cast<int>(in.choose(4));
        for (int i = 0; i < n; ++i)
          rw.add_wheel({.axis = in.vector(-3, 0, wild), .inertia = in.magnitude(-4, -1, wild, false),
                        .speed0 = in.magnitude(-3, 3, wild), .max_torque = in.magnitude(-3, 1, wild)});
        const RigidBody<double> hub = rw.hub_body(body.inertia());
        rw.start(s.time, s.omega);
        ReactionWheels<double>::WheelVector u(n);
        for (int i = 0; i < n; ++i) u(i) = in.magnitude(-3, 1, wild);
        rw.hold(s.time, u);
        Magnetorquer<double> mtq(DipoleField<double>(CircularOrbit<double>(in.magnitude(6.5, 7.5, wild, false), in.unit())));
        mtq.dipole = in.vector(-3, 1, wild);
        using S = Scene<double, ReactionWheels<double>, HeldBodyTorque<double>, Magnetorquer<double>>;
        const S scene(hub, rw, HeldBodyTorque<double>(in.vector(-3, 1, wild)), mtq);
        if (in.byte() & 1) return exercise_sampled(scene, s, in, wild);
        return with_scheme(scene, s, in, wild);
      }
      case 1: return with_scheme(HeavyTop<double>(body, UniformGravity<double>(Mgl, E, up)), s, in, wild);
      case 2: {
        using S = Scene<double, UniformGravity<double>, ViscousDamping<double>, ConstantBodyTorque<double>,
                        ConstantSpaceTorque<double>, Rotor<double>>;
        const double c = in.magnitude(-3, 2, wild);
        const Vec3 tb = in.vector(-3, 2, wild), ts = in.vector(-3, 2, wild), hr = in.vector(-3, 2, wild);
        return with_scheme(S(body, UniformGravity<double>(Mgl, E, up), ViscousDamping<double>(c),
                             ConstantBodyTorque<double>(tb), ConstantSpaceTorque<double>(ts), Rotor<double>(hr)),
                           s, in, wild);
      }
      default: {
        // A general potential: V = k (γ·ΛE)² (not linear in Λ), Hessian by differences.
        const Vec3 En = E.normalized(), upn = up.normalized();
        if (!En.allFinite() || !upn.allFinite()) return {};
        const double k = Mgl;
        auto V = [=](const Mat3& L) {
          const double c = upn.dot(L * En);
          return k * c * c;
        };
        auto g = [=](const Mat3& L) -> Vec3 { return 2 * k * upn.dot(L * En) * En.cross(L.transpose() * upn); };
        const auto pot = make_potential<double>(V, g);
        return with_scheme(Scene<double, std::decay_t<decltype(pot)>>(body, pot), s, in, wild);
      }
    }
  } catch (const invalid_input&) {
    return {};  // rejected input: the contract for bad input
  } catch (const std::exception& e) {
    return std::string("unexpected exception: ") + e.what();
  }
}

}  // namespace trompo_fuzz
