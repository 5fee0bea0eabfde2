#!/usr/bin/env bash
# The Strider peer (issue 20): pylinkage (pure Python and numba) against
# kinema from the model file, positions over one crank turn in 360 steps,
# the same positions compared, timings side by side. Own venv
# (.venv-strider, requirements-strider.txt); kinema's release binary.
#   benches/peers/run_strider.sh [REPS]
set -euo pipefail
cd "$(dirname "$0")"
reps="${1:-20}"
PY=.venv-strider/bin/python
if [ ! -x "$PY" ]; then
  python3 -m venv .venv-strider
  .venv-strider/bin/pip install -q -r requirements-strider.txt
fi
mkdir -p results
root=../..
model=$root/crates/kinema-bench/models/strider.kin
(cd $root && cargo build --release -q -p kinema-cli --bin kinema)
kinema=$root/target/release/kinema
$kinema run "$model" --steps 360 --positions-only --out results/strider_kinema.csv > /dev/null
$PY bench_strider.py --reps "$reps" --csv results/strider_pylinkage.csv \
  --json results/strider.json --kinema results/strider_kinema.csv
# kinema from the model file, the whole process (read, derive, tapes, 360
# steps, CSV), best and median of REPS runs.
$PY - "$kinema" "$model" "$reps" <<'PY'
import statistics, subprocess, sys, time
kinema, model, reps = sys.argv[1], sys.argv[2], int(sys.argv[3])
for extra in (["--positions-only"], []):
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        subprocess.run([kinema, "run", model, "--steps", "360", *extra, "--out",
                        "results/strider_kinema_timed.csv"], check=True, stdout=subprocess.DEVNULL)
        times.append(time.perf_counter() - t0)
    label = " ".join(extra) or "(full analysis)"
    print(f"kinema run {label}: whole process median {statistics.median(times) * 1e3:.2f} ms, "
          f"best {min(times) * 1e3:.2f} ms")
PY
(cd $root && cargo run --release -q -p kinema-bench --example strider -- "$reps")
