"""Ctrl-C in Python: a long plan, a SwingPlanner's plan (its re-plans and restore run through the same
wait), a closed loop on either plant and the MPC timing
loop raise KeyboardInterrupt promptly instead of finishing their work first.

The interrupt is simulated with `_thread.interrupt_main` from a timer thread (the effect of SIGINT
arriving on the main thread); the binding polls for it while the work runs without the GIL. Each
call is given work that takes far longer than the interrupt's delay; the bound asserted is generous
(5 s) so that a loaded machine cannot fail it.
"""

import _thread
import threading
import time

import brachia

TASK = {"q0": [-2.35, 0.0, -1.55, 0.0], "target": [0.8, 0.0]}
# a 20 s swing on 10 ms knots (2000 stages) takes far longer to plan than the interrupt's delay
LONG = {"swing_time": 20.0, "knot_dt": 0.01}
DELAY_S = 0.1


def interrupted_call(work, delay_s=DELAY_S):
    """Call work() with an interrupt after delay_s; returns (interrupted, seconds taken). An interrupt
    that arrives after the call returned is absorbed here, never by the test runner."""
    timer = threading.Timer(delay_s, _thread.interrupt_main)
    start = time.monotonic()
    timer.start()
    try:
        work()
        interrupted = False
    except KeyboardInterrupt:
        interrupted = True
    took = time.monotonic() - start
    if not interrupted:
        try:
            timer.join()
            time.sleep(0.2)
        except KeyboardInterrupt:
            pass
    timer.join()
    return interrupted, took


def plan_interrupted(robot):
    """Plan the long swing with an interrupt after DELAY_S."""
    return interrupted_call(lambda: brachia.plan(robot, TASK, **LONG))


def test_keyboard_interrupt_stops_a_long_plan(robot):
    interrupted, took = plan_interrupted(robot)
    assert interrupted, f"the plan returned after {took:.3f} s, before the interrupt"
    print(f"plan of a 20 s swing: KeyboardInterrupt {took - DELAY_S:.3f} s after the interrupt")
    assert took < DELAY_S + 5.0


def test_a_plan_after_an_interrupt_is_unaffected(robot):
    interrupted, _ = plan_interrupted(robot)
    assert interrupted
    p = brachia.plan(robot, TASK)
    assert p.converged, p.status


def check_prompt(what, interrupted, took, delay_s=DELAY_S):
    assert interrupted, f"{what} returned after {took:.3f} s, before the interrupt"
    print(f"{what}: KeyboardInterrupt {took - delay_s:.3f} s after the interrupt")
    assert took < delay_s + 5.0


def test_keyboard_interrupt_stops_a_swing_planners_plan(robot):
    sp = brachia.SwingPlanner(robot, TASK, LONG)
    interrupted, took = interrupted_call(sp.plan)
    check_prompt("SwingPlanner.plan of a 20 s swing", interrupted, took)
    # the planner is usable afterwards: a short planner plans as before
    short = brachia.SwingPlanner(robot, TASK, {"knot_dt": 0.03})
    assert short.plan().converged


def start(plan):
    """The plan's first state [q, qd]."""
    return list(plan.q[0]) + list(plan.qd[0])


def long_track(robot, plan, plant):
    # ten minutes of closed loop at 1 kHz (the reference held at its end after the swing)
    return lambda: brachia.track(robot, plan, controller="mpc", plant=plant, duration=600.0)


def test_keyboard_interrupt_stops_a_track_on_the_model_plant(robot, tracking_plan):
    plant = brachia.ModelPlant(robot, start(tracking_plan))
    interrupted, took = interrupted_call(long_track(robot, tracking_plan, plant), 0.3)
    check_prompt("track, MPC, model plant, 600 s", interrupted, took, 0.3)
    # the plant was released: it steps again
    plant.step([0.0, 0.0, 0.0], 0.001)


def test_keyboard_interrupt_stops_a_track_on_the_rapier_plant(robot, tracking_plan):
    plant = brachia.RapierPlant(robot, start(tracking_plan))
    interrupted, took = interrupted_call(long_track(robot, tracking_plan, plant), 0.3)
    check_prompt("track, MPC, rapier plant, 600 s", interrupted, took, 0.3)
    plant.step([0.0, 0.0, 0.0], 0.001)


def test_keyboard_interrupt_stops_the_mpc_timing_loop(robot, tracking_plan):
    work = lambda: brachia.rust_mpc_step_times(robot, tracking_plan, 1_000_000)  # noqa: E731
    interrupted, took = interrupted_call(work, 0.3)
    check_prompt("rust_mpc_step_times, 1e6 calls", interrupted, took, 0.3)


def test_keyboard_interrupt_stops_a_scenarios_plan(tmp_path, root):
    text = (root / "scenarios" / "tracking.toml").read_text()
    text = text.replace('params = "../params/paper.toml"', f'params = "{root / "params" / "paper.toml"}"')
    text = text.replace('swing_time = "auto"', "swing_time = 20.0").replace("knot_dt = 0.03", "knot_dt = 0.01")
    path = tmp_path / "long.toml"
    path.write_text(text)
    sc = brachia.Scenario.from_toml(path)
    interrupted, took = interrupted_call(sc.plan)
    check_prompt("Scenario.plan of a 20 s swing", interrupted, took)
