#pragma once
// Layer 3, the nonlinear solvers the implicit schemes call: Newton, damped Newton and the
// small LU the latter solves with.
#include "trompo/solvers/damped_newton.hpp"
#include "trompo/solvers/newton.hpp"
#include "trompo/solvers/small_lu.hpp"
