"""The GIL is released while Rust runs: Python keeps running beside it."""

from __future__ import annotations

import threading
import time

import numpy as np

import kinema

from conftest import ROOT


def test_python_runs_while_a_model_runs():
    model = kinema.Model.from_file(ROOT / "models" / "chain10.kin")
    model.run(steps=10)  # compiled (JIT) before timing
    done = threading.Event()
    result = {}

    def work():
        start = time.perf_counter()
        result["res"] = model.run(t_end=1.0, steps=20000)
        result["seconds"] = time.perf_counter() - start
        done.set()

    counter = 0
    t = threading.Thread(target=work)
    t.start()
    # Busy Python in the main thread: with the GIL held by the run it would
    # get only the interpreter's switch interval slices at run's entry.
    while not done.is_set():
        counter += 1
    t.join()
    assert len(result["res"]) == 20001
    # With the GIL released the main thread spins freely for the whole run
    # (millions of iterations per second); held, it would stall.
    assert counter > 50_000 * max(result["seconds"], 0.01), (counter, result["seconds"])


def test_python_runs_while_forward_dynamics_runs():
    model = kinema.Model.from_file(ROOT / "models" / "iftomm" / "a01_pendulum.kin")
    done = threading.Event()
    result = {}

    def work():
        start = time.perf_counter()
        result["res"] = model.forward(t_end=20.0, steps=200, step=1e-4)
        result["seconds"] = time.perf_counter() - start
        done.set()

    counter = 0
    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        counter += 1
    t.join()
    assert len(result["res"]) == 201
    assert counter > 50_000 * max(result["seconds"], 0.01), (counter, result["seconds"])


def test_threads_give_the_same_numbers():
    model = kinema.Model.from_file(ROOT / "models" / "slider_crank.kin")
    expected = model.run(steps=500).values
    out = [None] * 4

    def work(k):
        out[k] = model.run(steps=500).values

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for v in out:
        assert np.array_equal(v, expected)
