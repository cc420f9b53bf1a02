// No heap allocation in a step (nor in integrate without an observer), proven two ways:
//  - every global operator new/delete of this executable is replaced by a counting one;
//  - Eigen's own heap (aligned_malloc, which bypasses operator new) is watched with
//    EIGEN_RUNTIME_NO_MALLOC, whose check goes through eigen_assert, defined here so that
//    it records a violation in Release builds too (where the plain assert is compiled out).
// Covered: every scheme on the free body, the heavy top, and scenes with every effect
// (damping, body and space torques, rotor, a general potential); composed steppers;
// failing steps; integrate() with sub-stepping recovery; a scheme with memory (a Trajectory)
// through Stepper, ComposedStepper and integrate(); the closed loop (wheels, friction, the
// near-integrable compositions with wheels, adaptive holds, magnetorquers).
#include "support/allocation_counter.hpp"  // first: it replaces operator new/delete

#include <catch2/catch.hpp>

#include "support/midpoint_scheme.hpp"
#include "trompo/trompo.hpp"

using namespace trompo;
using no_alloc::allocations_in;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

namespace {

template <class St>
void no_allocation_in_steps(const St& st, State<double> s, double h, int n = 50) {
  int ok = 0, failed = 0;
  const long count = allocations_in([&] {
    for (int i = 0; i < n; ++i) (st.step(s, h).ok() ? ok : failed)++;
  });
  INFO(ok << " steps ok, " << failed << " failed");
  CHECK(count == 0);
  CHECK(ok + failed == n);
  // And along a trajectory, where a scheme with memory (the history predictor) uses it.
  int traj_ok = 0;
  auto traj = st.start(s);
  const long traj_count = allocations_in([&] {
    for (int i = 0; i < n; ++i) traj_ok += st.step(traj, h).ok() ? 1 : 0;
  });
  INFO(traj_ok << " trajectory steps ok");
  CHECK(traj_count == 0);
}

template <class Scheme>
void all_scenes(const Scheme& scheme) {
  const State<double> start = [] {
    State<double> s;
    s.rotation = SO3d::exp(Vec3(0.3, -0.2, 0.1));
    s.omega = Vec3(0.5, -1.0, 3.0);
    return s;
  }();
  const RigidBody<double> body(Vec3(1, 2, 2.5));
  const UniformGravity<double> gravity(5.0, Vec3(0.1, 0.2, 1.0));
  SECTION("free body") { no_allocation_in_steps(Stepper<Scheme, Scene<double>>(scheme, Scene<double>(body)), start, 0.01); }
  SECTION("heavy top") {
    no_allocation_in_steps(Stepper<Scheme, HeavyTop<double>>(scheme, HeavyTop<double>(body, gravity)), start, 0.01);
  }
  SECTION("gravity, damping, body and space torques, rotor") {
    using S = Scene<double, UniformGravity<double>, ViscousDamping<double>, ConstantBodyTorque<double>,
                    ConstantSpaceTorque<double>, Rotor<double>>;
    const S scene(body, gravity, ViscousDamping<double>(0.1), ConstantBodyTorque<double>(Vec3(0.1, 0, 0)),
                  ConstantSpaceTorque<double>(Vec3(0, 0.1, 0)), Rotor<double>(Vec3(0, 0, 0.5)));
    no_allocation_in_steps(Stepper<Scheme, S>(scheme, scene), start, 0.01);
  }
  SECTION("a time-dependent torque given by a lambda") {
    auto f = [](double t) { return Vec3(std::sin(t), 0, 0); };
    using S = Scene<double, BodyTorque<double, decltype(f)>>;
    no_allocation_in_steps(Stepper<Scheme, S>(scheme, S(body, body_torque<double>(f))), start, 0.01);
  }
  SECTION("a general potential (Hessian by central differences)") {
    const Vec3 E(0, 0, 1), up(0, 0, 1);
    auto V = [=](const Mat3& L) {
      const double c = up.dot(L * E);
      return 2.0 * c * c;
    };
    auto g = [=](const Mat3& L) -> Vec3 { return 4.0 * up.dot(L * E) * E.cross(L.transpose() * up); };
    const auto pot = make_potential<double>(V, g);
    using S = Scene<double, std::decay_t<decltype(pot)>>;
    no_allocation_in_steps(Stepper<Scheme, S>(scheme, S(body, pot)), start, 0.01);
  }
  SECTION("failing steps (h far too large) allocate nothing either") {
    no_allocation_in_steps(Stepper<Scheme, HeavyTop<double>>(scheme, HeavyTop<double>(body, gravity)), start, 2.0, 5);
  }
}

}  // namespace

TEMPLATE_TEST_CASE("no heap allocation in a step", "[no_alloc]", SimoAlpha, SimoCollocation, SimoKappa,
                   GeradinBauchau, GeradinBauchauPaper, RK4) {
  all_scenes(TestType{});
}

// The pointers escape through volatile stores: a new-expression whose result goes nowhere may be
// elided (C++14 [expr.new]; g++ does at -O1), and the control would then fail at any optimisation
// but the sanitizer build's -O0.
namespace {
int* volatile escaped_int = nullptr;
double* volatile escaped_data = nullptr;
}  // namespace

TEST_CASE("the allocation counter works (a control)", "[no_alloc]") {
  CHECK(allocations_in([] {
          escaped_int = new int(3);
          delete escaped_int;
        }) == 1);
  CHECK(allocations_in([] {
          Eigen::MatrixXd m(4, 4);
          m.setZero();
          escaped_data = m.data();
        }) >= 1);
}

TEST_CASE("no heap allocation in composed steppers", "[no_alloc]") {
  const auto c = cases::ht1<double>();
  const ComposedStepper<SimoKappa, cases::Top<double>> st4(SimoKappa{}, c.scene, 4);
  const ComposedStepper<GeradinBauchau, cases::Top<double>> st6(GeradinBauchau{}, c.scene, 6);
  no_allocation_in_steps(st4, c.initial, 0.001);
  no_allocation_in_steps(st6, c.initial, 0.001);
}

TEST_CASE("no heap allocation in integrate without an observer, recovery included", "[no_alloc]") {
  const auto c = cases::ht0<double>();
  const Stepper<SimoKappa, cases::Top<double>> st(SimoKappa{}, c.scene);
  const Stepper<GeradinBauchau, cases::Top<double>> gb(GeradinBauchau{}, c.scene);
  State<double> s = c.initial, t = c.initial;
  IntegrationSummary<double> a, b;
  CHECK(allocations_in([&] { a = integrate(st, s, 1.0, 0.1); }) == 0);  // every interval recovered
  CHECK(allocations_in([&] { b = integrate(gb, t, 1.0, 0.05); }) == 0);
  CHECK(a.ok());
  CHECK(a.recovered == 10);
  CHECK(b.ok());
  CHECK(b.recovered == 20);
  // An observer that does not allocate keeps it so.
  double max_H = 0;
  State<double> u = c.initial;
  CHECK(allocations_in([&] {
          integrate(st, u, 1.0, 0.01, [&](const State<double>& x) { max_H = std::max(max_H, c.scene.energy(x)); });
        }) == 0);
  CHECK(max_H > 0);
}

TEST_CASE("no heap allocation for a scheme with memory (Stepper, ComposedStepper, integrate)", "[no_alloc][memory]") {
  using trompo_test::MidpointQ;
  const auto c = cases::ht1<double>();
  using Top = cases::Top<double>;
  const Stepper<MidpointQ, Top> st(MidpointQ{}, c.scene);
  const ComposedStepper<MidpointQ, Top> st4(MidpointQ{}, c.scene, Composition::suzuki5);
  auto traj = st.start(c.initial);
  auto traj4 = st4.start(c.initial);
  int ok = 0;
  CHECK(allocations_in([&] {
          for (int i = 0; i < 50; ++i) ok += st.step(traj, 0.001).ok() + st4.step(traj4, 0.001).ok();
        }) == 0);
  CHECK(ok == 100);
  CHECK(traj.memory.steps == 50);
  // integrate() with recovery by sub-steps: h too large for the fixed point on FB1.
  const auto f = cases::fb1<double>();
  const Stepper<MidpointQ, cases::Free<double>> free_st(MidpointQ{}, f.scene);
  auto ftraj = free_st.start(f.initial);
  const double h = 3.0 / f.initial.omega.norm();
  IntegrationSummary<double> sum;
  CHECK(allocations_in([&] { sum = integrate(free_st, ftraj, 10 * h, h); }) == 0);
  CHECK(sum.ok());
  CHECK(sum.recovered > 0);
}

TEST_CASE("no heap allocation in the splitting schemes and in 17-stage compositions with memory", "[no_alloc][memory]") {
  const auto c = cases::ht1<double>();
  using Top = cases::Top<double>;
  const RigidBody<double> body(Mat3{{2.0, 0.1, 0.2}, {0.1, 3.0, 0.3}, {0.2, 0.3, 4.0}});  // full inertia
  using Damped = Scene<double, UniformGravity<double>, ViscousDamping<double>, Rotor<double>>;
  const Damped damped(body, UniformGravity<double>(5.0, Vec3(0.1, 0.2, 1.0)), ViscousDamping<double>(0.1),
                      Rotor<double>(Vec3(0, 0, 0.5)));
  auto steps = [](const auto& stepper, const State<double>& s0, double h) {
    auto traj = stepper.start(s0);
    int ok = 0;
    const long count = allocations_in([&] {
      for (int i = 0; i < 50; ++i) ok += stepper.step(traj, h).ok();
    });
    CHECK(count == 0);
    CHECK(ok == 50);
  };
  for (const SplittingMethod m : {SplittingMethod::strang, SplittingMethod::chin_4a, SplittingMethod::chin_triple_jump,
                                  SplittingMethod::suzuki_5, SplittingMethod::kahan_li_9}) {
    INFO(to_string(m));
    steps(Stepper<Splitting, Top>(Splitting(m), c.scene), c.initial, 0.001);
    steps(Stepper<SplittingProjected, Top>(SplittingProjected(m), c.scene), c.initial, 0.001);
  }
  steps(Stepper<Splitting, Damped>(Splitting(SplittingMethod::kahan_li_9), damped), c.initial, 0.001);
  steps(ComposedStepper<SimoKappa, Top>(SimoKappa{}, c.scene, Composition::kahan_li17), c.initial, 0.001);
  steps(ComposedStepper<GeradinBauchau, Top>(GeradinBauchau{}, c.scene, Composition::mclachlan15), c.initial, 0.001);
}

TEST_CASE("no heap allocation in the processed composition (step, advance, output, integrate)", "[no_alloc][memory]") {
  const auto c = cases::ht1<double>();
  using Top = cases::Top<double>;
  const ProcessedStepper<SimoKappa, Top> st(SimoKappa{}, c.scene);
  auto traj = st.start(c.initial);
  int ok = 0;
  CHECK(allocations_in([&] {
          for (int i = 0; i < 20; ++i) ok += st.step(traj, 0.001).ok();
          for (int i = 0; i < 20; ++i) ok += st.advance(traj, 0.001).ok();
          ok += st.output(traj).ok();
        }) == 0);
  CHECK(ok == 41);
  // integrate(): deferred output, a last step of another h (re-processing), and recovery.
  auto t2 = st.start(c.initial);
  IntegrationSummary<double> sum;
  CHECK(allocations_in([&] { sum = integrate(st, t2, 0.105, 0.01); }) == 0);
  CHECK(sum.ok());
  CHECK(sum.steps == 11);
}

// The closed loop of docs/control.md: the sampled driver with its built-in controllers, the
// wheels' hold and saturation, the friction split around plain and composed steps [W17],
// adaptive steps between the samples, and magnetorquers with B-dot. What a controller of
// the user's allocates is the user's; the built-ins allocate nothing.
TEST_CASE("no heap allocation in the closed loop: wheels, friction, adaptive holds, magnetorquers", "[no_alloc][control]") {
  using Wheels = ReactionWheels<double>;
  using Sc = Scene<double, Wheels>;
  Wheels rw;
  for (int i = 0; i < 3; ++i)
    rw.add_wheel({.axis = Vec3::Unit(i), .inertia = 0.08, .speed0 = 100.0 * (i + 1), .max_torque = 0.2, .max_speed = 600.0});
  Wheels rw_friction = rw;
  for (int i = 0; i < 3; ++i) rw_friction.set_friction(i, 0.01);
  const Mat3 J = Vec3(900, 800, 600).asDiagonal();
  State<double> s0;
  s0.rotation = SO3d::exp(Vec3(0.1, 0.2, -0.3));
  s0.omega = Vec3(0.001, -0.01, 0.03);
  auto loop = [&](auto stepper, const auto& between) {
    State<double> s = s0;
    stepper.scene().template effect<Wheels>().start(s.time, s.omega);
    MrpPd<double> pd{.K = 3.5, .P = 30};
    SampledSummary<double> sum;
    const long count = allocations_in([&] { sum = integrate_sampled(stepper, s, 5.0, 0.1, pd, between); });
    CHECK(count == 0);
    CHECK(sum.ok());
    CHECK(sum.samples == 50);
  };
  SECTION("fixed steps, plain and composed, and the splitting") {
    loop(Stepper<SimoKappa, Sc>(SimoKappa{}, Sc(rw.hub_body(J), rw)), FixedSteps<double>{0.05});
    loop(ComposedStepper<SimoKappa, Sc>(SimoKappa{}, Sc(rw.hub_body(J), rw), 6), FixedSteps<double>{0.1});
    loop(Stepper<Splitting, Sc>(Splitting(SplittingMethod::kahan_li_9), Sc(rw.hub_body(J), rw)), FixedSteps<double>{0.1});
  }
  SECTION("the near-integrable compositions with wheels [W18], asymmetric and symmetric hubs") {
    const Mat3 J_sym = Vec3(800, 800, 600).asDiagonal();
    for (SplittingMethod method : {SplittingMethod::saba2c, SplittingMethod::saba4c, SplittingMethod::sbab3c}) {
      loop(Stepper<Splitting, Sc>(Splitting(method), Sc(rw.hub_body(J), rw)), FixedSteps<double>{0.05});
      loop(Stepper<Splitting, Sc>(Splitting(method), Sc(rw.hub_body(J_sym), rw)), FixedSteps<double>{0.1});
    }
  }
  SECTION("friction split around plain and composed steps") {
    loop(Stepper<SimoKappa, Sc>(SimoKappa{}, Sc(rw_friction.hub_body(J), rw_friction)), FixedSteps<double>{0.05});
    loop(ComposedStepper<SimoKappa, Sc>(SimoKappa{}, Sc(rw_friction.hub_body(J), rw_friction), 4), FixedSteps<double>{0.1});
  }
  SECTION("adaptive steps between the samples") {
    loop(Stepper<SimoKappa, Sc>(SimoKappa{}, Sc(rw.hub_body(J), rw)), AdaptiveSteps<double>{{.rtol = 1e-8, .atol = 1e-8}});
    // with friction: the adaptive driver on the split step [W17]
    loop(Stepper<SimoKappa, Sc>(SimoKappa{}, Sc(rw_friction.hub_body(J), rw_friction)),
         AdaptiveSteps<double>{{.rtol = 1e-8, .atol = 1e-8}});
    loop(ComposedStepper<SimoKappa, Sc>(SimoKappa{}, Sc(rw_friction.hub_body(J), rw_friction), 4),
         AdaptiveSteps<double>{{.rtol = 1e-8, .atol = 1e-8}});
  }
  SECTION("magnetorquers and B-dot") {
    using Mag = Scene<double, Magnetorquer<double>>;
    const CircularOrbit<double> orbit(6771e3, 0.9, 0.3, 0.2);
    Stepper<Splitting, Mag> stepper(Splitting(SplittingMethod::kahan_li_9),
                                    Mag(RigidBody<double>(Vec3(0.033, 0.034, 0.007), allow_unphysical_inertia),
                                        Magnetorquer<double>(DipoleField<double>(orbit), Vec3::Constant(0.2))));
    State<double> s;
    s.omega = Vec3::Constant(0.5);
    BDot<double> bdot{.k = 1e4};
    SampledSummary<double> sum;
    const long count = allocations_in([&] {
      sum = integrate_sampled(stepper, s, 10.0, 0.25, bdot, FixedSteps<double>{0.25, {}, 0.15});
    });
    CHECK(count == 0);
    CHECK(sum.ok());
    CHECK(sum.samples == 40);
  }
}
