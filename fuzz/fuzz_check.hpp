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
//    time, between the start and t_end (integrate_sampled likewise);
//  - the adaptive driver (solve: tolerances, t_eval, events, dense output) either throws
//    invalid_input or returns outputs that keep its contract (exercise_adaptive).
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
#include <vector>

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

/// Inputs whose adaptive run solve() took (not refused as invalid input), and of those the
/// runs that ended at t_end, at a terminal event, or failed (statistics for the corpus test).
struct AdaptiveCounts {
  long solved = 0, reached_end = 0, event = 0, failed = 0;
};
inline AdaptiveCounts& adaptive_counts() {
  static AdaptiveCounts n;
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

// ---- the adaptive driver (include/trompo/drivers/adaptive.hpp) ---------------------------
inline bool unit_rotation(const trompo::State<double>& s) {
  return std::abs(s.rotation.unit_quaternion().norm() - 1.0) <= 1e-12;
}

/// Whether t lies in the closed span between a and b (either order).
inline bool within(double t, double a, double b) { return t >= std::min(a, b) && t <= std::max(a, b); }

/// The adaptive driver on stepper `st` from `s`: options (tolerances from 1e-300 to 1e10,
/// raw doubles when wild; either step control; every estimate; a bounded max_steps), a
/// t_eval grid, up to two events (a component of Ω crossing a level, the body axis crossing
/// a plane; terminal or not) and dense-output queries, drawn from the input, through solve()
/// (integrate_adaptive with its observer and event sink). Contract:
///  - solve throws invalid_input (bad options, t_eval, events) or returns a summary whose
///    time lies in the span; reached_end: at t_end exactly; a failed run (status failed)
///    leaves finite states, the last at the summary's time;
///  - every output state and accepted node is finite with a unit quaternion; without t_eval
///    the states are the start and every accepted step, monotone in time;
///  - t_eval states are at the requested times, in order, all those the run reached; event
///    states lie in the run's span, in order; a terminal event ends the run at the last
///    occurrence of an event with `terminal` set;
///  - the dense solution runs from t0 to the summary's time through monotone nodes; at a
///    node time it is that node, each step's interpolant meets its two nodes to round-off,
///    a query anywhere in the span is finite and at that time, and one outside is refused.
/// The processed composition does not adapt (exercise() integrates it instead); the work
/// per input is bounded by max_steps ≤ 48 attempts.
template <class St>
std::string exercise_adaptive(const St& st, const trompo::State<double>& s0, Reader& in, bool wild, double h) {
  using namespace trompo;
  std::ostringstream why;
  why.precision(17);
  AdaptiveOptions<double> opt;
  const auto tolerance = [&](bool zero_ok) {
    switch (in.choose(8)) {
      case 5: return in.magnitude(-300, -13, false, false);  // below ε: the 8ε noise floor
      case 6: return in.magnitude(0, 10, false, false);      // nothing to resolve
      case 7: return wild ? in.raw() : (zero_ok ? 0.0 : in.magnitude(-16, -1, false, false));
      default: return in.magnitude(-12, -2, false, false);
    }
  };
  opt.rtol = tolerance(false);
  opt.atol = tolerance(true);
  const std::uint8_t how = in.byte();
  opt.control = (how & 3) == 3 ? StepControl::reversible : StepControl::tolerance;
  opt.estimate = static_cast<ErrorEstimate>((how >> 2) & 3);
  if (how & 0x10) {  // Richardson's m where the estimate takes one; 1 in 16 anything (invalid)
    const std::uint8_t sub = in.byte();
    if (sub % 16 == 0) opt.substeps = sub / 16;
    else if (opt.estimate == ErrorEstimate::automatic || opt.estimate == ErrorEstimate::richardson)
      opt.substeps = 2 + sub % 15;
    else if (opt.estimate == ErrorEstimate::doubling)
      opt.substeps = 2;
  }
  opt.tolerance_over_span = !(how & 0x20);
  opt.quintic = !(how & 0x40);
  opt.hold_invariants = !(how & 0x80);
  const std::uint8_t more = in.byte();
  if (more & 1) opt.first_step = std::abs(h);
  if (more & 2) opt.max_step = in.magnitude(-6, 1, wild, false);
  if (more & 4) opt.max_rotation = 4.5 * in.unit();  // (0, 4] valid
  if (more & 8) opt.epsilon = in.magnitude(-8, 0, wild, false);
  if (more & 16) opt.omega_floor = in.magnitude(-8, 2, wild, false);
  // Bounded work per input: at most 48 attempts (each up to 17 steps of a composition).
  opt.max_steps = 1 + static_cast<std::int64_t>(in.choose(48));

  const double t0 = s0.time;
  const double span = std::abs(h) * static_cast<double>(1 + in.choose(32)) * (more & 32 ? -1.0 : 1.0);
  const double t_end = in.byte() == 7 ? in.raw() : t0 + span;
  const bool forward = t_end >= t0;

  // t_eval: fractions of the span in the run's order (t0 and t_end themselves possible);
  // 1 in 8 shuffled or outside, which solve must refuse.
  std::vector<double> t_eval;
  const unsigned n_eval = in.choose(6);
  for (unsigned i = 0; i < n_eval; ++i) {
    const std::uint8_t b = in.byte();
    t_eval.push_back(b == 0 ? t0 : b == 255 ? t_end : t0 + (t_end - t0) * (b / 255.0));
  }
  const bool bad_order = (in.byte() % 8) == 0;
  if (!bad_order) {
    std::sort(t_eval.begin(), t_eval.end());
    t_eval.erase(std::unique(t_eval.begin(), t_eval.end()), t_eval.end());
    if (!forward) std::reverse(t_eval.begin(), t_eval.end());
  }

  // Events: a component of Ω crossing a level near Ω0's, or the body axis crossing a plane.
  std::vector<Event<double>> events;
  const unsigned n_events = in.choose(3);
  for (unsigned i = 0; i < n_events; ++i) {
    const std::uint8_t b = in.byte();
    const int direction = static_cast<int>(b % 3) - 1;
    const int terminal = static_cast<int>((b >> 2) % 3);
    if (b & 0x80) {
      events.push_back(events::axis_crossing<double>(in.vector(-2, 0, wild), in.vector(-2, 0, wild), direction, terminal));
    } else {
      const int k = static_cast<int>(in.choose(3));
      const double level = s0.omega(k) * (2.0 * in.unit() - 1.0) * 1.5;
      Event<double> e;
      e.name = "omega-level";
      e.g = [k, level](double, const SO3<double>&, const Vec3& w) { return w(k) - level; };
      e.direction = (b & 0x40) && wild ? 2 : direction;  // 2: invalid
      e.terminal = terminal;
      events.push_back(e);
    }
  }

  const std::uint8_t entry = in.byte();
  // solve: t_eval states, events and the dense solution
  const bool dense = (entry & 4) == 0;
  AdaptiveRun<double> run;
  try {
    run = solve(st, s0, t_end, opt, t_eval, events, dense);
  } catch (const invalid_input& e) {
#ifdef TROMPO_FUZZ_DEBUG
    std::fprintf(stderr, "adaptive refused: %s\n", e.what());
#endif
    // invalid_input is for bad input, found before any step: inputs that pass these checks
    // must give a summary (a step failure inside the run must not throw).
    bool valid = std::isfinite(t_end);
    try {
      opt.validate();
      s0.validate();
    } catch (const invalid_input&) {
      valid = false;
    }
    for (std::size_t i = 0; i < t_eval.size(); ++i)
      valid = valid && std::isfinite(t_eval[i]) && within(t_eval[i], t0, t_end) &&
              (i == 0 || (forward ? t_eval[i] > t_eval[i - 1] : t_eval[i] < t_eval[i - 1]));
    for (const Event<double>& ev : events) valid = valid && ev.direction >= -1 && ev.direction <= 1 && ev.terminal >= 0;
    valid = valid && !(opt.estimate == ErrorEstimate::defect && st.order() > 6);
    const bool pilot = opt.control == StepControl::reversible && opt.epsilon == 0;  // may find no step: refused
    if (valid && !pilot) {
      why << "solve threw invalid_input on inputs that validate (inside the run?): " << e.what();
      return why.str();
    }
    return {};
  }
  if (bad_order) {
    // solve took it: then the grid must have been valid after all
    for (std::size_t i = 0; i < t_eval.size(); ++i)
      if (!within(t_eval[i], t0, t_end) || (i > 0 && !(forward ? t_eval[i] > t_eval[i - 1] : t_eval[i] < t_eval[i - 1])))
        return "solve: accepted an unsorted or out-of-span t_eval";
  }
  const AdaptiveSummary<double>& sum = run.summary;
  const double t_run = sum.time;
#ifdef TROMPO_FUZZ_DEBUG
  std::fprintf(stderr, "adaptive: rtol %.3g atol %.3g control %d estimate %d m %d max_steps %lld; t0 %.17g t_end %.17g; "
               "%zu t_eval, %zu events, dense %d: %s at t = %.17g, %lld accepted, %zu nodes\n",
               opt.rtol, opt.atol, static_cast<int>(opt.control), static_cast<int>(opt.estimate), opt.substeps,
               static_cast<long long>(opt.max_steps), t0, t_end, t_eval.size(), events.size(), int(dense), sum.message(),
               t_run, static_cast<long long>(sum.accepted), run.solution.nodes().size());
  for (std::size_t k = 0; k < events.size(); ++k)
    for (const State<double>& x : run.events[k])
      std::fprintf(stderr, "  event %zu (%s, direction %d, terminal %d) at t = %.17g\n", k, events[k].name.c_str(),
                   events[k].direction, events[k].terminal, x.time);
  std::fprintf(stderr, "  quintic %d hold %d\n", int(opt.quintic), int(opt.hold_invariants));
  for (const auto& n : run.solution.nodes())
    std::fprintf(stderr, "  node t = %.17g omega (%.17g %.17g %.17g) dot (%.6g %.6g %.6g) ddot (%.6g %.6g %.6g) second %d\n",
                 n.state.time, n.state.omega.x(), n.state.omega.y(), n.state.omega.z(), n.omega_dot.x(), n.omega_dot.y(),
                 n.omega_dot.z(), n.omega_ddot.x(), n.omega_ddot.y(), n.omega_ddot.z(), int(n.second));
#endif
  AdaptiveCounts& counts = adaptive_counts();
  ++counts.solved;
  ++(sum.status == AdaptiveStatus::reached_end ? counts.reached_end
     : sum.status == AdaptiveStatus::event     ? counts.event
                                               : counts.failed);
  if (!within(t_run, t0, t_end)) {
    why << "solve: summary time " << t_run << " outside [" << t0 << ", " << t_end << "]";
    return why.str();
  }
  if (sum.status == AdaptiveStatus::reached_end && !(t_run == t_end)) {
    why << "solve: reached_end at t = " << t_run << " != t_end = " << t_end;
    return why.str();
  }
  for (const State<double>& x : run.states)
    if (!finite_state(x) || !unit_rotation(x)) {
      why << "solve: output state not finite or |q| != 1 at t = " << x.time << " (" << sum.message() << ")";
      return why.str();
    }
  if (t_eval.empty()) {  // every accepted step: from t0, monotone, ending at the summary's time
    if (run.states.empty() || !(run.states.front().time == t0)) return "solve: no initial state in the output";
    for (std::size_t i = 1; i < run.states.size(); ++i)
      if (!(forward ? run.states[i].time > run.states[i - 1].time : run.states[i].time < run.states[i - 1].time)) {
        why << "solve: output times not monotone at " << i << ": " << run.states[i - 1].time << ", " << run.states[i].time;
        return why.str();
      }
    if (!(run.states.back().time == t_run)) {
      why << "solve: last output at t = " << run.states.back().time << ", summary at " << t_run << " (" << sum.message() << ")";
      return why.str();
    }
  } else {  // the requested times, in order, all those the run reached
    std::size_t reached = 0;
    for (double t : t_eval)
      if (within(t, t0, t_run)) ++reached;
    if (run.states.size() != reached) {
      why << "solve: " << run.states.size() << " t_eval states for " << reached << " requested times reached (run to "
          << t_run << ", " << sum.message() << ")";
      return why.str();
    }
    for (std::size_t i = 0; i < run.states.size(); ++i)
      if (!(run.states[i].time == t_eval[i])) {
        why << "solve: t_eval state " << i << " at t = " << run.states[i].time << ", asked " << t_eval[i];
        return why.str();
      }
  }
  bool ended_here = false;
  // A terminal event within a few ulp of t after a step's start (the driver's too_small: 4ε
  // of max(|t0|, |t_end|)) ends the run at that start; events of the same step found before
  // it may lie that far beyond the run's end (found by the fuzzer: 3.6e-129 past t = 0).
  const double slack = 4 * std::numeric_limits<double>::epsilon() * std::max(std::abs(t0), std::abs(t_end));
  const double t_reach = forward ? t_run + slack : t_run - slack;
  for (std::size_t k = 0; k < run.events.size(); ++k) {
    const std::vector<State<double>>& occ = run.events[k];
    for (std::size_t i = 0; i < occ.size(); ++i) {
      if (!finite_state(occ[i]) || !within(occ[i].time, t0, t_reach)) {
        why << "solve: event " << k << " at t = " << occ[i].time << " outside the run [" << t0 << ", " << t_run
            << "] or not finite";
        return why.str();
      }
      if (i > 0 && (forward ? occ[i].time < occ[i - 1].time : occ[i].time > occ[i - 1].time)) {
        why << "solve: event " << k << " occurrences out of order: " << occ[i - 1].time << ", " << occ[i].time;
        return why.str();
      }
    }
    if (events[k].terminal > 0 && !occ.empty() && occ.back().time == t_run) ended_here = true;
  }
  if (sum.status == AdaptiveStatus::event && !ended_here) {
    why << "solve: status event at t = " << t_run << " with no terminal occurrence there";
    return why.str();
  }
  if (!dense) return {};
  const auto& nodes = run.solution.nodes();
  if (nodes.empty() || !(nodes.front().state.time == t0)) return "solve: the dense solution does not start at t0";
  if (!(nodes.back().state.time == t_run)) {
    why << "solve: the dense solution ends at " << nodes.back().state.time << ", the run at " << t_run;
    return why.str();
  }
  try {
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      const State<double>& n = nodes[i].state;
      if (!finite_state(n) || !unit_rotation(n)) return "solve: a dense node is not finite or |q| != 1";
      if (i > 0 && !(forward ? n.time > nodes[i - 1].state.time : n.time < nodes[i - 1].state.time)) {
        why << "solve: dense nodes not monotone at " << i << ": " << nodes[i - 1].state.time << ", " << n.time;
        return why.str();
      }
      if (!same_bits(run.solution(n.time), n)) {
        why << "solve: solution(" << n.time << ") is not the node there";
        return why.str();
      }
      if (i == 0) continue;
      // The interpolant of step i−1 → i at its ends, by its polynomial: the nodes, to
      // round-off (the rotation through log and exp, Ω through the Hermite basis).
      const LieHermite<double> seg(nodes[i - 1], nodes[i], opt.quintic);
      for (double theta : {0.0, 1.0}) {
        Vec3 xi, w;
        seg.algebra(theta, xi, w);
        const State<double>& end = theta == 0.0 ? nodes[i - 1].state : n;
        const double dq = (seg.rotation_at(xi).matrix() - end.rotation.matrix()).norm();
        const double dw = (w - end.omega).norm();
        const double scale_w = 64 * std::numeric_limits<double>::epsilon() *
                               (nodes[i - 1].state.omega.norm() + n.omega.norm() +
                                std::abs(seg.step()) * (nodes[i - 1].omega_dot.norm() + nodes[i].omega_dot.norm()));
        const double scale_q = 64 * std::numeric_limits<double>::epsilon() * (1 + seg.phi().norm());
        if (!(dq <= scale_q) || !(dw <= scale_w + std::numeric_limits<double>::denorm_min())) {
          why << "solve: interpolant of step " << i << " at theta = " << theta << " misses the node by |dR| = " << dq
              << " (bound " << scale_q << "), |dW| = " << dw << " (bound " << scale_w << ")";
          return why.str();
        }
      }
    }
    // Queries anywhere in the span: finite, unit, at the time asked; outside: refused.
    for (int i = 0; i < 3; ++i) {
      const double t = t0 + (t_run - t0) * in.unit();
      if (!within(t, t0, t_run)) continue;
      const State<double> x = run.solution(t);
      if (!finite_state(x) || !unit_rotation(x) || !(x.time == t)) {
        why << "solve: solution(" << t << ") gave t = " << x.time << ", finite " << finite_state(x);
        return why.str();
      }
    }
  } catch (const invalid_input& e) {
    why << "solve: a dense query inside the span threw: " << e.what();
    return why.str();
  }
  const double outside = forward ? t_run + std::max(1.0, std::abs(t_run)) : t_run - std::max(1.0, std::abs(t_run));
  try {
    (void)run.solution(outside);
    if (std::isfinite(outside) && !(outside == t_run)) return "solve: a dense query outside the span was answered";
  } catch (const invalid_input&) {
  }
  return {};
}

/// The decoded run: steps (or an integrate call, or the adaptive driver where `Adaptive`)
/// of one stepper from one state.
template <bool Adaptive, class St>
std::string exercise(const St& st, trompo::State<double> s, Reader& in, bool wild) {
  using namespace trompo;
  std::ostringstream why;
  why.precision(17);
  ++reached_stepper();
  const double h = in.byte() == 0 ? 0.0 : in.magnitude(-8, 0.5, wild);
  const std::uint8_t mode_byte = in.byte();
  const unsigned mode = mode_byte % 4;
  // Half the integrate inputs (bit 2 of the same byte, so that the older corpus's other
  // inputs decode as before) run the adaptive driver instead, on the steppers that adapt
  // here (with_entry: one kind per scheme and scene, which keeps the target's compile time).
  if constexpr (Adaptive) {
    static_assert(!trompo::detail::is_processed<typename St::base_type>(), "the processed composition does not adapt");
    if (mode == 3 && (mode_byte & 4)) return exercise_adaptive(static_cast<const typename St::base_type&>(st), s, in, wild, h);
  }
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
  /// The wrapped stepper (the adaptive driver gets it as it is).
  using base_type = Base;
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
      return exercise<true>(StateStepper<ComposedStepper<S, Scene>>(scheme, scene, method, opt), s, in, wild);
    }
    if (how == 2) return exercise<false>(StateStepper<ProcessedStepper<S, Scene>>(scheme, scene, opt), s, in, wild);
  }
  if constexpr (std::is_same_v<S, Splitting> && detail::splitting_effects_of<Scene>::conservative) {
    if (how == 1) return exercise<false>(StateStepper<Stepper<SplittingProjected, Scene>>(SplittingProjected(scheme.method), scene, opt), s, in, wild);
  }
  // The adaptive driver on the plain stepper where the scheme does not compose here (the
  // composed one, whose compositions include the base step, covers the others).
  return exercise<Entry::compositions != Compositions::symmetric>(StateStepper<Stepper<S, Scene>>(scheme, scene, opt), s, in, wild);
}

/// The sampled driver on a control scene: a controller of drawn (possibly wild) commands
/// sampled every T, held, and fixed steps between the samples by a drawn wheel-carrying
/// scheme, or (Simo-κ) adaptive steps of drawn options. Contract: integrate_sampled throws invalid_input or returns; ok means the state
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
  // Viscous wheel friction [W17]: one byte after each branch's own draws
  // (a corpus input that ends before it keeps its run without friction), then c for each wheel.
  const auto maybe_friction = [&](auto& stepper) {
    if (!(in.byte() & 1)) return;
    auto& rw = stepper.scene().template effect<ReactionWheels<double>>();
    for (int i = 0; i < rw.size(); ++i) rw.set_friction(i, in.magnitude(-4, 0, wild, false));
  };
  try {
    switch (in.choose(3)) {
      case 0: {
        Stepper<SimoKappa, Scene> st(SimoKappa{}, scene);
        if (in.byte() & 1) {
          // Adaptive holds: each a new integrate_adaptive run to the next sample, with drawn
          // tolerances (raw doubles when wild), either step control, any estimate and at most
          // 48 attempts a hold. (One byte more than the fixed holds read: a corpus input that
          // ends here keeps its fixed-step run.)
          AdaptiveOptions<double> opt;
          opt.rtol = wild && (in.byte() & 1) ? in.raw() : in.magnitude(-14, 0, false, false);
          opt.atol = wild && (in.byte() & 1) ? in.raw() : in.magnitude(-14, 0, false, false);
          const std::uint8_t how = in.byte();
          opt.control = (how & 3) == 3 ? StepControl::reversible : StepControl::tolerance;
          opt.estimate = static_cast<ErrorEstimate>((how >> 2) & 3);
          opt.max_steps = 1 + static_cast<std::int64_t>(in.choose(48));
          maybe_friction(st);  // the split step under the adaptive driver [W17] (a byte more)
          // Observed, so that the driver forms its dense nodes, with friction at each node's own
          // line (W17.a-b, FrictionSplitStepper::wheels_at); the contract below is the run's.
          sum = integrate_sampled(st, s, t_end, period, ctrl, AdaptiveSteps<double>{opt}, [](const State<double>&) {});
        } else {
          maybe_friction(st);
          if (in.byte() & 1) {
            // Simo-κ's triple jump: with friction its flows around each sub-step (one byte
            // more: a corpus input that ends before it keeps its single-step run).
            ComposedStepper<SimoKappa, Scene> composed(SimoKappa{}, st.scene(), 4);
            sum = integrate_sampled(composed, s, t_end, period, ctrl, FixedSteps<double>{h});
          } else {
            sum = integrate_sampled(st, s, t_end, period, ctrl, FixedSteps<double>{h});
          }
        }
        break;
      }
      case 1: {
        Stepper<RK4, Scene> st(RK4{}, scene);
        maybe_friction(st);
        sum = integrate_sampled(st, s, t_end, period, ctrl, FixedSteps<double>{h});
        break;
      }
      default: {
        Stepper<Splitting, Scene> st(Splitting(), scene);
        // Steps that follow the rate (FixedSteps::max_angle, [W16]) on tame inputs, where the
        // start's rate asks at most 10^4 steps a hold (a drawn 0 byte: off, as before), and no
        // hold more than 10^4 (FixedSteps::max_steps): a body the held torques spin up asks more
        // at later samples (found by the fuzzer: 12,800 rad/s, 419,000 steps in five holds,
        // 8.5 s under the sanitizers, past the fuzzer's timeout on a loaded machine).
        double angle = 0;
        if (!wild && (in.byte() & 1)) {
          angle = in.magnitude(-1.3, 0, false, false);
          if (!(s.omega.norm() * period / angle <= 1e4)) angle = 0;
        }
        maybe_friction(st);
        sum = integrate_sampled(st, s, t_end, period, ctrl, FixedSteps<double>{h, {}, angle, 10000});
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
