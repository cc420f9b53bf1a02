#pragma once
// The Simo family, [T1]–[T3]: Simo-α, Simo collocation and Simo-κ.
#include "trompo/schemes/simo/simo_alpha.hpp"
#include "trompo/schemes/simo/simo_collocation.hpp"
#include "trompo/schemes/simo/simo_kappa.hpp"
