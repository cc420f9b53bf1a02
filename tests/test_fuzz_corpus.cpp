// The fuzz corpus as a regression test: every input libFuzzer kept (fuzz/corpus, merged by
// scripts/fuzz.sh --merge, including the inputs of past crashes) is replayed through the
// same contract check as the fuzz target (fuzz/fuzz_check.hpp), compiled here without
// libFuzzer — so it also runs under the ASan/UBSan build of scripts/sanitize.sh, and
// where clang is not available. A fixed-seed batch of random inputs adds breadth.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "fuzz_check.hpp"

#ifndef TROMPO_FUZZ_CORPUS_DIR
// Built outside tests/CMakeLists.txt: the corpus sits next to this file's directory.
#define TROMPO_FUZZ_CORPUS_DIR (std::filesystem::path(__FILE__).parent_path().parent_path() / "fuzz" / "corpus").string()
#endif

namespace fs = std::filesystem;

TEST_CASE("fuzz corpus: every kept input satisfies the step contract", "[fuzz][robustness]") {
  const fs::path dir = TROMPO_FUZZ_CORPUS_DIR;
  INFO("corpus: " << dir.string());
  REQUIRE(fs::is_directory(dir));
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.is_regular_file()) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  REQUIRE(files.size() >= 50);
  int broken = 0;
  const trompo_fuzz::AdaptiveCounts before = trompo_fuzz::adaptive_counts();
  for (const fs::path& file : files) {
    std::ifstream in(file, std::ios::binary);
    const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string why = trompo_fuzz::check(bytes.data(), bytes.size());
    if (!why.empty()) {
      ++broken;
      UNSCOPED_INFO(file.filename().string() << ": " << why);
    }
  }
  CHECK(broken == 0);
  // The corpus reaches the adaptive driver (fuzz_check.hpp, exercise_adaptive; random bytes
  // rarely get that deep), and its runs end every way: at t_end, at a terminal event, and
  // failed (max_steps reached, a step that cannot be taken).
  const trompo_fuzz::AdaptiveCounts& a = trompo_fuzz::adaptive_counts();
  const long solved = a.solved - before.solved, ended = a.reached_end - before.reached_end,
             events = a.event - before.event, failed = a.failed - before.failed;
  std::printf("fuzz corpus: %zu inputs, %ld adaptive runs (reached t_end %ld, terminal event %ld, failed %ld)\n",
              files.size(), solved, ended, events, failed);
  INFO(solved << " adaptive runs: reached t_end " << ended << ", terminal event " << events << ", failed " << failed);
  CHECK(ended > 0);
  CHECK(events > 0);
  CHECK(failed > 0);
}

TEST_CASE("fuzz contract on fixed-seed random inputs", "[fuzz][robustness]") {
#ifdef TROMPO_SANITIZED
  constexpr int inputs = 500;
#else
  constexpr int inputs = 3000;
#endif
  std::mt19937_64 rng(20261122);
  int broken = 0;
  const long reached_before = trompo_fuzz::reached_stepper();
  for (int i = 0; i < inputs; ++i) {
    std::vector<std::uint8_t> bytes(8 + rng() % 120);
    for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
    const std::string why = trompo_fuzz::check(bytes.data(), bytes.size());
    if (!why.empty()) {
      ++broken;
      UNSCOPED_INFO("input " << i << ": " << why);
    }
  }
  CHECK(broken == 0);
  // Most inputs must get past the constructors, or the harness tests only validation.
  const long reached = trompo_fuzz::reached_stepper() - reached_before;
  INFO(reached << " of " << inputs << " random inputs reached a stepper");
  CHECK(reached >= inputs / 2);
}
