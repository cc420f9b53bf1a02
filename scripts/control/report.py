#!/usr/bin/env python3
"""The closed-loop targets from a trompo-bench-control JSON (docs/control.md).

    build/release/bench/trompo-bench-control --benchmark_out=control.json
    python3 scripts/control/report.py control.json > report/control.md

For each case: every method's cheapest configuration (median CPU time over the repetitions)
whose attitude error at the end is at most the bound, its momentum error, and the ratio of
the odeint baselines to trompo's cheapest. A method that reaches the bound at none of its
configurations says so. Then the control issue's targets, each with what this run measured
and whether it is met.
"""
import json
import statistics
import sys
from collections import defaultdict

BOUNDS = {"rw": 1e-9, "rw-friction": 1e-9, "pointing": 1e-8, "bdot": 1e-8, "spinner": 1e-8}
BASELINES = ("odeint-rk4", "odeint-dopri5")
# The fast loops' targets: trompo's cheapest at least this many times cheaper than each baseline.
FAST_LOOPS = {"bdot": "fast loop (a), B-dot", "spinner": "fast loop (b), spinner"}
FAST_RATIO = 5.0
# Total momentum where no external torque acts (the cases with wheels only).
MOMENTUM_CASES = ("rw", "rw-friction", "spinner")
# Viscous wheel friction [W17]: its cost, the friction case's cheapest configuration against
# the same configuration without friction.
FRICTION = ("rw-friction", "rw")


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
    best_of = cheapest(runs, info)
    cases = sorted({k[0] for k in runs}, key=list(BOUNDS).index)
    print("| case | bound on ‖ΔΛ‖ | method | cheapest configuration | CPU (ms) | ‖ΔΛ‖ | max ‖Δπ‖/‖π‖ | odeint / trompo's best |")
    print("|---|---|---|---|---|---|---|---|")
    for case in cases:
        bound = BOUNDS[case]
        best = best_of[case]
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
    print_targets(best_of)
    print_friction_cost(runs, best_of)


def cheapest(runs, info):
    """{case: {method: (median CPU ms, param, err_rot, err_pi)}} over the configurations within the bound."""
    out = defaultdict(dict)
    for (case, method, param), times in runs.items():
        err_rot, err_pi, _, _ = info[(case, method, param)]
        if err_rot > BOUNDS[case]:
            continue
        t = statistics.median(times)
        if method not in out[case] or t < out[case][method][0]:
            out[case][method] = (t, param, err_rot, err_pi)
    return out


def print_targets(best):
    """The issue's targets as rows: target, configuration and measurement, met."""
    print()
    print("| target | measured (this run) | met |")
    print("|---|---|---|")
    for case, title in FAST_LOOPS.items():
        if case not in best:
            continue
        trompo = {m: v for m, v in best[case].items() if m not in BASELINES}
        if not trompo:
            print(f"| {title}: ≥ {FAST_RATIO:.0f}× | no trompo configuration reaches {BOUNDS[case]:.0e} | no |")
            continue
        m, (t, param, _, _) = min(trompo.items(), key=lambda kv: kv[1][0])
        for base, what in (("odeint-rk4", "RK4 sub-stepping each sample"), ("odeint-dopri5", "dopri5 restarted at each sample")):
            if base not in best[case]:
                print(f"| {title}: ≥ {FAST_RATIO:.0f}× less CPU than {what} at ‖ΔΛ‖ ≤ {BOUNDS[case]:.0e} | "
                      f"{base} reaches the bound at none of its configurations | — |")
                continue
            tb, pb, _, _ = best[case][base]
            r = tb / t
            print(f"| {title}: ≥ {FAST_RATIO:.0f}× less CPU than {what} at ‖ΔΛ‖ ≤ {BOUNDS[case]:.0e} | "
                  f"{r:.1f}× ({m} {param}: {t:.1f} ms; {base} {pb}: {tb:.1f} ms) | {'yes' if r >= FAST_RATIO else 'no'} |")
    for case in MOMENTUM_CASES:
        if case not in best:
            continue
        rows = sorted((v[3], m) for m, v in best[case].items() if m not in BASELINES)
        if rows:
            worst, m = rows[-1]
            low, m_low = rows[0]
            print(f"| total momentum kept where no external torque acts ({case}) | max ‖Δπ‖/‖π‖ over the run: "
                  f"{low:.1e} ({m_low}) … {worst:.1e} ({m}) | to round-off |")


def print_friction_cost(runs, best):
    """Friction's cost: the cheapest configuration within the bound with friction, and the
    same configuration's median time without (both from this run)."""
    case, plain = FRICTION
    if case not in best or not best[case]:
        return
    m, (t, param, _, _) = min(best[case].items(), key=lambda kv: kv[1][0])
    times = runs.get((plain, m, param))
    if not times:
        return
    t0 = statistics.median(times)
    print(f"| viscous wheel friction [W17] on {plain}: its cost | {m} {param}: {t:.1f} ms with friction, "
          f"{t0:.1f} ms without ({t / t0:.2f}×) | — |")


if __name__ == "__main__":
    main(sys.argv[1])
