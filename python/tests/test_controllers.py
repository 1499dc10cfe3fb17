"""Every controller of a scenario's [tracking] section from Python, and the [disturbances] stack in
track(): built on a scenario's settings, they give the closed loop Scenario.track (the run of
`brachia track`) gives, bit for bit; their settings are checked as strictly as the scenario file's.
"""

import numpy as np
import pytest

import brachia

from conftest import ROOT

SWING = """
params = "../params/paper.toml"
[task]
q0 = [-2.35, 0.0, -1.55, 0.0]
qd0 = [0.0, 0.0, 0.0, 0.0]
target = [0.8, 0.0]
[planner]
swing_time = "auto"
knot_dt = 0.03
transcription = "multiple-shooting"
[solver]
backend = "ocp"
"""

DISTURBED = """
[disturbances]
mass_scale = [1.05, 1.0, 0.95, 1.1]
motor_time_constant_s = 0.004
actuation_delay_s = 0.002
noise_q_std = 0.0005
noise_qd_std = 0.005
seed = 3
pushes = [{ t_s = 0.6, link = 4, point_m = 0.3, impulse_n_s = [0.0, 0.1] }]
"""


def scenario_of(text, name):
    return brachia.Scenario.from_toml_str(SWING + text, base_dir=ROOT / "scenarios", source_name=name)


def python_run(sc, plan, controller):
    """brachia.track with the scenario's robot, run settings and disturbances."""
    tr = sc.tracking
    return brachia.track(
        sc.robot,
        plan,
        controller=controller,
        disturbances=sc.disturbances,
        duration=plan.t[-1] + tr["hold_s"],
        control_dt=tr["control_dt"],
    )


def assert_same_run(py, cli):
    assert cli.tracked and py.x.shape == cli.x.shape
    np.testing.assert_array_equal(py.t, cli.t)
    np.testing.assert_array_equal(py.x, cli.x)
    np.testing.assert_array_equal(py.tau, cli.tau)


def test_tvlqr_behind_the_kalman_filter_with_disturbances_is_the_scenarios_run(tracking_plan):
    sc = scenario_of(
        '[tracking]\ncontroller = "tvlqr"\nkalman = true\nhold_s = 0.05\n'
        "[tracking.estimator]\nmeas_q_std = 0.001\n" + DISTURBED,
        "tvlqr-kalman.toml",
    )
    cli = sc.track(reference=tracking_plan)
    tr, robot = sc.tracking, sc.robot
    ctrl = brachia.Kalman(brachia.Tvlqr(robot, tracking_plan, tr["tvlqr"]), tr["estimator"])
    py = python_run(sc, tracking_plan, ctrl)
    assert_same_run(py, cli)
    # the disturbances did act: the undisturbed run differs
    calm = brachia.track(robot, tracking_plan, controller=ctrl, duration=tracking_plan.t[-1] + 0.05)
    assert np.abs(calm.x - cli.x).max() > 1e-3
    assert py.report["disturbances"]["seed"] == 3


@pytest.mark.parametrize("kind", ["pd", "open-loop", "mpc"])
def test_the_baselines_and_the_mpc_are_the_scenarios_runs(tracking_plan, kind):
    sc = scenario_of(f'[tracking]\ncontroller = "{kind}"\n' + DISTURBED, f"{kind}.toml")
    cli = sc.track(reference=tracking_plan)
    tr, robot = sc.tracking, sc.robot
    ctrl = {
        "pd": lambda: brachia.Pd(robot, tracking_plan, tr["pd"]),
        "open-loop": lambda: brachia.OpenLoop(robot, tracking_plan),
        "mpc": lambda: brachia.Mpc(robot, tracking_plan, tr["mpc"]),
    }[kind]()
    assert_same_run(python_run(sc, tracking_plan, ctrl), cli)


def test_adaptive_replanning_mpc_is_the_scenarios_run(tracking_plan):
    # a fixed latency: without it a re-plan is adopted after its measured wall time
    sc = scenario_of(
        '[tracking]\ncontroller = "mpc"\nreplan = { threshold_m = 0.005, max_replans = 2, latency_s = 0.02 }\n'
        "estimate_params = {}\n[disturbances]\nmass_scale = [1.3, 1.3, 1.3, 1.3]\n",
        "adaptive-replan.toml",
    )
    cli = sc.track(reference=tracking_plan)
    tr, robot = sc.tracking, sc.robot
    mpc = brachia.Mpc(robot, tracking_plan, tr["mpc"])
    re = brachia.Replanning(mpc, sc.task, sc.plan_settings, tr["replan"])
    ctrl = brachia.Adaptive(re, tr["estimate_params"])
    py = python_run(sc, tracking_plan, ctrl)
    assert_same_run(py, cli)
    assert py.report["replanning"] is True
    assert py.report["replan_count"] == cli.report["replan_count"]
    assert [e["t_trigger_s"] for e in py.report["replans"]] == [e["t_trigger_s"] for e in cli.report["replans"]]
    assert py.report["estimate"]["theta"] == cli.report["estimate"]["theta"]
    # a recipe builds afresh: the same run again
    np.testing.assert_array_equal(python_run(sc, tracking_plan, ctrl).x, py.x)


def test_a_controllers_name_and_its_object_with_default_settings_agree(robot, tracking_plan):
    for name, obj in [("tvlqr", brachia.Tvlqr(robot, tracking_plan)), ("pd", brachia.Pd(robot, tracking_plan))]:
        a = brachia.track(robot, tracking_plan, controller=name, duration=0.3)
        b = brachia.track(robot, tracking_plan, controller=obj, duration=0.3)
        np.testing.assert_array_equal(a.x, b.x)


def test_unknown_settings_are_refused_naming_the_key(robot, tracking_plan):
    cases = [
        lambda: brachia.Tvlqr(robot, tracking_plan, {"q_diagonal": [1.0] * 8}),
        lambda: brachia.Pd(robot, tracking_plan, q_diagonal=1.0),
        lambda: brachia.Kalman(brachia.Pd(robot, tracking_plan), {"q_diagonal": 1.0}),
        lambda: brachia.Replanning(
            brachia.Mpc(robot, tracking_plan), {"q0": [-2.35, 0, -1.55, 0], "target": [0.8, 0]}, q_diagonal=1
        ),
        lambda: brachia.Adaptive(brachia.Mpc(robot, tracking_plan), q_diagonal=1),
        lambda: brachia.track(robot, tracking_plan, disturbances={"q_diagonal": 1.0}, duration=0.01),
    ]
    for make in cases:
        with pytest.raises(brachia.BrachiaError, match="q_diagonal"):
            make()


def test_bad_settings_and_compositions_are_refused(robot, tracking_plan):
    with pytest.raises(brachia.BrachiaError):
        brachia.Tvlqr(robot, tracking_plan, q_diag=[1.0, 2.0])  # 2n = 8 values needed
    with pytest.raises(brachia.BrachiaError, match="open-loop"):
        brachia.Kalman(brachia.OpenLoop(robot, tracking_plan))
    with pytest.raises(brachia.BrachiaError, match="MPC only"):
        brachia.Replanning(brachia.Pd(robot, tracking_plan), {"q0": [-2.35, 0, -1.55, 0], "target": [0.8, 0]})
    with pytest.raises(brachia.BrachiaError, match="MPC only"):
        brachia.Adaptive(brachia.Kalman(brachia.Mpc(robot, tracking_plan)))
    with pytest.raises(brachia.BrachiaError, match="knot_dt_s"):
        brachia.Replanning(
            brachia.Mpc(robot, tracking_plan), {"q0": [-2.35, 0, -1.55, 0], "target": [0.8, 0]}, knot_dt_s=-1.0
        )
    with pytest.raises(brachia.BrachiaError, match="controller object"):
        brachia.Kalman("mpc")
    other = brachia.plan(robot, {"q0": [-2.35, 0.0, -1.55, 0.0], "target": [0.7, 0.0]})
    with pytest.raises(brachia.BrachiaError, match="another reference"):
        brachia.track(robot, other, controller=brachia.Pd(robot, tracking_plan), duration=0.01)


def test_disturbances_in_track(robot, tracking_plan):
    # the model mismatch and the start offset make the model plant; a given plant refuses them
    plant = brachia.ModelPlant(robot, np.concatenate([tracking_plan.q[0], tracking_plan.qd[0]]))
    with pytest.raises(brachia.BrachiaError, match="disturbances.mass_scale"):
        brachia.track(robot, tracking_plan, plant=plant, disturbances={"mass_scale": [1.1] * 4}, duration=0.01)
    off = [0.01, 0, 0, 0, 0, 0, 0, 0]
    res = brachia.track(robot, tracking_plan, controller="pd", disturbances={"start_offset": off}, duration=0.01)
    np.testing.assert_allclose(res.x[0], np.concatenate([tracking_plan.q[0], tracking_plan.qd[0]]) + off)
    # the wrappers act on a given plant too: a motor lag changes the run
    x0 = np.concatenate([tracking_plan.q[0], tracking_plan.qd[0]])
    a = brachia.track(robot, tracking_plan, controller="pd", plant=brachia.ModelPlant(robot, x0), duration=0.2)
    b = brachia.track(
        robot,
        tracking_plan,
        controller="pd",
        plant=brachia.ModelPlant(robot, x0),
        duration=0.2,
        disturbances={"motor_time_constant_s": 0.02},
    )
    assert np.abs(a.x[-1] - b.x[-1]).max() > 1e-6
    with pytest.raises(brachia.BrachiaError, match="twice"):
        brachia.track(robot, tracking_plan, noise_q_std=0.01, disturbances={"noise_q_std": 0.01}, duration=0.01)
    with pytest.raises(brachia.BrachiaError, match="pushes"):
        brachia.track(robot, tracking_plan, disturbances={"pushes": [{"t_s": 0.1, "link": 9, "point_m": 0.1,
                                                                      "impulse_n_s": [0, 1]}]}, duration=0.01)


def test_a_ball_on_the_rapier_plant_is_the_scenarios_run(tracking_plan):
    # balls are the rapier plant's obstacles ([plant] obstacles): the plant made with them, the
    # disturbances' wrappers around it
    sc = scenario_of(
        '[tracking]\ncontroller = "mpc"\n[plant]\nkind = "rapier"\nobstacles = [{ kind = "ball", '
        "center = [0.02, -0.44], radius = 0.05, mass = 0.4, restitution = 0.3, gravity = false }]\n"
        "[disturbances]\nmotor_time_constant_s = 0.004\n",
        "ball.toml",
    )
    cli = sc.track(reference=tracking_plan)
    pl, tr, robot = sc.plant, sc.tracking, sc.robot
    x0 = np.concatenate([tracking_plan.q[0], tracking_plan.qd[0]])
    settings = {k: pl[k] for k in ["substeps", "link_friction", "link_restitution"]}
    plant = brachia.RapierPlant(robot, x0, settings, obstacles=pl["obstacles"])
    py = brachia.track(
        robot,
        tracking_plan,
        controller=brachia.Mpc(robot, tracking_plan, tr["mpc"]),
        plant=plant,
        disturbances=sc.disturbances,
        duration=tracking_plan.t[-1],
    )
    assert_same_run(py, cli)
    assert cli.report["contact_events"] > 0 and len(plant.contacts()) == cli.report["contact_events"]


def test_keyboard_interrupt_stops_a_run_of_a_wrapped_controller(tracking_plan):
    from test_interrupt import DELAY_S, interrupted_call

    sc = scenario_of("", "interrupt.toml")
    robot = sc.robot
    ctrl = brachia.Replanning(brachia.Mpc(robot, tracking_plan), sc.task, sc.plan_settings, threshold_m=0.001)
    # 300 s of closed loop (the swing held at its end) after the re-planner's cold plan
    interrupted, took = interrupted_call(
        lambda: brachia.track(robot, tracking_plan, controller=ctrl, duration=300.0)
    )
    assert interrupted, f"the run returned after {took:.3f} s, before the interrupt"
    assert took < DELAY_S + 5.0
