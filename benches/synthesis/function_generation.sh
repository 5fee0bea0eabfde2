#!/usr/bin/env bash
# The two function-generation problems (README.md §6 log10, §7 crankrocker30):
# kinema fit's ladder (1, 2, 4, … 64 starts, every variant: log10 on both
# branches), then pylinkage's optimizers on the same problems — one run, for
# BENCHMARKS.md's "Function generation" table. Per line: problem, variant,
# starts, wall seconds, the best design's rms error (the literature's error
# is rows × rms²). Needs the venv of run.sh (.venv).
#
#   CARGO_TARGET_DIR=… benches/synthesis/function_generation.sh
set -euo pipefail
cd "$(dirname "$0")"
root=../..
(cd "$root" && cargo build --release -q -p kinema-cli --bin kinema)
K="${CARGO_TARGET_DIR:-$root/target}/release/kinema"
two_pi=6.283185307179586
out=results/function_generation
mkdir -p "$out"
for b in 1 -1; do
  sed -e "s/^    param branch = .*;/    param branch = $b;/" log10.kin > "$out/log10.b$b.kin"
done
# run NAME STARTS SUMMARY -- kinema fit arguments...
run() {
  local name=$1 n=$2 summary=$3 t0 t1
  shift 4
  t0=$EPOCHREALTIME
  "$K" fit "$@" --starts "$n" --summary "$summary" > /dev/null 2>&1
  t1=$EPOCHREALTIME
  echo "$name $n $(awk "BEGIN{print $t1 - $t0}") $(sed -n 2p "$summary" | cut -d, -f2)"
}
for n in 1 2 4 8 16 32 64; do
  for b in 1 -1; do
    run "log10.b$b" "$n" "$out/log10.b$b.n$n.csv" -- "$out/log10.b$b.kin" --target log10.csv \
      --t-end 1.5707963267948966 --steps 90 --vary r2,r3,r4,phase,psi0 \
      --bounds "r2=0.05:5,r3=0.05:5,r4=0.05:5,phase=0:$two_pi,psi0=0:$two_pi"
  done
  run crankrocker30 "$n" "$out/crankrocker30.n$n.csv" -- crankrocker30.kin \
    --target crankrocker30.csv --t-end "$two_pi" --full-turn crank --vary l2,gmax \
    --bounds "l2=1:10,gmax=0.7853981633974483:2.356194490192345"
done
.venv/bin/python pylinkage_bench.py --problems log10,crankrocker30 --json "$out/pylinkage.json"
