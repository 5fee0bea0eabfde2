"""The native analyses take one request dict each (src/request.rs): a key
left out takes the default the Python layer's keyword has, a bad request is
a TypeError that names its key, never a panic or a silent ignore."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import kinema

from conftest import ROOT

SLIDER = ROOT / "models" / "slider_crank.kin"
PENDULUM = ROOT / "models" / "iftomm" / "a01_pendulum.kin"


def test_left_out_keys_take_the_python_defaults():
    model = kinema.Model.from_file(SLIDER)
    native = model._native.run({"times": None})
    np.testing.assert_array_equal(native["values"], model.run().values)
    table = np.array([[0.3], [0.35]])
    times = [0.0, 0.5, 1.0]
    native = model._native.sweep({"names": ["l1"], "table": table, "times": times})
    np.testing.assert_array_equal(native["values"], model.sweep({"l1": [0.3, 0.35]}, times=times).values)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", kinema.KinemaWarning)
        pendulum = kinema.Model.from_file(PENDULUM)
        expected = pendulum.forward(times=[0.0, 0.1, 0.2]).values
    native = pendulum._native.forward({"times": [0.0, 0.1, 0.2]})
    np.testing.assert_array_equal(native["values"], expected)
    assert native["integrator"].startswith("HHT")


@pytest.mark.parametrize(
    "method, request_, match",
    [
        ("run", {"times": None, "step": 1e-3}, "run request: unknown key 'step'"),
        ("run", {"times": None, "steps": "10"}, "RunRequest.steps"),
        ("run", {"times": None, "backend": 1}, "RunRequest.backend"),
        ("run", {}, "run request: the key 'times' is missing"),
        ("forward", {"times": [0.0, 0.1], "integrator": None}, "ForwardRequest.integrator"),
        ("forward", {"columns": None}, "forward request: the key 'times' is missing"),
        ("sweep", {"names": ["l1"], "table": [[0.3]], "times": [0.0], "threads": 1.5}, "SweepRequest.threads"),
        ("sweep", {"names": ["l1"], "table": [[0.3]], "times": [0.0], "first": -1}, "SweepRequest.first"),
        ("sweep", {"names": ["l1"], "table": [[0.3]], "times": [0.0], 7: 1}, "unknown key 7"),
        ("sweep", {"names": ["l1"], "table": [[0.3]]}, "the key 'times' is missing"),
    ],
)
def test_bad_requests_are_type_errors_naming_the_key(method, request_, match):
    model = kinema.Model.from_file(SLIDER)
    with pytest.raises(TypeError, match=match):
        getattr(model._native, method)(request_)


def test_a_request_is_a_dict():
    model = kinema.Model.from_file(SLIDER)
    with pytest.raises(TypeError):
        model._native.run(None)
    with pytest.raises(TypeError):
        model._native.run(times=None)
