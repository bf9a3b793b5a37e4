"""Shared fixtures: one quick run folder, designed once per session, that the stage tests
build on (design → reduce → twin → PEA → stage identification → track)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import flexstage as fs

#: The workspace's release binary (the CLI the messages and timings are compared with).
ROOT = Path(__file__).resolve().parents[2]
CLI = ROOT / "target" / "release" / "flexstage"


def quick(max_iterations: int = 12) -> fs.Scenario:
    """The quick preset with fewer design iterations (the tests check the bindings, not the
    optimizer; the notebook designs the full preset)."""
    s = fs.Scenario.preset("quick")
    s.optimization.max_iterations = max_iterations
    return s


@pytest.fixture(scope="session")
def cli() -> Path:
    if not CLI.exists():
        pytest.skip(f"{CLI} not built (cargo build --release -p flexstage)")
    return CLI


@pytest.fixture(scope="session")
def run(tmp_path_factory: pytest.TempPathFactory):
    folder = tmp_path_factory.mktemp("run") / "quick"
    r = fs.Run(quick(), folder)
    r.design(progress=False)
    yield r
    r.close()
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="session")
def tracked(run):
    """One tracking case (circle, PI + notch + feedforward), its Monte-Carlo study on two
    perturbed twins (100 by default, seconds apiece: the tests check the bindings)."""
    return run.track(trajectory="circle", controllers=["pi-notch-ff"], montecarlo_plants=2,
                     progress=False)
