#!/usr/bin/env bash
# What accuracy costs: the README's main-job command (docs/accuracy.md).
#   1. install missing Debian packages (python3-matplotlib for the plots)
#   2. build trompo-bench in Release (build/report)
#   3. run it: per-step costs and the Δt sweep (JSON), then the long-run energy series (CSV);
#      one progress line per finished benchmark (count of total, elapsed time, case and method)
#   4. /usr/bin/python3 -m report (the package scripts/report/): report/report.md, *.csv, *.png
#      and report/accuracy.md, the docs page generated whole from this run
#   5. trompo-bench-control (four closed loops against odeint) and its table, report/control.md
# About 12 minutes on 2 cores after the build (2,980 benchmarks: 682 s measured; 807 s from a clean clone). Run it on a quiet machine: the timings are CPU times of a
# single thread, but a busy machine still inflates them (caches, frequency).
# Usage: scripts/report.sh [extra trompo-bench flags, e.g. --benchmark_filter=ht1]
#        TROMPO_UPDATE_DOCS=1 scripts/report.sh   also copies the plots to docs/img/ and
#        report/accuracy.md over docs/accuracy.md
#        TROMPO_REPORT_CONFIGURE_ONLY=1 TROMPO_REPORT_BUILD_DIR=DIR scripts/report.sh
#                                                 configures the bench build in DIR and stops
#                                                 (ctest's report:configure: the main job's
#                                                 configuration cannot break unseen)
set -euo pipefail
cd "$(dirname "$0")/.."
out=report
build=${TROMPO_REPORT_BUILD_DIR:-build/report}

scripts/deps.sh python3-matplotlib libcli11-dev

echo "== build trompo-bench (Release)"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DTROMPO_BUILD_TESTS=OFF -DTROMPO_BUILD_EXAMPLES=OFF -DTROMPO_BUILD_TOOLS=OFF \
  -DTROMPO_BUILD_BENCH=ON >/dev/null
if [ "${TROMPO_REPORT_CONFIGURE_ONLY:-0}" = 1 ]; then
  echo "   configured in $build (TROMPO_REPORT_CONFIGURE_ONLY)"
  exit 0
fi
cmake --build "$build" --target trompo-bench trompo-bench-control -j"$(nproc)"

# Copies Google Benchmark's console output (stdin) to the file $1, unchanged, and prints one
# line per finished benchmark: [done/total] elapsed, kind (step/sweep), case, method, h.
# Repetitions and their aggregates (_mean, _median, _stddev, _cv) count once.
progress() {
  local file=$1 total=$2 done=0 last="" line name shown
  exec 3>"$file"
  while IFS= read -r line; do
    printf '%s\n' "$line" >&3
    name=${line%% *}
    case $name in step/* | step-pair/* | step-adaptive/* | sweep/*) ;; *) continue ;; esac
    for suffix in _mean _median _stddev _cv; do name=${name%"$suffix"}; done
    [ "$name" = "$last" ] && continue
    last=$name
    done=$((done + 1))
    shown=${name%%/min_time:*}
    shown=${shown%%/repeats:*}
    printf '   [%*d/%d] %4d s  %s\n' "${#total}" "$done" "$total" "$((SECONDS - start_s))" "${shown//\// }"
  done
  exec 3>&-
}

mkdir -p "$out"
lscpu >"$out/machine.txt" 2>/dev/null || true
start=$(date +%s)
start_s=$SECONDS
total=$("$build/bench/trompo-bench" --benchmark_list_tests "$@" | grep -c -E '^(step|step-pair|step-adaptive|sweep)/' || true)
echo "== trompo-bench: per-step costs and the Δt sweep ($total benchmarks) -> $out/bench.json"
"$build/bench/trompo-bench" --benchmark_out="$out/bench.json" --benchmark_out_format=json \
  --benchmark_counters_tabular=false "$@" | progress "$out/bench_console.txt" "$total"
echo "   $(grep -c '^sweep/' "$out/bench_console.txt" || true) sweep runs, $(($(date +%s) - start)) s"
echo "== trompo-bench: long-run energy series -> $out/energy_series.csv"
"$build/bench/trompo-bench" --trompo_energy_series="$out/energy_series.csv"
echo "== trompo-bench: sat1 over 1000 orbits -> $out/satellite_series.csv"
"$build/bench/trompo-bench" --trompo_satellite_series="$out/satellite_series.csv"

echo "== trompo-bench-control: closed loops against odeint (about 2 minutes) -> $out/control.json"
"$build/bench/trompo-bench-control" --benchmark_out="$out/control.json" --benchmark_out_format=json >"$out/control_console.txt"

echo "== report"
PYTHONPATH=scripts /usr/bin/python3 -m report "$out"
/usr/bin/python3 scripts/control/report.py "$out/control.json" >"$out/control.md"
echo "   closed-loop targets: $out/control.md (docs/control.md, \"Closed loops\")"
if [ "${TROMPO_UPDATE_DOCS:-0}" = 1 ]; then
  cp "$out"/{work_precision,work_precision_core,frontier,energy_vs_h,energy_over_time,newton_vs_h,satellite,adaptive_tolerance,adaptive_work_precision}.png docs/img/
  mkdir -p docs/img/families  # the families (docs/families.md, scripts/report/families.py)
  cp "$out"/{work_precision,work_precision_gen-alpha,work_precision_constrained,work_precision_energy-decaying,invariants_families,large_step_ht0}.png docs/img/families/
  echo "   plots copied to docs/img/; docs/accuracy.md written whole from this run"
fi
echo "== done in $(($(date +%s) - start)) s (after the build): $out/report.md"
