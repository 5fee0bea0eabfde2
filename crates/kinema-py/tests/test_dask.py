"""kinema.dask.sweep on a 2-worker LocalCluster equals the in-process sweep."""

from __future__ import annotations

import numpy as np
import pytest

import kinema

from conftest import ROOT

distributed = pytest.importorskip("distributed")

SLIDER = ROOT / "models" / "slider_crank.kin"


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


def table(n: int):
    rng = np.random.default_rng(41)
    return {"l1": rng.uniform(0.2, 0.35, n), "l2": rng.uniform(0.9, 1.3, n)}


def test_dask_sweep_equals_in_process(client):
    import kinema.dask

    t = table(300)
    local = kinema.Model.from_file(SLIDER).sweep(t, t_end=1.0, steps=40)
    spread = kinema.dask.sweep(client, SLIDER, t, t_end=1.0, steps=40)
    assert spread.columns == local.columns
    assert spread.values.shape == (300 * 41, len(local.columns))
    assert np.array_equal(spread.values, local.values)
    # Every variant numbered once, in order.
    assert np.array_equal(np.unique(spread["row"]), np.arange(1, 301))


def test_dask_sweep_positions_only_and_uneven_shards(client):
    import kinema.dask

    t = table(37)
    local = kinema.Model.from_file(SLIDER).sweep(t, steps=10, positions_only=True)
    spread = kinema.dask.sweep(client, SLIDER, t, steps=10, positions_only=True, n_shards=5)
    assert np.array_equal(spread.values, local.values)


def test_dask_sweep_failures_as_in_process(client):
    import kinema.dask

    t = {"l2": [1.0, 0.2, 1.1, 0.1]}
    with pytest.raises(kinema.AnalysisError, match="2 of 4 variants failed") as info:
        kinema.dask.sweep(client, SLIDER, t, steps=5, n_shards=3)
    with pytest.raises(kinema.AnalysisError) as local:
        kinema.Model.from_file(SLIDER).sweep(t, steps=5)
    assert np.array_equal(info.value.results.values, local.value.results.values)


def test_dask_bad_model_raises_before_submitting(client, tmp_path):
    import kinema.dask

    with pytest.raises(FileNotFoundError):
        kinema.dask.sweep(client, tmp_path / "none.kin", {"l1": [0.3]})


def test_shards_cover_the_rows():
    import kinema.dask

    for n in (0, 1, 7, 100):
        for parts in (1, 3, 8):
            r = kinema.dask.shards(n, parts)
            assert sum(b - a for a, b in r) == n
            assert all(a < b for a, b in r)
            assert all(r[i][1] == r[i + 1][0] for i in range(len(r) - 1))
