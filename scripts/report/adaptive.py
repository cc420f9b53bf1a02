"""The adaptive driver's part of the report (docs/adaptive.md; docs/accuracy.md, "Adaptive steps").

Reads from trompo-bench's JSON the tolerance sweeps sweep/<case>/adaptive-<method>/tol:<tol>
(bench/methods/adaptive.cpp), the fixed-h sweeps sweep/<case>/<method>/h:<h> of the same
methods, odeint's dopri5 at the same tolerances, and the per-step pairs
step-adaptive/ht1/<method> against step/ht1/<method>. Writes the figures
adaptive_tolerance.png (end error against tolerance) and adaptive_work_precision.png (CPU
time against end error, adaptive beside fixed h and dopri5), and returns the Markdown of the
section: the issue's targets as a table, the per-method summary and the estimator overhead.

    PYTHONPATH=scripts python3 -m report.adaptive [--summary] BENCH.json [MORE.json ...]

prints the tables alone (without --summary: every point, with dopri5's error and time at the
same tolerance).
"""
import json
import math
import os
import sys
from collections import defaultdict

UNIT = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}
CASE_ORDER = ["ht0", "ht1", "ht2", "fb1", "spin-down"]
CONSERVATIVE_CASES = ("ht0", "ht1", "ht2", "fb1")  # H and μ are invariants there (not under damping)
# The targets (docs/adaptive.md): proportionality over rtol 1e-4 … 1e-10 on HT0, HT1,
# FB1 at orders 2, 4, 6; cost at equal error; the estimator's overhead per composition.
PROPORTIONAL_CASES = ("ht0", "ht1", "fb1")
SIMO_METHODS = ("simo-kappa", "simo-kappa-o4s", "simo-kappa-o6")
RATIO_RANGE = (0.1, 30.0)
SLOPE_RANGE = (0.85, 1.15)
COST_TARGET = 1.3
# The case whose time scale varies (bench/methods/adaptive.cpp): a free body spun at 30 rad/s
# under viscous damping, slowing to 0.2 rad/s by t = 100. (FB1's rare, fast flips near the
# separatrix were the first choice: its fixed-h and adaptive runs cost about the same at equal
# error, since its error is the flips' phase, which a per-step tolerance does not steer.)
VARYING_CASE = "spin-down"
VARYING_TEXT = "SPIN-DOWN: J = diag(1, 2, 3), Ω₀ = (30, 0.5, 0.5), damping c = 0.05, t = 100 (30 → 0.2 rad/s)"
STEPS_TARGET = 2.0
OVERHEAD_TARGETS = {"simo-kappa-o4s": 1.35, "splitting-suzuki-5": 1.35, "simo-kappa-o6": 1.20,
                    "splitting-kahan-li-9": 1.20}
TITLES = {"simo-kappa": "Simo-κ", "simo-kappa-o4s": "Simo-κ, Suzuki-5 (order 4)",
          "simo-kappa-o6": "Simo-κ, Kahan–Li-9 (order 6)", "splitting-strang": "splitting, Strang",
          "splitting-suzuki-5": "splitting, Suzuki-5", "splitting-kahan-li-9": "splitting, Kahan–Li-9"}
COLORS = {"simo-kappa": "#1f77b4", "simo-kappa-o4s": "#2ca02c", "simo-kappa-o6": "#d62728",
          "splitting-strang": "#9467bd", "splitting-suzuki-5": "#8c564b", "splitting-kahan-li-9": "#e377c2"}


def seconds(b):
    return b["cpu_time"] * UNIT[b.get("time_unit", "ns")]


def load(paths):
    """(adaptive, fixed, dopri, (steps, adaptive_steps)) from one or more JSON files."""
    rows = []
    for path in paths:
        with open(path) as f:
            rows += [b for b in json.load(f)["benchmarks"] if not b.get("error_occurred")]
    adaptive = defaultdict(list)  # (case, method) -> [(tol, bench)]
    fixed = defaultdict(list)  # (case, method) -> [(err, seconds, steps)]
    dopri = {}  # (case, tol) -> bench
    steps = defaultdict(list)  # (case, method) -> [seconds per plain step]
    adaptive_steps = defaultdict(list)  # (case, method) -> [seconds per accepted adaptive step]
    for b in rows:
        if b.get("run_type", "iteration") != "iteration":
            continue
        # the benchmark's name without Google Benchmark's /min_time:…/repeats:…/manual_time suffixes
        parts = [x for x in b.get("run_name", b["name"]).split("/")
                 if not x.startswith(("min_time:", "repeats:")) and x != "manual_time"]
        if parts[0] == "sweep" and len(parts) == 4:
            case, method, arg = parts[1], parts[2], parts[3]
            if method.startswith("adaptive-") and arg.startswith("tol:"):
                adaptive[(case, method[len("adaptive-"):])].append((float(arg[4:]), b))
            elif method == "odeint-dopri5" and arg.startswith("tol:"):
                dopri[(case, float(arg[4:]))] = b
            elif arg.startswith("h:") and b.get("err_rot", 0) > 0:
                fixed[(case, method)].append((b["err_rot"], seconds(b), b.get("steps", float("nan"))))
        elif parts[0] == "step-adaptive" and len(parts) == 3:
            adaptive_steps[(parts[1], parts[2])].append(b)
        elif parts[0] == "step" and len(parts) == 3:
            steps[(parts[1], parts[2])].append(seconds(b))
    for pts in adaptive.values():
        pts.sort(key=lambda x: -x[0])
    return adaptive, fixed, dopri, (steps, adaptive_steps)


def fixed_at(curve, err, index):
    """Column `index` (1: CPU time, 2: steps) of the fixed-h sweep at error `err`, by
    log-log interpolation between its two neighbouring points; None outside its range."""
    pts = sorted(curve)
    for a, b in zip(pts, pts[1:]):
        if a[0] <= err <= b[0] and b[0] > a[0]:
            w = (math.log(err) - math.log(a[0])) / (math.log(b[0]) - math.log(a[0]))
            return math.exp(math.log(a[index]) + w * (math.log(b[index]) - math.log(a[index])))
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


def at_floor(pts, held_by_cap):
    """Per point (tolerance decreasing): True from the first point on whose error fell less
    than 3x below its looser neighbour's for a tenfold tighter tolerance: the round-off floor,
    where err/tol and the comparisons at equal error say nothing about the control (round-off:
    errors below 1e-8; above, a slow fall is the loose end's, not a floor). A point
    the rotation cap holds is compared with none (its error is its neighbour's, the steps being
    the same): a point after held ones is compared with the last point not held, and counts as
    at the floor when its error, below 1e-8, is 1000x below its tolerance (the splitting with
    Richardson's estimate on FB1, whose error is round-off at any step the cap allows)."""
    e = [b["err_rot"] for _, b in pts]
    tols = [t for t, _ in pts]
    out, floor, last = [], False, None
    for k in range(len(e)):
        if not held_by_cap[k]:
            floor = floor or (e[k] < 1e-8 and e[k] < 1e-3 * tols[k]) or (
                last is not None and e[k] < 1e-8 and not (e[k] < e[last] / 3 ** (k - last)))
            last = k
        out.append(floor)
    return out


def active(pts, lo=None, hi=None):
    """The points where the tolerance sets the steps and the error follows it (not held by
    the rotation cap, not at the round-off floor), optionally within [lo, hi]."""
    h_cap = held(pts)
    out = [(tol, b) for (tol, b), h, f in zip(pts, h_cap, at_floor(pts, h_cap)) if not h and not f]
    return [(t, b) for t, b in out if (lo is None or t >= lo * 0.999) and (hi is None or t <= hi * 1.001)]


def rng(xs, digits=2):
    return f"{min(xs):.{digits}g}–{max(xs):.{digits}g}" if xs else "-"


def summary_rows(adaptive, fixed):
    """Per case and method, over the points where the tolerance sets the steps: tol range,
    err/tol, slope, time and steps over the fixed-h sweep's at equal error."""
    out = []
    for (case, method), pts in sorted(adaptive.items(), key=lambda kv: (CASE_ORDER.index(kv[0][0])
                                                                          if kv[0][0] in CASE_ORDER else 9, kv[0][1])):
        act = active(pts)
        curve = fixed.get((case, method), [])
        costs = [seconds(b) / ft for _, b in act for ft in [fixed_at(curve, b["err_rot"], 1)] if ft]
        fewer = [fs / b["accepted"] for _, b in act for fs in [fixed_at(curve, b["err_rot"], 2)] if fs]
        out.append({"case": case, "method": method, "all": pts, "active": act,
                    "ratios": [b["err_rot"] / t for t, b in act],
                    "slope": slope([(t, b["err_rot"]) for t, b in act]) if len(act) > 1 else float("nan"),
                    "costs": costs, "fewer": fewer,
                    "max_dH": max((b.get("max_dH", 0) for _, b in pts), default=0),
                    "max_dmu": max((b.get("max_dmu", 0) for _, b in pts), default=0)})
    return out


def summary_table(rows):
    L = ["| case | method | tol range | err/tol | slope | time / fixed-h time | fixed-h steps / steps |",
         "|---|---|---|---|---|---|---|"]
    for r in rows:
        if not r["active"]:
            L.append(f"| {r['case'].upper()} | {r['method']} | - | (every point held by the rotation cap or at the "
                     f"round-off floor) | | | |")
            continue
        s = f"{r['slope']:.2f}" if not math.isnan(r["slope"]) else "-"
        L.append(f"| {r['case'].upper()} | {r['method']} | {r['active'][0][0]:.0e} … {r['active'][-1][0]:.0e} | "
                 f"{rng(r['ratios'])} | {s} | {rng(r['costs'])} | {rng(r['fewer'])} |")
    return L


def overhead_rows(step_times):
    """method -> (plain s/step, adaptive s/step, ratio): medians over the repetitions of
    step-adaptive/…, which times the fixed-h run and the adaptive run in alternation (its
    `ratio`); an older JSON without it: against step/<case>/<method>."""
    steps, adaptive_steps = step_times
    median = lambda xs: sorted(xs)[len(xs) // 2]  # noqa: E731
    out = {}
    for (case, method), reps in sorted(adaptive_steps.items()):
        a = median([b["s_per_step"] for b in reps])
        if all("ratio" in b for b in reps):
            out[method] = (median([b["plain_s_per_step"] for b in reps]), a, median([b["ratio"] for b in reps]))
        else:
            plain = steps.get((case, method))
            p = median(plain) if plain else None
            out[method] = (p, a, a / p if p else None)
    return out


def overhead_table(over):
    L = ["| method | plain step (µs) | adaptive step (µs) | ratio |", "|---|---|---|---|"]
    for method, (p, a, r) in over.items():
        L.append(f"| {method} | {p * 1e6:.3g} | {a * 1e6:.3g} | {r:.2f} |" if p else
                 f"| {method} | - | {a * 1e6:.3g} | - |")
    return L


def verdict(ok):
    return "yes" if ok else "**no**"


def targets_table(rows, over):
    """The issue's targets with what this run measured."""
    by = {(r["case"], r["method"]): r for r in rows}
    L = ["| target | configuration | measured | met |", "|---|---|---|---|"]
    # proportionality
    ratios, slopes = [], []
    for case in PROPORTIONAL_CASES:
        for m in SIMO_METHODS:
            r = by.get((case, m))
            if not r:
                continue
            act = active(r["all"], 1e-10, 1e-4)
            ratios += [b["err_rot"] / t for t, b in act]
            if len(act) > 1:
                slopes.append(slope([(t, b["err_rot"]) for t, b in act]))
    if ratios:
        L.append(f"| end error / tol in [{RATIO_RANGE[0]:g}, {RATIO_RANGE[1]:g}] | HT0, HT1, FB1; Simo-κ orders 2, 4, 6; "
                 f"rtol = atol 1e-4 … 1e-10 where the tolerance sets the steps | {rng(ratios)} | "
                 f"{verdict(RATIO_RANGE[0] <= min(ratios) and max(ratios) <= RATIO_RANGE[1])} |")
    if slopes:
        L.append(f"| log–log slope in [{SLOPE_RANGE[0]:g}, {SLOPE_RANGE[1]:g}] | same | {rng(slopes, 3)} | "
                 f"{verdict(SLOPE_RANGE[0] <= min(slopes) and max(slopes) <= SLOPE_RANGE[1])} |")
    # cost at equal error
    for case in PROPORTIONAL_CASES:
        costs = [(c, m) for m in SIMO_METHODS if (case, m) in by for c in by[(case, m)]["costs"]]
        if costs:
            best = min(costs)
            L.append(f"| time ≤ {COST_TARGET}× the best fixed h at equal error | {case.upper()}, Simo-κ orders 2–6 "
                     f"(each against its own fixed-h sweep) | {rng([c for c, _ in costs])} (best "
                     f"{best[0]:.2f}, {TITLES.get(best[1], best[1])}) | {verdict(best[0] <= COST_TARGET)} "
                     f"(best); {verdict(max(c for c, _ in costs) <= COST_TARGET)} (all) |")
    fewer = [(f, m) for m in SIMO_METHODS if (VARYING_CASE, m) in by for f in by[(VARYING_CASE, m)]["fewer"]]
    if fewer:
        L.append(f"| ≥ {STEPS_TARGET:g}× fewer steps than fixed h at equal error, where the time scale varies | "
                 f"{VARYING_TEXT}; Simo-κ orders 4, 6 | {rng([f for f, _ in fewer])} | "
                 f"{verdict(max(f for f, _ in fewer) >= STEPS_TARGET)} (best) |")
    for method, limit in OVERHEAD_TARGETS.items():
        if method in over and over[method][0]:
            p, a, r = over[method]
            L.append(f"| estimator + controller ≤ +{round((limit - 1) * 100)} % of a step | HT1, {TITLES[method]}, "
                     f"h = 1e-3 | {a * 1e6:.3g} / {p * 1e6:.3g} µs: {r:.2f}× | {verdict(r <= limit)} |")
    simo = [r for r in rows if r["method"] in SIMO_METHODS and r["case"] in CONSERVATIVE_CASES]
    if simo:
        dH = max(r["max_dH"] for r in simo)
        dmu = max(r["max_dmu"] for r in simo)
        L.append(f"| H and μ ≤ 1e-13 relative, Simo-κ, tolerance mode | every sweep run (HT0, HT1, HT2, FB1) | "
                 f"max \\|ΔH/H\\| {dH:.1e}, \\|Δμ/μ\\| {dmu:.1e} | {verdict(dH <= 1e-13 and dmu <= 1e-13)} |")
    return L


def _finish_panel(ax, case, dopri_points, xlabel):
    """dopri5's line (x, err), the title, the labels and the grid of one case's panel."""
    if dopri_points:
        ax.loglog([x for x, _ in dopri_points], [e for _, e in dopri_points], color="black", linestyle="-.",
                  marker="^", markersize=3, label="odeint dopri5")
    ax.set_title(case.upper())
    ax.set_xlabel(xlabel)
    ax.set_ylabel("‖Λ − Λref‖ at the end")
    ax.grid(True, alpha=0.4)


def _save(plt, fig, axes, path, title, ncol, bottom):
    """The legend of the first panel under the figure, the title, and the file."""
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=ncol, fontsize=8, frameon=False)
    fig.suptitle(title)
    fig.tight_layout(rect=(0, bottom, 1, 0.97))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot(report_dir, adaptive, fixed, dopri):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    cases = [c for c in CASE_ORDER if any(k[0] == c for k in adaptive)]
    if not cases:
        return []
    nrows = (len(cases) + 1) // 2
    # end error against tolerance
    fig, axes = plt.subplots(nrows, 2, figsize=(12, 4.5 * nrows), squeeze=False)
    for ax in axes.flat[len(cases):]:
        ax.set_visible(False)
    for ax, case in zip(axes.flat, cases):
        tols = sorted({t for (c, _), pts in adaptive.items() if c == case for t, _ in pts})
        if tols:
            ax.fill_between(tols, [RATIO_RANGE[0] * t for t in tols], [RATIO_RANGE[1] * t for t in tols],
                            color="0.9", label="err/tol in [0.1, 30]")
            ax.loglog(tols, tols, color="0.5", linestyle=":", linewidth=1, label="err = tol")
        for (c, m), pts in sorted(adaptive.items()):
            if c == case:
                ax.loglog([t for t, _ in pts], [max(b["err_rot"], 1e-16) for _, b in pts], marker="o",
                          markersize=3, color=COLORS.get(m, "gray"), label=TITLES.get(m, m))
        _finish_panel(ax, case, sorted((t, b["err_rot"]) for (c, t), b in dopri.items() if c == case), "rtol = atol")
    _save(plt, fig, axes, os.path.join(report_dir, "adaptive_tolerance.png"),
          "Adaptive steps: end error against the tolerance (over the span)", 5, 0.06)
    # work–precision: adaptive (solid) beside the same method at fixed h (dotted) and dopri5
    fig, axes = plt.subplots(nrows, 2, figsize=(12, 4.5 * nrows), squeeze=False)
    for ax in axes.flat[len(cases):]:
        ax.set_visible(False)
    for ax, case in zip(axes.flat, cases):
        for (c, m), pts in sorted(adaptive.items()):
            if c != case:
                continue
            col = COLORS.get(m, "gray")
            ax.loglog([seconds(b) * 1e3 for _, b in pts], [max(b["err_rot"], 1e-16) for _, b in pts], color=col,
                      marker="o", markersize=3, label=TITLES.get(m, m) + ", adaptive")
            f = sorted(fixed.get((case, m), []), key=lambda x: x[1])
            if f:
                ax.loglog([x[1] * 1e3 for x in f], [x[0] for x in f], color=col, linestyle=":", linewidth=1,
                          label=TITLES.get(m, m) + ", fixed h")
        _finish_panel(ax, case, sorted((seconds(b) * 1e3, b["err_rot"]) for (c, t), b in dopri.items() if c == case),
                      "CPU time per run [ms]")
    _save(plt, fig, axes, os.path.join(report_dir, "adaptive_work_precision.png"),
          "Adaptive steps: work–precision beside fixed h and dopri5", 4, 0.08)
    return ["adaptive_tolerance.png", "adaptive_work_precision.png"]


def tables(paths):
    adaptive, fixed, dopri, step_times = load(paths)
    rows = summary_rows(adaptive, fixed)
    over = overhead_rows(step_times)
    return adaptive, fixed, dopri, rows, over


def section(report_dir):
    """The Markdown lines of docs/accuracy.md's "Adaptive steps", and its figures; [] when
    the run has no adaptive sweep."""
    adaptive, fixed, dopri, rows, over = tables([os.path.join(report_dir, "bench.json")])
    if not adaptive:
        return []
    plot(report_dir, adaptive, fixed, dopri)
    L = ["## Adaptive steps", "",
         "![Adaptive steps: end error against the tolerance](img/adaptive_tolerance.png)", "",
         "![Adaptive steps: work–precision beside fixed h and dopri5](img/adaptive_work_precision.png)", "",
         "The adaptive driver ([adaptive.md](adaptive.md)) in tolerance mode, rtol = atol = tol a decade apart, "
         "the tolerance over the span (the end error ≈ tol), the automatic estimate (the defect for Simo-κ, "
         "Richardson's with 8 steps per attempt for the splitting): Simo-κ at orders "
         "2, 4 (Suzuki-5), 6 (Kahan–Li-9) and the splitting (Strang, Suzuki-5, Kahan–Li-9), each beside its own "
         "fixed-h sweep and odeint's dopri5 at the same tolerances (dopri5's tolerance is per step: its end "
         "error is not tol). Where the accepted count stays within 5 % of the looser tolerance's, the rotation "
         "cap (3 rad a step) holds h and the tolerance does not set the steps; from the first point whose error "
         "falls less than 3× below the looser tolerance's (below 1e-8; comparing points the cap does not hold), "
         "or from the first below 1e-8 and 1000× below its tolerance, the error sits at the round-off floor: both kinds of "
         "points are left out of the ratios. \"time / fixed-h time\" and \"fixed-h steps / steps\" compare with the same method's fixed-h "
         "sweep at the same end error (log–log interpolation between its two neighbouring points). SPIN-DOWN, "
         "the case whose time scale varies (a free body J = diag(1, 2, 3) spun at 30 rad/s about its minor axis "
         "under viscous damping c = 0.05, 0.2 rad/s at t = 100; reference: Simo-κ order 6 at h = 1e-3, good to ~1e-11), has "
         "Simo-κ at orders 4 and 6 to tol 1e-8 and no dopri5 line.", "",
         "### Targets", ""]
    L += targets_table(rows, over)
    L += ["", "### Per method", ""] + summary_table(rows)
    L += ["", "### Estimator overhead (HT1, h = 1e-3: one accepted adaptive step against one fixed-h step, the two runs timed in alternation; medians of 3 repetitions)", ""]
    L += overhead_table(over)
    return L


def main(args):
    paths = [a for a in args if a != "--summary"]
    if not paths:
        sys.exit("usage: python3 -m report.adaptive [--summary] BENCH.json [MORE.json ...]")
    adaptive, fixed, dopri, rows, over = tables(paths)
    print("\n".join(targets_table(rows, over)))
    print()
    print("\n".join(summary_table(rows)))
    if "--summary" not in args:
        for case in [c for c in CASE_ORDER if any(k[0] == c for k in adaptive)]:
            print(f"\n**{case.upper()}** (err = ‖ΔΛ‖_F at t_end; time = CPU time of the run; "
                  "fixed = time / time of the fixed-h sweep at the same error)\n")
            print("| method | tol | err | err/tol | accepted | rejected | max ΔH/H | time (ms) | fixed | dopri5 err | dopri5 ms |")
            print("|---|---|---|---|---|---|---|---|---|---|---|")
            for (c, method), pts in sorted(adaptive.items()):
                if c != case:
                    continue
                for tol, b in pts:
                    err, t = b["err_rot"], seconds(b)
                    ft = fixed_at(fixed.get((case, method), []), err, 1)
                    d = dopri.get((case, tol))
                    fixed_text = f"{t / ft:.2f}" if ft else "-"
                    dopri_text = f"{d['err_rot']:.1e} | {seconds(d) * 1e3:.3g}" if d else "- | -"
                    print(f"| {method} | {tol:.0e} | {err:.1e} | {err / tol:.2g} | {b['accepted']:.0f} | "
                          f"{b['rejected']:.0f} | {b.get('max_dH', 0):.1e} | {t * 1e3:.3g} | {fixed_text} | "
                          f"{dopri_text} |")
    print()
    print("\n".join(overhead_table(over)))


if __name__ == "__main__":
    main(sys.argv[1:])
