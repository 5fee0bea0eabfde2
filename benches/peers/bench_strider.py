"""The Strider walking linkage of pylinkage's docs/examples/strider.py, with
its published dimensions, solved by pylinkage (pure Python and numba):
positions over one crank turn in 360 steps, timed, and written as CSV for
comparison with kinema's crates/kinema-bench/models/strider.kin.

Usage: bench_strider.py [--reps R] [--csv OUT.csv] [--json OUT.json]
                        [--kinema KINEMA.csv]

With --kinema, the CSV of `kinema run strider.kin --steps 360
--positions-only` is read and the largest difference of the points C...I
over the turn (kinema's row k is pylinkage's step k) is reported.

The linkage (this script's own construction, from the example's numbers):
frame points A = (0, 0), Y = (0, 1); B, B' at distance 2 from A at -pi/4 and
+pi/4 from A->Y; crank C of radius 1 about A, starting at (0, -1) and turning
clockwise; knees D = RRR(B', C; 1.8, 2.6), E = RRR(B, C; 1.8, 2.6); ankles
F = Fixed(C, E; 1.4, -(pi + 0.2)), G = Fixed(C, D; 1.4, pi + 0.2); feet
H = RRR(D, F; 2.5, 1.8), I = RRR(E, G; 2.5, 1.8).
"""

import argparse
import json
import math
import statistics
import time

import numpy as np

import pylinkage
from pylinkage.actuators import Crank
from pylinkage.components import Ground
from pylinkage.dyads import FixedDyad, RRRDyad
from pylinkage.simulation import Linkage

STEPS = 360
TRIANGLE, APERTURE, FEMUR, ROCKER_L, ROCKER_S, PHI, TIBIA, F = (
    2.0, math.pi / 4, 1.8, 2.6, 1.4, math.pi + 0.2, 2.5, 1.8)
# The example's initial coordinates of A, Y, B, B', C, D, E, F, G, H, I.
INIT = ((0, 0), (0, 1), (1.41, 1.41), (-1.41, 1.41), (0, -1), (-2.25, 0),
        (2.25, 0), (-1.4, -1.2), (1.4, -1.2), (-2.7, -2.7), (2.7, -2.7))
NAMES = ("A", "Y", "B", "Bp", "C", "D", "E", "F", "G", "H", "I")


def strider():
    a = Ground(*INIT[0], name="A")
    y = Ground(*INIT[1], name="Y")
    b = FixedDyad(anchor1=a, anchor2=y, distance=TRIANGLE, angle=-APERTURE, name="B")
    bp = FixedDyad(anchor1=a, anchor2=y, distance=TRIANGLE, angle=APERTURE, name="Bp")
    # One turn per STEPS steps of dt = 1, clockwise as in the example.
    c = Crank(anchor=a, radius=1, angular_velocity=-2 * math.pi / STEPS, name="C")
    d = RRRDyad(anchor1=bp, anchor2=c.output, distance1=FEMUR, distance2=ROCKER_L, name="D")
    e = RRRDyad(anchor1=b, anchor2=c.output, distance1=FEMUR, distance2=ROCKER_L, name="E")
    f = FixedDyad(anchor1=c.output, anchor2=e, distance=ROCKER_S, angle=-PHI, name="F")
    g = FixedDyad(anchor1=c.output, anchor2=d, distance=ROCKER_S, angle=PHI, name="G")
    h = RRRDyad(anchor1=d, anchor2=f, distance1=TIBIA, distance2=F, name="H")
    i = RRRDyad(anchor1=e, anchor2=g, distance1=TIBIA, distance2=F, name="I")
    linkage = Linkage([a, y, b, bp, c, d, e, f, g, h, i], name="Strider")
    linkage.set_coords(list(INIT))
    return linkage


# kinema's named points for pylinkage's C...I.
KINEMA_POINTS = ("crank.c", "rocker_l.d", "rocker_r.e", "tri_e.f", "tri_d.g", "leg_dh.h",
                 "leg_ei.i")


def compare(traj, path):
    """Largest |kinema - pylinkage| over the points C...I and the turn."""
    with open(path) as f:
        header = f.readline().strip().split(",")
        rows = [[float(v) for v in line.split(",")] for line in f if line.strip()]
    if len(rows) != STEPS + 1:
        raise SystemExit(f"{path}: {len(rows)} rows, expected {STEPS + 1}")
    worst = 0.0
    for k, row in enumerate(traj):
        kin = rows[k + 1]
        for j, name in enumerate(KINEMA_POINTS):
            for c, axis in enumerate("xy"):
                value = kin[header.index(f"{name}.{axis}")]
                worst = max(worst, abs(value - row[4 + j][c]))
    return worst


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--reps", type=int, default=20)
    ap.add_argument("--csv", default=None)
    ap.add_argument("--json", default=None)
    ap.add_argument("--kinema", default=None)
    args = ap.parse_args()

    # Pure Python: the generator over components.
    linkage = strider()
    t0 = time.perf_counter()
    python_traj = np.array([[p for p in step] for step in linkage.step(iterations=STEPS)])
    python_first = time.perf_counter() - t0
    python_times = []
    for _ in range(max(3, args.reps // 4)):
        linkage = strider()
        t0 = time.perf_counter()
        for _step in linkage.step(iterations=STEPS):
            pass
        python_times.append(time.perf_counter() - t0)

    # numba: step_fast (the first call compiles).
    linkage = strider()
    t0 = time.perf_counter()
    traj = linkage.step_fast(iterations=STEPS)
    numba_first = time.perf_counter() - t0
    numba_times = []
    for _ in range(args.reps):
        linkage = strider()
        t0 = time.perf_counter()
        linkage.step_fast(iterations=STEPS)
        numba_times.append(time.perf_counter() - t0)
    # Build + one turn, as a design loop pays it per variant.
    build_times = []
    for _ in range(args.reps):
        t0 = time.perf_counter()
        strider().step_fast(iterations=STEPS)
        build_times.append(time.perf_counter() - t0)

    gap = float(np.nanmax(np.abs(traj - python_traj)))
    if not np.isfinite(traj).all():
        raise SystemExit("pylinkage: the Strider did not build over the turn (NaN)")
    if args.csv:
        with open(args.csv, "w") as out:
            out.write("step,crank_angle," + ",".join(
                f"{n}.{c}" for n in NAMES[4:] for c in "xy") + "\n")
            for k, row in enumerate(traj):
                angle = -math.pi / 2 - 2 * math.pi * (k + 1) / STEPS
                values = [row[j][c] for j in range(4, len(NAMES)) for c in (0, 1)]
                out.write(f"{k + 1},{angle!r}," + ",".join(repr(float(v)) for v in values) + "\n")
    result = {
        "pylinkage": pylinkage.__version__,
        "steps": STEPS,
        "python_turn_s": statistics.median(python_times),
        "python_first_s": python_first,
        "numba_turn_s": statistics.median(numba_times),
        "numba_first_s": numba_first,
        "numba_build_and_turn_s": statistics.median(build_times),
        "python_vs_numba_max_gap": gap,
    }
    if args.kinema:
        result["kinema_vs_pylinkage_max_gap"] = compare(traj, args.kinema)
    print(json.dumps(result, indent=1))
    if args.json:
        with open(args.json, "w") as out:
            json.dump(result, out, indent=1)


if __name__ == "__main__":
    main()
