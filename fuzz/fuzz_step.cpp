// libFuzzer target: the contract of fuzz/fuzz_check.hpp (steps, integrate, the sampled and
// the adaptive drivers) on fuzzer-drawn scenes, states and h. Built and run (bounded) by
// scripts/fuzz.sh:
//   clang++ -std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined ... fuzz/fuzz_step.cpp
// Any violation prints what broke and aborts, so libFuzzer saves the input as a crash.
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string broken = trompo_fuzz::check(data, size);
  if (!broken.empty()) {
    std::fprintf(stderr, "trompo step contract violated: %s\n", broken.c_str());
    std::abort();
  }
  return 0;
}
