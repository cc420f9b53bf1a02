#pragma once
// The scheme of examples/example_own_scheme.cpp (README "Write your own scheme"): the
// implicit midpoint rule on the unit quaternion q and Ω of a free body, solved by
// fixed-point iteration, with a memory that counts the steps taken along the trajectory.
//
// A header of its own so that a test build can register it (include/trompo/schemes/
// registry.hpp, TROMPO_EXTRA_SCHEMES): tests/CMakeLists.txt then builds the CLI and the
// generic property tests with it and checks it appears in both with no other edit.
#include <trompo/trompo.hpp>

namespace example {
using namespace trompo;

struct Midpoint {  // the implicit midpoint rule on (q, Ω), free body
  static constexpr const char* name = "my-midpoint";
  static constexpr SchemeTraits traits{                    // its properties, checked by the compiler
      .order = 2,
      .symmetric = true,                                      // Φ_{−h} = Φ_h⁻¹: may be composed
      .keeps = [](SceneKind s) { return Keeps{.energy = s.is_free}; },  // H on the free body
      .memory = MemoryUse::carried};                          // it has a Memory, part of the trajectory
  template <class Scene> struct Memory { long steps = 0; };  // what it carries between steps

  template <class Scene>
  StepReport<double> step(const Scene& scene, const State<double>& in, double h, const NewtonOptions<double>&,
                          State<double>& out, Memory<Scene>& memory) const {
    const Eigen::Vector4d q0 = in.rotation.unit_quaternion().coeffs();
    Eigen::Vector4d q = q0;
    Eigen::Vector3d w = in.omega;
    StepReport<double> report;
    report.status = StepStatus::not_converged;
    for (report.iterations = 1; report.iterations <= 50; ++report.iterations) {  // fixed point
      const Eigen::Vector3d wm = (in.omega + w) / 2;                             // Ω_m
      const Eigen::Quaterniond qm(Eigen::Vector4d((q0 + q) / 2));               // q_m
      const Eigen::Vector4d q_new = q0 + h / 2 * (qm * Eigen::Quaterniond(0, wm.x(), wm.y(), wm.z())).coeffs();
      const Eigen::Vector3d w_new = in.omega + h * scene.body().inertia_inverse() * scene.momentum(wm).cross(wm);
      const double change = (q_new - q).norm() + (w_new - w).norm();
      q = q_new;
      w = w_new;
      if (!(change < 1e3)) break;  // diverging (or NaN): report the failure
      if (change <= 1e-15 * (1 + in.omega.norm())) { report.status = StepStatus::ok; break; }
    }
    if (!report.ok()) return report;  // the Stepper leaves state and memory untouched
    out.rotation = SO3d::renormalized(Eigen::Quaterniond(q));
    out.omega = w;
    out.time = in.time + h;
    ++memory.steps;
    return report;
  }
};
static_assert(SchemeFor<Midpoint, FreeScene<double>>);

}  // namespace example
