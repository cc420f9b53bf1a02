#!/usr/bin/env bash
# Bounded libFuzzer run of the step contract (fuzz/fuzz_check.hpp, target fuzz/fuzz_step.cpp)
# with AddressSanitizer and UndefinedBehaviorSanitizer, built by Debian's clang.
#
#   scripts/fuzz.sh            # build, replay fuzz/corpus, then fuzz for 30 s
#   scripts/fuzz.sh --merge    # then merge the new coverage into fuzz/corpus (to commit)
#   TROMPO_FUZZ_SECONDS=600 scripts/fuzz.sh --merge   # a longer campaign
#
# fuzz/corpus is read-only during the run: new inputs go to build/fuzz/new, crashes to
# build/fuzz/crash-*. A crash fails the script; keep its input as a regression by copying
# it into fuzz/corpus once fixed (tests/test_fuzz_corpus.cpp replays the whole corpus).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${TROMPO_FUZZ_SECONDS:-30}
merge=0
[ "${1:-}" = "--merge" ] && merge=1
out=build/fuzz
mkdir -p "$out/new"

cxx=${TROMPO_FUZZ_CXX:-}
if [ -z "$cxx" ]; then
  for c in clang++ clang++-14 clang++-15 clang++-16; do
    if command -v "$c" >/dev/null; then cxx=$c; break; fi
  done
fi
[ -n "$cxx" ] || [ -n "${TROMPO_FUZZ_BIN:-}" ] || { echo "fuzz: clang++ not found (apt-get install clang libclang-rt-14-dev)" >&2; exit 1; }
eigen=$(pkg-config --cflags-only-I eigen3 2>/dev/null || echo -I/usr/include/eigen3)

# TROMPO_FUZZ_BIN: a fuzz_step built already (scripts/test.sh: by the sanitizer build,
# fuzz/CMakeLists.txt). Otherwise build/fuzz/fuzz_step, rebuilt when any header or the
# target is newer than the binary.
bin=${TROMPO_FUZZ_BIN:-$out/fuzz_step}
if [ -n "${TROMPO_FUZZ_BIN:-}" ]; then
  [ -x "$bin" ] || { echo "fuzz: TROMPO_FUZZ_BIN=$bin is not an executable" >&2; exit 1; }
elif [ ! -x "$bin" ] || [ -n "$(find include fuzz -newer "$bin" \( -name '*.hpp' -o -name '*.cpp' \) -print -quit)" ]; then
  echo "fuzz: building $bin with $cxx"
  # shellcheck disable=SC2086
  "$cxx" -std=c++20 -O1 -g -fno-omit-frame-pointer \
    -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
    -Wall -Wextra -Iinclude -isystem ${eigen#-I} fuzz/fuzz_step.cpp -o "$bin"
fi

export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
common=(-max_len=256 -timeout=10 -rss_limit_mb=2048 -artifact_prefix="$out/" -print_final_stats=1)

echo "fuzz: replaying fuzz/corpus ($(ls fuzz/corpus | wc -l) inputs)"
"$bin" "${common[@]}" -runs=0 fuzz/corpus 2>&1 | tail -n 3
echo "fuzz: exploring for ${seconds}s"
"$bin" "${common[@]}" -max_total_time="$seconds" "$out/new" fuzz/corpus 2>&1 | tail -n 8

if [ "$merge" = 1 ]; then
  echo "fuzz: merging new coverage into fuzz/corpus"
  # Edge coverage only (no hit counters): a small corpus, each input adding a new edge.
  "$bin" "${common[@]}" -merge=1 -use_counters=0 fuzz/corpus "$out/new" 2>&1 | tail -n 2
fi
