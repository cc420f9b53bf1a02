"""The implicit energy-momentum schemes' targets (docs/predictor.md) in the report.

section(sweep, steps) returns the report's markdown lines:
  - the target table: the Simo-kappa step vs odeint's runge_kutta4 step (HT1, h = 1e-3), a
    composed sub-step vs a base step (both from step-pair/ht1/..., each pair timed in
    alternation, when the run has them; else from the step/ rows), attitude alone at 1e-10
    (t = 10), and the joint bound at t = 1000 (HT0, HT1) against dopri5 and RK4;
  - the joint and attitude-only frontiers at t = 1000 (cases "ht0-t1000", "ht1-t1000": the
    implicit rows from bench/methods/implicit_long.cpp, the explicit ones from the
    splitting family's bench/methods/splitting.cpp).
It reads the rows common.load() makes and changes nothing else.
"""
from .common import cheapest, fmt, is_dopri, is_rk4, is_trompo_exact, ok_rows, pair

STEP_VS_ODEINT = 1.3      # Simo-kappa step / odeint rk4 step, HT1, h = 1e-3
SUBSTEP_VS_BASE = 1.05    # composed sub-step / base step
ATTITUDE = 1e-10          # ||dLambda|| at t = 10
ATTITUDE_TARGET = {"ht0": 1.0, "ht1": 1.5, "ht2": 1.5}  # implicit / dopri5
JOINT_ROT, JOINT_DH = 1e-6, 1e-12
JOINT_FRACTION = 1.0 / 3.0
LONG_CASES = ("ht0-t1000", "ht1-t1000")
LONG_ATTITUDE = (1e-4, 1e-6, 1e-8)


def _joint(r):
    return r["err_rot"] <= JOINT_ROT and r["max_dH"] <= JOINT_DH


def _config(r):
    if r is None:
        return "not reached"
    if r["method"] == "odeint-dopri5":
        return f"odeint dopri5, tol {r['tol']:.1e}: {fmt(r['cpu_ms'])} ms"
    return f"{r['method']}, h = {r['h']:.3g}: {fmt(r['cpu_ms'])} ms"


def _status(ok):
    return "met" if ok else "**missed**"


def _alternated(pr):
    """A pair timed in alternation (step-pair/…, common.pair): both times and the ratio."""
    return (f"{pr['method_ns']:.0f} ns vs {pr['baseline_ns']:.0f} ns, timed in alternation: **{pr['ratio']:.2f}×** "
            f"(repetitions {pr['ratio_min']:.2f}–{pr['ratio_max']:.2f}×)")


def _targets(sweep, steps):
    L = ["| target | configuration and measurement | status |", "|---|---|---|"]
    k, o = steps.get(("ht1", "simo-kappa")), steps.get(("ht1", "odeint-rk4"))
    pk = pair(steps, "ht1", "simo-kappa", "odeint-rk4")
    if pk:
        L.append(f"| Simo-κ step, HT1, h = 1e-3 ≤ {STEP_VS_ODEINT:g}× odeint runge_kutta4 | {_alternated(pk)}, "
                 f"{k['newton_mean']:.2f} corrections/step | {_status(pk['ratio'] <= STEP_VS_ODEINT)} |")
    elif k and o:
        ratio = k["ns"] / o["ns"]
        lo, hi = k["ns_min"] / o["ns_max"], k["ns_max"] / o["ns_min"]
        L.append(f"| Simo-κ step, HT1, h = 1e-3 ≤ {STEP_VS_ODEINT:g}× odeint runge_kutta4 | "
                 f"{k['ns']:.0f} ns vs {o['ns']:.0f} ns: **{ratio:.2f}×** (repetitions {lo:.2f}–{hi:.2f}×), "
                 f"{k['newton_mean']:.2f} corrections/step | {_status(ratio <= STEP_VS_ODEINT)} |")
    else:
        L.append("| Simo-κ step vs odeint runge_kutta4 | not in this run | — |")
    for scheme in ("simo-kappa", "geradin-bauchau"):
        base = steps.get(("ht1", scheme))
        for v in ("o4s", "o6", "o8", "p6"):
            comp = steps.get(("ht1", f"{scheme}-{v}"))
            pr = pair(steps, "ht1", f"{scheme}-{v}", scheme)
            if pr:
                L.append(f"| composed sub-step ≤ {SUBSTEP_VS_BASE:g}× base step ({scheme}-{v}, HT1, h = 1e-3) | "
                         f"{_alternated(pr)} | {_status(pr['ratio'] <= SUBSTEP_VS_BASE)} |")
            elif base and comp:
                per = comp["ns"] / comp["substeps"]
                ratio = per / base["ns"]
                L.append(f"| composed sub-step ≤ {SUBSTEP_VS_BASE:g}× base step ({scheme}-{v}, HT1, h = 1e-3) | "
                         f"{per:.0f} ns vs {base['ns']:.0f} ns (separate benchmarks): **{ratio:.2f}×** | "
                         f"{_status(ratio <= SUBSTEP_VS_BASE)} |")
    for case in ("ht0", "ht1", "ht2"):
        rows = ok_rows(sweep, case)
        imp = cheapest(rows, lambda r: is_trompo_exact(r) and r["err_rot"] <= ATTITUDE)
        dop = cheapest(rows, lambda r: is_dopri(r) and r["err_rot"] <= ATTITUDE)
        target = ATTITUDE_TARGET[case]
        if imp and dop:
            ratio = imp["cpu_ms"] / dop["cpu_ms"]
            L.append(f"| attitude ‖ΔΛ‖ ≤ {ATTITUDE:g}, {case.upper()}, t = 10: implicit ≤ {target:g}× dopri5 | "
                     f"{_config(imp)} vs {_config(dop)}: **{ratio:.2f}×** | {_status(ratio <= target)} |")
        else:
            L.append(f"| attitude ‖ΔΛ‖ ≤ {ATTITUDE:g}, {case.upper()}, t = 10 | implicit: {_config(imp)}; "
                     f"dopri5: {_config(dop)} | — |")
    for case in LONG_CASES:
        rows = ok_rows(sweep, case)
        if not rows:
            L.append(f"| joint bound, {case.upper()} | not in this run | — |")
            continue
        imp = cheapest(rows, lambda r: is_trompo_exact(r) and _joint(r))
        dop = cheapest(rows, lambda r: is_dopri(r) and _joint(r))
        rk = cheapest(rows, lambda r: is_rk4(r) and _joint(r))
        have_explicit = any(is_dopri(r) or is_rk4(r) for r in rows)
        explicit = [r for r in (dop, rk) if r]
        if imp and explicit:
            best = min(explicit, key=lambda r: r["cpu_ms"])
            ratio = imp["cpu_ms"] / best["cpu_ms"]
            ok = ratio <= JOINT_FRACTION
            meas = f"{_config(imp)} vs {_config(best)}: **{ratio:.2f}×**"
        elif imp and have_explicit:
            ok, meas = True, f"{_config(imp)}; dopri5 and RK4 do not reach it"
        else:
            ok, meas = False, f"implicit: {_config(imp)}" + ("" if have_explicit else "; no explicit rows in this run")
        L.append(f"| joint ‖ΔΛ‖ ≤ {JOINT_ROT:g}, max ΔH/H ≤ {JOINT_DH:g}, {case.upper()}: implicit ≤ ⅓ of the "
                 f"cheapest dopri5/RK4 | {meas} | {_status(ok) if (imp or have_explicit) else '—'} |")
    return L


def _long_frontiers(sweep):
    L = []
    for case in LONG_CASES:
        rows = ok_rows(sweep, case)
        if not rows:
            continue
        L.append(f"### {case.upper()} (t = 1000)\n")
        L.append("| bound | implicit energy-momentum | dopri5 | RK4 |")
        L.append("|---|---|---|---|")
        fams = ((is_trompo_exact, "implicit"), (is_dopri, "dopri5"), (is_rk4, "rk4"))
        cells = [_config(cheapest(rows, lambda r, p=p: p(r) and _joint(r))) for p, _ in fams]
        L.append(f"| joint: ‖ΔΛ‖ ≤ {JOINT_ROT:g} and max ΔH/H ≤ {JOINT_DH:g} | " + " | ".join(cells) + " |")
        for level in LONG_ATTITUDE:
            cells = [_config(cheapest(rows, lambda r, p=p: p(r) and r["err_rot"] <= level)) for p, _ in fams]
            L.append(f"| attitude only: ‖ΔΛ‖ ≤ {level:g} | " + " | ".join(cells) + " |")
        L.append("")
        L.append("| method | h range | CPU ms | ‖ΔΛ‖ at t = 1000 | max ΔH/H | max Δμ/μ |")
        L.append("|---|---|---|---|---|---|")
        # the exact schemes, and the symplectic LGVI beside them (H bounded, not exact: docs/theory.md §19)
        for m in sorted({r["method"] for r in rows if is_trompo_exact(r) or r["scheme"] == "lgvi"}):
            good = [r for r in rows if r["method"] == m]
            L.append(f"| {m} | {fmt(min(r['h'] for r in good))} – {fmt(max(r['h'] for r in good))} | "
                     f"{fmt(min(r['cpu_ms'] for r in good))} – {fmt(max(r['cpu_ms'] for r in good))} | "
                     f"{fmt(min(r['err_rot'] for r in good))} – {fmt(max(r['err_rot'] for r in good))} | "
                     f"{fmt(max(r['max_dH'] for r in good))} | {fmt(max(r['max_dmu'] for r in good))} |")
        L.append("")
    if not L:
        L.append("No t = 1000 rows in this run (bench/methods/implicit_long.cpp not built, or filtered out).\n")
    return L


def section(sweep, steps):
    """Markdown lines: the implicit schemes' targets and the t = 1000 frontiers."""
    L = ["## Implicit energy-momentum schemes: targets (docs/predictor.md)\n",
         "Ratios within this run; the machine is shared, so quote ranges over runs.\n"]
    L += _targets(sweep, steps)
    L.append("")
    L.append("## Long horizon: frontiers at t = 1000 (HT0, HT1)\n")
    L += _long_frontiers(sweep)
    return L
