"""brachia.policy.EnvPolicy on states the environment never shows: joints spun past the model's angle
limit and non-finite measurements still give an observation (the benchmark's disturbed runs reach
them after a policy loses control). Needs Gymnasium, not torch."""

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import brachia  # noqa: E402
from brachia.policy import EnvPolicy  # noqa: E402


def test_observation_of_spun_joints_has_the_hand_of_the_wrapped_angles():
    env = gymnasium.make("brachia/Swing-v0")
    pol = EnvPolicy(lambda obs: np.zeros(3), env)
    x = np.array([-2.35, 0.4, -1.55, 0.3, 0.1, -0.2, 0.3, 0.5])
    spun = x.copy()
    spun[3] -= 2 * 2 * np.pi  # joint 4 two turns further (beyond the 4 pi angle limit)
    spun[1] += 6 * np.pi
    ref, obs = pol.observation(0.5, x), pol.observation(0.5, spun)
    # the hand relative to the bar is that of the same pose, the angles clipped to the bounds
    np.testing.assert_allclose(obs[8:10], ref[8:10], atol=1e-5)
    high = env.observation_space.high
    assert obs[3] == -high[3] and obs[1] == high[1]
    assert env.observation_space.contains(obs)


def test_policy_runs_on_a_non_finite_measurement():
    env = gymnasium.make("brachia/Swing-v0")
    seen = []
    pol = EnvPolicy(lambda obs: (seen.append(obs), np.ones(3))[1], env)
    x = np.array([np.nan, 0.0, np.inf, 0.0, 0.0, 0.0, 0.0, 0.0])
    tau = pol(0.0, x)
    np.testing.assert_allclose(tau, env.unwrapped.robot.tau_max)
    assert np.all(np.isfinite(seen[0])) and env.observation_space.contains(seen[0])


def test_benchmark_runs_a_policy_that_spins_the_joints(scenario):
    """A policy at full torque spins the arm past the angle limits; the benchmark scores it."""
    env = gymnasium.make("brachia/Swing-v0")
    out = brachia.benchmark(
        scenario, controllers={"full": EnvPolicy(lambda obs: np.ones(3), env)}, builtin=[],
        levels=2, monte_carlo_runs=0, family_runs=0, sweeps=["mass"],
    )
    schema, *lines = out["runs_csv"].strip().splitlines()
    assert schema == "# brachia runs schema 2"
    head = lines[0].split(",")
    rows = [dict(zip(head, line.split(","))) for line in lines[1:]]
    assert [r["controller"] for r in rows] == ["full", "full"]
    assert all(r["success"] == "0" for r in rows)
