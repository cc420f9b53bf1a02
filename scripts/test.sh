#!/usr/bin/env bash
# The whole test suite, from a clean clone on Debian 12 (README quick start, and .ci/run).
#   1. install missing Debian packages
#   2. build the tests, examples, tools and the Python module in Release with warnings as
#      errors, and the bench at -O0 (a compile check: TROMPO_BENCH_COMPILE_CHECK; the main
#      job builds it optimised); run ctest (the pytest suite is its python:pytest entry)
#   3. the API reference (Doxygen, target docs): fails on any warning, e.g. an undocumented
#      public name in include/trompo
#   4. a bounded libFuzzer run of the step contract (clang)
#   5. the contract tests (bad input, failure, memory, fuzz corpus, …: tests/CMakeLists.txt)
#      with AddressSanitizer + UndefinedBehaviorSanitizer; run ctest (last, so that the run
#      closes on ctest's summary line)
# Where the time goes, and what each choice saved: docs/testing.md.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)

# doxygen/graphviz: the API reference; the Python module and its tests (python:pytest in
# ctest): pybind11, NumPy, pytest, Dask.
scripts/deps.sh ninja-build clang libclang-rt-14-dev doxygen graphviz python3 \
  pybind11-dev python3-pybind11 python3-numpy python3-pytest python3-dask python3-distributed python3-matplotlib python3-dev

echo "== build (Release, -Werror)"
# Ninja (from ninja-build): a build dir made earlier by another generator is made anew.
if [ -f build/test/CMakeCache.txt ] && ! grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja$' build/test/CMakeCache.txt; then
  rm -rf build/test
fi
cmake -S . -B build/test -G Ninja -DCMAKE_BUILD_TYPE=Release -DTROMPO_WARNINGS_AS_ERRORS=ON \
  -DTROMPO_BENCH_COMPILE_CHECK=ON >/dev/null
cmake --build build/test -j"$jobs"
echo "== ctest"
ctest --test-dir build/test --output-on-failure -j"$jobs"

echo "== docs (Doxygen; any warning fails)"
cmake --build build/test --target docs

echo "== fuzz"
scripts/fuzz.sh
echo "== sanitizers"
scripts/sanitize.sh
