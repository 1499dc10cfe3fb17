"""Benchmark: one MPC control step called from Python vs the same step in Rust.

Plans the V-B swing (scenarios/tracking.toml), then times, in this one process, `steps` calls of
`Mpc.control(t_k, x_k)` from Python (t_k = k * 1 ms, x_k the reference state, precomputed) and the
same sequence made inside Rust by `brachia.rust_mpc_step_times` (a fresh Mpc with the same settings).
Both are repeated `rounds` times, interleaved, and the medians over all calls are compared; the
ratio is Python median / Rust median. Timings on a loaded machine are inflated: compare the ratio.

    python python/bench/mpc_step.py [--steps 1000] [--rounds 5]
"""

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import brachia

ROOT = Path(__file__).resolve().parents[2]


def python_step_times(robot, plan, settings, steps, dt):
    mpc = brachia.Mpc(robot, plan, settings)
    traj = plan.trajectory
    xs = [traj.state_at(k * dt) for k in range(steps)]
    out = np.empty(steps)
    clock = time.perf_counter
    for k in range(steps):
        t = k * dt
        x = xs[k]
        start = clock()
        mpc.control(t, x)
        out[k] = clock() - start
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1000, help="control calls per round (1 ms apart)")
    ap.add_argument("--rounds", type=int, default=5, help="interleaved rounds of each")
    args = ap.parse_args()
    sc = brachia.Scenario.from_toml(ROOT / "scenarios" / "tracking.toml")
    plan = sc.plan()
    if not plan.converged:
        sys.exit(f"plan did not converge: {plan.status}")
    robot, settings, dt = sc.robot, sc.mpc_settings, 1e-3
    py_times, rust_times = [], []
    for _ in range(args.rounds):
        rust_times.extend(brachia.rust_mpc_step_times(robot, plan, args.steps, dt, settings))
        py_times.extend(python_step_times(robot, plan, settings, args.steps, dt))
    py_med = statistics.median(py_times) * 1e6
    rust_med = statistics.median(rust_times) * 1e6
    ratio = py_med / rust_med
    print(f"MPC step (horizon {settings['horizon']}, {args.rounds} x {args.steps} calls):")
    print(f"  Rust   median {rust_med:8.2f} us")
    print(f"  Python median {py_med:8.2f} us   (Mpc.control from Python)")
    print(f"  ratio  {ratio:.3f}")
    sys.exit(0 if ratio <= 2.0 else 1)


if __name__ == "__main__":
    main()
