"""The peer side of the synthesis benchmark: pylinkage (pinned in
requirements.txt) solving the published four-bar problems of problems.py
with its own optimizers, on this machine, one run each.

    .venv/bin/python pylinkage_bench.py [--method pso|de|both] [--problems a,b]
                                        [--json results/pylinkage.json]

The linkage is pylinkage's own (Ground O and D, a Crank, an RRRDyad for B,
a FixedDyad for the coupler point), simulated by pylinkage; the fitness
function is the literature's: the sum of squared distances from the
coupler point to the targets at the crank angles of the design (prescribed,
or design variables as in the literature when the timing is free). The
crank is stepped from target to target in steps of at most 0.05 rad, so
pylinkage's dyads stay on the branch they started on (it picks the
intersection nearest the previous position) and a design that locks between
two targets is rejected (UnbuildableError); one whose free crank angles are
out of order (the literature's order constraint) or, in FULL_TURN problems,
whose crank cannot turn fully (Grashof, crank or ground shortest) pays a
penalty, as in the literature.

Optimizers: pylinkage.optimization.particle_swarm_optimization (its own
local-best PSO, defaults: 100 particles x 200 iterations) and
differential_evolution_optimization (scipy's DE, popsize 15, maxiter 1000,
with scipy's final polish). The DE wrapper sizes the problem from the
linkage's constraints, so it is handed a stand-in linkage with as many
constraints as design variables; the fitness builds the real one.

Printed per problem: best error reached (the literature's measure), wall
time, fitness evaluations, and the time and evaluations at which the best
error first fell to the target (the best published defect-free error).
"""

import argparse
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from problems import (  # noqa: E402
    CRANKROCKER,
    FUNCTION,
    PI,
    PROBLEMS,
    PUBLISHED,
    defects,
    error_literature,
    freudenstein_reference,
    function_error,
    function_targets,
    crankrocker_defects,
    crankrocker_error,
    crankrocker_gammas,
    crankrocker_reference,
    crankrocker_start_angles,
    crankrocker_targets,
    grashof,
    out_of_bounds,
)

import pylinkage  # noqa: E402
from pylinkage.actuators import Crank  # noqa: E402
from pylinkage.components import Ground  # noqa: E402
from pylinkage.dyads import FixedDyad, RRRDyad  # noqa: E402
from pylinkage.exceptions import UnbuildableError  # noqa: E402
from pylinkage.optimization import (  # noqa: E402
    differential_evolution_optimization,
    particle_swarm_optimization,
)
from pylinkage.simulation import Linkage  # noqa: E402

MAX_STEP = 0.05  # rad between two crank positions
# Problems whose crank must turn fully (a Grashof crank: the literature's
# constraint for these, and run.sh's --full-turn crank), a penalty as there.
FULL_TURN = {"straight6", "closed18", "semicircle6", "ellipse10"}
UNBUILDABLE = 1e6
ORDER_PENALTY = 1e4


def variables(name):
    """Names and (lo, hi) bounds of the problem's design variables."""
    p = PROBLEMS[name]
    b = p["bounds"]
    names, lo, hi = ["r1", "r2", "r3", "r4"], [max(b["r"][0], 1e-3)] * 4, [b["r"][1]] * 4
    names += ["rcx", "rcy"]
    lo += [b["rc"][0]] * 2
    hi += [b["rc"][1]] * 2
    for v in ("x0", "y0"):
        if v not in p["fixed"]:
            names.append(v)
            lo.append(b["xy0"][0])
            hi.append(b["xy0"][1])
    if "theta0" not in p["fixed"]:
        names.append("theta0")
        lo.append(b["ang"][0])
        hi.append(b["ang"][1])
    n = len(p["targets"])
    k = n if p["timing"] is None else (1 if p["timing"] == "uniform20" else 0)
    for i in range(k):
        names.append(f"th2_{i + 1}")
        lo.append(b["ang"][0])
        hi.append(b["ang"][1])
    return names, lo, hi


def literature_vector(name, dims):
    """The literature's x = [r1..rcy, x0, y0, theta0, th2...] from the design variables."""
    p = PROBLEMS[name]
    names, _, _ = variables(name)
    v = dict(zip(names, dims))
    v.update(p["fixed"])
    x = [v[k] for k in ("r1", "r2", "r3", "r4", "rcx", "rcy", "x0", "y0", "theta0")]
    x += [v[k] for k in names if k.startswith("th2_")]
    return x


def angles(name, x):
    p = PROBLEMS[name]
    n = len(p["targets"])
    if p["timing"] is None:
        return list(x[9:9 + n])
    if p["timing"] == "uniform20":
        return [x[9] + i * PI / 9 for i in range(n)]
    return list(p["timing"])


def ordered(ths):
    """The literature's order condition: monotone in one sense within one turn."""
    d = np.diff(ths)
    return sum(v % (2 * PI) for v in d) < 2 * PI + 1e-9 or sum((-v) % (2 * PI) for v in d) < 2 * PI + 1e-9


def rocker_angles(x, ths, sigma):
    """pylinkage's rocker angle (D->B from the ground link) at each crank angle."""
    pts = coupler_points(x, ths, sigma, joint="B")
    if pts is None:
        return None
    r1, t0, x0, y0 = x[0], x[8], x[6], x[7]
    dx, dy = x0 + r1 * math.cos(t0), y0 + r1 * math.sin(t0)
    return [math.atan2(by - dy, bx - dx) - t0 for bx, by in pts]


def coupler_points(x, ths, sigma=1, joint="C"):
    """pylinkage's coupler point at each crank angle (th2 from the ground link)."""
    r1, r2, r3, r4, rcx, rcy, x0, y0, t0 = x[:9]
    o = Ground(x0, y0, name="O")
    d = Ground(x0 + r1 * math.cos(t0), y0 + r1 * math.sin(t0), name="D")
    crank = Crank(anchor=o, radius=r2, angular_velocity=1.0, initial_angle=t0 + ths[0], name="A")
    # B on the literature's branch at the first target (left of A->D).
    ax, ay = crank.x, crank.y
    ux, uy = d.x - ax, d.y - ay
    dist = math.hypot(ux, uy)
    if dist == 0:
        return None
    a = (r3 * r3 - r4 * r4 + dist * dist) / (2 * dist)
    h2 = r3 * r3 - a * a
    if h2 < 0:
        return None
    h = math.sqrt(h2)
    b = RRRDyad(anchor1=crank.output, anchor2=d, distance1=r3, distance2=r4, name="B")
    b.x, b.y = ax + (a * ux - sigma * h * uy) / dist, ay + (a * uy + sigma * h * ux) / dist
    c = FixedDyad(anchor1=crank.output, anchor2=b, distance=math.hypot(rcx, rcy),
                  angle=math.atan2(rcy, rcx), name="C")
    linkage = Linkage([o, d, crank, b, c], name="fourbar")
    tip = c if joint == "C" else b
    out = []
    try:
        for _ in linkage.step(iterations=1, dt=0.0):
            pass
        out.append((tip.x, tip.y))
        for prev, nxt in zip(ths, ths[1:]):
            delta = nxt - prev
            k = max(1, math.ceil(abs(delta) / MAX_STEP))
            for _ in linkage.step(iterations=k, dt=delta / k):
                pass
            out.append((tip.x, tip.y))
    except UnbuildableError:
        return None
    return out


LEVELS = (1.0, 1e-1, 1e-2, 1e-3, 1e-4, 1e-6, 1e-8)


class Tracker:
    """Counts fitness evaluations and when the best error reached the target
    and each of LEVELS (seconds, evaluations)."""

    def __init__(self, name, target):
        self.name, self.target = name, target
        self.evals, self.best, self.best_x = 0, math.inf, None
        self.t_reach = self.e_reach = None
        # When the best error last improved: the time to the final best.
        self.t_best = self.e_best = None
        self.levels = {}
        self.t0 = time.perf_counter()

    def record(self, f, x):
        if f < self.best:
            self.best, self.best_x = f, list(x)
            now = time.perf_counter() - self.t0
            self.t_best, self.e_best = now, self.evals
            if self.t_reach is None and f <= self.target:
                self.t_reach, self.e_reach = now, self.evals
            for level in LEVELS:
                if f <= level and level not in self.levels:
                    self.levels[level] = (now, self.evals)

    def fitness(self, dims):
        self.evals += 1
        x = literature_vector(self.name, dims)
        ths = angles(self.name, x)
        # Unwrap free crank angles in the sense they advance, so the crank
        # turns from one target to the next the short way round the order.
        p = PROBLEMS[self.name]
        penalty = 0.0
        if p["timing"] is None:
            if not ordered(ths):
                penalty = ORDER_PENALTY
            else:
                fwd = sum(v % (2 * PI) for v in np.diff(ths)) < 2 * PI + 1e-9
                un = [ths[0]]
                for v in np.diff(ths):
                    un.append(un[-1] + (v % (2 * PI) if fwd else -((-v) % (2 * PI))))
                ths = un
        if self.name in FULL_TURN and grashof(*x[:4]) != "crank":
            penalty += ORDER_PENALTY
        pts = coupler_points(x, ths)
        if pts is None:
            return UNBUILDABLE + penalty
        f = sum((cx - tx) ** 2 + (cy - ty) ** 2 for (cx, cy), (tx, ty) in zip(pts, p["targets"]))
        f += penalty
        self.record(f, x)
        return f


class FunctionTracker(Tracker):
    """The function-generation problem (log10): design (r2, r3, r4, th2s, psis),
    pylinkage's linkage stepped through the targets' crank angles; the error
    is the sum of squared rocker-angle errors [rad^2]."""

    def fitness(self, dims):
        self.evals += 1
        r2, r3, r4, th2s, psis = dims
        tg = function_targets()
        x = [1.0, r2, r3, r4, 0.0, 0.0, 0.0, 0.0, 0.0]
        ths = [th2s + t for t, _ in tg]
        best = None
        # Both assembly branches are designs; a user would try both.
        for sigma in (1, -1):
            psi = rocker_angles(x, ths, sigma)
            if psi is None:
                continue
            f = sum(((p - psis - d + PI) % (2 * PI) - PI) ** 2 for p, (_t, d) in zip(psi, tg))
            if best is None or f < best:
                best = f
        f = UNBUILDABLE if best is None else best
        self.record(f, list(dims))
        return f


class CrankRockerTracker(Tracker):
    """The published function-generation problem (crankrocker30): design
    (l2, l3) in [1, 10] as in the book; pylinkage's linkage (crank 1, frame
    5) stepped from the extreme position phi0 through the 30 targets on the
    book's branch (sigma = +1); the error is the book's, the sum of squared
    rocker-angle errors [rad^2]; the book's transmission-angle constraints
    (45 to 135 deg) are a penalty, as a pylinkage user would write them."""

    def fitness(self, dims):
        self.evals += 1
        l2, l3 = dims
        a, d = CRANKROCKER["crank"], CRANKROCKER["frame"]
        try:
            phi0, psi0 = crankrocker_start_angles(l2, l3)
            gmin, gmax = crankrocker_gammas(l2, l3)
        except ValueError:  # not a crank-rocker: no extreme position
            self.record(UNBUILDABLE, list(dims))
            return UNBUILDABLE
        lo, hi = CRANKROCKER["gamma"]
        violation = max(0.0, lo - gmin) + max(0.0, gmax - hi)
        tg = crankrocker_targets()
        x = [d, a, l2, l3, 0.0, 0.0, 0.0, 0.0, 0.0]
        psi = rocker_angles(x, [phi0] + [phi0 + t for t, _ in tg], 1)
        if psi is None:
            f = UNBUILDABLE
        else:
            f = sum((p - psi0 - dp) ** 2 for p, (_t, dp) in zip(psi[1:], tg))
            f += ORDER_PENALTY * violation
        self.record(f, list(dims))
        return f


class StandIn:
    """What pylinkage's DE wrapper reads from a linkage: the number of constraints."""

    def __init__(self, n):
        self.n = n

    def get_constraints(self):
        return [1.0] * self.n

    def get_coords(self):
        return []


def best_published_defect_free(name):
    """The best published error among designs without defects, within the bounds."""
    best = math.inf
    for _label, _via, x in PUBLISHED[name]:
        found, _, _ = defects(name, x)
        if not found and not out_of_bounds(name, x):
            best = min(best, error_literature(name, x))
    return best


def run(name, method, seed):
    if name == "crankrocker30":
        names = ["l2", "l3"]
        lo, hi = [CRANKROCKER["bounds"]["l"][0]] * 2, [CRANKROCKER["bounds"]["l"][1]] * 2
        target = crankrocker_reference()[2]
        tr = CrankRockerTracker(name, target)
    elif name == "log10":
        b = FUNCTION["bounds"]
        names = ["r2", "r3", "r4", "th2s", "psis"]
        lo, hi = [b["r"][0]] * 3 + [b["ang"][0]] * 2, [b["r"][1]] * 3 + [b["ang"][1]] * 2
        target = function_error(*freudenstein_reference(PI / 6, 5 * PI / 12), sigma=-1)
        tr = FunctionTracker(name, target)
    else:
        names, lo, hi = variables(name)
        target = best_published_defect_free(name)
        tr = Tracker(name, target)

    def eval_func(_linkage, dims, _pos):
        return tr.fitness(dims)

    np.random.seed(seed)
    t0 = time.perf_counter()
    if method == "pso":
        particle_swarm_optimization(eval_func, StandIn(len(names)), dimensions=len(names),
                                    bounds=(lo, hi), order_relation=min, verbose=False)
    else:
        differential_evolution_optimization(eval_func, StandIn(len(names)), bounds=(lo, hi),
                                            order_relation=min, seed=seed, verbose=False)
    wall = time.perf_counter() - t0
    if name == "crankrocker30":
        found = crankrocker_defects(*tr.best_x) if tr.best < UNBUILDABLE else ["unbuildable"]
        formula = crankrocker_error(*tr.best_x) if tr.best < UNBUILDABLE else None
    elif name == "log10":
        found = [] if tr.best < UNBUILDABLE else ["unbuildable"]
        formula = None
    else:
        found, _, _ = defects(name, tr.best_x) if tr.best_x else (["none"], 0, 0)
        formula = error_literature(name, tr.best_x) if tr.best_x else None
    return dict(problem=name, method=method, variables=len(names), best_error=tr.best,
                literature_formula_error=formula, defects=found, wall_s=wall,
                evaluations=tr.evals, target_error=target, time_to_target_s=tr.t_reach,
                time_to_best_s=tr.t_best, evals_to_best=tr.e_best,
                evals_to_target=tr.e_reach, design=tr.best_x,
                levels={f"{k:g}": v for k, v in sorted(tr.levels.items(), reverse=True)})


def check(name):
    """pylinkage reproduces the literature's error of every published design (a model check)."""
    worst = 0.0
    for _label, _via, x in PUBLISHED[name]:
        found, fb, _ = defects(name, x)
        if found:
            continue
        tr = Tracker(name, 0.0)
        names, _, _ = variables(name)
        # Map the literature vector back to the design variables.
        full = dict(zip(["r1", "r2", "r3", "r4", "rcx", "rcy", "x0", "y0", "theta0"], x[:9]))
        extra = x[9:]
        dims = [full[k] for k in names if not k.startswith("th2_")] + list(extra)
        f = tr.fitness(dims)
        worst = max(worst, abs(f - fb) / max(fb, 1e-12))
    return worst


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--method", default="both", choices=["pso", "de", "both"])
    ap.add_argument("--problems",
                    default=",".join(list(PROBLEMS) + ["log10", "crankrocker30"]))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    print(f"pylinkage {pylinkage.__version__}, numpy {np.__version__}")
    results = []
    for name in args.problems.split(","):
        if name == "crankrocker30":
            l2, l3, want = crankrocker_reference()
            got = CrankRockerTracker(name, 0.0).fitness([l2, l3])
            print(f"{name}: pylinkage reproduces the book's optimum's error to "
                  f"{abs(got - want) / want:.1e} (relative)")
        elif name == "log10":
            ref = freudenstein_reference(PI / 6, 5 * PI / 12)
            tr = FunctionTracker(name, 0.0)
            got = tr.fitness(list(ref))
            want = function_error(*ref, sigma=-1)
            print(f"{name}: pylinkage reproduces the textbook design's error to "
                  f"{abs(got - want) / want:.1e} (relative)")
        else:
            print(f"{name}: pylinkage reproduces the published defect-free designs' error "
                  f"to {check(name):.1e} (relative)")
        for method in (["pso", "de"] if args.method == "both" else [args.method]):
            r = run(name, method, args.seed)
            results.append(r)
            reach = (f"reached the target {r['target_error']:.4g} after {r['time_to_target_s']:.2f} s"
                     f" ({r['evals_to_target']} evaluations)" if r["time_to_target_s"] is not None
                     else f"did not reach the target {r['target_error']:.4g}")
            print(f"  {method.upper():3s} best error {r['best_error']:.6g} in {r['wall_s']:.1f} s, "
                  f"{r['evaluations']} evaluations; {reach}; defects: "
                  f"{'; '.join(r['defects']) or 'none'}", flush=True)
            print("      first at or below: " + ", ".join(
                f"{k}: {t:.2f} s/{e} ev" for k, (t, e) in r["levels"].items()), flush=True)
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as f:
            json.dump(dict(pylinkage=pylinkage.__version__, results=results), f, indent=1)


if __name__ == "__main__":
    main()
