// integrate_ensemble (ensemble.hpp): every member bit-identical to a single integrate()
// run with its stepper, for 1, 2 and 3 threads; a failing member stops alone, at the
// state its single run stops at; per-member scenes; a scheme with memory; bad input
// thrown before any step; allocations that do not grow with the number of steps.
#include <algorithm>
#include <cstdio>
#include "support/allocation_counter.hpp"  // first: it replaces operator new/delete

#include <catch2/catch.hpp>

#include <vector>

#include "support/midpoint_scheme.hpp"
#include "support/same_bits.hpp"
#include "trompo/drivers/ensemble.hpp"
#include "trompo/trompo.hpp"

using namespace trompo;
using trompo_test::same_bits;
using Vec3 = Eigen::Vector3d;

namespace {

using Top = HeavyTop<double>;

/// HT1 with its tilt and spin perturbed member by member (a small sweep).
std::vector<State<double>> ht1_members(int n) {
  std::vector<State<double>> out;
  for (int i = 0; i < n; ++i) {
    State<double> s;
    s.rotation = SO3d::exp(Vec3(0.05 + 0.01 * i, 0.002 * (i % 3), 0));
    s.omega = Vec3(0, 0.1 * (i % 5), 40 + i);
    out.push_back(s);
  }
  return out;
}

bool same_summary(const IntegrationSummary<double>& a, const IntegrationSummary<double>& b) {
  return a.steps == b.steps && a.substeps == b.substeps && a.recovered == b.recovered && a.failures == b.failures &&
         a.iterations == b.iterations && a.status == b.status && a.time == b.time;
}

}  // namespace

TEST_CASE("ensemble: each member is bit-identical to its single integrate run, for 1, 2 and 3 threads and any chunk", "[ensemble]") {
  const auto ht1 = cases::ht1<double>();
  const Stepper<SimoKappa, Top> stepper(SimoKappa{}, ht1.scene);
  const auto start = ht1_members(7);
  const double t_end = 0.3, h = 0.001;

  std::vector<State<double>> single = start;
  std::vector<IntegrationSummary<double>> single_sum;
  for (auto& s : single) single_sum.push_back(integrate(stepper, s, t_end, h));

  // Chunks of 1, 2 and the default (dynamic schedule, ensemble.hpp): whichever thread takes a
  // member, its result is the same.
  for (unsigned threads : {1u, 2u, 3u})
  for (std::size_t chunk : {std::size_t(0), std::size_t(1), std::size_t(2)}) {
    INFO("threads " << threads << ", chunk " << chunk);
    auto members = start;
    const auto sums = integrate_ensemble(stepper, members, t_end, h, {.threads = threads, .chunk = chunk});
    REQUIRE(sums.size() == members.size());
    for (std::size_t i = 0; i < members.size(); ++i) {
      INFO("member " << i);
      CHECK(sums[i].ok());
      CHECK(sums[i].steps == 300);
      CHECK(same_bits(members[i], single[i]));
      CHECK(same_summary(sums[i], single_sum[i]));
    }
  }
}

TEST_CASE("ensemble: progress is called once a chunk, done increasing to n, and changes no member", "[ensemble]") {
  const auto ht1 = cases::ht1<double>();
  const Stepper<SimoKappa, Top> stepper(SimoKappa{}, ht1.scene);
  const auto start = ht1_members(7);
  auto quiet = start;
  (void)integrate_ensemble(stepper, quiet, 0.1, 0.001, {.threads = 2, .chunk = 2});
  for (unsigned threads : {1u, 2u, 3u}) {
    INFO("threads " << threads);
    std::vector<std::size_t> seen;  // progress calls are serialised: no lock needed here
    std::size_t total = 0;
    auto members = start;
    EnsembleOptions options{.threads = threads, .chunk = 2};
    options.progress = [&](std::size_t done, std::size_t n) {
      seen.push_back(done);
      total = n;
    };
    (void)integrate_ensemble(stepper, members, 0.1, 0.001, options);
    REQUIRE(seen.size() == 4);  // chunks of 2, 2, 2, 1
    CHECK(total == 7);
    CHECK(std::is_sorted(seen.begin(), seen.end()));
    CHECK(seen.front() >= 1);
    CHECK(seen.back() == 7);
    for (std::size_t i = 0; i < members.size(); ++i) CHECK(same_bits(members[i], quiet[i]));
  }
}

TEST_CASE("ensemble: the default chunk", "[ensemble]") {
  CHECK(ensemble_chunk(10, 2) == 1);
  CHECK(ensemble_chunk(1600, 2) == 50);
  CHECK(ensemble_chunk(16384, 16) == 64);
  CHECK(ensemble_chunk(100000, 2) == 64);
}

TEST_CASE("ensemble: per-member scenes (inertia and weight) and a composed stepper", "[ensemble]") {
  const auto start = ht1_members(5);
  std::vector<ComposedStepper<SimoKappa, Top>> steppers;
  for (int i = 0; i < 5; ++i)
    steppers.emplace_back(SimoKappa{}, Top(RigidBody<double>(Vec3(5, 5, 1 + 0.1 * i)),
                                           UniformGravity<double>(20.0 + i, Vec3::UnitZ(), Vec3::UnitZ())),
                          Composition::suzuki5);
  auto one = start, two = start;
  integrate_ensemble(steppers, one, 0.1, 0.002, {.threads = 1});
  const auto sums = integrate_ensemble(steppers, two, 0.1, 0.002, {.threads = 2});
  for (std::size_t i = 0; i < start.size(); ++i) {
    INFO("member " << i);
    State<double> s = start[i];
    const auto sum = integrate(steppers[i], s, 0.1, 0.002);
    CHECK(same_bits(one[i], s));
    CHECK(same_bits(two[i], s));
    CHECK(same_summary(sums[i], sum));
    // The invariants a composed Simo-kappa keeps, member by member.
    const double H0 = steppers[i].scene().energy(start[i]);
    CHECK(std::abs(steppers[i].scene().energy(s) - H0) <= 1e-12 * std::abs(H0));
  }
  // The members differ (each got its own scene), so the check above is not vacuous.
  CHECK_FALSE(same_bits(one[0], one[1]));
}

TEST_CASE("ensemble: a failing member stops at its last good state, the others finish", "[ensemble]") {
  const auto fb1 = cases::fb1<double>();
  const Stepper<SimoKappa, cases::Free<double>> stepper(SimoKappa{}, fb1.scene);
  std::vector<State<double>> start(4, fb1.initial);
  start[2].omega = Vec3(0, 1e6, 0);  // |Θ| = 1e5 rad a step: not even 1024 sub-steps save it
  const double t_end = 0.5, h = 0.1;

  for (unsigned threads : {1u, 2u}) {
    INFO("threads " << threads);
    auto members = start;
    const auto sums = integrate_ensemble(stepper, members, t_end, h, {.threads = threads});
    for (std::size_t i = 0; i < members.size(); ++i) {
      INFO("member " << i);
      State<double> s = start[i];
      const auto sum = integrate(stepper, s, t_end, h);
      CHECK(same_bits(members[i], s));
      CHECK(same_summary(sums[i], sum));
      CHECK(sums[i].ok() == (i != 2));
    }
    CHECK(sums[2].status != StepStatus::ok);
    CHECK(members[2].time == 0.0);       // nothing was accepted
    CHECK(members[3].time == t_end);     // the member after it finished
  }
}

TEST_CASE("ensemble: a scheme with memory (a fresh trajectory per member, as integrate gives)", "[ensemble]") {
  const auto fb1 = cases::fb1<double>();
  const Stepper<trompo_test::MidpointQ, cases::Free<double>> stepper(trompo_test::MidpointQ{}, fb1.scene);
  std::vector<State<double>> start(3, fb1.initial);
  start[1].omega *= 1.5;
  start[2].omega *= 2.0;
  auto members = start;
  integrate_ensemble(stepper, members, 1.0, 0.01, {.threads = 2});
  for (std::size_t i = 0; i < start.size(); ++i) {
    State<double> s = start[i];
    integrate(stepper, s, 1.0, 0.01);
    CHECK(same_bits(members[i], s));
  }
}

TEST_CASE("ensemble: bad input throws before any member is stepped", "[ensemble]") {
  const auto ht1 = cases::ht1<double>();
  const Stepper<SimoKappa, Top> stepper(SimoKappa{}, ht1.scene);
  auto members = ht1_members(3);
  const auto before = members;
  members[1].omega.x() = std::nan("");
  CHECK_THROWS_WITH(integrate_ensemble(stepper, members, 1.0, 0.01), Catch::Contains("member 1") && Catch::Contains("omega"));
  CHECK(same_bits(members[0], before[0]));
  members = before;
  CHECK_THROWS_WITH(integrate_ensemble(stepper, members, 1.0, 0.0), Catch::Contains("h must be finite and non-zero"));
  CHECK_THROWS_WITH(integrate_ensemble(stepper, members, -1.0, 0.01), Catch::Contains("behind its start"));
  std::vector<Stepper<SimoKappa, Top>> two(2, stepper);
  CHECK_THROWS_WITH(integrate_ensemble(two, members, 1.0, 0.01), Catch::Contains("2 steppers for 3 members"));
  CHECK(same_bits(members[2], before[2]));
}

TEST_CASE("ensemble: allocations do not grow with the number of steps", "[ensemble]") {
  const auto ht1 = cases::ht1<double>();
  const Stepper<SimoKappa, Top> stepper(SimoKappa{}, ht1.scene);
  auto count = [&](double t_end, unsigned threads) {
    auto members = ht1_members(4);
    no_alloc::news = 0;
    no_alloc::counting = true;
    const auto sums = integrate_ensemble(stepper, members, t_end, 0.001, {.threads = threads});
    no_alloc::counting = false;
    CHECK(sums[3].ok());
    return no_alloc::news.load();
  };
  for (unsigned threads : {1u, 2u}) {
    INFO("threads " << threads);
    const long short_run = count(0.01, threads), long_run = count(0.5, threads);  // 10 and 500 steps
    CHECK(short_run == long_run);
    CHECK(long_run <= 2 + 2 * static_cast<long>(threads));  // summaries, error slots, the threads
  }
}

TEST_CASE("ensemble: adaptive members (t_eval, events) are their single solve runs, bit for bit", "[ensemble]") {
  const auto ht1 = cases::ht1<double>();
  const Stepper<SimoKappa, Top> stepper(SimoKappa{}, ht1.scene);
#ifdef TROMPO_SANITIZED
  // ASan/UBSan at -O0 (the test command's sanitizer build): the same checks on a shorter run.
  const auto start = ht1_members(3);
  const double t_end = 0.1;
  const std::vector<double> t_eval{0.02, 0.05, 0.1};
#else
  const auto start = ht1_members(5);
  const double t_end = 0.3;
  const std::vector<double> t_eval{0.05, 0.1, 0.2, 0.3};
#endif
  AdaptiveOptions<double> opt;
  opt.rtol = opt.atol = 1e-8;
  const std::vector<Event<double>> ev{events::by_name(ht1.scene, "nutation-max")};
  std::vector<AdaptiveRun<double>> single;
  for (const auto& s : start) single.push_back(solve(stepper, s, t_end, opt, t_eval, ev, false));
  for (unsigned threads : {1u, 2u, 3u}) {
    INFO("threads " << threads);
    const auto runs = solve_ensemble(stepper, start, t_end, opt, t_eval, ev, false, {.threads = threads, .chunk = 1});
    REQUIRE(runs.size() == start.size());
    for (std::size_t i = 0; i < runs.size(); ++i) {
      INFO("member " << i);
      REQUIRE(runs[i].success());
      REQUIRE(runs[i].states.size() == t_eval.size());
      for (std::size_t k = 0; k < t_eval.size(); ++k) CHECK(same_bits(runs[i].states[k], single[i].states[k]));
      REQUIRE(runs[i].events.size() == 1);
      REQUIRE(runs[i].events[0].size() == single[i].events[0].size());
      for (std::size_t k = 0; k < runs[i].events[0].size(); ++k) CHECK(same_bits(runs[i].events[0][k], single[i].events[0][k]));
      CHECK(runs[i].summary.accepted == single[i].summary.accepted);
      CHECK(runs[i].summary.rejected == single[i].summary.rejected);
    }
  }
  // The members differ (the check could tell them apart), and some found nutation maxima.
  CHECK_FALSE(same_bits(single[0].states.back(), single[1].states.back()));
  std::size_t found = 0;
  for (const auto& r : single) found += r.events[0].size();
  CHECK(found > 0);
  // A bad t_eval throws, after the members have run.
  CHECK_THROWS_AS(solve_ensemble(stepper, start, t_end, opt, {0.5}, ev), invalid_input);
}

// Closed-loop members (integrate_sampled_ensemble): Basilisk's wheel spacecraft under MRP
// feedback, one member per initial attitude, with per-member wheel speeds and gains set by
// `setup`. Each member equals its single integrate_sampled run bit for bit, whatever the
// threads and chunk; the total momentum of each stays at its own start (no external torque).
TEST_CASE("ensemble: closed-loop members with wheels, each its single sampled run", "[ensemble][control]") {
  using Wheels = ReactionWheels<double>;
  using Craft = Scene<double, Wheels>;
  const double rpm = 2 * 3.14159265358979323846 / 60, Js = 50.0 / (6000 * rpm);
  Wheels rw;
  for (int i = 0; i < 3; ++i) rw.add_wheel({.axis = Vec3::Unit(i), .inertia = Js, .speed0 = 100.0 * (i + 1) * rpm, .max_torque = 0.2});
  const Stepper<SimoKappa, Craft> stepper(SimoKappa{}, Craft(rw.hub_body(Vec3(900, 800, 600).asDiagonal()), rw));
  std::vector<State<double>> start(7);
  for (std::size_t i = 0; i < start.size(); ++i) {
    start[i].rotation = SO3d::from_matrix(rotation_of_mrp(Vec3(Vec3(0.1, 0.2, -0.3) * (1.0 + 0.1 * double(i)))));
    start[i].omega = Vec3(0.001, -0.01, 0.03);
  }
  const MrpPd<double> pd{.K = 3.5, .P = 30};
  const FixedSteps<double> between{0.1};
  // Per member: wheel 1 spun 10 rad/s faster per index, and a stiffer K.
  auto setup = [&](std::size_t i, Stepper<SimoKappa, Craft>& st, MrpPd<double>& c) {
    Wheels& w = st.scene().effect<Wheels>();
    Wheels::WheelVector speeds = w.speeds(start[i].time, start[i].omega);
    speeds(0) += 10.0 * double(i);
    w.set_speeds(start[i].time, start[i].omega, speeds);
    c.K = 3.5 + 0.5 * double(i);
  };
  const double t_end = 60.0, period = 0.1;
  std::vector<State<double>> single(start.size());
  std::vector<Vec3> pi0(start.size()), pi_single(start.size());
  std::vector<double> energy_single(start.size());
  std::vector<Wheels::WheelVector> u_single(start.size());
  std::vector<std::int64_t> iterations_single(start.size());
  for (std::size_t i = 0; i < start.size(); ++i) {
    Stepper<SimoKappa, Craft> st = stepper;
    MrpPd<double> c = pd;
    st.scene().effect<Wheels>().start(start[i].time, start[i].omega);
    setup(i, st, c);
    pi0[i] = st.scene().spatial_momentum(start[i]);
    single[i] = start[i];
    const SampledSummary<double> sum = integrate_sampled(st, single[i], t_end, period, c, between);
    REQUIRE(sum.ok());
    iterations_single[i] = sum.iterations;
    energy_single[i] = st.scene().energy(single[i]);
    pi_single[i] = st.scene().spatial_momentum(single[i]);
    u_single[i] = st.scene().effect<Wheels>().torques();
  }
  double worst_pi = 0;
  for (unsigned threads : {1u, 2u}) {
    INFO("threads " << threads);
    const auto members = integrate_sampled_ensemble(stepper, start, t_end, period, pd, between, {.threads = threads, .chunk = 1}, setup);
    REQUIRE(members.size() == start.size());
    for (std::size_t i = 0; i < members.size(); ++i) {
      INFO("member " << i);
      REQUIRE(members[i].summary.ok());
      CHECK(members[i].summary.samples == 600);
      CHECK(same_bits(members[i].state, single[i]));
      REQUIRE(members[i].wheel_speeds.size() == 3);
      // π = Λ(J_hubΩ + h_w) from the member's end state and wheel speeds: its own start's.
      const Vec3 h_w = Js * (members[i].wheel_speeds + members[i].state.omega);  // axes e_1, e_2, e_3
      const Vec3 pi = members[i].state.rotation.matrix() * (stepper.scene().body().inertia() * members[i].state.omega + h_w);
      CHECK((pi - pi0[i]).norm() <= 1e-14 * pi0[i].norm());  // measured 1.9e-15
      worst_pi = std::max(worst_pi, (pi - pi0[i]).norm() / pi0[i].norm());
      // The end's energy, momentum, held torques and Newton count: the single run's scene's.
      CHECK(members[i].energy == energy_single[i]);
      CHECK(members[i].spatial_momentum == pi_single[i]);
      CHECK(members[i].wheel_torques == u_single[i]);
      CHECK(members[i].summary.iterations == iterations_single[i]);
      CHECK(members[i].summary.iterations >= 600);  // Simo-κ: at least one Newton iteration a step
    }
  }
  std::printf("closed-loop ensemble, 7 members x 600 samples: each its single run bit for bit; max |dpi|/|pi| %.2e\n", worst_pi);
  // The members differ (the check could tell them apart).
  CHECK_FALSE(same_bits(single[0], single[1]));
  CHECK_THROWS_AS(integrate_sampled_ensemble(stepper, start, t_end, 0.0, pd, between), invalid_input);
}
