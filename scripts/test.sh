#!/usr/bin/env bash
# The whole test suite, from a clean clone on Debian 12 (README quick start, and .ci/run).
#   1. install missing Debian packages
#   2. build (g++, Release type at -O1, warnings as errors) every test but the contract
#      tests (TROMPO_TEST_SET=numbers), the examples, the tools, the Python module, and the
#      bench at -O0 (a compile check: TROMPO_BENCH_COMPILE_CHECK; the main job builds it
#      optimised)
#   3. build (clang, ASan + UBSan) the contract tests (TROMPO_TEST_SET=contracts) and the
#      libFuzzer target
#   4. ctest on the Release build (the pytest suite is its python:pytest entry), with a
#      bounded libFuzzer run of the step contract beside it (it replays fuzz/corpus first)
#   5. the API reference (Doxygen, target docs): fails on any warning, e.g. an undocumented
#      public name in include/trompo
#   6. ctest on the sanitizer build (last, so that the run closes on ctest's summary line)
# Each test is built once, in the build that needs it. Where the time goes, and what each
# choice saved: docs/testing.md.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)

# doxygen/graphviz: the API reference; the Python module and its tests (python:pytest in
# ctest): pybind11, NumPy, pytest, Dask; CLI11: trompo-simulate's command line (tools/simulate/flags.cpp).
scripts/deps.sh ninja-build clang libclang-rt-14-dev doxygen graphviz python3 \
  pybind11-dev python3-pybind11 python3-numpy python3-pytest python3-dask python3-distributed python3-matplotlib python3-dev \
  libcli11-dev

echo "== build (Release at -O1, -Werror)"
# Ninja (from ninja-build): a build dir made earlier by another generator is made anew.
if [ -f build/test/CMakeCache.txt ] && ! grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja$' build/test/CMakeCache.txt; then
  rm -rf build/test
fi
# -O1: the tests check numbers, contracts and counts, none of which depends on the
# optimisation level (no -ffast-math, no FMA contraction on x86-64 without -march); -O1
# compiles the CLI engine in 153 s instead of 269 s at -O3 (docs/testing.md). Speed is the
# bench's business.
cmake -S . -B build/test -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O1 -DNDEBUG" \
  -DTROMPO_WARNINGS_AS_ERRORS=ON -DTROMPO_TEST_SET=numbers -DTROMPO_BENCH_COMPILE_CHECK=ON >/dev/null
cmake --build build/test -j"$jobs"

echo "== build (sanitizers)"
scripts/sanitize.sh build

echo "== ctest (Release), and the fuzz run beside it (its output follows the docs)"
fuzz_log=build/fuzz.log
mkdir -p build
if [ -x build/asan/fuzz/fuzz_step ]; then export TROMPO_FUZZ_BIN=build/asan/fuzz/fuzz_step; fi
scripts/fuzz.sh >"$fuzz_log" 2>&1 &
fuzz_pid=$!
trap 'kill "$fuzz_pid" 2>/dev/null || true' EXIT
ctest --test-dir build/test --output-on-failure -j"$jobs"

echo "== docs (Doxygen; any warning fails)"
cmake --build build/test --target docs

echo "== fuzz"
fuzz_rc=0
wait "$fuzz_pid" || fuzz_rc=$?
trap - EXIT
cat "$fuzz_log"
if [ "$fuzz_rc" -ne 0 ]; then
  echo "fuzz: failed (exit $fuzz_rc)" >&2
  exit 1
fi

echo "== sanitizers"
scripts/sanitize.sh test
