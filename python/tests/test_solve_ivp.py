"""trompo.solve_ivp: SciPy's vocabulary over trompo-simulate's adaptive engine, bit for bit
the CLI's rows (--rtol/--atol/--t-eval/--event); H and mu exact; events; bad input."""
import numpy as np
import pytest

import trompo
from conftest import run_cli, same_rows


def test_bit_identical_to_the_cli(tmp_path):
    res = trompo.solve_ivp("ht0", (0, 1), rtol=1e-8, atol=1e-8, order=4, t_eval=[0.1, 0.25, 0.5, 1.0])
    code, cli, err = run_cli(["--case", "ht0", "--t-end", "1", "--order", "4", "--rtol", "1e-08", "--atol", "1e-08",
                              "--t-eval", "0.1,0.25,0.5,1.0"])
    assert code == 0 and "accepted" in err
    same_rows(res, cli)
    assert list(res.t) == [0.1, 0.25, 0.5, 1.0]
    assert res.y.shape == (12, 4)
    assert res.status == 0 and res.success and res.nsteps > 10 and res.nreject >= 0


def test_invariants_and_events():
    res = trompo.solve_ivp("ht0", (0, 5), rtol=1e-10, atol=1e-10, order=6,
                           events=["nutation-max", type("E", (), {"name": "nutation-min", "terminal": 3})()])
    assert res.status == 1
    assert len(res.t_events[1]) == 3 and res.t[-1] == res.t_events[1][-1]
    # HT0's tilt minima are a nutation period apart (t = 0 is one)
    T = res.t_events[1][0]
    assert np.allclose(res.t_events[1], T * np.arange(1, 4), atol=1e-9)
    assert len(res.t_events[0]) == 3 and res.y_events[0].shape == (3, 12)
    assert np.max(np.abs(res.H / res.H[0] - 1)) <= 1e-13
    assert np.max(np.abs(res.mu / res.mu[0] - 1)) <= 1e-13


def test_hold_third_integral_keeps_omega3_of_a_lagrange_top():
    # hold_third_integral=True is --hold-third-integral (docs/theory.md [A9]): HT0 over 100
    # nutation periods, Simo-κ order 6 compensated; Ω3 starts at 50. Measured: 1.4e-16 held,
    # 1.6e-14 not.
    drift = {}
    for on in (False, True):
        res = trompo.solve_ivp("ht0", (0, 118.6), rtol=1e-11, atol=1e-11, scheme="simo-kappa", order=6,
                               compensated=True, t_eval=[118.6], hold_third_integral=on)
        assert res.success
        drift[on] = abs(res.y[11, -1] / 50 - 1)
    assert drift[True] <= 1e-15
    assert drift[False] >= 4e-15


def test_tolerance_scope_and_estimate():
    # over the span (default) the end error is ~tol; per unit time ("time") ~tol*T: fewer steps
    span = trompo.solve_ivp("ht0", (0, 4), rtol=1e-8, atol=1e-8, order=4)
    per_time = trompo.solve_ivp("ht0", (0, 4), rtol=1e-8, atol=1e-8, order=4, tol_scope="time")
    doubling = trompo.solve_ivp("ht0", (0, 4), rtol=1e-8, atol=1e-8, order=4, estimate="doubling")
    assert span.success and per_time.success and doubling.success
    assert per_time.nsteps < span.nsteps
    assert np.max(np.abs(doubling.H / doubling.H[0] - 1)) <= 1e-13
    with pytest.raises(ValueError, match="^tol_scope: must be span or time"):
        trompo.solve_ivp("ht0", (0, 1), rtol=1e-6, tol_scope="orbit")
    with pytest.raises(ValueError, match="estimate"):
        trompo.solve_ivp("ht0", (0, 1), rtol=1e-6, estimate="guess")


def test_richardson_for_the_splitting():
    # automatic: Richardson's estimate, m = 8 steps per attempt at order 6 (nsteps a multiple
    # of 8); substeps=2 is accepted as a flag; the rows are the CLI's
    res = trompo.solve_ivp("ht1", (0, 2), rtol=1e-10, atol=1e-10, scheme="splitting", order=6)
    two = trompo.solve_ivp("ht1", (0, 2), rtol=1e-10, atol=1e-10, scheme="splitting", order=6, substeps=2)
    defect = trompo.solve_ivp("ht1", (0, 2), rtol=1e-10, atol=1e-10, scheme="splitting", order=6, estimate="defect")
    assert res.success and two.success and defect.success
    assert res.nsteps % 8 == 0 and two.nsteps % 2 == 0
    assert 2 * res.nsteps <= defect.nsteps  # the defect overestimates the splitting's error
    code, cli, err = run_cli(["--case", "ht1", "--t-end", "2", "--scheme", "splitting", "--order", "6",
                              "--rtol", "1e-10", "--atol", "1e-10", "--substeps", "2"])
    assert code == 0
    same_rows(two, cli)
    with pytest.raises(ValueError, match="substeps"):
        trompo.solve_ivp("ht1", (0, 1), rtol=1e-6, scheme="splitting", substeps=1)


def test_bad_input():
    with pytest.raises(ValueError, match="rtol"):
        trompo.solve_ivp("ht1", (0, 1), rtol=0)
    with pytest.raises(ValueError, match="^t_eval: "):
        trompo.solve_ivp("ht1", (0, 1), rtol=1e-6, t_eval=[0.5, 0.2])
    with pytest.raises(ValueError, match="t_span"):
        trompo.solve_ivp("ht1", (1, float("inf")))
    with pytest.raises(ValueError, match="span"):
        trompo.solve_ivp("ht1", (1, 1.5), rtol=1e-6, dense_output=True).sol(1.6)
    with pytest.raises(ValueError, match="direction"):
        bad = lambda t, y: y[0]  # noqa: E731
        bad.direction = 2
        trompo.solve_ivp("ht1", (0, 1), events=[bad])
    with pytest.raises(TypeError, match="events"):
        trompo.solve_ivp("ht1", (0, 1), events=[42])


# issue 37's top: a Lagrange top J = (4, 4, 1.3), Mgl = 25, |Omega| about 9
LAGRANGE = dict(inertia=[4, 4, 1.3], mgl=25, rotation=[0.4, 0, 0], omega=[0.3, 0.2, 9])


def test_defaults_pick_the_method_and_the_first_step():
    # no scheme, order or first_step: the engine's pick (docs/adaptive.md), named in .method,
    # the end error within 10x the tolerance; the CLI's rows bit for bit
    res = trompo.solve_ivp(None, (0, 20), rtol=1e-8, atol=1e-8, **LAGRANGE)
    exact = trompo.simulate(scheme="exact", dt=20, t_end=20, **LAGRANGE)
    assert res.success and res.method.startswith("splitting chin-triple-jump (order 6), picked")
    assert np.linalg.norm(res.R[-1] - exact["R"][-1]) <= 10 * 1e-8
    code, cli, err = run_cli(["--inertia", "4,4,1.3", "--mgl", "25", "--rotation", "0.4,0,0", "--omega", "0.3,0.2,9",
                              "--t-end", "20", "--rtol", "1e-08", "--atol", "1e-08"])
    assert code == 0 and "adaptive (reversible, rtol 1e-08, atol 1e-08)" in err
    same_rows(res, cli)
    # given a scheme and an order, the method is the one asked for
    asked = trompo.solve_ivp(None, (0, 1), rtol=1e-6, scheme="simo-kappa", order=6, **LAGRANGE)
    assert asked.method == "simo-kappa kahan-li-9 (order 6)"


def test_rtol_below_the_round_off_floor_is_raised_with_a_warning():
    with pytest.warns(UserWarning, match=r"^rtol 1e-16 is below the round-off floor 100\*eps = 2.22e-14"):
        res = trompo.solve_ivp(None, (0, 1), rtol=1e-16, atol=1e-16, **LAGRANGE)
    assert res.success


def test_flip_on_a_symmetric_body_is_refused():
    with pytest.raises(ValueError, match=r"^events flip: the body's principal moments 1.3, 4, 4 have two equal"):
        trompo.solve_ivp(None, (0, 1), rtol=1e-6, events=["flip"], **LAGRANGE)


def test_python_callable_events():
    # FB1 (J = 1, 2, 3): the body momentum along the intermediate axis, 2 Ω_y, changes sign at
    # each flip: a Python g(t, y) finds the built-in "flip" events.
    def flip(t, y):
        return 2.0 * y[10]

    res = trompo.solve_ivp("fb1", (0, 60), rtol=1e-10, atol=1e-10, order=4, events=["flip", flip])
    assert res.status == 0 and len(res.t_events[0]) >= 2
    assert res.t_events[1].shape == res.t_events[0].shape
    assert np.allclose(res.t_events[1], res.t_events[0], rtol=0, atol=1e-12)
    assert res.y_events[1].shape == (len(res.t_events[1]), 12)
    assert np.allclose(res.y_events[1][:, 10], 0, atol=1e-12)  # g = 0 at the event states
    # direction (SciPy's): +1 keeps the rising zeros only; terminal: the first ends the run
    rising = lambda t, y: 2.0 * y[10]  # noqa: E731
    rising.direction = 1
    rising.terminal = True
    one = trompo.solve_ivp("fb1", (0, 60), rtol=1e-10, atol=1e-10, order=4, events=[rising])
    # the first zero with g < 0 at the step end before it
    first_rising = next(t for t in res.t_events[1] if flip(0, res.y[:, np.searchsorted(res.t, t) - 1]) < 0)
    assert one.status == 1 and one.success and len(one.t_events[0]) == 1
    assert abs(one.t_events[0][0] - first_rising) <= 1e-12 and one.t[-1] == one.t_events[0][0]
    # H and π exact through the terminal step (Simo-κ, the default scheme)
    assert np.max(np.abs(one.H / one.H[0] - 1)) <= 1e-13
    # the time given to g is the user's: t_span from 5, a zero of t - 5.3 found at 5.3
    at = lambda t, y: t - 5.3  # noqa: E731
    shifted = trompo.solve_ivp("ht1", (5, 6), rtol=1e-8, atol=1e-8, events=[at])
    assert len(shifted.t_events[0]) == 1 and abs(shifted.t_events[0][0] - 5.3) <= 1e-12
    # an exception raised in g ends the run and is raised again
    def broken(t, y):
        raise ZeroDivisionError("no")
    with pytest.raises(RuntimeError, match="ZeroDivisionError"):
        trompo.solve_ivp("ht1", (0, 1), rtol=1e-6, events=[broken])


def test_ensemble_progress_same_bits():
    rng = np.random.default_rng(1)
    rotation = rng.normal(size=(25, 3)) * 0.2
    omega = rng.normal(size=(25, 3)) + np.array([0, 0, 20])
    seen = []
    a = trompo.ensemble(rotation, omega, case="ht1", t_end=0.2, threads=2)
    b = trompo.ensemble(rotation, omega, case="ht1", t_end=0.2, threads=2, progress=lambda k, n: seen.append((k, n)))
    # one call a chunk (25 members on 2 threads: chunks of 1), done increasing to N
    assert seen[-1] == (25, 25) and len(seen) == 25 and [k for k, _ in seen] == sorted(k for k, _ in seen)
    for key in a:
        assert np.array_equal(np.asarray(a[key]), np.asarray(b[key])), key


def test_dense_output_is_the_runs_interpolant():
    # sol(t) is the Lie-Hermite dense output of the same run: at the step ends the step ends
    # themselves, bit for bit; between them the CLI's --t-eval rows, bit for bit; and within
    # the tolerance of a converged run.
    res = trompo.solve_ivp("ht0", (0, 1), rtol=1e-8, atol=1e-8, order=4, dense_output=True)
    assert res.t.size > 20
    assert np.array_equal(res.sol(res.t), res.y)
    assert np.array_equal(res.sol(res.t[5]), res.y[:, 5])
    mid = 0.5 * (res.t[1:] + res.t[:-1])
    between = res.sol(mid)
    assert between.shape == (12, mid.size)
    code, cli, err = run_cli(["--case", "ht0", "--t-end", "1", "--order", "4", "--rtol", "1e-08", "--atol", "1e-08",
                              "--t-eval", ",".join(repr(float(t)) for t in mid)])
    assert code == 0
    assert np.array_equal(between, np.concatenate([cli["R"].reshape(-1, 9), cli["W"]], axis=1).T)
    ref = trompo.solve_ivp("ht0", (0, 1), rtol=1e-12, atol=1e-12, order=6, t_eval=mid)
    err_rot = np.max(np.linalg.norm(between[:9] - ref.y[:9], axis=0))
    print(f"sol between steps, HT0 rtol 1e-8: max |dLambda|_F = {err_rot:.2e} over {mid.size} midpoints")
    assert err_rot < 1e-7
    assert res.sol([]).shape == (12, 0)


def test_t_span_not_starting_at_zero():
    # The engine's scenes are autonomous: the run over [t0, t1] is the run over [0, t1 - t0]
    # shifted, with the times the caller gave.
    a = trompo.solve_ivp("ht1", (0, 1), rtol=1e-8, atol=1e-8, order=4, t_eval=[0.125, 0.25, 1.0],
                         events=["nutation-max"], dense_output=True)
    b = trompo.solve_ivp("ht1", (2, 3), rtol=1e-8, atol=1e-8, order=4, t_eval=[2.125, 2.25, 3.0],
                         events=["nutation-max"], dense_output=True)
    assert list(b.t) == [2.125, 2.25, 3.0]
    assert np.array_equal(a.y, b.y)
    assert len(a.t_events[0]) >= 1 and np.allclose(b.t_events[0], a.t_events[0] + 2, rtol=0, atol=1e-14)
    assert np.array_equal(b.sol(2.3), a.sol(2.3 - 2))  # the run over [0, 1] at the shifted time
    c = trompo.solve_ivp("ht1", (2, 2.5), rtol=1e-8, atol=1e-8, order=4)
    assert c.t[0] == 2 and c.t[-1] == 2.5 and np.all(np.diff(c.t) > 0)
