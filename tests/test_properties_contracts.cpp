// The generic property suite over the scheme registry, its contracts: a failed step
// changes nothing, backward steps, no heap allocation (tests/support/scheme_properties.hpp
// says what the suite checks and why it is two files). Built under the sanitizers.
#include "support/allocation_counter.hpp"  // first: it replaces operator new/delete

#include <cmath>
#include <limits>
#include <string>

#include <catch2/catch.hpp>

#include "support/scheme_properties.hpp"
#include "support/same_bits.hpp"
#include "support/show.hpp"

using namespace trompo;
using namespace trompo_test::properties;
using trompo_test::Vec3;

TEMPLATE_LIST_TEST_CASE("registry: a failed step (h = NaN, starved Newton, h = 50) leaves state and memory bit-identical",
                        "[properties][failure]", Entries) {
  auto check_on = []([[maybe_unused]] const auto& c) {
    using SceneT = typename std::decay_t<decltype(c)>::SceneT;
    if constexpr (TestType::template steps<SceneT>) {
      NewtonOptions<double> starved;
      starved.max_iterations = 1;
      for (const bool starve : {false, true}) {
        for_each_stepper<TestType>(
            c.scene,
            [&](const auto& st, int, const char* label) {
              INFO("scheme " << TestType::name << ", " << label << " on " << c.name << (starve ? ", starved Newton" : ""));
              auto traj = st.start(c.initial);
              if (!starve) REQUIRE(advance(st, traj, 0.005, 3));  // a memory that holds something
              int failures = 0;
              for (const double h : {std::numeric_limits<double>::quiet_NaN(), 0.05, 50.0}) {
                const State<double> before = traj.state();
                const auto memory = bytes_of(traj.memory);
                const auto rep = st.step(traj, h);
                if (std::isnan(h)) CHECK(rep.status == StepStatus::invalid_step);
                if (!rep.ok()) {
                  ++failures;
                  CHECK(trompo_test::same_bits(before, traj.state()));
                  CHECK(bytes_of(traj.memory) == memory);
                }
              }
              CHECK(failures >= 1);
            },
            starve ? starved : NewtonOptions<double>{});
      }
    }
  };
  check_on(cases::ht1<double>());
  check_on(cases::fb1<double>());
}

TEMPLATE_LIST_TEST_CASE("registry: backward steps: h then -h (symmetric: 1e-14), 50 steps of h then 50 of -h return to the start (symmetric: 1e-12, else within the two one-way errors)",
                        "[properties][backward]", Entries) {
  auto check_on = []([[maybe_unused]] const auto& c, [[maybe_unused]] double h) {
    using SceneT = typename std::decay_t<decltype(c)>::SceneT;
    if constexpr (TestType::template steps<SceneT>) {
      for_each_stepper<TestType>(c.scene, [&](const auto& st, int, const char* label) {
        const bool sym = symmetric_stepper(st, label);
        INFO("scheme " << TestType::name << ", " << label << " on " << c.name << (sym ? " (symmetric)" : ""));
        if (sym) {  // one step of h then −h, from the start and after 20 steps
          for (int k = 0; k < 2; ++k) {
            auto from = st.start(c.initial);
            REQUIRE(advance(st, from, h, 20 * k));
            auto t = from;
            REQUIRE(st.step(t, h).ok());
            REQUIRE(st.step(t, -h).ok());
            const double dL1 = trompo_test::max_abs(t.rotation.matrix() - from.rotation.matrix());
            const double dW1 = (t.omega - from.omega).norm() / from.omega.norm();
            INFO("one step h, -h after " << 20 * k << " steps: |dLambda|_max " << dL1 << ", |dOmega|/|Omega| " << dW1);
            CHECK(dL1 <= 1e-14);
            CHECK(dW1 <= 1e-13);
          }
        }
        auto traj = st.start(c.initial);
        REQUIRE(advance(st, traj, h, 50));
        REQUIRE(advance(st, traj, -h, 50));
        const double dR = (traj.rotation.matrix() - c.initial.rotation.matrix()).norm();
        const double dW = (traj.omega - c.initial.omega).norm() / c.initial.omega.norm();
        INFO("|dLambda| " << dR << ", |dOmega|/|Omega| " << dW << ", t " << traj.time);
        CHECK(std::abs(traj.time) <= 1e-12);
        if (sym) {
          CHECK(dR <= 1e-12);
          CHECK(dW <= 1e-12);
        } else {
          // Not symmetric: the two runs' errors of order p need not cancel, but the round
          // trip errs by no more than the two one-way runs, 2 (eR + eW), each measured here
          // against the same stepper at h/8 (its error 8^p times smaller). Measured: the
          // round trip is at most 0.13 (eR + eW) (the even orders' leading terms cancel).
          // It was 50 (h|Omega|)^p, 0.05 on HT1 for order 2.
          auto fine = st.start(c.initial), fwd = st.start(c.initial);
          REQUIRE(advance(st, fine, h / 8, 400));
          REQUIRE(advance(st, fwd, h, 50));
          const double eR = (fwd.rotation.matrix() - fine.rotation.matrix()).norm();
          const double eW = (fwd.omega - fine.omega).norm() / c.initial.omega.norm();
          const double tol = 2 * (eR + eW);
          // The bound fails a backward run that is not the scheme's steps of -h (here a
          // step 1% too long, as a stale step size or time would give).
          auto off = fwd;
          REQUIRE(advance(st, off, -1.01 * h, 50));
          CHECK_FALSE((off.rotation.matrix() - c.initial.rotation.matrix()).norm() <= tol);
          SHOW(TestType::name << ", " << label << " on " << c.name << ": round trip |dLambda| " << dR << ", |dOmega|/|Omega| "
                              << dW << "; one way (vs h/8) " << eR << ", " << eW << ": bound " << tol << ", ratio "
                              << std::max(dR, dW) / (eR + eW));
          CHECK(tol > 0);
          CHECK(dR <= tol);
          CHECK(dW <= tol);
        }
      });
    }
  };
  check_on(cases::ht1<double>(), 0.002);
  check_on(cases::fb1<double>(), 0.02);
}

TEMPLATE_LIST_TEST_CASE("registry: no heap allocation in a step (plain, composed, processed, on HT1 and FB1)",
                        "[properties][no_alloc]", Entries) {
  auto check_on = []([[maybe_unused]] const auto& c, [[maybe_unused]] double h) {
    using SceneT = typename std::decay_t<decltype(c)>::SceneT;
    if constexpr (TestType::template steps<SceneT>) {
      for_each_stepper<TestType>(c.scene, [&](const auto& st, int, const char* label) {
        INFO("scheme " << TestType::name << ", " << label << " on " << c.name);
        auto traj = st.start(c.initial);
        int ok = 0;
        const long count = no_alloc::allocations_in([&] {
          for (int k = 0; k < 20; ++k) ok += st.step(traj, h).ok() ? 1 : 0;
        });
        CHECK(ok == 20);
        CHECK(count == 0);
      });
    }
  };
  check_on(cases::ht1<double>(), 0.005);
  check_on(cases::fb1<double>(), 0.02);
}
