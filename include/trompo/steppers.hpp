#pragma once
// Layer 5, steppers: commit-on-success stepping, composition and processed composition.
#include "trompo/schemes.hpp"
#include "trompo/steppers/composition.hpp"
#include "trompo/steppers/composition_core.hpp"
#include "trompo/steppers/processed_composition.hpp"
#include "trompo/steppers/stepper.hpp"
