#pragma once
// Beside the layers: closed-form references (the Lagrange top, the torque-free body).
// Needs the Boost.Math headers besides Eigen (target trompo::exact).
#include "trompo/exact/free_body.hpp"
#include "trompo/exact/lagrange_top.hpp"
