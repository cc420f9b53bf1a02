// trompo-invariants: per registered scheme (include/trompo/schemes/registry.hpp, at its
// default parameters), on HT1 (t = 10) and HT2 (t = 2) at h = 0.001 and 0.005,
// the max |ΔH/H| and |Δμ/μ| over the run, the mean Newton iterations per step, the end
// attitude error ‖Λ − Λref‖_F, and the observed order log(err(5h)/err(h))/log 5.
// Λref: the closed-form Lagrange top (HT1), the published 128-bit solution (HT2, docs/theory.md §8).
//
//   build/…/tools/trompo-invariants
#include <cmath>
#include <cstdio>

#include "data/reference_cases.hpp"  // tests/data: the project's one reference set
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
  auto s = stepper.start(c.initial);  // the state, with the scheme's memory
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
  RegisteredSchemes::for_each([&](auto entry) {
    using Entry = typename decltype(entry)::type;
    if constexpr (Entry::template steps<typename Case::SceneT>) row(Entry::name, typename Entry::Scheme{}, c, t_end, ref);
  });
}

}  // namespace

int main() {
  std::printf("%-4s %-22s %9s %9s %5s %9s | %9s %9s %5s %9s | %5s\n", "case", "scheme", "dH/H", "dmu/mu", "its",
              "|dLambda|", "dH/H", "dmu/mu", "its", "|dLambda|", "order");
  std::printf("%-27s %-37s | %-37s |\n", "", "h = 0.001", "h = 0.005");
  const auto ht1 = cases::ht1<double>();
  const exact::LagrangeTop top(5, 1, 20, ht1.initial.rotation.matrix(), ht1.initial.omega);
  table(ht1, 10.0, top.rotation(10.0));
  // Λ(2) of HT2: the published solution of docs/theory.md §8 (Runge–Kutta–Fehlberg 7(8), 128-bit, tol 1e-26).
  const M3 ht2_ref = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(
      trompo_test::reference::rotation_of(trompo_test::reference::ht2[1]));
  table(cases::ht2<double>(), 2.0, ht2_ref);
  return 0;
}
