"""Traverses from Python: brachia.traverse(scenario) / Scenario.traverse() run what `brachia traverse`
runs and return its swings, world-frame arrays, grip switches, report, run folder and page.

A two-swing ladder (three bars 1 m apart, the paper's robot, the MPC on the model plant) is run once
per test module.
"""

import os
import subprocess

import numpy as np
import pytest

import brachia

from conftest import ROOT
from test_interrupt import interrupted_call

LADDER = """
params = "../params/paper.toml"
[ladder]
bars = [{ x = 0.0, y = 0.0 }, { x = 1.0, y = 0.0 }, { x = 2.0, y = 0.0 }]
capture_radius = 0.02
capture_speed = 0.1
[planner]
swing_time = "auto"
knot_dt = 0.03
transcription = "multiple-shooting"
[planner.bounds]
qd_end_max = 1.0
[solver]
backend = "ocp"
"""


@pytest.fixture(scope="module")
def ladder():
    return brachia.Scenario.from_toml_str(LADDER, base_dir=ROOT / "scenarios", source_name="two-swings.toml")


@pytest.fixture(scope="module")
def result(ladder):
    return ladder.traverse()


def test_a_traverse_scenario_reads_from_a_file_and_a_string(ladder):
    assert ladder.is_traverse and ladder.name == "two-swings"
    from_file = brachia.Scenario.from_toml(ROOT / "scenarios" / "ladder-even.toml")
    assert from_file.is_traverse and from_file.name == "ladder-even"
    assert not brachia.Scenario.from_toml(ROOT / "scenarios" / "tracking.toml").is_traverse
    with pytest.raises(brachia.BrachiaError, match="swing scenario"):
        brachia.Scenario.from_toml(ROOT / "scenarios" / "tracking.toml").traverse()
    with pytest.raises(brachia.BrachiaError, match=r"two-swings.toml.*ladder.capture_radius"):
        brachia.Scenario.from_toml_str(
            LADDER.replace("capture_radius = 0.02", "capture_radius = -1.0"),
            base_dir=ROOT / "scenarios",
            source_name="two-swings.toml",
        )


def test_the_traverse_catches_every_bar(result, robot):
    assert result.completed, result.status
    sw = result.swings
    assert [s["from_bar"] for s in sw] == [0, 1] and [s["to_bar"] for s in sw] == [1, 2]
    assert all(s["captured"] for s in sw)
    rep = result.report
    assert rep["completed"] is True and rep["totals"]["bars_caught"] == 2
    assert rep["totals"]["energy_j"] == pytest.approx(sum(s["energy_j"] for s in sw))
    g = result.grip_switches
    assert [x["bar"] for x in g] == [1, 2] and [x["hand"] for x in g] == [1, 0]
    assert g[0]["t_s"] == pytest.approx(sw[1]["t_start_s"])


def test_world_frame_arrays(result, robot):
    n = robot.n_links
    rows = len(result.t)
    assert result.x.shape == (rows, 2 * n) and result.tau.shape == (rows, n - 1)
    assert result.ee.shape == (rows, 2) and result.joints.shape == (rows, n + 1, 2)
    assert np.all(np.diff(result.t) >= 0.0)
    assert set(result.swing) == {0, 1}
    # hand A holds bar 0 in swing 0, hand B holds bar 1 (where it caught it) in swing 1 (joints in
    # the file's order)
    first, second = result.swing == 0, result.swing == 1
    grips = [s["grip"] for s in result.swings]
    np.testing.assert_allclose(result.joints[first, 0], np.tile(grips[0], (first.sum(), 1)), rtol=0, atol=1e-12)
    np.testing.assert_allclose(result.joints[second, -1], np.tile(grips[1], (second.sum(), 1)), rtol=0, atol=1e-12)
    assert grips[0] == [0.0, 0.0] and np.hypot(grips[1][0] - 1.0, grips[1][1]) < 0.02
    # the swinging hand ends each swing on its bar
    end0 = np.flatnonzero(first)[-1]
    assert np.hypot(*(result.ee[end0] - [1.0, 0.0])) < 0.02
    np.testing.assert_allclose(result.ee[-1], [2.0, 0.0], atol=0.02)


def test_write_is_the_cli_folder_and_view_draws_it(result, ladder, tmp_path):
    out = tmp_path / "ours"
    result.write(out)
    for name in ["traverse.csv", "report.json", "scenario.toml", "params.toml", "view.html"]:
        assert (out / name).is_file(), name
    head = (out / "traverse.csv").read_text().splitlines()[0]
    assert head.startswith("# brachia ") and head.endswith(" schema 1")
    with pytest.raises(brachia.BrachiaError):
        result.write(tmp_path / "ours" / "traverse.csv")
    html = result._repr_html_()
    assert html.startswith("<iframe") and "srcdoc" in html
    page = brachia.view(result, tmp_path / "page.html")
    assert page.read_text().startswith("<!DOCTYPE html>")


@pytest.mark.skipif(not os.environ.get("BRACHIA_BIN"), reason="BRACHIA_BIN (the built brachia binary) not set")
def test_traverse_equals_the_cli(result, tmp_path):
    (tmp_path / "sc").mkdir()
    path = tmp_path / "sc" / "two-swings.toml"
    path.write_text(LADDER.replace("../params/paper.toml", str(ROOT / "params" / "paper.toml")))
    out = tmp_path / "cli"
    subprocess.run(
        [os.environ["BRACHIA_BIN"], "traverse", "--scenario", str(path), "--out", str(out), "--no-view"],
        check=True,
        capture_output=True,
    )
    ours = tmp_path / "ours"
    brachia.traverse(path).write(ours)
    assert (ours / "traverse.csv").read_bytes() == (out / "traverse.csv").read_bytes()
    # and the run of the string scenario is the same traverse
    result.write(tmp_path / "from-string")
    assert (tmp_path / "from-string" / "traverse.csv").read_bytes() == (out / "traverse.csv").read_bytes()


def test_brachia_traverse_takes_a_scenario_or_a_path(ladder):
    with pytest.raises(brachia.BrachiaError, match="Scenario or the path"):
        brachia.traverse(3)
    with pytest.raises(brachia.BrachiaError, match="swing scenario"):
        brachia.traverse(ROOT / "scenarios" / "tracking.toml")


def test_keyboard_interrupt_stops_a_traverse():
    # the six-bar ladder takes far longer than the interrupt's delay
    sc = brachia.Scenario.from_toml(ROOT / "scenarios" / "ladder-even.toml")
    interrupted, took = interrupted_call(sc.traverse)
    assert interrupted, f"the traverse returned after {took:.3f} s, before the interrupt"
    assert took < 0.1 + 5.0
