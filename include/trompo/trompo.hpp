#pragma once
// trompo: structure-preserving integrators for nonlinear rigid-body rotation.
// The umbrella header. The library is layered, each folder one layer, each layer
// including only those below it (docs/design.md, "Layers"):
//   lie/ ← model/ ← solvers/ ← schemes/ ← steppers/ ← drivers/     (exact/ beside)
//   model/ ← control/ ← drivers/ (flight software: commands, samples, MRP feedback, B-dot)
// Each layer has its umbrella (trompo/lie.hpp, …); each header is usable on its own.
// exact/ needs Boost.Math and is not included here (trompo/exact.hpp).
#include "trompo/control.hpp"
#include "trompo/drivers.hpp"
#include "trompo/errors.hpp"
