"""What report.py and report_splitting.py share: reading a method's cost off its sweep.

A sweep row is a dict with at least "cpu_ms" (the CPU time of the run); `ratio(row)` is the
row's error over the bound it must reach (<= 1: reached).
"""
import math


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
