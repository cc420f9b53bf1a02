"""The spin-exact splitting's part of the report (bench/methods/splitting.cpp, docs/splitting.md).

Called from core.py: section() gives the target table of the splitting issue as Markdown
lines (every target row, the configuration behind it, the measured dopri5/splitting CPU-time
ratio and whether it is met), style() and method_rank() place the splitting series in the
plots. All ratios come from one trompo-bench run (dopri5 and the splitting timed together).

A ratio is dopri5's CPU time at the cheapest point of its tolerance sweep that reaches the
bound, over the splitting's cheapest configuration (any method, with or without the energy
projection) that reaches it; in brackets, the same with both sides interpolated log-log
between the grid points around the bound (the grids are coarse: √2 in h, half a decade in
tolerance).
"""
import os

from . import common
from .common import cheapest, family_crossing, is_dopri, ok_rows

SCHEMES = ("splitting", "splitting-projected")
METHOD_COLORS = {
    "strang": "#17becf",
    "suzuki-5": "#bcbd22",
    "kahan-li-9": "#e377c2",
    "chin-4a": "#7f7f7f",
    "chin-tj": "#393b79",
}


def parse(method):
    """'splitting-projected-chin-4a' -> ('splitting-projected', 'chin-4a'); None if not a splitting."""
    for s in ("splitting-projected", "splitting"):
        if method.startswith(s + "-"):
            return s, method[len(s) + 1:]
    return None


def is_splitting(method):
    return parse(method) is not None


def style(method):
    scheme, m = parse(method)
    return {"color": METHOD_COLORS.get(m, "gray"), "linestyle": "-" if scheme == "splitting" else "--",
            "linewidth": 1.6, "marker": "D", "markersize": 2.5}


def method_rank(method):
    scheme, m = parse(method)
    names = list(METHOD_COLORS)
    return (20 + (scheme == "splitting-projected"), names.index(m) if m in names else 9)


def in_work_precision(method):
    """The work–precision plot shows the unprojected splittings (the projection changes the
    energy, not the attitude error); the joint plot shows both."""
    p = parse(method)
    return p is None or p[0] == "splitting"


def _is_split(r):
    return r["scheme"] in SCHEMES


def _is_rk4(r):
    return r["method"] == "odeint-rk4"


def _config(r):
    if r is None:
        return "not reached"
    if is_dopri(r):
        return f"dopri5 tol {r['tol']:.1e}: {r['cpu_ms']:.3g} ms"
    return f"{r['method']} h = {r['h']:.3g}: {r['cpu_ms']:.3g} ms"


def measure(sweep, case, bound_rot, bound_dH=None, baseline=is_dopri):
    """(splitting row, baseline row, grid ratio, interpolated ratio) at a bound."""
    rows = ok_rows(sweep, case)

    def reach(r):
        return r["err_rot"] <= bound_rot and (bound_dH is None or r["max_dH"] <= bound_dH)

    def ratio(r):
        x = r["err_rot"] / bound_rot
        return max(x, r["max_dH"] / bound_dH) if bound_dH else x

    s = cheapest(rows, lambda r: _is_split(r) and reach(r))
    b = cheapest(rows, lambda r: baseline(r) and reach(r))
    grid = b["cpu_ms"] / s["cpu_ms"] if s and b else None
    si = family_crossing(rows, _is_split, ratio)
    bi = family_crossing(rows, baseline, ratio)
    interp = bi[0] / si[0] if si and bi else None
    return s, b, grid, interp


def _fmt_ratio(x):
    return "—" if x is None else (f"{x:.1f}×" if x < 100 else f"{x:.0f}×")


def _step_row(steps, case, target, where, name, bound):
    """The row of a per-step target against odeint's runge_kutta4: from the pair timed in
    alternation (step-pair/<case>/splitting-strang/vs:odeint-rk4) when the run has it, else
    from the two step/ rows."""
    pr = common.pair(steps, case, "splitting-strang", "odeint-rk4")
    if pr:
        r = pr["ratio"]
        return [f"| {target} | {where} | {name} {pr['method_ns']:.0f} ns | runge_kutta4 {pr['baseline_ns']:.0f} ns "
                f"(timed in alternation) | {r:.2f}× of rk4 (repetitions {pr['ratio_min']:.2f}–{pr['ratio_max']:.2f}×) | "
                f"{'yes' if r <= bound else 'no'} |"]
    a, o = steps.get((case, "splitting-strang")), steps.get((case, "odeint-rk4"))
    if not (a and o):
        return []
    r = a["ns"] / o["ns"]
    return [f"| {target} | {where} | {name} {a['ns']:.0f} ns | runge_kutta4 {o['ns']:.0f} ns | {r:.2f}× of rk4 | "
            f"{'yes' if r <= bound else 'no'} |"]


def section(sweep, steps):
    """The Markdown lines of the splitting section (empty if the run has no splitting)."""
    if not any(_is_split(r) for r in sweep):
        return []
    L = ["", "## Spin-exact splitting: targets", "",
         "Ratios are dopri5's CPU time over the splitting's (> 1: the splitting is cheaper), both from this run; "
         "each side is its cheapest grid point reaching the bound (in brackets: interpolated to the bound). "
         "The configuration behind each row is the cheapest splitting reaching the bound, any method, with or "
         "without the energy projection.", "",
         "| target | case, bound | splitting (cheapest) | baseline (cheapest) | measured | met |",
         "|---|---|---|---|---|---|"]
    rows_out = []

    def add(target, where, s, b, grid, interp, need, baseline_name="dopri5"):
        met = None if grid is None else grid >= need
        if grid is None and s is not None and b is None:
            verdict = f"{baseline_name} not reached"
        else:
            verdict = "yes" if met else ("no" if met is not None else "—")
        L.append(f"| {target} | {where} | {_config(s)} | {_config(b)} | {_fmt_ratio(grid)} "
                 f"[{_fmt_ratio(interp)}] | {verdict} |")
        rows_out.append((target, where, grid, interp, verdict))

    # Per-step cost.
    L += _step_row(steps, "ht1", "Strang step ≤ 0.6× odeint runge_kutta4 step", "HT1, h = 1e-3", "Strang", 0.6)
    for case, need in (("ht0", 10), ("ht1", 10), ("ht2", 40)):
        for bound in (1e-6, 1e-8, 1e-10):
            add(f"attitude alone, t = {'2' if case == 'ht2' else '10'}: ≥ {need}×", f"{case.upper()}, ‖ΔΛ‖ ≤ {bound:g}",
                *measure(sweep, case, bound), need)
    for bound in (1e-6, 1e-8):
        add("attitude alone, t = 1000: ≥ 12×", f"HT1, ‖ΔΛ‖ ≤ {bound:g}", *measure(sweep, "ht1-t1000", bound), 12)
    add("attitude alone, t = 1000: ≥ 40×", "HT0, ‖ΔΛ‖ ≤ 1e-6", *measure(sweep, "ht0-t1000", 1e-6), 40)
    s, b, grid, interp = measure(sweep, "ht0-t1000", 1e-8, baseline=_is_rk4)
    add("t = 1000, HT0 at 1e-8 in ≤ 1/60 of RK4's time", "HT0, ‖ΔΛ‖ ≤ 1e-8 (baseline: runge_kutta4)",
        s, b, grid, interp, 60, "runge_kutta4")
    d = measure(sweep, "ht0-t1000", 1e-8)
    L.append(f"| (dopri5 at t = 1000, HT0, 1e-8) | HT0, ‖ΔΛ‖ ≤ 1e-8 | {_config(d[0])} | {_config(d[1])} | "
             f"{_fmt_ratio(d[2])} | {'dopri5 not reached' if d[1] is None else ''} |")
    for case, need in (("ht1", 30), ("ht0", 45), ("ht2", 300)):
        add(f"joint bound, t = {'2' if case == 'ht2' else '10'}: ≥ {need}×",
            f"{case.upper()}, ‖ΔΛ‖ ≤ 1e-6 and max|ΔH/H| ≤ 1e-12", *measure(sweep, case, 1e-6, 1e-12), need)
    add("joint bound, t = 1000: ≥ 40×", "HT1, ‖ΔΛ‖ ≤ 1e-6 and max|ΔH/H| ≤ 1e-12",
        *measure(sweep, "ht1-t1000", 1e-6, 1e-12), 40)
    # The exact free rotation of any body (docs/splitting.md, asymmetric bodies): its step,
    # the free body FB1, the asymmetric tops HTA and HT2A, the tumbling satellite sat1.
    L += _step_row(steps, "fb1", "exact free-flow step ≤ 2.5× odeint runge_kutta4 step", "FB1, h = 0.01",
                   "Strang (the exact flow)", 2.5)
    for bound, need in ((1e-8, 50), (1e-10, 100)):
        add(f"free body, t = 100: ≥ {need}×", f"FB1, ‖ΔΛ‖ ≤ {bound:g}", *measure(sweep, "fb1", bound), need)
    e = steps.get(("fb1", "exact-free-body"))
    if e:
        L.append(f"| exact::FreeBody at any t within 5 µs | FB1, Λ(t) at 1,000 times over [0, 1000] | "
                 f"{e['ns'] / 1e3:.2f} µs an evaluation (median of 3; {e['ns_min'] / 1e3:.2f}–{e['ns_max'] / 1e3:.2f}) | "
                 f"— | — | {'yes' if e['ns'] <= 5000 else 'no'} |")
    f100 = steps.get(("fb1", "free-flow-h100"))
    if e and f100:
        r = f100["ns"] / e["ns"]
        L.append(f"| one free-flow step of h = 100 within 1.5× an exact::FreeBody evaluation | FB1, Strang step of "
                 f"h = 100 from 1,000 states | {f100['ns'] / 1e3:.2f} µs a step (median of 3) | — | {r:.2f}× | "
                 f"{'yes' if r <= 1.5 else 'no'} |")
    for case, name in (("hta", "HTA"), ("ht2a", "HT2A")):
        for bound, need in ((1e-8, 6), (1e-10, 4)):
            add(f"fast asymmetric top ({name}, full inertia): ≥ {need}×", f"{name}, ‖ΔΛ‖ ≤ {bound:g}",
                *measure(sweep, case, bound), need)
    for bound, need in ((1e-6, 6), (1e-8, 10)):
        add(f"tumbling satellite, 10 orbits: ≥ {need}×", f"sat1, ‖ΔΛ‖ ≤ {bound:g}", *measure(sweep, "sat1", bound), need)
    # sat1 at 1e-10: beyond dopri5's reach; met when a splitting run reaches it for less CPU
    # than dopri5's most accurate run of the sweep.
    rows = ok_rows(sweep, "sat1")
    s10 = cheapest(rows, lambda r: _is_split(r) and r["err_rot"] <= 1e-10)
    dop = [r for r in rows if is_dopri(r)]
    best = min(dop, key=lambda r: r["err_rot"]) if dop else None
    if best is not None:
        met = s10 is not None and s10["cpu_ms"] < best["cpu_ms"]
        L.append(f"| tumbling satellite, 10 orbits: 1e-10 reached for less than dopri5's best | sat1, ‖ΔΛ‖ ≤ 1e-10 | "
                 f"{_config(s10)} | dopri5's best: {best['err_rot']:.2g} at tol {best['tol']:.1e}, "
                 f"{best['cpu_ms']:.3g} ms | {'—' if s10 is None else _fmt_ratio(best['cpu_ms'] / s10['cpu_ms'])} | "
                 f"{'yes' if met else 'no'} |")
    L += ["", "HTA: J = R diag(5, 5.5, 1) Rᵀ with R = exp((0.3, −0.2, 0.4)^), E = R e3, Mgl = 20, "
          "Λ0 = exp(0.05 ê1), Ω0 = R (0, 0, 50), t = 10; reference: a converged long-double run (Chin's triple jump on the exact free flow, "
          "8,000 steps, checked against 4,000: bench/methods/splitting.cpp, the run's context). HT2A: HT2 made asymmetric, J = R diag(15.234375, 0.46875, 15.6) Rᵀ, "
          "E = R e2, Mgl = 15·9.81, Λ0 = I, Ω0 = R (0, 150, −4.61538), t = 2 (same R); reference likewise. sat1: "
          "docs/spacecraft.md.", ""]
    return L


def write_csv(report_dir, sweep, steps):
    """splitting_targets.csv: the rows of the target table."""
    import csv
    with open(os.path.join(report_dir, "splitting_targets.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["line"])
        for line in section(sweep, steps):
            if line.startswith("| ") and not line.startswith("| target") and not line.startswith("|---"):
                w.writerow([line])
