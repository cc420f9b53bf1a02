// The sleeping top: a symmetric heavy top spinning upright about its vertical symmetry
// axis. J = diag(5, 5, 1) about the tip, Mgl = 20, E = γ = e3 (HT1's top).
//  * Exactly upright it stays upright: the gravity torque E × Λᵀ(−Mglγ) vanishes, and the
//    step must handle ρ = 0 of [T2] (collocation's α has no preferred value) and
//    keep the spin Ω3 and H exactly.
//  * Slightly tilted, it stays up only if it spins fast enough: upright rotation is stable
//    when J3²ω3² > 4 Mgl J1 (the Maxwell–Klein condition), here ω3 > ω_c = 20 rad/s. At
//    ω3 = 50 a tilt of 1e-3 rad stays of that order; at ω3 = 10 it grows until the top
//    falls over (and swings back: energy is conserved).
// Checks (Simo collocation, h = 0.001, t ≤ 10): the exactly upright top keeps Λe3 = e3
// and Ω3 to round-off; max tilt < 5·1e-3 at ω3 = 50 and > 0.5 rad at ω3 = 10; H exact.
#include <cmath>
#include <cstdio>

#include "trompo/trompo.hpp"

namespace {

using namespace trompo;
using V = Eigen::Vector3d;

struct Run {
  double max_tilt = 0;   ///< max angle between the symmetry axis Λe3 and the vertical
  double max_dH = 0;     ///< max |H − H0|/|H0|
  double max_dspin = 0;  ///< max |Ω3 − Ω3(0)|
  bool ok = true;
};

Run spin(double omega3, double tilt) {
  const HeavyTop<double> top(RigidBody<double>(V(5, 5, 1)), UniformGravity<double>(20.0, V::UnitZ(), V::UnitZ()));
  const Stepper<SimoCollocation, HeavyTop<double>> stepper(SimoCollocation{}, top);
  State<double> s;
  s.rotation = SO3d::exp(V(tilt, 0, 0));
  s.omega = V(0, 0, omega3);
  const double H0 = top.energy(s);
  Run r;
  for (int n = 0; n < 10000; ++n) {
    if (!stepper.step(s, 0.001).ok()) {
      r.ok = false;
      return r;
    }
    const V axis = s.rotation * V::UnitZ();
    r.max_tilt = std::max(r.max_tilt, std::atan2(axis.head<2>().norm(), axis.z()));
    r.max_dH = std::max(r.max_dH, std::abs(top.energy(s) - H0) / std::abs(H0));
    r.max_dspin = std::max(r.max_dspin, std::abs(s.omega.z() - omega3));
  }
  return r;
}

}  // namespace

int main() {
  const double omega_c = 2 * std::sqrt(20.0 * 5.0) / 1.0;  // 2√(Mgl J1)/J3
  const Run upright = spin(50, 0.0);
  const Run fast = spin(50, 1e-3);
  const Run slow = spin(10, 1e-3);
  std::printf("Sleeping top, J = diag(5, 5, 1), Mgl = 20, critical spin 2 sqrt(Mgl J1)/J3 = %g rad/s\n", omega_c);
  std::printf("  upright, spin 50:       max tilt %.1e rad, max |dOmega3| %.1e, max |dH/H| %.1e\n", upright.max_tilt,
              upright.max_dspin, upright.max_dH);
  std::printf("  tilt 1e-3, spin 50:     max tilt %.2e rad (stays up), max |dH/H| %.1e\n", fast.max_tilt, fast.max_dH);
  std::printf("  tilt 1e-3, spin 10:     max tilt %.2f rad (falls),    max |dH/H| %.1e\n", slow.max_tilt, slow.max_dH);
  const bool ok = upright.ok && fast.ok && slow.ok && upright.max_tilt < 1e-12 && upright.max_dspin < 1e-12 &&
                  fast.max_tilt < 5e-3 && slow.max_tilt > 0.5 && upright.max_dH < 1e-12 && fast.max_dH < 1e-12 &&
                  slow.max_dH < 1e-12;
  std::printf("%s\n", ok ? "check passed" : "CHECK FAILED");
  return ok ? 0 : 1;
}
