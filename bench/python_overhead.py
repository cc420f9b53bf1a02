#!/usr/bin/env python3
"""The overhead of trompo.simulate over trompo-simulate's own compute (issue 14 target:
<= 5% for a 10^6-step run).

The same run both ways, interleaved, `--repeat` times each: HT1, Simo-kappa, h = 0.001,
t_end = 1000 (10^6 steps), rows every 1000 steps (the compute) and every step (10^6 rows:
the CLI formats text, Python fills arrays). The CLI is timed as a child process (its CPU
time from getrusage, and wall time including process start), Python in-process
(time.process_time and time.perf_counter around the call). Prints min and median of each
and the ratio Python / CLI of the minima (CPU time: the least disturbed by other load on
a shared machine).

    PYTHONPATH=build/python python3 bench/python_overhead.py build/tools/trompo-simulate
"""
import argparse
import resource
import statistics
import subprocess
import time

import trompo


def cli_run(binary, args):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([binary, *args, "--csv", "/dev/null"], check=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall


def py_run(kwargs):
    c0, t0 = time.process_time(), time.perf_counter()
    rows = trompo.simulate(**kwargs)
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    assert rows["t"][-1] == kwargs["t_end"]
    return cpu, wall


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("cli", help="path to trompo-simulate")
    p.add_argument("--repeat", type=int, default=5)
    a = p.parse_args()
    for every in (1000, 1):
        args = ["--case", "ht1", "--t-end", "1000", "--every", str(every)]
        kwargs = dict(case="ht1", t_end=1000, every=every)
        cli, py = [], []
        for _ in range(a.repeat):
            cli.append(cli_run(a.cli, args))
            py.append(py_run(kwargs))
        print(f"HT1, 10^6 steps, every {every} ({10**6 // every + 1} rows), {a.repeat} runs each:")
        for name, runs in (("CLI   ", cli), ("Python", py)):
            cpu = [r[0] for r in runs]
            wall = [r[1] for r in runs]
            print(f"  {name} cpu min {min(cpu):.4f} s median {statistics.median(cpu):.4f} s | "
                  f"wall min {min(wall):.4f} s median {statistics.median(wall):.4f} s")
        ratio_cpu = min(r[0] for r in py) / min(r[0] for r in cli)
        ratio_wall = min(r[1] for r in py) / min(r[1] for r in cli)
        print(f"  Python / CLI: cpu {ratio_cpu:.3f}, wall {ratio_wall:.3f} (overhead {100 * (ratio_cpu - 1):+.1f}% cpu)")


if __name__ == "__main__":
    main()
