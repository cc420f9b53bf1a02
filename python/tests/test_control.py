"""trompo.control: control in the loop from Python (docs/python.md, "Control in the loop from
Python"). A numpy MRP-PD law gives the built-in MrpPd's rows bit for bit; the callable is
called exactly at the samples; the three ways to give the initial attitude agree; a raising
controller and a non-finite command end the run with the rows so far; unknown keywords are
TypeErrors with a suggestion; the GIL is released while C++ integrates."""
import math
import sys
import threading
import traceback

import numpy as np
import pytest

import trompo
from conftest import import_or_skip, run_cli, engine_ran_beside_python

RPM = 2 * math.pi / 60
JS = 50 / (6000 * RPM)  # 50 N m s at 6000 rpm


def rotation_of_mrp(sigma):
    """C++ trompo::rotation_of_mrp: Λ = [BN]^T, [BN] = I + (8S² − 4(1 − σᵀσ)S)/(1 + σᵀσ)²."""
    s = np.asarray(sigma, dtype=float)
    s2 = s @ s
    S = np.array([[0, -s[2], s[1]], [s[2], 0, -s[0]], [-s[1], s[0], 0]])
    BN = np.eye(3) + (8 * S @ S - 4 * (1 - s2) * S) / ((1 + s2) * (1 + s2))
    return BN.T


def basilisk():
    """Basilisk's scenarioAttitudeFeedbackRW (examples/example_attitude_feedback_rw.cpp)."""
    wheels = [trompo.Wheel(axis, JS, speed0=rpm * RPM, max_torque=0.2, max_speed=6000 * RPM)
              for axis, rpm in zip(np.eye(3), (100, 200, 300))]
    sc = trompo.Spacecraft([900, 800, 600], wheels=wheels)
    state = trompo.initial_state(rotation=rotation_of_mrp((0.1, 0.2, -0.3)), omega=(0.001, -0.01, 0.03))
    return sc, state


mrp_of_matrix = trompo.mrp


def mrp_pd(K, P):
    """The MRP PD law in Python, to the identity target, on three wheels along the body axes:
    L = −Kσ − PΩ, u = −G_sᵀ(G_sG_sᵀ)⁻¹L = −L (G_s = I: the C++ products and the cofactor
    inverse are exact there, so only σ's operations matter)."""
    def f(t, R, W, wheel_speeds, memory):
        s = mrp_of_matrix(R.tolist())  # target = I: Rᵀ_target Λ = Λ exactly
        w = W.tolist()
        L = [-K * s[i] - P * w[i] for i in range(3)]
        memory["calls"] = memory.get("calls", 0) + 1
        return {"wheel_torques": np.array([-L[0], -L[1], -L[2]])}
    return f


def test_python_mrp_pd_gives_the_builtin_rows_bit_for_bit():
    sc, s0 = basilisk()
    run = dict(dt=0.05, period=0.1)
    builtin = trompo.control(sc, s0, 20.0, controller=trompo.MrpPd(K=3.5, P=30), **run)
    python = trompo.control(sc, s0, 20.0, controller=mrp_pd(3.5, 30.0), **run)
    assert builtin.success and python.success
    assert len(builtin.t) == 401 and builtin.wheel_speeds.shape == (401, 3) and builtin.u.shape == (401, 3)
    for key in ("t", "R", "W", "H", "mu", "pi", "wheel_speeds", "u"):
        np.testing.assert_array_equal(python[key], builtin[key], err_msg=key)
    # the law did act: the wheels saturate at first, and the attitude settles
    assert np.max(np.abs(builtin.u)) == 0.2
    assert builtin.u[0].tolist() != [0.0, 0.0, 0.0]


def test_the_controller_is_called_exactly_at_the_samples():
    sc, s0 = basilisk()
    seen = []

    def f(t, R, W, wheel_speeds, memory):
        seen.append(t)
        memory["n"] = memory.get("n", 0) + 1
        assert memory["n"] == len(seen)  # the same dict across the run
        assert R.shape == (3, 3) and W.shape == (3,) and wheel_speeds.shape == (3,)
        return None

    res = trompo.control(sc, s0, 2.0, dt=0.01, period=0.25, controller=f, every=5)
    assert seen == [k * 0.25 for k in range(8)]
    assert res.t[0] == 0 and res.t[-1] == 2.0 and len(res.t) == 41
    assert np.all(res.u == 0)
    # a period that does not divide t_end: the last hold is shorter
    seen.clear()
    trompo.control(sc, s0, 1.0, dt=0.05, period=0.3, controller=f)
    assert seen == [0.0, 0.3, 0.6, 0.8999999999999999]  # t_k = k * T, multiplied, not summed


def test_state_from_matrix_quaternion_and_rotvec_agree():
    sc, _ = basilisk()
    R = rotation_of_mrp((0.1, 0.2, -0.3))
    # the quaternion (w, x, y, z) and rotation vector of R
    w = math.sqrt(1 + np.trace(R)) / 2
    q = np.array([w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)])
    angle = 2 * math.atan2(np.linalg.norm(q[1:]), q[0])
    rotvec = angle * q[1:] / np.linalg.norm(q[1:])
    states = [trompo.initial_state(rotation=R, omega=(0.001, -0.01, 0.03)),
              trompo.initial_state(quaternion=q, omega=(0.001, -0.01, 0.03)),
              trompo.initial_state(quaternion=np.roll(q, -1), scalar_first=False, omega=(0.001, -0.01, 0.03)),
              trompo.initial_state(rotvec=rotvec, omega=(0.001, -0.01, 0.03))]
    for s in states[1:]:
        np.testing.assert_allclose(s.R, R, rtol=0, atol=1e-15)
    finals = [trompo.control(sc, s, 5.0, dt=0.1, period=0.1, controller=trompo.MrpPd(3.5, 30)).R[-1] for s in states]
    for f in finals[1:]:
        np.testing.assert_allclose(f, finals[0], rtol=0, atol=1e-13)
    try:
        from scipy.spatial.transform import Rotation
    except ImportError:
        return
    np.testing.assert_allclose(Rotation.from_quat(np.roll(q, -1)).as_matrix(), R, atol=1e-15)
    np.testing.assert_allclose(Rotation.from_rotvec(rotvec).as_matrix(), R, atol=1e-15)
    with pytest.raises(ValueError, match="exactly one of rotation, quaternion, rotvec"):
        trompo.initial_state(rotation=R, rotvec=rotvec)


def test_an_exception_in_the_controller_ends_the_run_with_the_rows_so_far():
    sc, s0 = basilisk()

    def failing_controller(t, R, W, wheel_speeds, memory):
        if t >= 1.0:
            raise ZeroDivisionError("the law divided by zero")
        return {"wheel_torques": [0.01, 0.0, 0.0]}

    with pytest.raises(trompo.ControlError) as e:
        trompo.control(sc, s0, 5.0, dt=0.05, period=0.1, controller=failing_controller)
    err = e.value
    assert isinstance(err.__cause__, ZeroDivisionError)
    assert "ZeroDivisionError at t = 1.0" in str(err) and err.t == 1.0
    frames = [fr.name for fr in traceback.extract_tb(err.__cause__.__traceback__)]
    assert "failing_controller" in frames
    rows = err.result
    assert rows.t[0] == 0 and rows.t[-1] == pytest.approx(0.95) and len(rows.t) == 20
    assert np.all(rows.u[:, 0] == 0.01)
    # a bad return value is a controller error too, chained the same way
    with pytest.raises(trompo.ControlError) as e:
        trompo.control(sc, s0, 1.0, dt=0.05, period=0.1, controller=lambda *a: {"torque": [1, 2, 3]})
    assert isinstance(e.value.__cause__, ValueError) and "unknown command 'torque'" in str(e.value.__cause__)
    with pytest.raises(trompo.ControlError) as e:  # no orbit: no field for a dipole
        trompo.control(sc, s0, 1.0, dt=0.05, period=0.1, controller=lambda *a: {"dipole": [1, 0, 0]})
    assert "no orbit" in str(e.value.__cause__)


def test_a_non_finite_command_raises_value_error_naming_it_and_t_k():
    sc, s0 = basilisk()

    def f(t, R, W, wheel_speeds, memory):
        return {"wheel_torques": [0.0, math.nan if t >= 0.5 else 0.0, 0.0]}

    with pytest.raises(ValueError, match=r"non-finite command wheel_torques at t = 0\.5$") as e:
        trompo.control(sc, s0, 2.0, dt=0.1, period=0.1, controller=f)
    assert isinstance(e.value, trompo.CommandError) and e.value.t == 0.5
    assert e.value.result.t[-1] == 0.5 and not e.value.result.success
    with pytest.raises(trompo.CommandError, match="body_torque at t = 0"):
        trompo.control(sc, s0, 1.0, dt=0.1, period=0.1, controller=lambda *a: {"body_torque": [math.inf, 0, 0]})
    with pytest.raises(trompo.CommandError, match="wheel_torques has 2 entries for 3 wheels at t = 0"):
        trompo.control(sc, s0, 1.0, dt=0.1, period=0.1, controller=lambda *a: {"wheel_torques": [0, 0]})


def test_objects_are_validated_in_python_words():
    with pytest.raises(ValueError, match="^axis: must be non-zero"):
        trompo.Wheel((0, 0, 0), 1.0)
    with pytest.raises(ValueError, match="^Js: must be > 0"):
        trompo.Wheel((1, 0, 0), -1.0)
    with pytest.raises(ValueError, match="^radius: must be > 0"):
        trompo.Orbit(-7e6)
    with pytest.raises(ValueError, match="^inertia: not positive definite"):
        trompo.Spacecraft([1, -2, 3])
    with pytest.raises(ValueError, match="^max_dipole: needs an orbit"):
        trompo.Spacecraft([1, 2, 3], max_dipole=5)
    sc, s0 = basilisk()
    with pytest.raises(ValueError, match="^period: 0.01 is shorter than the step dt = 0.1"):
        trompo.control(sc, s0, 1.0, dt=0.1, period=0.01, controller=trompo.MrpPd(1, 1))
    with pytest.raises(ValueError, match="^controller: BDot needs spacecraft.orbit"):
        trompo.control(sc, s0, 1.0, dt=0.1, period=0.1, controller=trompo.BDot(1e4))


def test_bdot_runs_in_the_field():
    sc = trompo.Spacecraft([10, 12, 14], orbit=trompo.Orbit(6.778e6, math.radians(51.6)), max_dipole=1.0)
    s0 = trompo.initial_state(rotvec=(0, 0, 0), omega=(0.05, -0.04, 0.03))
    res = trompo.control(sc, s0, 600.0, dt=0.5, period=1.0, controller=trompo.BDot(3e5), every=100)
    assert res.success and res.wheel_speeds.shape == (len(res.t), 0)
    assert np.linalg.norm(res.W[-1]) < np.linalg.norm(res.W[0])


def test_steps_follow_the_rate_with_max_step_angle():
    """|Ω| = 0.866 rad/s turns 0.2165 rad a 0.25 s hold: 0.05 rad a step is 5 steps a sample,
    and the samples stay grid points; a bad angle is refused in Python words."""
    sc = trompo.Spacecraft([0.035, 0.034, 0.01], orbit=trompo.Orbit(6771e3, math.radians(51.6)), max_dipole=0.2)
    s0 = trompo.initial_state(rotvec=(0, 0, 0), omega=(0.5, 0.5, 0.5))
    kw = dict(dt=0.25, period=0.25, controller=trompo.BDot(1e5), scheme="splitting")
    res = trompo.control(sc, s0, 2.0, max_step_angle=0.05, **kw)
    assert res.success and len(res.t) == 41
    assert all(np.any(res.t == 0.25 * k) for k in range(9))
    assert len(trompo.control(sc, s0, 2.0, **kw).t) == 9  # one step a sample without it
    with pytest.raises(ValueError, match="max_step_angle: must be > 0"):
        trompo.control(sc, s0, 2.0, max_step_angle=-1.0, **kw)
    with pytest.raises(ValueError, match="max_step_angle: fixed steps only, not with rtol"):
        trompo.control(sc, s0, 2.0, max_step_angle=0.1, rtol=1e-8, **kw)


def test_a_spinner_with_wheels_takes_the_near_integrable_splitting():
    """composition="saba2c" with scheme="splitting" [W18]: a spinner at 60 rpm whose wheels
    damp its nutation (the bench's, docs/control.md), one step a sample. SABA2 is far closer
    to a converged run than Strang at the same step, pi stays to round-off, and the ensemble
    takes the keyword too; a composition that is not a name is refused in Python words."""
    wheels = [trompo.Wheel(axis, 0.05, max_torque=0.5) for axis in np.eye(3)]
    sc = trompo.Spacecraft([120, 100, 150], wheels=wheels)
    s0 = trompo.initial_state(rotation=np.eye(3), omega=(0.6, 0.0, 60 * RPM))

    def damper(t, R, W, wheel_speeds, memory):
        u = [W[i] - 0.2 * 0.05 * (W[i] + wheel_speeds[i]) for i in range(2)]
        return {"wheel_torques": np.array([u[0], u[1], 0.0])}

    def run(composition, dt):
        return trompo.control(sc, s0, 3.0, dt=dt, period=0.05, controller=damper, scheme="splitting",
                              composition=composition, every=10**6)
    ref = run("kahan-li-9", 0.05 / 8).R[-1]
    saba = run("saba2c", 0.05)
    strang = run("strang", 0.05)
    err_saba, err_strang = np.linalg.norm(saba.R[-1] - ref), np.linalg.norm(strang.R[-1] - ref)
    assert saba.success and err_saba <= err_strang / 100, (err_saba, err_strang)
    assert np.max(np.abs(saba.pi - saba.pi[0])) <= 1e-13 * np.linalg.norm(saba.pi[0])
    e = trompo.control_ensemble(sc, np.array([np.eye(3)]), np.array([s0.omega]), 3.0, dt=0.05, period=0.05,
                                controller=trompo.MrpPd(0, 0), scheme="splitting", composition="saba2c")
    single = trompo.control(sc, s0, 3.0, dt=0.05, period=0.05, controller=trompo.MrpPd(0, 0), scheme="splitting",
                            composition="saba2c", every=10**6)
    assert np.array_equal(e["R"][0], single.R[-1])
    with pytest.raises(ValueError, match="^composition: expected a method's name"):
        run(2, 0.05)
    with pytest.raises(ValueError, match="composition"):
        run("saba9", 0.05)


def test_unknown_keywords_are_type_errors_with_a_suggestion():
    with pytest.raises(TypeError, match=r"simulate\(\) got an unexpected keyword argument 't_edn'; did you mean 't_end'"):
        trompo.simulate(case="ht1", t_edn=1)
    with pytest.raises(TypeError, match=r"solve_ivp\(\) got an unexpected keyword argument 'rtl'; did you mean 'rtol'"):
        trompo.solve_ivp("ht1", (0, 1), rtl=1e-6)
    with pytest.raises(TypeError, match=r"ensemble\(\) got an unexpected keyword argument 'thread'; did you mean 'threads'"):
        trompo.ensemble(np.zeros((1, 3)), np.ones((1, 3)), case="ht1", t_end=0.1, thread=1)
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'xyzzy'$"):
        trompo.simulate(case="ht1", xyzzy=1)
    # a CLI flag simulate() does not list still goes to the CLI's parser, with its message
    # in Python's words (the keyword for the flag)
    rc, _, err = run_cli(["--case", "ht1", "--max-dipole", "-1"])
    with pytest.raises(ValueError) as e:
        trompo.simulate(case="ht1", max_dipole=-1)
    assert rc == 2 and err.strip() == "trompo-simulate: --max-dipole: must be > 0 (A m^2), got -1"
    assert str(e.value) == "max_dipole: must be > 0 (A m^2), got -1"


def test_the_gil_is_released_while_cpp_integrates():
    """The engine's thread runs C++ between two samples of a Python controller while another
    Python thread holds the GIL (conftest.engine_ran_beside_python: shown by its CPU clock,
    without timing)."""
    sc, s0 = basilisk()
    samples = []

    def f(t, R, W, wheel_speeds, memory):
        samples.append(t)
        return None

    seen, run, error = engine_ran_beside_python(
        lambda: trompo.control(sc, s0, 5e3, dt=0.01, period=1.0, controller=f, every=10**6))
    if error is not None:
        raise error
    assert seen, "the engine's thread did not run C++ while this one held the GIL"
    assert len(samples) == 5000 and run.t[-1] == 5e3


def test_the_example_runs_and_plots(tmp_path):
    """examples/python/attitude_control.py on a short run (matplotlib, Agg)."""
    import_or_skip("matplotlib")  # an error under TROMPO_REQUIRE_ALL=1 (ctest)
    import os
    import pathlib
    import subprocess
    import sys
    root = pathlib.Path(os.environ.get("TROMPO_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
    png = tmp_path / "attitude.png"
    p = subprocess.run([sys.executable, str(root / "examples/python/attitude_control.py"), str(png), "--t-end", "5"],
                       capture_output=True, text=True, env=dict(os.environ, MPLBACKEND="Agg"))
    assert p.returncode == 0, p.stderr
    assert "51 rows" in p.stdout and png.stat().st_size > 1000


def test_wheel_friction_keeps_pi_and_takes_energy_out(tmp_path):
    """Wheel(friction=c): the torque -c * speed between wheel and body [W17], split around the
    fixed steps. With no command (MrpPd(0, 0)) the energy never rises and the wheels slow
    relative to the body; pi stays to round-off; the CLI's rows with the friction column are
    the same bits; rtol adapts the split step, with t_eval, events and dense_output that see
    the friction (W17.a-b); a negative c is refused in Python words."""
    from conftest import cli_path
    import subprocess
    wheels = [trompo.Wheel(axis, 0.05, speed0=s, friction=c)
              for axis, s, c in zip(np.eye(3), (10.0, -5.0, 0.0), (0.002, 0.001, 0.0))]
    sc = trompo.Spacecraft([10, 12, 8], wheels=wheels)
    s0 = trompo.initial_state(rotation=np.eye(3), omega=(0.02, -0.01, 0.03))
    res = trompo.control(sc, s0, 60.0, dt=0.1, period=0.5, controller=trompo.MrpPd(0, 0), every=10)
    assert res.success and len(res.t) == 61
    assert np.all(np.diff(res.H) <= 1e-15 * res.H[0]) and res.H[-1] < 0.99 * res.H[0]
    assert np.max(np.abs(res.pi - res.pi[0])) <= 1e-13 * np.linalg.norm(res.pi[0])
    assert abs(res.wheel_speeds[-1, 0]) < 0.5 * 10.0 and res.wheel_speeds[-1, 2] != 0.0
    assert "friction=0.002" in repr(wheels[0])
    csv = tmp_path / "wheels.csv"
    csv.write_text("gx,gy,gz,Js,speed0,max_torque,max_speed,friction\n" + "".join(
        f"{w.axis[0]!r},{w.axis[1]!r},{w.axis[2]!r},{w.Js!r},{w.speed0!r},inf,inf,{w.friction!r}\n" for w in wheels))
    p = subprocess.run([cli_path(), "--inertia", "10,12,8", "--wheels", str(csv), "--omega", "0.02,-0.01,0.03",
                        "--controller", "mrp-pd:0,0", "--control-period", "0.5", "--dt", "0.1", "--t-end", "60",
                        "--every", "10"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    a = np.array([[float(x) for x in line.split(",")] for line in p.stdout.splitlines()[1:]])
    np.testing.assert_array_equal(res.R.reshape(-1, 9), a[:, 1:10])
    np.testing.assert_array_equal(res.wheel_speeds, a[:, 19:22])
    # In an ensemble: each member its single run with the same lossy wheels, bit for bit.
    om = np.array([[0.02, -0.01, 0.03], [0.0, 0.05, -0.02]])
    e = trompo.control_ensemble(sc, np.array([np.eye(3)] * 2), om, 20.0, dt=0.1, period=0.5,
                                controller=trompo.MrpPd(1, 5), threads=2)
    for i in range(2):
        single = trompo.control(sc, trompo.initial_state(rotation=np.eye(3), omega=om[i]), 20.0, dt=0.1, period=0.5,
                                controller=trompo.MrpPd(1, 5), every=10**6)
        assert np.array_equal(e["R"][i], single.R[-1]) and np.array_equal(e["wheel_speeds"][i], single.wheel_speeds[-1])
    with pytest.raises(ValueError, match="^friction: must be >= 0"):
        trompo.Wheel((1, 0, 0), 0.05, friction=-1.0)
    # Adaptive steps (rtol) adapt the split step [W17]: pi exact in every row (each with its
    # own wheels), the end within 1e-6 of the fixed-step run at dt = 0.025 (order 2 there:
    # ~1e-8 off).
    ada = trompo.control(sc, s0, 60.0, rtol=1e-9, atol=1e-9, period=0.5, controller=trompo.MrpPd(1, 5))
    loose = trompo.control(sc, s0, 60.0, rtol=1e-6, atol=1e-6, period=0.5, controller=trompo.MrpPd(1, 5))
    fine = trompo.control(sc, s0, 60.0, dt=0.025, period=0.5, controller=trompo.MrpPd(1, 5), every=10**6)
    assert ada.success and loose.success and ada.nsteps > 2 * loose.nsteps
    assert np.max(np.abs(ada.pi - ada.pi[0])) <= 1e-13 * np.linalg.norm(ada.pi[0])
    assert np.max(np.abs(ada.R[-1] - fine.R[-1])) <= 1e-6
    # t_eval, an event function and dense output see the friction (W17.a-b): rows inside the
    # holds within 3e-7 of the converged run at the same times, the wheels' speeds too
    # (measured 7.1e-8, the order-2 run's own error), and pi at them within 1e-12 of pi0
    # (measured 1.8e-14; with the wheels' line at the step's end moved by u alone, the
    # friction left out, ~1e-4); the event at its time; sol(t) the t_eval row's bits.
    times = [0.3, 7.65, 30.1, 59.9]
    at = trompo.control(sc, s0, 60.0, rtol=1e-10, atol=1e-10, period=0.5, controller=trompo.MrpPd(1, 5),
                        t_eval=times, events=[lambda t, y: t - 7.3], dense_output=True)
    ref = trompo.control(sc, s0, 60.0, dt=0.025, period=0.5, order=6, controller=trompo.MrpPd(1, 5))
    assert at.t.tolist() == times
    for k, t in enumerate(times):
        j = int(np.argmin(np.abs(ref.t - t)))
        assert abs(ref.t[j] - t) <= 1e-9
        assert np.max(np.abs(at.R[k] - ref.R[j])) <= 3e-7
        assert np.max(np.abs(at.W[k] - ref.W[j])) <= 3e-7
        assert np.max(np.abs(at.wheel_speeds[k] - ref.wheel_speeds[j])) <= 3e-7
        assert np.linalg.norm(at.pi[k] - ref.pi[0]) <= 1e-12 * np.linalg.norm(ref.pi[0])
    assert len(at.t_events[0]) == 1 and abs(at.t_events[0][0] - 7.3) <= 1e-12
    j = int(np.argmin(np.abs(ref.t - 7.3)))  # the state at the event, from its step's interpolant
    assert abs(ref.t[j] - 7.3) <= 1e-9
    assert np.max(np.abs(at.y_events[0][0][:9] - ref.R[j].ravel())) <= 3e-7
    assert np.max(np.abs(at.y_events[0][0][9:] - ref.W[j])) <= 3e-7
    np.testing.assert_array_equal(at.sol(7.65)[:9], at.R[1].ravel())
    np.testing.assert_array_equal(at.sol(7.65)[9:], at.W[1])


def test_the_builtin_controller_gives_the_cli_rows(tmp_path):
    """trompo.control with MrpPd runs trompo-simulate's control path: the CLI's rows, wheel
    columns included, bit for bit (identity start: the same quaternion both ways)."""
    from conftest import cli_path
    import subprocess
    sc, _ = basilisk()
    s0 = trompo.initial_state(rotation=np.eye(3), omega=(0.001, -0.01, 0.03))
    wheels = tmp_path / "wheels.csv"
    wheels.write_text("gx,gy,gz,Js,speed0,max_torque,max_speed\n" + "".join(
        f"{w.axis[0]!r},{w.axis[1]!r},{w.axis[2]!r},{w.Js!r},{w.speed0!r},{w.max_torque!r},{w.max_speed!r}\n"
        for w in sc.wheels))
    p = subprocess.run([cli_path(), "--inertia", "900,800,600", "--wheels", str(wheels), "--omega", "0.001,-0.01,0.03",
                        "--controller", "mrp-pd:3.5,30", "--control-period", "0.1", "--target-rotation", "0.1,0,0",
                        "--dt", "0.05", "--t-end", "5", "--order", "4"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert lines[0].endswith(",wheel1,wheel2,wheel3,u1,u2,u3")
    a = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    target = trompo.initial_state(rotvec=(0.1, 0, 0)).R  # not C++'s exp to the bit: give the CLI's
    res = trompo.control(sc, s0, 5.0, dt=0.05, period=0.1, order=4, controller=trompo.MrpPd(3.5, 30, target=target))
    assert len(res.t) == len(a) == 101
    np.testing.assert_allclose(res.R.reshape(-1, 9), a[:, 1:10], rtol=0, atol=1e-13)
    # without a target (identity both ways) the bits agree
    p = subprocess.run([cli_path(), "--inertia", "900,800,600", "--wheels", str(wheels), "--omega", "0.001,-0.01,0.03",
                        "--controller", "mrp-pd:3.5,30", "--control-period", "0.1", "--dt", "0.05", "--t-end", "5",
                        "--order", "4"], capture_output=True, text=True)
    a = np.array([[float(x) for x in line.split(",")] for line in p.stdout.splitlines()[1:]])
    res = trompo.control(sc, s0, 5.0, dt=0.05, period=0.1, order=4, controller=trompo.MrpPd(3.5, 30))
    np.testing.assert_array_equal(res.t, a[:, 0])
    np.testing.assert_array_equal(res.R.reshape(-1, 9), a[:, 1:10])
    np.testing.assert_array_equal(res.W, a[:, 10:13])
    np.testing.assert_array_equal(res.H, a[:, 13])
    np.testing.assert_array_equal(res.pi, a[:, 15:18])
    np.testing.assert_array_equal(res.wheel_speeds, a[:, 19:22])
    np.testing.assert_array_equal(res.u, a[:, 22:25])


def test_adaptive_steps_between_the_samples():
    """rtol: adaptive steps over each hold (a new run each hold), the controller still called
    exactly at the samples; the Python law bit for bit the built-in one; total momentum exact;
    rows at t_eval across the samples; a callable event located in the loop."""
    sc, s0 = basilisk()
    seen = []
    law = mrp_pd(3.5, 30.0)

    def f(t, R, W, wheel_speeds, memory):
        seen.append(t)
        return law(t, R, W, wheel_speeds, memory)

    run = dict(period=0.1, rtol=1e-10, atol=1e-10)
    python = trompo.control(sc, s0, 20.0, controller=f, **run)
    builtin = trompo.control(sc, s0, 20.0, controller=trompo.MrpPd(K=3.5, P=30), **run)
    assert python.success and python.method == "simo-kappa (order 2)" and python.nsteps > 0
    assert seen == [0.1 * k for k in range(200)]
    for key in ("t", "R", "W", "pi", "wheel_speeds", "u"):
        np.testing.assert_array_equal(python[key], builtin[key], err_msg=key)
    pi = builtin.pi
    assert np.max(np.linalg.norm(pi - pi[0], axis=1)) <= 1e-14 * np.linalg.norm(pi[0])
    # against a converged fixed-step run (order 4, dt = 1e-3): the tolerance holds
    ref = trompo.control(sc, s0, 20.0, controller=trompo.MrpPd(K=3.5, P=30), period=0.1, dt=1e-3, order=4, every=20000)
    assert np.max(np.abs(builtin.R[-1] - ref.R[-1])) <= 1e-8
    # t_eval across the samples, a callable event (the body rate Omega_1 through zero, near t = 1.6)
    crossing = lambda t, y: y[9]  # noqa: E731  (y: Λ row-major, then Ω)
    at = trompo.control(sc, s0, 20.0, controller=trompo.MrpPd(K=3.5, P=30), t_eval=[0, 0.05, 0.1, 10, 20],
                        events=[crossing], **run)
    assert at.t.tolist() == [0, 0.05, 0.1, 10, 20]
    np.testing.assert_array_equal(at.R[-1], builtin.R[-1])
    np.testing.assert_array_equal(at.R[2], builtin.R[builtin.t.tolist().index(0.1)])
    assert len(at.t_events[0]) >= 1
    for t, y in zip(at.t_events[0], at.y_events[0]):
        assert abs(y[9]) <= 1e-12 and 1 < t < 20
    # dense output across the samples: the run again with rows at t (a Python controller from
    # a fresh memory), so sol(t) is the t_eval run's row at t, bit for bit
    dense = trompo.control(sc, s0, 20.0, controller=mrp_pd(3.5, 30.0), dense_output=True, **run)
    y = dense.sol([0.05, 10.0, 20.0])
    assert y.shape == (12, 3)
    for k, j in enumerate((1, 3, 4)):
        np.testing.assert_array_equal(y[:9, k], at.R[j].ravel())
        np.testing.assert_array_equal(y[9:, k], at.W[j])
    np.testing.assert_array_equal(dense.sol(20.0)[:9], builtin.R[-1].ravel())
    # a terminal event function would end a hold, not the run (the next samples off the grid
    # k * period): refused, as the CLI refuses --event NAME:terminal
    stop = lambda t, y: y[9]  # noqa: E731
    stop.terminal = True
    with pytest.raises(ValueError, match="^events\\[1\\]\\.terminal: a terminal event would end a hold"):
        trompo.control(sc, s0, 1.0, controller=trompo.MrpPd(K=3.5, P=30), events=[crossing, stop], **run)
    with pytest.raises(ValueError, match="^t_eval: only with adaptive steps"):
        trompo.control(sc, s0, 1.0, controller=trompo.MrpPd(K=3.5, P=30), period=0.1, dt=0.05, t_eval=[0.5])
    with pytest.raises(ValueError, match="^dt: required"):
        trompo.control(sc, s0, 1.0, controller=trompo.MrpPd(K=3.5, P=30), period=0.1)


def test_control_ensemble_members_are_their_single_runs():
    """trompo.control_ensemble: each member the last row of its own trompo.control run, bit for
    bit (state, H, pi, wheel speeds, held torques), on 1 and 2 threads; per-member inertia;
    B-dot members with max_step_angle; a Python callable is refused."""
    sc, _ = basilisk()
    om = np.array([[0.001, -0.01, 0.03], [0.01, 0.0, 0.0], [0.0, 0.0, 0.02]])
    starts = [trompo.initial_state(rotvec=r, omega=w) for r, w in zip([(0.1, 0.2, -0.3), (0.3, -0.1, 0.2), (0, 0, 1)], om)]
    rot = np.array([s.R for s in starts])  # (N, 3, 3): the members start from the single runs' matrices
    J = np.array([[900, 800, 600], [900, 800, 600], [700, 800, 900]], dtype=float)
    pd = trompo.MrpPd(3.5, 30, target=rotation_of_mrp((0.05, 0.0, 0.1)))
    kw = dict(dt=0.1, period=0.1, controller=pd)
    e1 = trompo.control_ensemble(sc, rot, om, 20.0, inertia=J, threads=1, **kw)
    e2 = trompo.control_ensemble(sc, rot, om, 20.0, inertia=J, threads=2, **kw)
    assert e1["ok"].all() and list(e1["status"]) == ["ok"] * 3 and (e1["samples"] == 200).all()
    for key in ("t", "R", "W", "H", "pi", "wheel_speeds", "u", "iterations"):
        assert np.array_equal(e1[key], e2[key]), key
    for i in range(3):
        craft = trompo.Spacecraft(J[i], wheels=sc.wheels)
        single = trompo.control(craft, starts[i], 20.0, every=10**6, **kw)
        assert np.array_equal(e1["R"][i], single.R[-1]) and np.array_equal(e1["W"][i], single.W[-1])
        assert e1["H"][i] == single.H[-1] and np.array_equal(e1["pi"][i], single.pi[-1])
        assert np.array_equal(e1["wheel_speeds"][i], single.wheel_speeds[-1])
        assert np.array_equal(e1["u"][i], single.u[-1])
    assert not np.array_equal(e1["R"][0], e1["R"][1])  # the members differ
    mag = trompo.Spacecraft([0.035, 0.034, 0.01], orbit=trompo.Orbit(6771e3, math.radians(51.6)), max_dipole=0.2)
    b = trompo.control_ensemble(mag, np.array([np.eye(3)] * 2), [[0.5, 0.5, 0.5], [0.2, -0.4, 0.1]], 30.0, dt=0.25, period=0.25,
                                controller=trompo.BDot(1e5), scheme="splitting", max_step_angle=0.05)
    single = trompo.control(mag, trompo.initial_state(rotvec=(0, 0, 0), omega=(0.5, 0.5, 0.5)), 30.0, dt=0.25,
                            period=0.25, controller=trompo.BDot(1e5), scheme="splitting", max_step_angle=0.05,
                            every=10**6)
    assert b["ok"].all() and b["wheel_speeds"].shape == (2, 0)
    assert np.array_equal(b["R"][0], single.R[-1]) and np.array_equal(b["W"][0], single.W[-1])
    # Adaptive holds (rtol): each member its single adaptive control run; progress reaches (N, N).
    calls = []
    a = trompo.control_ensemble(sc, rot, om, 5.0, inertia=J, rtol=1e-9, atol=1e-9, period=0.1, controller=pd,
                                order=4, progress=lambda k, n: calls.append((k, n)))
    single = trompo.control(trompo.Spacecraft(J[1], wheels=sc.wheels), starts[1], 5.0, rtol=1e-9, atol=1e-9, period=0.1,
                            controller=pd, order=4)
    assert a["ok"].all() and np.array_equal(a["R"][1], single.R[-1]) and np.array_equal(a["W"][1], single.W[-1])
    assert calls and calls[-1] == (3, 3)
    with pytest.raises(ValueError, match="controller: a closed-loop ensemble takes trompo.MrpPd or trompo.BDot"):
        trompo.control_ensemble(sc, rot, om, 1.0, dt=0.1, period=0.1, controller=mrp_pd(1, 5))
    with pytest.raises(ValueError, match="member 2: .*hub"):
        trompo.control_ensemble(sc, rot, om, 1.0, dt=0.1, period=0.1, controller=pd,
                                inertia=[[900, 800, 600], [900, 800, 600], [0.05, 0.05, 0.05]])


def test_the_engine_refuses_event_functions_that_control_refuses():
    """The engine's own check (check_control) sees the event functions too, since the binding
    adds them before it: a terminal one, with or without friction (control() refuses it
    first, in Python words; before, the engine never saw the functions, and a terminal one
    ended a hold and shifted the samples off k * period)."""
    s0 = trompo.initial_state(rotvec=(0, 0, 0), omega=(0.01, 0, 0))
    cases = ((0.0, 1, "^--event python-event-0: terminal: not in a control run"),
             (1e-3, 1, "^--event python-event-0: terminal: not in a control run"))
    for friction, terminal, message in cases:
        wheels = [trompo.Wheel(axis, 0.05, speed0=10.0, friction=friction) for axis in np.eye(3)]
        sc = trompo.Spacecraft([900, 800, 600], wheels=wheels)
        flags, target, fn = trompo._control_flags(sc, trompo.MrpPd(0, 0), 1.0, 0.5, None, 1e-8, "simo-kappa", 2,
                                                  None, None)
        flags.update({"--rtol": "1e-8", "--atol": "1e-8"})
        wheels, limits = trompo._wheel_arrays(sc)
        event = ("python-event-0", lambda t, y: t - 0.3, 0, terminal)
        with pytest.raises(ValueError, match=message):
            trompo._control_run(flags, wheels, limits, s0.R, s0.omega, target, fn, None, [event])
