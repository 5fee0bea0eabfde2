"""Writes the kinema models and target tables of the benchmark problems
(problems.py): <name>.kin with the problem's starting design, <name>.csv
with the targets, <name>.published.kin with the published design of least error (by the
literature's formula; defects or not, see README.md) and
<name>.published.times with its targets' times, the log10 files and the
crankrocker30 files (a published function-generation problem, its own
model: CRANKROCKER_TEMPLATE).

    .venv/bin/python make_models.py      (numpy, through problems.py)

The model is the literature's four-bar: ground pivot O = (x0, y0), the
ground link O->D of length r1 at theta0, crank r2, coupler r3 (A->B),
rocker r4 (D->B), the coupler point (rcx, rcy) in a frame at A with x along
A->B. The crank angle measured from the ground link is th2 = phase + sense * t:
with prescribed timing t = th2 - th2_1 (phase = th2_1, sense = 1); without
it each target's time is an unknown in one turn [0, 2 pi), phase is the
crank angle at t = 0 (a design variable) and sense (+1 or -1, not varied)
the way it turns. Function generation (log10) reads the output psi, the
rocker's turn from psi0 (a design variable).
"""

import sys

sys.path.insert(0, __file__.rsplit("/", 1)[0] if "/" in __file__ else ".")
from problems import PI, PROBLEMS, PUBLISHED, crank_angles  # noqa: E402

TEMPLATE = """\
//! {title}
//! Benchmark problem `{name}` of benches/synthesis/README.md: the
//! literature's four-bar, parametrized as published. {design}
mechanism {mech} {{
    /// ground pivot O, x [length]
    param x0 = {x0!r};
    /// ground pivot O, y [length]
    param y0 = {y0!r};
    /// angle of the ground link O->D [rad]
    param theta0 = {theta0!r};
    /// ground link |OD| [length]
    param r1 = {r1!r};
    /// crank |OA| [length]
    param r2 = {r2!r};
    /// coupler |AB| [length]
    param r3 = {r3!r};
    /// rocker |DB| [length]
    param r4 = {r4!r};
    /// coupler point along A->B [length]
    param rcx = {rcx!r};
    /// coupler point normal to A->B [length]
    param rcy = {rcy!r};
    /// crank angle from the ground link at t = 0 [rad]
    param phase = {phase!r};
    /// +1: the crank angle grows with t; -1: it falls (not to be varied)
    param sense = {sense!r};
    /// assembly branch at t = 0: +1 with B left of A->D, -1 right (not to be varied)
    param branch = {branch!r};
    /// function generation: the rocker angle at t = 0, from the ground link [rad]
    param psi0 = {psi0!r};

    // The guesses are the closed-form assembly at t = 0 on `branch` (the
    // coupler turned from A->D by the triangle ABD's angle at A), so the
    // model assembles on the literature's branch whatever the design.
    body crank {{ guess: (x0, y0, theta0 + phase) }}
    body coupler {{ guess: (x0 + r2 * cos(theta0 + phase), y0 + r2 * sin(theta0 + phase), {phic}) }}
    body rocker {{ guess: (x0 + r1 * cos(theta0), y0 + r1 * sin(theta0),
        atan2(r2 * sin(theta0 + phase) + r3 * sin({phic}) - r1 * sin(theta0),
              r2 * cos(theta0 + phase) + r3 * cos({phic}) - r1 * cos(theta0))) }}

    /// the coupler point C (the path generator)
    point coupler.p = (rcx, rcy);

    /// O: crank to ground
    joint o: revolute(crank(0, 0), ground(x0, y0));
    /// A: crank to coupler
    joint a: revolute(crank(r2, 0), coupler(0, 0));
    /// B: coupler to rocker
    joint b: revolute(coupler(r3, 0), rocker(r4, 0));
    /// D: rocker to ground
    joint d: revolute(rocker(0, 0), ground(x0 + r1 * cos(theta0), y0 + r1 * sin(theta0)));
    /// th2 = phase + sense * t, measured from the ground link
    driver crank_angle: crank.phi == theta0 + phase + sense * t;

    /// function generation: the rocker's turn from psi0 [rad]
    output psi: rocker.phi - theta0 - psi0;
}}
"""


def geometry_exprs():
    """The coupler angle at t = 0 on `branch`, as a .kin expression of the params."""
    ux = "r1 * cos(theta0) - r2 * cos(theta0 + phase)"
    uy = "r1 * sin(theta0) - r2 * sin(theta0 + phase)"
    d2 = "(r1 * r1 + r2 * r2 - 2 * r1 * r2 * cos(phase))"
    phic = (f"atan2({uy}, {ux}) + branch * acos((r3 * r3 + {d2} - r4 * r4) / "
            f"(2 * r3 * sqrt({d2})))")
    return dict(phic=phic)


def design_params(name, x, sense=1.0):
    keys = ["r1", "r2", "r3", "r4", "rcx", "rcy", "x0", "y0", "theta0"]
    p = {k: float(v) for k, v in zip(keys, x[:9])}
    fixed = PROBLEMS[name]["fixed"]
    p.update({k: float(v) for k, v in fixed.items()})
    p["phase"] = 0.0
    p["sense"] = float(sense)
    p["branch"] = 1.0
    p["psi0"] = 0.0
    return p


def write_model(path, name, params, design_note, title=None):
    mech = "Bench" + "".join(c for c in name.title() if c.isalnum())
    text = TEMPLATE.format(title=title or PROBLEMS[name]["title"], name=name, mech=mech,
                           design=design_note, **params, **geometry_exprs())
    with open(path, "w") as f:
        f.write(text)


def timing_of(name, x):
    """(times t_i, phase, sense) such that th2_i = phase + sense * t_i, t_1 = 0.

    Prescribed timing (including closed18's uniform 20-degree steps from a
    free th2_1) gives the t column; t starts at the first target so that a
    run from t = 0 covers only the motion the task asks for.
    """
    ths = crank_angles(name, x)
    diffs = [(b - a) for a, b in zip(ths, ths[1:])]
    fwd = sum(d % (2 * PI) for d in diffs)
    sense = 1.0 if fwd < 2 * PI + 1e-9 else -1.0
    t = [0.0]
    for d in diffs:
        t.append(t[-1] + ((sense * d) % (2 * PI)))
    return t, ths[0], sense


def prescribed_times(name):
    """The t column of a problem with prescribed timing, else None."""
    p = PROBLEMS[name]
    if p["timing"] is None:
        return None
    n = len(p["targets"])
    if p["timing"] == "uniform20":
        return [i * PI / 9 for i in range(n)]
    return [th - p["timing"][0] for th in p["timing"]]


def main():
    here = __file__.rsplit("/", 1)[0] if "/" in __file__ else "."
    for name, p in PROBLEMS.items():
        # Targets: with a t column when the timing is prescribed.
        times = prescribed_times(name)
        with open(f"{here}/{name}.csv", "w") as f:
            f.write("t,coupler.p.x,coupler.p.y\n" if times else "coupler.p.x,coupler.p.y\n")
            for i, (tx, ty) in enumerate(p["targets"]):
                f.write((f"{times[i]!r}," if times else "") + f"{tx!r},{ty!r}\n")
        # The starting model: a mid-range design (the fit's start).
        b = p["bounds"]
        rmid = 0.5 * (b["r"][0] + b["r"][1])
        start = [rmid, 0.3 * rmid, rmid, rmid, 0.0, 0.0, 0.0, 0.0, 0.0]
        params = design_params(name, start)
        if isinstance(p["timing"], list):
            params["phase"] = p["timing"][0]
        write_model(f"{here}/{name}.kin", name, params,
                    "The values are a start for `kinema fit` (see README.md).")
        # The best published design (by the literature's error; see README).
        label, via, x = min(PUBLISHED[name], key=lambda d: _err(name, d[2]))
        t, phase, sense = timing_of(name, x)
        params = design_params(name, x, sense)
        params["phase"] = phase
        write_model(f"{here}/{name}.published.kin", name, params,
                    f"The values are the design of {label} ({via}).")
        with open(f"{here}/{name}.published.times", "w") as f:
            f.write("# times t_i of the targets for the published design (th2 = phase + sense t)\n")
            f.write("\n".join(repr(v) for v in t) + "\n")
    write_function_problem(here)
    write_crankrocker(here)


def write_function_problem(here):
    """log10.csv (t, psi), log10.kin (a start) and log10.reference.kin
    (Freudenstein's three-point Chebyshev design, the textbook method)."""
    from problems import FUNCTION, freudenstein_reference, function_targets
    with open(f"{here}/log10.csv", "w") as f:
        f.write("t,psi\n")
        for t, psi in function_targets():
            f.write(f"{t!r},{psi!r}\n")
    base = dict(x0=0.0, y0=0.0, theta0=0.0, r1=1.0, rcx=0.0, rcy=0.0, sense=1.0)
    start = dict(base, r2=1.0, r3=2.0, r4=2.0, phase=PI / 4, psi0=PI / 2, branch=-1.0)
    write_model(f"{here}/log10.kin", "log10", start,
                "The values are a start for `kinema fit` (see README.md).", FUNCTION["title"])
    r2, r3, r4, th2s, psis = (float(v) for v in freudenstein_reference(PI / 6, 5 * PI / 12))
    ref = dict(base, r2=r2, r3=r3, r4=r4, phase=th2s, psi0=psis, branch=-1.0)
    write_model(f"{here}/log10.reference.kin", "log10", ref,
                "The values are Freudenstein's three-point design at Chebyshev spacing "
                "with th2s = 30 deg, psis = 75 deg (a textbook baseline, not a published optimum).",
                FUNCTION["title"])


CRANKROCKER_TEMPLATE = """\
//! {title}
//! Benchmark problem `crankrocker30` of benches/synthesis/README.md: the
//! textbook's crank-rocker, crank A->B, coupler B->C, rocker D->C, frame
//! A->D along x. The rocker |DC| is written through the largest
//! transmission angle `gmax` (the book's constraint gamma <= 135 deg
//! becomes the bound gmax <= 3 pi / 4). The crank starts at phi0, the
//! rocker's right extreme position (crank and coupler in line), where the
//! rocker is at psi0: both are functions of the design, written out. {design}
mechanism BenchCrankrocker30 {{
    /// crank |AB| [length] (fixed by the problem)
    param l1 = {l1!r};
    /// frame |AD| [length] (fixed by the problem)
    param l4 = {l4!r};
    /// coupler |BC| [length]
    param l2 = {l2!r};
    /// the largest transmission angle over a turn, crank pointing away from D [rad]
    param gmax = {gmax!r};

    // At t = 0 the crank and coupler are in line (the extreme position):
    // the guesses are that configuration exactly, on the book's branch.
    body crank {{ guess: (0, 0, {phi0}) }}
    body coupler {{ guess: (l1 * cos({phi0}), l1 * sin({phi0}), {phi0}) }}
    body rocker {{ guess: (l4, 0, {psi0}) }}

    /// A: crank to ground
    joint a: revolute(crank(0, 0), ground(0, 0));
    /// B: crank to coupler
    joint b: revolute(crank(l1, 0), coupler(0, 0));
    /// C: coupler to rocker (the rocker |DC| from l2 and gmax)
    joint c: revolute(coupler(l2, 0), rocker({l3}, 0));
    /// D: rocker to ground
    joint d: revolute(rocker(0, 0), ground(l4, 0));
    /// phi = phi0 + t, from the frame line A->D
    driver crank_angle: crank.phi == {phi0} + t;

    /// the rocker's turn from psi0 (the book's psi - psi0) [rad]
    output psi: rocker.phi - {psi0};
}}
"""


def crankrocker_exprs():
    """The rocker length, phi0 and psi0 as .kin expressions of l1, l4, l2, gmax."""
    l3 = "(l2 * cos(gmax) + sqrt((l4 + l1) * (l4 + l1) - l2 * l2 * sin(gmax) * sin(gmax)))"
    phi0 = (f"acos(((l1 + l2) * (l1 + l2) - {l3} * {l3} + l4 * l4) / "
            f"(2 * (l1 + l2) * l4))")
    psi0 = f"acos(((l1 + l2) * (l1 + l2) - {l3} * {l3} - l4 * l4) / (2 * {l3} * l4))"
    return dict(l3=l3, phi0=phi0, psi0=psi0)


def write_crankrocker(here):
    """crankrocker30.csv (t, psi), crankrocker30.kin (the book's start, l2 =
    4.5, l3 = 4) and crankrocker30.published.kin (the book's optimum, as
    recomputed by problems.crankrocker_reference)."""
    from problems import (CRANKROCKER, crankrocker_gammas, crankrocker_reference,
                          crankrocker_targets)
    name = CRANKROCKER["name"]
    with open(f"{here}/{name}.csv", "w") as f:
        f.write("t,psi\n")
        for t, psi in crankrocker_targets():
            f.write(f"{t!r},{psi!r}\n")
    base = dict(title=CRANKROCKER["title"], l1=CRANKROCKER["crank"], l4=CRANKROCKER["frame"],
                **crankrocker_exprs())
    with open(f"{here}/{name}.kin", "w") as f:
        f.write(CRANKROCKER_TEMPLATE.format(
            l2=4.5, gmax=crankrocker_gammas(4.5, 4.0)[1],
            design="The values are the book's start x0 = (4.5, 4), a start for `kinema fit`.",
            **base))
    l2, l3, err = crankrocker_reference()
    with open(f"{here}/{name}.published.kin", "w") as f:
        f.write(CRANKROCKER_TEMPLATE.format(
            l2=l2, gmax=crankrocker_gammas(l2, l3)[1],
            design=f"The values are the book's optimum (l2 = {l2:.6f}, l3 = {l3:.6f}, error "
                   f"{err:.6g}), recomputed by its method (see README.md).",
            **base))


def _err(name, x):
    from problems import error_literature
    return error_literature(name, x)


if __name__ == "__main__":
    main()
