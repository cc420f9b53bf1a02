// Long runs (docs/theory.md §9): 10⁵ steps of HT1 and FB1 with Simo-κ and Géradin–Bauchau keep
// |ΔH/H|, |Δμ/μ| and ‖ΛᵀΛ − I‖ below 1e-11 at every step — the assertions of
// trompo-bench-long-run (bench/bench_long_run.cpp), which runs 10⁷ steps.
//
// What this guards: round-off that is biased from step to step turns the √N·ε random
// walk of an exact scheme into an N·ε drift. Simo-κ on HT1 used to lose H like
// −4e-12 per 10⁶ steps because the Rodrigues matrix multiplied the large momentum
// (schemes/simo.hpp). At 10⁵ steps that is −4.4e-13: under 1e-11, so the runs are also
// held to 3·√N·ε (2.1e-13 at 10⁵ steps; measured ≤ 4e-14), which that drift exceeds.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>

#include "trompo/trompo.hpp"

using namespace trompo;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

namespace {

#ifdef TROMPO_SANITIZED
constexpr std::int64_t kSteps = 20'000;  // ASan/UBSan at -O1: the same checks, fewer steps
#else
constexpr std::int64_t kSteps = 100'000;
#endif

struct Figures {
  double max_dH = 0, max_dmu = 0, max_dpi = 0, max_orth = 0;
  double final_dH = 0, final_dmu = 0;
};

template <class Scheme, class Case>
Figures long_run(const Case& c, double h, std::int64_t n) {
  using Scene = typename Case::SceneT;
  const Stepper<Scheme, Scene> st(Scheme{}, c.scene);
  State<double> s = c.initial;
  const double H0 = c.scene.energy(s);
  const Vec3 pi0 = c.scene.spatial_momentum(s);
  // μ about γ for a top; about the initial momentum direction for a free body.
  const Vec3 axis = Scene::is_free ? Vec3(pi0.normalized()) : c.scene.momentum_axis();
  const double mu0 = axis.dot(pi0);
  Figures f;
  for (std::int64_t i = 0; i < n; ++i) {
    REQUIRE(st.step(s, h).ok());
    const Vec3 pi = c.scene.spatial_momentum(s);
    const Mat3 R = s.rotation.matrix();
    const double dH = (c.scene.energy(s) - H0) / H0;
    const double dmu = (axis.dot(pi) - mu0) / mu0;
    f.max_dH = std::max(f.max_dH, std::abs(dH));
    f.max_dmu = std::max(f.max_dmu, std::abs(dmu));
    f.max_dpi = std::max(f.max_dpi, (pi - pi0).norm() / pi0.norm());
    f.max_orth = std::max(f.max_orth, (R.transpose() * R - Mat3::Identity()).norm());
    f.final_dH = dH;
    f.final_dmu = dmu;
  }
  return f;
}

template <class Scheme, class Case>
void check_long_run(const Case& c, double h) {
  const Figures f = long_run<Scheme>(c, h, kSteps);
  INFO(Scheme::name << " " << c.name << " h = " << h << ", " << kSteps << " steps: final/max |dH/H| " << f.final_dH
                    << " / " << f.max_dH << ", final/max |dmu/mu| " << f.final_dmu << " / " << f.max_dmu
                    << ", max ||L^T L - I|| " << f.max_orth);
  CHECK(f.max_dH <= 1e-11);
  CHECK(f.max_dmu <= 1e-11);
  CHECK(f.max_orth <= 1e-11);
  if constexpr (Case::SceneT::is_free) CHECK(f.max_dpi <= 1e-11);
  // A random walk of ≲ ε a step stays within √N·ε (7e-14 at 10⁵ steps); allow 3×.
  const double walk = 3 * std::sqrt(static_cast<double>(kSteps)) * 2.220446049250313e-16;
  CHECK(f.max_dH <= walk);
  CHECK(f.max_dmu <= walk);
}

}  // namespace

TEST_CASE("long run: Simo-kappa on HT1, 1e5 steps of h = 0.001", "[long]") {
  check_long_run<SimoKappa>(cases::ht1<double>(), 1e-3);
}
TEST_CASE("long run: Geradin-Bauchau on HT1, 1e5 steps of h = 0.001", "[long]") {
  check_long_run<GeradinBauchau>(cases::ht1<double>(), 1e-3);
}
TEST_CASE("long run: Simo-kappa on FB1, 1e5 steps of h = 0.01", "[long]") {
  check_long_run<SimoKappa>(cases::fb1<double>(), 1e-2);
}
TEST_CASE("long run: Geradin-Bauchau on FB1, 1e5 steps of h = 0.01", "[long]") {
  check_long_run<GeradinBauchau>(cases::fb1<double>(), 1e-2);
}
