// No heap allocation in a step of the families of docs/theory.md §11 (gen-α, the
// energy-decaying scheme, the constrained trapezoid), proven as in test_no_alloc.cpp:
//  - every global operator new/delete of this executable is replaced by a counting one;
//  - Eigen's own heap (aligned_malloc, which bypasses operator new) is watched with
//    EIGEN_RUNTIME_NO_MALLOC, whose check goes through eigen_assert, defined here so that
//    it records a violation in Release builds too (where the plain assert is compiled out).
#include <atomic>
#include <cstdlib>
#include <new>

namespace no_alloc {
/// Violations of EIGEN_RUNTIME_NO_MALLOC (or of any other Eigen assertion) in this file.
inline std::atomic<long> eigen_violations{0};
inline void eigen_violation(const char* /*what*/) { ++eigen_violations; }
/// operator new calls while `counting` is set.
inline std::atomic<long> news{0};
inline std::atomic<bool> counting{false};
}  // namespace no_alloc

#define EIGEN_RUNTIME_NO_MALLOC
#define eigen_assert(x)                                 \
  do {                                                  \
    if (!static_cast<bool>(x)) no_alloc::eigen_violation(#x); \
  } while (false)

#include <catch2/catch.hpp>

#include "trompo/trompo.hpp"

// ---- the counting global allocation functions ---------------------------------------------
namespace {
void* counted(std::size_t n) {
  if (no_alloc::counting.load(std::memory_order_relaxed)) ++no_alloc::news;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* counted_aligned(std::size_t n, std::align_val_t a) {
  if (no_alloc::counting.load(std::memory_order_relaxed)) ++no_alloc::news;
  const std::size_t al = static_cast<std::size_t>(a);
  if (void* p = std::aligned_alloc(al, (n + al - 1) / al * al)) return p;
  throw std::bad_alloc();
}
}  // namespace

void* operator new(std::size_t n) { return counted(n); }
void* operator new[](std::size_t n) { return counted(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new(std::size_t n, std::align_val_t a) { return counted_aligned(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return counted_aligned(n, a); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }


using namespace trompo;
using Vec3 = Eigen::Vector3d;

namespace {

template <class F>
long allocations_in(F&& f) {
  const long eigen_before = no_alloc::eigen_violations.load();
  no_alloc::news = 0;
  Eigen::internal::set_is_malloc_allowed(false);
  no_alloc::counting = true;
  f();
  no_alloc::counting = false;
  Eigen::internal::set_is_malloc_allowed(true);
  return no_alloc::news.load() + (no_alloc::eigen_violations.load() - eigen_before);
}

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
