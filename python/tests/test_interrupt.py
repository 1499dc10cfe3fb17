"""Ctrl-C in Python: a long plan raises KeyboardInterrupt promptly instead of finishing its solve first.

The interrupt is simulated with `_thread.interrupt_main` from a timer thread (the effect of SIGINT
arriving on the main thread); the binding polls for it while the solve runs without the GIL.
"""

import _thread
import threading
import time

import brachia

TASK = {"q0": [-2.35, 0.0, -1.55, 0.0], "target": [0.8, 0.0]}
# a 20 s swing on 10 ms knots (2000 stages) takes far longer to plan than the interrupt's delay
LONG = {"swing_time": 20.0, "knot_dt": 0.01}
DELAY_S = 0.1


def plan_interrupted(robot):
    """Plan the long swing with an interrupt after DELAY_S; returns (interrupted, seconds taken). An
    interrupt that arrives after the plan returned is absorbed here, never by the test runner."""
    timer = threading.Timer(DELAY_S, _thread.interrupt_main)
    start = time.monotonic()
    timer.start()
    try:
        brachia.plan(robot, TASK, **LONG)
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
