"""Two models in two threads against one after the other (BENCHMARKS.md,
"Python (issue 41)"): the GIL is released while Rust runs, so the threads
overlap. Usage: python gil.py [STEPS] [REPEATS]"""

import statistics
import sys
import threading
import time

import kinema

steps = int(sys.argv[1]) if len(sys.argv) > 1 else 100_000
repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 5
models = [kinema.Model.from_file("models/slider_crank.kin"), kinema.Model.from_file("models/four_bar.kin")]
for m in models:
    while m.run(steps=100).backend != "jit":
        time.sleep(0.05)


def sequential():
    for m in models:
        m.run(t_end=10.0, steps=steps)


def threaded():
    ts = [threading.Thread(target=m.run, kwargs=dict(t_end=10.0, steps=steps)) for m in models]
    for t in ts:
        t.start()
    for t in ts:
        t.join()


ratios = []
for _ in range(repeats):
    a = time.perf_counter()
    sequential()
    b = time.perf_counter()
    threaded()
    c = time.perf_counter()
    ratios.append(((c - b) / (b - a), b - a, c - b))
    print(f"one after the other {b - a:.3f} s, two threads {c - b:.3f} s, ratio {(c - b) / (b - a):.3f}", flush=True)
r = statistics.median(x[0] for x in ratios)
print(f"median ratio (two threads / one after the other) over {repeats}: {r:.3f}")
