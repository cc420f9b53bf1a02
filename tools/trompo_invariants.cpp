// trompo-invariants: per scheme, on HT1 (t = 10) and HT2 (t = 2) at h = 0.001 and 0.005,
// the max |ΔH/H| and |Δμ/μ| over the run, the mean Newton iterations per step, the end
// attitude error ‖Λ − Λref‖_F, and the observed order log(err(5h)/err(h))/log 5.
// Λref: the closed-form Lagrange top (HT1), the published 128-bit solution (HT2, docs/theory.md §8).
//
//   build/…/tools/trompo-invariants
#include <cmath>
#include <cstdio>

#include "trompo/exact/lagrange_top.hpp"
#include "trompo/trompo.hpp"

namespace {

using namespace trompo;
using M3 = Eigen::Matrix3d;

struct Figures {
  double dH = 0, dmu = 0, its = 0, err = 0;
  bool ok = true;
};

template <class Scheme, class Case>
Figures run(const Scheme& scheme, const Case& c, double h, double t_end, const M3& ref) {
  using SceneT = typename Case::SceneT;
  Stepper<Scheme, SceneT> stepper(scheme, c.scene);
  State<double> s = c.initial;
  const double H0 = c.scene.energy(s), mu0 = c.scene.momentum_map(s);
  Figures f;
  long iterations = 0;
  auto observe = [&](const State<double>& st) {
    f.dH = std::max(f.dH, std::abs(c.scene.energy(st) - H0) / std::abs(H0));
    f.dmu = std::max(f.dmu, std::abs(c.scene.momentum_map(st) - mu0) / std::abs(mu0));
  };
  const long n = std::lround(t_end / h);
  for (long k = 1; k <= n; ++k) {
    const auto rep = stepper.step(s, h);
    if (!rep.ok()) {
      f.ok = false;
      return f;
    }
    iterations += rep.iterations;
    observe(s);
  }
  f.its = double(iterations) / double(n);
  f.err = (s.rotation.matrix() - ref).norm();
  return f;
}

template <class Scheme, class Case>
void row(const char* name, const Scheme& scheme, const Case& c, double t_end, const M3& ref) {
  const Figures a = run(scheme, c, 0.001, t_end, ref);
  const Figures b = run(scheme, c, 0.005, t_end, ref);
  if (!a.ok || !b.ok) {
    std::printf("%-4s %-22s a step failed\n", c.name, name);
    return;
  }
  std::printf("%-4s %-22s %9.1e %9.1e %5.2f %9.1e | %9.1e %9.1e %5.2f %9.1e | %5.2f\n", c.name, name, a.dH, a.dmu,
              a.its, a.err, b.dH, b.dmu, b.its, b.err, std::log(b.err / a.err) / std::log(5.0));
}

template <class Case>
void table(const Case& c, double t_end, const M3& ref) {
  row("simo-alpha 1/2", SimoAlpha{}, c, t_end, ref);
  row("simo-collocation", SimoCollocation{}, c, t_end, ref);
  row("simo-kappa", SimoKappa{}, c, t_end, ref);
  row("geradin-bauchau", GeradinBauchau{}, c, t_end, ref);
  row("geradin-bauchau-paper", GeradinBauchauPaper{}, c, t_end, ref);
  row("rk4", RK4{}, c, t_end, ref);
}

}  // namespace

int main() {
  std::printf("%-4s %-22s %9s %9s %5s %9s | %9s %9s %5s %9s | %5s\n", "case", "scheme", "dH/H", "dmu/mu", "its",
              "|dLambda|", "dH/H", "dmu/mu", "its", "|dLambda|", "order");
  std::printf("%-27s %-37s | %-37s |\n", "", "h = 0.001", "h = 0.005");
  const auto ht1 = cases::ht1<double>();
  const exact::LagrangeTop top(5, 1, 20, ht1.initial.rotation.matrix(), ht1.initial.omega);
  table(ht1, 10.0, top.rotation(10.0));
  M3 ht2_ref;  // Λ(2) of HT2, the published solution of docs/theory.md §8 (Runge–Kutta–Fehlberg 7(8), 128-bit, tol 1e-26)
  ht2_ref << -0.4874490822362657103411952, -0.150416822745641759810031, 0.8600977686647771186846382,
      -0.5379397438441505933085278, -0.7241655916368956507485545, -0.4315148060983244312796754,
      0.6877602956117137709979562, -0.6730222695604440960502209, 0.2720786659328456273933256;
  table(cases::ht2<double>(), 2.0, ht2_ref);
  return 0;
}
