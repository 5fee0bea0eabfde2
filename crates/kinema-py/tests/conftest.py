"""Shared fixtures: the repository, the `kinema` command line to compare with."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path
from typing import List, Tuple

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]


def _find_cli() -> Path:
    env = os.environ.get("KINEMA_CLI")
    if env:
        return Path(env)
    for profile in ("release", "debug"):
        p = ROOT / "target" / profile / "kinema"
        if p.exists():
            return p
    found = shutil.which("kinema")
    if found:
        return Path(found)
    raise RuntimeError(
        "the tests compare with the `kinema` command line: build it (cargo build -p kinema-cli) "
        "or set KINEMA_CLI"
    )


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def cli() -> Path:
    return _find_cli()


def read_csv(path: Path) -> Tuple[List[str], np.ndarray]:
    """The CLI's CSV: header names and a float64 array (the CLI writes the
    shortest round-trip text, so parsing gives the exact doubles)."""
    text = path.read_text()
    lines = text.splitlines()
    names = lines[0].split(",")
    rows = [[float(x) for x in line.split(",")] for line in lines[1:] if line]
    values = np.array(rows, dtype=np.float64).reshape(len(rows), len(names))
    return names, values


@pytest.fixture()
def run_cli(cli: Path, tmp_path: Path):
    """Runs `kinema ARGS --out FILE`, returns (columns, values, completed process)."""

    def run(*args: str, check: bool = True):
        out = tmp_path / f"cli_{len(list(tmp_path.iterdir()))}.csv"
        p = subprocess.run(
            [str(cli), *args, "--out", str(out)],
            capture_output=True,
            text=True,
            cwd=ROOT,
        )
        if check and p.returncode != 0:
            raise AssertionError(f"kinema {' '.join(args)} failed ({p.returncode}):\n{p.stderr}")
        names, values = read_csv(out) if out.exists() else ([], np.zeros((0, 0)))
        return names, values, p

    return run
