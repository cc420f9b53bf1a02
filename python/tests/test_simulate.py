"""trompo.simulate: bit-identical to trompo-simulate's rows, the invariants the schemes
keep, the CLI's error messages as ValueError, StepFailed with the rows so far, and the
GIL released while C++ integrates."""
import re
import threading
import warnings

import numpy as np
import pytest

import trompo
from conftest import run_cli, same_rows, engine_ran_beside_python

# (CLI flags, the same as keywords)
CASES = [
    (["--case", "ht1", "--t-end", "1", "--every", "10"], dict(case="ht1", t_end=1, every=10)),
    (["--case", "ht0", "--scheme", "simo-collocation", "--composition", "suzuki-5", "--t-end", "0.5"],
     dict(case="ht0", scheme="simo-collocation", composition="suzuki-5", t_end=0.5)),
    (["--case", "ht2", "--scheme", "geradin-bauchau", "--order", "4", "--t-end", "0.1", "--every", "7"],
     dict(case="ht2", scheme="geradin-bauchau", order=4, t_end=0.1, every=7)),
    (["--case", "fb1", "--scheme", "rk4", "--t-end", "3.05"], dict(case="fb1", scheme="rk4", t_end=3.05)),
    (["--case", "fb2", "--scheme", "simo-alpha", "--alpha", "0.3", "--t-end", "5"],
     dict(case="fb2", scheme="simo-alpha", alpha=0.3, t_end=5)),
    (["--case", "ht1", "--scheme", "simo-kappa", "--order", "6", "--t-end", "1", "--every", "50"],
     dict(case="ht1", order=6, t_end=1, every=50)),
    (["--inertia", "2,3,4,0.1,0.2,0.3", "--mgl", "7.5", "--com", "0.1,0.2,1", "--up", "0,1,1", "--rotation",
      "0.3,-0.2,0.1", "--omega", "1,-2,3", "--dt", "0.01", "--t-end", "2", "--scheme", "geradin-bauchau-paper"],
     dict(inertia=[[2, 0.1, 0.2], [0.1, 3, 0.3], [0.2, 0.3, 4]], mgl=7.5, com=(0.1, 0.2, 1), up=np.array([0, 1, 1]),
          rotation=[0.3, -0.2, 0.1], omega=[1, -2, 3], dt=0.01, t_end=2, scheme="geradin-bauchau-paper")),
    (["--case", "ht1", "--damping", "0.5", "--torque", "0.1,0,0", "--space-torque", "0,0.2,0", "--rotor", "0,0,1",
      "--t-end", "1", "--every", "20"],
     dict(case="ht1", damping=0.5, torque=[0.1, 0, 0], space_torque=[0, 0.2, 0], rotor=[0, 0, 1], t_end=1, every=20)),
    (["--case", "ht1", "--scheme", "exact", "--t-end", "2", "--every", "100"],
     dict(case="ht1", scheme="exact", t_end=2, every=100)),
    (["--case", "ht1", "--dt", "-0.001", "--t-end", "-0.05"], dict(case="ht1", dt=-0.001, t_end=-0.05)),
    # the schemes with memory: splitting (with the one switch flag), the families, order 8
    (["--case", "ht0", "--scheme", "splitting", "--order", "4", "--energy-projection", "--dt", "0.01", "--t-end", "1"],
     dict(case="ht0", scheme="splitting", order=4, energy_projection=True, dt=0.01, t_end=1)),
    (["--case", "fb1", "--scheme", "splitting", "--composition", "kahan-li-9", "--t-end", "5"],
     dict(case="fb1", scheme="splitting", composition="kahan-li-9", energy_projection=False, t_end=5)),
    (["--case", "ht1", "--scheme", "lie-gen-alpha", "--rho-inf", "0.5", "--t-end", "0.5"],
     dict(case="ht1", scheme="lie-gen-alpha", rho_inf=0.5, t_end=0.5)),
    (["--case", "ht2", "--scheme", "energy-decaying", "--chi", "0.1", "--chi-schedule", "sensor", "--t-end", "0.05"],
     dict(case="ht2", scheme="energy-decaying", chi=0.1, chi_schedule="sensor", t_end=0.05)),
    (["--case", "ht1", "--scheme", "constrained-trapezoid", "--t-end", "0.5"],
     dict(case="ht1", scheme="constrained-trapezoid", t_end=0.5)),
    (["--case", "ht1", "--composition", "kahan-li-17", "--dt", "0.02", "--t-end", "1"],
     dict(case="ht1", composition="kahan-li-17", dt=0.02, t_end=1)),
    (["--case", "ht1", "--composition", "blanes-casas-murua-13", "--dt", "0.02", "--t-end", "1"],
     dict(case="ht1", composition="blanes-casas-murua-13", dt=0.02, t_end=1)),
    # the fourth family (docs/theory.md §18): the LGVI composed, the DMV, the explicit Lie group methods
    (["--case", "ht1", "--scheme", "lgvi", "--order", "4", "--dt", "0.01", "--t-end", "0.5"],
     dict(case="ht1", scheme="lgvi", order=4, dt=0.01, t_end=0.5)),
    (["--case", "fb1", "--scheme", "dmv", "--t-end", "2"], dict(case="fb1", scheme="dmv", t_end=2)),
    (["--case", "ht2", "--scheme", "rkmk4", "--t-end", "0.05"], dict(case="ht2", scheme="rkmk4", t_end=0.05)),
    (["--case", "ht1", "--scheme", "crouch-grossman", "--t-end", "0.5"], dict(case="ht1", scheme="crouch-grossman", t_end=0.5)),
    # a satellite (docs/spacecraft.md): the preset and its flags
    (["--case", "sat1", "--scheme", "splitting", "--composition", "chin-4a", "--t-end", "600", "--every", "50"],
     dict(case="sat1", scheme="splitting", composition="chin-4a", t_end=600, every=50)),
    (["--inertia", "100,120,80", "--gravity-gradient", "0.0011", "--orbit-normal", "0,0,1", "--radial", "1,0,0",
      "--rotation", "0.3,-0.2,0.5", "--omega", "0.05,0.07,0.04", "--dt", "2", "--t-end", "400", "--scheme", "rk4"],
     dict(inertia=[100, 120, 80], gravity_gradient=0.0011, orbit_normal=[0, 0, 1], radial=np.array([1, 0, 0]),
          rotation=[0.3, -0.2, 0.5], omega=[0.05, 0.07, 0.04], dt=2, t_end=400, scheme="rk4")),
    # the other switch: a negative damping asked for by name
    (["--case", "ht1", "--damping", "-0.5", "--allow-negative-damping", "--t-end", "1", "--every", "20"],
     dict(case="ht1", damping=-0.5, allow_negative_damping=True, t_end=1, every=20)),
]


@pytest.mark.parametrize("flags,kwargs", CASES, ids=[" ".join(f) for f, _ in CASES])
def test_rows_bit_identical_to_the_cli(flags, kwargs):
    rc, cli, err = run_cli(flags)
    assert rc == 0, err
    rows = trompo.simulate(**kwargs)
    assert same_rows(rows, cli)
    assert rows["R"].shape == (len(rows["t"]), 3, 3)
    assert rows["iterations"].dtype == np.int64


def test_recovered_by_substeps_warns_and_matches_the_cli():
    rc, cli, err = run_cli(["--case", "ht0", "--dt", "0.2", "--t-end", "1"])
    assert rc == 0 and "recovered by sub-stepping" in err
    with pytest.warns(trompo.Recovered, match="recovered by sub-stepping"):
        rows = trompo.simulate(case="ht0", dt=0.2, t_end=1)
    assert same_rows(rows, cli)


def test_invariants_simo_kappa_ht1():
    r = trompo.simulate(case="ht1", t_end=10, every=100)
    assert len(r["t"]) == 101 and r["t"][-1] == 10.0
    assert np.max(np.abs(r["H"] / r["H"][0] - 1)) < 1e-12
    assert np.max(np.abs(r["mu"] / r["mu"][0] - 1)) < 1e-12
    RtR = np.einsum("nki,nkj->nij", r["R"], r["R"])
    assert np.max(np.abs(RtR - np.eye(3))) < 1e-14
    assert np.all(r["iterations"][1:] > 0) and r["iterations"][0] == 0


def test_invariants_free_body_spatial_momentum():
    r = trompo.simulate(case="fb1", scheme="geradin-bauchau", t_end=100, every=1000)
    assert np.max(np.linalg.norm(r["pi"] - r["pi"][0], axis=1)) < 1e-12 * np.linalg.norm(r["pi"][0])
    assert np.max(np.abs(r["H"] / r["H"][0] - 1)) < 1e-12


def test_order_4_beats_order_2_against_the_closed_form():
    exact = trompo.simulate(case="ht1", scheme="exact", dt=0.01, t_end=10, every=1000)["R"][-1]
    e2 = np.linalg.norm(trompo.simulate(case="ht1", dt=0.01, t_end=10, every=1000)["R"][-1] - exact)
    e4 = np.linalg.norm(trompo.simulate(case="ht1", dt=0.01, t_end=10, every=1000, composition="suzuki-5")["R"][-1]
                        - exact)
    assert e4 < e2 / 100


BAD = [
    (["--case", "ht1", "--dt", "0"], dict(case="ht1", dt=0)),
    (["--case", "ht1", "--dt", "nan"], dict(case="ht1", dt=float("nan"))),
    (["--case", "ht1", "--scheme", "euler"], dict(case="ht1", scheme="euler")),
    (["--case", "ht9"], dict(case="ht9")),
    (["--case", "ht1", "--inertia", "1,1,5"], dict(case="ht1", inertia=[1, 1, 5])),
    (["--case", "ht1", "--alpha", "0.3"], dict(case="ht1", alpha=0.3)),
    (["--case", "ht1", "--order", "3"], dict(case="ht1", order=3)),
    (["--case", "ht1", "--scheme", "rk4", "--order", "4"], dict(case="ht1", scheme="rk4", order=4)),
    (["--case", "ht1", "--composition", "suzuki-5", "--order", "6"], dict(case="ht1", composition="suzuki-5", order=6)),
    (["--case", "ht1", "--t-end", "-1"], dict(case="ht1", t_end=-1)),
    (["--inertia", "1,2,3", "--dt", "0.1"], dict(inertia=[1, 2, 3], dt=0.1)),
    (["--case", "ht1", "--com", "0,0,0"], dict(case="ht1", com=[0, 0, 0])),
    (["--case", "ht2", "--scheme", "exact"], dict(case="ht2", scheme="exact")),
    (["--case", "ht1", "--every", "0"], dict(case="ht1", every=0)),
    (["--case", "ht1", "--rotor", "1,2"], None),
    (["--case", "sat1", "--radial", "1,0,1"], dict(case="sat1", radial=[1, 0, 1])),
    (["--case", "sat1", "--gravity-gradient", "-1"], dict(case="sat1", gravity_gradient=-1)),
    (["--case", "ht1", "--orbit-normal", "0,0,1"], dict(case="ht1", orbit_normal=[0, 0, 1])),
    # issue 18: a negative damping unless asked for by name; an initial state that overflows
    (["--case", "ht1", "--damping", "-1"], dict(case="ht1", damping=-1)),
    (["--case", "ht1", "--omega", "1e200,0,0"], dict(case="ht1", omega=[1e200, 0, 0])),
    (["--case", "ht1", "--rotation", "1e300,0,0"], dict(case="ht1", rotation=[1e300, 0, 0])),
]


@pytest.mark.parametrize("flags,kwargs", BAD, ids=[" ".join(f) for f, _ in BAD])
def test_bad_arguments_raise_the_cli_message(flags, kwargs):
    rc, rows, err = run_cli(flags)
    assert rc == 2 and rows is None
    message = err.strip().removeprefix("trompo-simulate: ")
    if kwargs is None:  # a vector of the wrong length is caught in Python, with the flag's name
        with pytest.raises(ValueError, match="^rotor: expected 3 numbers"):
            trompo.simulate(case="ht1", rotor=[1, 2])
        return
    with pytest.raises(ValueError) as e:
        trompo.simulate(**kwargs)
    # the CLI's message with each flag as its keyword (issue: errors in Python's words)
    assert str(e.value) == re.sub(r"--([a-z][a-z0-9-]*)", lambda m: m.group(1).replace("-", "_"), message)
    assert "--" not in str(e.value)


def test_other_keywords_are_passed_as_flags():
    """A keyword simulate() does not list goes to the CLI's parser as --name when the CLI
    has that flag (its --help lists it: flags the CLI gains work from Python at once); an
    unknown one is a TypeError naming it, as Python's own (test_control.py: did you mean)."""
    rc, rows, err = run_cli(["--case", "ht1", "--spin-rate", "3"])
    assert rc == 2 and "unknown option '--spin-rate'" in err
    with pytest.raises(TypeError, match="unexpected keyword argument 'spin_rate'"):
        trompo.simulate(case="ht1", spin_rate=3)
    with pytest.raises(TypeError):
        trompo.simulate(case="ht1", csv="out.csv")


def test_step_failed_carries_the_rows_up_to_the_last_good_state():
    # A torque that spins the top up until not even 1024 sub-steps can take a step.
    flags = ["--case", "ht1", "--torque", "0,0,1e7", "--dt", "0.01", "--t-end", "0.1"]
    rc, cli, err = run_cli(flags)
    assert rc == 3 and len(cli["t"]) == 4
    with pytest.raises(trompo.StepFailed) as e:
        trompo.simulate(case="ht1", torque=[0, 0, 1e7], dt=0.01, t_end=0.1)
    assert str(e.value) == err.strip().splitlines()[-1].removeprefix("trompo-simulate: ")
    assert "not recovered by sub-stepping" in str(e.value)
    assert same_rows(e.value.rows, cli)
    assert e.value.t == cli["t"][-1] == 0.03


def test_gil_released_while_cpp_integrates():
    """The engine's thread runs C++ while another Python thread holds the GIL
    (conftest.engine_ran_beside_python: shown by its CPU clock, without timing)."""
    seen, rows, error = engine_ran_beside_python(lambda: trompo.simulate("fb1", t_end=1e3, dt=1e-3, every=10**6))
    if error is not None:
        raise error
    assert seen, "the engine's thread did not run C++ while this one held the GIL"
    assert rows["t"][-1] == 1e3


def test_a_switch_takes_a_bool_only():
    # energy_projection=True is --energy-projection; a number or a string is refused (0 is not False).
    for value in (1, 0, "false"):
        with pytest.raises(ValueError, match="takes no value"):
            trompo.simulate(case="ht1", scheme="splitting", energy_projection=value, t_end=0.01)
    off = trompo.simulate(case="ht1", scheme="splitting", energy_projection=False, t_end=0.01)
    plain = trompo.simulate(case="ht1", scheme="splitting", t_end=0.01)
    assert np.array_equal(off["R"], plain["R"])


def test_satellite_reports_the_jacobi_integral():
    """On a satellite the H column is E_J = T + V - n o.pi, kept by the projected splitting."""
    rows = trompo.simulate("sat1", scheme="splitting", composition="strang", energy_projection=True, dt=2.0,
                           t_end=5712.0, every=100)
    n = 0.0011
    J = np.diag([100.0, 120.0, 80.0])
    t, R, W = rows["t"], rows["R"], rows["W"]
    r = np.stack([np.cos(n * t), np.sin(n * t), np.zeros_like(t)], axis=1)
    c = np.einsum("kji,kj->ki", R, r)  # Lambda^T r
    pi = np.einsum("kij,kj->ki", R, W @ J)
    EJ = 0.5 * np.einsum("ki,ki->k", W, W @ J) + 1.5 * n * n * np.einsum("ki,ki->k", c, c @ J) - n * pi[:, 2]
    assert np.allclose(rows["H"], EJ, rtol=1e-13, atol=0)
    assert np.max(np.abs(rows["H"] - rows["H"][0])) < 1e-11


def test_compensated_state_keeps_h_and_mu_to_a_few_eps():
    # compensated=True is --compensated (docs/theory.md §18): 2·10^5 Simo-κ steps of HT0.
    # Measured: 2.2e-16 and 4.4e-16 with it, 3.6e-14 and 3.0e-14 without.
    drift = {}
    for on in (False, True):
        r = trompo.simulate(case="ht0", scheme="simo-kappa", compensated=on, dt=1e-5, t_end=2, every=1000)
        drift[on] = max(np.max(np.abs(r["H"] / r["H"][0] - 1)), np.max(np.abs(r["mu"] / r["mu"][0] - 1)))
    assert drift[True] <= 4 * np.finfo(float).eps
    assert drift[False] >= 10 * drift[True]
    with pytest.raises(ValueError, match="^compensated: only with scheme simo-kappa"):
        trompo.simulate(case="ht1", scheme="rk4", compensated=True, t_end=0.1)
