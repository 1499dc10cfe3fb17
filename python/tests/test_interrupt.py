"""Ctrl-C in Python: a long plan raises KeyboardInterrupt promptly instead of finishing its solve first.

The interrupt is simulated with `_thread.interrupt_main` from a timer thread (the effect of SIGINT
arriving on the main thread); the binding polls for it while the solve runs without the GIL.
"""

import _thread
import threading
import time

import pytest

import brachia

TASK = {"q0": [-2.35, 0.0, -1.55, 0.0], "target": [0.8, 0.0]}


def interrupt_after(seconds):
    timer = threading.Timer(seconds, _thread.interrupt_main)
    timer.start()
    return timer


def test_keyboard_interrupt_stops_a_long_plan(robot):
    # a 20 s swing takes far longer to plan than the test waits
    timer = interrupt_after(0.5)
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        brachia.plan(robot, TASK, swing_time=20.0, knot_dt=0.03)
    took = time.monotonic() - start
    timer.join()
    print(f"plan of a 20 s swing: KeyboardInterrupt {took - 0.5:.3f} s after the interrupt")
    assert took < 0.5 + 5.0


def test_a_plan_after_an_interrupt_is_unaffected(robot):
    timer = interrupt_after(0.2)
    with pytest.raises(KeyboardInterrupt):
        brachia.plan(robot, TASK, swing_time=20.0, knot_dt=0.03)
    timer.join()
    p = brachia.plan(robot, TASK)
    assert p.converged, p.status
