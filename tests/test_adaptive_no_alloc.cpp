// The adaptive driver allocates nothing per step (include/trompo/drivers/adaptive.hpp):
// integrate_adaptive without events allocates nothing at all, in both controls; with
// events and an observer, the count is the same for a short and a 100x longer run (the
// event scratch is reserved once, before the loop).
#include "support/allocation_counter.hpp"  // first: it replaces operator new/delete

#include <catch2/catch.hpp>

#include "trompo/drivers/adaptive.hpp"
#include "trompo/trompo.hpp"

using namespace trompo;
using no_alloc::allocations_in;

TEST_CASE("adaptive: no allocation in the step loop", "[adaptive][no_alloc]") {
  const auto c = cases::ht1();
  ComposedStepper<SimoKappa, HeavyTop<double>> stepper(SimoKappa{}, c.scene, 4);
  for (StepControl control : {StepControl::tolerance, StepControl::reversible}) {
    AdaptiveOptions<double> opt;
    opt.rtol = opt.atol = 1e-8;
    opt.control = control;
    auto traj = stepper.start(c.initial);
    AdaptiveSummary<double> sum;
    const long count = allocations_in([&] { sum = integrate_adaptive(stepper, traj, 2.0, opt); });
    INFO(sum.accepted << " steps");
    CHECK(sum.ok());
    CHECK(sum.accepted > 50);
    CHECK(count == 0);
  }
  // Events and an observer: allocations independent of the number of steps.
  const std::vector<Event<double>> ev{events::nutation(c.scene, true), events::nutation(c.scene, false)};
  double last = 0;
  auto obs = [&](const DenseNode<double>&, const DenseNode<double>& b) { last = b.state.time; };
  long counts[2];
  std::int64_t steps[2];
  for (int i = 0; i < 2; ++i) {
    AdaptiveOptions<double> opt;
    opt.rtol = opt.atol = 1e-8;
    State<double> s = c.initial;
    AdaptiveSummary<double> sum;
    counts[i] = allocations_in([&] { sum = integrate_adaptive(stepper, s, i == 0 ? 0.1 : 10.0, opt, obs, &ev); });
    steps[i] = sum.accepted;
  }
  INFO(steps[0] << " and " << steps[1] << " steps: " << counts[0] << " and " << counts[1] << " allocations");
  CHECK(steps[1] > 50 * steps[0]);
  CHECK(counts[0] == counts[1]);
  CHECK(last == 10.0);
}

TEST_CASE("adaptive: no allocation in Richardson's step loop (the splitting)", "[adaptive][no_alloc]") {
  // Richardson's attempt keeps its m − 1 inner states in a fixed array for their dense nodes.
  const auto c = cases::ht1();
  Stepper<Splitting, HeavyTop<double>> stepper(Splitting(SplittingMethod::kahan_li_9), c.scene);
  AdaptiveOptions<double> opt;
  opt.rtol = opt.atol = 1e-10;
  State<double> s = c.initial;
  AdaptiveSummary<double> sum;
  const long count = allocations_in([&] { sum = integrate_adaptive(stepper, s, 2.0, opt); });
  CHECK(sum.ok());
  CHECK(sum.substeps == 8);
  CHECK(sum.accepted > 50);
  CHECK(count == 0);
  const std::vector<Event<double>> ev{events::nutation(c.scene, true), events::nutation(c.scene, false)};
  std::int64_t nodes = 0;
  auto obs = [&](const DenseNode<double>&, const DenseNode<double>&) { ++nodes; };
  long counts[2];
  std::int64_t steps[2];
  for (int i = 0; i < 2; ++i) {
    State<double> e = c.initial;
    counts[i] = allocations_in([&] { sum = integrate_adaptive(stepper, e, i == 0 ? 0.1 : 10.0, opt, obs, &ev); });
    steps[i] = sum.accepted;
  }
  INFO(steps[0] << " and " << steps[1] << " steps: " << counts[0] << " and " << counts[1] << " allocations");
  CHECK(steps[1] > 50 * steps[0]);
  CHECK(counts[0] == counts[1]);
  CHECK(nodes == steps[0] + steps[1]);  // one node per step kept
}
