#!/usr/bin/env python3
"""What the scene objects cost (issue 34's targets), CPU by time.process_time, the minimum of
--repeat runs, interleaved:

1. A scene built from objects and run for 10^6 steps against the CLI with the same flags
   (the target: within 1.05x). The scene is a heavy top with damping (HT1's body, Mgl = 20,
   C = 0.1), Simo-kappa at h = 1e-5 to t = 10, a row every 10^4 steps; the CLI's CPU is its
   child process's (os.times), which includes writing its CSV rows and its process start.
2. A Python torque law per step (the slow path): a constant body torque as a TorqueLaw with
   its Jacobians by differences and given, against the built-in BodyTorque, per step and in
   calls of the law per step, for Simo-kappa and RK4 (2,000 steps of h = 1e-3).

    PYTHONPATH=build/python TROMPO_SIMULATE=build/tools/trompo-simulate python3 bench/python_scene.py
"""
import argparse
import os
import subprocess
import time

import numpy as np

import trompo


def cpu(f):
    t = time.process_time()
    f()
    return time.process_time() - t


def child_cpu(args):
    before = os.times()
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
    after = os.times()
    return (after.children_user - before.children_user) + (after.children_system - before.children_system)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--cli", default=os.environ.get("TROMPO_SIMULATE", "build/tools/trompo-simulate"))
    a = ap.parse_args()

    # ---- 1. objects against the CLI, 10^6 steps ----
    scene = trompo.Scene(trompo.RigidBody([1.0, 1.0, 0.4]), trompo.Gravity(20.0), trompo.Damping(0.1))
    state = trompo.initial_state(rotvec=[0.05, 0, 0], omega=[0.0, 0.0, 20.0])
    flags = ["--inertia", "1,1,0.4", "--mgl", "20", "--damping", "0.1", "--rotation", "0.05,0,0", "--omega", "0,0,20",
             "--dt", "1e-5", "--t-end", "10", "--every", "10000", "--scheme", "simo-kappa"]
    objects, cli = [], []
    for _ in range(a.repeat):
        objects.append(cpu(lambda: trompo.simulate(scene, state=state, dt=1e-5, t_end=10, every=10000)))
        cli.append(child_cpu([a.cli, *flags]))
    print(f"10^6 Simo-kappa steps, heavy top with damping: objects {min(objects):.3f} s CPU, CLI {min(cli):.3f} s CPU, "
          f"ratio {min(objects) / min(cli):.3f} (min of {a.repeat})")

    # ---- 2. a torque law per step ----
    body = trompo.RigidBody([2.0, 3.0, 4.0])
    state = trompo.initial_state(rotvec=[0.3, -0.2, 0.1], omega=[1.0, -2.0, 3.0])
    tau = np.array([0.3, -0.1, 0.2])
    calls = [0]

    def law(t, R, W):
        calls[0] += 1
        return tau

    def jacobian(t, R, W):
        return np.zeros((3, 3)), np.zeros((3, 3))

    variants = {"BodyTorque (built in)": trompo.Scene(body, trompo.BodyTorque(tau)),
                "TorqueLaw, differences": trompo.Scene(body, trompo.TorqueLaw(law)),
                "TorqueLaw, jacobian given": trompo.Scene(body, trompo.TorqueLaw(law, jacobian=jacobian))}
    steps = 2000
    for scheme in ("simo-kappa", "rk4"):
        best = {}
        per_step_calls = {}
        for _ in range(a.repeat):
            for name, sc in variants.items():
                calls[0] = 0
                t = cpu(lambda: trompo.simulate(sc, state=state, scheme=scheme, dt=1e-3, t_end=steps * 1e-3,
                                                every=steps))
                best[name] = min(best.get(name, np.inf), t)
                per_step_calls[name] = calls[0] / steps
        base = best["BodyTorque (built in)"]
        for name, t in best.items():
            print(f"{scheme:10s} {name:26s} {1e6 * t / steps:8.2f} us/step ({t / base:6.1f}x built in), "
                  f"{per_step_calls[name]:.1f} calls of the law per step")


if __name__ == "__main__":
    main()
