"""trompo: structure-preserving integrators for rigid-body rotation, from Python.

A scene is built from objects (Scene, RigidBody, Gravity, Damping, BodyTorque, SpaceTorque,
Rotor, GravityGradient, TorqueLaw: trompo/scene.py) or named by a case ("ht1"); simulate()
runs one trajectory (the CLI's own engine: its rows bit for bit, as NumPy arrays; any of
trompo-simulate's flags as a keyword), solve_ivp() adaptive steps with SciPy's vocabulary,
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
from .scene import (BodyTorque, Damping, Gravity, GravityGradient, RigidBody, Rotor, Scene, SpaceTorque, State,
                    TorqueLaw, initial_state)
from .scene import _array, _finite, _inertia, _rotation_matrix, _text, state_of_y

__all__ = ["simulate", "solve_ivp", "ensemble", "StepFailed", "Recovered", "COLUMNS", "__version__",
           "RigidBody", "Gravity", "Damping", "BodyTorque", "SpaceTorque", "Rotor", "GravityGradient", "TorqueLaw",
           "Scene", "control", "control_ensemble", "Wheel", "Orbit", "Spacecraft", "State", "initial_state", "MrpPd", "BDot", "ControlResult",
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
        raise ValueError(f"{name}: not a number: {x!r}")
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
            raise ValueError(f"inertia: not symmetric: {a.tolist()}")
        a = np.array([a[0, 0], a[1, 1], a[2, 2], a[0, 1], a[0, 2], a[1, 2]])
    if a.ndim != 1 or a.size not in sizes:
        want = " or ".join(str(s) for s in sizes)
        raise ValueError(f"{name}: expected {want} numbers, got shape {a.shape}")
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
            flags[flag] = _number(name, value)
        elif name in _VECTORS:
            flags[flag] = _vector(name, value, _VECTORS[name])
        elif isinstance(value, str):
            # Any other keyword is passed on as the flag of that name: a flag the CLI gains
            # is usable from Python at once, and an unknown one is the CLI's error.
            flags[flag] = value
        elif isinstance(value, (numbers.Real, np.number)):
            flags[flag] = _number(name, value)
        else:
            a = np.asarray(value, dtype=float).ravel()
            flags[flag] = ",".join(repr(float(v)) for v in a)
    return flags


# ---- objects and keywords to the engine, and its messages back in Python's words ----
def _python_words(message, renames=None):
    """The engine's message with each flag as the keyword that sets it: "--t-end: required"
    is "t_end: required" (``renames``: a flag whose keyword differs, e.g. solve_ivp's
    first_step for --dt)."""
    renames = renames or {}

    def keyword(m):
        name = m.group(1).replace("-", "_")
        return renames.get(name, name)
    return re.sub(r"--([a-z][a-z0-9-]*)", keyword, message)


def _engine_args(function, kwargs, state, scene_keywords=()):
    """(flags, rotation matrix or None, torque laws or None) for the engine from the
    keywords, a Scene given as ``case`` and a State. A number given both by the scene (or
    the state) and by a keyword is a TypeError naming it."""
    scene = kwargs.get("case")
    if isinstance(scene, Scene):
        kwargs = dict(kwargs, case=None)
    elif scene is not None and not isinstance(scene, str):
        raise TypeError(f"{function}(): the first argument is a case's name or a trompo.Scene, got {scene!r}")
    else:
        scene = None
    flags = _flags(kwargs)
    rotation, laws = None, None
    if scene is not None:
        for flag, value in scene._flags().items():
            if flag in flags:
                raise TypeError(f"{function}(): {flag[2:].replace('-', '_')!r} is given by the scene too")
            flags[flag] = value
        laws = scene._laws()
    if state is not None:
        if not isinstance(state, State):
            raise TypeError(f"{function}(): state must be a trompo.State (trompo.initial_state(...)), got {state!r}")
        for name in ("rotation", "omega"):
            if "--" + name in flags:
                raise TypeError(f"{function}(): {name!r} is given by the state too")
        if state.rotvec is not None:  # as --rotation: bit for bit the keyword's run
            flags["--rotation"] = _text(state.rotvec)
        else:
            rotation = np.ascontiguousarray(state.R, dtype=float)
        flags["--omega"] = _text(state.omega)
    return flags, rotation, laws


def _run_engine(flags, rotation=None, laws=None, code_events=None, renames=None):
    """simulate_flags, its ValueError in Python's words (a TorqueLaw's own exception, marked
    by the engine, goes through as raised)."""
    try:
        return _simulate_flags(flags, code_events, rotation, laws)
    except ValueError as e:
        if getattr(e, "trompo_torque_law", False):
            raise
        raise ValueError(_python_words(str(e), renames)) from None


#: solve_ivp's keywords for the flags whose names differ.
_SOLVE_IVP_WORDS = {"dt": "first_step", "t_end": "t_span", "event": "events"}


def simulate(case=None, *, state=None, scheme=None, alpha=None, order=None, composition=None, inertia=None, mgl=None,
             com=None, up=None, rotation=None, omega=None, dt=None, t_end=None, every=None, damping=None,
             torque=None, space_torque=None, rotor=None, gravity_gradient=None, orbit_normal=None, radial=None,
             **flags):
    """One trajectory: ``case`` a trompo.Scene or a case's name ("ht1", ...), ``state`` a
    trompo.State (initial_state(...)), fixed steps of ``dt`` to ``t_end``; the other keywords
    are trompo-simulate's flags (``t_end`` is ``--t-end``), bit for bit its rows.

    Returns a dict of NumPy arrays keyed like the CSV header (``t``, ``R``, ``W``, ``H``,
    ``mu``, ``pi``, ``iterations``); raises ValueError naming the keyword at fault,
    StepFailed when a step fails beyond recovery. docs/python.md, "trompo.simulate".
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
    status, rows, messages = _run_engine(*_engine_args("simulate", kwargs, state))
    if status == 3:
        raise StepFailed(_python_words(messages[-1]), rows)
    _warn_engine(messages, Recovered, stacklevel=2)
    return rows


# ---- adaptive steps (docs/adaptive.md) ----
class OdeResult(dict):
    """solve_ivp's result, a dict with attribute access as SciPy's: t, y, sol, t_events,
    y_events, status, message, success, and R, W, H, mu, pi, iterations (per row, as
    simulate()'s), nsteps, nreject, nfail, niter (all Newton iterations) and method."""

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None


_SUMMARY = re.compile(r"adaptive \((\w+), rtol [^,]*, atol [^)]*\): (\d+) accepted, (\d+) rejected, (\d+) failed attempts, "
                      r"(\d+) Newton iterations; (.*?); method (.*)$")

#: The engine's warnings (a message that starts so), e.g. an rtol raised to its floor.
_WARNING = "warning: "


def _warn_engine(messages, category, stacklevel, renames=None):
    """The engine's messages as Python warnings: its own warnings as UserWarning, the rest
    (sub-stepping's recoveries) as `category`; a summary line (adaptive runs) is not one."""
    for m in messages:
        if m.startswith(_WARNING):
            warnings.warn(_python_words(m[len(_WARNING):], renames), UserWarning, stacklevel=stacklevel + 1)
        elif category is not None and not _SUMMARY.match(m):
            warnings.warn(m, category, stacklevel=stacklevel + 1)


def solve_ivp(case=None, t_span=None, y0=None, *, rtol=1e-3, atol=1e-6, t_eval=None, events=None, first_step=None,
              control=None, dense_output=False, **flags):
    """Adaptive steps with SciPy's vocabulary, through trompo-simulate's own engine (bit for
    bit the rows of ``trompo-simulate --rtol R --atol A ...`` with the same flags): ``case`` a
    trompo.Scene or a case's name, ``y0`` a trompo.State or 12 numbers (R row-major, then
    omega: the columns of ``y``).

    Without ``scheme``, ``order`` and ``first_step`` the engine picks the first step and the
    cheapest method for the scene and tolerance, named in ``method``; an ``rtol`` below
    100 eps is raised to it with a UserWarning. Returns an OdeResult (``t``, ``y``,
    ``t_events``, ``y_events``, ``status``, ``sol``, ``method``, ...); trompo's tolerances
    bound the error at the end of the span. docs/python.md, "trompo.solve_ivp: adaptive steps".
    """
    kwargs = dict(case=case, rtol=rtol, atol=atol, control=control, dt=first_step, **flags)
    for name in ("ensemble", "csv", "threads", "t_end", "event_csv", "every"):
        if name in flags:
            raise TypeError(f"solve_ivp: {name!r} is not a solve_ivp argument")
    _check_keywords("solve_ivp", flags, ("case", "t_span", "y0", "rtol", "atol", "t_eval", "events", "first_step",
                                         "control", "dense_output"))
    state = None if y0 is None else state_of_y("y0", y0)

    def run(kw, code_events=None):
        return _run_engine(*_engine_args("solve_ivp", kw, state), code_events=code_events, renames=_SOLVE_IVP_WORDS)
    t0, t1 = 0.0, None
    if t_span is not None:
        t0, t1 = (float(x) for x in t_span)
        if not (np.isfinite(t0) and np.isfinite(t1)):
            raise ValueError(f"t_span: must be finite, got {t_span!r}")
        satellite = isinstance(case, Scene) and case.effect(GravityGradient) is not None
        if t0 != 0.0 and (flags.get("gravity_gradient") is not None or str(case).startswith("sat") or satellite):
            # a satellite's orbit frame turns with t (radial direction given at t = 0)
            raise ValueError("t_span: t0 != 0 needs a scene without time dependence (not a satellite)")
        kwargs["t_end"] = t1 - t0  # the autonomous run from 0 (docstring)
    if t_eval is not None:
        t_eval = np.atleast_1d(np.asarray(t_eval, dtype=float))
        kwargs["t_eval"] = ",".join(repr(float(v - t0)) for v in t_eval)
    names, items, code_events = _event_list("solve_ivp", events, t0)
    if items:
        kwargs["event"] = ";".join(items)
    status, rows, messages, event_rows = _with_event_csv(names, kwargs, lambda kw: run(kw, code_events or None))
    m = next((_SUMMARY.match(x) for x in messages if _SUMMARY.match(x)), None)
    if m is None:
        raise RuntimeError("solve_ivp: no summary from the engine: " + "; ".join(messages))
    _warn_engine(messages, None, stacklevel=2, renames=_SOLVE_IVP_WORDS)
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
        res["sol"] = _dense_solution(run, kwargs, t0, t0, t_last, code_events or None)
    res["t_events"], res["y_events"] = _events_by_name(names, event_rows, t0)
    res["status"] = code
    res["success"] = code >= 0
    res["message"] = {1: "A termination event occurred.",
                      0: "The solver successfully reached the end of the integration interval."}.get(code, ended)
    res["nsteps"], res["nreject"], res["nfail"], res["niter"] = (int(m.group(k)) for k in (2, 3, 4, 5))
    res["method"] = m.group(7)
    return res


def _event_list(function, events, t0):
    """(names, built-in items for --event, code events) from solve_ivp's ``events``: built-in
    names (or objects with .name) and callables g(t, y) with .terminal and .direction."""
    names = []       # per event, in the order given: the name its rows carry
    items = []       # the built-in ones as --event's NAME[:terminal:N]
    code_events = []  # the callables: (name, g, direction, terminal)
    if events is None:
        return names, items, code_events
    if callable(events) or isinstance(events, str) or not isinstance(events, (list, tuple)):
        events = [events]
    for i, e in enumerate(events):
        terminal = int(getattr(e, "terminal", 0))  # True counts as 1
        if terminal < 0:
            raise ValueError(f"events[{i}].terminal: must be a bool or a count >= 0, got {terminal!r}")
        if isinstance(e, str) or (hasattr(e, "name") and isinstance(e.name, str) and not callable(e)):
            name = e if isinstance(e, str) else e.name
            if getattr(e, "direction", 0) not in (0,):
                raise ValueError(f"{function}: the built-in events carry their own direction")
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
    return names, items, code_events


def _with_event_csv(names, kwargs, run, key="event_csv"):
    """run(kwargs) with kwargs[key] (--event-csv) a temporary file when there are events:
    run's tuple, then the event rows as lists of text."""
    if not names:  # no event file to read (its creation costs as much as a short run)
        return (*run(kwargs), [])
    fd, event_path = tempfile.mkstemp(suffix=".csv")
    os.close(fd)
    try:
        out = run(dict(kwargs, **{key: event_path}))
        with open(event_path) as f:
            next(f)
            event_rows = [line.rstrip("\n").split(",") for line in f]
    finally:
        os.unlink(event_path)
    return (*out, event_rows)


def _events_by_name(names, event_rows, t0):
    """SciPy's t_events and y_events (y: R row-major, then omega) from the event rows."""
    t_events, y_events = [], []
    for name in names:
        sel = [r for r in event_rows if r[0] == name]
        t_events.append(np.array([float(r[1]) + t0 for r in sel]))
        y_events.append(np.array([[float(v) for v in r[2:14]] for r in sel]).reshape(len(sel), 12))
    return t_events, y_events


def _event_function(e, t0):
    """g(t, y) -> float for the engine, at the user's time (the engine runs from 0)."""
    def g(t, y):
        return float(e(t + t0, y))
    return g


def _column_states(rows):
    """(n, 12): Λ row-major, then Ω, per row of the engine."""
    n = len(rows["t"])
    return np.concatenate([rows["R"].reshape(n, 9), rows["W"]], axis=1)


def _dense_solution(run, kwargs, t0, t_first, t_last, code_events=None):
    """solve_ivp's ``sol``: the run of ``kwargs`` again (by ``run``), with rows at the
    requested times."""
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
        status, rows, messages = run(dict(kwargs, t_eval=",".join(repr(float(v - t0)) for v in times)), code_events)
        if len(rows["t"]) != len(times):
            raise RuntimeError("sol: the engine gave %d of %d rows: %s" % (len(rows["t"]), len(times), "; ".join(messages)))
        y = _column_states(rows)[np.searchsorted(times, flat) if t_last >= t_first
                                 else len(times) - 1 - np.searchsorted(times[::-1], flat)]
        return y[0] if ts.ndim == 0 else y.T.reshape((12,) + ts.shape)

    return sol
# ---- end adaptive ----


def ensemble(rotation, omega, *, scene=None, mgl=None, inertia=None, case=None, scheme=None, alpha=None, order=None,
             composition=None, com=None, up=None, dt=None, t_end=None, damping=None, torque=None,
             space_torque=None, rotor=None, threads=0, progress=False, events=None, **flags):
    """N independent trajectories from t = 0 to ``t_end``, across ``threads`` cores (0: all).

    ``rotation`` (N,3) or (N,3,3), ``omega`` (N,3), ``scene`` a trompo.Scene shared by the
    members (or ``case`` a name), optional per-member ``mgl`` and ``inertia`` arrays; the
    other keywords are simulate()'s. Fixed steps of ``dt``, or with ``rtol`` (``atol``,
    ``t_eval``, built-in ``events`` by name) adaptive members: then also ``nsteps``,
    ``nreject``, ``nfail`` (N,), ``y_eval`` (N, 12, len(t_eval)) as solve_ivp's ``y`` per
    member, ``t_events``/``y_events`` per member. Returns a dict of arrays, one entry per
    member, each bit-identical to its single run; a failed member raises nothing (``ok``,
    ``status``). docs/python.md, "Python: trompo.ensemble".
    """
    kwargs = dict(case=case, scheme=scheme, alpha=alpha, order=order, composition=composition, com=com, up=up,
                  dt=dt, t_end=t_end, damping=damping, torque=torque, space_torque=space_torque, rotor=rotor,
                  threads=threads, **flags)
    for name in ("ensemble", "csv", "every"):
        if name in flags:
            raise TypeError(f"ensemble: {name!r} is not for ensemble")
    _check_keywords("ensemble", flags, ("rotation", "omega", "scene", "mgl", "inertia", "progress", "events"))
    if events is not None:  # built-in names only (a Python g would serialise the threads)
        names = [events] if isinstance(events, str) else list(events)
        if not all(isinstance(e, str) for e in names):
            raise TypeError("ensemble(): events are built-in names (nutation-max, nutation-min, axis-crossing, flip)")
        kwargs["event"] = ";".join(names)
    if scene is not None:
        if not isinstance(scene, Scene):
            raise TypeError(f"ensemble(): scene must be a trompo.Scene, got {scene!r}")
        if case is not None:
            raise TypeError("ensemble(): give scene or case, not both")
        if scene._laws() is not None:
            raise ValueError("scene: a TorqueLaw cannot run in an ensemble (each call takes the interpreter's lock); "
                             "give its torque as a built-in effect")
    flags, _, _ = _engine_args("ensemble", dict(kwargs, case=scene if scene is not None else case), None)
    flags["--ensemble"] = "(arrays)"
    rotation = np.asarray(rotation, dtype=float)
    omega = np.asarray(omega, dtype=float)
    if mgl is not None:
        mgl = np.asarray(mgl, dtype=float)
    if inertia is not None:
        inertia = np.asarray(inertia, dtype=float)
    return _run_ensemble("ensemble", progress, flags, rotation, omega, mgl, inertia)


def _run_ensemble(function, progress, flags, rotation, omega, mgl, inertia, **closed_loop):
    """The engine's ensemble in Python's words: messages with keywords for flags, its warnings
    as UserWarnings at the caller's line. ``progress``: called by C++ after each chunk of
    members (done, n), from the thread that finished it, one call at a time; True prints a
    line on stderr."""
    report = None
    if progress:
        report = progress if callable(progress) else (lambda k, n: print(f"{function}: {k}/{n} members", file=sys.stderr))
    try:
        out = _ensemble_flags(flags, rotation, omega, mgl, inertia, report, **closed_loop)
    except ValueError as e:
        raise ValueError(_python_words(str(e))) from None
    for m in out.pop("messages"):
        if m.startswith(_WARNING):
            warnings.warn(_python_words(m[len(_WARNING):]), UserWarning, stacklevel=3)
    return out


def usage():
    """trompo-simulate --help: the vocabulary of simulate()'s keywords."""
    return _usage()


# ---- control in the loop (docs/python.md, "Control in the loop from Python") ----
class Wheel:
    """A reaction wheel: spin ``axis`` in body axes (normalised by the engine), axial inertia
    ``Js`` (kg m^2), initial speed ``speed0`` relative to the body (rad/s), motor torque limit
    ``max_torque`` (N m) and speed limit ``max_speed`` (rad/s); ``inf``: no limit. ``friction``
    is the viscous coefficient c (N m s/rad): the torque -c * speed between wheel and body, which
    ``control`` applies around each step, fixed (``dt``) or adaptive (``rtol``, with ``t_eval``,
    ``events`` and ``dense_output``, whose interpolants see it; docs/theory.md [W17])."""

    def __init__(self, axis, Js, speed0=0.0, max_torque=math.inf, max_speed=math.inf, friction=0.0):
        self.axis = _array("axis", axis, (3,))
        if not np.any(self.axis != 0):
            raise ValueError("axis: must be non-zero")
        self.Js = _finite("Js", Js, positive=True)
        self.speed0 = _finite("speed0", speed0)
        self.max_torque = _finite("max_torque", max_torque, positive=True, allow_inf=True)
        self.max_speed = _finite("max_speed", max_speed, positive=True, allow_inf=True)
        self.friction = _finite("friction", friction, nonnegative=True)

    def __repr__(self):
        return (f"Wheel(axis={self.axis.tolist()}, Js={self.Js!r}, speed0={self.speed0!r}, "
                f"max_torque={self.max_torque!r}, max_speed={self.max_speed!r}, friction={self.friction!r})")


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
        self.inertia = _inertia("inertia", inertia)
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


def _control_flags(spacecraft, controller, t_end, period, dt, rtol, scheme, order, max_step_angle, composition=None):
    """The engine's flags of a control run (or of each member of a closed-loop ensemble), the
    MrpPd target (or None) and a Python controller (or None), after the checks of the
    arguments they share (a ValueError naming the keyword)."""
    if not isinstance(spacecraft, Spacecraft):
        raise ValueError(f"spacecraft: expected a trompo.Spacecraft, got {spacecraft!r}")
    t_end = _finite("t_end", t_end, positive=True)
    if dt is None and rtol is None:
        raise ValueError("dt: required (or give rtol for adaptive steps)")
    if dt is not None:
        dt = _finite("dt", dt, positive=True)
    period = _finite("period", period, positive=True)
    if dt is not None and period < dt:
        raise ValueError(f"period: {period!r} is shorter than the step dt = {dt!r}")
    if isinstance(order, bool) or not isinstance(order, (numbers.Integral, np.integer)):
        raise ValueError(f"order: must be an integer, got {order!r}")
    flags = {"--inertia": _vector("inertia", spacecraft.inertia, (3, 6)), "--t-end": repr(t_end),
             "--scheme": str(scheme), "--control-period": repr(period)}
    if dt is not None:
        flags["--dt"] = repr(dt)
    if max_step_angle is not None:
        flags["--max-step-angle"] = _number("max_step_angle", max_step_angle)
    if order != 2:
        flags["--order"] = str(int(order))
    if composition is not None:
        if not isinstance(composition, str):
            raise ValueError(f"composition: expected a method's name (e.g. 'saba2c', 'kahan-li-9'), got {composition!r}")
        flags["--composition"] = composition
    if spacecraft.orbit is not None:
        flags["--orbit-radius"] = repr(spacecraft.orbit.radius)
        flags["--orbit-inclination"] = repr(math.degrees(spacecraft.orbit.inclination))
        if math.isfinite(spacecraft.max_dipole):
            flags["--max-dipole"] = repr(spacecraft.max_dipole)
    target, fn = None, None
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
        fn = controller
    else:
        raise ValueError(f"controller: expected trompo.MrpPd, trompo.BDot or a callable "
                         f"f(t, R, W, wheel_speeds, memory), got {controller!r}")
    return flags, target, fn


def _wheel_arrays(spacecraft):
    """The wheels as the engine takes them: (N, 5) axis, Js, speed0 and (N, 3) max_torque,
    max_speed, friction."""
    n = len(spacecraft.wheels)
    wheels = np.array([[*w.axis, w.Js, w.speed0] for w in spacecraft.wheels]).reshape(n, 5)
    limits = np.array([[w.max_torque, w.max_speed, w.friction] for w in spacecraft.wheels]).reshape(n, 3)
    return wheels, limits


def control(spacecraft, state, t_end, *, period, controller, dt=None, rtol=None, atol=1e-6, t_eval=None, events=None,
            dense_output=False, scheme="simo-kappa", order=2, composition=None, every=1, max_step_angle=None):
    """Integrates ``spacecraft`` from ``state`` to ``t_end`` with ``controller`` (MrpPd, BDot,
    or a Python callable ``f(t, R, W, wheel_speeds, memory)`` returning a dict of commands)
    sampled every ``period``, its commands held in between: fixed steps of ``dt``, or with
    ``rtol`` adaptive steps over each hold (``dt`` the first step, optional), rows at
    ``t_eval`` and ``events`` (non-terminal: built-in names or callables g(t, y)) as
    solve_ivp's, across the samples; ``dense_output``: ``res.sol(t)`` as solve_ivp's (the
    run again with rows at t, a Python controller starting from a fresh memory).
    ``max_step_angle`` (rad, fixed steps): each hold split into the fewest equal steps, none
    longer than ``dt``, that turn the body by at most this angle at the sample's rate.
    ``composition``: a named composition or splitting method, as the CLI's ``--composition``
    (e.g. ``scheme="splitting", composition="saba2c"``, the near-integrable method of a fast
    spinner with wheels, theory [W18]); ``order`` then must agree or stay at its default.

    Returns a ControlResult; raises ValueError, CommandError, ControlError or StepFailed,
    carrying the rows so far. docs/python.md, "Control in the loop from Python".
    """
    if not isinstance(spacecraft, Spacecraft):
        raise ValueError(f"spacecraft: expected a trompo.Spacecraft, got {spacecraft!r}")
    if not isinstance(state, State):
        raise ValueError(f"state: expected a trompo.State (trompo.initial_state(...)), got {state!r}")
    if rtol is None and (t_eval is not None or events is not None or dense_output):
        what = "t_eval" if t_eval is not None else "events" if events is not None else "dense_output"
        raise ValueError(f"{what}: only with adaptive steps (give rtol)")
    if isinstance(every, bool) or not isinstance(every, (numbers.Integral, np.integer)) or every < 1:
        raise ValueError(f"every: must be a positive integer, got {every!r}")
    flags, target, fn = _control_flags(spacecraft, controller, t_end, period, dt, rtol, scheme, order, max_step_angle,
                                       composition)
    memory = {} if fn is not None else None
    if t_eval is None:
        flags["--every"] = str(int(every))
    names, code_events = [], []
    if rtol is not None:
        flags["--rtol"] = _number("rtol", rtol)
        flags["--atol"] = _number("atol", atol)
        if t_eval is not None:
            flags["--t-eval"] = _text(np.atleast_1d(np.asarray(t_eval, dtype=float)))
        names, items, code_events = _event_list("control", events, 0.0)
        for name, _, _, terminal in code_events:  # as the engine refuses --event NAME:terminal
            if terminal > 0:
                raise ValueError(f"events[{name.rsplit('-', 1)[1]}].terminal: a terminal event would end a hold, "
                                 "not the run: not in a control run (non-terminal events only)")
        if items:
            flags["--event"] = ";".join(items)
    wheels, limits = _wheel_arrays(spacecraft)

    def run(f, memory=memory):
        return _control_run(f, wheels, limits, state.R, state.omega, target, fn, memory, code_events or None)
    try:
        status, rows, messages, raised, t_raised, event_rows = _with_event_csv(names, flags, run, key="--event-csv")
    except ValueError as e:
        raise ValueError(_python_words(str(e))) from None
    res = ControlResult(rows)
    summary = next((_SUMMARY.match(x) for x in messages if _SUMMARY.match(x)), None)
    if summary is not None:
        res["nsteps"], res["nreject"], res["nfail"], res["niter"] = (int(summary.group(k)) for k in (2, 3, 4, 5))
        res["method"] = summary.group(7)
    if names:
        res["t_events"], res["y_events"] = _events_by_name(names, event_rows, 0.0)
    res["sol"] = None
    if dense_output and status == 0:
        quiet = {k: v for k, v in flags.items() if k not in ("--t-eval", "--event", "--every")}

        def again(f):  # the same run (the samples, the steps), a fresh memory for a Python controller
            status_, rows_, messages_, *_ = run(f, None if fn is None else {})
            return status_, rows_, messages_
        res["sol"] = _dense_solution(lambda kw, _events=None: again(dict(quiet, **{"--t-eval": kw["t_eval"]})), {}, 0.0,
                                     0.0, float(t_end))
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


def control_ensemble(spacecraft, rotation, omega, t_end, *, period, controller, dt=None, rtol=None, atol=1e-6,
                     scheme="simo-kappa", order=2, composition=None, max_step_angle=None, inertia=None, threads=0,
                     progress=False):
    """N closed loops at once, across ``threads`` cores (0: all): member i is ``control`` of
    ``spacecraft`` from ``rotation[i]`` ((N,3) rotation vectors or (N,3,3) matrices) and
    ``omega[i]`` (N,3), each with its own wheels (started at its own rates) and its own
    controller memory; ``inertia`` (N,3), (N,6) or (N,3,3) the whole spacecraft's per member.
    The controller is a built-in (MrpPd, BDot): a Python callable would take the interpreter's
    lock at every sample of every member. Returns a dict of arrays, one entry per member, each
    bit-identical to the last row of its single ``control`` run: ``t``, ``R``, ``W``, ``H``,
    ``mu``, ``pi``, ``wheel_speeds`` (N, n_w), ``u`` (N, n_w) the torques held at the end,
    ``iterations``, ``ok``, ``status``. docs/python.md, "Closed-loop ensembles".
    """
    if not isinstance(controller, (MrpPd, BDot)):
        raise ValueError(f"controller: a closed-loop ensemble takes trompo.MrpPd or trompo.BDot (a Python callable "
                         f"would serialise the members on the interpreter's lock), got {controller!r}")
    flags, target, _ = _control_flags(spacecraft, controller, t_end, period, dt, rtol, scheme, order, max_step_angle,
                                      composition)
    if rtol is not None:
        flags["--rtol"] = _number("rtol", rtol)
        flags["--atol"] = _number("atol", atol)
    flags["--threads"] = _number("threads", threads)
    flags["--ensemble"] = "(arrays)"
    wheels, limits = _wheel_arrays(spacecraft)
    rotation = np.asarray(rotation, dtype=float)
    omega = np.asarray(omega, dtype=float)
    if inertia is not None:
        inertia = np.asarray(inertia, dtype=float)
    return _run_ensemble("control_ensemble", progress, flags, rotation, omega, None, inertia, wheels=wheels,
                         limits=limits, target=None if target is None else np.asarray(target, dtype=float))
# ---- end control ----
