"""A reference for what `kinema fit` should reach: multi-start bounded least
squares (scipy's trust-region reflective, finite-difference Jacobian) on the
same problems and variables as pylinkage_bench.py, with the closed-form
four-bar on one assembly branch (problems.th3_branch), keeping only
defect-free designs (problems.defects; a Grashof crank where FULL_TURN).
Not kinema and not a peer: a check that the published best errors are
reachable by least squares, and how fast a plain Python one gets there.

    .venv/bin/python lsq_reference.py [--starts 64] [--problems a,b]
"""

import argparse
import math
import os
import sys
import time

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import qmc

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from problems import (  # noqa: E402
    PROBLEMS,
    coupler_point,
    defects,
    grashof,
    th3_branch,
)
from pylinkage_bench import (  # noqa: E402
    FULL_TURN,
    angles,
    best_published_defect_free,
    literature_vector,
    ordered,
    variables,
)


def residuals(name, dims, sigma):
    x = literature_vector(name, dims)
    r = []
    for (tx, ty), th2 in zip(PROBLEMS[name]["targets"], angles(name, x)):
        th3 = th3_branch(*x[:4], th2, sigma)
        if th3 is None:
            r += [1e3, 1e3]
            continue
        cx, cy = coupler_point(x, th2, th3)
        r += [cx - tx, cy - ty]
    return np.array(r)


def acceptable(name, x):
    found, _, _ = defects(name, x)
    if found:
        return False
    if PROBLEMS[name]["timing"] is None and not ordered(angles(name, x)):
        return False
    return not (name in FULL_TURN and grashof(*x[:4]) != "crank")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--starts", type=int, default=64)
    ap.add_argument("--problems", default=",".join(PROBLEMS))
    args = ap.parse_args()
    for name in args.problems.split(","):
        names, lo, hi = variables(name)
        lo, hi = np.array(lo), np.array(hi)
        target = best_published_defect_free(name)
        starts = qmc.scale(qmc.LatinHypercube(d=len(names), seed=1).random(args.starts), lo, hi)
        t0 = time.perf_counter()
        best, best_x, nfev, t_reach, rejected = math.inf, None, 0, None, 0
        for s in starts:
            for sigma in (1, -1):
                res = least_squares(lambda v: residuals(name, v, sigma), s, bounds=(lo, hi),
                                    xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000)
                nfev += res.nfev
                x = literature_vector(name, res.x)
                f = float(res.fun @ res.fun)
                if not acceptable(name, x):
                    rejected += 1
                    continue
                if f < best:
                    best, best_x = f, x
                    if t_reach is None and f <= target * (1 + 1e-9):
                        t_reach = time.perf_counter() - t0
        wall = time.perf_counter() - t0
        reach = f"reached {target:.4g} after {t_reach:.2f} s" if t_reach is not None else \
            f"did not reach {target:.4g}"
        print(f"{name:12s} best defect-free {best:.6g} in {wall:.1f} s ({args.starts} starts x 2 "
              f"branches, {nfev} residual evaluations, {rejected} rejected); {reach}", flush=True)
        if best_x is not None:
            print("    design " + " ".join(f"{v:.9g}" for v in best_x))


if __name__ == "__main__":
    main()
