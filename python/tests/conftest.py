"""Shared helpers of the trompo pytest suite (run by ctest as python:pytest, which sets
PYTHONPATH to the built module and TROMPO_SIMULATE to the built CLI)."""
import importlib
import os
import pathlib
import subprocess

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
