"""Shared fixtures: the repository root, the paper robot, one plan of the tracking scenario (V-B)."""

from pathlib import Path

import pytest

import brachia

ROOT = Path(__file__).resolve().parents[2]
TRACKING = ROOT / "scenarios" / "tracking.toml"


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def robot() -> brachia.Robot:
    return brachia.Robot.paper()


@pytest.fixture(scope="session")
def scenario() -> brachia.Scenario:
    return brachia.Scenario.from_toml(TRACKING)


@pytest.fixture(scope="session")
def tracking_plan(scenario: brachia.Scenario) -> brachia.Plan:
    """The V-B swing planned once per pytest run (about 2 s)."""
    p = scenario.plan()
    assert p.converged, p.status
    return p
