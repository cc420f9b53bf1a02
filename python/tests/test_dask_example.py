"""examples/python/nutation_sweep.py on a 2-worker LocalCluster (127.0.0.1): the gathered
sweep equals the same sweep computed without Dask, bit for bit; the amplitudes agree with
the closed-form Lagrange top sampled on the same grid (to 1e-3 relative at h = 0.001);
the PNG is written."""
import sys

import numpy as np

import trompo
from conftest import ROOT, import_or_skip

sys.path.insert(0, str(ROOT / "examples" / "python"))
import nutation_sweep  # noqa: E402

distributed = import_or_skip("dask.distributed")  # an error under TROMPO_REQUIRE_ALL=1 (ctest)


def closed_form_amplitude(tilt, spin, t_end, sample):
    r = trompo.simulate(case="ht1", scheme="exact", rotation=[tilt, 0, 0], omega=[0, 0, spin], dt=sample,
                        t_end=t_end)
    theta = np.arccos(np.clip(r["R"][:, 2, 2], -1, 1))
    return theta.max() - theta.min()


def test_sweep_on_a_two_worker_local_cluster(tmp_path):
    tilts = np.array([0.05, 0.2, 0.4])
    spins = np.array([20.0, 40.0, 60.0])
    kwargs = dict(t_end=1.0, sample=0.02)
    client, cluster = nutation_sweep.connect(None, 2)
    try:
        assert len(client.scheduler_info()["workers"]) == 2
        assert client.scheduler.address.startswith("tcp://127.0.0.1:")
        amplitude = nutation_sweep.sweep(client, tilts, spins, chunk=4, **kwargs)
    finally:
        client.close()
        cluster.close()
    assert amplitude.shape == (3, 3)
    local = nutation_sweep.sweep(None, tilts, spins, chunk=4, **kwargs)
    assert np.array_equal(amplitude, local)
    for i, tilt in enumerate(tilts):
        for j, spin in enumerate(spins):
            ref = closed_form_amplitude(tilt, spin, **kwargs)
            assert abs(amplitude[i, j] - ref) <= 1e-3 * ref, (tilt, spin)  # h = 0.001, order 2: ~3e-4 seen
    # faster tops nutate less
    assert np.all(np.diff(amplitude, axis=1) < 0)
    png = tmp_path / "nutation.png"
    nutation_sweep.plot(tilts, spins, amplitude, png)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
