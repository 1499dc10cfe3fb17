"""Error paths: bad files, fields and arrays raise BrachiaError (a ValueError) with the Rust message."""

import numpy as np
import pytest

import brachia

GOOD_ROBOT = """
name = "two"
[[links]]
length = 0.3
mass = 0.5
com = 0.15
inertia = 0.01
[[links]]
length = 0.3
mass = 0.5
com = 0.15
inertia = 0.01
[actuators]
tau_min = [-2.0]
tau_max = [2.0]
"""


def test_brachia_error_is_a_value_error():
    assert issubclass(brachia.BrachiaError, ValueError)


def test_bad_toml_field_names_file_field_value(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(GOOD_ROBOT.replace("mass = 0.5\ncom = 0.15\ninertia = 0.01\n[actuators]", "mass = -1.5\ncom = 0.15\ninertia = 0.01\n[actuators]"))
    with pytest.raises(brachia.BrachiaError) as e:
        brachia.Robot.from_toml(path)
    msg = str(e.value)
    # the Rust message unchanged: "<path>: field `links[1].mass` = -1.5: must be a finite number > 0"
    assert msg == f"{path}: field `links[1].mass` = -1.5: must be a finite number > 0"


def test_unknown_toml_field(tmp_path):
    path = tmp_path / "typo.toml"
    path.write_text(GOOD_ROBOT.replace("length = 0.3\nmass", "lenght = 0.3\nmass", 1))
    with pytest.raises(brachia.BrachiaError, match=r"typo\.toml.*lenght"):
        brachia.Robot.from_toml(path)


def test_missing_file(tmp_path):
    with pytest.raises(brachia.BrachiaError, match="nope.toml"):
        brachia.Robot.from_toml(tmp_path / "nope.toml")


def test_robot_from_string_is_valid():
    r = brachia.Robot.from_toml_str(GOOD_ROBOT)
    assert r.n_links == 2 and r.name == "two"


def test_bad_scenario_field(tmp_path, root):
    text = (root / "scenarios" / "tracking.toml").read_text()
    text = text.replace('params = "../params/paper.toml"', f'params = "{root / "params" / "paper.toml"}"')
    assert "knot_dt = 0.03" in text
    text = text.replace("knot_dt = 0.03", "knot_dt = -0.01")
    path = tmp_path / "bad-scenario.toml"
    path.write_text(text)
    with pytest.raises(brachia.BrachiaError) as e:
        brachia.Scenario.from_toml(path)
    assert str(e.value) == f"{path}: field `planner.knot_dt` = -0.01: must be a finite number > 0"


@pytest.mark.parametrize(
    "call",
    [
        lambda r: r.M([0.0, 1.0]),
        lambda r: r.M(np.zeros((2, 2))),
        lambda r: r.Cqd(np.zeros(4), np.zeros(5)),
        lambda r: r.G("abc"),
        lambda r: r.qdd(np.zeros(4), np.zeros(4), np.zeros(4)),
        lambda r: r.ee_jacobian([np.nan, 0, 0, 0]),
        lambda r: r.joint_positions([[0, 0, 0, 0]]),
        lambda r: brachia.ModelPlant(r, np.zeros(3)),
        lambda r: brachia.ModelPlant(r).step(np.zeros(2), 1e-3),
        lambda r: brachia.ModelPlant(r).step(np.zeros(3), -1.0),
        lambda r: brachia.ModelPlant(r, substeps=0),
        lambda r: brachia.RapierPlant(r, np.zeros(9)),
        lambda r: brachia.RapierPlant(r, link_friction=-1.0),
        lambda r: brachia.RapierPlant(r, obstacles=[{"kind": "circle", "center": [0.5], "radius": 0.1}]),
        lambda r: brachia.Trajectory([0.0, 0.0], np.zeros((2, 4)), np.zeros((2, 4)), np.zeros((2, 3))),
        lambda r: brachia.Trajectory([0.0, 1.0], np.zeros((2, 4)), np.zeros((3, 4)), np.zeros((2, 3))),
    ],
)
def test_wrong_arrays_raise_brachia_error(robot, call):
    with pytest.raises(brachia.BrachiaError):
        call(robot)


def test_wrong_array_message_names_argument(robot):
    with pytest.raises(brachia.BrachiaError) as e:
        robot.qdd(np.zeros(4), np.zeros(4), [1.0])
    assert str(e.value) == "tau: expected a 1-D array of 3 values (torques of joints 2..n, N m), got shape [1]"


def test_plan_bad_task_and_settings(robot):
    task = {"q0": [-2.35, 0.0, -1.55, 0.0], "target": [0.8, 0.0]}
    with pytest.raises(brachia.BrachiaError, match="unknown field `knot_dtt`"):
        brachia.plan(robot, task, knot_dtt=0.01)
    with pytest.raises(brachia.BrachiaError, match="knot_dt"):
        brachia.plan(robot, task, knot_dt=-1.0)
    with pytest.raises(brachia.BrachiaError, match="q0"):
        brachia.plan(robot, {"q0": [0.0, 1.0], "target": [0.8, 0.0]})
    with pytest.raises(brachia.BrachiaError, match="missing field `target`"):
        brachia.plan(robot, {"q0": [-2.35, 0.0, -1.55, 0.0]})
    with pytest.raises(brachia.BrachiaError, match="max_iterr"):
        brachia.plan(robot, task, solver={"max_iterr": 3})


def test_mpc_bad_input(robot, tracking_plan):
    with pytest.raises(brachia.BrachiaError, match="horizon"):
        brachia.Mpc(robot, tracking_plan, horizon=0)
    with pytest.raises(brachia.BrachiaError, match="reference"):
        brachia.Mpc(robot, "not a plan")
    mpc = brachia.Mpc(robot, tracking_plan)
    with pytest.raises(brachia.BrachiaError, match="x: expected"):
        mpc.control(0.0, np.zeros(7))
    with pytest.raises(brachia.BrachiaError, match="finite"):
        mpc.control(float("nan"), np.zeros(8))
    two = brachia.Robot.from_toml_str(GOOD_ROBOT)
    with pytest.raises(brachia.BrachiaError, match="dimension mismatch"):
        brachia.Mpc(two, tracking_plan)
    with pytest.raises(brachia.BrachiaError, match="controller"):
        brachia.track(robot, tracking_plan, controller="lqr")
    with pytest.raises(brachia.BrachiaError, match="control_dt"):
        brachia.track(robot, tracking_plan, control_dt=0.0)
