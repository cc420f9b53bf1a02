#!/usr/bin/env bash
# What accuracy costs: the README's main-job command (README "What accuracy costs").
#   1. install missing Debian packages (python3-matplotlib for the plots)
#   2. build trompo-bench in Release (build/report)
#   3. run it: per-step costs and the Δt sweep (JSON), then the long-run energy series (CSV)
#   4. /usr/bin/python3 scripts/report.py: report/report.md, *.csv, *.png
# About 4–5 minutes on 2 cores. Run it on a quiet machine: the timings are CPU times of a
# single thread, but a busy machine still inflates them (caches, frequency).
# Usage: scripts/report.sh [extra trompo-bench flags, e.g. --benchmark_filter=ht1]
#        TROMPO_UPDATE_DOCS=1 scripts/report.sh   also copies the plots to docs/img/
set -euo pipefail
cd "$(dirname "$0")/.."
out=report
build=build/report

scripts/deps.sh python3-matplotlib

echo "== build trompo-bench (Release)"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DTROMPO_BUILD_TESTS=OFF -DTROMPO_BUILD_EXAMPLES=OFF \
  -DTROMPO_BUILD_BENCH=ON >/dev/null
cmake --build "$build" --target trompo-bench -j"$(nproc)"

mkdir -p "$out"
lscpu >"$out/machine.txt" 2>/dev/null || true
start=$(date +%s)
echo "== trompo-bench: per-step costs and the Δt sweep -> $out/bench.json"
"$build/bench/trompo-bench" --benchmark_out="$out/bench.json" --benchmark_out_format=json \
  --benchmark_counters_tabular=false "$@" >"$out/bench_console.txt"
echo "   $(grep -c '^sweep/' "$out/bench_console.txt" || true) sweep runs, $(($(date +%s) - start)) s"
echo "== trompo-bench: long-run energy series -> $out/energy_series.csv"
"$build/bench/trompo-bench" --trompo_energy_series="$out/energy_series.csv"

echo "== report"
/usr/bin/python3 scripts/report.py "$out"
if [ "${TROMPO_UPDATE_DOCS:-0}" = 1 ]; then
  cp "$out"/{work_precision,frontier,energy_vs_h,energy_over_time,newton_vs_h}.png docs/img/
  mkdir -p docs/img/families  # the families (docs/families.md, scripts/report_families.py)
  cp "$out"/{work_precision,work_precision_gen-alpha,work_precision_constrained,work_precision_energy-decaying,invariants_families,large_step_ht0}.png docs/img/families/
  echo "   plots copied to docs/img/ (update the numbers in README "What accuracy costs" from $out/report.md)"
fi
echo "== done in $(($(date +%s) - start)) s (after the build): $out/report.md"
