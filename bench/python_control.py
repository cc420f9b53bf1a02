#!/usr/bin/env python3
"""What a Python controller costs in trompo.control, and trompo against SciPy restarted at
every sample (docs/python.md, "Control in the loop from Python").

(a) The binding's cost per sample: Basilisk's scenarioAttitudeFeedbackRW with one step per
    sample (period = dt = 0.1 s, t_end = 6000 s: 60 000 samples), a Python controller that
    returns a constant command (zero motor torques) against the built-in MrpPd(K=0, P=0),
    which commands the same zero torques in C++: the same trajectory, the same steps, so
    the difference of the CPU times divided by the samples is what one Python call costs
    (arrays in, the GIL taken, the dict read back). The numpy MRP-PD law's own cost is
    measured the same way (its run against the built-in MrpPd(3.5, 30)).
(b) The scenario over 600 s with a Python MRP-PD law (numpy) in trompo.control (Simo-kappa
    composed to order 4, one step a sample) against scipy.integrate.solve_ivp(DOP853,
    rtol=1e-9, atol=1e-12) restarted at every sample with the same law (the zero-order hold
    as SciPy users write it: one solve_ivp per hold). CPU time (time.process_time), minimum
    of --repeat runs; each one's attitude error at 600 s and the largest at the samples
    against a converged trompo run (built-in MrpPd, order 6, 20 steps a sample).

    PYTHONPATH=build/python python3 bench/python_control.py --repeat 3
"""
import argparse
import math
import time

import numpy as np

import trompo

RPM = 2 * math.pi / 60
JS = 50 / (6000 * RPM)
J = np.diag([900.0, 800.0, 600.0])
AXES = np.eye(3)  # wheel spin axes as columns
UMAX = 0.2
K, P, T = 3.5, 30.0, 0.1


def rotation_of_mrp(s):
    s = np.asarray(s, dtype=float)
    s2 = s @ s
    S = np.array([[0, -s[2], s[1]], [s[2], 0, -s[0]], [-s[1], s[0], 0]])
    return (np.eye(3) + (8 * S @ S - 4 * (1 - s2) * S) / (1 + s2) ** 2).T


def scenario():
    wheels = [trompo.Wheel(AXES[:, i], JS, speed0=rpm * RPM, max_torque=UMAX, max_speed=6000 * RPM)
              for i, rpm in enumerate((100, 200, 300))]
    sc = trompo.Spacecraft(J, wheels=wheels)
    s0 = trompo.initial_state(rotation=rotation_of_mrp((0.1, 0.2, -0.3)), omega=(0.001, -0.01, 0.03))
    return sc, s0


def mrp(R):
    """σ of a rotation matrix, as the C++ law computes it (trompo.mrp), as a NumPy vector."""
    return np.array(trompo.mrp(R))



MINUS_GINV = -AXES.T @ np.linalg.inv(AXES @ AXES.T)  # u = −G_sᵀ(G_sG_sᵀ)⁻¹ L


def law(R, W):
    return MINUS_GINV @ (-K * mrp(R) - P * W)


def python_mrp_pd(t, R, W, wheel_speeds, memory):
    return {"wheel_torques": law(R, W)}


ZERO = {"wheel_torques": np.zeros(3)}


def constant(t, R, W, wheel_speeds, memory):
    return ZERO


def cpu(f):
    c0 = time.process_time()
    out = f()
    return time.process_time() - c0, out


def attitude_error(Ra, Rb):
    """The angle of Raᵀ Rb (rad), accurate for small angles."""
    D = Ra.T @ Rb
    return math.asin(min(1.0, np.linalg.norm([D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1]]) / 2))


def scipy_run(s0, sc, t_end):
    """solve_ivp(DOP853) restarted at every sample: y = (Λ row-major, Ω, wheel speeds)."""
    from scipy.integrate import solve_ivp
    G = AXES
    Jhub = J - JS * G @ G.T
    Jhub_inv = np.linalg.inv(Jhub)

    def rhs(t, y, u):
        L = y[:9].reshape(3, 3)
        w = y[9:12]
        ws = y[12:]
        H = J @ w + JS * G @ ws
        wdot = Jhub_inv @ (-np.cross(w, H) - G @ u)
        wsdot = u / JS - G.T @ wdot
        What = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        return np.concatenate([(L @ What).ravel(), wdot, wsdot])

    y = np.concatenate([s0.R.ravel(), s0.omega, [w.speed0 for w in sc.wheels]])
    n = int(round(t_end / T))
    nfev = 0
    samples = [y[:9].reshape(3, 3)]
    for k in range(n):
        u = np.clip(law(y[:9].reshape(3, 3), y[9:12]), -UMAX, UMAX)  # trompo saturates the same way
        sol = solve_ivp(rhs, (k * T, (k + 1) * T), y, method="DOP853", rtol=1e-9, atol=1e-12, args=(u,))
        y = sol.y[:, -1]
        nfev += sol.nfev
        samples.append(y[:9].reshape(3, 3))
    return np.array(samples), nfev


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--samples", type=int, default=60000, help="samples of part (a)")
    a = p.parse_args()
    sc, s0 = scenario()

    # (a) the binding's cost per sample
    t_end = a.samples * T
    run = dict(dt=T, period=T, every=10**9)
    times = {"builtin MrpPd(0, 0)": [], "Python constant": [], "builtin MrpPd(3.5, 30)": [], "Python MRP-PD": []}
    for _ in range(a.repeat):
        times["builtin MrpPd(0, 0)"].append(cpu(lambda: trompo.control(sc, s0, t_end, controller=trompo.MrpPd(0, 0), **run))[0])
        times["Python constant"].append(cpu(lambda: trompo.control(sc, s0, t_end, controller=constant, **run))[0])
        times["builtin MrpPd(3.5, 30)"].append(cpu(lambda: trompo.control(sc, s0, t_end, controller=trompo.MrpPd(K, P), **run))[0])
        times["Python MRP-PD"].append(cpu(lambda: trompo.control(sc, s0, t_end, controller=python_mrp_pd, **run))[0])
    best = {k: min(v) for k, v in times.items()}
    print(f"(a) {a.samples} samples, one Simo-kappa step each, CPU time, min of {a.repeat}:")
    for k, v in best.items():
        print(f"  {k:24s} {v:.3f} s  ({v / a.samples * 1e6:.2f} us/sample)")
    print(f"  binding per sample (Python constant - builtin MrpPd(0,0)): "
          f"{(best['Python constant'] - best['builtin MrpPd(0, 0)']) / a.samples * 1e6:.2f} us")
    print(f"  numpy MRP-PD law per sample (Python MRP-PD - builtin MrpPd(3.5,30)): "
          f"{(best['Python MRP-PD'] - best['builtin MrpPd(3.5, 30)']) / a.samples * 1e6:.2f} us")

    # (b) 600 s: trompo with the Python law against SciPy restarted at every sample
    ref = trompo.control(sc, s0, 600.0, dt=T / 20, period=T, controller=trompo.MrpPd(K, P), order=6, every=20)
    tr, sp = [], []
    for _ in range(a.repeat):
        tr.append(cpu(lambda: trompo.control(sc, s0, 600.0, dt=T, period=T, controller=python_mrp_pd, order=4)))
        sp.append(cpu(lambda: scipy_run(s0, sc, 600.0)))
    t_trompo, res = min(tr, key=lambda x: x[0])
    t_scipy, (R_scipy, nfev) = min(sp, key=lambda x: x[0])
    assert len(ref.t) == len(res.t) == len(R_scipy) == 6001
    # at 600 s (the loop has forgotten most of the error by then) and the largest at the samples
    e_trompo = attitude_error(res.R[-1], ref.R[-1])
    e_scipy = attitude_error(R_scipy[-1], ref.R[-1])
    m_trompo = max(attitude_error(a_, b_) for a_, b_ in zip(res.R, ref.R))
    m_scipy = max(attitude_error(a_, b_) for a_, b_ in zip(R_scipy, ref.R))
    print(f"(b) Basilisk scenario, 600 s, 6000 samples, Python MRP-PD law, CPU time, min of {a.repeat}:")
    print(f"  trompo.control (simo-kappa order 4, dt = T)        {t_trompo:.3f} s, attitude error at 600 s "
          f"{e_trompo:.2e} rad, max over the samples {m_trompo:.2e} rad")
    print(f"  solve_ivp DOP853 rtol 1e-9 atol 1e-12, per sample  {t_scipy:.3f} s, attitude error at 600 s "
          f"{e_scipy:.2e} rad, max over the samples {m_scipy:.2e} rad ({nfev} f evaluations)")
    print(f"  SciPy / trompo CPU time: {t_scipy / t_trompo:.1f}")
    print(f"  |Omega| at 600 s: {np.linalg.norm(res.W[-1]):.2e} rad/s")


if __name__ == "__main__":
    main()
