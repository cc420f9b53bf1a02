#!/usr/bin/env python3
"""The closed-loop targets from a trompo-bench-control JSON (docs/control.md).

    build/release/bench/trompo-bench-control --benchmark_out=control.json
    python3 scripts/control/report.py control.json > report/control.md

For each case: every method's cheapest configuration (median CPU time over the repetitions)
whose attitude error at the end is at most the bound, its momentum error, and the ratio of
the odeint baselines to trompo's cheapest. A method that reaches the bound at none of its
configurations says so.
"""
import json
import statistics
import sys
from collections import defaultdict

BOUNDS = {"rw": 1e-9, "pointing": 1e-8, "bdot": 1e-8, "spinner": 1e-8}
BASELINES = ("odeint-rk4", "odeint-dopri5")


def load(path):
    with open(path) as f:
        data = json.load(f)
    runs = defaultdict(list)
    info = {}
    for b in data["benchmarks"]:
        if b.get("run_type") != "iteration" or "error_occurred" in b and b["error_occurred"]:
            continue
        label = dict(kv.split("=", 1) for kv in b["label"].split(";"))
        key = (label["case"], label["method"], label["param"])
        runs[key].append(b["cpu_time"] if b["time_unit"] == "ms" else b["cpu_time"] / 1e6)
        info[key] = (b["err_rot"], b["err_pi"], b["steps"], b["ref_check"])
    return runs, info


def main(path):
    runs, info = load(path)
    cases = sorted({k[0] for k in runs}, key=list(BOUNDS).index)
    print("| case | bound on ‖ΔΛ‖ | method | cheapest configuration | CPU (ms) | ‖ΔΛ‖ | max ‖Δπ‖/‖π‖ | odeint / trompo's best |")
    print("|---|---|---|---|---|---|---|---|")
    for case in cases:
        bound = BOUNDS[case]
        best = {}
        for (c, method, param), times in runs.items():
            if c != case:
                continue
            err_rot, err_pi, steps, check = info[(c, method, param)]
            if err_rot > bound:
                continue
            t = statistics.median(times)
            if method not in best or t < best[method][0]:
                best[method] = (t, param, err_rot, err_pi)
        methods = sorted({k[1] for k in runs if k[0] == case})
        trompo = [m for m in best if m not in BASELINES]
        t_best = min(best[m][0] for m in trompo) if trompo else None
        for m in sorted(methods, key=lambda m: best[m][0] if m in best else float("inf")):
            if m not in best:
                print(f"| {case} | {bound:.0e} | {m} | none reaches the bound | | | | |")
                continue
            t, param, err_rot, err_pi = best[m]
            ratio = f"{t / t_best:.1f}×" if m in BASELINES and t_best else ""
            pi = f"{err_pi:.1e}" if err_pi > 0 else "— (external torque)"
            print(f"| {case} | {bound:.0e} | {m} | {param} | {t:.1f} | {err_rot:.1e} | {pi} | {ratio} |")


if __name__ == "__main__":
    main(sys.argv[1])
