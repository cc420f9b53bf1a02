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


def test_bad_input():
    with pytest.raises(ValueError, match="rtol"):
        trompo.solve_ivp("ht1", (0, 1), rtol=0)
    with pytest.raises(ValueError, match="t-eval"):
        trompo.solve_ivp("ht1", (0, 1), rtol=1e-6, t_eval=[0.5, 0.2])
    with pytest.raises(ValueError, match="t_span"):
        trompo.solve_ivp("ht1", (1, 2))
    with pytest.raises(NotImplementedError):
        trompo.solve_ivp("ht1", (0, 1), events=[lambda t, y: y[0]])


def test_ensemble_progress_same_bits():
    rng = np.random.default_rng(1)
    rotation = rng.normal(size=(25, 3)) * 0.2
    omega = rng.normal(size=(25, 3)) + np.array([0, 0, 20])
    seen = []
    a = trompo.ensemble(rotation, omega, case="ht1", t_end=0.2, threads=2)
    b = trompo.ensemble(rotation, omega, case="ht1", t_end=0.2, threads=2, progress=lambda k, n: seen.append((k, n)))
    assert seen[-1] == (25, 25) and len(seen) == 13
    for key in a:
        assert np.array_equal(np.asarray(a[key]), np.asarray(b[key])), key
