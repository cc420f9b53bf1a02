#!/usr/bin/env python3
"""Nutation amplitude of a heavy top over initial tilt x spin, swept with Dask.

Each task integrates one chunk of the sweep as a trompo ensemble (trompo.ensemble: all the
tops of the chunk at once, in C++, GIL released); Dask spreads the chunks over workers,
here or on a cluster, and the results are gathered into one (tilt, spin) array and
plotted.

    # here: a LocalCluster of 2 worker processes on 127.0.0.1
    PYTHONPATH=build/python python3 examples/python/nutation_sweep.py --png nutation.png

    # on a cluster: start `dask-scheduler` on one machine and `dask-worker tcp://host:8786`
    # on the others (each with trompo installed: cmake --install), then, from any machine
    # that can reach the scheduler:
    python3 examples/python/nutation_sweep.py --scheduler tcp://host:8786 --png nutation.png

The top is HT1's Lagrange top (J = diag(5, 5, 1), Mgl = 20, centre of mass on the
symmetry axis) started at tilt theta0 about body axis 1 with spin omega3 about its axis.
The tilt theta(t) = arccos(e3 . Lambda e3) is sampled every `sample` seconds (the
ensemble is run segment by segment, each continuing from the last states) and the
amplitude is max theta - min theta over [0, t_end]. For a fast top it approaches
2 J1 Mgl sin(theta0) / (J3 omega3)^2.
"""
import argparse
import sys

import numpy as np


def nutation_chunk(tilts, spins, *, t_end=2.0, dt=0.001, sample=0.01, case="ht1", scheme="simo-kappa",
                   threads=1):
    """Nutation amplitude of the tops (tilts[i], spins[i]): one trompo ensemble per sample
    interval, each member continuing from its last state. Runs on a Dask worker."""
    import trompo

    tilts = np.asarray(tilts, dtype=float)
    spins = np.asarray(spins, dtype=float)
    n = tilts.size
    rotation = np.zeros((n, 3))
    rotation[:, 0] = tilts
    omega = np.zeros((n, 3))
    omega[:, 2] = spins
    theta_min = tilts.copy()
    theta_max = tilts.copy()
    segments = max(1, int(round(t_end / sample)))
    for _ in range(segments):
        out = trompo.ensemble(rotation, omega, case=case, scheme=scheme, dt=dt, t_end=t_end / segments,
                              threads=threads)
        if not out["ok"].all():
            bad = int(np.argmin(out["ok"]))
            raise RuntimeError(f"top {bad} (tilt {tilts[bad]}, spin {spins[bad]}): {out['status'][bad]}")
        # The tilt of the symmetry axis from the vertical: e3 . Lambda e3 = Lambda_33.
        theta = np.arccos(np.clip(out["R"][:, 2, 2], -1.0, 1.0))
        np.minimum(theta_min, theta, out=theta_min)
        np.maximum(theta_max, theta, out=theta_max)
        rotation, omega = out["R"], out["W"]
    return theta_max - theta_min


def sweep(client, tilts, spins, *, chunk=64, **kwargs):
    """The (len(tilts), len(spins)) array of nutation amplitudes, in chunks of `chunk`
    tops per Dask task. `client` None computes locally (same numbers)."""
    T, S = np.meshgrid(np.asarray(tilts, float), np.asarray(spins, float), indexing="ij")
    flat_t, flat_s = T.ravel(), S.ravel()
    pieces = [(flat_t[i:i + chunk], flat_s[i:i + chunk]) for i in range(0, flat_t.size, chunk)]
    if client is None:
        results = [nutation_chunk(t, s, **kwargs) for t, s in pieces]
    else:
        futures = [client.submit(nutation_chunk, t, s, pure=False, **kwargs) for t, s in pieces]
        results = client.gather(futures)
    return np.concatenate(results).reshape(T.shape)


def plot(tilts, spins, amplitude, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    mesh = ax.pcolormesh(spins, tilts, np.log10(amplitude), shading="auto", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label="log10 nutation amplitude [rad]")
    ax.set_xlabel("spin omega3 [rad/s]")
    ax.set_ylabel("initial tilt theta0 [rad]")
    ax.set_title("Heavy top (HT1): nutation amplitude, trompo ensembles on Dask")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def connect(scheduler, workers):
    """A Client on the given scheduler, or on a LocalCluster bound to 127.0.0.1 (no
    dashboard, nothing listening beyond loopback)."""
    from dask.distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler), None
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=None)
    return Client(cluster), cluster


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scheduler", help="address of a running Dask scheduler, e.g. tcp://host:8786 "
                                       "(default: a LocalCluster on 127.0.0.1)")
    p.add_argument("--workers", type=int, default=2, help="LocalCluster worker processes (default 2)")
    p.add_argument("--tilts", type=int, default=16, help="tilts from 0.05 to 0.5 rad (default 16)")
    p.add_argument("--spins", type=int, default=16, help="spins from 15 to 60 rad/s (default 16)")
    p.add_argument("--t-end", type=float, default=2.0, help="seconds per top (default 2)")
    p.add_argument("--chunk", type=int, default=32, help="tops per Dask task (default 32)")
    p.add_argument("--png", default="nutation.png", help="the plot (default nutation.png)")
    p.add_argument("--npy", help="also save the amplitude array (.npy)")
    a = p.parse_args(argv)
    tilts = np.linspace(0.05, 0.5, a.tilts)
    spins = np.linspace(15.0, 60.0, a.spins)
    client, cluster = connect(a.scheduler, a.workers)
    try:
        amplitude = sweep(client, tilts, spins, chunk=a.chunk, t_end=a.t_end)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    plot(tilts, spins, amplitude, a.png)
    if a.npy:
        np.save(a.npy, amplitude)
    print(f"{amplitude.size} tops in {-(-amplitude.size // a.chunk)} chunks; amplitude "
          f"{amplitude.min():.3g} .. {amplitude.max():.3g} rad; plot: {a.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
