"""Plan the V-B swing (scenarios/tracking.toml), track it with the MPC on the model plant, and plot.

    python python/examples/plan_track_plot.py [--out plan_track.png]

Prints the plan's status and energy and the tracking errors; draws the joint angles (planned and
tracked), the torques and the end-effector path with matplotlib when it is installed (else skips the
figure). Units: s, rad, N m, m.
"""

import argparse
from pathlib import Path

import numpy as np

import brachia

ROOT = Path(__file__).resolve().parents[2]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="plan_track.png", help="figure file (PNG)")
    args = ap.parse_args()

    sc = brachia.Scenario.from_toml(ROOT / "scenarios" / "tracking.toml")
    robot = sc.robot
    plan = brachia.plan(robot, sc.task, sc.plan_settings)
    print(f"plan: {plan.status}, T = {plan.swing_time:.3f} s, energy {plan.energy:.3f} J, "
          f"{plan.iterations} iterations")
    if not plan.converged:
        raise SystemExit(plan.failure_message)

    mpc = brachia.Mpc(robot, plan, sc.mpc_settings)
    run = brachia.track(robot, plan, controller=mpc, plant=brachia.ModelPlant(robot, np.r_[plan.q[0], plan.qd[0]]))
    s = run.summary
    print(f"track: EE final error {s['ee_final_error_m']:.2e} m, joint RMS error "
          f"{s['joint_rms_error_rad']:.2e} rad, control step p50 {s['control_step_us_p50']:.0f} us")

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no figure")
        return
    fig, ax = plt.subplots(1, 3, figsize=(13, 3.8))
    for i in range(robot.n_links):
        (line,) = ax[0].plot(plan.t, plan.q[:, i], label=f"q{i + 1} plan")
        ax[0].plot(run.t, run.q[:, i], "--", color=line.get_color(), label=f"q{i + 1} MPC")
    ax[0].set(xlabel="t [s]", ylabel="angle [rad]", title="joint angles")
    ax[0].legend(fontsize=7, ncol=2)
    for j in range(robot.nu):
        ax[1].plot(run.t, run.tau[:, j], label=f"tau{j + 2}")
    ax[1].set(xlabel="t [s]", ylabel="torque [N m]", title="MPC torques")
    ax[1].legend(fontsize=7)
    ax[2].plot(plan.ee[:, 0], plan.ee[:, 1], label="plan")
    ax[2].plot(run.ee[:, 0], run.ee[:, 1], "--", label="MPC")
    ax[2].plot(*sc.task["target"], "ko", label="target bar")
    ax[2].plot(0, 0, "ks", label="grip bar")
    ax[2].set(xlabel="x [m]", ylabel="y [m]", title="end effector", aspect="equal")
    ax[2].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"figure: {args.out}")


if __name__ == "__main__":
    main()
