#!/usr/bin/env python3
"""trompo.solve_ivp with its defaults against SciPy's DOP853 (issue 37's target: >= 100x less
CPU at the same rtol, the end error within 10x the tolerance).

The top of the issue: a Lagrange top J = (4, 4, 1.3), Mgl = 25, Λ0 = exp((0.4, 0, 0)^),
Ω0 = (0.3, 0.2, 9) rad/s (|Ω| ≈ 9), t = 20, rtol = atol = 1e-8 (--tol to change). trompo gets
no scheme, order or first step: the method the engine picks for the scene and tolerance
(docs/adaptive.md, "The method an adaptive run picks"). DOP853 integrates (Λ row-major, Ω)
in R^12. Both end errors are ‖Λ − Λexact‖_F at t = 20 against the closed form (--scheme
exact). CPU time by time.process_time, the minimum of --repeat runs of each, interleaved.

    PYTHONPATH=build/python python3 bench/python_solve_ivp_dop853.py
"""
import argparse
import time

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import trompo

J = np.array([4.0, 4.0, 1.3])
MGL, T = 25.0, 20.0
ROTATION, OMEGA = np.array([0.4, 0.0, 0.0]), np.array([0.3, 0.2, 9.0])


def rates(t, y):
    """(Λ̇, Ω̇) of the heavy top, centre of mass on body axis 3, up = e3."""
    R, W = y[:9].reshape(3, 3), y[9:]
    g = R[2]  # Λᵀ e3 (the third row of Λ)
    torque = MGL * np.array([g[1], -g[0], 0.0])  # (Λᵀ e3) × e3
    W_hat = np.array([[0, -W[2], W[1]], [W[2], 0, -W[0]], [-W[1], W[0], 0]])
    return np.concatenate([(R @ W_hat).ravel(), (np.cross(J * W, W) + torque) / J])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--repeat", type=int, default=20)
    args = ap.parse_args()
    exact = trompo.simulate(inertia=J, mgl=MGL, rotation=ROTATION, omega=OMEGA, scheme="exact", dt=T, t_end=T)["R"][-1]
    y0 = np.concatenate([Rotation.from_rotvec(ROTATION).as_matrix().ravel(), OMEGA])
    ours, theirs = [], []
    for _ in range(args.repeat):
        c0 = time.process_time()
        res = trompo.solve_ivp(None, (0, T), rtol=args.tol, atol=args.tol, inertia=J, mgl=MGL, rotation=ROTATION,
                               omega=OMEGA)
        ours.append(time.process_time() - c0)
        c0 = time.process_time()
        ref = solve_ivp(rates, (0, T), y0, method="DOP853", rtol=args.tol, atol=args.tol)
        theirs.append(time.process_time() - c0)
    err = np.linalg.norm(res.R[-1] - exact)
    err_ref = np.linalg.norm(ref.y[:9, -1].reshape(3, 3) - exact)
    print(f"trompo.solve_ivp: {min(ours) * 1e3:.3f} ms CPU, {res.nsteps} steps, end error {err:.3g} "
          f"({err / args.tol:.3g}x tol); method {res.method}")
    print(f"SciPy DOP853:     {min(theirs) * 1e3:.3f} ms CPU, {ref.nfev} evaluations, end error {err_ref:.3g} "
          f"({err_ref / args.tol:.3g}x tol)")
    print(f"CPU ratio DOP853 / trompo: {min(theirs) / min(ours):.0f}x")


if __name__ == "__main__":
    main()
