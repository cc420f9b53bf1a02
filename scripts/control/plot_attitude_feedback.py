#!/usr/bin/env python3
"""Plots the traces of examples/example_attitude_feedback_rw.cpp (docs/control.md).

    build/.../examples/example_attitude_feedback_rw traces.csv
    python3 scripts/control/plot_attitude_feedback.py traces.csv docs/img/control_attitude_feedback_rw.png
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(src, dst):
    with open(src) as f:
        rows = list(csv.DictReader(f))
    col = {k: [float(r[k]) for r in rows] for k in rows[0]}
    t = col["t"]
    fig, ax = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    panels = [
        (ax[0][0], "sigma", r"$\sigma_{BN}$ (MRP)"),
        (ax[0][1], "omega", r"$\Omega$ (rad/s)"),
        (ax[1][0], "wheel", r"wheel speed $\Omega_i$ (rad/s)"),
        (ax[1][1], "u", r"motor torque $u_i$ (N m), held"),
    ]
    for a, key, label in panels:
        for i in (1, 2, 3):
            a.plot(t, col[f"{key}{i}"], label=f"{i}")
        a.set_ylabel(label)
        a.grid(alpha=0.3)
        a.legend(loc="best", fontsize=8)
    for a in ax[1]:
        a.set_xlabel("t (s)")
    fig.suptitle("scenarioAttitudeFeedbackRW: MRP feedback at 10 Hz, three wheels (Simo-κ, order 4, h = 0.1 s)")
    fig.tight_layout()
    fig.savefig(dst, dpi=90)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
