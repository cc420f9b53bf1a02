#pragma once
// Flight software (the layer between model/ and drivers/): what a controller sees and returns, and the built-in laws
// (MRP feedback, B-dot). The sampled driver that calls them is drivers/sampled.hpp.
#include "trompo/control/bdot.hpp"
#include "trompo/control/command.hpp"
#include "trompo/control/mrp_feedback.hpp"
