#pragma once
// Layer 3, the nonlinear solvers the implicit schemes call: Newton and damped Newton.
#include "trompo/solvers/damped_newton.hpp"
#include "trompo/solvers/newton.hpp"
