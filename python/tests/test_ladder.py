"""Several swings of a ladder planned as one problem through the bindings (``plan_joint_swings``).

The paper robot (params/paper.toml) hangs from bar (0, 0) in the paper's start pose and swings to
(0.8, 0) and (1.6, 0), the grip switching at (0.8, 0); 30 ms knots, every joint slower than 1 rad/s
at the last bar. World frame for bars and obstacles, each swing's plan in its grip frame. m, rad, rad/s.
"""

import numpy as np
import pytest

import brachia

X0 = [-2.35, 0.0, -1.55, 0.0, 0.0, 0.0, 0.0, 0.0]
BARS = [[0.0, 0.0], [0.8, 0.0], [1.6, 0.0]]
SETTINGS = {"knot_dt": 0.03, "bounds": {"qd_end_max": 1.0}}


@pytest.fixture(scope="module")
def joint(robot):
    return brachia.plan_joint_swings(robot, X0, BARS, settings=SETTINGS)


def test_two_swings_jointly(robot, joint):
    j = joint
    assert j.converged and j.status == "converged", j.message
    assert j.iterations is not None and j.iterations > 0
    # the joint plan starts at the swing-by-swing plans, a feasible point of its problem
    assert j.objective <= j.reference_objective + 1e-9
    assert j.objective == pytest.approx(sum(p.objective for p in j.phases), rel=1e-12)
    assert j.reference_objective == pytest.approx(sum(p.objective for p in j.reference), rel=1e-9)
    pos, vel = j.capture_residual
    assert pos < 1e-6 and vel < 1e-6 and j.max_defect < 1e-6
    assert [p.holding_hand for p in j.phases] == [0, 1]
    for i, ph in enumerate(j.phases):
        np.testing.assert_array_equal(ph.grip, BARS[i])
        p = ph.plan
        assert p.converged
        # grip frame: the hand starts at the bar left (the start pose's hand for the first swing) and
        # ends at the next bar, at rest
        target = np.subtract(BARS[i + 1], BARS[i])
        np.testing.assert_allclose(p.ee[-1], target, atol=1e-3)
        assert np.abs(p.qd[-1]).max() <= 1.0 + 1e-6
    # the second swing starts where the first ended, held by the other hand: its free hand is on bar 0
    np.testing.assert_allclose(j.phases[1].plan.ee[0], np.subtract(BARS[0], BARS[1]), atol=1e-6)
    np.testing.assert_allclose(j.phases[0].plan.q[0], X0[:4], atol=0)
    rep = j.report
    assert rep["converged"] is True and rep["swings"] == 2 and len(rep["phases"]) == 2
    assert rep["joint"]["objective"] == pytest.approx(j.objective)
    assert j.energy == pytest.approx(sum(p.plan.energy for p in j.phases))


def test_rest_at_switches(robot, joint):
    j = brachia.plan_joint_swings(robot, X0, BARS, rest_at_switches=True, settings=SETTINGS)
    assert j.converged, j.message
    assert np.abs(j.phases[0].plan.qd[-1]).max() <= 1.0 + 1e-6
    # a constraint more than the free-switch plan: no lower cost
    assert j.objective >= joint.objective - 1e-9


def test_an_obstacle_crossed_between_knots_is_not_a_success(robot):
    # at 30 ms knots the arm's swing passes this obstacle between two knots: the joint plan's
    # clearance rows hold at the knots only, so the 1 ms check must refuse the plan, naming the link,
    # the obstacle and the shortfall, instead of reporting success
    j = brachia.plan_joint_swings(
        robot,
        X0,
        BARS,
        obstacles=[{"center": [1.2, -0.9], "radius": 0.05}],
        rest_at_switches=True,
        settings=SETTINGS,
    )
    assert not j.converged
    assert "breaks the clearance" in j.message and "obstacle 0" in j.message, j.message


def test_errors(robot):
    with pytest.raises(brachia.BrachiaError, match="x0"):
        brachia.plan_joint_swings(robot, X0[:4], BARS)
    with pytest.raises(brachia.BrachiaError, match="bars"):
        brachia.plan_joint_swings(robot, X0, BARS[:1])
    with pytest.raises(brachia.BrachiaError, match="bars"):
        brachia.plan_joint_swings(robot, X0, [[0.0, 0.0, 0.0]])
    with pytest.raises(brachia.BrachiaError, match="bars"):
        brachia.plan_joint_swings(robot, X0, [[0.0, 0.0]] * 18)
    with pytest.raises(brachia.BrachiaError, match=r"bars\[1\]\[0\] = nan: must be finite"):
        brachia.plan_joint_swings(robot, X0, [[0.0, 0.0], [float("nan"), 0.0]])
    # the interval count is checked before anything is allocated (1e-9 s knots asked for 196 GB once)
    with pytest.raises(brachia.BrachiaError, match="knot_dt"):
        brachia.plan_joint_swings(robot, X0, BARS, knot_dt=1e-9)
    with pytest.raises(brachia.BrachiaError, match="backend"):
        brachia.plan_joint_swings(robot, X0, BARS, solver={"backend": "pounce"})
    with pytest.raises(brachia.BrachiaError, match="obstacles"):
        brachia.plan_joint_swings(robot, X0, BARS, obstacles=[{"centre": [1.0, 0.0], "radius": 0.1}])
    with pytest.raises(brachia.BrachiaError, match="knot_dtt"):
        brachia.plan_joint_swings(robot, X0, BARS, knot_dtt=0.03)


def test_swing_reports_name_multiple_shooting_whatever_the_settings_say(robot, joint):
    j = brachia.plan_joint_swings(
        robot, X0, BARS, settings=SETTINGS, transcription="hermite-simpson"
    )
    assert j.converged, j.message
    assert j.objective == pytest.approx(joint.objective, rel=1e-9)
    for p in [ph.plan for ph in j.phases] + j.reference:
        assert p.report["transcription"] == "multiple-shooting", p.report["transcription"]


def test_no_joint_solve_reports_none_not_nan(robot):
    # two iterations are too few for the first swing-by-swing plan: no joint solve runs
    j = brachia.plan_joint_swings(robot, X0, BARS, settings={**SETTINGS, "solver": {"max_iter": 2}})
    assert j.status == "reference_failed" and not j.converged and j.phases == []
    assert j.objective is None and j.reference_objective is None and j.energy is None
    assert j.max_defect is None and j.capture_residual is None and j.iterations is None
    assert np.isfinite(j.reference_energy)
