"""Forward dynamics, equilibrium and inverse dynamics from Python give the
numbers of `kinema run` (and `kinema run --equilibrium`): the same column
names and the same doubles, bit for bit; passages and redundancy warn,
failures raise with the rows computed before them."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import kinema

from conftest import ROOT
from test_cli_equal import assert_same

# Every model file in the repository with inertia (models/ and the dynamics
# test models), and a simEngine2D model under a Dynamics analysis.
INERTIA = sorted(
    p
    for p in list((ROOT / "models").rglob("*.kin")) + list((ROOT / "tests" / "dynamics").glob("*.kin"))
    if "mass:" in p.read_text()
)
ADM_DATA = ROOT / "crates" / "kinema-adm" / "tests" / "data"


def quiet(f, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", kinema.KinemaWarning)
        return f(*args, **kwargs)


def test_models_with_inertia_are_covered():
    # The IFToMM benchmarks (forward dynamics) and the driven slider-crank
    # (inverse dynamics).
    assert len(INERTIA) >= 5, INERTIA
    motions = {quiet(kinema.Model.from_file, p).motion for p in INERTIA}
    assert motions == {"forward", "kinematic"}, motions


# (t_end, steps, HHT's step): Andrews' mechanism turns its crank 2.5 times
# in 0.03 s and needs steps well below 1e-4 s.
ANALYSIS = {"a03_andrews": (0.03, 30, 1e-5)}


@pytest.mark.parametrize("path", INERTIA, ids=lambda p: p.stem)
def test_every_model_with_inertia_equals_cli(path: Path, run_cli):
    t_end, steps, step = ANALYSIS.get(path.stem, (0.5, 25, None))
    extra = ["--step", repr(step)] if step is not None else []
    names, values, _ = run_cli("run", str(path), "--t-end", repr(t_end), "--steps", str(steps), *extra)
    model = quiet(kinema.Model.from_file, path)
    options = {"step": step} if step is not None else {}
    res = quiet(model.run, t_end=t_end, steps=steps, **options)
    assert_same(res, names, values)
    assert len(res) == steps + 1
    assert any(c.startswith("lambda.") for c in res.columns)
    if model.motion == "forward":
        assert res.info["motion"] == "forward"
        assert "HHT" in res.info["integrator"]
        # model.forward is the same run, said explicitly.
        again = quiet(model.forward, t_end=t_end, steps=steps, **options)
        assert np.array_equal(again.values, res.values)


def test_forward_options_equal_cli(run_cli):
    path = ROOT / "models" / "iftomm" / "a02_four_bar_1.kin"
    model = quiet(kinema.Model.from_file, path)
    cases = [
        (["--integrator", "accurate", "--rtol", "1e-9"], dict(integrator="accurate", rtol=1e-9)),
        (["--step", "0.004", "--energy"], dict(step=0.004, energy=True)),
        (["--project-velocity", "--columns", "bodies"], dict(project_velocity=True, columns="bodies")),
        (["--backend", "tape"], dict(backend="tape")),
    ]
    for cli_args, kwargs in cases:
        names, values, _ = run_cli("run", str(path), "--t-end", "0.4", "--steps", "20", *cli_args)
        res = quiet(model.forward, t_end=0.4, steps=20, **kwargs)
        assert_same(res, names, values)
    res = quiet(model.forward, t_end=0.4, steps=20, energy=True)
    assert res.columns[-3:] == ["energy.kinetic", "energy.potential", "energy.work"]
    e = res.info["energies"]
    assert abs(e["balance"]) < 1e-2 * max(abs(e["kinetic"]), abs(e["potential"]), 1e-300)


def test_simengine_dynamics_analysis_equals_cli(run_cli):
    adm, acf = ADM_DATA / "free_pendulum.adm", ADM_DATA / "dynamics.acf"
    names, values, _ = run_cli("run", str(adm), "--acf", str(acf))
    model = quiet(kinema.Model.from_file, adm, acf=acf)
    assert model.motion == "forward"
    res = quiet(model.run)
    assert len(res) == 401  # the ACF's outputSteps
    assert any(c.startswith("reaction.") and ".body" in c for c in res.columns)
    assert_same(res, names, values)
    names, values, _ = run_cli("run", str(adm), "--acf", str(acf), "--t-end", "1", "--steps", "10", "--integrator", "accurate")
    assert_same(quiet(model.run, t_end=1.0, steps=10, integrator="accurate"), names, values)


# A parallelogram four-bar with a third crank (crates/kinema-cli/tests/
# cli_redundant.rs): released from rest, it passes the flat configuration
# (a singular one) at t = 0.5; with the third crank's revolute, one of its
# rows is redundant.
def parallelogram(third: str, driver: str = "") -> str:
    return f"""mechanism Parallelogram {{
        param th = pi / 3;
        body crank0  {{ guess: (0.5 * cos(th), 0.5 * sin(th), th), mass: 1, inertia: 1 / 12 }}
        body crank1  {{ guess: (1 + 0.5 * cos(th), 0.5 * sin(th), th), mass: 1, inertia: 1 / 12 }}
        body coupler {{ guess: (cos(th) + 0.5, sin(th), 0), mass: 1, inertia: 1 / 12 }}
        body crank2  {{ guess: (0.5 + 0.5 * cos(th), 0.5 * sin(th), th), mass: 1, inertia: 1 / 12 }}
        gravity = (0, -9.81);
        joint p0: revolute(ground(0, 0), crank0(-0.5, 0));
        joint p1: revolute(ground(1, 0), crank1(-0.5, 0));
        joint a: revolute(crank0(0.5, 0), coupler(-0.5, 0));
        joint b: revolute(crank1(0.5, 0), coupler(0.5, 0));
        joint p2: revolute(ground(0.5, 0), crank2(-0.5, 0));
        {third}
        {driver}
    }}"""


REDUNDANT = "joint c: revolute(crank2(0.5, 0), coupler(0, 0));"


def test_a_singular_passage_warns_and_equals_cli(run_cli, tmp_path: Path):
    path = tmp_path / "pg.kin"
    path.write_text(parallelogram(""))
    names, values, p = run_cli("run", str(path), "--t-end", "0.8", "--steps", "80")
    assert "singular configuration passed at t = 0.5" in p.stderr
    model = kinema.Model.from_file(path)
    assert model.motion == "forward"
    with pytest.warns(kinema.SingularConfigurationWarning, match="singular configuration passed at t = 0.5"):
        res = model.run(t_end=0.8, steps=80)
    assert [e.kind for e in res.events] == ["passage"]
    assert 0.5 <= res.events[0].t < 0.6  # the warning prints "t = 0.53…"
    assert "p0.x" in res.events[0].equations
    assert_same(res, names, values)


def test_redundant_constraints_warn_and_equal_cli(run_cli, tmp_path: Path):
    path = tmp_path / "pg3.kin"
    path.write_text(parallelogram(REDUNDANT))
    names, values, p = run_cli("run", str(path), "--t-end", "0.3", "--steps", "30")
    assert "redundant constraints at the start" in p.stderr
    model = kinema.Model.from_file(path)
    assert model.motion == "forward"
    with pytest.warns(kinema.RedundantConstraintsWarning, match="redundant constraints at the start"):
        res = model.run(t_end=0.3, steps=30)
    assert res.info["redundant"]
    assert_same(res, names, values)
    # Driven as well: the prescribed motion by minimum-norm solves.
    path = tmp_path / "pg3d.kin"
    path.write_text(parallelogram(REDUNDANT, "driver turn: crank0.phi == th + t;"))
    names, values, _ = run_cli("run", str(path), "--t-end", "0.3", "--steps", "30")
    model = kinema.Model.from_file(path)
    assert model.motion == "prescribed"
    res = quiet(model.run, t_end=0.3, steps=30)
    assert res.info["motion"] == "prescribed"
    assert_same(res, names, values)


def test_a_failure_raises_with_the_rows_before_it(run_cli, tmp_path: Path):
    # A driver with a pole at t = 0.5052, between two output times.
    path = tmp_path / "drv.kin"
    path.write_text(
        """mechanism D {
            body bar { guess: (1, 0, 0), mass: 2, inertia: 0.3 }
            body block { guess: (3, 0, 0), mass: 1, inertia: 0.1 }
            gravity = (0, -9.81);
            constraint px: abs_x(bar(-1, 0), 0);
            constraint py: abs_y(bar(-1, 0), 0);
            constraint by: block.y == 0;
            constraint bphi: block.phi == 0;
            driver push: block.x == 3 + 1 / (t - 0.5052);
        }"""
    )
    names, values, p = run_cli("run", str(path), check=False)
    assert p.returncode == 1
    model = kinema.Model.from_file(path)
    assert model.motion == "forward"
    with pytest.raises(kinema.AnalysisError, match=r"equation `push` is unbounded at t = 0\.505") as e:
        model.run()
    res = e.value.results
    assert 0 < len(res) < 101
    assert_same(res, names, values)


def test_equilibrium_equals_cli(run_cli, tmp_path: Path):
    cases = [ROOT / "models" / "iftomm" / "a02_four_bar_1.kin", ROOT / "models" / "iftomm" / "a01_pendulum.kin"]
    for path in cases:
        names, values, p = run_cli("run", str(path), "--equilibrium")
        res = quiet(kinema.Model.from_file, path).equilibrium()
        assert len(res) == 1
        assert res.info["stability"] in p.stdout + p.stderr
        assert_same(res, names, values)
    # The pendulum hangs straight down: the bob at (0, -1).
    assert abs(res["bob.x"][0]) < 1e-9 and abs(res["bob.y"][0] + 1.0) < 1e-9
    assert res.info["stability"] == "stable"
    names, values, _ = run_cli("run", str(cases[0]), "--equilibrium", "--columns", "points")
    assert_same(quiet(kinema.Model.from_file, cases[0]).equilibrium(columns="points"), names, values)


def test_with_params_moves_the_start(tmp_path: Path):
    # A changed parameter moves the declared start (the guess is evaluated
    # at the new values): the same run as the text with that value.
    text = (ROOT / "models" / "iftomm" / "a01_pendulum.kin").read_text()
    a = quiet(kinema.Model(text, "a.kin").with_params(l=1.5).run, t_end=0.3, steps=10)
    b = quiet(kinema.Model(text.replace("param l = 1;", "param l = 1.5;"), "b.kin").run, t_end=0.3, steps=10)
    assert a.columns == b.columns
    np.testing.assert_allclose(a.values, b.values, rtol=0, atol=1e-12)
    assert abs(a["bob.x"][0] - 1.5) < 1e-12


def test_bad_dynamics_options_raise_clearly():
    pend = quiet(kinema.Model.from_file, ROOT / "models" / "iftomm" / "a01_pendulum.kin")
    kin = kinema.Model.from_file(ROOT / "models" / "slider_crank.kin")
    with pytest.raises(ValueError, match="rtol is the tolerance"):
        pend.run(rtol=1e-6)
    with pytest.raises(ValueError, match="step is HHT's"):
        pend.run(integrator="accurate", step=1e-3)
    with pytest.raises(ValueError, match="integrator must be"):
        pend.run(integrator="euler")
    with pytest.raises(ValueError, match="step must be a positive"):
        pend.run(step=-1e-3)
    with pytest.raises(ValueError, match="rtol must be in"):
        pend.run(integrator="accurate", rtol=2.0)
    with pytest.raises(TypeError, match="step must be a number"):
        pend.run(step="fast")
    with pytest.raises(ValueError, match="positions_only cannot be used with forward dynamics"):
        pend.run(positions_only=True)
    with pytest.raises(ValueError, match="are for forward dynamics"):
        kin.run(integrator="accurate")
    with pytest.raises(ValueError, match="step is for forward dynamics"):
        kin.run(step=1e-3)
    with pytest.raises(kinema.KinemaError, match="no inertia"):
        kin.forward()
    with pytest.raises(kinema.KinemaError, match="no inertia"):
        kin.equilibrium()
