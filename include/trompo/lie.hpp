#pragma once
// Layer 1, rotations: SO(3), its exponential and tangents, the small-angle series.
#include "trompo/lie/euler_poinsot.hpp"
#include "trompo/lie/jacobi.hpp"
#include "trompo/lie/lie_kit.hpp"
#include "trompo/lie/series.hpp"
#include "trompo/lie/so3.hpp"
