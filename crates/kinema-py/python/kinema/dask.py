"""Sweeps spread over a ``dask.distributed`` cluster.

:func:`sweep` splits a sweep's variants into contiguous shards (as
``kinema sweep --shard i/n`` does), runs each shard on a worker (the model
is read there from ``model_path``, once per worker process) and gathers one
:class:`kinema.Results` whose ``values`` equal those of
``Model.from_file(model_path).sweep(table, **run_options)`` in one process:
every variant starts from the model's initial guess, whichever worker runs
it.

Dask is an optional dependency: ``pip install "dask[distributed]"``.
"""

from __future__ import annotations

import os
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from . import Model, Results, TableLike, _finish_sweep, _table

__all__ = ["sweep", "shards"]

# Models read on this worker process: (path, mtime, size) -> Model.
_MODELS: Dict[Tuple[str, float, int], Model] = {}


def _model(path: str) -> Model:
    st = os.stat(path)
    key = (os.path.abspath(path), st.st_mtime, st.st_size)
    model = _MODELS.get(key)
    if model is None:
        model = Model.from_file(path)
        _MODELS.clear()
        _MODELS[key] = model
    return model


def shards(n: int, parts: int) -> List[Tuple[int, int]]:
    """The contiguous ranges [start, end) of ``n`` variants in ``parts``
    parts, sizes differing by at most one (empty parts dropped)."""
    if parts < 1:
        raise ValueError(f"parts must be at least 1, found {parts}")
    base, extra = divmod(n, parts)
    out = []
    start = 0
    for i in range(parts):
        end = start + base + (1 if i < extra else 0)
        if end > start:
            out.append((start, end))
        start = end
    return out


def _run_shard(
    model_path: str,
    names: List[str],
    block: np.ndarray,
    first: int,
    grid: List[float],
    options: Dict[str, Any],
) -> Dict[str, Any]:
    """One shard on a worker: the native sweep of rows ``first ..``."""
    model = _model(model_path)
    out = model._native.sweep({"names": names, "table": block, "times": grid, "first": first, **options})
    return {
        "columns": list(out["columns"]),
        "values": out["values"],
        "failures": list(out["failures"]),
        "flagged": list(out["flagged"]),
    }


def sweep(
    client: Any,
    model_path: "str | os.PathLike[str]",
    table: TableLike,
    *,
    shards_per_worker: int = 4,
    n_shards: Optional[int] = None,
    t_end: Optional[float] = None,
    steps: Optional[int] = None,
    times: Optional[Any] = None,
    positions_only: bool = False,
    stop_at_singular: bool = False,
    backend: str = "jit",
    threads: int = 1,
    errors: str = "raise",
) -> Results:
    """:meth:`kinema.Model.sweep` on a Dask cluster.

    Args:
        client: a ``dask.distributed.Client``.
        model_path: the ``.kin`` file, readable at this path on every worker.
        table: a dict of arrays or a DataFrame (parameter names as keys).
        shards_per_worker: shards per worker (more evens out the load).
        n_shards: the number of shards instead.
        threads: threads per shard on a worker (1: one core per worker
            thread, the usual Dask layout).
        t_end, steps, times, positions_only, stop_at_singular, backend,
        errors: as :meth:`kinema.Model.sweep`.

    Returns:
        The same :class:`kinema.Results` as the in-process sweep (same
        ``columns``, same ``values``).
    """
    path = os.fspath(model_path)
    model = Model.from_file(path)  # errors in the model are raised here, once
    grid = model._sweep_grid(t_end, steps, times)
    names, array = _table(table)
    if n_shards is None:
        workers = max(1, len(client.scheduler_info().get("workers", {})))
        n_shards = workers * max(1, int(shards_per_worker))
    options = {
        "positions_only": bool(positions_only),
        "stop_at_singular": bool(stop_at_singular),
        "backend": backend,
        "threads": threads,
    }
    ranges = shards(len(array), n_shards)
    futures = [
        client.submit(_run_shard, path, names, array[a:b], a, grid, options, pure=False)
        for a, b in ranges
    ]
    parts = client.gather(futures)
    columns = model._native.sweep({"names": names, "table": array[:0], "times": grid, **options, "threads": 1})["columns"]
    if parts:
        values = np.concatenate([p["values"] for p in parts], axis=0)
    else:
        values = np.zeros((0, len(columns)))
    failures = [f for p in parts for f in p["failures"]]
    flagged = [f for p in parts for f in p["flagged"]]
    return _finish_sweep(list(columns), values, failures, flagged, names, array, errors, stacklevel=3)
