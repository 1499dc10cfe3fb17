"""Hostile inputs to every entry point: arrays in another byte order, dtype or layout; finite but huge
values; setters and trajectories that the constructors would refuse; objects used from several
threads. Each is converted (the same answer as the plain float64 input) or refused with a
``BrachiaError`` that names the argument, the value and the rule; nothing returns NaN, and nothing
raises a ``PanicException`` or "Already borrowed".

The robot is the paper's (params/paper.toml); the swing is the tracking task on 30 ms multiple-shooting
knots (as test_replan.py). Units: s, m, rad, rad/s, N m.
"""

import re
import threading
import time

import numpy as np
import pytest

import brachia

TASK = {"q0": [-2.35, 0.0, -1.55, 0.0], "target": [0.8, 0.0]}
SETTINGS = {"knot_dt": 0.03, "shooting": {"substeps": 1}}
Q = np.array([-2.35, 0.1, -1.55, 0.2])
QD = np.array([0.3, -0.2, 0.5, -0.1])
TAU = np.array([1.0, -2.0, 0.5])


@pytest.fixture(scope="module")
def planned(robot):
    """A planner with its cold plan (about 0.1 s) and a checkpoint of it."""
    sp = brachia.SwingPlanner(robot, TASK, SETTINGS)
    p = sp.plan()
    assert p.converged, p.status
    return sp, p, sp.checkpoint()


def kicked_state(sp, k):
    """The planned state at knot k with the joint velocities kicked by 0.1 rad/s."""
    x = sp.knot_states()[k].copy()
    x[x.size // 2:] += 0.1
    return x


# ---------------------------------------------------------------------------------------------
# 1. Arrays: byte order, dtype, layout, shape


def big(a):
    return np.asarray(a, dtype=float).astype(">f8")


@pytest.mark.parametrize(
    "call",
    [
        lambda r, f: r.M(f(Q)),
        lambda r, f: r.Cqd(f(Q), f(QD)),
        lambda r, f: r.G(f(Q)),
        lambda r, f: r.qdd(f(Q), f(QD), f(TAU)),
        lambda r, f: r.inverse_dynamics(f(Q), f(QD), f(QD)),
        lambda r, f: r.joint_positions(f(Q)),
        lambda r, f: r.ee_velocity(f(Q), f(QD)),
        lambda r, f: r.ee_jacobian(f(Q)),
        lambda r, f: np.array(r.energy(f(Q), f(QD))),
    ],
)
@pytest.mark.parametrize(
    "layout",
    [
        big,
        lambda a: np.repeat(big(a), 2)[::2],  # strided, big-endian
        lambda a: np.asfortranarray(np.stack([a, a], axis=1))[:, 0],  # a column of a Fortran array
        lambda a: list(a),
        lambda a: tuple(float(v) for v in a),
    ],
)
def test_robot_reads_any_layout_and_byte_order_as_the_same_values(robot, call, layout):
    expected = call(robot, lambda a: np.asarray(a, dtype=float))
    np.testing.assert_array_equal(call(robot, layout), expected)


def test_float32_arrays_of_either_byte_order_convert(robot):
    q32 = Q.astype(np.float32)
    expected = robot.M(q32.astype(float))
    for a in (q32, q32.astype(">f4"), np.asfortranarray(q32.astype(">f4"))):
        np.testing.assert_array_equal(robot.M(a), expected)


def test_integer_arrays_convert(robot):
    q = np.array([-2, 0, -1, 0])
    for dtype in (np.int8, np.int64, ">i4", np.uint8):
        a = q.astype(dtype) if np.dtype(dtype).kind == "i" else np.zeros(4, dtype=dtype)
        np.testing.assert_array_equal(robot.G(a), robot.G(a.astype(float)))


@pytest.mark.parametrize(
    "value, dtype_words",
    [
        (Q.astype(complex) + 1j, "complex"),
        (np.array([True, False, True, False]), "bool"),
        (np.array([1.0, 2.0, 3.0, None], dtype=object), "object"),
        (np.array([1, 2, 3, 4], dtype=object), "object"),
        (np.array(["1", "2", "3", "4"]), "text"),
        (np.arange(4).astype("datetime64[D]"), "dates"),
        ([[1.0, 2.0], [3.0]], "ragged|numbers"),
    ],
)
def test_non_real_dtypes_are_refused_naming_the_argument(robot, value, dtype_words):
    with pytest.raises(brachia.BrachiaError, match=rf"^q: .*({dtype_words})"):
        robot.M(value)


def test_complex_part_is_never_dropped_silently(robot, tracking_plan):
    x = np.concatenate([tracking_plan.q[0], tracking_plan.qd[0]]).astype(complex)
    with pytest.raises(brachia.BrachiaError, match="^x: dtype complex128"):
        brachia.Mpc(robot, tracking_plan).control(0.0, x)
    with pytest.raises(brachia.BrachiaError, match="^x0: dtype complex128"):
        brachia.ModelPlant(robot, x)
    with pytest.raises(brachia.BrachiaError, match="^tau: dtype complex128"):
        brachia.ModelPlant(robot).step(TAU.astype(complex), 1e-3)


def test_mpc_reads_a_big_endian_state_as_the_native_one(robot, tracking_plan):
    x = tracking_plan.trajectory.state_at(0.5) + 0.01
    native = brachia.Mpc(robot, tracking_plan).control(0.5, x)
    swapped = brachia.Mpc(robot, tracking_plan).control(0.5, big(x))
    np.testing.assert_array_equal(swapped, native)


def test_replan_reads_a_big_endian_state_as_the_native_one(planned):
    sp, _, cp = planned
    k = sp.intervals // 3
    t_now = float(sp.knot_times()[k])
    x = kicked_state(sp, k)
    sp.restore(cp)
    native = sp.replan(t_now, x)
    native_states = sp.knot_states()
    sp.restore(cp)
    swapped = sp.replan(t_now, big(x))
    assert swapped.objective == native.objective
    np.testing.assert_array_equal(sp.knot_states(), native_states)
    np.testing.assert_array_equal(sp.knot_states()[0], x)
    sp.restore(cp)


def test_trajectory_reads_big_endian_and_fortran_arrays(tracking_plan):
    p = tracking_plan
    native = brachia.Trajectory(p.t, p.q, p.qd, p.tau)
    swapped = brachia.Trajectory(big(p.t), big(p.q), np.asfortranarray(big(p.qd)), big(p.tau)[:, :])
    for name in ("t", "q", "qd", "tau"):
        np.testing.assert_array_equal(getattr(swapped, name), getattr(native, name))
    np.testing.assert_array_equal(swapped.state_at(0.7), native.state_at(0.7))


def test_ladder_and_planner_arrays_read_big_endian(robot):
    sp = brachia.SwingPlanner(robot, {"q0": big(TASK["q0"]), "target": big(TASK["target"])}, SETTINGS)
    np.testing.assert_array_equal(sp.target, TASK["target"])
    sp.set_target(big([0.75, 0.05]))
    np.testing.assert_array_equal(sp.target, [0.75, 0.05])
    with pytest.raises(brachia.BrachiaError, match=r"^bars: expected an array of shape \(samples, 2\)"):
        brachia.plan_joint_swings(robot, np.zeros(8), big(np.zeros((3, 3))))
    with pytest.raises(brachia.BrachiaError, match=r"^x0: dtype complex128"):
        brachia.plan_joint_swings(robot, np.zeros(8, dtype=complex), np.zeros((3, 2)))


def test_wrong_shapes_name_argument_and_shape(robot):
    with pytest.raises(brachia.BrachiaError, match=r"^q: expected a 1-D array of 4 values .*got shape \[1, 4\]"):
        robot.M(big([Q]))
    with pytest.raises(brachia.BrachiaError, match=r"^q: expected a 1-D array of 4 values .*got shape \[\]"):
        robot.M(np.float64(1.0))
    with pytest.raises(brachia.BrachiaError, match=r"^tau: expected a 1-D array of 3 values"):
        brachia.ModelPlant(robot).step(np.zeros(0), 1e-3)


# ---------------------------------------------------------------------------------------------
# 2. Finite but huge inputs: refused, and never a NaN returned


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda r: r.M([1e308] * 4), r"^q\[0\] = 1e308: must be at most 12.56\d* rad in magnitude"),
        (lambda r: r.qdd(Q, [1e200] * 4, TAU), r"^qd\[0\] = 1e200: must be at most 1000 rad/s"),
        (lambda r: r.energy(Q, [0, 0, 0, 1e200]), r"^qd\[3\] = 1e200: must be at most 1000 rad/s"),
        (lambda r: r.qdd(Q, QD, [0, 1e300, 0]), r"^tau\[1\] = 1e300: must be at most 1000000 N m"),
        (lambda r: r.inverse_dynamics(Q, QD, [1e300, 0, 0, 0]), r"^qdd\[0\] = 1e300: must be at most"),
        (lambda r: r.ee_position([0, 0, 13.0, 0]), r"^q\[2\] = 13: must be at most 12.56"),
        (lambda r: r.Cqd(Q, [0, 0, -1001, 0]), r"^qd\[2\] = -1001: must be at most 1000 rad/s"),
        (lambda r: r.G([np.inf, 0, 0, 0]), r"^q\[0\] = inf: must be finite"),
        (lambda r: r.G(np.float64(1.0)), r"^q: expected a 1-D array of 4 values .*got shape \[\]"),
        (lambda r: brachia.ModelPlant(r).reset([1e300] * 8), r"^x\[0\] = 1e300: must be at most"),
        (lambda r: brachia.ModelPlant(r, [0] * 4 + [2e3] * 4), r"^x0\[4\] = 2000: must be at most 1000 rad/s"),
        (lambda r: brachia.RapierPlant(r).reset([0] * 7 + [1e300]), r"^x\[7\] = 1e300: must be at most"),
        (lambda r: brachia.ModelPlant(r).step([1e300, 0, 0], 1e-3), r"^tau\[0\] = 1e300: must be at most"),
        (lambda r: brachia.ModelPlant(r).step([0, 0, 0], 1e300), r"^dt = 1e300: must be in \(0, 1\] s"),
        (lambda r: brachia.plan_joint_swings(r, np.zeros(8), [[0, 0], [1e300, 0]]),
         r"^bars\[1\]\[0\] = 1e300: must be at most 1000 m"),
    ],
)
def test_huge_inputs_are_refused(robot, call, message):
    with pytest.raises(brachia.BrachiaError, match=message):
        call(robot)


def test_mpc_refuses_a_huge_state(robot, tracking_plan):
    mpc = brachia.Mpc(robot, tracking_plan)
    x = tracking_plan.trajectory.state_at(0.0)
    x[5] = 1e200
    with pytest.raises(brachia.BrachiaError, match=r"^x\[5\] = 1e200: must be at most 1000 rad/s"):
        mpc.control(0.0, x)
    with pytest.raises(brachia.BrachiaError, match=r"^t = nan: must be finite"):
        mpc.control(float("nan"), tracking_plan.trajectory.state_at(0.0))
    # the controller is usable after the refusals
    assert np.all(np.isfinite(mpc.control(0.0, tracking_plan.trajectory.state_at(0.0))))


def test_replan_refuses_a_huge_state_and_keeps_its_solution(planned):
    sp, _, cp = planned
    sp.restore(cp)
    before = sp.knot_states().copy()
    x = kicked_state(sp, 10)
    x[6] = 1e200
    with pytest.raises(brachia.BrachiaError, match=r"^x_now\[6\] = 1e200: must be at most 1000 rad/s"):
        sp.replan(float(sp.knot_times()[10]), x)
    np.testing.assert_array_equal(sp.knot_states(), before)


def test_a_diverging_plant_step_raises_and_the_plant_needs_a_reset(robot):
    # inside every input rule, but a 1 s RK4 step at 1000 rad/s leaves any sane state
    plant = brachia.ModelPlant(robot, [0, 0, 0, 0, 1000, -1000, 1000, -1000])
    with pytest.raises(brachia.BrachiaError, match=r"^ModelPlant.step: the simulation diverged at t = 1 s"):
        plant.step([0, 0, 0], 1.0)
    for use in (lambda: plant.state(), lambda: plant.energy(), lambda: plant.step([0, 0, 0], 1e-3)):
        with pytest.raises(brachia.BrachiaError, match="diverged.*reset"):
            use()
    plant.reset(np.zeros(8))
    assert plant.time == 0.0
    assert np.all(np.isfinite(plant.state())) and np.isfinite(plant.energy())


def test_a_diverging_closed_loop_reports_where_it_stopped(robot, tracking_plan):
    plant = brachia.ModelPlant(robot, [0, 0, 0, 0, 1000, -1000, 1000, -1000])
    res = brachia.track(robot, tracking_plan, controller="open-loop", plant=plant, control_dt=0.1, duration=2.0)
    assert res.diverged_at_s is not None and 0 < res.diverged_at_s <= 2.0
    assert res.summary["diverged_at_s"] == res.diverged_at_s
    assert np.all(np.isfinite(res.x)) and np.all(np.isfinite(res.ee))
    with pytest.raises(brachia.BrachiaError, match="diverged"):
        plant.state()
    with pytest.raises(brachia.BrachiaError, match=r"^ModelPlant.track: the simulation diverged"):
        brachia.track(robot, tracking_plan, plant=plant)
    ok = brachia.track(robot, tracking_plan, controller="open-loop", duration=0.1)
    assert ok.diverged_at_s is None


# ---------------------------------------------------------------------------------------------
# 3. Setters as strict as the constructors; trajectories validated


def test_set_target_is_checked_as_the_constructor_checks_the_target(robot, planned):
    sp, _, cp = planned
    with pytest.raises(brachia.BrachiaError, match=r"target.*\[100.0, 0.0\]"):
        brachia.SwingPlanner(robot, {**TASK, "target": [100.0, 0.0]}, SETTINGS)
    before = sp.target.copy()
    with pytest.raises(brachia.BrachiaError, match=r"^set_target: field `target` = \[100.0, 0.0\]: is 100.000 m from the grip"):
        sp.set_target([100, 0])
    with pytest.raises(brachia.BrachiaError, match=r"^target\[1\] = 1e300: must be at most 1000 m"):
        sp.set_target([0.5, 1e300])
    with pytest.raises(brachia.BrachiaError, match=r"^target\[0\] = nan: must be finite"):
        sp.set_target([np.nan, 0.0])
    np.testing.assert_array_equal(sp.target, before)
    sp.restore(cp)
    assert sp.replan(float(sp.knot_times()[5]), kicked_state(sp, 5)).converged


def test_set_target_inside_an_obstacle_is_refused(robot):
    task = {**TASK, "obstacles": [{"center": [0.5, -0.6], "radius": 0.1}]}
    sp = brachia.SwingPlanner(robot, task, SETTINGS)
    with pytest.raises(brachia.BrachiaError, match=r"^set_target: field `target` = \[0.5, -0.6\]: lies inside obstacles\[0\]"):
        sp.set_target([0.5, -0.6])
    np.testing.assert_array_equal(sp.target, TASK["target"])


@pytest.mark.parametrize(
    "t, message",
    [
        ([0.0, 1e-300], r"^t\[1\] = 1e-300: times must increase by at least 1e-6 s"),
        ([0.0, 0.5e-6], r"^t\[1\] = 5e-7: times must increase by at least 1e-6 s"),
        ([-1.0, 0.0], r"^t\[0\] = -1: must lie in \[0, 600\] s"),
        ([0.0, 1e300], r"^t\[1\] = 1e300: must lie in \[0, 600\] s"),
        ([0.0], r"^t: expected a 1-D array of 2 to 200000 values"),
        ([0.0, np.nan], r"^t\[1\] = nan: must be finite"),
    ],
)
def test_trajectory_times_are_validated(t, message):
    n = len(t)
    with pytest.raises(brachia.BrachiaError, match=message):
        brachia.Trajectory(t, np.zeros((n, 4)), np.zeros((n, 4)), np.zeros((n, 3)))


def test_trajectory_values_are_validated():
    t = [0.0, 0.5, 1.0]
    z = np.zeros((3, 4))
    with pytest.raises(brachia.BrachiaError, match=r"^q\[2\]\[1\] = 1e300: must be at most 12.56"):
        brachia.Trajectory(t, np.array([[0, 0, 0, 0], [0, 0, 0, 0], [0, 1e300, 0, 0]]), z, z[:, :3])
    with pytest.raises(brachia.BrachiaError, match=r"^qd\[0\]\[3\] = 5000: must be at most 1000 rad/s"):
        brachia.Trajectory(t, z, np.array([[0, 0, 0, 5e3], [0] * 4, [0] * 4]), z[:, :3])
    with pytest.raises(brachia.BrachiaError, match=r"^tau\[1\]\[0\] = -1e\+?20: must be at most 1000000 N m"):
        brachia.Trajectory(t, z, z, np.array([[0, 0, 0], [-1e20, 0, 0], [0, 0, 0]]))
    with pytest.raises(brachia.BrachiaError, match=r"^q: dtype complex128"):
        brachia.Trajectory(t, z.astype(complex), z, z[:, :3])


def test_a_run_shorter_than_a_control_period_is_refused(robot, tracking_plan):
    p = tracking_plan
    short = brachia.Trajectory([0.0, 1e-4], p.q[:2], p.qd[:2], p.tau[:2])
    with pytest.raises(brachia.BrachiaError, match=r"^duration = 0.0001 s: shorter than half a control period"):
        brachia.track(robot, short)
    with pytest.raises(brachia.BrachiaError, match=r"^duration = 1e-300: must lie in \[0, 600\] s|shorter than half"):
        brachia.track(robot, p, duration=1e-300)
    with pytest.raises(brachia.BrachiaError, match=r"^control_dt = 0.5: must lie in \[0.000001, 0.1\] s|^control_dt = 0.5: must lie"):
        brachia.track(robot, p, control_dt=0.5)
    with pytest.raises(brachia.BrachiaError, match=r"^duration = 1e300: must lie in \[0, 600\] s"):
        brachia.track(robot, p, duration=1e300)
    # a short run that is a run: one control step
    res = brachia.track(robot, short, duration=1e-3, controller="open-loop")
    assert len(res.t) == 2 and res.summary["ee_final_error_m"] >= 0


# ---------------------------------------------------------------------------------------------
# 4. Threads: every object usable from any thread, one call at a time


def run_threads(target, count):
    """Run `target(i)` in `count` threads; the exceptions they raised."""
    errors = []

    def wrap(i):
        try:
            target(i)
        except BaseException as e:  # noqa: BLE001 - a PanicException is a BaseException
            errors.append(e)

    threads = [threading.Thread(target=wrap, args=(i,)) for i in range(count)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return errors


@pytest.mark.parametrize("cls", [brachia.RapierPlant, brachia.ModelPlant])
def test_a_plant_made_in_one_thread_steps_in_others(robot, cls):
    x0 = np.array([-2.0, 0.3, -1.0, 0.2, 0.0, 0.0, 0.0, 0.0])
    serial = cls(robot, x0)
    for _ in range(40):
        serial.step(TAU, 1e-3)
    shared = cls(robot, x0)
    errors = run_threads(lambda i: [shared.step(TAU, 1e-3) for _ in range(10)], 4)
    assert errors == []
    assert shared.time == pytest.approx(0.04)
    # the same 40 steps of the same torque, whichever thread made each
    np.testing.assert_allclose(shared.state(), serial.state(), rtol=0, atol=1e-12)


def test_concurrent_replans_run_one_after_the_other(planned):
    sp, _, cp = planned
    k = sp.intervals // 3
    t_now = float(sp.knot_times()[k])
    x = kicked_state(sp, k)
    sp.restore(cp)
    serial = sp.replan(t_now, x)
    sp.restore(cp)
    outcomes = []
    errors = run_threads(lambda i: outcomes.append(sp.replan(t_now, x)), 4)
    assert errors == []
    assert len(outcomes) == 4 and all(o.converged for o in outcomes)
    # warm re-plans of one state from different warm starts reach the same optimum
    for o in outcomes:
        assert o.objective == pytest.approx(serial.objective, rel=1e-6)
    sp.restore(cp)


def test_planner_reads_while_another_thread_plans(robot):
    sp = brachia.SwingPlanner(robot, TASK, SETTINGS)
    seen = []

    def work(i):
        if i == 0:
            sp.plan()
        else:
            for _ in range(20):
                seen.append((sp.has_plan, sp.intervals, sp.target.tolist()))

    errors = run_threads(work, 3)
    assert errors == []
    assert sp.has_plan and len(seen) == 40
    assert all(s[1] == sp.intervals and s[2] == TASK["target"] for s in seen)


def test_one_mpc_from_several_threads(robot, tracking_plan):
    mpc = brachia.Mpc(robot, tracking_plan)
    ref = tracking_plan.trajectory
    results = []
    errors = run_threads(
        lambda i: results.extend(mpc.control(k * 1e-3, ref.state_at(k * 1e-3)) for k in range(20)), 3
    )
    assert errors == [] and len(results) == 60
    assert all(np.all(u <= robot.tau_max + 1e-9) and np.all(u >= robot.tau_min - 1e-9) for u in results)


def test_track_releases_the_gil(robot, tracking_plan):
    # the other thread wakes every millisecond and needs the GIL to count: while a call holds the
    # GIL it cannot count at all (it has no bytecode running that the interpreter could preempt)
    ticks = [0]
    stop = threading.Event()

    def tick():
        while not stop.is_set():
            time.sleep(0.001)
            ticks[0] += 1

    t = threading.Thread(target=tick)
    t.start()
    try:
        time.sleep(0.05)
        before = ticks[0]
        start = time.perf_counter()
        brachia.track(robot, tracking_plan, controller="mpc", duration=2.0)
        elapsed = time.perf_counter() - start
        during = ticks[0] - before
    finally:
        stop.set()
        t.join()
    assert elapsed > 0.05  # a run long enough to tell (about 0.25 s)
    assert during >= 10, (during, elapsed)


def test_a_plant_in_a_running_track_waits_for_it(robot, tracking_plan):
    x0 = np.concatenate([tracking_plan.q[0], tracking_plan.qd[0]])
    plant = brachia.ModelPlant(robot, x0)
    mpc = brachia.Mpc(robot, tracking_plan)
    times = []

    def work(i):
        if i == 0:
            brachia.track(robot, tracking_plan, controller=mpc, plant=plant, duration=0.5)
        else:
            time.sleep(0.01)
            times.append(plant.time)  # waits for the run, never sees it half-way
            mpc.control(0.0, x0)

    errors = run_threads(work, 2)
    assert errors == []
    assert times[0] in (0.0, pytest.approx(0.5))


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda r: brachia.plan(r, {"q0": [-2.35, 0, -1.55, 0], "target": [0.8, 1e300]}),
         r"^task.target\[1\] = 1e300: must be at most 1000 m"),
        (lambda r: brachia.SwingPlanner(r, {"q0": [-2.35, 0, -1e300, 0], "target": [0.8, 0]}),
         r"^task.q0\[2\] = -1e300: must be at most 12.56"),
        (lambda r: brachia.SwingPlanner(r, {**TASK, "qd0": [0, 0, 0, 1e200]}),
         r"^task.qd0\[3\] = 1e200: must be at most 1000 rad/s"),
        (lambda r: brachia.SwingPlanner(r, {**TASK, "obstacles": [{"center": [1e300, 0], "radius": 0.1}]}),
         r"^task.obstacles\[0\] \(center, radius\)\[0\] = 1e300: must be at most 1000 m"),
        (lambda r: brachia.RapierPlant(r, obstacles=[{"kind": "circle", "center": big([0.5, 1e300]), "radius": 0.1}]),
         r"^obstacles\[0\] \(center, radius\)\[1\] = 1e300: must be at most 1000 m"),
        (lambda r: brachia.plan_joint_swings(r, np.zeros(8), [[0, 0], [0.8, 0]], obstacles=[{"center": [0, 0], "radius": 1e300}]),
         r"^obstacles\[0\] \(center, radius\)\[2\] = 1e300: must be at most 1000 m"),
        (lambda r: brachia.Mpc(r, brachia.Trajectory([0, 1], np.zeros((2, 4)), np.zeros((2, 4)), np.zeros((2, 3))),
                               q_diag=np.ones(8, dtype=complex)),
         r"^mpc settings: cannot be read"),
    ],
)
def test_values_inside_dicts_obey_the_same_rules(robot, call, message):
    with pytest.raises(brachia.BrachiaError, match=message):
        call(robot)


class CallsBack:
    """An array-like whose conversion calls back into the object it is handed to."""

    def __init__(self, call, value):
        self.call, self.value = call, value

    def __array__(self, dtype=None, copy=None):
        self.call()
        return np.asarray(self.value, dtype=dtype)


def test_a_call_from_inside_its_own_call_is_refused_not_a_hang(robot, tracking_plan, planned):
    sp, _, cp = planned
    mpc = brachia.Mpc(robot, tracking_plan)
    x = tracking_plan.trajectory.state_at(0.0)
    with pytest.raises(brachia.BrachiaError, match="^x: .*Mpc: called again from inside one of its own calls"):
        mpc.control(0.0, CallsBack(lambda: mpc.control(0.0, x), x))
    assert np.all(np.isfinite(mpc.control(0.0, x)))
    plant = brachia.ModelPlant(robot)
    with pytest.raises(brachia.BrachiaError, match="^tau: .*ModelPlant: called again"):
        plant.step(CallsBack(lambda: plant.state(), TAU), 1e-3)
    assert plant.time == 0.0
    sp.restore(cp)
    xk = kicked_state(sp, 5)
    with pytest.raises(brachia.BrachiaError, match="^x_now: .*SwingPlanner: called again"):
        sp.replan(float(sp.knot_times()[5]), CallsBack(lambda: sp.knot_states(), xk))
    assert sp.replan(float(sp.knot_times()[5]), xk).converged
    sp.restore(cp)


def test_a_scenario_tracks_only_a_plan_of_its_own_task(tmp_path, root, scenario, tracking_plan):
    text = (root / "scenarios" / "tracking.toml").read_text()
    text = text.replace('params = "../params/paper.toml"', f'params = "{root / "params" / "paper.toml"}"')
    assert "target = [0.8, 0.0]" in text
    other = tmp_path / "other-bar.toml"
    other.write_text(text.replace("target = [0.8, 0.0]", "target = [0.75, 0.05]"))
    with pytest.raises(brachia.BrachiaError, match=r"^reference: a plan for another task: its target = \[0.8, 0.0\], .*other-bar.toml's task.target = \[0.75, 0.05\]"):
        brachia.Scenario.from_toml(other).track(reference=tracking_plan)
    params = re.sub(r"mass = ([0-9.]+)", lambda m: f"mass = {1.5 * float(m.group(1))}",
                    (root / "params" / "paper.toml").read_text(), count=1)
    (tmp_path / "heavy.toml").write_text(params)
    heavy = tmp_path / "heavy-robot.toml"
    heavy.write_text(text.replace(f'params = "{root / "params" / "paper.toml"}"', f'params = "{tmp_path / "heavy.toml"}"'))
    with pytest.raises(brachia.BrachiaError, match=r"^reference: a plan for another robot"):
        brachia.Scenario.from_toml(heavy).track(reference=tracking_plan)
    # a plan of the same task by brachia.plan is this scenario's plan
    again = brachia.plan(scenario.robot, scenario.task, scenario.plan_settings)
    res = scenario.track(reference=again, controller="open-loop")
    assert res.tracked
    # a re-planned solution starts elsewhere: not this scenario's task
    sp = brachia.SwingPlanner(scenario.robot, scenario.task, SETTINGS)
    sp.plan()
    k = sp.intervals // 2
    sp.replan(float(sp.knot_times()[k]), kicked_state(sp, k))
    with pytest.raises(brachia.BrachiaError, match=r"^reference: a plan for another task: its q0 = "):
        scenario.track(reference=sp.current_plan())


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda r, p: brachia.ModelPlant(r).step(TAU, np.complex128(1e-3 + 1j)), r"^expected a real number, got dtype complex128"),
        (lambda r, p: brachia.ModelPlant(r).step(TAU, np.complex128(1e-3)), r"^expected a real number, got dtype complex128"),
        (lambda r, p: brachia.ModelPlant(r).step(TAU, True), r"^expected a real number, got a bool"),
        (lambda r, p: brachia.ModelPlant(r).step(TAU, np.array([1e-3, 2e-3])), r"^expected a real number, got an array of shape \[2\]"),
        (lambda r, p: brachia.ModelPlant(r).step(TAU, "0.001"), r"^expected a real number, got dtype <U5: text"),
        (lambda r, p: brachia.Mpc(r, p).control(1j, np.zeros(8)), r"^expected a real number, got dtype complex128"),
        (lambda r, p: p.trajectory.state_at(np.bool_(True)), r"^expected a real number, got dtype bool"),
        (lambda r, p: brachia.track(r, p, control_dt=1e-3 + 0j), r"^expected a real number, got dtype complex128"),
        (lambda r, p: brachia.track(r, p, seed=-1), r"^expected a whole number >= 0, got -1"),
        (lambda r, p: brachia.track(r, p, seed=1.5), r"^expected a whole number >= 0, got 1.5"),
        (lambda r, p: brachia.ModelPlant(r, substeps=True), r"^expected a whole number >= 0, got a bool"),
        (lambda r, p: brachia.ModelPlant(r, substeps=2**70), r"^expected a whole number >= 0, got 1180591620717411303424"),
        (lambda r, p: brachia.rust_mpc_step_times(r, p, steps=np.float64(3.0)), r"^expected a whole number >= 0"),
    ],
)
def test_scalars_are_real_numbers(robot, tracking_plan, call, message):
    with pytest.raises(brachia.BrachiaError, match=message):
        call(robot, tracking_plan)


def test_real_scalars_of_any_numeric_type_convert(robot):
    a, b = brachia.ModelPlant(robot), brachia.ModelPlant(robot)
    for dt in (np.float32(2.0**-10), np.int64(1) / 1000, np.array(2e-3), np.longdouble(1e-3)):
        a.step(TAU, dt)
    for dt in (2.0**-10, 1e-3, 2e-3, float(np.longdouble(1e-3))):
        b.step(TAU, dt)
    assert a.time == b.time
    np.testing.assert_array_equal(a.state(), b.state())
    assert brachia.ModelPlant(robot, substeps=np.int32(3)).substeps == 3


# ---- settings that would have no effect on the run: refused before any work, as the CLI does ----

def scenario_with(tmp_path, root, extra):
    """The tracking scenario with `extra` appended, as a Scenario."""
    text = (root / "scenarios" / "tracking.toml").read_text()
    text = text.replace('params = "../params/paper.toml"', f'params = "{root / "params" / "paper.toml"}"')
    path = tmp_path / "s.toml"
    path.write_text(text + "\n" + extra + "\n")
    return brachia.Scenario.from_toml(path), str(path)


@pytest.mark.parametrize(
    "extra, controller, plant, field",
    [
        ("[tracking]\nreplan = { threshold_m = 0.01 }", "pd", None, "tracking.replan"),
        ("[tracking]\nreplan = { threshold_m = 0.01 }", "open-loop", None, "tracking.replan"),
        ("[tracking]\nkalman = true", "open-loop", None, "tracking.kalman"),
        ("[tracking.estimator]\nmeas_q_std = 0.01", None, None, "tracking.estimator"),
        ("[tracking.mpc]\nhorizon = 30", "pd", None, "tracking.mpc"),
        ("[plant]\nlink_friction = 0.9", None, "model", "plant.link_friction"),
    ],
)
def test_scenario_track_refuses_a_setting_it_would_ignore(tmp_path, root, extra, controller, plant, field):
    sc, path = scenario_with(tmp_path, root, extra)
    with pytest.raises(brachia.BrachiaError, match=re.escape(field)) as e:
        sc.track(controller=controller, plant=plant)
    assert path in str(e.value)
