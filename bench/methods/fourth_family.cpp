// The fourth family (docs/theory.md §19) in trompo-bench: the LGVI and the DMV, symmetric and
// in the registry's composable list, join the plain Δt sweep and the per-step family with the
// other registered schemes (bench_main.cpp); here their compositions (Suzuki-5, Kahan–Li-9),
// the explicit Lie group methods RKMK4 and Crouch–Grossman 3 (run plain: not symmetric), and
// the pair step-pair/<case>/lgvi/vs:simo-kappa that measures the target "an LGVI step costs at
// most a Simo-κ step at equal h" (both one 3×3 Newton solve; the two timed in alternation).
#include <string>

#include "bench_common.hpp"
#include "trompo/schemes/lie_rk/crouch_grossman.hpp"
#include "trompo/schemes/lie_rk/rkmk4.hpp"
#include "trompo/schemes/simo/simo_kappa.hpp"
#include "trompo/schemes/variational/lgvi.hpp"

namespace {

using namespace trompo;
using namespace trompo_bench;

/// The explicit Lie group methods, plain, on the grid of RK4 (orders 3 and 4).
template <class SceneT>
void explicit_sweeps(const Problem<SceneT>& p) {
  register_sweep_with(p, "rkmk4", RKMK4::name, p.rk4,
                      [](const SceneT& scene) { return Stepper<RKMK4, SceneT>(RKMK4{}, scene); });
  register_sweep_with(p, "crouch-grossman", CrouchGrossman3::name, p.rk4,
                      [](const SceneT& scene) { return Stepper<CrouchGrossman3, SceneT>(CrouchGrossman3{}, scene); });
}

template <class SceneT>
void fourth_family_sweeps_of(const Problem<SceneT>& p) {
  register_sweep(p, LGVI{}, Composition::suzuki5, p.o4s);
  register_sweep(p, LGVI{}, Composition::kahan_li9, p.o6);
  explicit_sweeps(p);
}

template <class SceneT>
void fourth_family_steps_of(const Problem<SceneT>& p) {
  register_step(p, LGVI{}, Composition::suzuki5);
  register_step_with(p, "rkmk4", RKMK4::name, [](const SceneT& scene) { return Stepper<RKMK4, SceneT>(RKMK4{}, scene); });
  register_step_with(p, "crouch-grossman", CrouchGrossman3::name,
                     [](const SceneT& scene) { return Stepper<CrouchGrossman3, SceneT>(CrouchGrossman3{}, scene); });
  register_step_pair(p, "lgvi", SimoKappa{}, [](const SceneT& scene) { return Stepper<LGVI, SceneT>(LGVI{}, scene); });
}

void register_fourth_sweeps() {
  for (const auto& p : tops) fourth_family_sweeps_of(p);
  for (const auto& p : frees) fourth_family_sweeps_of(p);
}

void register_fourth_steps() {
  for (const auto& p : tops) fourth_family_steps_of(p);
  for (const auto& p : frees) fourth_family_steps_of(p);
}

}  // namespace

const trompo_bench::MethodFamily fourth_family{"fourth-family", register_fourth_steps, register_fourth_sweeps};
