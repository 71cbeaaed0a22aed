"""Shared fixtures: the `lumo` binary the Python results are checked against, and temp dirs."""

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def lumo_bin() -> str:
    """The CLI built from the same sources (`cargo build --release`), or $LUMO_BIN."""
    path = os.environ.get("LUMO_BIN") or str(ROOT / "target" / "release" / "lumo")
    if not os.path.exists(path):
        pytest.fail(f"{path} is missing: run `cargo build --release -p lumo-cli` first (or set LUMO_BIN)")
    return path


def run_lumo(*args, cwd=None) -> subprocess.CompletedProcess:
    out = subprocess.run([lumo_bin(), *map(str, args)], capture_output=True, text=True, cwd=cwd)
    assert out.returncode == 0, out.stderr
    return out


@pytest.fixture
def lumo_cli():
    return run_lumo


@pytest.fixture
def scenes() -> Path:
    return ROOT / "scenes"
