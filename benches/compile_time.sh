#!/usr/bin/env bash
# Compile time of the generated solver of the chain N = 1000 through
# `mechanism!` (issue 20), release and debug: the macro's expansion (parse,
# check, derive, generate, in the proc-macro) plus rustc on its output.
#
# Writes the chain's model text and a one-line example into kinema-bench,
# builds the dependencies, then times `cargo build` of that example alone in
# each profile, and removes both files.
#
#   benches/compile_time.sh [N]        # default N = 1000
#   PROFILES=dev benches/compile_time.sh   # one profile only
# The debug build runs with CARGO_INCREMENTAL=0 (the incremental cache of
# this one file is gigabytes).
set -euo pipefail
cd "$(dirname "$0")/.."
n="${1:-1000}"
kin="crates/kinema-bench/examples/chain${n}_compile.kin"
example="crates/kinema-bench/examples/chain${n}_compile.rs"
trap 'rm -f "$kin" "$example"' EXIT
# kinema_model::chain::chain_kin(n), written by Python (same text).
python3 - "$n" > "$kin" <<'PY'
import math, sys
n = int(sys.argv[1])
print(f"/// Serial chain of {n} unit links (benchmark `chain{n}`), generated.")
print(f"mechanism Chain{n} {{")
px = py = 0.0
for k in range(1, n + 1):
    phi = math.pi / 4 + 0.3 * math.sin(k)
    c, s = math.cos(phi), math.sin(phi)
    print(f"    body b{k} {{ guess: ({px + 0.5 * c!r}, {py + 0.5 * s!r}, {phi!r}) }}")
    px += c
    py += s
print("    joint pin1: revolute(b1(-0.5, 0), ground(0, 0));")
for k in range(2, n + 1):
    print(f"    joint pin{k}: revolute(b{k - 1}(0.5, 0), b{k}(-0.5, 0));")
for k in range(1, n + 1):
    print(f"    driver angle{k}: abs_angle(b{k}, pi / 4 + 0.3 * sin(2 * pi * t + {k}));")
print("}")
PY
cat > "$example" <<RS
//! The chain N = ${n} through \`mechanism!\` (benches/compile_time.sh).
kinema::mechanism!(file = "examples/chain${n}_compile.kin");

fn main() {
    let chain = Chain${n}::default();
    let mut solver = chain.solver(kinema::Options::default()).expect("assembles");
    let state = solver.step(0.5).expect("steps");
    println!("q[0] at t = 0.5: {}", state.q()[0]);
}
RS
export CARGO_INCREMENTAL=0
for profile in ${PROFILES:-release dev}; do
  flag=$([ "$profile" = release ] && echo --release || true)
  # Dependencies first (the profile example has the same), untimed.
  cargo build $flag -p kinema-bench --example profile -q
  start=$(date +%s.%N)
  /usr/bin/time -f "%M" -o /tmp/compile_time_rss cargo build $flag -p kinema-bench --example "chain${n}_compile" -q
  end=$(date +%s.%N)
  dir=$([ "$profile" = release ] && echo release || echo debug)
  size=$(stat -c %s "target/$dir/examples/chain${n}_compile")
  run=$( { /usr/bin/time -f "%e" "target/$dir/examples/chain${n}_compile" >/dev/null; } 2>&1 )
  printf '%s: %.1f s to build the example (peak RSS %s MB), binary %s MB, run (load + 1 step) %s s\n' \
    "$profile" "$(echo "$end - $start" | bc)" "$(( $(cat /tmp/compile_time_rss) / 1024 ))" \
    "$(( size / 1048576 ))" "$run"
done
