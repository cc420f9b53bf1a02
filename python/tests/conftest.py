"""Shared helpers of the trompo pytest suite (run by ctest as python:pytest, which sets
PYTHONPATH to the built module and TROMPO_SIMULATE to the built CLI)."""
import importlib
import os
import pathlib
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

ROOT = pathlib.Path(os.environ.get("TROMPO_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))

# TROMPO_REQUIRE_ALL=1 (set by ctest's python:pytest entry, whose test command installs
# every dependency): what would be a skip by hand is an error, so that a missing module or
# binary fails the suite instead of showing as passed.
REQUIRE_ALL = os.environ.get("TROMPO_REQUIRE_ALL") == "1"


def skip_or_fail(reason):
    """pytest.skip(reason), or pytest.fail under TROMPO_REQUIRE_ALL=1."""
    if REQUIRE_ALL:
        pytest.fail(f"{reason} (TROMPO_REQUIRE_ALL=1: a skip is an error here)", pytrace=False)
    pytest.skip(reason)


def import_or_skip(name):
    """pytest.importorskip(name), but an ImportError under TROMPO_REQUIRE_ALL=1."""
    if REQUIRE_ALL:
        return importlib.import_module(name)
    return pytest.importorskip(name)


def cli_path():
    path = os.environ.get("TROMPO_SIMULATE")
    if not path:
        for cand in (ROOT / "build/tools/trompo-simulate", ROOT / "build/test/tools/trompo-simulate"):
            if cand.exists():
                path = str(cand)
                break
    if not path:
        skip_or_fail("no trompo-simulate binary (set TROMPO_SIMULATE)")
    return path


def run_cli(args):
    """(exit status, rows as simulate()'s dict, stderr) of trompo-simulate with `args`."""
    p = subprocess.run([cli_path(), *args], capture_output=True, text=True)
    lines = p.stdout.splitlines()
    rows = None
    if lines:
        assert lines[0] == "t,R00,R01,R02,R10,R11,R12,R20,R21,R22,W1,W2,W3,H,mu,pi1,pi2,pi3,iterations"
        # %.17g text parses back to the very same doubles.
        a = np.array([[float(x) for x in line.split(",")] for line in lines[1:]]).reshape(-1, 19)
        rows = {"t": a[:, 0], "R": a[:, 1:10].reshape(-1, 3, 3), "W": a[:, 10:13], "H": a[:, 13], "mu": a[:, 14],
                "pi": a[:, 15:18], "iterations": a[:, 18].astype(np.int64)}
    return p.returncode, rows, p.stderr


def same_rows(a, b):
    """Bit-identical rows: every array equal element for element, same shapes."""
    assert set(a) >= {"t", "R", "W", "H", "mu", "pi", "iterations"}
    for k in ("t", "R", "W", "H", "mu", "pi", "iterations"):
        assert a[k].shape == b[k].shape, k
        assert np.array_equal(a[k], b[k]), k
    return True


#: trompo's functions whose one call is into the C++ engine (simulate_flags, control_run):
#: while a run is inside C++, the innermost Python frame of its thread is one of these, on
#: the line of that call.
ENGINE_CALLERS = ("_run_engine", "control.<locals>.run")


def engine_ran_beside_python(run, cpu_seconds=0.02):
    """Runs run() (one call into the engine) on a thread while this thread runs Python, and
    says whether the engine's thread spent `cpu_seconds` of its own CPU time inside C++
    while this one ran: that is possible only where the engine releases the GIL. Returns
    (seen, run's result, run's exception).

    No timing and no race: this thread loops, reading the engine thread's innermost Python
    frame and its CPU clock (time.pthread_getcpuclockid) with the GIL held, and letting the
    GIL go between readings (the run's callbacks take it). Two readings with that frame an
    engine caller past its first line (ENGINE_CALLERS: the call into C++ is in progress) and
    `cpu_seconds` between them show C++ running beside this thread. Were the GIL held across
    C++, this thread would read the engine's thread only in its callbacks, before the call or
    once it returned (then it goes on, or waits for the GIL using no CPU), and `seen` would be
    False. `cpu_seconds` is small beside the runs the tests give (0.1 s and more of C++)."""
    import trompo
    box = {}

    def target():
        try:
            box["result"] = run()
        except BaseException as e:  # raised again by the test, on its thread
            box["error"] = e

    thread = threading.Thread(target=target)
    thread.start()
    clock = time.pthread_getcpuclockid(thread.ident)
    first, seen = None, False
    while thread.is_alive() and not seen:
        frame = sys._current_frames().get(thread.ident)
        code = frame.f_code if frame is not None else None
        in_cpp = (code is not None and code.co_filename == trompo.__file__ and code.co_qualname in ENGINE_CALLERS
                  and frame.f_lineno != code.co_firstlineno)
        if in_cpp:
            cpu = time.clock_gettime(clock)
            first = cpu if first is None else first
            seen = cpu - first >= cpu_seconds
        time.sleep(0)
    thread.join()
    return seen, box.get("result"), box.get("error")
