#!/usr/bin/env bash
# Runs every peer benchmark and writes results/*.json, results/traj_*.csv, RESULTS.md, reference/.
# ~6-8 minutes on the 2-core machine. Optional: apt-get install libopenblas-dev (LAPACK C variant).
set -euo pipefail
cd "$(dirname "$0")"
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
PY=.venv/bin/python
if [ ! -x "$PY" ]; then
  python3 -m venv .venv
  .venv/bin/pip install -q -r requirements.txt
fi
mkdir -p results build
rm -f results/*.json results/*.csv
start=$(date +%s)
for m in slider_crank four_bar chain2 chain10 chain50; do
  $PY bench_sympy.py "$m" --reps 5 --variants numpy,math,splu --naive-dense
  $PY bench_casadi.py "$m" --reps 7 --py-reps 3
done
# n = 600: dense peers time 100 steps (k=0..100) x 3 reps; sparse peers the full 1000 steps
$PY bench_sympy.py chain200 --reps 3 --variants numpy,splu --dense-steps 100 --naive-dense
$PY bench_casadi.py chain200 --reps 3 --c-steps 100 --py-reps 3
# n = 3000: dense LU is O(n^3); dense peers time only the first warm-started steps (k=1..3, own LU k=1)
$PY bench_sympy.py chain1000 --reps 2 --variants numpy,splu --dense-steps 3
$PY bench_casadi.py chain1000 --reps 1 --c-steps 3 --own-steps 1 --py-reps 2
$PY make_results.py > /dev/null
$PY make_reference.py > /dev/null   # reference/traj_*.csv (committed) from results/
# The Strider peer (pylinkage + numba), its own venv.
./run_strider.sh 10
echo "run_all.sh done in $(( $(date +%s) - start )) s; see RESULTS.md"
