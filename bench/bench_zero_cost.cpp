// trompo-bench-zero-cost: an effect a scene does not list costs nothing (scene.hpp).
//
// Per-step time of one Simo-κ step on the free body (J = diag(1, 2, 3), h = 0.01), as
//   free            FreeScene<double>: no effect at all
//   zero_gravity    Scene<double, UniformGravity>, Mgl = 0: same motion, but the step
//                   computes a (zero) torque, its Jacobian and κ terms
//   zero_effects    Scene with damping c = 0, body and space torques 0 and a rotor h_r = 0
//                   listed: same motion, the step adds zeros
//   hand_written    the free-body step written out below with Eigen alone: the same
//                   equations, predictor, Newton criteria and branch checks as the
//                   library's, without scenes, effects or the stepper
// Expected: free ≈ hand_written (the abstraction compiles away), free < zero_gravity.
//
// BM_ZeroCostRatios interleaves blocks of 256 steps of the four variants from the same
// start (so each block does identical work) and reports per-step times (minimum and
// median over blocks) and their ratios as counters, plus the heap allocations counted
// during the steps (operator new is replaced in this file) and the largest difference
// between the free scene's and the hand-written step's final states.
//
//   build/report/bench/trompo-bench-zero-cost --benchmark_filter=Ratios
//
// BM_CompensatedCost/k: what the compensated state costs a Simo-κ step of HT0 at h = 10^−k
// (BM_CompensatedCostLgvi/k: an LGVI step of FB1)
// (plain and compensated trajectories in interleaved blocks; docs/theory.md §18).
//
//   build/report/bench/trompo-bench-zero-cost --benchmark_filter=Compensated
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <vector>

#include "trompo/trompo.hpp"

// ---- heap allocation counter ----------------------------------------------------------------
namespace {
std::atomic<long> g_allocations{0};
}  // namespace
void* operator new(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
// GCC sees free() of memory from `new` once these are inlined; they are a matched pair.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

namespace {

using trompo::State;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

constexpr double kH = 0.01;
constexpr int kBlock = 256;

trompo::RigidBody<double> body() { return trompo::RigidBody<double>(Vec3(1, 2, 3)); }
State<double> start() {
  State<double> s;
  s.rotation = trompo::SO3d::exp(Vec3(0.2, -0.1, 0.3));
  s.omega = Vec3(0.4, 1.5, -0.7);
  return s;
}

using Free = trompo::FreeScene<double>;
using ZeroGravity = trompo::Scene<double, trompo::UniformGravity<double>>;
using ZeroEffects = trompo::Scene<double, trompo::ViscousDamping<double>, trompo::ConstantBodyTorque<double>,
                                  trompo::ConstantSpaceTorque<double>, trompo::Rotor<double>>;

const trompo::Stepper<trompo::SimoKappa, Free>& free_stepper() {
  static const trompo::Stepper<trompo::SimoKappa, Free> s(trompo::SimoKappa{}, Free(body()));
  return s;
}
const trompo::Stepper<trompo::SimoKappa, ZeroGravity>& zero_gravity_stepper() {
  static const trompo::Stepper<trompo::SimoKappa, ZeroGravity> s(
      trompo::SimoKappa{}, ZeroGravity(body(), trompo::UniformGravity<double>(0.0, Vec3::UnitZ())));
  return s;
}
const trompo::Stepper<trompo::SimoKappa, ZeroEffects>& zero_effects_stepper() {
  static const trompo::Stepper<trompo::SimoKappa, ZeroEffects> s(
      trompo::SimoKappa{}, ZeroEffects(body(), trompo::ViscousDamping<double>(0.0),
                                       trompo::ConstantBodyTorque<double>(Vec3::Zero()),
                                       trompo::ConstantSpaceTorque<double>(Vec3::Zero()),
                                       trompo::Rotor<double>(Vec3::Zero())));
  return s;
}

// ---- the hand-written free-body Simo step ------------------------------------------------------
/// Θ solves exp(Θ̂) J Ω_{n+1} = J Ω_n with Ω_{n+1} = 2Θ/h − Ω_n ([T1] without load).
/// Unknown y = Θ − hΩ_n; residual in the cross-product form exp(Θ̂)Π − Π_n =
/// (2/h)Jy + aΘ×Π + bΘ×(Θ×Π); tangent exp(Θ̂)[(2/h)J − Π̂ T(Θ)] ([T3]).
struct HandWritten {
  Vec3 J;     // principal moments (J diagonal)
  Mat3 Jm;    // J as a matrix
  Vec3 Jinv;  // their inverses

  static Mat3 hat(const Vec3& x) {
    Mat3 m;
    m << 0, -x.z(), x.y(), x.z(), 0, -x.x(), -x.y(), x.x(), 0;
    return m;
  }

  /// Returns false (and leaves s) if Newton fails or a branch check rejects the root.
  /// The Newton iteration is the library's (newton.hpp) with its default options: one
  /// tangent, chord steps with the kept inverse while corrections are below 1e-3 of the
  /// increment, and acceptance by the measured contraction.
  bool step(State<double>& s, double h) const {
    constexpr double eps = std::numeric_limits<double>::epsilon();
    const double tiny = std::numeric_limits<double>::min() / eps;
    const Vec3 w = s.omega;
    const Vec3 Pi_n = J.cwiseProduct(w);
    const double Pi_n_norm = Pi_n.norm();
    // predictor Θ⁰ = hΩ + (h²/2) J⁻¹ (Π × Ω)
    const Vec3 Theta0 = h * w + (h * h / 2) * Jinv.cwiseProduct(Pi_n.cross(w));
    const double size = Theta0.norm() + tiny;
    Vec3 y = Theta0 - h * w;
    Mat3 K = Mat3::Zero(), K_inv = Mat3::Zero();
    Vec3 R;
    double r = 0, scale = 1;
    // Residual, and the tangent if asked.
    const auto eval = [&](bool tangent) {
      const Vec3 Theta = h * w + y;
      const double th = Theta.norm();
      const trompo::detail::HalfAngle<double> ha = trompo::detail::half_angle(th);
      const double a = ha.sinc(), b = ha.one_minus_cos_over_sq();
      const Vec3 dPi = (2 / h) * J.cwiseProduct(y);
      const Vec3 Pi = Pi_n + dPi;
      const Vec3 c1 = Theta.cross(Pi);
      R = dPi + a * c1 + b * Theta.cross(c1);
      scale = Pi_n_norm + Pi.norm();
      r = R.norm();
      if (tangent) {
        const double c = trompo::detail::theta_minus_sin_over_cube(th);
        const Mat3 X = hat(Theta), X2 = trompo::SO3d::hat_squared(Theta);
        const Mat3 Q = Mat3::Identity() + a * X + b * X2;
        const Mat3 T = Mat3::Identity() - b * X + c * X2;
        K = Q * ((2 / h) * Jm - hat(Pi) * T);
      }
    };
    double last = std::numeric_limits<double>::infinity(), r_prev = last;
    bool last_fresh = true, converged = false;
    int iterations = 0;
    for (int k = 0;; ++k) {
      bool fresh = k == 0 || !(last <= 1e-3 * size);
      eval(fresh);
      if (!std::isfinite(r) || (fresh && !std::isfinite(K.sum()))) return false;
      const bool small_step = k == 0 ? r == 0.0 : last_fresh && last <= std::sqrt(eps) * size;
      if (r <= 64 * eps * scale && small_step) {
        converged = true;
        break;
      }
      if (k > 0 && last <= 8 * eps * size && r <= std::sqrt(eps) * scale) {
        converged = true;
        break;
      }
      if (iterations >= 25) return false;
      if (!fresh && !last_fresh && !(r <= r_prev / 10)) {
        fresh = true;
        eval(true);
        if (!std::isfinite(K.sum())) return false;
      }
      if (fresh && !trompo::detail::invert_unless_singular(K, K_inv)) return false;
      const Vec3 dy = -(K_inv * R);
      y += dy;
      const double step = dy.norm();
      ++iterations;
      if (k > 0) {
        const double rho = r / r_prev;
        const bool estimated = fresh == last_fresh && rho <= 0.01 && rho * step <= eps * size / 1024;
        const bool at_roundoff = !fresh && last_fresh && rho <= 1e-6 && step <= 8 * eps * size;
        if (estimated || at_roundoff) {
          converged = true;
          break;
        }
      }
      last = step;
      last_fresh = fresh;
      r_prev = r;
    }
    if (!converged) return false;
    const Vec3 Theta = h * w + y;
    if (!(Theta.norm() < 0.999 * 3.14159265358979323846) || !((Theta - Theta0).norm() <= 1.0) ||
        !(K.determinant() * h > 0))
      return false;
    // Λ_{n+1} = Λ_n exp(Θ̂), Ω_{n+1} = Ω_n + 2y/h (9)
    s.rotation = s.rotation * trompo::SO3d::exp(Theta);
    s.omega = w + 2 * y / h;
    s.time += h;
    return true;
  }
};

const HandWritten& hand_written() {
  static const HandWritten hw{Vec3(1, 2, 3), Mat3(Vec3(1, 2, 3).asDiagonal()), Vec3(1, 0.5, 1.0 / 3)};
  return hw;
}

// ---- per-variant benchmarks ----------------------------------------------------------------------
template <class StepperT>
void run_steps(benchmark::State& st, const StepperT& stepper) {
  State<double> s = start();
  long failures = 0;
  for (auto _ : st) {
    if (!stepper.step(s, kH).ok()) {
      ++failures;
      s = start();
    }
    benchmark::DoNotOptimize(s);
  }
  st.SetItemsProcessed(st.iterations());
  st.counters["failures"] = static_cast<double>(failures);
}

void BM_Free(benchmark::State& st) { run_steps(st, free_stepper()); }
void BM_ZeroGravity(benchmark::State& st) { run_steps(st, zero_gravity_stepper()); }
void BM_ZeroEffects(benchmark::State& st) { run_steps(st, zero_effects_stepper()); }
void BM_HandWritten(benchmark::State& st) {
  State<double> s = start();
  long failures = 0;
  for (auto _ : st) {
    if (!hand_written().step(s, kH)) {
      ++failures;
      s = start();
    }
    benchmark::DoNotOptimize(s);
  }
  st.SetItemsProcessed(st.iterations());
  st.counters["failures"] = static_cast<double>(failures);
}
BENCHMARK(BM_Free);
BENCHMARK(BM_ZeroGravity);
BENCHMARK(BM_ZeroEffects);
BENCHMARK(BM_HandWritten);

// ---- interleaved blocks and ratios ------------------------------------------------------------------
/// ns per step of one block of kBlock steps from `s0`; the final state goes to `out`.
template <class F>
double time_block(F&& step, const State<double>& s0, State<double>& out) {
  State<double> s = s0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < kBlock; ++k) {
    step(s);
    benchmark::DoNotOptimize(s);
  }
  const auto t1 = std::chrono::steady_clock::now();
  out = s;
  return std::chrono::duration<double, std::nano>(t1 - t0).count() / kBlock;
}

double median(std::vector<double>& v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

void BM_ZeroCostRatios(benchmark::State& st) {
  constexpr int kVariants = 4;
  std::vector<double> times[kVariants];
  for (auto& t : times) t.reserve(1 << 16);
  const auto step_free = [](State<double>& s) { (void)free_stepper().step(s, kH); };
  const auto step_gravity = [](State<double>& s) { (void)zero_gravity_stepper().step(s, kH); };
  const auto step_effects = [](State<double>& s) { (void)zero_effects_stepper().step(s, kH); };
  const auto step_hand = [](State<double>& s) { (void)hand_written().step(s, kH); };
  State<double> s0 = start(), out[kVariants];
  long allocations = 0, steps = 0, round = 0;
  double max_diff = 0;
  for (auto _ : st) {
    // Rotate the order each round so that no variant always runs first (warm caches).
    for (int j = 0; j < kVariants; ++j) {
      const int v = static_cast<int>((j + round) % kVariants);
      const long a0 = g_allocations.load();
      double t = 0;
      switch (v) {
        case 0: t = time_block(step_free, s0, out[0]); break;
        case 1: t = time_block(step_gravity, s0, out[1]); break;
        case 2: t = time_block(step_effects, s0, out[2]); break;
        default: t = time_block(step_hand, s0, out[3]); break;
      }
      allocations += g_allocations.load() - a0;
      times[v].push_back(t);
    }
    steps += kVariants * kBlock;
    max_diff = std::max({max_diff, (out[0].omega - out[3].omega).norm(),
                         (out[0].rotation.matrix() - out[3].rotation.matrix()).norm()});
    s0 = out[0];  // walk along the trajectory (all variants agree on it)
    ++round;
  }
  double mn[kVariants], md[kVariants];
  for (int v = 0; v < kVariants; ++v) {
    mn[v] = *std::min_element(times[v].begin(), times[v].end());
    md[v] = median(times[v]);
  }
  auto& c = st.counters;
  c["free_ns"] = md[0];
  c["zero_gravity_ns"] = md[1];
  c["zero_effects_ns"] = md[2];
  c["hand_ns"] = md[3];
  c["zero_gravity/free"] = md[1] / md[0];
  c["zero_effects/free"] = md[2] / md[0];
  c["free/hand"] = md[0] / md[3];
  c["min:zero_gravity/free"] = mn[1] / mn[0];
  c["min:zero_effects/free"] = mn[2] / mn[0];
  c["min:free/hand"] = mn[0] / mn[3];
  c["heap_allocs_per_step"] = static_cast<double>(allocations) / static_cast<double>(steps);
  c["max|free-hand|"] = max_diff;
}
BENCHMARK(BM_ZeroCostRatios)->Iterations(400)->Unit(benchmark::kMillisecond);

// ---- the compensated state's cost (docs/theory.md §18) --------------------------------------------
/// `Scheme` on `c` at h (state.range(0) = −log10 h): blocks of 256 steps of a plain and of a
/// compensated Trajectory, interleaved, each walking its own trajectory. Reports the median
/// per-step times, their ratio and the heap allocations per step.
template <class Scheme, class Case>
void compensated_cost(benchmark::State& st, const Case& c) {
  const double h = std::pow(10.0, -static_cast<double>(st.range(0)));
  Scheme plain, compensated;
  compensated.compensated = true;
  using SceneT = std::decay_t<decltype(c.scene)>;
  const trompo::Stepper<Scheme, SceneT> st_plain(plain, c.scene), st_comp(compensated, c.scene);
  auto traj_plain = st_plain.start(c.initial);
  auto traj_comp = st_comp.start(c.initial);
  std::vector<double> times[2];
  long allocations = 0, steps = 0, round = 0;
  for (auto _ : st) {
    for (int j = 0; j < 2; ++j) {
      const int v = static_cast<int>((j + round) % 2);  // alternate which runs first
      const long a0 = g_allocations.load();
      const auto t0 = std::chrono::steady_clock::now();
      for (int k = 0; k < kBlock; ++k) {
        if (v == 0) (void)st_plain.step(traj_plain, h);
        else (void)st_comp.step(traj_comp, h);
      }
      const auto t1 = std::chrono::steady_clock::now();
      allocations += g_allocations.load() - a0;
      times[v].push_back(std::chrono::duration<double, std::nano>(t1 - t0).count() / kBlock);
    }
    benchmark::DoNotOptimize(traj_plain);
    benchmark::DoNotOptimize(traj_comp);
    steps += 2 * kBlock;
    ++round;
  }
  const double plain_ns = median(times[0]), comp_ns = median(times[1]);
  st.counters["plain_ns"] = plain_ns;
  st.counters["compensated_ns"] = comp_ns;
  st.counters["compensated/plain"] = comp_ns / plain_ns;
  st.counters["heap_allocs_per_step"] = static_cast<double>(allocations) / static_cast<double>(steps);
}
/// Simo-κ on HT0.
void BM_CompensatedCost(benchmark::State& st) { compensated_cost<trompo::SimoKappa>(st, trompo::cases::ht0<double>()); }
BENCHMARK(BM_CompensatedCost)->Arg(2)->Arg(3)->Arg(5)->Iterations(400)->Unit(benchmark::kMillisecond);
/// The LGVI on FB1 (the compensated state of its Π, theory §18).
void BM_CompensatedCostLgvi(benchmark::State& st) { compensated_cost<trompo::LGVI>(st, trompo::cases::fb1<double>()); }
BENCHMARK(BM_CompensatedCostLgvi)->Arg(2)->Arg(3)->Iterations(400)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
