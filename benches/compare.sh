#!/usr/bin/env bash
# One command for the side-by-side comparison of BENCHMARKS.md: runs the
# peers (SymPy, CasADi; benches/peers/run_all.sh, ~6-8 min, makes its own
# Python venv) and kinema's criterion benchmarks (every benchmark mechanism,
# every back end, both modes; the derivation) back to back, then rewrites the
# comparison section of BENCHMARKS.md with the machine it ran on.
#
#   benches/compare.sh            # everything
#   benches/compare.sh --no-peers # reuse benches/peers/results from a previous run
#
# Run it on a quiet machine: the figures are medians, but two cores shared
# with a compiler are not quiet.
set -euo pipefail
cd "$(dirname "$0")/.."

if [ "${1:-}" != "--no-peers" ]; then
    benches/peers/run_all.sh
fi
if [ ! -f benches/peers/results/summary.csv ]; then
    echo "no peer results: run without --no-peers first" >&2
    exit 2
fi

# kinema: release builds, single process at a time.
cargo bench -p kinema-bench --features large --bench steps
cargo bench -p kinema-bench --bench derivation

python3 benches/make_table.py
echo "BENCHMARKS.md updated"
