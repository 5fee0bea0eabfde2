"""Names, shapes, dtypes, parameters, results by name, pandas."""

from __future__ import annotations

import numpy as np
import pytest

import kinema

from conftest import ROOT

SLIDER = ROOT / "models" / "slider_crank.kin"


def test_results_shape_dtype_and_names():
    model = kinema.Model.from_file(SLIDER)
    res = model.run(t_end=2.0, steps=200)
    assert isinstance(res.values, np.ndarray)
    assert res.values.dtype == np.float64
    assert res.values.ndim == 2
    assert res.shape == (201, len(res.columns))
    assert res.columns[0] == "t"
    assert res.columns[1:4] == ["crank.x", "crank.y", "crank.phi"]
    assert "slider.x_dot" in res.columns and "reach_ddot" in res.columns
    assert res.columns == model.columns()
    # A column by name is a view of the array, not a copy.
    x = res["slider.x"]
    assert x.shape == (201,)
    assert np.shares_memory(x, res.values)
    assert res["t"][-1] == 2.0
    # Closed form: the crank angle is pi/4 + 2 pi t.
    assert np.allclose(res["crank.phi"], np.pi / 4 + 2 * np.pi * res["t"], atol=1e-12)
    # The slider: x = l1 cos(phi) + sqrt(l2^2 - (l1 sin(phi))^2).
    phi = res["crank.phi"]
    xs = 0.3 * np.cos(phi) + np.sqrt(1.0 - (0.3 * np.sin(phi)) ** 2)
    assert np.allclose(res["slider.x"], xs, atol=1e-10)
    assert res.values.flags["C_CONTIGUOUS"]
    with pytest.raises(KeyError, match="no column 'slider.z'"):
        res["slider.z"]
    with pytest.raises(TypeError):
        res[3]  # type: ignore[index]


def test_to_pandas():
    pd = pytest.importorskip("pandas")
    res = kinema.Model.from_file(SLIDER).run(steps=10)
    df = res.to_pandas()
    assert isinstance(df, pd.DataFrame)
    assert list(df.columns) == res.columns
    assert np.array_equal(df.to_numpy(), res.values)


def test_params_and_with_params():
    model = kinema.Model.from_file(SLIDER)
    assert model.params == pytest.approx({"l1": 0.3, "l2": 1.0, "omega": 2 * np.pi})
    longer = model.with_params(l2=1.5)
    assert longer.params["l2"] == 1.5
    assert model.params["l2"] == 1.0  # the original is unchanged
    a = model.run(steps=20)
    b = longer.run(steps=20)
    # The same model written with l2 = 1.5 gives the same doubles.
    text = SLIDER.read_text().replace("param l2 = 1.0;", "param l2 = 1.5;")
    c = kinema.Model(text, "slider_crank.kin").run(steps=20)
    assert np.array_equal(b.values, c.values)
    assert not np.array_equal(a.values, b.values)
    # A sweep over l1 starts from the with_params values of the others.
    s = longer.sweep({"l1": [0.3]}, steps=20)
    assert s.columns[:3] == ["row", "l1", "t"]
    assert np.array_equal(s.values[:, 2:], b.values)


def test_check_is_the_dof_report():
    report = kinema.Model.from_file(SLIDER).check()
    assert report["name"] == "SliderCrank"
    assert report["bodies"] == ["crank", "rod", "slider"]
    assert len(report["coordinates"]) == 9
    assert report["kinematic_equations"] == 8
    assert report["driving_equations"] == 1
    assert report["kdof"] == 1
    assert report["dof"] == 0
    assert len(report["equations"]) == 9
    assert report["params"] == ["l1", "l2", "omega"]
    assert "reach" in report["results"]


def test_model_from_text_and_repr():
    model = kinema.Model(
        """mechanism Pendulum {
            param l = 1.0;
            body bar { guess: (0.5, 0.8, 1.0) }
            joint pin: revolute(ground(0, 0), bar(-l, 0));
            driver swing: bar.phi == 4 * t * t;
        }""",
        "pendulum.kin",
    )
    assert model.name == "Pendulum"
    assert model.file == "pendulum.kin"
    res = model.run(t_end=0.5, steps=5)
    assert abs(res["bar.phi"][-1] - 1.0) < 1e-12
    assert "Pendulum" in repr(model) and "6 rows" in repr(res)


def test_events_as_data():
    # A change-point four-bar: the branches cross once per turn, at the
    # crank angle 0 mod 2 pi (t = 0.875 with the model's drive).
    with pytest.warns(kinema.SingularConfigurationWarning):
        res = kinema.Model.from_file(ROOT / "tests" / "singular" / "change_point.kin").run()
    assert len(res.events) == 1
    e = res.events[0]
    assert e.kind == "bifurcation"
    assert abs(e.t - 0.875) < 1e-6
    assert "d.x" in e.equations
    assert "bifurcation at t = 0.875" in e.message
