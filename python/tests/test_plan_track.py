"""Planning and tracking through the bindings, against the CLI and against each other.

The V-B swing (scenarios/tracking.toml) is planned once per pytest run (conftest.py). With BRACHIA_BIN
set to the built `brachia` binary, its `brachia plan` output must equal the Python plan's arrays.
"""

import csv
import os
import subprocess

import numpy as np
import pytest

import brachia


def read_csv(path):
    with open(path) as f:
        first = f.readline()
        assert first.startswith("# brachia ") and first.rstrip().endswith(" schema 1"), first
        rows = list(csv.reader(f))
    header, data = rows[0], np.array(rows[1:], dtype=float)
    return header, data


def test_tracking_plan(tracking_plan, robot):
    p = tracking_plan
    assert p.status == "solved"
    n = robot.n_links
    rows = len(p.t)
    assert p.q.shape == (rows, n) and p.qd.shape == (rows, n)
    assert p.tau.shape == (rows, n - 1) and p.ee.shape == (rows, 2)
    assert p.t[0] == 0.0 and p.t[-1] == pytest.approx(p.swing_time)
    np.testing.assert_allclose(p.q[0], [-2.35, 0.0, -1.55, 0.0])
    np.testing.assert_allclose(p.ee[-1], [0.8, 0.0], atol=1e-3)
    assert np.all(p.tau <= robot.tau_max + 1e-9) and np.all(p.tau >= robot.tau_min - 1e-9)
    rep = p.report
    assert rep["status"] == "solved" and rep["converged"] is True
    assert rep["iterations"] == p.iterations
    assert rep["objective"] == pytest.approx(p.objective)
    assert rep["energy_j"] == pytest.approx(p.energy)
    assert len(p.knots) == rep["collocation_points"]


@pytest.mark.skipif(not os.environ.get("BRACHIA_BIN"), reason="BRACHIA_BIN (the built brachia binary) not set")
def test_plan_equals_cli(tracking_plan, root, tmp_path):
    out = tmp_path / "plan"
    subprocess.run(
        [os.environ["BRACHIA_BIN"], "plan", "--scenario", str(root / "scenarios" / "tracking.toml"), "--out", str(out)],
        check=True,
        capture_output=True,
    )
    header, data = read_csv(out / "trajectory.csv")
    assert header[:5] == ["t", "q1", "q2", "q3", "q4"]
    p = tracking_plan
    ours = np.column_stack([p.t, p.q, p.qd, p.tau, p.ee])
    assert data.shape == ours.shape
    # the CSV keeps 6 decimals for t and 9 for the rest
    np.testing.assert_allclose(data[:, 0], ours[:, 0], rtol=0, atol=5e-7)
    np.testing.assert_allclose(data[:, 1:], ours[:, 1:], rtol=0, atol=5e-9)
    # the Python run folder is the CLI's, byte for byte except the timings in report.json
    ours_dir = tmp_path / "ours"
    p.write(ours_dir)
    for name in ["trajectory.csv", "knots.csv", "scenario.toml"]:
        assert (ours_dir / name).read_bytes() == (out / name).read_bytes(), name


def test_plan_function_equals_scenario_plan(tracking_plan, scenario, robot):
    p = brachia.plan(robot, scenario.task, scenario.plan_settings)
    assert p.status == tracking_plan.status
    np.testing.assert_array_equal(p.q, tracking_plan.q)
    np.testing.assert_array_equal(p.tau, tracking_plan.tau)
    assert p.iterations == tracking_plan.iterations


def test_free_swing_time_is_optimised_within_its_range(robot):
    task = {"q0": [-2.35, 0.0, -1.55, 0.0], "target": [0.8, 0.0]}
    # the optimum lies above 2.2 s on this swing: T ends on the range's top
    p = brachia.plan(robot, task, free_swing_time=[2.0, 2.2])
    assert p.converged, p.status
    assert abs(p.swing_time - 2.2) < 1e-6
    assert abs(p.t[-1] - p.swing_time) < 1e-9
    assert p.report["swing_time_s"] == p.swing_time
    with pytest.raises(brachia.BrachiaError, match="free_swing_time"):
        brachia.plan(robot, task, free_swing_time=[3.0, 1.0])


def test_plan_not_converged_is_a_status(robot):
    task = {"q0": [-2.35, 0.0, -1.55, 0.0], "target": [0.8, 0.0]}
    p = brachia.plan(robot, task, solver={"max_iter": 2})
    assert not p.converged
    assert p.status == "max_iterations"
    assert p.report["converged"] is False
    assert p.failure_message


def test_an_obstacle_holding_the_bar_is_refused(robot):
    # the obstacle's surface is 0.01 m below the target bar: no pose grasping the bar clears it
    task = {
        "q0": [-2.35, 0.0, -1.55, 0.0],
        "target": [0.8, 0.0],
        "obstacles": [{"center": [0.8, -0.09], "radius": 0.08}],
    }
    with pytest.raises(brachia.BrachiaError, match="no pose that grasps the bar clears it"):
        brachia.plan(robot, task, solver={"max_iter": 40})
    free = brachia.plan(robot, {"q0": [-2.35, 0.0, -1.55, 0.0], "target": [0.8, 0.0]})
    assert free.converged and free.diagnosis is None


def test_a_swing_short_of_torque_says_how_much_it_needs(root):
    text = (root / "params" / "paper.toml").read_text()
    weak = text.replace("tau_min = [-5.0, -5.0, -5.0]", "tau_min = [-0.4, -0.4, -0.4]")
    weak = weak.replace("tau_max = [5.0, 5.0, 5.0]", "tau_max = [0.4, 0.4, 0.4]")
    assert weak != text
    robot = brachia.Robot.from_toml_str(weak, "weak.toml")
    task = {"q0": [-2.35, 0.0, -1.55, 0.0], "target": [0.8, 0.0]}
    # the continuation on the limits alone: without the search in T, which would plan "auto" at
    # another swing time
    p = brachia.plan(robot, task, swing_time_search=False)
    assert not p.converged
    assert "likely torque-limited" in p.failure_message
    t = p.report["torque_continuation"]
    assert t["relaxed_converged"] is True
    assert 1.0 <= t["failed_scale"] < t["reached_scale"]
    assert max(t["peak_torque_nm"]) > 0.4
    # off: the cold plan's failure alone
    q = brachia.plan(robot, task, torque_continuation=False, swing_time_search=False)
    assert not q.converged and q.report["torque_continuation"] is None
    assert q.iterations < p.iterations


def test_track_with_mpc_reaches_the_bar(tracking_plan, robot):
    mpc = brachia.Mpc(robot, tracking_plan)
    res = brachia.track(robot, tracking_plan, controller=mpc)
    rows = len(res.t)
    assert rows == len(tracking_plan.t)
    assert res.x.shape == (rows, 8) and res.tau.shape == (rows, 3) and res.ee.shape == (rows, 2)
    np.testing.assert_array_equal(res.q, res.x[:, :4])
    s = res.summary
    assert s["ee_final_error_m"] < 0.01
    np.testing.assert_allclose(res.ee[-1], [0.8, 0.0], atol=0.01)


def test_track_equals_scenario_track(tracking_plan, scenario, robot):
    mpc = brachia.Mpc(robot, tracking_plan, scenario.mpc_settings)
    ours = brachia.track(robot, tracking_plan, controller=mpc)
    cli = scenario.track(reference=tracking_plan)
    assert cli.tracked
    np.testing.assert_array_equal(ours.x, cli.x)
    np.testing.assert_array_equal(ours.tau, cli.tau)
    assert cli.report["controller"] == "mpc" and cli.report["plant"] == "model"
    assert cli.report["ee_final_error_m"] == pytest.approx(ours.summary["ee_final_error_m"])
    # the one capture rule (as `brachia track`, the benchmark and Swing-v0): the first row whose hand
    # is within 2 cm of the bar (0.8, 0) and no faster than 0.5 m/s
    assert brachia.SUCCESS_RADIUS_M == 0.02 and brachia.CAPTURE_SPEED_M_S == 0.5
    n = robot.n_links
    dist = np.hypot(ours.ee[:, 0] - 0.8, ours.ee[:, 1] - 0.0)
    speed = np.array([np.hypot(*robot.ee_velocity(x[:n], x[n:])) for x in ours.x])
    hits = np.flatnonzero((dist <= brachia.SUCCESS_RADIUS_M) & (speed <= brachia.CAPTURE_SPEED_M_S))
    assert len(hits) > 0 and cli.report["reaches_bar"]
    k = hits[0]
    assert cli.report["capture_t_s"] == pytest.approx(ours.t[k] - ours.t[0], abs=1e-9)
    assert cli.report["bar_error_m"] == pytest.approx(dist[k], abs=1e-9)
    # the hand comes to rest at the bar: the capture falls shortly before the planned end
    assert tracking_plan.t[-1] - 0.2 < ours.t[k] <= tracking_plan.t[-1]


def test_stepwise_loop_equals_track(tracking_plan, robot):
    """Mpc.control and ModelPlant.step driven from Python equal the Rust closed loop."""
    steps, dt = 150, 1e-3
    x0 = np.concatenate([tracking_plan.q[0], tracking_plan.qd[0]])
    mpc = brachia.Mpc(robot, tracking_plan)
    plant = brachia.ModelPlant(robot, x0)
    taus = []
    for k in range(steps):
        tau = mpc.control(plant.time, plant.state())
        tau = np.clip(tau, robot.tau_min, robot.tau_max)
        taus.append(tau)
        plant.step(tau, dt)
    res = brachia.track(robot, tracking_plan, controller=brachia.Mpc(robot, tracking_plan), duration=steps * dt)
    np.testing.assert_allclose(np.array(taus), res.tau[:steps], rtol=0, atol=1e-12)
    np.testing.assert_allclose(plant.state(), res.x[-1], rtol=0, atol=1e-12)


def test_set_reference_swaps_the_plan_in_place(tracking_plan, robot):
    # without the input-rate penalty: with it the torque also depends on the last command, which a
    # swap rightly keeps (the controller's memory of what it sent, not of the reference)
    no_rate = {"rate_diag": [0.0] * (robot.n_links - 1)}
    x = np.concatenate([tracking_plan.q[0], tracking_plan.qd[0]])
    fresh = brachia.Mpc(robot, tracking_plan, no_rate).control(0.0, x)
    mpc = brachia.Mpc(robot, tracking_plan, no_rate)
    for k in range(20):
        mpc.control(k * 1e-3, tracking_plan.trajectory.state_at(k * 1e-3))
    held = brachia.Trajectory(
        tracking_plan.t, np.repeat(tracking_plan.q[:1], len(tracking_plan.t), 0),
        np.zeros_like(tracking_plan.qd), np.zeros_like(tracking_plan.tau),
    )
    mpc.set_reference(held)
    assert mpc.reference.duration == pytest.approx(tracking_plan.swing_time)
    # tracking the held pose asks for other torques than the plan at the same state
    assert np.max(np.abs(mpc.control(0.0, x) - fresh)) > 1e-3
    mpc.set_reference(tracking_plan)
    # the warm start is kept across the swap: the same QP optimum, to the QP's tolerance
    np.testing.assert_allclose(mpc.control(0.0, x), fresh, rtol=0, atol=1e-8)
    # reset() forgets it: then the controller acts exactly as a fresh one
    mpc.reset()
    np.testing.assert_allclose(mpc.control(0.0, x), fresh, rtol=0, atol=1e-12)


def test_track_on_the_rapier_plant(tracking_plan, robot):
    x0 = np.concatenate([tracking_plan.q[0], tracking_plan.qd[0]])
    plant = brachia.RapierPlant(robot, x0, substeps=2)
    res = brachia.track(robot, tracking_plan, controller="pd", plant=plant, duration=0.3)
    assert len(res.t) == 301
    assert plant.time == pytest.approx(0.3)
    np.testing.assert_allclose(plant.state(), res.x[-1], atol=1e-12)
    assert res.summary["joint_rms_error_rad"] < 0.1


def test_rust_step_times(tracking_plan, robot):
    t = brachia.rust_mpc_step_times(robot, tracking_plan, steps=5)
    assert t.shape == (5,) and np.all(t > 0)
