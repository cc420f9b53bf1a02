// trompo-bench-ensemble: what integrate_ensemble (ensemble.hpp) costs and gains.
//
// The ensemble: 10^4 HT1-like tops (J = diag(5, 5, 1), Mgl = 20; tilt 0.02..0.4 rad, a
// little transverse spin, axial spin 30..60 rad/s, drawn from a fixed seed), 10^3 Simo-κ
// steps of h = 0.001 each (t_end = 1): 10^7 member-steps per run.
//
//   BM_SingleTrajectory      one top at a time through integrate(), cycling over the same
//                            10^4 tops: the cost of one step of a single run
//   BM_Ensemble/threads:T    integrate_ensemble over all 10^4 tops with T threads
//                            (wall time: UseRealTime)
//   BM_Sweep/threads:T/shuffled:S  a sweep whose members' costs rise along it (spin 5 … 400
//                            rad/s), in order or shuffled: the dynamic schedule's case
//
// Counters: ns_per_member_step (time / member-steps; the ensembles': wall time), and for
// the ensembles cpu_ns_per_member_step (CPU time of all threads / member-steps). The targets of issue 14: on one
// core the ensemble's ns_per_member_step ≤ 1.05 × the single trajectory's; on 2 cores
// throughput ≥ 1.8 × one core, i.e. BM_Ensemble/threads:1 time ≥ 1.8 × threads:2 time.
//
//   build/bench/trompo-bench-ensemble --benchmark_repetitions=3
//
// The machine is shared: run it a few times (repetitions), compare medians.
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <random>
#include <vector>

#include "trompo/drivers/ensemble.hpp"
#include "trompo/trompo.hpp"

namespace {

using namespace trompo;
using Vec3 = Eigen::Vector3d;
using Top = HeavyTop<double>;

constexpr std::size_t kMembers = 10000;
constexpr double kH = 0.001, kTEnd = 1.0;  // 10^3 steps
constexpr double kSteps = 1000;

const std::vector<State<double>>& members() {
  static const std::vector<State<double>> m = [] {
    std::mt19937_64 rng(14);
    std::uniform_real_distribution<double> tilt(0.02, 0.4), spin(30, 60), wobble(-0.5, 0.5);
    std::vector<State<double>> out(kMembers);
    for (auto& s : out) {
      s.rotation = SO3d::exp(Vec3(tilt(rng), 0.1 * wobble(rng), 0));
      s.omega = Vec3(wobble(rng), wobble(rng), spin(rng));
    }
    return out;
  }();
  return m;
}

const Stepper<SimoKappa, Top>& stepper() {
  static const Stepper<SimoKappa, Top> s(SimoKappa{}, cases::ht1<double>().scene);
  return s;
}

void BM_SingleTrajectory(benchmark::State& state) {
  const auto& m = members();
  std::size_t k = 0;
  for (auto _ : state) {
    State<double> s = m[k];
    const auto sum = integrate(stepper(), s, kTEnd, kH);
    benchmark::DoNotOptimize(s);
    if (!sum.ok()) state.SkipWithError("a member failed");
    k = (k + 1) % m.size();
  }
  state.counters["ns_per_member_step"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * kSteps * 1e-9, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_SingleTrajectory)->Unit(benchmark::kMicrosecond)->MinTime(3.0);

/// CPU time of the whole process (every thread), in seconds.
double process_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

void BM_Ensemble(benchmark::State& state) {
  const unsigned threads = static_cast<unsigned>(state.range(0));
  double cpu = 0;  // all threads
  for (auto _ : state) {
    state.PauseTiming();
    std::vector<State<double>> m = members();
    state.ResumeTiming();
    const double cpu0 = process_cpu_seconds();
    const auto sums = integrate_ensemble(stepper(), m, kTEnd, kH, {.threads = threads});
    cpu += process_cpu_seconds() - cpu0;
    benchmark::DoNotOptimize(m.data());
    for (const auto& s : sums)
      if (!s.ok()) state.SkipWithError("a member failed");
  }
  state.counters["ns_per_member_step"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * kMembers * kSteps * 1e-9,
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  // CPU time summed over the threads per member-step: equal for 1 and 2 threads when
  // threading costs nothing (no contention, no false sharing), whatever else runs.
  state.counters["cpu_ns_per_member_step"] =
      cpu * 1e9 / (static_cast<double>(state.iterations()) * kMembers * kSteps);
  state.counters["member_steps_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()) * kMembers * kSteps,
                                                            benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Ensemble)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);

/// A parameter sweep whose members' costs rise along the range: axial spin 5 … 400 rad/s in
/// order (Newton needs more iterations at larger hΩ), 2,000 tops, t_end = 0.5; `shuffled`
/// gives the same members in a fixed random order.
const std::vector<State<double>>& sweep(bool shuffled) {
  static const auto make = [](bool shuffle) {
    constexpr std::size_t n = 2000;
    std::vector<State<double>> out(n);
    for (std::size_t i = 0; i < n; ++i) {
      out[i].rotation = SO3d::exp(Vec3(0.2, 0, 0));
      out[i].omega = Vec3(0.1, 0, 5 + 395 * static_cast<double>(i) / (n - 1));
    }
    if (shuffle) std::shuffle(out.begin(), out.end(), std::mt19937_64(37));
    return out;
  };
  static const std::vector<State<double>> in_order = make(false), mixed = make(true);
  return shuffled ? mixed : in_order;
}

/// The sweep in order (range(1) = 0) or shuffled (1) with range(0) threads. Compare each
/// one's threads:2 against threads:1: the dynamic schedule (ensemble.hpp) should give the
/// in-order sweep the shuffled one's speed-up (issue 37: within 5 %).
void BM_Sweep(benchmark::State& state) {
  const unsigned threads = static_cast<unsigned>(state.range(0));
  const bool shuffled = state.range(1) != 0;
  for (auto _ : state) {
    state.PauseTiming();
    std::vector<State<double>> m = sweep(shuffled);
    state.ResumeTiming();
    const auto sums = integrate_ensemble(stepper(), m, 0.5, kH, {.threads = threads});
    benchmark::DoNotOptimize(m.data());
    for (const auto& s : sums)
      if (!s.ok()) state.SkipWithError("a member failed");
  }
}
BENCHMARK(BM_Sweep)
    ->ArgNames({"threads", "shuffled"})
    ->ArgsProduct({{1, 2}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
