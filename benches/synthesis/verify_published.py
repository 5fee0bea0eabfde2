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
from problems import PROBLEMS, PUBLISHED, defects, error_literature  # noqa: E402

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


def main():
    kinema = sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "../../target/debug/kinema")
    for name, p in PROBLEMS.items():
        model = os.path.join(HERE, f"{name}.published.kin")
        with open(os.path.join(HERE, f"{name}.published.times")) as f:
            times = [float(v) for v in f if not v.startswith("#")]
        label, _via, x = min(PUBLISHED[name], key=lambda d: error_literature(name, d[2]))
        total, warns = 0.0, set()
        for (tx, ty), t in zip(p["targets"], times):
            pt, warn = point_at(kinema, model, t)
            if pt is None:
                print(f"{name}: kinema failed at t = {t}: {warn}")
                total = float("nan")
                break
            if warn:
                warns.add(warn)
            total += (pt[0] - tx) ** 2 + (pt[1] - ty) ** 2
        lit = error_literature(name, x)
        found, _, _ = defects(name, x)
        rel = abs(total - lit) / max(lit, 1e-300)
        print(f"{name:12s} {label:36s} kinema {total:.10g}  literature formula {lit:.10g}"
              f"  (relative difference {rel:.1e})")
        for w in sorted(warns):
            print(f"    kinema: {w}")
        for d in found:
            print(f"    defect (problems.py): {d}")


if __name__ == "__main__":
    main()
