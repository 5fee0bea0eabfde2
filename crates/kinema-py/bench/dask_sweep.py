"""The Dask sweep of 10 000 slider-crank variants on a LocalCluster with 2
workers against 1 worker (one thread each), and its equality with the
in-process sweep (BENCHMARKS.md, "Python (issue 41)").
Usage: python dask_sweep.py [VARIANTS] [STEPS] [REPEATS]"""

import statistics
import sys
import time

import numpy as np
from distributed import Client, LocalCluster

import kinema
import kinema.dask


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 10_000
    steps = int(sys.argv[2]) if len(sys.argv) > 2 else 100
    repeats = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    rng = np.random.default_rng(41)
    table = {"l1": rng.uniform(0.2, 0.35, n), "l2": rng.uniform(0.9, 1.3, n)}
    path = "models/slider_crank.kin"
    start = time.perf_counter()
    local = kinema.Model.from_file(path).sweep(table, steps=steps, threads=1)
    print(f"in process, 1 thread: {time.perf_counter() - start:.2f} s, {local.values.shape}", flush=True)
    times = {}
    for workers in (1, 2):
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(cluster) as client:
            kinema.dask.sweep(client, path, {k: v[:50] for k, v in table.items()}, steps=steps)  # warm the workers
            runs = []
            for _ in range(repeats):
                start = time.perf_counter()
                spread = kinema.dask.sweep(client, path, table, steps=steps)
                runs.append(time.perf_counter() - start)
                assert np.array_equal(spread.values, local.values), "differs from the in-process sweep"
            times[workers] = statistics.median(runs)
            print(f"{workers} worker(s): " + ", ".join(f"{r:.2f} s" for r in runs) + f"; median {times[workers]:.2f} s (equal to in-process: yes)", flush=True)
    print(f"2 workers / 1 worker = {times[2] / times[1]:.3f}")


if __name__ == "__main__":
    main()
