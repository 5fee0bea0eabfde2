#!/usr/bin/env python3
"""Exudyn (PyPI) on the forward-dynamics benchmarks of fd_models.py (README.md section 6).

Same model: absolute coordinates, NodeRigidBody2D + ObjectRigidBody2D per body, RevoluteJoint2D
for every pin (MarkerBodyPosition on both sides; ObjectGround for the ground pins), the
slider's y and phi held by CoordinateConstraint to a ground node, gravity by
LoadMassProportional. Same integrator family: Exudyn's generalized-alpha (index 3) at the
spectral radius of HHT alpha = -0.1 (rho_inf = 0.8182), fixed step 1e-3, 1000 steps. Fastest
sensible settings: no solution file, no sensors, no renderer, one thread, the constant mass
matrix reused; every linear solver (EigenSparse, EigenDense, EXUdense) with modified Newton,
and the sparse and EXUdense ones with full Newton (--solvers).

Timed: solver.SolveSteps (the 1000 steps) after InitializeSolver (assembly, initial
accelerations), per step = time / 1000; median [min, max] over --reps runs, each on a freshly
built model. Writes results/fd_exudyn_MECH.json with q at t = 1 (absolute coordinates, kinema's
order) and Newton statistics.
"""
import argparse
import json
import os
import statistics
import time

import exudyn as exu
from exudyn.itemInterface import (
    CoordinateConstraint,
    LoadMassProportional,
    MarkerBodyMass,
    MarkerBodyPosition,
    MarkerNodeCoordinate,
    NodePointGround,
    NodeRigidBody2D,
    ObjectGround,
    ObjectRigidBody2D,
    RevoluteJoint2D,
)

import fd_models

HERE = os.path.dirname(os.path.abspath(__file__))


def build(mech):
    """(SystemContainer, MainSystem, node numbers, reference q) of `mech`."""
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddObject(ObjectGround(referencePosition=[0, 0, 0]))
    ground_node = mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0]))
    ground_coord = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground_node, coordinate=0))
    nodes, objects, q_ref = [], [], []
    for m, j, q0 in mech["bodies"]:
        node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(q0),
                                           initialCoordinates=[0, 0, 0],
                                           initialVelocities=[0, 0, 0]))
        body = mbs.AddObject(ObjectRigidBody2D(mass=m, inertia=j, nodeNumber=node))
        mass = mbs.AddMarker(MarkerBodyMass(bodyNumber=body))
        mbs.AddLoad(LoadMassProportional(markerNumber=mass,
                                         loadVector=[fd_models.G[0], fd_models.G[1], 0]))
        nodes.append(node)
        objects.append(body)
        q_ref.extend(q0)
    for i, si, j, sj in mech["pins"]:
        if i == 0:
            mi = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=[si[0], si[1], 0]))
        else:
            mi = mbs.AddMarker(MarkerBodyPosition(bodyNumber=objects[i - 1],
                                                  localPosition=[si[0], si[1], 0]))
        mj = mbs.AddMarker(MarkerBodyPosition(bodyNumber=objects[j - 1],
                                              localPosition=[sj[0], sj[1], 0]))
        mbs.AddObject(RevoluteJoint2D(markerNumbers=[mi, mj]))
    for i, which in mech["locks"]:
        # The node's displacement coordinate (1: y, 2: phi) equals the ground's (zero): the
        # coordinate stays at its reference value, 0 for the slider.
        c = {"y": 1, "phi": 2}[which]
        mc = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[i - 1], coordinate=c))
        mbs.AddObject(CoordinateConstraint(markerNumbers=[ground_coord, mc]))
    mbs.Assemble()
    return sc, mbs, nodes, q_ref


def settings(solver, modified):
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.numberOfSteps = fd_models.STEPS
    ti.endTime = fd_models.STEPS * fd_models.H
    ti.verboseMode = 0
    ti.generalizedAlpha.useNewmark = False
    ti.generalizedAlpha.useIndex2Constraints = False
    ti.generalizedAlpha.spectralRadius = fd_models.RHO_INF
    ti.generalizedAlpha.computeInitialAccelerations = True
    ti.newton.useModifiedNewton = modified
    ti.reuseConstantMassMatrix = True
    s.solution.file.write = False
    s.solution.file.writeInitialValues = False
    s.solution.sensors.writePeriod = 1e9
    s.show.computationTime = False
    s.show.statistics = False
    s.parallel.numberOfThreads = 1
    s.linearSolver.solverType = getattr(exu.LinearSolverType, solver)
    return s


def run_once(mech, solver, modified):
    """(seconds of the 1000 steps, q at t = 1, Newton iterations, Jacobians)."""
    sc, mbs, nodes, q_ref = build(mech)
    s = settings(solver, modified)
    sol = exu.MainSolverImplicitSecondOrder()
    sol.InitializeSolver(mbs, s)
    t0 = time.perf_counter()
    ok = sol.SolveSteps(mbs, s)
    elapsed = time.perf_counter() - t0
    it = sol.it
    newton = getattr(it, "newtonStepsCount", None)
    jacobians = getattr(it, "newtonJacobiCount", None)
    sol.FinalizeSolver(mbs, s)
    if not ok:
        raise SystemExit(f"{mech['name']}: Exudyn's solver failed")
    q = []
    disp = mbs.systemData.GetODE2Coordinates()
    for k, node in enumerate(nodes):
        idx = mbs.GetNodeODE2Index(node)
        q.extend(q_ref[3 * k + c] + disp[idx + c] for c in range(3))
    t_end = mbs.systemData.GetTime()
    return elapsed, q, newton, jacobians, t_end


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mech")
    ap.add_argument("--reps", type=int, default=7)
    # SOLVER or SOLVER/full (full Newton; modified Newton otherwise)
    ap.add_argument("--solvers", default="EigenSparse,EigenDense,EXUdense,EigenSparse/full,EXUdense/full")
    a = ap.parse_args()
    mech = fd_models.get(a.mech)
    out = dict(mech=a.mech, peer="exudyn", version=exu.__version__, h=fd_models.H,
               steps=fd_models.STEPS, rho_inf=fd_models.RHO_INF, variants=[])
    for variant in a.solvers.split(","):
        solver, _, newton_kind = variant.partition("/")
        modified = newton_kind != "full"
        times, q = [], None
        for _ in range(a.reps):
            elapsed, q, newton, jacobians, t_end = run_once(mech, solver, modified)
            times.append(elapsed / fd_models.STEPS * 1e6)
        v = dict(solver=solver, newton_kind="modified" if modified else "full", us_median=statistics.median(times), us_min=min(times),
                 us_max=max(times), reps=a.reps, newton=newton, jacobians=jacobians,
                 t_end=t_end, q=q)
        out["variants"].append(v)
        print(f"{a.mech} exudyn {variant}: {v['us_median']:.3g} us/step "
              f"[{v['us_min']:.3g}, {v['us_max']:.3g}] newton {newton} jac {jacobians} "
              f"t_end {t_end}", flush=True)
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    with open(os.path.join(HERE, "results", f"fd_exudyn_{a.mech}.json"), "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
