"""trompo: structure-preserving integrators for rigid-body rotation, from Python.

simulate() runs one trajectory with trompo-simulate's flags as keywords (the CLI's own engine:
its rows bit for bit, as NumPy arrays), solve_ivp() adaptive steps with SciPy's vocabulary,
ensemble() many tops across cores, control() a spacecraft with a sampled controller in the loop.

The API is described once, in docs/python.md of the repository.
"""
import difflib
import functools
import math
import numbers
import os
import re
import sys
import tempfile
import warnings

#: The interpreter the extension was built for (CMake's Python3_EXECUTABLE).
BUILT_FOR = "@Python3_EXECUTABLE@"

try:
    import numpy as np
except ImportError as e:  # e.g. a pyenv or venv python3 without Debian's python3-numpy
    raise ImportError(f"trompo needs NumPy, which {sys.executable} cannot import; the module was built for "
                      f"{BUILT_FOR} (docs/python.md, 'Which interpreter')") from e

from ._trompo import control_run as _control_run
from ._trompo import ensemble_flags as _ensemble_flags
from ._trompo import simulate_flags as _simulate_flags
from ._trompo import usage as _usage
from ._trompo import __version__

__all__ = ["simulate", "solve_ivp", "ensemble", "StepFailed", "Recovered", "COLUMNS", "__version__",
           "control", "Wheel", "Orbit", "Spacecraft", "State", "initial_state", "MrpPd", "BDot", "ControlResult",
           "ControlError", "CommandError", "mrp"]

#: The keys of simulate()'s dict, in the CSV header's order (R is (n,3,3), W and pi (n,3)).
COLUMNS = ("t", "R", "W", "H", "mu", "pi", "iterations")


class StepFailed(RuntimeError):
    """A step failed and sub-stepping could not recover it (the CLI's exit status 3).

    ``rows`` holds every row up to the last good state (a dict like simulate()'s),
    ``t`` the time of that state, and the message says why, as the CLI's stderr does.
    """

    def __init__(self, message, rows):
        super().__init__(message)
        self.rows = rows
        self.t = float(rows["t"][-1]) if len(rows["t"]) else None


class Recovered(UserWarning):
    """Some intervals needed sub-stepping to succeed (the CLI says so on stderr)."""


def _number(name, x):
    if isinstance(x, str):
        return x
    if isinstance(x, bool) or not isinstance(x, (numbers.Real, np.number)):
        raise ValueError(f"--{name}: not a number: {x!r}")
    if isinstance(x, (numbers.Integral, np.integer)):
        return str(int(x))
    # repr of a float is its shortest round-trip form: strtod gives back the same double.
    return repr(float(x))


def _vector(name, x, sizes=(3,)):
    if isinstance(x, str):
        return x
    a = np.asarray(x, dtype=float)
    if name == "inertia" and a.shape == (3, 3):
        if not np.array_equal(a, a.T):
            raise ValueError(f"--inertia: not symmetric: {a.tolist()}")
        a = np.array([a[0, 0], a[1, 1], a[2, 2], a[0, 1], a[0, 2], a[1, 2]])
    if a.ndim != 1 or a.size not in sizes:
        want = " or ".join(str(s) for s in sizes)
        raise ValueError(f"--{name.replace('_', '-')}: expected {want} numbers, got shape {a.shape}")
    return ",".join(repr(float(v)) for v in a)


@functools.lru_cache(maxsize=None)
def _cli_keywords():
    """The CLI's flags as keywords (--t-end -> t_end), read from its --help: a flag the CLI
    gains is a keyword at once."""
    return frozenset(m.replace("-", "_") for m in re.findall(r"--([a-z][a-z0-9-]*)", _usage()))


def _check_keywords(function, extra, listed, refused=()):
    """TypeError, as Python's own for an unexpected keyword, for a keyword that is neither
    listed by `function` nor a CLI flag, with difflib's nearest known keywords."""
    known = (set(listed) | _cli_keywords()) - set(refused)
    for name in extra:
        if name in known:
            continue
        near = difflib.get_close_matches(name, sorted(known), n=3)
        hint = "; did you mean " + " or ".join(repr(x) for x in near) + "?" if near else ""
        raise TypeError(f"{function}() got an unexpected keyword argument {name!r}{hint}")


_SCALARS = ("alpha", "mgl", "dt", "t_end", "every", "order", "damping", "threads", "gravity_gradient")
_VECTORS = {"inertia": (3, 6), "com": (3,), "up": (3,), "rotation": (3,), "omega": (3,), "torque": (3,),
            "space_torque": (3,), "rotor": (3,), "orbit_normal": (3,), "radial": (3,)}
_WORDS = ("case", "scheme", "composition")


def _flags(kwargs):
    flags = {}
    for name, value in kwargs.items():
        if value is None:
            continue
        flag = "--" + name.replace("_", "-")
        if isinstance(value, (bool, np.bool_)):
            # A switch (energy_projection=True is --energy-projection); False leaves it out.
            if value:
                flags[flag] = ""
            continue
        if name in _WORDS:
            flags[flag] = str(value)
        elif name in _SCALARS:
            flags[flag] = _number(name.replace("_", "-"), value)
        elif name in _VECTORS:
            flags[flag] = _vector(name, value, _VECTORS[name])
        elif isinstance(value, str):
            # Any other keyword is passed on as the flag of that name: a flag the CLI gains
            # is usable from Python at once, and an unknown one is the CLI's error.
            flags[flag] = value
        elif isinstance(value, (numbers.Real, np.number)):
            flags[flag] = _number(name.replace("_", "-"), value)
        else:
            a = np.asarray(value, dtype=float).ravel()
            flags[flag] = ",".join(repr(float(v)) for v in a)
    return flags


def simulate(case=None, *, scheme=None, alpha=None, order=None, composition=None, inertia=None, mgl=None,
             com=None, up=None, rotation=None, omega=None, dt=None, t_end=None, every=None, damping=None,
             torque=None, space_torque=None, rotor=None, gravity_gradient=None, orbit_normal=None, radial=None,
             **flags):
    """One trajectory, as ``trompo-simulate`` with the same flags (``t_end`` is ``--t-end``).

    Returns a dict of NumPy arrays keyed like the CSV header (``t``, ``R``, ``W``, ``H``,
    ``mu``, ``pi``, ``iterations``); raises ValueError with the CLI's message, StepFailed
    when a step fails beyond recovery. docs/python.md, "trompo.simulate".
    """
    kwargs = dict(case=case, scheme=scheme, alpha=alpha, order=order, composition=composition, inertia=inertia,
                  mgl=mgl, com=com, up=up, rotation=rotation, omega=omega, dt=dt, t_end=t_end, every=every,
                  damping=damping, torque=torque, space_torque=space_torque, rotor=rotor,
                  gravity_gradient=gravity_gradient, orbit_normal=orbit_normal, radial=radial, **flags)
    for name in ("ensemble", "csv", "threads"):
        if name in flags:
            raise TypeError(f"simulate: {name!r} is not for simulate (see trompo.ensemble)")
    _check_keywords("simulate", flags, simulate.__code__.co_varnames[:simulate.__code__.co_argcount +
                                                                      simulate.__code__.co_kwonlyargcount])
    status, rows, messages = _simulate_flags(_flags(kwargs))
    if status == 3:
        raise StepFailed(messages[-1], rows)
    for m in messages:
        warnings.warn(m, Recovered, stacklevel=2)
    return rows


# ---- adaptive steps (docs/adaptive.md) ----
class OdeResult(dict):
    """solve_ivp's result, a dict with attribute access as SciPy's: t, y, sol, t_events,
    y_events, status, message, success, and R, W, H, mu, pi, iterations (per row, as
    simulate()'s), nsteps, nreject, nfail and niter (all Newton iterations)."""

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None


_SUMMARY = re.compile(r"adaptive \((\w+), rtol [^,]*, atol [^)]*\): (\d+) accepted, (\d+) rejected, (\d+) failed attempts, "
                      r"(\d+) Newton iterations; (.*)")


def solve_ivp(case=None, t_span=None, *, rtol=1e-3, atol=1e-6, t_eval=None, events=None, first_step=None,
              control="tolerance", dense_output=False, **flags):
    """Adaptive steps with SciPy's vocabulary, through trompo-simulate's own engine (bit for
    bit the rows of ``trompo-simulate --rtol R --atol A ...`` with the same flags).

    Returns an OdeResult (``t``, ``y``, ``t_events``, ``y_events``, ``status``, ``sol``, ...);
    trompo's tolerances bound the error at the end of the span. docs/python.md,
    "trompo.solve_ivp: adaptive steps".
    """
    kwargs = dict(case=case, rtol=rtol, atol=atol, control=control, dt=first_step, **flags)
    for name in ("ensemble", "csv", "threads", "t_end", "event_csv", "every"):
        if name in flags:
            raise TypeError(f"solve_ivp: {name!r} is not a solve_ivp argument")
    _check_keywords("solve_ivp", flags, ("case", "t_span", "rtol", "atol", "t_eval", "events", "first_step", "control",
                                         "dense_output"))
    t0, t1 = 0.0, None
    if t_span is not None:
        t0, t1 = (float(x) for x in t_span)
        if not (np.isfinite(t0) and np.isfinite(t1)):
            raise ValueError(f"t_span: must be finite, got {t_span!r}")
        if t0 != 0.0 and (flags.get("gravity_gradient") is not None or str(case).startswith("sat")):
            # a satellite's orbit frame turns with t (radial direction given at t = 0)
            raise ValueError("t_span: t0 != 0 needs a scene without time dependence (not a satellite)")
        kwargs["t_end"] = t1 - t0  # the autonomous run from 0 (docstring)
    if t_eval is not None:
        t_eval = np.atleast_1d(np.asarray(t_eval, dtype=float))
        kwargs["t_eval"] = ",".join(repr(float(v - t0)) for v in t_eval)
    names = []       # per event, in the order given: the name its rows carry
    code_events = []  # the callables: (name, g, direction, terminal)
    if events is not None:
        if callable(events) or isinstance(events, str) or not isinstance(events, (list, tuple)):
            events = [events]
        items = []
        for i, e in enumerate(events):
            terminal = int(getattr(e, "terminal", 0))  # True counts as 1
            if terminal < 0:
                raise ValueError(f"events[{i}].terminal: must be a bool or a count >= 0, got {terminal!r}")
            if isinstance(e, str) or (hasattr(e, "name") and isinstance(e.name, str) and not callable(e)):
                name = e if isinstance(e, str) else e.name
                if getattr(e, "direction", 0) not in (0,):
                    raise ValueError("solve_ivp: the built-in events carry their own direction")
                names.append(name)
                items.append(name if terminal == 0 else f"{name}:terminal:{terminal}")
            elif callable(e):
                direction = getattr(e, "direction", 0)
                if direction not in (-1, 0, 1):  # -1.0, 0.0 and 1.0 compare equal too
                    raise ValueError(f"events[{i}].direction: must be -1, 0 or 1, got {direction!r}")
                name = f"python-event-{i}"
                names.append(name)
                code_events.append((name, _event_function(e, t0), int(direction), terminal))
            else:
                raise TypeError(f"events[{i}]: expected a built-in name or a callable g(t, y), got {e!r}")
        if items:
            kwargs["event"] = ";".join(items)
    fd, event_path = tempfile.mkstemp(suffix=".csv")
    os.close(fd)
    try:
        if names:
            kwargs["event_csv"] = event_path
        status, rows, messages = _simulate_flags(_flags(kwargs), code_events or None)
        event_rows = []
        if names:
            with open(event_path) as f:
                next(f)
                event_rows = [line.rstrip("\n").split(",") for line in f]
    finally:
        os.unlink(event_path)
    m = next((_SUMMARY.match(x) for x in messages if _SUMMARY.match(x)), None)
    if m is None:
        raise RuntimeError("solve_ivp: no summary from the engine: " + "; ".join(messages))
    ended = m.group(6)
    code = 1 if ended == "stopped by a terminal event" else 0 if ended == "reached t_end" else -1
    n = len(rows["t"])
    res = OdeResult(rows)
    if t_eval is not None:
        res["t"] = t_eval[:n].copy()  # the times as given (a terminal event may cut the list)
    elif t0 != 0.0:
        res["t"] = rows["t"] + t0
        if t1 is not None and rows["t"][-1] == t1 - t0:
            res["t"][-1] = t1
    res["y"] = _column_states(rows).T.copy()
    res["sol"] = None
    if dense_output and n:
        # the run's span: from t0 to its last state (t_end, or the terminal event)
        if t_eval is None:
            t_last = float(res["t"][-1])
        elif code == 1 and event_rows:
            t_last = float(event_rows[-1][1]) + t0
        else:
            t_last = t1 if t1 is not None else float(t_eval[-1])
        res["sol"] = _dense_solution(kwargs, t0, t0, t_last, code_events or None)
    res["t_events"], res["y_events"] = [], []
    for name in names:
        sel = [r for r in event_rows if r[0] == name]
        res["t_events"].append(np.array([float(r[1]) + t0 for r in sel]))
        res["y_events"].append(np.array([[float(v) for v in r[2:14]] for r in sel]).reshape(len(sel), 12))
    res["status"] = code
    res["success"] = code >= 0
    res["message"] = {1: "A termination event occurred.",
                      0: "The solver successfully reached the end of the integration interval."}.get(code, ended)
    res["nsteps"], res["nreject"], res["nfail"], res["niter"] = (int(m.group(k)) for k in (2, 3, 4, 5))
    return res


def _event_function(e, t0):
    """g(t, y) -> float for the engine, at the user's time (the engine runs from 0)."""
    def g(t, y):
        return float(e(t + t0, y))
    return g


def _column_states(rows):
    """(n, 12): Λ row-major, then Ω, per row of the engine."""
    n = len(rows["t"])
    return np.concatenate([rows["R"].reshape(n, 9), rows["W"]], axis=1)


def _dense_solution(kwargs, t0, t_first, t_last, code_events=None):
    """solve_ivp's ``sol``: the run of ``kwargs`` again, with rows at the requested times."""
    kwargs = {k: v for k, v in kwargs.items() if k not in ("t_eval", "event_csv")}
    lo, hi = min(t_first, t_last), max(t_first, t_last)

    def sol(t):
        ts = np.asarray(t, dtype=float)
        flat = np.atleast_1d(ts).ravel()
        if flat.size == 0:
            return np.empty((12, 0))
        if not np.all(np.isfinite(flat)) or flat.min() < lo or flat.max() > hi:
            raise ValueError(f"sol: t must lie in the run's span [{lo!r}, {hi!r}]")
        times = np.unique(flat)  # increasing; the engine wants the order of integration
        if t_last < t_first:
            times = times[::-1]
        # the same events: a terminal one ends this run at the same step, as the first
        status, rows, messages = _simulate_flags(_flags(dict(kwargs, t_eval=",".join(repr(float(v - t0)) for v in times))),
                                                 code_events)
        if len(rows["t"]) != len(times):
            raise RuntimeError("sol: the engine gave %d of %d rows: %s" % (len(rows["t"]), len(times), "; ".join(messages)))
        y = _column_states(rows)[np.searchsorted(times, flat) if t_last >= t_first
                                 else len(times) - 1 - np.searchsorted(times[::-1], flat)]
        return y[0] if ts.ndim == 0 else y.T.reshape((12,) + ts.shape)

    return sol
# ---- end adaptive ----


def ensemble(rotation, omega, *, mgl=None, inertia=None, case=None, scheme=None, alpha=None, order=None,
             composition=None, com=None, up=None, dt=None, t_end=None, damping=None, torque=None,
             space_torque=None, rotor=None, threads=0, progress=False, **flags):
    """N independent trajectories from t = 0 to ``t_end``, across ``threads`` cores (0: all).

    ``rotation`` (N,3) or (N,3,3), ``omega`` (N,3), optional per-member ``mgl`` and ``inertia``;
    the other keywords are simulate()'s. Returns a dict of arrays, one entry per member, each
    bit-identical to its single run; a failed member raises nothing (``ok``, ``status``).
    docs/python.md, "Python: trompo.ensemble".
    """
    kwargs = dict(case=case, scheme=scheme, alpha=alpha, order=order, composition=composition, com=com, up=up,
                  dt=dt, t_end=t_end, damping=damping, torque=torque, space_torque=space_torque, rotor=rotor,
                  threads=threads, **flags)
    for name in ("ensemble", "csv", "every"):
        if name in flags:
            raise TypeError(f"ensemble: {name!r} is not for ensemble")
    _check_keywords("ensemble", flags, ("rotation", "omega", "mgl", "inertia", "progress"))
    flags = _flags(kwargs)
    flags["--ensemble"] = "(arrays)"
    rotation = np.asarray(rotation, dtype=float)
    omega = np.asarray(omega, dtype=float)
    if mgl is not None:
        mgl = np.asarray(mgl, dtype=float)
    if inertia is not None:
        inertia = np.asarray(inertia, dtype=float)
    if not progress:
        return _ensemble_flags(flags, rotation, omega, mgl, inertia)
    report = progress if callable(progress) else (lambda k, n: print(f"ensemble: {k}/{n} members", file=sys.stderr))
    n = len(rotation)
    size = max(1, -(-n // 20))
    parts = []
    for lo in range(0, n, size):
        hi = min(n, lo + size)
        parts.append(_ensemble_flags(flags, rotation[lo:hi], omega[lo:hi], None if mgl is None else mgl[lo:hi],
                                     None if inertia is None else inertia[lo:hi]))
        report(hi, n)
    if not parts:  # N = 0: the engine's own error
        return _ensemble_flags(flags, rotation, omega, mgl, inertia)
    out = {}
    for key, first in parts[0].items():
        out[key] = [x for p in parts for x in p[key]] if isinstance(first, list) else np.concatenate([p[key] for p in parts])
    return out


def usage():
    """trompo-simulate --help: the vocabulary of simulate()'s keywords."""
    return _usage()


# ---- control in the loop (docs/python.md, "Control in the loop from Python") ----
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


def _rotation_matrix(name, x):
    a = _array(name, x, (3, 3))
    err = np.max(np.abs(a.T @ a - np.eye(3)))
    if not err <= 1e-9 or not np.linalg.det(a) > 0:
        raise ValueError(f"{name}: not a rotation matrix (max|R^T R - I| = {err:.3g}, det = {np.linalg.det(a):.6g})")
    return a


class Wheel:
    """A reaction wheel: spin ``axis`` in body axes (normalised by the engine), axial inertia
    ``Js`` (kg m^2), initial speed ``speed0`` relative to the body (rad/s), motor torque limit
    ``max_torque`` (N m) and speed limit ``max_speed`` (rad/s); ``inf``: no limit."""

    def __init__(self, axis, Js, speed0=0.0, max_torque=math.inf, max_speed=math.inf):
        self.axis = _array("axis", axis, (3,))
        if not np.any(self.axis != 0):
            raise ValueError("axis: must be non-zero")
        self.Js = _finite("Js", Js, positive=True)
        self.speed0 = _finite("speed0", speed0)
        self.max_torque = _finite("max_torque", max_torque, positive=True, allow_inf=True)
        self.max_speed = _finite("max_speed", max_speed, positive=True, allow_inf=True)

    def __repr__(self):
        return (f"Wheel(axis={self.axis.tolist()}, Js={self.Js!r}, speed0={self.speed0!r}, "
                f"max_torque={self.max_torque!r}, max_speed={self.max_speed!r})")


class Orbit:
    """A circular orbit of ``radius`` metres and ``inclination`` in RADIANS (the CLI's
    --orbit-inclination is in degrees): magnetorquers act in the Earth's dipole field along it
    (IGRF-13 2020.0 centred dipole, docs/control.md)."""

    def __init__(self, radius, inclination=0.0):
        self.radius = _finite("radius", radius, positive=True)
        self.inclination = _finite("inclination", inclination)

    def __repr__(self):
        return f"Orbit(radius={self.radius!r}, inclination={self.inclination!r})"


class Spacecraft:
    """The spacecraft: ``inertia`` the WHOLE spacecraft's (wheels included, as Basilisk's),
    three principal moments or a symmetric 3x3 array (kg m^2); ``wheels`` a sequence of
    Wheel (at most 8); ``orbit`` an Orbit for magnetorquers (None: no field, no dipole
    torque); ``max_dipole`` the magnetorquers' limit per axis (A m^2, needs an orbit)."""

    def __init__(self, inertia, wheels=(), orbit=None, max_dipole=math.inf):
        try:
            J = np.array(inertia, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"inertia: expected 3 principal moments or a 3x3 array, got {inertia!r}") from None
        if J.shape == (3,):
            J = np.diag(J)
        if J.shape != (3, 3):
            raise ValueError(f"inertia: expected 3 principal moments or a 3x3 array, got shape {J.shape}")
        if not np.all(np.isfinite(J)):
            raise ValueError(f"inertia: must be finite, got {J.tolist()}")
        if not np.array_equal(J, J.T):
            raise ValueError(f"inertia: not symmetric: {J.tolist()}")
        if not np.all(np.linalg.eigvalsh(J) > 0):
            raise ValueError(f"inertia: not positive definite: {J.tolist()}")
        self.inertia = J
        self.wheels = tuple(wheels)
        for i, w in enumerate(self.wheels):
            if not isinstance(w, Wheel):
                raise ValueError(f"wheels[{i}]: expected a trompo.Wheel, got {w!r}")
        if len(self.wheels) > 8:
            raise ValueError(f"wheels: at most 8, got {len(self.wheels)}")
        if orbit is not None and not isinstance(orbit, Orbit):
            raise ValueError(f"orbit: expected a trompo.Orbit or None, got {orbit!r}")
        self.orbit = orbit
        self.max_dipole = _finite("max_dipole", max_dipole, positive=True, allow_inf=True)
        if orbit is None and math.isfinite(self.max_dipole):
            raise ValueError("max_dipole: needs an orbit (magnetorquers act in the field along it)")

    def __repr__(self):
        return f"Spacecraft(inertia={self.inertia.tolist()}, wheels={list(self.wheels)}, orbit={self.orbit!r}, " \
               f"max_dipole={self.max_dipole!r})"


class State:
    """An initial state: ``R`` (3,3) body -> space (Λ: a body vector's space components are
    R @ v) and ``omega`` (3,) the body angular velocity (rad/s, body axes)."""

    def __init__(self, R, omega):
        self.R = R
        self.omega = omega

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
        angle = float(np.linalg.norm(v))
        K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
        if angle < 1e-8:  # the series, to round-off
            R = np.eye(3) + K + K @ K / 2
        else:
            R = np.eye(3) + math.sin(angle) / angle * K + (1 - math.cos(angle)) / angle ** 2 * (K @ K)
    return State(R, _array("omega", omega, (3,)))


def mrp(m):
    """The modified Rodrigues parameters σ of a rotation matrix m (for a target R, pass RᵀΛ),
    |σ| <= 1, exactly as C++ trompo::mrp_of_relative computes them: Eigen's quaternion of m
    (Shoemake's algorithm, the same operations in the same order), w >= 0, σ = v/(1 + w).
    Eigen's trace() sums the diagonal as a tree, m00 + (m11 + m22) (redux_novec_unroller
    splits 3 as 1 + 2): summed left to right instead, the rows differ in the last bit from
    t = 1.7 s on."""
    t = m[0][0] + (m[1][1] + m[2][2])
    q = [0.0, 0.0, 0.0, 0.0]  # x, y, z, w as Eigen's coeffs()
    if t > 0:
        t = math.sqrt(t + 1.0)
        q[3] = 0.5 * t
        t = 0.5 / t
        q[0] = (m[2][1] - m[1][2]) * t
        q[1] = (m[0][2] - m[2][0]) * t
        q[2] = (m[1][0] - m[0][1]) * t
    else:
        i = 0
        if m[1][1] > m[0][0]:
            i = 1
        if m[2][2] > m[i][i]:
            i = 2
        j = (i + 1) % 3
        k = (j + 1) % 3
        t = math.sqrt(m[i][i] - m[j][j] - m[k][k] + 1.0)
        q[i] = 0.5 * t
        t = 0.5 / t
        q[3] = (m[k][j] - m[j][k]) * t
        q[j] = (m[j][i] + m[i][j]) * t
        q[k] = (m[k][i] + m[i][k]) * t
    if q[3] < 0:
        q = [-x for x in q]
    return [q[0] / (1.0 + q[3]), q[1] / (1.0 + q[3]), q[2] / (1.0 + q[3])]



class MrpPd:
    """The built-in MRP PD law, run in C++ (no Python call): L = -K sigma - P Omega with
    sigma the MRP of R_target^T R (|sigma| <= 1), on the wheels by the minimum-norm inverse,
    else (no wheels) as a body torque (docs/control.md). ``target``: a rotation matrix (target
    -> space), or None for the identity."""

    def __init__(self, K, P, target=None):
        self.K = _finite("K", K, nonnegative=True)
        self.P = _finite("P", P, nonnegative=True)
        self.target = None if target is None else _rotation_matrix("target", target)

    def __repr__(self):
        return f"MrpPd(K={self.K!r}, P={self.P!r}, target={None if self.target is None else self.target.tolist()})"


class BDot:
    """The built-in B-dot detumbling law, run in C++: m = -k dB/dt from the field sampled in
    body axes (needs the spacecraft's orbit); the first sample commands m = 0."""

    def __init__(self, k):
        self.k = _finite("k", k, nonnegative=True)

    def __repr__(self):
        return f"BDot(k={self.k!r})"


class ControlResult(OdeResult):
    """trompo.control's rows (a dict with attribute access): ``t`` (n,), ``R`` (n,3,3) body ->
    space, ``W`` (n,3), ``H``, ``mu``, ``pi`` (n,3), ``iterations``, ``wheel_speeds`` (n,N)
    relative to the body and ``u`` (n,N) the motor torques held from each row on; ``success``
    and ``message``."""


class ControlError(RuntimeError):
    """A control run ended early: ``result`` (a ControlResult) holds the rows so far and ``t``
    the sample at which it stopped. When the Python controller raised, its exception is this
    one's ``__cause__`` (its traceback kept)."""

    def __init__(self, message, result, t=None):
        super().__init__(message)
        self.result = result
        self.t = t


class CommandError(ControlError, ValueError):
    """The controller's command could not be held (not finite, or not for this spacecraft):
    the message names the command and t_k. Also a ValueError."""


def control(spacecraft, state, t_end, *, dt, period, controller, scheme="simo-kappa", order=2, every=1):
    """Integrates ``spacecraft`` from ``state`` to ``t_end`` with ``controller`` (MrpPd, BDot,
    or a Python callable ``f(t, R, W, wheel_speeds, memory)`` returning a dict of commands)
    sampled every ``period``, its commands held in between, fixed steps of ``dt``.

    Returns a ControlResult; raises ValueError, CommandError, ControlError or StepFailed,
    carrying the rows so far. docs/python.md, "Control in the loop from Python".
    """
    if not isinstance(spacecraft, Spacecraft):
        raise ValueError(f"spacecraft: expected a trompo.Spacecraft, got {spacecraft!r}")
    if not isinstance(state, State):
        raise ValueError(f"state: expected a trompo.State (trompo.initial_state(...)), got {state!r}")
    t_end = _finite("t_end", t_end, positive=True)
    dt = _finite("dt", dt, positive=True)
    period = _finite("period", period, positive=True)
    if period < dt:
        raise ValueError(f"period: {period!r} is shorter than the step dt = {dt!r}")
    if isinstance(every, bool) or not isinstance(every, (numbers.Integral, np.integer)) or every < 1:
        raise ValueError(f"every: must be a positive integer, got {every!r}")
    if isinstance(order, bool) or not isinstance(order, (numbers.Integral, np.integer)):
        raise ValueError(f"order: must be an integer, got {order!r}")
    flags = {"--inertia": _vector("inertia", spacecraft.inertia, (3, 6)), "--dt": repr(dt), "--t-end": repr(t_end),
             "--every": str(int(every)), "--scheme": str(scheme), "--control-period": repr(period)}
    if order != 2:
        flags["--order"] = str(int(order))
    if spacecraft.orbit is not None:
        flags["--orbit-radius"] = repr(spacecraft.orbit.radius)
        flags["--orbit-inclination"] = repr(math.degrees(spacecraft.orbit.inclination))
        if math.isfinite(spacecraft.max_dipole):
            flags["--max-dipole"] = repr(spacecraft.max_dipole)
    target, fn, memory = None, None, None
    if isinstance(controller, MrpPd):
        if spacecraft.wheels:
            G = np.array([w.axis for w in spacecraft.wheels]).T
            if np.linalg.matrix_rank(G) < 3:
                raise ValueError("controller: MrpPd needs wheel axes that span 3-D (or no wheels: a body torque)")
        flags["--controller"] = f"mrp-pd:{controller.K!r},{controller.P!r}"
        target = controller.target
    elif isinstance(controller, BDot):
        if spacecraft.orbit is None:
            raise ValueError("controller: BDot needs spacecraft.orbit (the magnetic field)")
        flags["--controller"] = f"bdot:{controller.k!r}"
    elif callable(controller):
        flags["--controller"] = "code"
        fn, memory = controller, {}
    else:
        raise ValueError(f"controller: expected trompo.MrpPd, trompo.BDot or a callable "
                         f"f(t, R, W, wheel_speeds, memory), got {controller!r}")
    n = len(spacecraft.wheels)
    wheels = np.array([[*w.axis, w.Js, w.speed0] for w in spacecraft.wheels]).reshape(n, 5)
    limits = np.array([[w.max_torque, w.max_speed] for w in spacecraft.wheels]).reshape(n, 2)
    status, rows, messages, raised, t_raised = _control_run(flags, wheels, limits, state.R, state.omega, target, fn,
                                                            memory)
    res = ControlResult(rows)
    res["success"] = status == 0
    res["message"] = "ok" if status == 0 else (messages[-1] if messages else "")
    if status == -1:
        res["message"] = f"the controller raised {type(raised).__name__} at t = {t_raised!r}"
        raise ControlError(f"control: {res['message']}: {raised}", res, t_raised) from raised
    if status == 3:
        m = re.match(r"control run failed at t = (\S+): (.*)", res["message"])
        if m and m.group(2).startswith("controller:"):
            raise CommandError(m.group(2), res, float(m.group(1)))
        raise StepFailed(res["message"], rows)
    return res
# ---- end control ----
