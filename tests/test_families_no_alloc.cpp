// No heap allocation in a step of the families of docs/theory.md §11 (gen-α, the
// energy-decaying scheme, the constrained trapezoid), proven as in test_no_alloc.cpp:
//  - every global operator new/delete of this executable is replaced by a counting one;
//  - Eigen's own heap (aligned_malloc, which bypasses operator new) is watched with
//    EIGEN_RUNTIME_NO_MALLOC, whose check goes through eigen_assert, defined here so that
//    it records a violation in Release builds too (where the plain assert is compiled out).
#include "support/allocation_counter.hpp"  // first: it replaces operator new/delete

#include <catch2/catch.hpp>

#include "trompo/trompo.hpp"

using namespace trompo;
using no_alloc::allocations_in;
using Vec3 = Eigen::Vector3d;

namespace {

/// n steps of a trajectory (the memory included), none allocating.
template <class Scheme, class S>
void no_allocation_in_steps(const Scheme& scheme, const S& scene, double h, int n = 50) {
  State<double> s;
  s.rotation = SO3d::exp(Vec3(0.3, -0.2, 0.1));
  s.omega = Vec3(0.5, -1.0, 3.0);
  const Stepper<Scheme, S> st(scheme, scene);
  auto traj = st.start(s);
  int ok = 0, failed = 0;
  const long count = allocations_in([&] {
    for (int i = 0; i < n; ++i) (st.step(traj, h).ok() ? ok : failed)++;
  });
  INFO(ok << " steps ok, " << failed << " failed");
  CHECK(count == 0);
  CHECK(ok + failed == n);
}

template <class Scheme>
void conservative_scenes(const Scheme& scheme) {
  const RigidBody<double> body(Vec3(1, 2, 2.5));
  const UniformGravity<double> gravity(5.0, Vec3(0.1, 0.2, 1.0));
  no_allocation_in_steps(scheme, Scene<double>(body), 0.01);
  no_allocation_in_steps(scheme, HeavyTop<double>(body, gravity), 0.01);
  no_allocation_in_steps(scheme, HeavyTop<double>(body, gravity), 2.0, 5);  // failing steps
  using R = Scene<double, UniformGravity<double>, Rotor<double>>;
  no_allocation_in_steps(scheme, R(body, gravity, Rotor<double>(Vec3(0, 0, 0.5))), 0.01);
}

}  // namespace

TEST_CASE("Families: no heap allocation in a step (free body, heavy top, rotor, failing steps)", "[no_alloc][families]") {
  conservative_scenes(LieGenAlpha(0.8, LieGenAlpha::Start::perturbed));
  conservative_scenes(EnergyDecaying(1.0 / 9, ChiSchedule::sensor));
  conservative_scenes(ConstrainedTrapezoid{});
  // gen-α on any scene: damping and torques too
  const RigidBody<double> body(Vec3(1, 2, 2.5));
  using S = Scene<double, UniformGravity<double>, ViscousDamping<double>, ConstantBodyTorque<double>,
                  ConstantSpaceTorque<double>, Rotor<double>>;
  const S scene(body, UniformGravity<double>(5.0, Vec3(0.1, 0.2, 1.0)), ViscousDamping<double>(0.1),
                ConstantBodyTorque<double>(Vec3(0.1, 0, 0)), ConstantSpaceTorque<double>(Vec3(0, 0.1, 0)),
                Rotor<double>(Vec3(0, 0, 0.5)));
  no_allocation_in_steps(LieGenAlpha(0.0), scene, 0.01);
}

TEST_CASE("Families: no heap allocation in integrate with a trajectory, recovery included", "[no_alloc][families]") {
  const auto c = cases::ht0<double>();
  const Stepper<EnergyDecaying, cases::Top<double>> st(EnergyDecaying(0.0), c.scene);
  auto traj = st.start(c.initial);
  IntegrationSummary<double> sum;
  CHECK(allocations_in([&] { sum = integrate(st, traj, 1.0, 0.2); }) == 0);
  CHECK(sum.ok());
}
