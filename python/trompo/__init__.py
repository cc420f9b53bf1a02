"""trompo: structure-preserving integrators for rigid-body rotation, from Python.

    import trompo
    rows = trompo.simulate(case="ht1", t_end=1)          # the CLI's vocabulary
    rows["H"][-1], rows["R"].shape                       # (n,), (n, 3, 3)

    out = trompo.ensemble(rotation, omega, case="ht1", t_end=1, threads=2)
    out["R"][i], out["ok"][i]                            # final state of member i

``simulate`` runs exactly what ``trompo-simulate`` runs with the same flags (the same
C++ code: the parser, the checks, the dispatch), so its rows are bit-identical to the
CLI's CSV rows. See docs/python.md.
"""
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

from ._trompo import ensemble_flags as _ensemble_flags
from ._trompo import simulate_flags as _simulate_flags
from ._trompo import usage as _usage
from ._trompo import __version__

__all__ = ["simulate", "solve_ivp", "ensemble", "StepFailed", "Recovered", "COLUMNS", "__version__"]

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

    Returns a dict of NumPy arrays keyed like the CSV header: ``t`` (n,), ``R`` (n,3,3)
    (Λ), ``W`` (n,3) (Ω, body), ``H`` (n,), ``mu`` (n,), ``pi`` (n,3) and ``iterations``
    (n,), one entry per written row (every ``every``-th step, the first and the last).

    Raises ValueError with the CLI's message on bad arguments, and StepFailed (carrying
    the rows up to the last good state) when a step fails beyond recovery. Warns with
    Recovered when sub-stepping was needed. ``inertia`` is J11,J22,J33, six numbers
    J11,J22,J33,J12,J13,J23, or a symmetric 3×3 matrix. Any other keyword ``name=value``
    is passed as the CLI flag ``--name`` (``_`` becomes ``-``): the CLI's own parser
    accepts it or raises its ValueError (``unknown option '--name' (see --help)``).

    A satellite (docs/spacecraft.md): ``case="sat1"`` or ``"sat2"``, or ``gravity_gradient=n``
    (orbit rate, rad/s) with ``orbit_normal`` and ``radial`` (the radial direction at t = 0);
    its ``H`` column is then the Jacobi integral E_J = H - n ô·π, the motion's invariant.
    """
    kwargs = dict(case=case, scheme=scheme, alpha=alpha, order=order, composition=composition, inertia=inertia,
                  mgl=mgl, com=com, up=up, rotation=rotation, omega=omega, dt=dt, t_end=t_end, every=every,
                  damping=damping, torque=torque, space_torque=space_torque, rotor=rotor,
                  gravity_gradient=gravity_gradient, orbit_normal=orbit_normal, radial=radial, **flags)
    for name in ("ensemble", "csv", "threads"):
        if name in flags:
            raise TypeError(f"simulate: {name!r} is not for simulate (see trompo.ensemble)")
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

    ``t_span`` is (t0, t1): the engine's scenes are autonomous (constant torques; not the
    satellite, whose orbit frame turns with t: t0 must be 0 there), so the run over [t0, t1]
    is the CLI's run over [0, t1 - t0] with every time shifted by t0 (t_eval and the last
    time reported as given); ``first_step`` is ``--dt``
    (a case gives its own); ``control`` is "tolerance" or "reversible". ``events``: built-in
    names ("nutation-max", "nutation-min", "axis-crossing", "flip"), objects with ``.name``
    (one of those) and optionally ``.terminal`` (bool or count), or Python callables
    ``g(t, y)`` as SciPy's (y as a column of ``y``), with optional ``.terminal`` and
    ``.direction`` attributes: their zeros are located by the engine on its dense output,
    as the built-ins' (a terminal one ends the run with a real step to the event). A
    callable costs a Python call per sample (the step ends and three points inside each
    step). Other keywords are simulate()'s (scheme, order, inertia, ...).

    Returns an OdeResult: ``t`` (n,), ``y`` (12, n) (Λ row-major, then Ω, per column),
    ``t_events``/``y_events`` per event, ``status`` (0 end reached, 1 terminal event, -1
    failed), ``message``, ``success``, ``R``, ``W``, ``H``, ``mu``, ``pi``, ``iterations``
    (per row), ``nsteps`` (accepted), ``nreject``, ``nfail``, ``niter`` (Newton iterations
    in all); ``sol`` is None unless ``dense_output=True``: then ``sol(t)`` (t scalar or array
    within the run's span) is the driver's Lie-Hermite dense output of this same run, (12,) or
    (12, len(t)) as ``y``. It is evaluated by running the same engine again with ``--t-eval``
    at the requested times (the step sequence does not depend on t_eval, so the values are
    the interpolant of this run's steps, bit for bit the CLI's): each call costs one run.
    """
    kwargs = dict(case=case, rtol=rtol, atol=atol, control=control, dt=first_step, **flags)
    for name in ("ensemble", "csv", "threads", "t_end", "event_csv", "every"):
        if name in flags:
            raise TypeError(f"solve_ivp: {name!r} is not a solve_ivp argument")
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

    ``rotation`` is (N,3) rotation vectors (Λ0 = exp(R^), as ``--rotation``) or (N,3,3)
    rotation matrices; ``omega`` is (N,3). Optional per-member ``mgl`` (N,) and
    ``inertia`` (N,3) diagonal, (N,6) as ``--inertia`` or (N,3,3); everything else is
    shared, with simulate()'s vocabulary. Member i's final state is bit-identical to the
    last row of ``simulate`` with that member's values (a member with its own mgl is a
    heavy top, even at mgl = 0).

    Returns a dict of arrays with one entry per member: ``t``, ``R``, ``W``, ``H``,
    ``mu``, ``pi``, ``iterations`` (the member's total Newton iterations) as simulate's
    columns, plus ``ok`` (bool), ``status`` (list of str: "ok" or why the member stopped)
    and ``recovered`` (intervals saved by sub-stepping). A failed member does not stop
    the others and raises nothing: its row is its last good state. Other keywords are
    passed on as CLI flags, as for simulate().

    ``progress=True`` runs the members in about 20 batches and reports ``ensemble: k/N
    members`` on stderr after each (a callable gets ``(k, N)`` instead); the members are
    independent, so the results are the same bits as one batch.
    """
    kwargs = dict(case=case, scheme=scheme, alpha=alpha, order=order, composition=composition, com=com, up=up,
                  dt=dt, t_end=t_end, damping=damping, torque=torque, space_torque=space_torque, rotor=rotor,
                  threads=threads, **flags)
    for name in ("ensemble", "csv", "every"):
        if name in flags:
            raise TypeError(f"ensemble: {name!r} is not for ensemble")
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
