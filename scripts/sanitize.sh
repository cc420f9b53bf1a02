#!/usr/bin/env bash
# The contract tests (TROMPO_TEST_SET=contracts, the list TROMPO_CONTRACT_TESTS in
# tests/CMakeLists.txt: bad input, failure and recovery, memory, series thresholds,
# threads, and the contract half of the generic property suite) under AddressSanitizer +
# UndefinedBehaviorSanitizer. With clang the same build makes the libFuzzer target
# (fuzz/CMakeLists.txt), so that it compiles beside the tests and scripts/fuzz.sh only runs it.
#
#   scripts/sanitize.sh          # build, then ctest
#   scripts/sanitize.sh build    # build only (scripts/test.sh: the fuzz run comes between)
#   scripts/sanitize.sh test     # ctest only, on a build made before
#
# Debug build type so that Eigen's and the library's assertions are on, at -O1 with line
# tables only (-g1: enough for the sanitizers' stack traces) so that the build and the suite
# stay fast; TROMPO_SANITIZED lets the long tests use smaller counts. Neither the packaging
# tests (a Release consumer, nothing to sanitize) nor the Python module (an ASan-instrumented
# extension cannot be loaded by an uninstrumented interpreter) are here.
#
# Compiler: clang++ when available. With both sanitizers at -O1, g++ 12 spends ~4.5×
# longer compiling these Eigen-heavy tests (211 s against 47 s for one file). Warnings are
# enforced by the Release build (g++, -Werror) on everything but these files; here they are
# reported but not fatal, so that a clang-only warning cannot hide the sanitizers' verdict.
set -euo pipefail
cd "$(dirname "$0")/.."
what=${1:-all}
jobs=$(nproc)
build=build/asan
cxx=${TROMPO_SANITIZE_CXX:-}
if [ -z "$cxx" ]; then
  for c in clang++ clang++-14 g++; do
    if command -v "$c" >/dev/null; then cxx=$(command -v "$c"); break; fi
  done
fi
fuzz=OFF
case "$(basename "$cxx")" in clang++*) fuzz=ON ;; esac

if [ "$what" != test ]; then
  # A compiler or generator change needs a fresh cache.
  if [ -f "$build/CMakeCache.txt" ] && { ! grep -q "CMAKE_CXX_COMPILER:.*=$cxx\$" "$build/CMakeCache.txt" ||
                                         ! grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja$' "$build/CMakeCache.txt"; }; then
    rm -rf "$build"
  fi
  cmake -S . -B "$build" -G Ninja \
    -DCMAKE_CXX_COMPILER="$cxx" \
    -DCMAKE_BUILD_TYPE=Debug \
    -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" \
    -DCMAKE_CXX_FLAGS="-DTROMPO_SANITIZED=1" \
    -DTROMPO_SANITIZE=ON -DTROMPO_TEST_SET=contracts -DTROMPO_BUILD_FUZZ=$fuzz \
    -DTROMPO_WARNINGS_AS_ERRORS=OFF \
    -DTROMPO_BUILD_TESTS=ON -DTROMPO_BUILD_BENCH=OFF -DTROMPO_BUILD_EXAMPLES=OFF -DTROMPO_BUILD_TOOLS=OFF -DTROMPO_BUILD_PYTHON=OFF >/dev/null
  cmake --build "$build" -j"$jobs"
fi

if [ "$what" != build ]; then
  export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:strict_string_checks=1}
  export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
  ctest --test-dir "$build" --output-on-failure -j"$jobs" -E '^(package|report):'
fi
