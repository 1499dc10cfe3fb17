"""Re-plan a swing online after a kick, from Python: the persistent planner and the MPC in one loop.

    python python/examples/replan_online.py [--kick 0.4] [--t-kick 0.6]

Plans the paper's tracking swing (params/paper.toml, 30 ms multiple-shooting knots), tracks it with the
MPC on the model plant at 1 kHz, kicks every joint rate by ``--kick`` rad/s at ``--t-kick`` s, re-plans
warm from the measured state (``SwingPlanner.replan``) and tracks the new plan to the bar. Prints the
re-plan's iterations and time and the hand's miss at the end, with and without the re-plan.
Units: s, m, rad, rad/s, N m.
"""

import argparse

import numpy as np

import brachia

TASK = {"q0": [-2.35, 0.0, -1.55, 0.0], "target": [0.8, 0.0]}


def swing(robot, kick, t_kick, replan):
    sp = brachia.SwingPlanner(robot, TASK, knot_dt=0.03, shooting={"substeps": 1})
    ref = sp.plan()
    if not ref.converged:
        raise SystemExit(ref.failure_message)
    mpc = brachia.Mpc(robot, ref)
    plant = brachia.ModelPlant(robot, np.r_[ref.q[0], ref.qd[0]])
    n, dt = robot.n_links, 0.001
    t, t0, kicked = 0.0, 0.0, False
    while t < sp.swing_time - 0.5 * dt:
        if not kicked and t >= t_kick:
            x = plant.state()
            x[n:] += kick
            plant.reset(x)
            kicked = True
            if replan:
                out = sp.replan(t, x)
                print(f"  re-plan at t = {t:.3f} s: {out.status}, {out.iterations} iterations, "
                      f"{1e3 * out.solve_time_s:.2f} ms")
                if not out.converged:
                    raise SystemExit("the re-plan did not converge")
                mpc.set_reference(sp.current_plan())  # the new plan runs on its own clock
                t0 = t
        plant.step(mpc.control(t - t0, plant.state()), dt)
        t += dt
    x = plant.state()
    return np.linalg.norm(robot.ee_position(x[:n]) - TASK["target"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kick", type=float, default=0.4, help="added to every joint rate, rad/s")
    ap.add_argument("--t-kick", type=float, default=0.6, help="time of the kick, s")
    args = ap.parse_args()
    robot = brachia.Robot.paper()
    for replan in (False, True):
        print("MPC on the new plan after a re-plan:" if replan else "MPC on the old plan:")
        miss = swing(robot, args.kick, args.t_kick, replan)
        print(f"  hand {1e3 * miss:.2f} mm from the bar at T")


if __name__ == "__main__":
    main()
