"""Model.run and Model.sweep give the numbers of `kinema run` and `kinema
sweep`: the same column names and the same doubles, bit for bit."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import kinema

from conftest import ROOT, read_csv

MODELS = sorted((ROOT / "models").glob("*.kin"))
ADM = ROOT / "crates" / "kinema-adm" / "tests" / "data" / "slider_crank.adm"


def assert_same(py: kinema.Results, names, values) -> None:
    assert py.columns == names
    assert py.values.dtype == np.float64
    assert py.values.shape == values.shape
    # Bit for bit: the CLI prints the shortest text that reads back as the
    # same double.
    assert np.array_equal(py.values, values), np.max(np.abs(py.values - values))


def test_every_model_is_covered():
    assert len(MODELS) >= 10, MODELS


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_run_equals_cli(path: Path, run_cli):
    names, values, _ = run_cli("run", str(path), "--t-end", "1.5", "--steps", "60")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", kinema.KinemaWarning)
        res = kinema.Model.from_file(path).run(t_end=1.5, steps=60)
    assert_same(res, names, values)
    assert len(res) == 61


@pytest.mark.parametrize("path", MODELS[:4], ids=lambda p: p.stem)
def test_default_grid_equals_cli(path: Path, run_cli):
    names, values, _ = run_cli("run", str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", kinema.KinemaWarning)
        res = kinema.Model.from_file(path).run()
    assert_same(res, names, values)


def test_tape_backend_equals_cli(run_cli):
    path = ROOT / "models" / "four_bar.kin"
    names, values, _ = run_cli("run", str(path), "--steps", "40", "--backend", "tape")
    res = kinema.Model.from_file(path).run(steps=40, backend="tape")
    assert res.backend == "tape"
    assert_same(res, names, values)


def test_columns_and_positions_only_equal_cli(run_cli):
    path = ROOT / "models" / "slider_crank.kin"
    model = kinema.Model.from_file(path)
    names, values, _ = run_cli("run", str(path), "--steps", "30", "--columns", "slider,reach,crank.pin")
    assert_same(model.run(steps=30, columns="slider,reach,crank.pin"), names, values)
    assert_same(model.run(steps=30, columns=["slider", "reach", "crank.pin"]), names, values)
    names, values, _ = run_cli("run", str(path), "--steps", "30", "--positions-only")
    res = model.run(steps=30, positions_only=True)
    assert not any(c.endswith("_dot") for c in res.columns)
    assert_same(res, names, values)


def test_inverse_dynamics_columns_equal_cli(run_cli):
    path = ROOT / "tests" / "dynamics" / "slider_crank.kin"
    names, values, _ = run_cli("run", str(path), "--t-end", "1", "--steps", "50")
    res = kinema.Model.from_file(path).run(t_end=1.0, steps=50)
    assert any(c.startswith("lambda.") for c in res.columns)
    assert any(c.startswith("reaction.") for c in res.columns)
    assert_same(res, names, values)


def test_simengine_adm_equals_cli(run_cli):
    # The engine's default analysis (kinematics.acf: tend 5, stepSize 0.01,
    # 500 output steps), solved every stepSize as `kinema run` does.
    names, values, _ = run_cli("run", str(ADM))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", kinema.KinemaWarning)
        model = kinema.Model.from_file(ADM)
        res = model.run()
    assert len(res) == 501
    assert_same(res, names, values)
    # --t-end and --steps override tend and outputSteps.
    names, values, _ = run_cli("run", str(ADM), "--t-end", "1", "--steps", "20")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", kinema.KinemaWarning)
        assert_same(model.run(t_end=1.0, steps=20), names, values)


def test_times_array_equals_uniform_grid():
    model = kinema.Model.from_file(ROOT / "models" / "slider_crank.kin")
    a = model.run(t_end=1.0, steps=10)
    b = model.run(times=a["t"].copy())
    assert np.array_equal(a.values, b.values)


def test_sweep_equals_cli_sweep(run_cli, tmp_path: Path):
    path = ROOT / "models" / "slider_crank.kin"
    l1 = np.array([0.2, 0.25, 0.3, 0.35])
    l2 = np.array([0.9, 1.0, 1.1, 1.2])
    table = tmp_path / "table.csv"
    table.write_text("l1,l2\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(l1, l2)))
    names, values, _ = run_cli("sweep", str(path), "--params", str(table), "--t-end", "1", "--steps", "25")
    res = kinema.Model.from_file(path).sweep({"l1": l1, "l2": l2}, t_end=1.0, steps=25)
    assert res.columns[:4] == ["row", "l1", "l2", "t"]
    assert_same(res, names, values)
    assert len(res) == 4 * 26


def test_sweep_from_dataframe_positions_only_equals_cli(run_cli, tmp_path: Path):
    pd = pytest.importorskip("pandas")
    path = ROOT / "models" / "four_bar.kin"
    model = kinema.Model.from_file(path)
    name = list(model.params)[0]
    base = model.params[name]
    df = pd.DataFrame({name: [base * 0.98, base, base * 1.02]})
    table = tmp_path / "table.csv"
    table.write_text(f"{name}\n" + "".join(f"{float(v)!r}\n" for v in df[name]))
    names, values, _ = run_cli(
        "sweep", str(path), "--params", str(table), "--steps", "20", "--positions-only"
    )
    assert_same(model.sweep(df, steps=20, positions_only=True), names, values)


@pytest.mark.parametrize("name", ["change_point.kin", "parallelogram.kin", "six_bar.kin"])
def test_singular_runs_equal_cli(name: str, run_cli):
    # Through singular configurations (bifurcations, toggles, flagged rows):
    # the same branch, the same doubles.
    path = ROOT / "tests" / "singular" / name
    names, values, p = run_cli("run", str(path), "--t-end", "2", "--steps", "80")
    assert "warning" in p.stderr
    with pytest.warns(kinema.SingularConfigurationWarning):
        res = kinema.Model.from_file(path).run(t_end=2.0, steps=80)
    assert res.events
    assert_same(res, names, values)
