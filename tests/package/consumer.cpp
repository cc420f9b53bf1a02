// Smallest real use: one Simo-κ step of HT1 must keep the energy.
#include <trompo/trompo.hpp>

#include <cmath>
#include <cstdio>

int main() {
  auto c = trompo::cases::ht1<double>();
  trompo::Stepper<trompo::SimoKappa, decltype(c.scene)> stepper({}, c.scene);
  auto s = c.initial;
  const double H0 = c.scene.energy(s);
  for (int k = 0; k < 100; ++k)
    if (!stepper.step(s, 0.001).ok()) return 1;
  const double err = std::abs(c.scene.energy(s) - H0) / H0;
  std::printf("consumer: relative energy error %.3g\n", err);
  return err < 1e-13 ? 0 : 1;
}
