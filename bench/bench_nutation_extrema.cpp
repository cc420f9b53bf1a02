// trompo-bench-nutation-extrema: how close the adaptive driver's events come to the true
// nutation extrema of HT0 (issue 37's targets: the first 200 extrema within 1e-11 s, and
// 10⁴ nutation maxima, t ≈ 11,800, within 1e-9 s; docs/adaptive.md "Nutation extrema").
//
//   trompo-bench-nutation-extrema                    # 200 extrema (t ≤ 100.25 T ≈ 116), every configuration
//   trompo-bench-nutation-extrema --long             # 10⁴ maxima (t ≤ 9999.75 T ≈ 11,600)
//   trompo-bench-nutation-extrema --config s6,s8 --rtol 1e-10,1e-11   # a selection
//   trompo-bench-nutation-extrema --config split6-rev --max-step 1e-3  # AdaptiveOptions::max_step
//
// The truth is independent of the library: HT0 starts with Ω = (0, 0, 50), so u̇ = 0 at
// t = 0 (a tilt minimum) and the extrema lie at k·T/2 exactly, T = 2K(m)/λ the nutation
// period. T is computed here in long double from the initial state (u = γ·ΛE = cos θ obeys
// u̇² = f(u) = (u0 − u)[β(1 − u²) − b²(u0 − u)], β = 2Mgl/A, b = CΩ3/A; its roots
// u1 < u2 = u0 < u3, 4λ² = β(u3 − u1), m = (u2 − u1)/(u3 − u1), K by the AGM), and
// compared with exact::LagrangeTop's nutation_period() and tilt_turning_time().
//
// One row per configuration: the extrema found/expected, the largest |t_found − t_exact|
// over the maxima and the minima (and up to t = 50 for the short run), accepted steps and
// CPU seconds (std::clock). Exit status 0 always: it measures, the tests assert.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "trompo/drivers/adaptive.hpp"
#include "trompo/exact/lagrange_top.hpp"
#include "trompo/trompo.hpp"

namespace {

using namespace trompo;
using Top = cases::Top<double>;

// The nutation period of HT0 in long double (file comment).
long double period_long_double(const cases::Case<Top>& c) {
  const auto& g = c.scene.effect<UniformGravity<double>>();
  const auto& q = c.initial.rotation.unit_quaternion();
  const long double w = q.w(), x = q.x(), y = q.y(), z = q.z();
  const long double u0 = (w * w + z * z - x * x - y * y) / (w * w + x * x + y * y + z * z);  // Λ(2,2) = γ·ΛE
  const long double A = 5.0L, C = 1.0L, Mgl = g.Mgl(), Om3 = c.initial.omega(2);
  const long double beta = 2.0L * Mgl / A, b = C * Om3 / A, b2 = b * b;
  // β(1 − u²) − b²(u0 − u) = 0  ⇔  βu² − b²u + (b²u0 − β) = 0
  const long double disc = std::sqrt(b2 * b2 - 4.0L * beta * (b2 * u0 - beta));
  const long double u1 = (b2 - disc) / (2.0L * beta), u3 = (b2 + disc) / (2.0L * beta);
  const long double lambda = 0.5L * std::sqrt(beta * (u3 - u1));
  const long double m = (u0 - u1) / (u3 - u1);
  long double a0 = 1.0L, b0 = std::sqrt(1.0L - m);
  for (int i = 0; i < 40 && a0 != b0; ++i) {
    const long double an = 0.5L * (a0 + b0);
    b0 = std::sqrt(a0 * b0);
    a0 = an;
  }
  const long double K = 3.14159265358979323846264338327950288L / (2.0L * a0);
  return 2.0L * K / lambda;
}

struct Row {
  std::string config;
  double rtol = 0;
  std::size_t found_max = 0, found_min = 0, want_max = 0, want_min = 0;
  double err_max = 0, err_min = 0, err_early = 0;
  long long steps = 0;
  double cpu = 0;
  double dH = 0, dmu = 0, dOm3 = 0;  // relative drift at t_end
  bool ok = true;
};

struct Config {
  std::string name, what;
};

const std::vector<Config>& configs() {
  static const std::vector<Config> all{
      {"s6", "Simo-k Kahan-Li-9 (order 6), tolerance control, H and mu held"},
      {"s6-unheld", "the same, hold_invariants = false"},
      {"s6c", "the same, compensated state, held"},
      {"s6c-unheld", "the same, compensated state, hold_invariants = false"},
      {"s8", "Simo-k Kahan-Li-17 (order 8; step doubling), tolerance control, held"},
      {"s8c-unheld", "the same, compensated state, hold_invariants = false"},
      {"split6", "splitting chin-triple-jump (order 6), tolerance control (Richardson m = 8)"},
      {"split6-rev", "splitting chin-triple-jump (order 6), reversible control"},
      {"split6-rev-unheld", "the same, hold_invariants = false"},
      {"s6-rev", "Simo-k Kahan-Li-9 (order 6), reversible control"},
      {"s6c-l3", "Simo-k Kahan-Li-9, compensated, H, mu and the Lagrange top's Omega3 held [A9]"},
      {"s8c-l3", "Simo-k Kahan-Li-17 (order 8), compensated, H, mu and Omega3 held [A9]"},
      {"s6-rev-l3", "Simo-k Kahan-Li-9, reversible control, H, mu and Omega3 held [A9]"},
  };
  return all;
}

template <class Stepper>
Row measure(const std::string& name, const Stepper& stepper, const cases::Case<Top>& c, AdaptiveOptions<double> opt,
            long double T, bool long_run) {
  Row r;
  r.config = name;
  r.rtol = opt.rtol;
  // Short: 100 maxima and 100 minima (t ≤ 100.25 T). Long: 10⁴ maxima (t ≤ 9999.75 T).
  const long double t_end = long_run ? 9999.75L * T : 100.25L * T;
  std::vector<Event<double>> ev{events::nutation(c.scene, true)};
  if (!long_run) ev.push_back(events::nutation(c.scene, false));
  const std::clock_t c0 = std::clock();
  // t_eval = {t_end}: one state kept (an empty t_eval would keep every accepted step).
  const AdaptiveRun<double> run =
      solve(stepper, c.initial, static_cast<double>(t_end), opt, {static_cast<double>(t_end)}, ev, false);
  r.cpu = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  r.ok = run.success();
  r.steps = static_cast<long long>(run.summary.accepted);
  if (!run.states.empty()) {  // the invariants' drift at the end (H, μ = γ·π, Ω3: the third integral)
    const State<double>& e = run.states.back();
    const double H0 = c.scene.energy(c.initial), mu0 = c.scene.momentum_axis().dot(c.scene.spatial_momentum(c.initial));
    r.dH = std::abs(c.scene.energy(e) - H0) / std::abs(H0);
    r.dmu = std::abs(c.scene.momentum_axis().dot(c.scene.spatial_momentum(e)) - mu0) / std::abs(mu0);
    r.dOm3 = std::abs(e.omega(2) - c.initial.omega(2)) / std::abs(c.initial.omega(2));
  }
  const auto worst = [&](const std::vector<State<double>>& found, long double offset, std::size_t& want,
                         std::size_t& got, double& early) {
    double e = 0;
    want = 0;
    while ((static_cast<long double>(want) + 1 + offset) * T < t_end) ++want;
    got = found.size();
    for (std::size_t k = 0; k < std::min(want, got); ++k) {
      const long double t = (static_cast<long double>(k) + 1 + offset) * T;
      const double d = static_cast<double>(std::abs(static_cast<long double>(found[k].time) - t));
      e = std::max(e, d);
      if (t <= 50) early = std::max(early, d);
    }
    if (got != want) e = std::numeric_limits<double>::infinity();
    return e;
  };
  r.err_max = worst(run.events[0], -0.5L, r.want_max, r.found_max, r.err_early);
  if (!long_run) r.err_min = worst(run.events[1], 0.0L, r.want_min, r.found_min, r.err_early);
  return r;
}

Row run_config(const std::string& name, double rtol, double max_step, const cases::Case<Top>& c, long double T,
               bool long_run) {
  AdaptiveOptions<double> opt;
  opt.rtol = opt.atol = rtol;
  if (max_step > 0) opt.max_step = max_step;
  SimoKappa sk;
  if (name.find("unheld") != std::string::npos) opt.hold_invariants = false;
  if (name.rfind("s6c", 0) == 0 || name.rfind("s8c", 0) == 0) sk.compensated = true;
  if (name.find("-rev") != std::string::npos) opt.control = StepControl::reversible;
  if (name.find("-l3") != std::string::npos) opt.hold_third_integral = true;
  if (name.rfind("split6", 0) == 0)
    return measure(name, Stepper<Splitting, Top>(Splitting(SplittingMethod::chin_triple_jump), c.scene), c, opt, T,
                   long_run);
  if (name.rfind("s8", 0) == 0)
    return measure(name, ComposedStepper<SimoKappa, Top>(sk, c.scene, Composition::kahan_li17), c, opt, T, long_run);
  if (name.rfind("s6", 0) == 0)
    return measure(name, ComposedStepper<SimoKappa, Top>(sk, c.scene, 6), c, opt, T, long_run);
  std::fprintf(stderr, "unknown configuration %s\n", name.c_str());
  std::exit(2);
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ',')) out.push_back(item);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  bool long_run = false;
  std::vector<std::string> names;
  std::vector<double> rtols;
  double max_step = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--long") {
      long_run = true;
    } else if (a == "--config" && i + 1 < argc) {
      names = split(argv[++i]);
    } else if (a == "--max-step" && i + 1 < argc) {
      max_step = std::strtod(argv[++i], nullptr);
    } else if (a == "--rtol" && i + 1 < argc) {
      for (const auto& t : split(argv[++i])) rtols.push_back(std::strtod(t.c_str(), nullptr));
    } else {
      std::fprintf(stderr, "usage: %s [--long] [--config NAME,...] [--rtol R,...] [--max-step H]\nconfigurations:\n", argv[0]);
      for (const auto& cf : configs()) std::fprintf(stderr, "  %-17s %s\n", cf.name.c_str(), cf.what.c_str());
      return 2;
    }
  }
  if (names.empty())
    for (const auto& cf : configs()) names.push_back(cf.name);
  if (rtols.empty()) rtols = long_run ? std::vector<double>{1e-9} : std::vector<double>{1e-10, 1e-11, 1e-12};

  const auto c = cases::ht0();
  const auto& g = c.scene.effect<UniformGravity<double>>();
  const exact::LagrangeTop top(5, 1, g.Mgl(), c.initial.rotation.matrix(), c.initial.omega, g.up());
  const long double T = period_long_double(c);
  std::printf("HT0 nutation period T = %.18Lf s (long double); closed form %.17g (diff %.2e s, x 1e4 periods %.2e s)\n", T,
              top.nutation_period(), static_cast<double>(static_cast<long double>(top.nutation_period()) - T),
              static_cast<double>(1e4L * (static_cast<long double>(top.nutation_period()) - T)));
  long j0 = 0;
  for (long j = -8; j <= 8; ++j)
    if (std::abs(top.tilt_turning_time(j)) < std::abs(top.tilt_turning_time(j0))) j0 = j;
  std::printf("closed form: turning point at t = %.3e (j = %ld); its 20000th after it off k*T/2 by %.2e s\n",
              top.tilt_turning_time(j0), j0,
              static_cast<double>(static_cast<long double>(top.tilt_turning_time(j0 + 20000)) - 10000.0L * T));
  std::printf("%s: %s\n", long_run ? "10^4 maxima, t_end = 9999.75 T" : "200 extrema, t_end = 100.25 T",
              long_run ? "error over all maxima" : "error over maxima / minima / up to t = 50");
  std::printf("%-17s %7s %13s %10s %10s %10s %10s %9s %9s %9s %9s\n", "config", "rtol", "found/want", "err max",
              "err min", "err t<=50", "steps", "CPU s", "dH/H", "dmu/mu", "dOm3/Om3");
  for (const auto& n : names)
    for (const double rt : rtols) {
      const Row r = run_config(n, rt, max_step, c, T, long_run);
      std::printf("%-17s %7.0e %6zu/%-6zu %10.2e %10.2e %10.2e %10lld %9.2f %9.1e %9.1e %9.1e%s\n", r.config.c_str(),
                  r.rtol, r.found_max + r.found_min, r.want_max + r.want_min, r.err_max, r.err_min, r.err_early, r.steps,
                  r.cpu, r.dH, r.dmu, r.dOm3, r.ok ? "" : "  (run failed)");
      std::fflush(stdout);
    }
  return 0;
}
