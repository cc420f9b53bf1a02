#pragma once
// The heavy top: a body under uniform gravity (docs/theory.md §1).
#include "trompo/model/effects/uniform_gravity.hpp"
#include "trompo/model/scene.hpp"

namespace trompo {
/// The heavy top: a body under uniform gravity.
template <class Scalar>
using HeavyTop = Scene<Scalar, UniformGravity<Scalar>>;
}  // namespace trompo
