#!/usr/bin/env bash
# The synthesis benchmark (issue 40): `kinema fit` on each published problem
# (README.md), timed, then the peer, pylinkage's own optimizers on the same
# problems (pylinkage_bench.py), same machine, one run each.
#
#   benches/synthesis/run.sh [STARTS]        (default 64 starts per fit)
#
# First every problem with STARTS starts (its fitted models, plots and
# summaries in results/), then the ladder: every problem again with 1, 2,
# 4, … STARTS starts (results/ladder/), for kinema's time to reach a given
# error (table.py: the smallest rung whose best design, over the variants,
# is at or below pylinkage's best; its time, the variants' sum).
#
# Needs: python3 (a venv .venv with requirements.txt is made on first use),
# and kinema's release binary (built here). Results in results/: the fitted
# models, fit plots, kinema's summaries, pylinkage.json/.txt.
#
# The kinema fit invocations follow the interface of issue 40; adjust them
# here if the CLI differs. Problems without prescribed timing are fitted
# for both senses of crank rotation (param sense = +1, -1) and, like every
# problem, both assembly branches (param branch = +1, -1): these are
# discrete choices a least-squares fit does not vary.
set -euo pipefail
cd "$(dirname "$0")"
starts="${1:-64}"
root=../..
(cd "$root" && cargo build --release -q -p kinema-cli --bin kinema)
kinema="${CARGO_TARGET_DIR:-$root/target}/release/kinema"
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
  .venv/bin/pip install -q -r requirements.txt
fi
mkdir -p results
two_pi=6.283185307179586
ang="0:$two_pi"

# variant MODEL SENSE BRANCH -> a copy of MODEL with those params
variant() {
  local model=$1 sense=$2 branch=$3 out
  out="results/$(basename "$model" .kin).s${sense}.b${branch}.kin"
  sed -e "s/^    param sense = .*;/    param sense = ${sense};/" \
      -e "s/^    param branch = .*;/    param branch = ${branch};/" "$model" > "$out"
  echo "$out"
}

# fit NAME SENSES BRANCHES -- kinema fit arguments...
fit() {
  local name=$1 senses=$2 branches=$3
  shift 4
  for s in $senses; do
    for b in $branches; do
      local model tag t0 t1
      model=$(variant "$name.kin" "$s" "$b")
      tag="$name.s$s.b$b${ladder:+.n$starts}"
      t0=$EPOCHREALTIME
      if "$kinema" fit "$model" --target "$name.csv" --starts "$starts" "$@" \
          --out "$dir/$tag.fitted.kin" --plot "$dir/$tag.svg" \
          --summary "$dir/$tag.summary.csv" > "$dir/$tag.fit.txt" 2>&1; then
        status=ok
      else
        status="exit $?"
      fi
      t1=$EPOCHREALTIME
      printf '%-28s %4d starts %8.3f s  (%s)\n' "kinema fit $tag" "$starts" "$(awk "BEGIN{print $t1 - $t0}")" "$status"
      printf '%s %s %s\n' "$tag" "$starts" "$(awk "BEGIN{print $t1 - $t0}")" >> "$dir/kinema_times.txt"
      [ "$quiet" = 1 ] || sed 's/^/    /' "$dir/$tag.fit.txt" | tail -n 15
    done
  done
}

# every problem, with $starts starts, into $dir
problems() {
  # 6 points on a line, no timing (Cabrera et al. 2002 / Kunjur & Krishnamurty 1997).
  fit straight6 "1 -1" "1 -1" -- --t-end "$two_pi" --full-turn crank \
    --vary r1,r2,r3,r4,rcx,rcy,x0,y0,theta0,phase \
    --bounds "r1=5:60,r2=5:60,r3=5:60,r4=5:60,rcx=-60:60,rcy=-60:60,x0=-60:60,y0=-60:60,theta0=$ang,phase=$ang"
  # 5 points on an arc, prescribed timing, frame fixed (Kunjur & Krishnamurty 1997).
  fit arc5 "1" "1 -1" -- --t-end 1.0471975511965979 --steps 60 \
    --vary r1,r2,r3,r4,rcx,rcy \
    --bounds "r1=0.001:50,r2=0.001:50,r3=0.001:50,r4=0.001:50,rcx=-50:50,rcy=-50:50"
  # 18 points on a closed curve, 20-degree steps from a free start (Cabrera et al. 2002).
  fit closed18 "1" "1 -1" -- --t-end "$two_pi" --full-turn crank \
    --vary r1,r2,r3,r4,rcx,rcy,x0,y0,theta0,phase \
    --bounds "r1=0.001:50,r2=0.001:50,r3=0.001:50,r4=0.001:50,rcx=-50:50,rcy=-50:50,x0=-50:50,y0=-50:50,theta0=$ang,phase=$ang"
  # 6 points on a half circle, prescribed timing; the crank turns fully
  # (checked over one turn, so the cycle is 2π, the targets within it).
  fit semicircle6 "1" "1 -1" -- --t-end "$two_pi" --full-turn crank \
    --vary r1,r2,r3,r4,rcx,rcy,x0,y0,theta0 \
    --bounds "r1=5:50,r2=5:50,r3=5:50,r4=5:50,rcx=-50:50,rcy=-50:50,x0=-50:50,y0=-50:50,theta0=$ang"
  # 10 points on an ellipse, no timing (first = last: see README.md).
  fit ellipse10 "1 -1" "1 -1" -- --t-end "$two_pi" --full-turn crank \
    --vary r1,r2,r3,r4,rcx,rcy,x0,y0,theta0,phase \
    --bounds "r1=0.001:80,r2=0.001:80,r3=0.001:80,r4=0.001:80,rcx=-80:80,rcy=-80:80,x0=-80:80,y0=-80:80,theta0=$ang,phase=$ang"
  # Function generation y = log10(x) (kinema's statement; r1 = 1).
  fit log10 "1" "1 -1" -- --t-end 1.5707963267948966 --steps 90 \
    --vary r2,r3,r4,phase,psi0 \
    --bounds "r2=0.05:5,r3=0.05:5,r4=0.05:5,phase=$ang,psi0=$ang"
  # Function generation, published: the textbook crank-rocker (README.md);
  # gmax <= 3π/4 is the book's transmission-angle constraint, π/4 no
  # restriction (gmax >= gmin >= 45°); the crank turns fully.
  fit crankrocker30 "1" "1" -- --t-end "$two_pi" --full-turn crank \
    --vary l2,gmax --bounds "l2=1:10,gmax=0.7853981633974483:2.356194490192345"
}

echo "== kinema fit ($starts starts per fit)"
dir=results quiet=0 ladder=
: > "$dir/kinema_times.txt"
problems

echo "== kinema's designs by the literature's closed form (check_fitted.py)"
.venv/bin/python check_fitted.py | tee results/check.txt

echo "== kinema fit, the ladder (1, 2, 4, … $starts starts)"
full=$starts
dir=results/ladder quiet=1 ladder=1
mkdir -p "$dir"
: > "$dir/kinema_times.txt"
starts=1
while [ "$starts" -le "$full" ]; do
  problems
  starts=$((starts * 2))
done

echo "== pylinkage (its PSO and DE, one run each)"
t0=$EPOCHREALTIME
.venv/bin/python pylinkage_bench.py --json results/pylinkage.json | tee results/pylinkage.txt
t1=$EPOCHREALTIME
printf 'pylinkage total %.1f s\n' "$(awk "BEGIN{print $t1 - $t0}")"
python3 table.py
