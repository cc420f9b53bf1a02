// The open Scheme concept (scheme.hpp): a scheme defined here, outside include/, with a
// memory between steps (tests/support/midpoint_scheme.hpp), runs through Stepper,
// ComposedStepper and integrate(), and keeps the step contract for its memory as for the
// state: a failed step leaves both bit-identical; sub-steps and composition sub-steps
// carry it; a trajectory starts it fresh; reset() forgets it.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <type_traits>

#include "support/midpoint_scheme.hpp"
#include "support/same_bits.hpp"
#include "trompo/trompo.hpp"

using namespace trompo;
using trompo_test::MidpointQ;
using trompo_test::same_bits;
using Vec3 = Eigen::Vector3d;

namespace {

using Free = cases::Free<double>;
using Top = cases::Top<double>;
using Memory = scheme_memory_t<MidpointQ, Free>;

// ---- the concept, at compile time ------------------------------------------------------
static_assert(SchemeFor<MidpointQ, Free>);
static_assert(SchemeFor<MidpointQ, Top>);
static_assert(has_memory_v<MidpointQ, Free>);
static_assert(!has_memory_v<SimoAlpha, Free>);
static_assert(std::is_same_v<scheme_memory_t<SimoAlpha, Top>, NoMemory>);
// The energy-exact schemes carry their history predictor's memory and the compensated
// state's residue (SimoMemory), which are only a hint: a plain State may still be stepped
// (each step from fresh memory).
static_assert(std::is_same_v<scheme_memory_t<SimoKappa, Top>, detail::SimoMemory<double>>);
static_assert(std::is_base_of_v<IncrementHistory<double>, scheme_memory_t<SimoKappa, Top>>);
static_assert(has_memory_v<GeradinBauchau, Free> && has_memory_v<SimoCollocation, Top>);
static_assert(memory_is_hint_v<SimoKappa, Top> && memory_is_hint_v<SimoAlpha, Top> && !memory_is_hint_v<MidpointQ, Free>);
static_assert(SchemeFor<SimoAlpha, Top> && SchemeFor<SimoCollocation, Top> && SchemeFor<SimoKappa, Top> &&
              SchemeFor<GeradinBauchau, Top> && SchemeFor<GeradinBauchauPaper, Top> && SchemeFor<RK4, Top>);
/// A type that is not a scheme (no traits, no step) is refused by the concept.
struct NotAScheme {};
static_assert(!SchemeFor<NotAScheme, Free>);

// ---- traits the compiler checks --------------------------------------------------------
// A name and a step, as a scheme has; declared only (the concept reads signatures).
struct StepOnly {
  static constexpr const char* name = "step-only";
  template <class Scene>
  StepReport<typename Scene::Scalar> step(const Scene&, const State<typename Scene::Scalar>&, typename Scene::Scalar,
                                          const NewtonOptions<typename Scene::Scalar>&, State<typename Scene::Scalar>&,
                                          NoMemory&) const;
};
/// Without the required traits value, a step alone is not a scheme (before, order, symmetry
/// and what it keeps were separate members, the optional ones found by `requires`).
static_assert(!SchemeFor<StepOnly, Free>);
/// With it, it is.
struct WithTraits : StepOnly {
  static constexpr SchemeTraits traits{.order = 2, .symmetric = true};
};
static_assert(SchemeFor<WithTraits, Free>);
/// A traits member of another type (the old `static constexpr bool symmetric` habit) is refused.
struct WrongTraitsType : StepOnly {
  static constexpr bool traits = true;
};
static_assert(!SchemeFor<WrongTraitsType, Free>);
/// The traits announce a run-time refinement that the scheme misspells (`refine`): refused,
/// where the optional `is_symmetric` of before was silently ignored and a first-order
/// Simo-α composed.
struct MisspeltRefinement : StepOnly {
  static constexpr SchemeTraits traits{.order = 2, .symmetric = true, .refined = true};
  SchemeTraits refine() const;
};
static_assert(!SchemeFor<MisspeltRefinement, Free>);
/// A refinement the traits do not announce is refused too: it would never be read.
struct UnannouncedRefinement : StepOnly {
  static constexpr SchemeTraits traits{.order = 2, .symmetric = true};
  SchemeTraits refined() const;
};
static_assert(!SchemeFor<UnannouncedRefinement, Free>);
/// Likewise a parameter check: announced and misspelt, or present and not announced.
struct MisspeltValidate : StepOnly {
  static constexpr SchemeTraits traits{.order = 2, .validated = true};
  void validates() const;
};
struct UnannouncedValidate : StepOnly {
  static constexpr SchemeTraits traits{.order = 2};
  void validate() const;
};
static_assert(!SchemeFor<MisspeltValidate, Free> && !SchemeFor<UnannouncedValidate, Free>);
/// A memory the traits announce must exist (a misspelt `Memroy` is refused), and the reverse.
struct AnnouncedMemoryMissing : StepOnly {
  static constexpr SchemeTraits traits{.order = 2, .memory = MemoryUse::carried};
  template <class Scene>
  struct Memroy {};
};
struct UnannouncedMemory : StepOnly {
  static constexpr SchemeTraits traits{.order = 2};
  template <class Scene>
  using Memory = NoMemory;
};
static_assert(!SchemeFor<AnnouncedMemoryMissing, Free> && !SchemeFor<UnannouncedMemory, Free>);
/// Writing the memory on success only means nothing without a memory.
struct WritesNoMemory : StepOnly {
  static constexpr SchemeTraits traits{.order = 2, .writes_memory_on_success = true};
};
static_assert(!SchemeFor<WritesNoMemory, Free>);
// (A misspelt field of the traits value itself, `.symetric = true`, does not compile at all:
// designated initialisers name existing fields only.)
/// A memoryless composed stepper carries no memory either: zero cost.
static_assert(std::is_same_v<ComposedStepper<SimoAlpha, Top>::Memory, NoMemory>);
static_assert(std::is_same_v<Stepper<SimoAlpha, Top>::TrajectoryType, Trajectory<double, NoMemory>>);

bool same_memory(const Memory& a, const Memory& b) { return std::memcmp(&a, &b, sizeof(Memory)) == 0; }

}  // namespace

TEST_CASE("Scheme concept: the traits a test reads come from the scheme", "[scheme]") {
  const MidpointQ m;
  CHECK(symmetric(m));
  CHECK(order_of_accuracy(m) == 2);
  CHECK(keeps<Free>(m).energy);
  CHECK_FALSE(keeps<Top>(m).energy);
  CHECK_FALSE(keeps<Free>(m).momentum_map);
  // Run-time refinements: Simo-α is symmetric and second order at α = ½ only.
  CHECK(symmetric(SimoAlpha(0.5)));
  CHECK_FALSE(symmetric(SimoAlpha(0.3)));
  CHECK(order_of_accuracy(SimoAlpha(0.3)) == 1);
  CHECK(order_of_accuracy(SimoAlpha(0.5)) == 2);
  // The refinement changes what is kept, too: the energy-decaying scheme keeps H at χ = 0 only.
  CHECK(keeps<Top>(EnergyDecaying(0.0)).energy);
  CHECK_FALSE(keeps<Top>(EnergyDecaying(0.5)).energy);
  CHECK(keeps<Top>(EnergyDecaying(0.5)).energy_decays);
  CHECK_FALSE(scheme_keeps_v<EnergyDecaying, Top>.energy);  // the static traits: only what every χ keeps
  CHECK(order_of_accuracy(Splitting(SplittingMethod::kahan_li_9)) == 6);
  CHECK_FALSE(symmetric(RK4{}));
  CHECK(order_of_accuracy(RK4{}) == 4);
  // Per kind of scene: GB keeps H only for potentials linear in Λ; [T5] never keeps μ.
  CHECK(keeps<Top>(GeradinBauchau{}).energy);
  CHECK_FALSE(keeps<Top>(GeradinBauchauPaper{}).momentum_map);
  CHECK(keeps<Free>(SimoKappa{}).spatial_momentum);
  CHECK_FALSE(keeps<Top>(SimoKappa{}).spatial_momentum);
  // The splitting keeps μ on every scene, π only where the scene's flow keeps it.
  CHECK(keeps<Top>(Splitting(SplittingMethod::strang)).momentum_map);
  CHECK_FALSE(keeps<Top>(Splitting(SplittingMethod::strang)).spatial_momentum);
  CHECK(keeps<Free>(SplittingProjected(SplittingMethod::chin_4a)).spatial_momentum);
  CHECK(keeps<Free>(SplittingProjected(SplittingMethod::chin_4a)).energy);
}

TEST_CASE("Scheme concept: a user scheme with memory through Stepper keeps H on FB1 and counts its steps",
          "[scheme][memory]") {
  const auto c = cases::fb1<double>();
  const Stepper<MidpointQ, Free> stepper(MidpointQ{}, c.scene);
  auto traj = stepper.start(c.initial);
  CHECK(traj.memory.steps == 0);
  const double H0 = c.scene.energy(traj);
  double max_dH = 0;
  for (int i = 0; i < 2000; ++i) {
    REQUIRE(stepper.step(traj, 0.01).ok());
    max_dH = std::max(max_dH, std::abs(c.scene.energy(traj) - H0) / H0);
  }
  INFO("midpoint on FB1, 2000 steps of 0.01: max |dH/H| = " << max_dH);
  CHECK(traj.memory.steps == 2000);
  // The trait says H is kept on the free body: to round-off.
  REQUIRE(stepper.keeps().energy);
  CHECK(max_dH <= 1e-13);
  // A state edited by hand: reset() forgets the memory.
  traj.omega *= 0.5;
  traj.reset();
  CHECK(traj.memory.steps == 0);
  REQUIRE(stepper.step(traj, 0.01).ok());
  CHECK(traj.memory.steps == 1);
}

TEST_CASE("Scheme concept: observed order of the user scheme is its trait (self-convergence on HT1)", "[scheme][order]") {
  const auto c = cases::ht1<double>();
  const Stepper<MidpointQ, Top> stepper(MidpointQ{}, c.scene);
  auto run = [&](double h) {
    State<double> s = c.initial;
    const auto sum = integrate(stepper, s, 0.5, h);  // a plain State: a fresh trajectory
    REQUIRE(sum.ok());
    return s;
  };
  const State<double> s1 = run(0.002), s2 = run(0.001), s3 = run(0.0005);
  const double e1 = (s1.rotation.matrix() - s2.rotation.matrix()).norm();
  const double e2 = (s2.rotation.matrix() - s3.rotation.matrix()).norm();
  const double p = std::log2(e1 / e2);
  INFO("self-convergence errors " << e1 << ", " << e2 << ": order " << p);
  CHECK(std::abs(p - MidpointQ::traits.order) <= 0.1);
}

TEST_CASE("Scheme concept: a failed step leaves state and memory bit-identical", "[scheme][memory][contract]") {
  const auto c = cases::fb1<double>();
  const Stepper<MidpointQ, Free> stepper(MidpointQ{}, c.scene);
  auto traj = stepper.start(c.initial);
  for (int i = 0; i < 5; ++i) REQUIRE(stepper.step(traj, 0.01).ok());
  const auto before = traj;
  // |hΩ| far beyond the fixed point's contraction: the step fails.
  const double h_bad = 40.0 / c.initial.omega.norm();
  const StepReport<double> rep = stepper.step(traj, h_bad);
  REQUIRE_FALSE(rep.ok());
  INFO(rep.reason());
  CHECK(same_bits(traj.state(), before.state()));
  CHECK(same_memory(traj.memory, before.memory));
  CHECK(traj.memory.steps == 5);
  // Δt = 0 and NaN are refused before the scheme is called.
  CHECK(stepper.step(traj, 0.0).status == StepStatus::invalid_step);
  CHECK(stepper.step(traj, std::nan("")).status == StepStatus::invalid_step);
  CHECK(same_memory(traj.memory, before.memory));
}

TEST_CASE("Scheme concept: integrate() carries the memory through recovered sub-steps", "[scheme][memory][integrate]") {
  const auto c = cases::fb1<double>();
  const Stepper<MidpointQ, Free> stepper(MidpointQ{}, c.scene);
  auto traj = stepper.start(c.initial);
  // h with |hΩ| ≈ 3: every whole step fails and is recovered by halves or quarters.
  const double h = 3.0 / c.initial.omega.norm();
  const auto sum = integrate(stepper, traj, 10 * h, h);
  REQUIRE(sum.ok());
  INFO("steps " << sum.steps << ", recovered " << sum.recovered << ", sub-steps " << sum.substeps << ", failures "
                << sum.failures);
  CHECK(sum.recovered > 0);
  // Every accepted step, whole or sub-step, advanced the memory once; failed ones did not.
  CHECK(traj.memory.steps == sum.steps + sum.substeps);
  // And the memory carries over to the next call.
  const auto more = integrate(stepper, traj, traj.time + 0.1, 0.01);
  REQUIRE(more.ok());
  CHECK(traj.memory.steps == sum.steps + sum.substeps + more.steps + more.substeps);
  // An interval that cannot be recovered leaves state and memory as the last good step did.
  auto stuck = stepper.start(c.initial);
  IntegrateOptions no_recovery;
  no_recovery.max_halvings = 0;
  const auto fail = integrate(stepper, stuck, 10 * h, h, NoObserver{}, no_recovery);
  CHECK_FALSE(fail.ok());
  CHECK(same_bits(stuck.state(), c.initial));
  CHECK(stuck.memory.steps == 0);
}

TEST_CASE("Scheme concept: ComposedStepper gives each sub-step index its own memory", "[scheme][memory][composition]") {
  const auto c = cases::fb1<double>();
  const ComposedStepper<MidpointQ, Free> composed(MidpointQ{}, c.scene, Composition::suzuki5);
  auto traj = composed.start(c.initial);
  static_assert(std::is_same_v<decltype(traj.memory), std::array<Memory, CompositionCoefficients<double>::max_stages>>);
  const double H0 = c.scene.energy(traj);
  for (int i = 0; i < 100; ++i) REQUIRE(composed.step(traj, 0.02).ok());
  for (int i = 0; i < composed.stages(); ++i) CHECK(traj.memory[static_cast<std::size_t>(i)].steps == 100);
  for (std::size_t i = static_cast<std::size_t>(composed.stages()); i < traj.memory.size(); ++i)
    CHECK(traj.memory[i].steps == 0);
  // Every sub-step is a base step: what the base keeps, the composition keeps.
  CHECK(composed.keeps().energy);
  CHECK(std::abs(c.scene.energy(traj) - H0) / H0 <= 1e-13);
  // A sub-step that fails (the long backward middle one is the first to) leaves all as it was.
  const auto before = traj;
  const StepReport<double> rep = composed.step(traj, 12.0 / c.initial.omega.norm());
  REQUIRE_FALSE(rep.ok());
  CHECK(same_bits(traj.state(), before.state()));
  CHECK(std::memcmp(traj.memory.data(), before.memory.data(), sizeof(traj.memory)) == 0);
}

TEST_CASE("Scheme concept: the composed user scheme reaches order 4 (Suzuki-5, self-convergence on HT1)",
          "[scheme][order][composition]") {
  const auto c = cases::ht1<double>();
  const ComposedStepper<MidpointQ, Top> composed(MidpointQ{}, c.scene, Composition::suzuki5);
  auto run = [&](double h) {
    auto traj = composed.start(c.initial);
    REQUIRE(integrate(composed, traj, 0.5, h).ok());
    return traj.state();
  };
  const State<double> s1 = run(0.01), s2 = run(0.005), s3 = run(0.0025);
  const double e1 = (s1.rotation.matrix() - s2.rotation.matrix()).norm();
  const double e2 = (s2.rotation.matrix() - s3.rotation.matrix()).norm();
  const double p = std::log2(e1 / e2);
  INFO("Suzuki-5 of the midpoint: self-convergence errors " << e1 << ", " << e2 << ": order " << p);
  CHECK(std::abs(p - composed.order()) <= 0.2);
}
