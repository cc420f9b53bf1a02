"""What every part of the report shares: reading trompo-bench's JSON into rows, the
predicates and look-ups on them, number formatting, and a method's cost at a bound.

A sweep row (load()) is a dict with "case", "method", "scheme", "order", "stages", "h",
"tol", "error" and, when the run did not fail, "cpu_ms", "steps", "max_dH", "max_dmu",
"err_rot", "err_omega", "newton", "rhs". A step entry is keyed (case, method) with the
median "ns" of its repetitions, "ns_min", "ns_max", "newton_mean" and "substeps".
"""
import json
import math
import os

CASES = ("ht0", "ht1", "ht2", "fb1")
EXACT_SCHEMES = ("simo-kappa", "simo-collocation", "geradin-bauchau")


def split_method(m):
    """'simo-kappa-o4s' -> ('simo-kappa', 'o4s'); variants: o4 (triple jump), o4s (Suzuki's
    five steps), o6 (Kahan-Li), p6 (processed, Blanes-Casas-Murua); '' for the base scheme
    and the baselines."""
    for v in ("o4s", "o4", "o6", "p6"):
        if m.endswith("-" + v):
            return m[: -len(v) - 1], v
    return m, ""


def parse_label(label):
    out = {}
    for part in label.split(";"):
        if "=" in part:
            k, v = part.split("=", 1)
            out[k] = v
    return out


def load(report_dir):
    with open(os.path.join(report_dir, "bench.json")) as f:
        data = json.load(f)
    sweep, steps, pairs = [], {}, {}
    for b in data["benchmarks"]:
        name = b["name"]
        lab = parse_label(b.get("label", ""))
        if name.startswith("sweep/"):
            if b.get("run_type") == "aggregate":
                continue
            row = {
                "case": lab.get("case", name.split("/")[1]),
                "method": lab.get("method", name.split("/")[2]),
                "scheme": lab.get("scheme", ""),
                "order": int(lab.get("order", "0") or 0),
                "stages": int(lab.get("stages", "1") or 1),
                "h": float(lab.get("h", "nan")),
                "tol": float(lab.get("tol", "0")),
                "error": b.get("error_message", "") if b.get("error_occurred") else "",
            }
            if not row["error"]:
                unit = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}[b.get("time_unit", "ms")]
                row.update(
                    cpu_ms=b["cpu_time"] * unit,
                    steps=b["steps"],
                    max_dH=b["max_dH"],
                    max_dmu=b["max_dmu"],
                    err_rot=b["err_rot"],
                    err_omega=b["err_omega"],
                    newton=b["newton"],
                    rhs=b["rhs"],
                )
            sweep.append(row)
        elif name.startswith("step/"):
            # Repetitions: keep the individual runs, take the median ourselves.
            if b.get("run_type") == "aggregate":
                continue
            unit = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}[b.get("time_unit", "ns")]
            key = (lab.get("case"), lab.get("method"))
            steps.setdefault(key, {"case": lab.get("case"), "method": lab.get("method"),
                                   "scheme": lab.get("scheme"), "order": int(lab.get("order", "0")),
                                   "h": float(lab.get("h", "nan")), "cpu": [], "newton": [],
                                   "substeps": b.get("substeps", 1)})
            steps[key]["cpu"].append(b["cpu_time"] * unit)
            steps[key]["newton"].append(b.get("newton", 0.0))
        elif name.startswith("step-pair/"):
            # A method's (sub-)step against a baseline's step, timed in alternation
            # (bench_common.hpp, register_timed_pair).
            if b.get("run_type") == "aggregate" or b.get("error_occurred"):
                continue
            pairs.setdefault(((lab.get("case"), lab.get("method")), lab.get("baseline")), []).append(b)
    for s in steps.values():
        c = sorted(s["cpu"])
        s["ns"] = _median(c)
        s["ns_min"], s["ns_max"] = c[0], c[-1]
        s["newton_mean"] = sum(s["newton"]) / len(s["newton"])
    # the pairs go with the method's step row: steps[key]["pairs"][baseline], medians over the
    # repetitions of each repetition's own median ratio
    for (key, baseline), reps in pairs.items():
        if key in steps:
            ratios = sorted(r["ratio"] for r in reps)
            steps[key].setdefault("pairs", {})[baseline] = {
                "ratio": _median(ratios), "ratio_min": ratios[0], "ratio_max": ratios[-1],
                "baseline_ns": _median(sorted(r["baseline_ns"] for r in reps)),
                "method_ns": _median(sorted(r["method_ns"] for r in reps)),
                "repetitions": len(reps),
            }
    return data.get("context", {}), sweep, steps


def pair(steps, case, method, baseline):
    """The alternation-timed pair of `method` against `baseline` on `case`, or None."""
    s = steps.get((case, method))
    return s.get("pairs", {}).get(baseline) if s else None


def _median(c):
    """The median of a sorted, non-empty list."""
    return c[len(c) // 2] if len(c) % 2 else 0.5 * (c[len(c) // 2 - 1] + c[len(c) // 2])


def fmt(x, digits=2):
    if x is None or (isinstance(x, float) and (math.isnan(x) or math.isinf(x))):
        return "—"
    if x == 0:
        return "0"
    return f"{x:.{digits}e}" if (abs(x) < 1e-2 or abs(x) >= 1e4) else f"{x:.{digits + 1}g}"


def ok_rows(sweep, case=None):
    return [r for r in sweep if not r["error"] and (case is None or r["case"] == case)]


def cheapest(rows, pred):
    good = [r for r in rows if pred(r)]
    return min(good, key=lambda r: r["cpu_ms"]) if good else None


def is_trompo_exact(r):
    return r["scheme"] in EXACT_SCHEMES


def is_rk4(r):
    return r["method"] in ("rk4", "odeint-rk4")


def is_dopri(r):
    return r["method"] == "odeint-dopri5"


def crossing_cost(rows, ratio):
    """CPU time at which one method's line first reaches ratio(r) <= 1, interpolated
    log-log between the two grid points around the crossing (the grid is coarse: √2 in h,
    half a decade in tolerance), or None."""
    rows = sorted(rows, key=lambda r: r["cpu_ms"])
    for j, r in enumerate(rows):
        if ratio(r) <= 1:
            if j == 0:
                return r["cpu_ms"]
            a, b = rows[j - 1], r
            fa, fb = math.log(max(ratio(a), 1e-300)), math.log(max(ratio(b), 1e-300))
            if fa <= fb:
                return b["cpu_ms"]
            w = fa / (fa - fb)
            return math.exp(math.log(a["cpu_ms"]) + w * (math.log(b["cpu_ms"]) - math.log(a["cpu_ms"])))
    return None


def family_crossing(rows, pred, ratio):
    """The cheapest crossing of the bound (ratio(r) <= 1) over the methods whose rows match
    pred: (CPU ms, method), or None."""
    by = {}
    for r in rows:
        if pred(r):
            by.setdefault(r["method"], []).append(r)
    best = None
    for m, rs in by.items():
        c = crossing_cost(rs, ratio)
        if c is not None and (best is None or c < best[0]):
            best = (c, m)
    return best


def read_machine(report_dir):
    out = {}
    path = os.path.join(report_dir, "machine.txt")
    if os.path.exists(path):
        with open(path) as f:
            for line in f:
                if ":" in line:
                    k, v = line.split(":", 1)
                    out[k.strip()] = v.strip()
    return out
