"""docs/accuracy.md, whole, from one run: the page's prose states only figures of that run.

page() returns the Markdown of the page: fixed text that explains the method (no measured
figure in it), sentences built from the run's rows (the cheapest line per case and bound
against dopri5, the joint frontier, the invariants, the Newton counts), and the report's
tables (report.md, headings one level down). __main__.py writes it to REPORT_DIR/accuracy.md,
and with TROMPO_UPDATE_DOCS=1 over docs/accuracy.md. Change the page here, not by hand.
"""
import math
import os

from . import adaptive, families
from .core import method_title
from .common import CASES, EXACT_SCHEMES, cheapest, fmt, is_dopri, is_rk4, ok_rows

DOCS_ACCURACY = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "docs", "accuracy.md")
LEVELS = (1e-8, 1e-10)  # attitude bounds of the picture's sentences
CASE_END = {"ht0": "t = 10", "ht1": "t = 10", "ht2": "t = 2", "fb1": "t = 100"}
EM_EXACT = EXACT_SCHEMES + ("geradin-bauchau-paper",)  # energy-exact at every h (the paper's form too)
MU_EXACT = ("simo-alpha",) + EXACT_SCHEMES  # μ (π for FB1) kept; the paper's form is not [T5]

INTRO = """\
# What accuracy costs

<!-- Generated whole by scripts/report (python3 -m report, run by TROMPO_UPDATE_DOCS=1 bash
scripts/report.sh) from one trompo-bench run: every figure on this page is from that run.
Do not edit by hand; change scripts/report/accuracy.py. -->

`bash scripts/report.sh` builds `trompo-bench` (Google Benchmark) in Release, runs the
per-step benchmark and the Δt sweep, and writes `report/`: `report.md` (all tables),
`sweep.csv`, `step.csv`, `frontier.csv`, `attitude_only.csv`, the raw `bench.json`, the
plots below and this page (`report/accuracy.md`); `report/` itself is not in git. With
`TROMPO_UPDATE_DOCS=1` it also copies the plots to `docs/img/` and this page over
`docs/accuracy.md`. It prints each case and method as it finishes, with a count and the
elapsed time. Every run of trompo in it goes through `trompo::integrate()` (recovery by
sub-stepping off: a configuration whose step fails is reported, not timed).

Each point of the sweep is one full run to the case's end time (HT0, HT1: t = 10; HT2:
t = 2; FB1: t = 100) on a geometric grid of h (ratio √2): the energy-momentum schemes at
order 2 and composed to order 4 (triple jump, and Suzuki's five steps: "order 4, Suzuki"),
6 (Kahan–Li; processed: Blanes–Casas–Murua) and 8; the spin-exact splitting
([splitting.md](splitting.md)); the other families ([families.md](families.md)); our RK4;
and Boost.Odeint's `runge_kutta4` and `runge_kutta_dopri5` (controlled, abs = rel
tolerance 1e-3 … 1e-14, half a decade apart) on the quaternion ODE, as a user would write
it. The end error is ‖Λ − Λref‖ (Frobenius) against the closed-form Lagrange top (HT0,
HT1) and free body (FB1) of `trompo/exact`, and against the published 128-bit solution for
HT2 (the cross-checks of the references are under **Machine** in the tables below). Times
are one thread's CPU time.

`bench/CMakeLists.txt` raises GCC's cap on a translation unit's growth by inlining
(`--param=inline-unit-growth=1000`): `trompo-bench` instantiates about a hundred integrator
configurations, and without it those compiled last keep calls that a user's own program
would inline, which skews the ratios between methods.
"""


def _title(m):
    """A method as the page names it: the families' titles, else the core's."""
    t = families.METHOD_TITLES.get(m)
    return t if t else method_title(m)


def _bound(x):
    """1e-08 -> '1e-8'."""
    return f"{x:.0e}".replace("e-0", "e-").replace("e+0", "e+")


def _what(r):
    if is_dopri(r):
        return f"dopri5 at tol {r['tol']:.1e}"
    return f"{_title(r['method'])} at h = {r['h']:.3g}"


def _ratio_text(a, b):
    """'N× cheaper than' / 'N× dearer than' for CPU times a (ours) and b (the baseline)."""
    x = b / a
    return f"{x:.1f}× cheaper than" if x >= 1 else f"{1 / x:.1f}× dearer than"


def _cheapest_line(rows, level):
    return cheapest(rows, lambda r: r["err_rot"] <= level)


def picture(sweep):
    """Per case and bound: the cheapest configuration of any family, against dopri5."""
    L = []
    for case in CASES:
        rows = ok_rows(sweep, case)
        if not rows:
            continue
        parts = []
        for level in LEVELS:
            best = _cheapest_line(rows, level)
            dop = cheapest(rows, lambda r: is_dopri(r) and r["err_rot"] <= level)
            if best is None:
                parts.append(f"no configuration reaches ‖ΔΛ‖ ≤ {_bound(level)}")
                continue
            fam = families.family_of(best["method"])
            text = f"at ‖ΔΛ‖ ≤ {_bound(level)} the cheapest line is {_what(best)} ({fam}), {fmt(best['cpu_ms'], 3)} ms"
            if dop is None:
                text += "; dopri5 does not reach it"
            elif dop is not best:
                text += f", {_ratio_text(best['cpu_ms'], dop['cpu_ms'])} dopri5 ({fmt(dop['cpu_ms'], 3)} ms, tol {dop['tol']:.0e})"
            parts.append(text)
        L.append(f"- **{case.upper()}** ({CASE_END[case]}): " + "; ".join(parts) + ".")
    return L


def energy_momentum(sweep):
    """Per case at the finest bound: the cheapest energy-momentum configuration against dopri5 and RK4."""
    L = []
    level = LEVELS[-1]
    for case in CASES:
        rows = ok_rows(sweep, case)
        em = cheapest(rows, lambda r: families.family_of(r["method"]) == "energy-momentum" and r["err_rot"] <= level)
        if em is None:
            continue
        dop = cheapest(rows, lambda r: is_dopri(r) and r["err_rot"] <= level)
        rk = cheapest(rows, lambda r: is_rk4(r) and r["err_rot"] <= level)
        text = f"- {case.upper()}: {_what(em)}, {fmt(em['cpu_ms'], 3)} ms"
        for name, b in (("dopri5", dop), ("RK4", rk)):
            text += f"; {_ratio_text(em['cpu_ms'], b['cpu_ms'])} {name}" if b else f"; {name} does not reach it"
        L.append(text + ".")
    return L


def joint(fr, bound_rot, bound_dH):
    """The joint frontier (core.frontier's result) as sentences."""
    L = []
    for case, f in fr.items():
        t = f["trompo"]
        if all(f[k] is None for k in ("trompo", "dopri5", "rk4")):
            continue  # the case is not in this run
        if t is None:
            L.append(f"- {case.upper()}: no energy-exact configuration reaches both bounds.")
            continue
        text = (f"- {case.upper()}: the cheapest energy-exact run reaching ‖ΔΛ‖ ≤ {_bound(bound_rot)} and max |ΔH/H| ≤ "
                f"{_bound(bound_dH)} is {_what(t)}, {fmt(t['cpu_ms'], 3)} ms")
        for name, key in (("dopri5", "dopri5"), ("RK4", "rk4")):
            b = f[key]
            if b:
                text += f"; {_ratio_text(t['cpu_ms'], b['cpu_ms'])} {name} ({_what(b)}, {fmt(b['cpu_ms'], 3)} ms)"
            else:
                text += f"; {name} does not reach both"
        L.append(text + ".")
    return L


def _nearest(rows, h):
    return min(rows, key=lambda r: abs(math.log(r["h"] / h))) if rows else None


def _schemes(rows):
    """The schemes of these rows, in a sentence."""
    return ", ".join(sorted({r["scheme"] for r in rows}))


def invariants(sweep):
    """Sentences on H and μ over the whole sweep."""
    tops = [r for c in CASES for r in ok_rows(sweep, c)]
    L = []
    exact = [r for r in tops if r["scheme"] in EM_EXACT]
    if exact:
        L.append(f"The energy-exact schemes of the run ({_schemes(exact)}) keep H to ≤ "
                 f"{fmt(max(r['max_dH'] for r in exact))} at every h and order of the sweep.")
    mu = [r for r in tops if r["scheme"] in MU_EXACT]
    if mu:
        L.append(f"μ (for FB1: π) is kept to ≤ {fmt(max(r['max_dmu'] for r in mu))} by {_schemes(mu)} at every h "
                 "and order.")
    drifts = []
    for case in ("ht1", "ht2"):
        paper = [r for r in ok_rows(sweep, case) if r["method"] == "geradin-bauchau-paper"]
        r = _nearest(paper, 1e-3 if case == "ht1" else 1e-4)
        if r:
            drifts.append(f"{fmt(r['max_dmu'])} on {case.upper()} at h = {r['h']:.3g}")
    if drifts:
        L.append(f"The paper's printed Géradin–Bauchau form [T5] drifts in μ: {' and '.join(drifts)} "
                 "([theory §4](theory.md#4-géradinbauchau)).")
    ht1 = ok_rows(sweep, "ht1")
    for m, name in (("simo-alpha", "Simo-α ½ (not energy-exact: an O(h²) bounded error)"), ("rk4", "Our RK4"),
                    ("odeint-rk4", "Odeint's RK4")):
        r = _nearest([x for x in ht1 if x["method"] == m], 1e-3)
        if r:
            L.append(f"{name}: max |ΔH/H| = {fmt(r['max_dH'])} on HT1 at h = {r['h']:.3g}.")
    return [" ".join(L)] if L else []


def newton(sweep, steps):
    """Sentences on Newton corrections per base step."""
    L = []
    k = steps.get(("ht1", "simo-kappa"))
    if k:
        L.append(f"Simo-κ on HT1 at h = {k['h']:g}: {k['newton_mean']:.2f} corrections per step.")
    em = [r for c in CASES for r in ok_rows(sweep, c)
          if families.family_of(r["method"]) == "energy-momentum" and r["stages"] > 0 and r["steps"] > 0]
    if em:
        per = [r["newton"] / r["stages"] for r in em]
        L.append(f"Over the sweep's energy-momentum runs: {min(per):.2f} to {max(per):.2f} per base step.")
    return [" ".join(L)] if L else []


def tables(report_dir):
    """report.md without its title, headings one level down."""
    with open(os.path.join(report_dir, "report.md")) as f:
        lines = f.read().splitlines()
    return ["#" + line if line.startswith("#") else line for line in lines[1:]]


def page(report_dir, sweep, steps, fr, bound_rot, bound_dH):
    L = [INTRO]
    L += ["## The picture", "",
          "![Work–precision by family: the lower envelope of each family's methods](img/work_precision.png)", "",
          "Each line is the lower envelope of one family's configurations (every scheme, order and step of the "
          "sweep). The cheapest configuration of any family, per case and attitude bound, against the cheapest "
          "dopri5 run reaching the same bound:", ""]
    L += picture(sweep)
    L += ["", "The energy-momentum schemes and the baselines alone, every configuration:", "",
          "![Work–precision of the energy-momentum schemes and the baselines](img/work_precision_core.png)", "",
          f"The cheapest energy-momentum configuration reaching ‖ΔΛ‖ ≤ {_bound(LEVELS[-1])}:", ""]
    L += energy_momentum(sweep)
    L += ["", "## The joint target", "",
          "![Joint target: both the attitude and the energy bound, against CPU time](img/frontier.png)", "",
          f"The joint plot puts both bounds on one axis, max(‖ΔΛ‖/{_bound(bound_rot)}, max|ΔH/H|/{_bound(bound_dH)}): below the "
          "line both hold. The energy-exact schemes meet the energy bound at any h, so their cost is that of the "
          "attitude bound alone; the explicit methods must run far below their attitude need until their energy "
          "drift falls under the bound.", ""]
    L += joint(fr, bound_rot, bound_dH)
    L += ["", "## Invariants", "", "![max |ΔH/H| vs h](img/energy_vs_h.png)", "",
          "![|ΔH/H| over 5·10⁵ steps](img/energy_over_time.png)", ""]
    L += invariants(sweep)
    if os.path.exists(os.path.join(report_dir, "satellite.png")):
        L += ["", "## Spacecraft: sat1 over 1000 orbits", "", "![sat1: the local vertical in body axes, and E_J per orbit](img/satellite.png)", "",
              "The tumbling satellite sat1 ([spacecraft.md](spacecraft.md)) run over 1000 orbits (trompo-bench "
              "--trompo_satellite_series): above, the local vertical in body axes over the first 20 minutes (one dot per step); below, "
              "the largest |ΔE_J/E_J| of each orbit, SABA₄C at h = 8 s (its cheapest run to 1e-8 over 10 orbits) "
              "against dopri5 at tolerance 1e-10 (its run to 1e-6).", ""]
    ad = adaptive.section(report_dir)
    if ad:
        L += [""] + ad
    L += ["", "## Newton", "", "![Newton iterations per base step vs h](img/newton_vs_h.png)", "",
          "Corrections per base step (full Newton and chord steps alike; see [design.md](design.md#simplified-newton) "
          "for the simplified Newton). A chord correction costs a residual evaluation and a 3×3 matrix-vector "
          "product, about half a Newton correction. Composed steps count the corrections of their sub-steps; the "
          "plot divides by their number.", ""]
    L += newton(sweep, steps)
    L += ["", "## trompo-invariants", "",
          "`trompo-invariants` (built from `tools/` when Boost is found) prints, per scheme, on HT1 (t = 10) and HT2 "
          "(t = 2) at h = 0.001 and 0.005: max |ΔH/H|, max |Δμ/μ|, mean Newton iterations per step, the end attitude "
          "error ‖Λ − Λref‖_F against the closed form (HT1) or the 128-bit reference (HT2), and the observed order "
          "log(err(5h)/err(h))/log 5. On HT2 at h = 0.005 (|hΩ| = 0.75 a step) every scheme is pre-asymptotic, so "
          "its \"order\" column there says little.", "",
          "## Tables of this run", ""]
    L += tables(report_dir)
    return "\n".join(L).rstrip("\n") + "\n"


def write(report_dir, sweep, steps, fr, bound_rot, bound_dH):
    """Writes REPORT_DIR/accuracy.md; returns its path."""
    path = os.path.join(report_dir, "accuracy.md")
    with open(path, "w") as f:
        f.write(page(report_dir, sweep, steps, fr, bound_rot, bound_dH))
    return path


def update_docs(report_dir, path=DOCS_ACCURACY):
    """Copies REPORT_DIR/accuracy.md over docs/accuracy.md."""
    with open(os.path.join(report_dir, "accuracy.md")) as f:
        text = f.read()
    with open(path, "w") as f:
        f.write(text)
    return os.path.normpath(path)
