#!/usr/bin/env python3
"""IFToMM A02 (the N four-bar mechanism, N = 1 and 40, the published start and 20 s) with
kinema and Exudyn side by side, in one run (BENCHMARKS.md, "IFToMM problems").

For each setting, in turn: Exudyn (iftomm_exudyn.py, a process of its own) and the `kinema`
release binary on models/iftomm/a02_four_bar_N.kin (400 outputs). Error: the largest difference
over the outputs and the N + 1 cranks between a crank's angle and the one-degree-of-freedom
reference (iftomm_ref.py). Time: Exudyn's solve (set-up not counted), kinema's whole process
(parse, derivation, tape compilation, solve and CSV writing all counted). Prints a Markdown
table.

  python run_iftomm.py [--kinema ../../target/release/kinema] [--quick]
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

from iftomm_ref import reference

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))


def kinema_run(binary, n, options):
    """(max crank error, wall seconds, singular passages in the run's summary) of one kinema
    run (the warnings themselves stop listing at 20)."""
    model = os.path.join(ROOT, "models", "iftomm", f"a02_four_bar_{n}.kin")
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "a02.csv")
        cmd = [binary, "run", model, "--t-end", "20", "--steps", "400", "--out", out, *options]
        t0 = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            return None, wall, p.stderr.strip().splitlines()[-1:]
        data = np.genfromtxt(out, delimiter=",", names=True)
    t = data["t"]
    exact = reference(n, t)
    worst = max(float(np.max(np.abs(data[f"crank{i}phi"] - exact))) for i in range(n + 1))
    found = re.search(r"singular configurations passed: (\d+)", p.stdout + p.stderr)
    passages = int(found.group(1)) if found else 0
    return worst, wall, passages


def exudyn_run(n, h):
    p = subprocess.run([sys.executable, os.path.join(HERE, "iftomm_exudyn.py"), str(n), "--h", str(h)],
                       capture_output=True, text=True)
    if p.returncode != 0:
        return None
    return json.loads(p.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--kinema", default=os.path.join(ROOT, "target", "release", "kinema"))
    ap.add_argument("--quick", action="store_true", help="N = 1 only")
    a = ap.parse_args()
    rows = []
    for n in ([1] if a.quick else [1, 40]):
        for h in [1e-3, 2.5e-4]:
            e = exudyn_run(n, h)
            k_err, k_wall, k_pass = kinema_run(a.kinema, n, ["--step", str(h)])
            if e is None:
                ex = "failed"
            elif not e["ok"]:
                ex = (f"stopped at t = {e['t_reached']:.2f} (solver failed); "
                      f"{e['max_crank_error']:.2g} rad until then, {e['wall_s']:.2f} s")
            else:
                ex = f"{e['max_crank_error']:.2g} rad, {e['wall_s']:.2f} s"
            ki = f"{k_err:.2g} rad, {k_wall:.2f} s ({k_pass} passages)" if k_err is not None \
                else f"failed: {k_pass}"
            rows.append((n, f"fixed step h = {h:g}", ex, ki))
            print(rows[-1], flush=True)
        for rtol in ["1e-6", "1e-8"]:
            k_err, k_wall, k_pass = kinema_run(a.kinema, n, ["--integrator", "accurate", "--rtol", rtol])
            ki = f"{k_err:.2g} rad, {k_wall:.2f} s ({k_pass} passages)" if k_err is not None \
                else f"failed: {k_pass}"
            rows.append((n, f"kinema accurate, rtol {rtol}", "—", ki))
            print(rows[-1], flush=True)
    print()
    print("| A02, 20 s | setting | Exudyn generalized-α (ρ∞ = 0.8182) | kinema (HHT α = −0.1 / accurate) |")
    print("|---|---|---|---|")
    for n, setting, ex, ki in rows:
        print(f"| N = {n} | {setting} | {ex} | {ki} |")


if __name__ == "__main__":
    main()
