"""trompo.ensemble: each member bit-identical to the last row of its single simulate()
run (and so of the CLI's), per-member mgl and inertia, threads 1 and 2 identical, a
failing member reported without stopping the others, rotation matrices as input, and
bad shapes as ValueError."""
import numpy as np
import pytest

import trompo
from conftest import run_cli

KEYS = ("t", "R", "W", "H", "mu", "pi")


def members(n, seed=1):
    rng = np.random.default_rng(seed)
    rotation = np.column_stack([rng.uniform(0.02, 0.4, n), rng.uniform(-0.05, 0.05, n), np.zeros(n)])
    omega = np.column_stack([rng.normal(0, 0.5, n), rng.normal(0, 0.5, n), rng.uniform(20, 60, n)])
    return rotation, omega


def test_members_bit_identical_to_single_runs():
    rotation, omega = members(6)
    out = trompo.ensemble(rotation, omega, case="ht1", t_end=0.5, threads=2)
    assert out["ok"].all() and out["status"] == ["ok"] * 6
    for i in range(6):
        single = trompo.simulate(case="ht1", t_end=0.5, rotation=rotation[i], omega=omega[i])
        for k in KEYS:
            assert np.array_equal(out[k][i], single[k][-1]), (i, k)
        assert out["iterations"][i] == single["iterations"].sum()


def test_per_member_mgl_and_inertia_match_the_cli():
    rotation, omega = members(4, seed=2)
    mgl = np.array([20.0, 10.0, 0.0, 35.5])
    inertia = np.array([[5, 5, 1], [4, 4.5, 1.2], [3, 3, 2], [6, 5, 1.5]], dtype=float)
    out = trompo.ensemble(rotation, omega, mgl=mgl, inertia=inertia, case="ht1", order=4, t_end=0.2)
    for i in range(4):
        flags = ["--case", "ht1", "--order", "4", "--t-end", "0.2", "--mgl", repr(mgl[i]),
                 "--inertia", ",".join(repr(x) for x in inertia[i]),
                 "--rotation", ",".join(repr(x) for x in rotation[i]), "--omega", ",".join(repr(x) for x in omega[i])]
        rc, cli, err = run_cli(flags)
        assert rc == 0, err
        for k in KEYS:
            assert np.array_equal(out[k][i], cli[k][-1]), (i, k)
    # energy conserved member by member (Simo-kappa, order 4)
    first = trompo.ensemble(rotation, omega, mgl=mgl, inertia=inertia, case="ht1", order=4, t_end=0.001, dt=0.001)
    assert np.allclose(out["H"], first["H"], rtol=1e-12, atol=0)


def test_threads_one_and_two_identical_and_matrices_as_input():
    rotation, omega = members(9, seed=3)
    one = trompo.ensemble(rotation, omega, case="ht1", t_end=0.3, threads=1)
    two = trompo.ensemble(rotation, omega, case="ht1", t_end=0.3, threads=2)
    for k in KEYS + ("iterations", "ok"):
        assert np.array_equal(one[k], two[k]), k
    # Continuing from the final matrices: a second leg from the first's states.
    leg = trompo.ensemble(one["R"], one["W"], case="ht1", t_end=0.3)
    assert leg["ok"].all()
    assert np.allclose(leg["H"], one["H"], rtol=1e-12, atol=0)


def test_a_failing_member_does_not_stop_the_others():
    rotation = np.zeros((3, 3))
    omega = np.array([[0.01, 2, 0.01], [0, 1e6, 0], [0.01, 2, 0.02]])
    out = trompo.ensemble(rotation, omega, case="fb1", dt=1, t_end=2)
    assert list(out["ok"]) == [True, False, True]
    assert "wrong branch" in out["status"][1]
    assert out["t"][1] == 0 and out["t"][0] == 2 and out["t"][2] == 2
    assert np.array_equal(out["W"][1], omega[1])  # its last good state: the start


@pytest.mark.parametrize("args,kwargs,message", [
    ((np.zeros((2, 2)), np.zeros((2, 3))), {}, "rotation: expected rotation vectors (N, 3) or matrices (N, 3, 3), got shape (2, 2)"),
    ((np.zeros((2, 3)), np.zeros((3, 3))), {}, "omega: expected shape (2, 3), got (3, 3)"),
    ((np.zeros((2, 3)), np.zeros((2, 3))), {"mgl": [1.0]}, "mgl: expected shape (2,), got (1,)"),
    ((np.zeros((2, 3)), np.zeros((2, 3))), {"inertia": np.ones((2, 4))}, "inertia: expected shape (2, 3), (2, 6) or (2, 3, 3)"),
    ((np.zeros((2, 3)), np.array([[0, 0, 1], [0, np.nan, 1]])), {}, "member 1: state: non-finite omega"),
    ((np.zeros((2, 3)), np.zeros((2, 3))), {"inertia": [[1, 2, 3], [1, 1, 5]]}, "member 1: "),
    ((np.zeros((1, 3, 3)), np.zeros((1, 3))), {}, "member 0: "),
    ((np.zeros((2, 3)), np.zeros((2, 3))), {"scheme": "exact"}, "ensemble: not with scheme exact"),
    ((np.zeros((2, 3)), np.zeros((2, 3))), {"dt": 0}, "dt: must be non-zero, got 0"),
])
def test_bad_input_is_a_value_error(args, kwargs, message):
    with pytest.raises(ValueError) as e:
        trompo.ensemble(*args, **{"case": "ht1", "t_end": 0.01, **kwargs})
    assert str(e.value).startswith(message)


def test_adaptive_members_are_their_single_runs():
    """rtol: adaptive members (issue: ensembles with tolerances, t_eval and events), each
    bit-identical to solve_ivp's run of that member, whatever the threads; per-member
    inertia from an array."""
    rng = np.random.default_rng(11)
    n = 6
    rotation = rng.normal(scale=0.5, size=(n, 3))
    omega = rng.normal(scale=2.0, size=(n, 3))
    inertia = np.array([[1.0, 1.0, 0.4]] * n) * rng.uniform(0.8, 1.2, size=(n, 1))
    t_eval = [0.0, 0.25, 0.5, 1.0]
    run = dict(case="ht1", scheme="simo-kappa", order=4, rtol=1e-8, atol=1e-8, t_end=1.0)
    for threads in (1, 3):
        ens = trompo.ensemble(rotation, omega, inertia=inertia, t_eval=t_eval, events=["nutation-max"], threads=threads,
                              **run)
        assert ens["y_eval"].shape == (n, 12, 4) and ens["ok"].all()
        for i in range(n):
            one = trompo.solve_ivp("ht1", (0, 1), rtol=1e-8, atol=1e-8, t_eval=t_eval, events=["nutation-max"],
                                   scheme="simo-kappa", order=4, inertia=inertia[i], rotation=rotation[i], omega=omega[i])
            assert np.array_equal(ens["y_eval"][i], one.y), (threads, i)
            assert np.array_equal(ens["R"][i], one.R[-1]) and np.array_equal(ens["W"][i], one.W[-1])
            assert ens["nsteps"][i] == one.nsteps and ens["nreject"][i] == one.nreject
            assert np.array_equal(ens["t_events"][i][0], one.t_events[0])
            assert np.array_equal(ens["y_events"][i][0], one.y_events[0])
    assert sum(len(ens["t_events"][i][0]) for i in range(n)) > 0  # the events did occur
