#!/usr/bin/env bash
# The Python package's CI: a fresh virtual environment, the package built
# from source by maturin (one release build), numpy, pandas,
# dask[distributed], pytest and matplotlib from the package registry, then
# its pytest suite (which compares with the `kinema` binary: KINEMA_CLI, or
# target/{release,debug}/kinema) and the example notebook script.
# Usage: crates/kinema-py/ci.sh [VENV_DIR]   (exit status: pytest's)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="${1:-$root/target/kinema-py-venv}"
python3 -m venv --clear "$venv"
"$venv/bin/python" -m pip install --quiet --upgrade pip
# The package: maturin from the registry as the build backend, the Rust
# build in release mode (its own target directory under crates/kinema-py).
"$venv/bin/python" -m pip install --quiet "$here"
"$venv/bin/python" -m pip install --quiet numpy pandas "dask[distributed]" pytest matplotlib
cd "$root"
# pytest's exit status is this script's (5, no test collected, fails too).
"$venv/bin/python" -m pytest -q "$here/tests"
