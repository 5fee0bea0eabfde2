"""The Python overhead of a run (BENCHMARKS.md, "Python (issue 41)"):
median wall time of `model.run(t_end=1, steps=N)` on the JIT back end, once
compiled. Compare with `cargo run --release -p kinema-bench --example
py_overhead models/slider_crank.kin N RUNS` (the same run in Rust).
Usage: python overhead.py [MODEL] [STEPS] [RUNS]"""

import statistics
import sys
import time

import kinema

path = sys.argv[1] if len(sys.argv) > 1 else "models/slider_crank.kin"
steps = int(sys.argv[2]) if len(sys.argv) > 2 else 1000
runs = int(sys.argv[3]) if len(sys.argv) > 3 else 21
model = kinema.Model.from_file(path)
for _ in range(50):  # until the JIT's code is in use
    if model.run(t_end=1.0, steps=steps).backend == "jit":
        break
    time.sleep(0.05)
seconds = []
inside = []
for _ in range(runs):
    start = time.perf_counter()
    res = model.run(t_end=1.0, steps=steps)
    seconds.append(time.perf_counter() - start)
    inside.append(res.rust_seconds)
assert res.backend == "jit"
wall, rust = statistics.median(seconds), statistics.median(inside)
ratios = [w / r for w, r in zip(seconds, inside)]
extra = [w - r for w, r in zip(seconds, inside)]
print(
    f"{path}: {steps} steps, {res.values.size} values, median of {runs} runs: "
    f"model.run {wall * 1e3:.3f} ms (min {min(seconds) * 1e3:.3f} ms), of which the Rust loop "
    f"{rust * 1e3:.3f} ms; per run: Python around Rust median {statistics.median(extra) * 1e3:.3f} ms, "
    f"wall / Rust median {statistics.median(ratios):.3f}"
)
