#pragma once
// Layer 6, drivers: runs to an end time with recovery, ensembles across threads.
#include "trompo/drivers/ensemble.hpp"
#include "trompo/drivers/integrate.hpp"
#include "trompo/steppers.hpp"
