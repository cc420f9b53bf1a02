// Write your own scheme (README "Write your own scheme"): the implicit midpoint rule on the
// unit quaternion q and Ω of a free body, solved by fixed-point iteration, with a memory
// that counts the steps taken along the trajectory. It models trompo::SchemeFor, so
// Stepper and integrate() drive it like the library's own schemes. The midpoint rule
// keeps every quadratic invariant, here the free body's energy ½Ω·JΩ.
//
// Check: FB1 (J = diag(1, 2, 3), Ω0 = (0.01, 2, 0.01)) to t = 100 with h = 0.01 keeps H to
// 1e-12 relative, the memory has counted 10⁴ steps, and a step too large for the
// fixed-point iteration fails without touching the trajectory.
#include <cmath>
#include <cstdio>

#include <trompo/trompo.hpp>

#include "own_scheme.hpp"  // struct Midpoint: the README example

using namespace trompo;
using example::Midpoint;

int main() {  // ---- the README example: own_scheme.hpp, then these lines ----
  const auto fb1 = cases::fb1<double>();
  Stepper<Midpoint, FreeScene<double>> stepper(Midpoint{}, fb1.scene);
  auto trajectory = stepper.start(fb1.initial);  // a State plus Midpoint's memory
  const IntegrationSummary<double> run = integrate(stepper, trajectory, fb1.t_end, 0.01);
  // ---- the README example ends here ----
  const double H0 = fb1.scene.energy(fb1.initial);
  const double dH = std::abs(fb1.scene.energy(trajectory) - H0) / H0;
  std::printf("my-midpoint on FB1, h = 0.01 to t = %g: %s, %ld steps in memory, |dH/H| = %.2e\n",
              trajectory.time, run.ok() ? "ok" : run.reason(), trajectory.memory.steps, dH);

  // A step far too large for the fixed-point iteration fails and changes nothing.
  const auto before = trajectory;
  const StepReport<double> big = stepper.step(trajectory, 5.0);
  const bool untouched = trajectory.omega == before.omega && trajectory.time == before.time &&
                         trajectory.memory.steps == before.memory.steps;
  std::printf("a step of h = 5: %s, trajectory %s\n", big.ok() ? "accepted" : "failed",
              untouched ? "unchanged" : "CHANGED");

  const bool pass = run.ok() && trajectory.memory.steps == 10000 && dH <= 1e-12 &&
                    !big.ok() && untouched;
  std::printf("%s\n", pass ? "PASS" : "FAIL");
  return pass ? 0 : 1;
}
