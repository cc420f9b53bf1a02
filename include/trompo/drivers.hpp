#pragma once
// Layer 6, drivers: runs to an end time with recovery, adaptive steps with dense output and
// events, ensembles across threads.
#include "trompo/drivers/adaptive.hpp"
#include "trompo/drivers/dense_output.hpp"
#include "trompo/drivers/ensemble.hpp"
#include "trompo/drivers/integrate.hpp"
#include "trompo/drivers/invariant_hold.hpp"
#include "trompo/drivers/sampled.hpp"
#include "trompo/steppers.hpp"
