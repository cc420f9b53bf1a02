// The Dzhanibekov effect (docs/theory.md §8, case FB1): a free body spun about its intermediate
// principal axis does not keep spinning about it. J = diag(1, 2, 3), Ω0 = (0.01, 2, 0.01):
// every so often the body turns over, Ω2 changing sign, while the spatial momentum π and
// the energy stay fixed. The motion is periodic in the body: Euler's equations are solved
// by Jacobi elliptic functions (Landau & Lifshitz §37). With G² = |JΩ|² > 2T J2, the
// intermediate component is Ω2 ∝ sn(λt, k), which changes sign every half period
//
//   T_flip = 2K(k)/λ,  λ² = (J3 − J2)(G² − 2T J1)/(J1 J2 J3),
//   k² = (J2 − J1)(2T J3 − G²) / ((J3 − J2)(G² − 2T J1)),
//
// K the complete elliptic integral of the first kind (std::comp_ellint_1 takes k).
// Check: the mean time between flips of a Simo-κ run (h = 0.01, t ≤ 100) against T_flip,
// and π, H exact along the run.
#include <cmath>
#include <cstdio>
#include <vector>

#include "trompo/trompo.hpp"

int main() {
  using namespace trompo;
  using V = Eigen::Vector3d;
  const V J(1, 2, 3);
  const FreeScene<double> scene{RigidBody<double>(J)};
  State<double> s;
  s.omega = V(0.01, 2, 0.01);

  // The elliptic-function period from the invariants of the initial state.
  // G² − 2T J_i = Σ_j J_j (J_j − J_i) Ω_j², written without cancellation of large terms.
  const auto excess = [&](int i) {
    double e = 0;
    for (int j = 0; j < 3; ++j) e += J(j) * (J(j) - J(i)) * s.omega(j) * s.omega(j);
    return e;
  };
  const double S1 = excess(0), S2 = excess(1), S3 = -excess(2);  // G²−2TJ1, G²−2TJ2, 2TJ3−G²
  if (!(S2 > 0)) {
    std::printf("this example expects G^2 > 2T J2 (momentum circulating about axis 3)\n");
    return 1;
  }
  const double lambda = std::sqrt((J(2) - J(1)) * S1 / (J(0) * J(1) * J(2)));
  const double k2c = (J(2) - J(0)) * S2 / ((J(2) - J(1)) * S1);  // k'² = 1 − k²
  const double k = std::sqrt((J(1) - J(0)) * S3 / ((J(2) - J(1)) * S1));
  const double T_flip = 2 * std::comp_ellint_1(k) / lambda;

  // Integrate and time the sign changes of Ω2 (linear interpolation inside the step).
  const Stepper<SimoKappa, FreeScene<double>> stepper(SimoKappa{}, scene);
  const double h = 0.01, t_end = 100;
  const double H0 = scene.energy(s);
  const V pi0 = scene.spatial_momentum(s);
  std::vector<double> flips;
  double max_dH = 0, max_dpi = 0;
  while (s.time < t_end - h / 2) {
    const State<double> before = s;
    const StepReport<double> rep = stepper.step(s, h);
    if (!rep.ok()) {
      std::printf("step failed at t = %g: %s\n", before.time, rep.reason());
      return 1;
    }
    if ((before.omega.y() > 0) != (s.omega.y() > 0))
      flips.push_back(before.time + h * before.omega.y() / (before.omega.y() - s.omega.y()));
    max_dH = std::max(max_dH, std::abs(scene.energy(s) - H0) / H0);
    max_dpi = std::max(max_dpi, (scene.spatial_momentum(s) - pi0).norm() / pi0.norm());
  }
  if (flips.size() < 2) {
    std::printf("expected several flips, saw %zu\n", flips.size());
    return 1;
  }
  const double measured = (flips.back() - flips.front()) / static_cast<double>(flips.size() - 1);
  const double rel = std::abs(measured - T_flip) / T_flip;

  std::printf("Dzhanibekov flip, J = diag(1, 2, 3), Omega0 = (0.01, 2, 0.01), Simo-kappa h = %g\n", h);
  std::printf("  k'^2 = %.6e   K(k) = %.10f   lambda = %.10f\n", k2c, std::comp_ellint_1(k), lambda);
  std::printf("  flips in [0, %g]: %zu\n", t_end, flips.size());
  std::printf("  time between flips: measured %.6f, elliptic 2K/lambda = %.6f, relative difference %.2e\n",
              measured, T_flip, rel);
  std::printf("  max |dH/H| = %.1e, max |dpi|/|pi| = %.1e\n", max_dH, max_dpi);
  const bool ok = rel < 1e-3 && max_dH < 1e-12 && max_dpi < 1e-12;
  std::printf("%s\n", ok ? "check passed" : "CHECK FAILED");
  return ok ? 0 : 1;
}
