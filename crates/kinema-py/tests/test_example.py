"""The notebook-style example runs and draws its figures."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from conftest import ROOT


def test_example_runs(tmp_path):
    pytest.importorskip("matplotlib")
    script = ROOT / "crates" / "kinema-py" / "examples" / "slider_crank_notebook.py"
    env = dict(os.environ, MPLBACKEND="Agg", KINEMA_EXAMPLE_OUT=str(tmp_path))
    p = subprocess.run([sys.executable, str(script)], cwd=ROOT, env=env, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    for name in ("path.png", "sweep.png", "dynamics.png"):
        f = tmp_path / name
        assert f.exists() and f.stat().st_size > 5000, name
    assert "stroke" in p.stdout
    assert "motion: forward" in p.stdout and "equilibrium: stable" in p.stdout
