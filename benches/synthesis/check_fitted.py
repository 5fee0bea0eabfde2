"""kinema fit's best designs checked by the literature's own closed form
(problems.py): for each problem, the best variant's design (results/
<tag>.summary.csv: params, and the target times t1…tn) is turned into the
literature's design vector [r1, r2, r3, r4, rcx, rcy, x0, y0, θ0, θ2ⁱ…]
(θ2 = phase + sense·t, from the ground link), its error recomputed with
Freudenstein's formula on one branch, and its defects looked for (Grashof,
change point, branch, order, locking between targets) — independently of
kinema's own checks. Run by run.sh after the fits.
"""
import csv
import glob
import math
import os
import re

from problems import (PROBLEMS, coupler_point, crank_angles, crankrocker_defects,
                      crankrocker_error, crankrocker_gammas, crankrocker_l3, crankrocker_reference,
                      defects, function_error, out_of_bounds, th3_branch)

HERE = os.path.dirname(os.path.abspath(__file__))
RES = os.path.join(HERE, "results")
VALUES = {"straight6": 12, "arc5": 10, "closed18": 36, "semicircle6": 12, "ellipse10": 20}


def params_of(kin):
    """`param NAME = VALUE;` of a model file."""
    text = open(kin).read()
    return {m.group(1): float(m.group(2))
            for m in re.finditer(r"param (\w+) = ([-+0-9.eE]+);", text)}


def main():
    for name in VALUES:
        best = None
        for path in glob.glob(os.path.join(RES, f"{name}.*.summary.csv")):
            rows = list(csv.DictReader(open(path)))
            if rows and (best is None or float(rows[0]["rms"]) < best[0]):
                best = (float(rows[0]["rms"]), path, rows[0])
        if best is None:
            print(f"{name}: no fitted design")
            continue
        rms, path, row = best
        tag = os.path.basename(path)[:-len(".summary.csv")]
        p = params_of(os.path.join(RES, f"{tag}.fitted.kin"))
        t = [float(row[k]) for k in row if re.fullmatch(r"t\d+", k)]
        th2 = [p["phase"] + p["sense"] * ti for ti in t]
        x = [p[k] for k in ("r1", "r2", "r3", "r4", "rcx", "rcy", "x0", "y0", "theta0")]
        timing = PROBLEMS[name]["timing"]
        if timing is None:
            x += th2
        elif timing == "uniform20":
            x += [th2[0]]
        found, _, _ = defects(name, x)
        # The error by the closed form on the model's branch (σ = +1: B left
        # of A→D, as the model's `branch`).
        f = 0.0
        for (tx, ty), a in zip(PROBLEMS[name]["targets"], crank_angles(name, x)):
            th3 = th3_branch(*x[:4], a, p["branch"])
            if th3 is None:
                f = float("nan")
                break
            cx, cy = coupler_point(x, a, th3)
            f += (cx - tx) ** 2 + (cy - ty) ** 2
        kinema_f = rms ** 2 * VALUES[name]
        print(f"{name} ({tag}): kinema {kinema_f:.6g}, the literature's closed form on its "
              f"branch {f:.6g}; defects: {', '.join(found) if found else 'none'}"
              f"{'; out of bounds: ' + ', '.join(out_of_bounds(name, x)) if out_of_bounds(name, x) else ''}")
    # The function generator: Σ(ψ − ψd)² by the closed form.
    for path in sorted(glob.glob(os.path.join(RES, "log10.*.fitted.kin"))):
        p = params_of(path)
        f = function_error(p["r2"], p["r3"], p["r4"], p["phase"], p["psi0"], sigma=p["branch"])
        print(f"log10 ({os.path.basename(path)}): literature's formula {f:.6g}")
    # The published function-generation problem: the book's objective and
    # constraints (problems.crankrocker_*), against its optimum.
    for path in sorted(glob.glob(os.path.join(RES, "crankrocker30.*.fitted.kin"))):
        p = params_of(path)
        l3 = crankrocker_l3(p["l2"], p["gmax"])
        f = crankrocker_error(p["l2"], l3)
        gmin, gmax = (math.degrees(g) for g in crankrocker_gammas(p["l2"], l3))
        found = crankrocker_defects(p["l2"], l3)
        print(f"crankrocker30 ({os.path.basename(path)}): l2 = {p['l2']:.9g}, l3 = {l3:.9g}; the "
              f"book's formula {f:.10g} (its optimum {crankrocker_reference()[2]:.10g}); "
              f"transmission angle {gmin:.4f} to {gmax:.4f} deg; "
              f"defects: {', '.join(found) if found else 'none'}")


if __name__ == "__main__":
    main()
