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


@pytest.fixture(scope="session")
def cluster():
    """A local Ray cluster of three one-CPU nodes on the loopback interface, shared by the
    Ray tests (starting one takes seconds)."""
    ray = pytest.importorskip("ray")
    from ray.cluster_utils import Cluster

    import lumo.ray as lray

    lray.loopback_only()
    c = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "include_dashboard": False})
    for _ in range(2):
        c.add_node(num_cpus=1)
    ray.init(address=c.address, log_to_driver=False)
    c.wait_for_nodes()
    yield c
    ray.shutdown()
    c.shutdown()
