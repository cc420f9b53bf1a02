#pragma once
// trompo: structure-preserving integrators for nonlinear rigid-body rotation.
// The umbrella header; each part is usable on its own.
#include "trompo/body.hpp"
#include "trompo/cases.hpp"
#include "trompo/composition.hpp"
#include "trompo/effects/external_torque.hpp"
#include "trompo/effects/potential.hpp"
#include "trompo/effects/rotor.hpp"
#include "trompo/effects/uniform_gravity.hpp"
#include "trompo/effects/viscous_damping.hpp"
#include "trompo/ensemble.hpp"
#include "trompo/errors.hpp"
#include "trompo/integrate.hpp"
#include "trompo/newton.hpp"
#include "trompo/processed_composition.hpp"
#include "trompo/scene.hpp"
#include "trompo/scheme.hpp"
#include "trompo/schemes/constrained_trapezoid.hpp"
#include "trompo/schemes/energy_decaying.hpp"
#include "trompo/schemes/geradin_bauchau.hpp"
#include "trompo/schemes/geradin_bauchau_paper.hpp"
#include "trompo/schemes/lie_gen_alpha.hpp"
#include "trompo/schemes/rk4.hpp"
#include "trompo/schemes/simo_alpha.hpp"
#include "trompo/schemes/simo_collocation.hpp"
#include "trompo/schemes/simo_kappa.hpp"
#include "trompo/schemes/splitting.hpp"
#include "trompo/so3.hpp"
#include "trompo/state.hpp"
#include "trompo/stepper.hpp"

namespace trompo {
/// The heavy top: a body under uniform gravity.
template <class Scalar>
using HeavyTop = Scene<Scalar, UniformGravity<Scalar>>;
}  // namespace trompo
