#pragma once
// integrate_ensemble: N independent trajectories (a Monte-Carlo set of perturbed tops, a
// parameter sweep) integrated across cores.
//
//   auto c = trompo::cases::ht1<double>();
//   Stepper<SimoKappa, HeavyTop<double>> stepper(SimoKappa{}, c.scene);
//   std::vector<State<double>> members(10000, c.initial);   // then perturb each
//   auto summaries = integrate_ensemble(stepper, members, 1.0, 0.001);
//   // members[i] is the final state of member i; summaries[i].ok() says whether it got there
//
// One stepper for all the members (same scene), or one per member (the same scene type
// with per-member parameters: inertia, weight, …):
//
//   std::vector<Stepper<SimoKappa, HeavyTop<double>>> steppers;   // steppers[i] for members[i]
//   integrate_ensemble(steppers, members, t_end, h, {.threads = 2});
//
// What a member gets. Member i is integrated by exactly `integrate(stepper_i, members[i],
// t_end, h, NoObserver{}, options.integrate)` (integrate.hpp): same grid, same recovery
// by sub-stepping, so its final state is bit-identical to that single run, whatever the
// number of threads. Members never interact; a member whose step fails beyond recovery
// stops at its last good state with its summary saying why, and the others go on.
//
// Threads. std::thread, not OpenMP: the library is header-only, and an OpenMP pragma
// would make every program that includes it link GCC's libgomp (and build with
// -fopenmp) or silently run serially; std::thread needs nothing beyond the C++ standard
// library. The schedule is dynamic: the threads take chunks of consecutive members from a
// shared counter until none is left. Members of a sweep need not cost the same (a sweep
// in order of spin costs more and more along the range), and a static split into T blocks
// left threads idle: 16 threads gave 11.2× one thread on such a sweep against 11.4× on a
// uniform ensemble, and on 2 cores 1.43× against 1.70× for the same members shuffled. A
// member's result does not depend on which thread ran it (members are independent), so it
// is still bit-identical to its single run. Each member is integrated on a local copy of
// its state and written back once at the end, so threads do not share cache lines while
// they step.
//
// Adaptive members: solve_ensemble runs solve() (adaptive.hpp: tolerances, t_eval, events,
// dense output) per member on the same schedule, each result that single run's.
//
// Closed-loop members (a Monte-Carlo of flight software in the loop, docs/control.md):
// integrate_sampled_ensemble runs integrate_sampled (sampled.hpp) per member, each on its own
// copy of the stepper (its scene holds the wheels' hold and the held commands, which the
// driver changes) and of the controller (its memory), the wheels started at the member's
// state and then `setup(i, stepper_i, controller_i)` for per-member parameters; each result
// is that single run's, bit for bit, with the wheels' speeds at its end.
//
// Cost. The only allocations are the summaries and the threads, before any step; no
// allocation per step (the Stepper's guarantee); one atomic increment per chunk.
//
// Bad input throws invalid_input on the calling thread before any member is stepped:
// h zero or not finite, t_end not finite, a member's state not finite or its t_end behind
// its start, a stepper count that is neither 1 nor the member count.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <exception>
#include <functional>
#include <mutex>
#include <ranges>
#include <string>
#include <thread>
#include <vector>

#include "trompo/errors.hpp"
#include "trompo/drivers/adaptive.hpp"
#include "trompo/drivers/integrate.hpp"
#include "trompo/drivers/sampled.hpp"
#include "trompo/model/state.hpp"

namespace trompo {

/// Controls of integrate_ensemble.
struct EnsembleOptions {
  /// Worker threads: 0 takes std::thread::hardware_concurrency(); never more than the
  /// members. 1 integrates every member on the calling thread (no thread is started).
  unsigned threads = 0;
  /// Each member's recovery of failed steps, as for integrate().
  IntegrateOptions integrate{};
  /// Members a thread takes from the shared counter at a time: 0 chooses
  /// ensemble_chunk(members, threads), about 16 chunks a thread (fewer than 64 members a
  /// chunk), so that an uneven sweep still ends with all threads busy.
  std::size_t chunk = 0;
  /// Progress of a long ensemble: called as progress(done, n) after each chunk a thread
  /// finishes (done: the members finished so far, of n), one call at a time and with done
  /// increasing, from the thread that finished the chunk; empty: no call. The members'
  /// results do not depend on it.
  std::function<void(std::size_t, std::size_t)> progress{};
};

/// The chunk integrate_ensemble takes at a time for `members` members on `threads` threads
/// when EnsembleOptions::chunk is 0: members/(16·threads), at least 1 and at most 64.
inline std::size_t ensemble_chunk(std::size_t members, unsigned threads) {
  const std::size_t c = members / (16 * std::size_t(threads ? threads : 1));
  return std::clamp<std::size_t>(c, 1, 64);
}

/// The number of threads integrate_ensemble uses for `members` members when
/// `requested` are asked for (0: the hardware's).
inline unsigned ensemble_threads(std::size_t members, unsigned requested) {
  unsigned t = requested ? requested : std::thread::hardware_concurrency();
  if (t == 0) t = 1;
  if (members < t) t = static_cast<unsigned>(members ? members : 1);
  return t;
}

namespace detail {

/// Calls run(i) for every i in [0, n) on ensemble_threads(n, options.threads) threads, the
/// members taken in chunks from a shared counter (the dynamic schedule of the file comment).
/// What run(i) throws is rethrown on the calling thread after all have finished (the first
/// member's in index order).
template <class Run>
void for_each_member(std::size_t n, const EnsembleOptions& options, Run&& run) {
  std::vector<std::exception_ptr> errors(n);
  const unsigned threads = ensemble_threads(n, options.threads);
  const std::size_t chunk = options.chunk ? options.chunk : ensemble_chunk(n, threads);
  std::atomic<std::size_t> next{0};  // the first member no thread has taken yet
  std::mutex progress_lock;          // one progress call at a time, done increasing
  std::size_t done = 0;              // members finished (under progress_lock)
  auto work = [&] {
    for (;;) {
      const std::size_t begin = next.fetch_add(chunk, std::memory_order_relaxed);
      if (begin >= n) return;
      const std::size_t end = std::min(n, begin + chunk);
      for (std::size_t i = begin; i < end; ++i) {
        try {
          run(i);
        } catch (...) {
          errors[i] = std::current_exception();
        }
      }
      if (options.progress) {
        const std::lock_guard<std::mutex> hold(progress_lock);
        done += end - begin;
        options.progress(done, n);
      }
    }
  };
  if (threads <= 1) {
    work();
  } else {
    // jthread: if starting a thread throws, the ones already started are joined on unwinding.
    std::vector<std::jthread> pool;
    pool.reserve(threads - 1);
    for (unsigned k = 1; k < threads; ++k) pool.emplace_back(work);
    work();  // the calling thread works too
    for (auto& t : pool) t.join();
  }
  for (std::size_t i = 0; i < n; ++i)
    if (errors[i]) std::rethrow_exception(errors[i]);
}

/// Runs member i for i in [0, n) with `stepper_of(i)`; see the file comment.
template <class StepperOf, class States, class Scalar>
std::vector<IntegrationSummary<Scalar>> run_ensemble(std::size_t n_steppers, StepperOf stepper_of, States& states,
                                                     Scalar t_end, Scalar h, const EnsembleOptions& options) {
  using std::isfinite;
  const std::size_t n = std::ranges::size(states);
  if (n_steppers != 1 && n_steppers != n)
    fail("integrate_ensemble: ", n_steppers, " steppers for ", n, " members (give 1 or one per member)");
  if (!isfinite(h) || h == Scalar(0)) fail("integrate_ensemble: time step h must be finite and non-zero, got ", h);
  if (!isfinite(t_end)) fail("integrate_ensemble: end time t_end must be finite, got ", t_end);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& s = states[i];
    try {
      s.validate();
    } catch (const invalid_input& e) {
      fail("integrate_ensemble: member ", i, ": ", e.what());
    }
    const Scalar span = t_end - s.time;
    if ((h > 0 && span < 0) || (h < 0 && span > 0))
      fail("integrate_ensemble: member ", i, ": end time t_end = ", t_end, " is behind its start t0 = ", s.time,
           " for the direction of h = ", h);
  }

  std::vector<IntegrationSummary<Scalar>> summaries(n);
  for_each_member(n, options, [&](std::size_t i) {
    auto local = states[i];  // stepped privately, written back once
    summaries[i] = integrate(stepper_of(i), local, t_end, h, NoObserver{}, options.integrate);
    states[i] = local;
  });
  return summaries;
}

}  // namespace detail

/// Integrates every state of `states` (a random-access range of State or Trajectory,
/// updated in place) from its own time to t_end with steps h, all with one stepper
/// (one scene). Returns one summary per member. See the file comment.
template <class StepperT, std::ranges::random_access_range States>
  requires(!std::ranges::range<StepperT>)
std::vector<IntegrationSummary<typename StepperT::Scalar>> integrate_ensemble(const StepperT& stepper, States& states,
                                                                               typename StepperT::Scalar t_end,
                                                                               typename StepperT::Scalar h,
                                                                               EnsembleOptions options = {}) {
  return detail::run_ensemble(1, [&](std::size_t) -> const StepperT& { return stepper; }, states, t_end, h, options);
}

/// Integrates member i of `states` with steppers[i] (per-member scenes of one scene
/// type: inertia, weight, effects), from its own time to t_end with steps h. The two
/// ranges have the same size. Returns one summary per member. See the file comment.
template <std::ranges::random_access_range Steppers, std::ranges::random_access_range States>
std::vector<IntegrationSummary<typename std::ranges::range_value_t<Steppers>::Scalar>> integrate_ensemble(
    const Steppers& steppers, States& states, typename std::ranges::range_value_t<Steppers>::Scalar t_end,
    typename std::ranges::range_value_t<Steppers>::Scalar h, EnsembleOptions options = {}) {
  const std::size_t n = std::ranges::size(steppers);
  if (n != std::ranges::size(states))
    detail::fail("integrate_ensemble: ", n, " steppers for ", std::ranges::size(states), " members (give one per member)");
  return detail::run_ensemble(
      n, [&](std::size_t i) -> const std::ranges::range_value_t<Steppers>& { return steppers[i]; }, states, t_end, h,
      options);
}

/// Adaptive members, all with one stepper: member i is exactly `solve(stepper, initials[i],
/// t_end, options, t_eval, events, dense)` (adaptive.hpp), one AdaptiveRun per member (its
/// states at t_eval or at every accepted step, its events, its dense solution if `dense`, its
/// summary), bit-identical to that single run whatever the threads and the chunk. Bad options
/// throw invalid_input before any member runs; a member whose run throws (t_eval outside its
/// span, bad events) makes the call throw once the others have finished.
template <class StepperT>
std::vector<AdaptiveRun<typename StepperT::Scalar>> solve_ensemble(
    const StepperT& stepper, const std::vector<State<typename StepperT::Scalar>>& initials,
    typename StepperT::Scalar t_end, const AdaptiveOptions<typename StepperT::Scalar>& options,
    const std::vector<typename StepperT::Scalar>& t_eval = {},
    const std::vector<Event<typename StepperT::Scalar>>& events = {}, bool dense = false,
    EnsembleOptions ensemble = {}) {
  options.validate();
  std::vector<AdaptiveRun<typename StepperT::Scalar>> runs(initials.size());
  detail::for_each_member(initials.size(), ensemble, [&](std::size_t i) {
    runs[i] = solve(stepper, initials[i], t_end, options, t_eval, events, dense);
  });
  return runs;
}

/// One closed-loop member's end: its state, its wheels' speeds relative to the body and the
/// motor torques held at the end (empty without wheels), its energy and total momentum on its
/// own scene (wheels included, [W3]), and what integrate_sampled did.
template <class Scalar>
struct SampledMember {
  State<Scalar> state;                                          ///< at summary.time
  typename ReactionWheels<Scalar>::WheelVector wheel_speeds;    ///< Ω_i at the end (rad/s)
  typename ReactionWheels<Scalar>::WheelVector wheel_torques;   ///< u_i held at the end (N m)
  Scalar energy = Scalar(0);                                    ///< Scene::energy at the end
  Eigen::Matrix<Scalar, 3, 1> spatial_momentum = Eigen::Matrix<Scalar, 3, 1>::Zero();  ///< π at the end
  SampledSummary<Scalar> summary;                               ///< samples, steps, why it stopped
};

namespace detail {
/// No per-member parameters.
struct NoSetup {
  template <class StepperT, class Controller>
  void operator()(std::size_t, StepperT&, Controller&) const {}
};
}  // namespace detail

/// Closed-loop members: member i is integrate_sampled(stepper_i, state_i, t_end, period,
/// controller_i, between) (sampled.hpp) from initials[i], where stepper_i and controller_i are
/// copies of `stepper` and `controller`, the scene's wheels (if any) started at initials[i]
/// (ReactionWheels::start: their initial speeds), then `setup(i, stepper_i, controller_i)`
/// (per-member wheel speeds, gains, limits). Each member's result is that single run's, bit
/// for bit, whatever the threads and the chunk. Throws invalid_input for a bad period or t_end
/// before any member runs; a member whose run throws (its state not finite) makes the call
/// throw once the others have finished.
template <class StepperT, class Controller, class Between, class Setup = detail::NoSetup>
std::vector<SampledMember<typename StepperT::Scalar>> integrate_sampled_ensemble(
    const StepperT& stepper, const std::vector<State<typename StepperT::Scalar>>& initials,
    typename StepperT::Scalar t_end, typename StepperT::Scalar period, const Controller& controller,
    const Between& between, EnsembleOptions ensemble = {}, Setup setup = {}) {
  using Scalar = typename StepperT::Scalar;
  using Scene = std::decay_t<decltype(stepper.scene())>;
  if (!std::isfinite(static_cast<double>(period)) || !(period > Scalar(0)))
    detail::fail("integrate_sampled_ensemble: control period must be finite and > 0, got ", period);
  if (!std::isfinite(static_cast<double>(t_end))) detail::fail("integrate_sampled_ensemble: t_end must be finite, got ", t_end);
  std::vector<SampledMember<Scalar>> members(initials.size());
  detail::for_each_member(initials.size(), ensemble, [&](std::size_t i) {
    StepperT own = stepper;         // its scene: the wheels' hold and the held commands
    Controller control = controller;  // its memory
    State<Scalar> s = initials[i];
    if constexpr (Scene::has_wheels) own.scene().template effect<ReactionWheels<Scalar>>().start(s.time, s.omega);
    setup(i, own, control);
    SampledMember<Scalar>& m = members[i];
    m.summary = integrate_sampled(own, s, t_end, period, control, between);
    m.state = s;
    if constexpr (Scene::has_wheels) {
      const auto& rw = own.scene().template effect<ReactionWheels<Scalar>>();
      m.wheel_speeds = rw.speeds(s.time, s.omega);
      m.wheel_torques = rw.torques();
    }
    m.energy = own.scene().energy(s);
    m.spatial_momentum = own.scene().spatial_momentum(s);
  });
  return members;
}

}  // namespace trompo
