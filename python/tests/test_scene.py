"""Scenes as objects (trompo.Scene, its effects, trompo.State): bit for bit the keywords'
runs, states from a matrix, a quaternion or a rotation vector agreeing, a Python torque law
(TorqueLaw) against the built-in effects and its own convergence order, and errors that
name the argument at fault."""
import math

import numpy as np
import pytest

import trompo
from conftest import same_rows

EPS = np.finfo(float).eps

# A general top: full inertia, gravity off the symmetry axis, every constant effect.
J = [[2.0, 0.1, 0.2], [0.1, 3.0, 0.3], [0.2, 0.3, 4.0]]
KEYWORDS = dict(inertia=J, mgl=7.5, com=(0.1, 0.2, 1), up=(0, 1, 1), damping=0.2, torque=(0.1, 0, 0),
                space_torque=(0, 0.2, 0), rotor=(0, 0, 1))


def general_scene():
    return trompo.Scene(trompo.RigidBody(J), trompo.Gravity(7.5, com=(0.1, 0.2, 1), up=(0, 1, 1)), trompo.Damping(0.2),
                        trompo.BodyTorque((0.1, 0, 0)), trompo.SpaceTorque((0, 0.2, 0)), trompo.Rotor((0, 0, 1)))


def test_a_scene_runs_bit_for_bit_as_its_keywords():
    state = trompo.initial_state(rotvec=[0.3, -0.2, 0.1], omega=[1, -2, 3])
    for scheme, order in (("simo-kappa", 2), ("splitting", 4), ("rk4", 2)):
        objects = trompo.simulate(general_scene(), state=state, scheme=scheme, order=order, dt=0.01, t_end=1)
        keywords = trompo.simulate(scheme=scheme, order=order, rotation=[0.3, -0.2, 0.1], omega=[1, -2, 3], dt=0.01,
                                   t_end=1, **KEYWORDS)
        assert same_rows(objects, keywords)
    # a satellite (the gravity gradient alone), principal moments
    sat = trompo.Scene(trompo.RigidBody([100, 120, 80]), trompo.GravityGradient(0.0011, radial=(1, 0, 0)))
    state = trompo.initial_state(rotvec=[0.3, -0.2, 0.5], omega=[0.05, 0.07, 0.04])
    assert same_rows(trompo.simulate(sat, state=state, dt=2, t_end=400, scheme="rk4"),
                     trompo.simulate(inertia=[100, 120, 80], gravity_gradient=0.0011, rotation=[0.3, -0.2, 0.5],
                                     omega=[0.05, 0.07, 0.04], dt=2, t_end=400, scheme="rk4"))


def test_solve_ivp_and_ensemble_take_a_scene():
    state = trompo.initial_state(rotvec=[0.4, 0, 0], omega=[0.3, 0.2, 9])
    top = trompo.Scene(trompo.RigidBody([4, 4, 1.3]), trompo.Gravity(25))
    a = trompo.solve_ivp(top, (0, 2), state, rtol=1e-8, atol=1e-8, events=["nutation-max"])
    b = trompo.solve_ivp(None, (0, 2), rtol=1e-8, atol=1e-8, events=["nutation-max"], inertia=[4, 4, 1.3], mgl=25,
                         rotation=[0.4, 0, 0], omega=[0.3, 0.2, 9])
    assert same_rows(a, b) and a.method == b.method and len(a.t_events[0]) > 0
    assert np.array_equal(a.t_events[0], b.t_events[0])
    # y0 as 12 numbers (solve_ivp's columns): the state of row 0 of y
    c = trompo.solve_ivp(top, (0, 2), a.y[:, 0], rtol=1e-8, atol=1e-8)
    assert np.allclose(c.y[:, -1], a.y[:, -1], rtol=0, atol=1e-7)
    rng = np.random.default_rng(3)
    rotation, omega = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    e1 = trompo.ensemble(rotation, omega, scene=general_scene(), dt=0.01, t_end=0.3)
    # each member bit for bit its single run from the same objects
    for i in range(5):
        one = trompo.simulate(general_scene(), state=trompo.initial_state(rotvec=rotation[i], omega=omega[i]), dt=0.01,
                              t_end=0.3)
        for key in ("t", "R", "W", "H", "pi"):
            assert np.array_equal(e1[key][i], one[key][-1]), (i, key)


def test_states_from_a_matrix_a_quaternion_and_a_rotation_vector_agree():
    v = np.array([0.3, -0.5, 0.7])
    angle = np.linalg.norm(v)
    q = np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * v / angle])  # scalar first, body -> space
    by_vector = trompo.initial_state(rotvec=v, omega=[1, 2, 3])
    by_quaternion = trompo.initial_state(quaternion=q, omega=[1, 2, 3])
    by_xyzw = trompo.initial_state(quaternion=np.roll(q, -1), scalar_first=False, omega=[1, 2, 3])
    by_matrix = trompo.initial_state(rotation=by_quaternion.R, omega=[1, 2, 3])
    for s in (by_quaternion, by_xyzw, by_matrix):
        assert np.max(np.abs(s.R - by_vector.R)) <= 4 * EPS
    runs = [trompo.simulate(general_scene(), state=s, dt=0.01, t_end=1) for s in (by_vector, by_quaternion, by_matrix)]
    for r in runs[1:]:
        assert np.max(np.abs(r["R"] - runs[0]["R"])) <= 1e-13
        assert np.max(np.abs(r["W"] - runs[0]["W"])) <= 1e-13
    # the matrix reaches the engine unrounded: row 0 is the matrix given, to the quaternion's round-off
    assert np.max(np.abs(runs[2]["R"][0] - by_matrix.R)) <= 4 * EPS


# ---- a torque law of your own (the slow path) ----
def test_a_torque_law_matches_the_built_in_effect_it_restates():
    """A constant body torque, a space torque and damping written as TorqueLaw agree with
    BodyTorque, SpaceTorque and Damping to the Newton tolerance (the same discrete torque at
    the mid configuration; only the Jacobians differ: differences against closed forms)."""
    state = trompo.initial_state(rotvec=[0.3, -0.2, 0.1], omega=[1, -2, 3])
    body = trompo.RigidBody([2, 3, 4])
    cases = [
        (trompo.BodyTorque((0.3, -0.1, 0.2)), trompo.TorqueLaw(lambda t, R, W: np.array([0.3, -0.1, 0.2]))),
        (trompo.SpaceTorque((0.1, 0.2, -0.3)), trompo.TorqueLaw(lambda t, R, W: [0.1, 0.2, -0.3], axes="space")),
        (trompo.Damping(0.4), trompo.TorqueLaw(lambda t, R, W: -0.4 * W)),
    ]
    for builtin, law in cases:
        for scheme in ("simo-kappa", "simo-collocation", "rk4"):
            a = trompo.simulate(trompo.Scene(body, builtin), state=state, scheme=scheme, dt=0.01, t_end=2)
            b = trompo.simulate(trompo.Scene(body, law), state=state, scheme=scheme, dt=0.01, t_end=2)
            assert np.max(np.abs(a["R"] - b["R"])) <= 1e-12, (builtin, scheme)
            assert np.max(np.abs(a["W"] - b["W"])) <= 1e-12, (builtin, scheme)


def gravity_law(mgl, com):
    """The heavy top's gravity torque in body axes, -mgl c x (R^T e3) (the weight -mg e3
    at l c), as a law."""
    c = np.asarray(com, dtype=float) / np.linalg.norm(com)
    return lambda t, R, W: -mgl * np.cross(c, R[2])  # R^T e3 is R's third row


def test_a_torque_law_converges_at_order_2_to_the_heavy_top():
    """Gravity written as a body torque law (evaluated at the mid configuration, not the
    scheme's discrete gradient): its error against the converged heavy top falls as h^2
    (Simo-kappa) and h^4 (its order-4 composition)."""
    state = trompo.initial_state(rotvec=[0.3, 0, 0], omega=[0.5, -0.3, 8])
    top = trompo.Scene(trompo.RigidBody([4, 4, 1.3]), trompo.Gravity(25, com=(0.1, 0, 1)))
    law = trompo.Scene(trompo.RigidBody([4, 4, 1.3]), trompo.TorqueLaw(gravity_law(25, (0.1, 0, 1))))
    ref = trompo.simulate(top, state=state, order=6, dt=1e-3, t_end=1)["R"][-1]
    for order, hs, p in ((2, (0.02, 0.01, 0.005), 2), (4, (0.04, 0.02, 0.01), 4)):
        err = [np.linalg.norm(trompo.simulate(law, state=state, order=order, dt=h, t_end=1)["R"][-1] - ref) for h in hs]
        measured = [math.log2(err[k] / err[k + 1]) for k in range(2)]
        assert all(abs(m - p) <= 0.3 for m in measured), (order, err, measured)


def test_given_jacobians_agree_with_differences_and_save_calls():
    calls = {"law": 0, "jac": 0}
    c = np.array([0.1, 0, 1]) / np.linalg.norm([0.1, 0, 1])

    def law(t, R, W):
        calls["law"] += 1
        return -25 * np.cross(c, R[2]) - 0.1 * W

    def jac(t, R, W):
        # tau = -25 c x g - 0.1 W with g = R^T e3; under R exp(hat(w)), g -> g - w x g =
        # g + hat(g) w, so d tau / dw = -25 hat(c) hat(g); d tau / dW = -0.1 I
        calls["jac"] += 1
        g = R[2]
        hat = lambda v: np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])  # noqa: E731
        return -25 * hat(c) @ hat(g), -0.1 * np.eye(3)

    state = trompo.initial_state(rotvec=[0.3, 0, 0], omega=[0.5, -0.3, 8])
    body = trompo.RigidBody([4, 4, 1.3])
    by_differences = trompo.simulate(trompo.Scene(body, trompo.TorqueLaw(law)), state=state, dt=0.01, t_end=1)
    n_differences = calls["law"]
    calls["law"] = 0
    given = trompo.simulate(trompo.Scene(body, trompo.TorqueLaw(law, jacobian=jac)), state=state, dt=0.01, t_end=1)
    assert calls["jac"] > 0 and calls["law"] < n_differences / 3
    assert np.max(np.abs(given["R"] - by_differences["R"])) <= 1e-12
    assert np.array_equal(given["iterations"][1:] > 0, by_differences["iterations"][1:] > 0)


def test_adaptive_steps_with_a_torque_law_pick_simo_kappa():
    law = trompo.Scene(trompo.RigidBody([4, 4, 1.3]), trompo.TorqueLaw(gravity_law(25, (0, 0, 1))))
    top = trompo.Scene(trompo.RigidBody([4, 4, 1.3]), trompo.Gravity(25))
    y0 = trompo.initial_state(rotvec=[0.4, 0, 0], omega=[0.3, 0.2, 9])
    res = trompo.solve_ivp(law, (0, 1), y0, rtol=1e-8, atol=1e-8)
    assert res.success and res.method.startswith("simo-kappa kahan-li-9 (order 6), picked")
    exact = trompo.simulate(top, state=y0, scheme="exact", dt=1, t_end=1)
    assert np.linalg.norm(res.R[-1] - exact["R"][-1]) <= 10 * 1e-8


def test_a_torque_law_that_raises_or_returns_garbage():
    body = trompo.RigidBody([2, 3, 4])
    state = trompo.initial_state(rotvec=[0.1, 0, 0], omega=[1, 2, 3])

    class Boom(Exception):
        pass

    def boom(t, R, W):
        if t > 0.05:
            raise Boom("at t > 0.05")
        return np.zeros(3)

    with pytest.raises(Boom, match="at t > 0.05") as e:
        trompo.simulate(trompo.Scene(body, trompo.TorqueLaw(boom)), state=state, dt=0.01, t_end=1)
    assert any(frame.name == "boom" for frame in e.traceback)  # the law's own frame, kept
    with pytest.raises(ValueError, match="^TorqueLaw: the law must return 3 numbers"):
        trompo.simulate(trompo.Scene(body, trompo.TorqueLaw(lambda t, R, W: [1, 2])), state=state, dt=0.01, t_end=1)
    with pytest.raises(trompo.StepFailed) as failed:
        trompo.simulate(trompo.Scene(body, trompo.TorqueLaw(lambda t, R, W: [math.nan, 0, 0] if t > 0.05 else [0, 0, 0])),
                        state=state, scheme="rk4", dt=0.01, t_end=1)
    assert failed.value.t == pytest.approx(0.05) and "non-finite" in str(failed.value)
    with pytest.raises(ValueError, match="^TorqueLaw: runs with scheme simo-kappa, simo-collocation"):
        trompo.simulate(trompo.Scene(body, trompo.TorqueLaw(boom)), state=state, scheme="geradin-bauchau", dt=0.01,
                        t_end=1)
    with pytest.raises(ValueError, match="^scene: a TorqueLaw cannot run in an ensemble"):
        trompo.ensemble(np.zeros((2, 3)), np.ones((2, 3)), scene=trompo.Scene(body, trompo.TorqueLaw(boom)), dt=0.01,
                        t_end=0.1)


# ---- errors in Python's words ----
def test_objects_name_the_argument_at_fault():
    with pytest.raises(ValueError, match=r"^RigidBody.inertia: not positive definite"):
        trompo.RigidBody([1, -2, 3])
    with pytest.raises(ValueError, match=r"^Gravity.mgl: must be finite, got nan"):
        trompo.Gravity(float("nan"))
    with pytest.raises(ValueError, match=r"^Gravity.com: must be non-zero"):
        trompo.Gravity(1, com=(0, 0, 0))
    with pytest.raises(ValueError, match=r"^Damping.C: negative coefficient -1.0 feeds energy in"):
        trompo.Damping(-1)
    with pytest.raises(ValueError, match=r"^GravityGradient.rate: must be > 0"):
        trompo.GravityGradient(0)
    with pytest.raises(ValueError, match=r"^TorqueLaw.axes: 'body' or 'space'"):
        trompo.TorqueLaw(lambda t, R, W: W, axes="inertial")
    with pytest.raises(ValueError, match=r"^Scene: two Damping \(effects\[0\] and effects\[1\]\)"):
        trompo.Scene([1, 2, 3], trompo.Damping(1), trompo.Damping(2))
    with pytest.raises(ValueError, match=r"^Scene: a GravityGradient scene \(a satellite\) has that effect alone"):
        trompo.Scene([1, 2, 3], trompo.GravityGradient(1e-3), trompo.Damping(1))
    with pytest.raises(ValueError, match=r"^y0\[:9\] \(R row-major\): not a rotation matrix"):
        trompo.solve_ivp(trompo.Scene([1, 2, 3]), (0, 1), np.arange(12.0))
    with pytest.raises(TypeError, match=r"^simulate\(\): 'mgl' is given by the scene too"):
        trompo.simulate(trompo.Scene([1, 2, 3], trompo.Gravity(1)), mgl=2, dt=0.1, t_end=1)
    with pytest.raises(TypeError, match=r"^simulate\(\): 'omega' is given by the state too"):
        trompo.simulate("ht1", state=trompo.initial_state(rotvec=[0, 0, 0]), omega=[1, 2, 3])
    # the engine's messages name the keyword, not the CLI's flag
    with pytest.raises(ValueError, match=r"^dt: required \(or give case, or rtol for adaptive steps\)$"):
        trompo.simulate(trompo.Scene([1, 2, 3]), t_end=1)
    with pytest.raises(ValueError, match=r"^first_step: must be non-zero, got 0"):
        trompo.solve_ivp("ht1", (0, 1), rtol=1e-6, first_step=0)
