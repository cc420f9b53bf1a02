#pragma once
// Appends the scheme of examples/own_scheme.hpp (README "Write your own scheme") to the
// scheme registry: include/trompo/schemes/registry.hpp includes this file in the test build
// of tests/CMakeLists.txt ("registry:own-scheme") through TROMPO_EXTRA_SCHEMES_HEADER. This
// one entry is all it takes for the CLI and the generic property tests to run it.
#include "../../examples/own_scheme.hpp"

#define TROMPO_EXTRA_SCHEMES , trompo::Registered<example::Midpoint, trompo::Compositions::symmetric, trompo::Scenes::free_body>
