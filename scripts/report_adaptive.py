#!/usr/bin/env python3
"""The adaptive driver's table (docs/adaptive.md) from a trompo-bench JSON.

    build/h/bench/trompo-bench --benchmark_filter='<see docs/adaptive.md>' \
        --benchmark_out=adaptive.json --benchmark_out_format=json
    python3 scripts/report_adaptive.py [--summary] adaptive.json [more.json ...]

Reads sweep/<case>/adaptive-<method>/tol:<tol> (bench/methods/adaptive.cpp), the fixed-h
sweeps sweep/<case>/<method>/h:<h> of the same methods, odeint's dopri5 at the same
tolerances, and the per-step pairs step-adaptive/ht1/<method> against step/ht1/<method>.
Prints Markdown: per case and method, the achieved error ‖ΔΛ‖_F at t_end over tol, the
slope d log err / d log tol (least squares), accepted/rejected steps, max |ΔH/H0|, the CPU
time and its ratio to the fixed-h sweep's time at the same error (log-log interpolation
between its two neighbouring points; '-' outside its range); then the estimator overhead.
"""
import json
import math
import sys
from collections import defaultdict

UNIT = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}


def seconds(b):
    return b["cpu_time"] * UNIT[b.get("time_unit", "ns")]


def load(paths):
    rows = []
    for path in paths:
        with open(path) as f:
            rows += [b for b in json.load(f)["benchmarks"] if not b.get("error_occurred")]
    adaptive = defaultdict(list)  # (case, method) -> [(tol, bench)]
    fixed = defaultdict(list)  # (case, method) -> [(err, seconds)]
    dopri = {}  # (case, tol text) -> bench
    steps = defaultdict(list)  # (case, method) -> [seconds per plain step]
    adaptive_steps = defaultdict(list)  # (case, method) -> [seconds per accepted adaptive step]
    for b in rows:
        # the benchmark's name without Google Benchmark's /min_time:…/repeats:… suffixes
        parts = [x for x in b.get("run_name", b["name"]).split("/") if not x.startswith(("min_time:", "repeats:"))]
        name = "/".join(parts)
        if parts[0] == "sweep" and len(parts) == 4:
            case, method, arg = parts[1], parts[2], parts[3]
            if method.startswith("adaptive-") and arg.startswith("tol:"):
                adaptive[(case, method[len("adaptive-"):])].append((float(arg[4:]), b))
            elif method == "odeint-dopri5" and arg.startswith("tol:"):
                dopri[(case, float(arg[4:]))] = b
            elif arg.startswith("h:") and b.get("err_rot", 0) > 0:
                fixed[(case, method)].append((b["err_rot"], seconds(b)))
        elif parts[0] == "step-adaptive" and len(parts) == 3 and b.get("run_type", "iteration") == "iteration":
            adaptive_steps[(parts[1], parts[2])].append(b["s_per_step"])
        elif parts[0] == "step" and len(parts) == 3 and b.get("run_type", "iteration") == "iteration":
            steps[(parts[1], parts[2])].append(seconds(b))
    return adaptive, fixed, dopri, (steps, adaptive_steps)


def fixed_time_at(curve, err):
    """CPU time of the fixed-h sweep at error `err` (log-log interpolation), or None."""
    pts = sorted(curve)
    for (e0, t0), (e1, t1) in zip(pts, pts[1:]):
        if e0 <= err <= e1 and e1 > e0:
            w = (math.log(err) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + w * (math.log(t1) - math.log(t0)))
    return None


def slope(points):
    xs = [math.log10(t) for t, _ in points]
    ys = [math.log10(e) for _, e in points]
    if len(xs) < 2:
        return float("nan")
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx


def held(pts):
    """Per point (tolerance decreasing): True when the tolerance did not set the steps, i.e.
    the accepted count is within 5 % of its looser neighbour's (the rotation cap holds h)."""
    n = [b["accepted"] for _, b in pts]
    close = [abs(n[k] - n[k - 1]) <= 0.05 * n[k] for k in range(1, len(n))]
    return [close[0] if close else False] + close


def summary(adaptive, fixed):
    """One line per case and method over the points where the tolerance sets the steps."""
    print("| case | method | tol range | err/tol | slope | time / fixed-h time at equal error |")
    print("|---|---|---|---|---|---|")
    order = {"ht0": 0, "ht1": 1, "ht2": 2, "fb1": 3}
    for (case, method), pts in sorted(adaptive.items(), key=lambda kv: (order.get(kv[0][0], 9), kv[0][1])):
        pts = sorted(pts, key=lambda x: -x[0])
        active = [(tol, b) for (tol, b), h in zip(pts, held(pts)) if not h]
        if not active:
            print(f"| {case.upper()} | {method} | - | (all held by the rotation cap) | | |")
            continue
        ratios = [b["err_rot"] / tol for tol, b in active]
        costs = [seconds(b) / ft for tol, b in active
                 for ft in [fixed_time_at(fixed.get((case, method), []), b["err_rot"])] if ft]
        cost = f"{min(costs):.2f}–{max(costs):.2f}" if costs else "-"
        slope_text = f"{slope([(t, b['err_rot']) for t, b in active]):.2f}" if len(active) > 1 else "-"
        print(f"| {case.upper()} | {method} | {active[0][0]:.0e} … {active[-1][0]:.0e} | "
              f"{min(ratios):.2g}–{max(ratios):.2g} | {slope_text} | {cost} |")


def main(paths):
    adaptive, fixed, dopri, steps = load(paths)
    if "--summary" in sys.argv:
        summary(adaptive, fixed)
        overhead(steps)
        return
    cases = sorted({c for c, _ in adaptive}, key=lambda c: ["ht0", "ht1", "ht2", "fb1"].index(c) if c in
                   ["ht0", "ht1", "ht2", "fb1"] else 9)
    for case in cases:
        print(f"\n**{case.upper()}** (err = ‖ΔΛ‖_F at t_end; time = CPU time of the run; "
              "fixed = time / time of the fixed-h sweep at the same error)\n")
        print("| method | tol | err | err/tol | accepted | rejected | max ΔH/H | time (ms) | fixed | dopri5 err | dopri5 ms |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for (c, method), pts in sorted(adaptive.items()):
            if c != case:
                continue
            pts.sort(key=lambda x: -x[0])
            for tol, b in pts:
                err = b["err_rot"]
                t = seconds(b)
                ft = fixed_time_at(fixed.get((case, method), []), err)
                ratio = f"{t / ft:.2f}" if ft else "-"
                d = dopri.get((case, tol))
                d_err = f"{d['err_rot']:.1e}" if d else "-"
                d_ms = f"{seconds(d) * 1e3:.3g}" if d else "-"
                print(f"| {method} | {tol:.0e} | {err:.1e} | {err / tol:.2g} | {b['accepted']:.0f} | "
                      f"{b['rejected']:.0f} | {b['max_dH']:.1e} | {t * 1e3:.3g} | {ratio} | {d_err} | {d_ms} |")
            usable = [(tol, b["err_rot"]) for tol, b in pts if b["err_rot"] > 1e-13]
            print(f"| {method} | slope | {slope(usable):.2f} | | | | | | | | |")
    overhead(steps)


def overhead(step_times):
    steps, adaptive_steps = step_times
    print("\n**Estimator overhead** (HT1, h = h_step; one accepted adaptive step vs one plain step, "
          "median of the repetitions)\n")
    print("| method | plain step (µs) | adaptive step (µs) | ratio |")
    print("|---|---|---|---|")
    median = lambda xs: sorted(xs)[len(xs) // 2]  # noqa: E731
    for (case, method), times in sorted(adaptive_steps.items()):
        a = median(times)
        plain = steps.get((case, method))
        if plain:
            p = median(plain)
            print(f"| {method} | {p * 1e6:.3g} | {a * 1e6:.3g} | {a / p:.2f} |")
        else:
            print(f"| {method} | - | {a * 1e6:.3g} | - |")


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--summary"]
    if not args:
        sys.exit("usage: report_adaptive.py [--summary] BENCH.json [MORE.json ...]")
    main(args)
