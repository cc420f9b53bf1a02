#pragma once
// Layer 4, one step of each scheme: the Scheme concept and every family.
#include "trompo/model.hpp"
#include "trompo/schemes/explicit/rk4.hpp"
#include "trompo/schemes/families/constrained_trapezoid.hpp"
#include "trompo/schemes/families/energy_decaying.hpp"
#include "trompo/schemes/families/lie_gen_alpha.hpp"
#include "trompo/schemes/geradin_bauchau/geradin_bauchau.hpp"
#include "trompo/schemes/geradin_bauchau/geradin_bauchau_paper.hpp"
#include "trompo/schemes/registry.hpp"
#include "trompo/schemes/scheme.hpp"
#include "trompo/schemes/simo/simo.hpp"
#include "trompo/schemes/splitting/splitting.hpp"
#include "trompo/solvers.hpp"
