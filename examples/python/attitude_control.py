#!/usr/bin/env python3
"""Basilisk's scenarioAttitudeFeedbackRW from Python, with the MRP PD law written in Python
(docs/python.md, "Control in the loop from Python"; the C++ version is
examples/example_attitude_feedback_rw.cpp).

A 900/800/600 kg m^2 spacecraft with three reaction wheels along its body axes (50 N m s at
6000 rpm, 0.2 N m motors, 100/200/300 rpm at t = 0) starts at sigma = (0.1, 0.2, -0.3),
omega = (0.001, -0.01, 0.03) rad/s; the law L = -K sigma - P omega (K = 3.5, P = 30) runs
at 10 Hz for 600 s, on the wheels; the commands are held in between (zero-order hold).
Plots sigma, omega, the wheel speeds and the motor torques to the PNG given:

    PYTHONPATH=build/python python3 examples/python/attitude_control.py attitude.png
"""
import argparse
import math

import numpy as np

import trompo

RPM = 2 * math.pi / 60


def rotation_of_mrp(s):
    """The rotation body -> space whose MRP (to the identity) is s, as C++ rotation_of_mrp."""
    s = np.asarray(s, dtype=float)
    s2 = s @ s
    S = np.array([[0, -s[2], s[1]], [s[2], 0, -s[0]], [-s[1], s[0], 0]])
    return (np.eye(3) + (8 * S @ S - 4 * (1 - s2) * S) / (1 + s2) ** 2).T


def mrp(R):
    """σ of a rotation matrix, as the C++ law computes it (trompo.mrp), as a NumPy vector."""
    return np.array(trompo.mrp(R))



def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("png", help="where to write the plot")
    p.add_argument("--t-end", type=float, default=600.0)
    a = p.parse_args()

    axes = np.eye(3)
    wheels = [trompo.Wheel(axes[i], 50 / (6000 * RPM), speed0=rpm * RPM, max_torque=0.2, max_speed=6000 * RPM)
              for i, rpm in enumerate((100, 200, 300))]
    sc = trompo.Spacecraft([900, 800, 600], wheels=wheels)
    s0 = trompo.initial_state(rotation=rotation_of_mrp((0.1, 0.2, -0.3)), omega=(0.001, -0.01, 0.03))
    K, P = 3.5, 30.0
    to_wheels = -axes.T @ np.linalg.inv(axes @ axes.T)  # minimum-norm: the body feels L

    def controller(t, R, W, wheel_speeds, memory):
        L = -K * mrp(R) - P * W
        memory["samples"] = memory.get("samples", 0) + 1
        return {"wheel_torques": to_wheels @ L}  # saturated to ±0.2 N m by trompo

    res = trompo.control(sc, s0, a.t_end, dt=0.1, period=0.1, controller=controller, order=4)
    sigma = np.array([mrp(R) for R in res.R])
    print(f"{len(res.t)} rows; |sigma| at {res.t[-1]:g} s: {np.linalg.norm(sigma[-1]):.3e}, "
          f"|omega|: {np.linalg.norm(res.W[-1]):.3e} rad/s; "
          f"|pi(t) - pi(0)| max: {np.max(np.linalg.norm(res.pi - res.pi[0], axis=1)):.2e} N m s")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(4, 1, sharex=True, figsize=(8, 10))
    for i in range(3):
        ax[0].plot(res.t, sigma[:, i], label=f"sigma{i + 1}")
        ax[1].plot(res.t, res.W[:, i], label=f"omega{i + 1}")
        ax[2].plot(res.t, res.wheel_speeds[:, i] / RPM, label=f"wheel {i + 1}")
        ax[3].plot(res.t, res.u[:, i], label=f"u{i + 1}")
    for axis, label in zip(ax, ("sigma_BR", "omega (rad/s)", "wheel speed (rpm)", "motor torque (N m)")):
        axis.set_ylabel(label)
        axis.legend(loc="right")
        axis.grid(True)
    ax[-1].set_xlabel("t (s)")
    ax[0].set_title("Basilisk scenarioAttitudeFeedbackRW: MRP PD in Python, trompo.control")
    fig.tight_layout()
    fig.savefig(a.png, dpi=80)
    print("wrote", a.png)


if __name__ == "__main__":
    main()
