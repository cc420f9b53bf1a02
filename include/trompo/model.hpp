#pragma once
// Layer 2, the mechanics: body, state, scene and its effects, the standard cases.
#include "trompo/lie.hpp"
#include "trompo/model/body.hpp"
#include "trompo/model/cases.hpp"
#include "trompo/model/effects/external_torque.hpp"
#include "trompo/model/effects/gravity_gradient.hpp"
#include "trompo/model/effects/potential.hpp"
#include "trompo/model/effects/rotor.hpp"
#include "trompo/model/effects/uniform_gravity.hpp"
#include "trompo/model/effects/viscous_damping.hpp"
#include "trompo/model/heavy_top.hpp"
#include "trompo/model/scene.hpp"
#include "trompo/model/state.hpp"
