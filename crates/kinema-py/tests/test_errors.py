"""Bad input raises clear Python exceptions; warnings go through `warnings`."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import kinema

from conftest import ROOT

SLIDER = ROOT / "models" / "slider_crank.kin"


def test_typo_raises_model_error_with_line_and_column():
    text = SLIDER.read_text().replace("joint pin:   revolute(crank(", "joint pin:   revolute(crnk(")
    with pytest.raises(kinema.ModelError) as info:
        kinema.Model(text, "typo.kin")
    message = str(info.value)
    line = next(i for i, l in enumerate(text.splitlines(), 1) if "crnk(" in l)
    col = text.splitlines()[line - 1].index("crnk") + 1
    assert f"typo.kin:{line}:{col}" in message, message
    assert "crnk" in message
    d = info.value.diagnostics[0]
    assert (d["severity"], d["line"], d["column"]) == ("error", line, col)
    assert "crnk" in d["message"]
    assert isinstance(info.value, kinema.KinemaError)


def test_typo_in_a_file(tmp_path):
    bad = tmp_path / "bad.kin"
    bad.write_text(SLIDER.read_text().replace("param l2 = 1.0;", "param l2 = 1.0 +;"))
    with pytest.raises(kinema.ModelError, match=r"bad\.kin:\d+:\d+"):
        kinema.Model.from_file(bad)


def test_bad_adm_raises_model_error_with_position():
    with pytest.raises(kinema.ModelError, match=r"bad_json\.adm:\d+:\d+"):
        kinema.Model.from_file(ROOT / "crates" / "kinema-adm" / "tests" / "data" / "bad_json.adm")


def test_missing_file():
    with pytest.raises(FileNotFoundError, match="no_such.kin"):
        kinema.Model.from_file(ROOT / "no_such.kin")


@pytest.mark.parametrize(
    "kwargs, exc, match",
    [
        (dict(steps=-5), ValueError, "steps must be at least 1"),
        (dict(steps=0), ValueError, "steps must be at least 1"),
        (dict(steps=10**12), ValueError, "more than one run takes"),
        (dict(steps=2.5), TypeError, "steps must be a whole number"),
        (dict(steps="10"), TypeError, "steps must be a whole number"),
        (dict(steps=True), TypeError, "steps must be a whole number"),
        (dict(t_end=-1.0), ValueError, "t_end must be a positive finite time"),
        (dict(t_end=float("nan")), ValueError, "t_end must be a positive finite time"),
        (dict(t_end="1"), TypeError, "t_end must be a number"),
        (dict(times=[0.0, 0.2, 0.1]), ValueError, "increase strictly"),
        (dict(times=[0.0, float("inf")]), ValueError, "finite"),
        (dict(times=[[0.0, 1.0]]), ValueError, "one-dimensional"),
        (dict(times=["a"]), TypeError, "times must be an array of numbers"),
        (dict(times=[0.0, 1.0], steps=3), TypeError, "either times"),
        (dict(columns="crank,nothing"), ValueError, "`nothing` is not a column"),
        (dict(columns=[1, 2]), TypeError, "columns must be names"),
        (dict(backend="gpu"), ValueError, "backend must be"),
    ],
)
def test_bad_run_arguments(kwargs, exc, match):
    model = kinema.Model.from_file(SLIDER)
    with pytest.raises(exc, match=match):
        model.run(**kwargs)


def test_bad_params_and_tables():
    model = kinema.Model.from_file(SLIDER)
    with pytest.raises(ValueError, match="`l3` is not a parameter .* `l1`, `l2`, `omega`"):
        model.with_params(l3=1.0)
    with pytest.raises(TypeError, match="must be a number"):
        model.with_params(l1="long")
    with pytest.raises(ValueError, match="finite"):
        model.with_params(l1=float("inf"))
    with pytest.raises(ValueError, match="`l9` is not a parameter"):
        model.sweep({"l9": [1.0]})
    with pytest.raises(ValueError, match="differ in length"):
        model.sweep({"l1": [0.3, 0.2], "l2": [1.0]})
    with pytest.raises(TypeError, match="dict of arrays or a pandas DataFrame"):
        model.sweep([0.3, 0.2])
    with pytest.raises(ValueError, match="finite"):
        model.sweep({"l1": [0.3, float("nan")]})
    with pytest.raises(TypeError):
        kinema.Model(42)  # type: ignore[arg-type]
    with pytest.raises(TypeError):
        kinema.Model.from_file(3.5)  # type: ignore[arg-type]


def test_singular_run_warns():
    with pytest.warns(kinema.SingularConfigurationWarning, match="bifurcation at t = 0.875"):
        kinema.Model.from_file(ROOT / "tests" / "singular" / "change_point.kin").run()
    # Rows within the threshold of a singular configuration: flagged, warned.
    with pytest.warns(kinema.SingularConfigurationWarning, match="3 row\\(s\\) at t = 0.0 ... 1.0"):
        res = kinema.Model.from_file(ROOT / "tests" / "singular" / "parallelogram.kin").run()
    assert res.flagged == [0.0, 0.5, 1.0]


def test_failure_carries_the_rows_before_it():
    # A non-Grashof four-bar driven at its crank locks up at its dead point
    # (t = 0.0595): the step there fails.
    model = kinema.Model.from_file(ROOT / "tests" / "singular" / "dead_point.kin")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", kinema.KinemaWarning)
        with pytest.raises(kinema.AnalysisError) as info:
            model.run(t_end=0.5, steps=100, stop_at_singular=True)
    res = info.value.results
    assert isinstance(res, kinema.Results)
    assert 0 < len(res) < 101
    assert res.values.shape[1] == len(res.columns)
    assert np.all(np.isfinite(res.values))
    assert "computed before the failure" in str(info.value)


def test_failed_variants_in_a_sweep():
    model = kinema.Model.from_file(SLIDER)
    # l2 = 0.2 < l1: the slider cannot reach, assembly fails for variant 2.
    table = {"l2": [1.0, 0.2, 1.1]}
    with pytest.raises(kinema.AnalysisError, match="1 of 3 variants failed") as info:
        model.sweep(table, steps=10)
    rows = info.value.results["row"]
    assert set(rows) == {1.0, 3.0}
    with pytest.warns(kinema.SweepWarning, match="variant 2"):
        res = model.sweep(table, steps=10, errors="warn")
    assert [k for k, _ in res.failures] == [1]
