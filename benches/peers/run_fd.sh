#!/usr/bin/env bash
# Forward-dynamics peer benchmark (README.md section 6): Exudyn on fd_slider_crank, fd_chain10,
# fd_chain100; kinema's tape forward step (criterion); kinema's reference q at t = 1; then the
# forward-dynamics section of RESULTS.md. ~15 minutes on the 2-core machine (the release build of
# kinema-bench not counted).
set -euo pipefail
cd "$(dirname "$0")"
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
PY=.venv/bin/python
if [ ! -x "$PY" ]; then
  python3 -m venv .venv
  .venv/bin/pip install -q -r requirements.txt
fi
if ! "$PY" -c "import exudyn" 2>/dev/null; then
  .venv/bin/pip install -q -r requirements-fd.txt
fi
mkdir -p results
start=$(date +%s)
$PY bench_exudyn.py fd_slider_crank --reps 15
$PY bench_exudyn.py fd_chain10 --reps 9
# Dense LU at n + m = 500 with full Newton takes minutes a run: the sparse solver both ways, dense modified
$PY bench_exudyn.py fd_chain100 --reps 3 --solvers EigenSparse,EigenSparse/full,EigenDense
(cd ../.. && cargo run -q --release -p kinema-bench --example fd_reference > benches/peers/reference/fd_q_t1.csv)
(cd ../.. && cargo bench -p kinema-bench --bench forward_tape)
python3 make_fd_results.py > /dev/null
echo "run_fd.sh done in $(( $(date +%s) - start )) s; see RESULTS.md"
