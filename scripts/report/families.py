"""The families of schemes in the accuracy-cost report (docs/families.md).

Called by __main__.py with the parsed bench data; also runnable on its own, from scripts/:
    /usr/bin/python3 -m report.families REPORT_DIR
Writes REPORT_DIR/work_precision.png        (main figure: each family's lower envelope)
       REPORT_DIR/work_precision_<family>.png (per new family: every method of it; the
                                              energy-momentum family and the baselines are in
                                              report.py's work_precision_core.png)
       REPORT_DIR/invariants_families.png    (ΔH and Δμ against h for the new families)
       REPORT_DIR/large_step_ht0.png         (HT0 at h = 0.05: H/H0 over 10 s)
       REPORT_DIR/families.md                (the family table and the large-step table)
"""
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from .common import load  # noqa: E402

CASES = ("ht0", "ht1", "ht2", "fb1")
CASE_TITLES = {
    "ht0": "HT0 (Mgl = 196.2), t = 10",
    "ht1": "HT1 (Simo-Wong top), t = 10",
    "ht2": "HT2 (Brüls–Cardona fast top), t = 2",
    "fb1": "FB1 (free body, intermediate axis), t = 100",
}
# family key, title, colour
FAMILIES = (
    ("energy-momentum", "energy-momentum (Simo, GB; compositions)", "#1f77b4"),
    ("gen-alpha", "Lie-group generalised-α (numerical dissipation)", "#d62728"),
    ("constrained", "constrained trapezoid (enforced energy)", "#2ca02c"),
    ("energy-decaying", "energy-decaying, μ exact", "#9467bd"),
    ("splitting", "spin-exact splitting (explicit; μ, π exact)", "#ff7f0e"),
    ("lie-group", "Lie group variational (LGVI, DMV; μ, π exact) and Lie group RK (RKMK4, CG3)", "#17becf"),
    ("explicit", "explicit baselines (RK4, odeint)", "#555555"),
    ("other", "other methods", "#bcbd22"),
)
FAMILY_TITLE = {k: t for k, t, _ in FAMILIES}
FAMILY_COLOR = {k: c for k, _, c in FAMILIES}
# The fourth family (docs/theory.md §19): the LGVI (plain, -o4s, -o6), the DMV, RKMK4, Crouch–Grossman 3.
LIE_GROUP_SCHEMES = ("lgvi", "dmv", "rkmk4", "crouch-grossman")
EM_SCHEMES = ("simo-alpha", "simo-kappa", "simo-collocation", "geradin-bauchau", "geradin-bauchau-paper")
METHOD_TITLES = {
    "lie-gen-alpha-r1": "gen-α ρ∞ = 1 (= trapezoid)",
    "lie-gen-alpha-r0.8": "gen-α ρ∞ = 0.8",
    "lie-gen-alpha-r0": "gen-α ρ∞ = 0",
    "constrained-trapezoid": "constrained trapezoid",
    "energy-decaying-chi0": "energy-decaying χ = 0 (EM)",
    "energy-decaying-sensor0.11": "energy-decaying χ = 1/9, sensor",
    "energy-decaying-const0.11": "energy-decaying χ = 1/9, constant",
    "energy-decaying-const1": "energy-decaying χ = 1, constant",
    "simo-kappa": "simo-kappa (EM)",
}


def family_of(method):
    if method.startswith("lie-gen-alpha"):
        return "gen-alpha"
    if method.startswith("constrained-trapezoid"):
        return "constrained"
    if method.startswith("energy-decaying"):
        return "energy-decaying"
    if method in ("rk4", "odeint-rk4") or method.startswith("odeint-dopri5"):
        return "explicit"
    if method.startswith("splitting"):
        return "splitting"
    if method.split("-o")[0] in LIE_GROUP_SCHEMES:
        return "lie-group"
    base = method
    for v in ("-o4s", "-o4", "-o6", "-o8m", "-o8", "-p6"):
        if base.endswith(v):
            base = base[: -len(v)]
    return "energy-momentum" if base in EM_SCHEMES else "other"


def title(method):
    return METHOD_TITLES.get(method, method)


def ok(rows, case):
    return [r for r in rows if r["case"] == case and not r["error"]]


def envelope(points):
    """The lower envelope (Pareto front) of (cost, error) points: cheaper and more accurate."""
    front, best = [], math.inf
    for x, y in sorted(points):
        if y < best:
            best = y
            front.append((x, y))
    return front


def plot_envelopes(report_dir, sweep):
    fig, axes = plt.subplots(2, 2, figsize=(13, 10))
    handles = {}
    for ax, case in zip(axes.flat, CASES):
        by = {}
        for r in ok(sweep, case):
            by.setdefault(family_of(r["method"]), []).append((r["cpu_ms"], max(r["err_rot"], 1e-16)))
        for fam, _, col in FAMILIES:
            if fam not in by:
                continue
            xs, ys = zip(*envelope(by[fam]))
            (line,) = ax.loglog(xs, ys, drawstyle="steps-post", color=col, linewidth=1.8, marker="o", markersize=2.5)
            handles[fam] = line
        ax.set_title(CASE_TITLES[case], fontsize=10)
        ax.set_xlabel("CPU time per run [ms]")
        ax.set_ylabel("‖Λ − Λref‖ at the end")
        ax.grid(True, alpha=0.4)
    order = [f for f, _, _ in FAMILIES if f in handles]
    fig.legend([handles[f] for f in order], [FAMILY_TITLE[f] for f in order], loc="lower center", ncol=3, fontsize=9,
               frameon=False)
    fig.suptitle("Work–precision by family: the lower envelope of every method of each family "
                 "(detail: work_precision_<family>.png)")
    fig.tight_layout(rect=(0, 0.06, 1, 0.97))
    fig.savefig(os.path.join(report_dir, "work_precision.png"), dpi=110)
    plt.close(fig)


def plot_family(report_dir, sweep, fam, style=None):
    methods = sorted({r["method"] for r in sweep if family_of(r["method"]) == fam})
    if not methods:
        return False
    fig, axes = plt.subplots(2, 2, figsize=(13, 10))
    handles = {}
    cmap = plt.get_cmap("tab10")
    for ax, case in zip(axes.flat, CASES):
        rows = ok(sweep, case)
        for i, m in enumerate(methods):
            pts = sorted((r["cpu_ms"], max(r["err_rot"], 1e-16)) for r in rows if r["method"] == m)
            if not pts:
                continue
            kw = style(m) if style else {"color": cmap(i % 10), "marker": "o", "markersize": 2, "linewidth": 1.3}
            (line,) = ax.loglog(*zip(*pts), label=title(m), **kw)
            handles[m] = line
        ax.set_title(CASE_TITLES[case], fontsize=10)
        ax.set_xlabel("CPU time per run [ms]")
        ax.set_ylabel("‖Λ − Λref‖ at the end")
        ax.grid(True, alpha=0.4)
    fig.legend([handles[m] for m in handles], [title(m) for m in handles], loc="lower center", ncol=4, fontsize=8,
               frameon=False)
    fig.suptitle(f"Work–precision: {FAMILY_TITLE[fam]}")
    fig.tight_layout(rect=(0, 0.07, 1, 0.97))
    fig.savefig(os.path.join(report_dir, f"work_precision_{fam}.png"), dpi=110)
    plt.close(fig)
    return True


def plot_invariants(report_dir, sweep):
    """max |ΔH/H| and max |Δμ/μ| against h for the new families (HT0, HT1, HT2)."""
    new = ("gen-alpha", "constrained", "energy-decaying", "lie-group")
    methods = sorted({r["method"] for r in sweep if family_of(r["method"]) in new})
    if not methods:
        return False
    fig, axes = plt.subplots(2, 3, figsize=(15, 9))
    cmap = plt.get_cmap("tab10")
    handles = {}
    for j, case in enumerate(("ht0", "ht1", "ht2")):
        rows = ok(sweep, case)
        for key, ax, label in (("max_dH", axes[0][j], "max |ΔH/H|"), ("max_dmu", axes[1][j], "max |Δμ/μ|")):
            for i, m in enumerate(methods):
                pts = sorted((r["h"], max(r[key], 1e-17)) for r in rows if r["method"] == m)
                if pts:
                    (line,) = ax.loglog(*zip(*pts), color=cmap(i % 10), marker="o", markersize=2, linewidth=1.3)
                    handles[m] = line
            ax.set_title(CASE_TITLES[case], fontsize=10)
            ax.set_xlabel("h")
            ax.set_ylabel(label + " over the run")
            ax.grid(True, alpha=0.4)
    fig.legend([handles[m] for m in handles], [title(m) for m in handles], loc="lower center", ncol=4, fontsize=8,
               frameon=False)
    fig.suptitle("What the families keep: energy and momentum-map errors vs step size")
    fig.tight_layout(rect=(0, 0.07, 1, 0.97))
    fig.savefig(os.path.join(report_dir, "invariants_families.png"), dpi=110)
    plt.close(fig)
    return True


def slope(rows, key):
    """Observed order: log-log slope of `key` against h over the finest two points where
    `key` is above round-off (1e-13)."""
    pts = sorted((r["h"], r[key]) for r in rows if r[key] > 1e-12)
    if len(pts) < 2:
        return None
    (h1, e1), (h2, e2) = pts[0], pts[1]
    return math.log(e2 / e1) / math.log(h2 / h1)


def nearest(rows, h):
    return min(rows, key=lambda r: abs(math.log(r["h"] / h))) if rows else None


def fmt(x, digits=2):
    if x is None:
        return "–"
    if x == 0:
        return "0"
    return f"{x:.{digits}g}" if abs(x) >= 1e-3 and abs(x) < 1e4 else f"{x:.{digits - 1}e}"


def family_table(sweep, steps, cases=("ht1", "ht0", "ht2", "fb1"), h_of={"ht1": 1e-3, "ht0": 1e-3, "ht2": 1e-4,
                                                                            "fb1": 1e-2}):
    L = ["| case | family | method | order (Λ) | ‖ΔΛ‖ at h | max ΔH/H at h | ΔH order | max Δμ/μ at h | Δμ order | "
         "ns / step | Newton / step |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for case in cases:
        methods = sorted({r["method"] for r in ok(sweep, case)}, key=lambda m: ([f for f, _, _ in FAMILIES].index(
            family_of(m)), m))
        for m in methods:
            fam = family_of(m)
            if fam in ("explicit", "other") or ("-o" in m and fam == "energy-momentum"):
                continue
            rows = [r for r in ok(sweep, case) if r["method"] == m and r["steps"] > 0]
            r = nearest(rows, h_of[case])
            if not r:
                continue
            s = steps.get((case, m))
            L.append(f"| {case.upper()} | {fam} | {title(m)} | {fmt(slope(rows, 'err_rot'), 3)} | {fmt(r['err_rot'])} "
                     f"(h = {r['h']:.2g}) | {fmt(r['max_dH'])} | {fmt(slope(rows, 'max_dH'), 2)} | {fmt(r['max_dmu'])} | "
                     f"{fmt(slope(rows, 'max_dmu'), 2)} | {fmt(s['ns'], 3) if s else '–'} | "
                     f"{fmt(r['newton'], 3)} |")
    return "\n".join(L)


def load_large(report_dir):
    with open(os.path.join(report_dir, "bench.json")) as f:
        data = json.load(f)
    out = {}
    for b in data["benchmarks"]:
        if not b["name"].startswith("large/") or b.get("error_occurred"):
            continue
        method = b["name"].split("/")[2]
        series = sorted((int(k[1:]) * 0.25, v) for k, v in b.items() if k.startswith("e") and k[1:].isdigit())
        out[method] = {"series": series, **{k: b.get(k) for k in ("max_dmu", "omega3_end", "max_omega_perp",
                                                                    "max_rise", "newton")}}
    return out


def plot_large(report_dir, large):
    if not large:
        return False
    fig, axes = plt.subplots(1, 2, figsize=(13, 5))
    cmap = plt.get_cmap("tab10")
    family_style = {"gen-alpha": "-", "constrained": "--", "energy-decaying": "-.", "energy-momentum": ":"}
    for i, m in enumerate(sorted(large, key=lambda m: ([f for f, _, _ in FAMILIES].index(family_of(m)), m))):
        ts, hs = zip(*large[m]["series"])
        kw = {"color": cmap(i % 10), "linewidth": 1.5, "linestyle": family_style.get(family_of(m), "-")}
        for ax in axes:
            ax.plot(ts, hs, label=title(m), marker="o", markersize=2, **kw)
    axes[0].set_ylabel("H / H0")
    axes[1].set_ylim(0.995, 1.001)
    axes[1].set_title("the same, near H0", fontsize=10)
    axes[0].set_title("HT0 at h = 0.05 (200 steps, Θ ≈ 2.5 rad per step): energy over 10 s", fontsize=10)
    for ax in axes:
        ax.set_xlabel("t")
        ax.grid(True, alpha=0.4)
    axes[0].legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    fig.savefig(os.path.join(report_dir, "large_step_ht0.png"), dpi=110)
    plt.close(fig)
    return True


def large_table(large):
    L = ["| method | H/H0 t = 1 | t = 5 | t = 10 | max Δμ/μ | Ω3(10) | max ‖Ω⊥‖ | max one-step ΔH/H0 | Newton / step |",
         "|---|---|---|---|---|---|---|---|---|"]
    for m in sorted(large, key=lambda m: ([f for f, _, _ in FAMILIES].index(family_of(m)), m)):
        d = large[m]
        at = dict(d["series"])
        L.append(f"| {title(m)} | {at.get(1.0, float('nan')):.5f} | {at.get(5.0, float('nan')):.5f} | "
                 f"{at.get(10.0, float('nan')):.5f} | {fmt(d['max_dmu'])} | {d['omega3_end']:.2f} | "
                 f"{d['max_omega_perp']:.2f} | {fmt(d['max_rise'])} | {fmt(d['newton'], 3)} |")
    return "\n".join(L)


def write(report_dir, sweep, steps):
    """Everything of this module; returns the markdown (also written to families.md)."""
    plot_envelopes(report_dir, sweep)
    for fam in ("gen-alpha", "constrained", "energy-decaying", "lie-group", "other"):
        plot_family(report_dir, sweep, fam)
    plot_invariants(report_dir, sweep)
    large = load_large(report_dir)
    plot_large(report_dir, large)
    md = ["# The families side by side (trompo-bench)\n",
          "Per case and method: the observed order of the end attitude (slope over the two finest h of the sweep), "
          "the errors at one h of the sweep, the slopes of the invariant errors in h (– where they stay at round-off), "
          "the cost of a step (step/ family, median of 3) and Newton iterations per step.\n",
          family_table(sweep, steps), "\n",
          "## Large step: HT0 at h = 0.05 for 10 s (large_step_ht0.png)\n", large_table(large), "\n"]
    text = "\n".join(md)
    with open(os.path.join(report_dir, "families.md"), "w") as f:
        f.write(text)
    return text


def main():
    report_dir = sys.argv[1] if len(sys.argv) > 1 else "report"
    _, sweep, steps = load(report_dir)
    print(write(report_dir, sweep, steps))


if __name__ == "__main__":
    main()
