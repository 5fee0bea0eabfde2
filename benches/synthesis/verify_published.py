"""Runs kinema on each <name>.published.kin to the targets' times and
compares the coupler point with the targets: the sum of squared distances
(the literature's error measure) against the same number computed from the
literature's own formula (problems.py). Agreement checks both the model and
the published figure; kinema's warnings (singular configurations) are shown.

    python3 verify_published.py [KINEMA]   (default ../../target/debug/kinema)
"""

import math
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_models import design_params, timing_of, write_model  # noqa: E402
from problems import (  # noqa: E402
    PROBLEMS,
    crankrocker_reference,
    crankrocker_targets,
    PUBLISHED,
    defects,
    error_literature,
    freudenstein_reference,
    function_error,
    function_targets,
)

HERE = os.path.dirname(os.path.abspath(__file__))


def point_at(kinema, model, t):
    """(x, y) of coupler.p at time t, run from t = 0 (steps <= 0.01 apart), and stderr."""
    steps = max(1, math.ceil(t / 0.01))
    out = subprocess.run([kinema, "run", model, "--t-end", repr(t) if t > 0 else "1e-9",
                          "--steps", str(steps), "--positions-only", "--columns", "coupler.p",
                          "--out", "-"], capture_output=True, text=True)
    if out.returncode != 0:
        return None, out.stderr.strip()
    lines = out.stdout.strip().splitlines()
    head = lines[0].split(",")
    last = [float(v) for v in lines[-1].split(",")]
    warn = "\n".join(line for line in out.stderr.splitlines() if "warning" in line.lower())
    return (last[head.index("coupler.p.x")], last[head.index("coupler.p.y")]), warn


def error_through_kinema(kinema, model, name, times):
    """The error at the targets (one run per target from t = 0) and kinema's warnings."""
    total, warns = 0.0, set()
    for (tx, ty), t in zip(PROBLEMS[name]["targets"], times):
        pt, warn = point_at(kinema, model, t)
        if pt is None:
            return float("nan"), {f"failed at t = {t:.4g}: {warn.splitlines()[0] if warn else ''}"}
        if warn:
            warns.update(warn.splitlines())
        total += (pt[0] - tx) ** 2 + (pt[1] - ty) ** 2
    return total, warns


def main():
    kinema = sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "../../target/debug/kinema")
    tmp = os.path.join(HERE, "results")
    os.makedirs(tmp, exist_ok=True)
    print("Best published design per problem (the .published.kin files):")
    for name in PROBLEMS:
        model = os.path.join(HERE, f"{name}.published.kin")
        with open(os.path.join(HERE, f"{name}.published.times")) as f:
            times = [float(v) for v in f if not v.startswith("#")]
        label, _via, x = min(PUBLISHED[name], key=lambda d: error_literature(name, d[2]))
        total, _ = error_through_kinema(kinema, model, name, times)
        lit = error_literature(name, x)
        rel = abs(total - lit) / max(lit, 1e-300)
        print(f"  {name:12s} {label:36s} kinema {total:.10g}  literature formula {lit:.10g}"
              f"  (relative difference {rel:.1e})")
    # Function generation: the textbook reference design, one run on the targets' grid.
    tg = function_targets()
    model = os.path.join(HERE, "log10.reference.kin")
    out = subprocess.run([kinema, "run", model, "--t-end", repr(tg[-1][0]), "--steps",
                          str(len(tg) - 1), "--positions-only", "--columns", "psi", "--out", "-"],
                         capture_output=True, text=True, check=True)
    rows = [line.split(",") for line in out.stdout.strip().splitlines()]
    col = rows[0].index("psi")
    total = sum((float(r[col]) - psi) ** 2 for r, (_t, psi) in zip(rows[1:], tg))
    ref = function_error(*freudenstein_reference(math.pi / 6, 5 * math.pi / 12), sigma=-1)
    print(f"  log10        Freudenstein 3-point (textbook)      kinema {total:.10g}  closed form "
          f"{ref:.10g}  (relative difference {abs(total - ref) / ref:.1e})")
    # The published function generator: the book's optimum, one run on the targets' grid
    # (t = 0 is the extreme position; the targets are the 30 steps after it).
    tg = crankrocker_targets()
    model = os.path.join(HERE, "crankrocker30.published.kin")
    out = subprocess.run([kinema, "run", model, "--t-end", repr(tg[-1][0]), "--steps",
                          str(len(tg)), "--positions-only", "--columns", "psi", "--out", "-"],
                         capture_output=True, text=True, check=True)
    rows = [line.split(",") for line in out.stdout.strip().splitlines()]
    col = rows[0].index("psi")
    total = sum((float(r[col]) - psi) ** 2 for r, (_t, psi) in zip(rows[2:], tg))
    ref = crankrocker_reference()[2]
    print(f"  crankrocker30 the book's optimum (recomputed)      kinema {total:.10g}  book's formula "
          f"{ref:.10g}  (relative difference {abs(total - ref) / ref:.1e})")
    print("Every published design, through kinema (error, warnings) and problems.py (defects):")
    for name in PROBLEMS:
        print(f"  {name}")
        for label, _via, x in PUBLISHED[name]:
            t, phase, sense = timing_of(name, x)
            params = design_params(name, x, sense)
            params["phase"] = phase
            model = os.path.join(tmp, f"{name}.check.kin")
            write_model(model, name, params, f"A published design: {label}.")
            total, warns = error_through_kinema(kinema, model, name, t)
            found, _, _ = defects(name, x)
            print(f"    {label:38s} kinema {total:.6g} (formula {error_literature(name, x):.6g})")
            for w in sorted(warns):
                print(f"        kinema: {w}")
            for d in found:
                print(f"        defect: {d}")


if __name__ == "__main__":
    main()
