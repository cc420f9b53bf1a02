"""Scenes as objects: a rigid body, the effects acting on it, and an initial state.

    scene = trompo.Scene(trompo.RigidBody([4, 4, 1.3]), trompo.Gravity(mgl=25),
                         trompo.Damping(0.01), trompo.TorqueLaw(my_torque))
    rows = trompo.simulate(scene, state=trompo.initial_state(rotvec=[0.1, 0, 0], omega=[0, 0, 9]),
                           dt=1e-3, t_end=20)

Every object checks its own numbers and names the argument at fault (ValueError). A scene
without a TorqueLaw runs exactly as the same keywords would (the same engine, the same
numbers, bit for bit); a TorqueLaw is Python code called at every evaluation of the torque
(the slow path: docs/python.md, "A torque law of your own").
"""
import math
import numbers

import numpy as np

__all__ = ["RigidBody", "Gravity", "Damping", "BodyTorque", "SpaceTorque", "Rotor", "GravityGradient", "TorqueLaw",
           "Scene", "State", "initial_state"]


# ---- checks shared by the objects (the argument named in every message) ----
def _finite(name, x, *, positive=False, nonnegative=False, allow_inf=False):
    if isinstance(x, bool) or not isinstance(x, (numbers.Real, np.number)):
        raise ValueError(f"{name}: expected a number, got {x!r}")
    x = float(x)
    if math.isnan(x) or (math.isinf(x) and not (allow_inf and x > 0)):
        raise ValueError(f"{name}: must be finite{' or inf' if allow_inf else ''}, got {x!r}")
    if positive and not x > 0:
        raise ValueError(f"{name}: must be > 0, got {x!r}")
    if nonnegative and not x >= 0:
        raise ValueError(f"{name}: must be >= 0, got {x!r}")
    return x


def _array(name, x, shape):
    try:
        a = np.array(x, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected numbers of shape {shape}, got {x!r}") from None
    if a.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: must be finite, got {a.tolist()}")
    return a


def _nonzero(name, x):
    a = _array(name, x, (3,))
    if not np.any(a != 0):
        raise ValueError(f"{name}: must be non-zero")
    return a


def _rotation_matrix(name, x):
    a = _array(name, x, (3, 3))
    err = np.max(np.abs(a.T @ a - np.eye(3)))
    if not err <= 1e-9 or not np.linalg.det(a) > 0:
        raise ValueError(f"{name}: not a rotation matrix (max|R^T R - I| = {err:.3g}, det = {np.linalg.det(a):.6g})")
    return a


def _inertia(name, inertia):
    """A symmetric positive-definite 3x3 array from 3 principal moments or a 3x3 array."""
    try:
        J = np.array(inertia, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected 3 principal moments or a 3x3 array, got {inertia!r}") from None
    if J.shape == (3,):
        J = np.diag(J)
    if J.shape != (3, 3):
        raise ValueError(f"{name}: expected 3 principal moments or a 3x3 array, got shape {J.shape}")
    if not np.all(np.isfinite(J)):
        raise ValueError(f"{name}: must be finite, got {J.tolist()}")
    if not np.array_equal(J, J.T):
        raise ValueError(f"{name}: not symmetric: {J.tolist()}")
    if not np.all(np.linalg.eigvalsh(J) > 0):
        raise ValueError(f"{name}: not positive definite: {J.tolist()}")
    return J


def _text(v):
    """Numbers as the engine reads them: repr of a float is its shortest round-trip form."""
    return ",".join(repr(float(x)) for x in np.ravel(v))


# ---- the body ----
class RigidBody:
    """A rigid body: ``inertia`` about the fixed point (heavy top) or the centre of mass,
    three principal moments (J1, J2, J3) or a symmetric 3x3 array, in kg m^2. Physical
    bodies satisfy the triangle inequalities J_i + J_j >= J_k (the engine says so if not)."""

    def __init__(self, inertia):
        self.inertia = _inertia("RigidBody.inertia", inertia)

    def _flags(self):
        J = self.inertia
        if np.count_nonzero(J - np.diag(np.diag(J))) == 0:
            return {"--inertia": _text(np.diag(J))}
        return {"--inertia": _text([J[0, 0], J[1, 1], J[2, 2], J[0, 1], J[0, 2], J[1, 2]])}

    def __repr__(self):
        return f"RigidBody(inertia={self.inertia.tolist()})"


# ---- the effects (docs/scenes.md: what each adds to the equations) ----
class Gravity:
    """Uniform gravity on a heavy top: ``mgl`` the weight times the distance from the fixed
    point to the centre of mass (N m), ``com`` the direction of the centre of mass in body
    axes and ``up`` the vertical in space axes (both normalised by the engine)."""

    def __init__(self, mgl, com=(0.0, 0.0, 1.0), up=(0.0, 0.0, 1.0)):
        self.mgl = _finite("Gravity.mgl", mgl)
        self.com = _nonzero("Gravity.com", com)
        self.up = _nonzero("Gravity.up", up)

    def _flags(self):
        return {"--mgl": repr(self.mgl), "--com": _text(self.com), "--up": _text(self.up)}

    def __repr__(self):
        return f"Gravity(mgl={self.mgl!r}, com={self.com.tolist()}, up={self.up.tolist()})"


class Damping:
    """Viscous damping, torque -C Omega in body axes (N m s). ``C < 0`` feeds energy in; it
    is refused unless ``allow_negative=True``."""

    def __init__(self, C, allow_negative=False):
        self.C = _finite("Damping.C", C)
        if self.C < 0 and not allow_negative:
            raise ValueError(f"Damping.C: negative coefficient {self.C!r} feeds energy in; give allow_negative=True "
                             "to run it anyway")
        self.allow_negative = bool(allow_negative)

    def _flags(self):
        flags = {"--damping": repr(self.C)}
        if self.allow_negative:
            flags["--allow-negative-damping"] = ""
        return flags

    def __repr__(self):
        return f"Damping(C={self.C!r})"


class BodyTorque:
    """A constant torque in body axes (N m): a thruster fixed to the body."""

    def __init__(self, torque):
        self.torque = _array("BodyTorque.torque", torque, (3,))

    def _flags(self):
        return {"--torque": _text(self.torque)}

    def __repr__(self):
        return f"BodyTorque(torque={self.torque.tolist()})"


class SpaceTorque:
    """A constant torque in space axes (N m): a disturbance fixed in inertial space."""

    def __init__(self, torque):
        self.torque = _array("SpaceTorque.torque", torque, (3,))

    def _flags(self):
        return {"--space-torque": _text(self.torque)}

    def __repr__(self):
        return f"SpaceTorque(torque={self.torque.tolist()})"


class Rotor:
    """An internal rotor of constant angular momentum ``h`` in body axes (N m s): a gyrostat."""

    def __init__(self, h):
        self.h = _array("Rotor.h", h, (3,))

    def _flags(self):
        return {"--rotor": _text(self.h)}

    def __repr__(self):
        return f"Rotor(h={self.h.tolist()})"


class GravityGradient:
    """The gravity-gradient torque of a circular orbit of mean motion ``rate`` (rad/s), the
    orbit's normal and the radial direction at t = 0 in space axes (docs/spacecraft.md). A
    satellite's scene has this effect alone; its H column is the Jacobi integral."""

    def __init__(self, rate, orbit_normal=(0.0, 0.0, 1.0), radial=(1.0, 0.0, 0.0)):
        self.rate = _finite("GravityGradient.rate", rate, positive=True)
        self.orbit_normal = _nonzero("GravityGradient.orbit_normal", orbit_normal)
        self.radial = _nonzero("GravityGradient.radial", radial)

    def _flags(self):
        return {"--gravity-gradient": repr(self.rate), "--orbit-normal": _text(self.orbit_normal),
                "--radial": _text(self.radial)}

    def __repr__(self):
        return (f"GravityGradient(rate={self.rate!r}, orbit_normal={self.orbit_normal.tolist()}, "
                f"radial={self.radial.tolist()})")


class TorqueLaw:
    """A torque law of your own, ``torque(t, R, W) -> 3 numbers`` (N m): ``R`` the (3, 3)
    rotation body -> space, ``W`` the body angular velocity (3,); ``axes`` "body" or "space",
    the axes of the returned torque.

    The implicit schemes need its Jacobians: give ``jacobian(t, R, W) -> (D_w, D_W)``, two
    3x3 arrays in the law's axes, D_w the derivative along the right perturbation
    R exp(hat(w)) at w = 0 and D_W along W; without it they come from central differences of
    the law (12 more calls). The law is called by C++ with the interpreter's lock taken at
    every evaluation: the slow path (docs/python.md gives its cost per step). It runs with
    the schemes simo-kappa and simo-collocation (any order or composition) and rk4; an
    exception raised in it ends the run and is raised again by the driver."""

    def __init__(self, torque, axes="body", jacobian=None):
        if not callable(torque):
            raise ValueError(f"TorqueLaw.torque: expected a callable torque(t, R, W), got {torque!r}")
        if axes not in ("body", "space"):
            raise ValueError(f"TorqueLaw.axes: 'body' or 'space', got {axes!r}")
        if jacobian is not None and not callable(jacobian):
            raise ValueError(f"TorqueLaw.jacobian: expected a callable jacobian(t, R, W) or None, got {jacobian!r}")
        self.torque, self.axes, self.jacobian = torque, axes, jacobian

    def __repr__(self):
        return f"TorqueLaw({self.torque!r}, axes={self.axes!r}, jacobian={self.jacobian!r})"


_EFFECTS = (Gravity, Damping, BodyTorque, SpaceTorque, Rotor, GravityGradient, TorqueLaw)


class Scene:
    """A body and the effects acting on it: ``Scene(body, *effects)``, ``body`` a RigidBody
    (or its inertia), each effect one of Gravity, Damping, BodyTorque, SpaceTorque, Rotor,
    GravityGradient (alone: a satellite) and TorqueLaw (one per axes); at most one of each
    other kind. simulate(), solve_ivp() and ensemble() take it in place of a case's name."""

    def __init__(self, body, *effects):
        self.body = body if isinstance(body, RigidBody) else RigidBody(body)
        seen = {}
        for i, e in enumerate(effects):
            if not isinstance(e, _EFFECTS):
                names = ", ".join(k.__name__ for k in _EFFECTS)
                raise ValueError(f"Scene: effects[{i}] is not an effect ({names}), got {e!r}")
            key = (type(e), e.axes) if isinstance(e, TorqueLaw) else type(e)
            if key in seen:
                what = f"TorqueLaw in {e.axes} axes" if isinstance(e, TorqueLaw) else type(e).__name__
                raise ValueError(f"Scene: two {what} (effects[{seen[key]}] and effects[{i}]); give their sum as one")
            seen[key] = i
        if GravityGradient in seen and len(seen) > 1:
            raise ValueError("Scene: a GravityGradient scene (a satellite) has that effect alone")
        self.effects = tuple(effects)

    def effect(self, kind, axes=None):
        """The effect of type ``kind`` (for a TorqueLaw, of ``axes``), or None."""
        return next((e for e in self.effects if isinstance(e, kind) and (axes is None or e.axes == axes)), None)

    def _flags(self):
        flags = self.body._flags()
        for e in self.effects:
            if not isinstance(e, TorqueLaw):
                flags.update(e._flags())
        return flags

    def _laws(self):
        """(body law, its jacobian, space law, its jacobian) for the engine, or None."""
        body, space = self.effect(TorqueLaw, "body"), self.effect(TorqueLaw, "space")
        if body is None and space is None:
            return None
        return (body and body.torque, body and body.jacobian, space and space.torque, space and space.jacobian)

    def __repr__(self):
        return "Scene(" + ", ".join([repr(self.body)] + [repr(e) for e in self.effects]) + ")"


# ---- the initial state ----
class State:
    """An initial state: ``R`` (3,3) body -> space (a body vector's space components are
    R @ v) and ``omega`` (3,) the body angular velocity (rad/s, body axes). Made by
    initial_state(); ``rotvec`` is kept when the state was given by one, so that it reaches
    the engine unrounded (as the CLI's --rotation)."""

    def __init__(self, R, omega, rotvec=None):
        self.R = R
        self.omega = omega
        self.rotvec = rotvec

    @property
    def y(self):
        """The state as solve_ivp's columns: R row-major, then omega (12,)."""
        return np.concatenate([np.asarray(self.R).ravel(), self.omega])

    def __repr__(self):
        return f"State(R={self.R.tolist()}, omega={self.omega.tolist()})"


def _matrix_of_quaternion(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def initial_state(*, rotation=None, quaternion=None, scalar_first=True, rotvec=None, omega=(0.0, 0.0, 0.0)):
    """The initial state from exactly one of: ``rotation`` a 3x3 rotation matrix body ->
    space; ``quaternion`` body -> space, scalar first (w, x, y, z) by default as SciPy's
    ``Rotation.from_quat(q, scalar_first=True)`` (``scalar_first=False``: (x, y, z, w),
    SciPy's default), normalised; ``rotvec`` a rotation vector (angle * axis, radians) as
    SciPy's ``from_rotvec`` and the CLI's --rotation. ``omega``: body angular velocity."""
    given = [n for n, v in (("rotation", rotation), ("quaternion", quaternion), ("rotvec", rotvec)) if v is not None]
    if len(given) != 1:
        raise ValueError("initial_state: give exactly one of rotation, quaternion, rotvec"
                         + (f" (got {', '.join(given)})" if given else ""))
    kept = None
    if rotation is not None:
        R = _rotation_matrix("rotation", rotation)
    elif quaternion is not None:
        q = _array("quaternion", quaternion, (4,))
        if not scalar_first:
            q = np.roll(q, 1)
        n = np.linalg.norm(q)
        if not n > 0:
            raise ValueError("quaternion: must be non-zero")
        R = _matrix_of_quaternion(q / n)
    else:
        v = _array("rotvec", rotvec, (3,))
        kept = v
        angle = float(np.linalg.norm(v))
        K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
        if angle < 1e-8:  # the series, to round-off
            R = np.eye(3) + K + K @ K / 2
        else:
            R = np.eye(3) + math.sin(angle) / angle * K + (1 - math.cos(angle)) / angle ** 2 * (K @ K)
    return State(R, _array("omega", omega, (3,)), kept)


def state_of_y(name, y0):
    """A State from solve_ivp's y0: a State, or 12 numbers (R row-major, then omega)."""
    if isinstance(y0, State):
        return y0
    y = _array(name, y0, (12,))
    return State(_rotation_matrix(name + "[:9] (R row-major)", y[:9].reshape(3, 3)), y[9:].copy())
