#!/usr/bin/env python3
"""Exudyn (PyPI) on IFToMM benchmark A02, the N four-bar mechanism (BENCHMARKS.md, "IFToMM
problems"), for the side-by-side table with kinema.

The model is the one of models/iftomm/a02_four_bar_N.kin: N + 1 cranks pinned to the ground 1 m
apart and N couplers joining their tips, 2N + 1 uniform bars of 1 m and 1 kg
(NodeRigidBody2D + ObjectRigidBody2D, centroidal inertia m l^2 / 12), RevoluteJoint2D for every
pin, gravity 9.81 in -y by LoadMassProportional; the published start (cranks vertical, the first
crank's tip moving at 1 m/s in +x). The constraints are redundant (2 (3N + 1) rows on 3 (2N + 1)
coordinates with one degree of freedom): Exudyn's documented setting for that is
`linearSolver.ignoreSingularJacobian = True` (its fourBarMechanism3D example; formerly under linearSolverSettings), without
which the first factorization fails. Integrator: Exudyn's generalized-alpha (index 3) at the
spectral radius of kinema's HHT alpha = -0.1 (rho_inf = 0.8182), fixed step h, full Newton,
EigenDense or EigenSparse.

Measured: the largest difference over the 400 output times (every 0.05 s) and the N + 1 cranks
between a crank's angle and the one-degree-of-freedom reference
c_T th'' = -g c_V cos th (c_T = (N+1) m l^2/3 + N m l^2, c_V = (N+1) m l/2 + N m l), integrated
here by scipy's DOP853 at rtol = atol = 1e-13; and the wall time of the solve (the set-up and the
initial accelerations not counted).

  iftomm_exudyn.py N --h 2.5e-4 [--solver EigenSparse] [--t-end 20]
"""
import argparse
import json
import math
import os
import time

import exudyn as exu
import numpy as np
from exudyn.itemInterface import (
    LoadMassProportional,
    MarkerBodyMass,
    MarkerBodyPosition,
    NodeRigidBody2D,
    ObjectGround,
    ObjectRigidBody2D,
    RevoluteJoint2D,
    SensorNode,
)

from iftomm_ref import reference

HERE = os.path.dirname(os.path.abspath(__file__))
G, L, M, V0 = 9.81, 1.0, 1.0, 1.0
RHO_INF = 0.8182
OUTPUTS = 400


def build(n, t_end):
    """(SystemContainer, MainSystem, crank sensors, crank reference angles)."""
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddObject(ObjectGround(referencePosition=[0, 0, 0]))
    inertia = M * L * L / 12

    def body(q, v):
        node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(q), initialVelocities=list(v)))
        obj = mbs.AddObject(ObjectRigidBody2D(mass=M, inertia=inertia, nodeNumber=node))
        mass = mbs.AddMarker(MarkerBodyMass(bodyNumber=obj))
        mbs.AddLoad(LoadMassProportional(markerNumber=mass, loadVector=[0, -G, 0]))
        return node, obj

    def pin(a, sa, b, sb):
        ma = mbs.AddMarker(MarkerBodyPosition(bodyNumber=a, localPosition=[sa[0], sa[1], 0]))
        mb = mbs.AddMarker(MarkerBodyPosition(bodyNumber=b, localPosition=[sb[0], sb[1], 0]))
        mbs.AddObject(RevoluteJoint2D(markerNumbers=[ma, mb]))

    cranks = []
    for i in range(n + 1):
        # Vertical, the centroid at (i l, l/2), turning at -v0/l: its centroid moves at v0/2.
        node, obj = body([i * L, L / 2, math.pi / 2], [V0 / 2, 0, -V0 / L])
        pin(ground, [i * L, 0], obj, [-L / 2, 0])
        cranks.append((node, obj))
    for i in range(1, n + 1):
        _, coupler = body([i * L - L / 2, L, 0], [V0, 0, 0])
        pin(cranks[i - 1][1], [L / 2, 0], coupler, [-L / 2, 0])
        pin(cranks[i][1], [L / 2, 0], coupler, [L / 2, 0])
    sensors = [
        mbs.AddSensor(SensorNode(nodeNumber=node, storeInternal=True,
                                 outputVariableType=exu.OutputVariableType.Coordinates))
        for node, _ in cranks
    ]
    mbs.Assemble()
    return sc, mbs, sensors


def settings(h, t_end, solver):
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.numberOfSteps = round(t_end / h)
    ti.endTime = t_end
    ti.verboseMode = 0
    ti.generalizedAlpha.useNewmark = False
    ti.generalizedAlpha.useIndex2Constraints = False
    ti.generalizedAlpha.spectralRadius = RHO_INF
    ti.generalizedAlpha.computeInitialAccelerations = True
    ti.newton.useModifiedNewton = False
    ti.reuseConstantMassMatrix = True
    s.linearSolver.ignoreSingularJacobian = True
    s.solution.file.write = False
    s.solution.file.writeInitialValues = False
    s.solution.sensors.writePeriod = t_end / OUTPUTS
    s.show.computationTime = False
    s.show.statistics = False
    s.parallel.numberOfThreads = 1
    s.linearSolver.solverType = getattr(exu.LinearSolverType, solver)
    return s


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("n", type=int)
    ap.add_argument("--h", type=float, default=1e-3)
    ap.add_argument("--t-end", type=float, default=20.0)
    ap.add_argument("--solver", default="EigenSparse")
    a = ap.parse_args()
    sc, mbs, sensors = build(a.n, a.t_end)
    s = settings(a.h, a.t_end, a.solver)
    sol = exu.MainSolverImplicitSecondOrder()
    sol.InitializeSolver(mbs, s)
    t0 = time.perf_counter()
    ok = sol.SolveSteps(mbs, s)
    elapsed = time.perf_counter() - t0
    sol.FinalizeSolver(mbs, s)
    t_reached = mbs.systemData.GetTime()
    worst = 0.0
    rows = 0
    for sensor in sensors:
        data = np.asarray(mbs.GetSensorStoredData(sensor))
        # Columns: t, then the node's displacement coordinates (x, y, phi from the reference).
        t, phi = data[:, 0], math.pi / 2 + data[:, 3]
        worst = max(worst, float(np.max(np.abs(phi - reference(a.n, t)))))
        rows = len(t)
    out = dict(peer="exudyn", version=exu.__version__, n=a.n, h=a.h, solver=a.solver,
               rho_inf=RHO_INF, ok=bool(ok), t_reached=t_reached, outputs=rows,
               max_crank_error=worst, wall_s=elapsed)
    print(json.dumps(out), flush=True)
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    with open(os.path.join(HERE, "results", f"iftomm_exudyn_a02_n{a.n}_h{a.h:g}.json"), "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
