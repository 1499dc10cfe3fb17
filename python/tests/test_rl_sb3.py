"""The stable-baselines3 adapter (brachia.sb3) against stable-baselines3 itself: its env checker, the
VecEnv contract (the adapter steps as stable-baselines3's DummyVecEnv over single envs), a few PPO
steps and the trained model as a controller. Skipped when stable-baselines3 is not installed.

stable-baselines3 (and torch) are imported inside the tests, never when pytest collects this file:
test_gym.py checks that importing brachia and using the adapter's core imports neither."""

import importlib.util

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import brachia  # noqa: E402
from brachia.policy import EnvPolicy  # noqa: E402
from brachia.sb3 import swing_vec_env  # noqa: E402

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("stable_baselines3") is None,
    reason="stable-baselines3 is not installed (pip install stable-baselines3)",
)


@pytest.fixture
def sb3():
    import stable_baselines3
    import stable_baselines3.common.env_checker
    import stable_baselines3.common.vec_env

    return stable_baselines3

# short episodes that end both ways: truncation after 10 steps, termination when a rate passes 2 rad/s
SHORT = {"time_limit_s": 0.1, "max_rate_rad_s": 2.0}


def test_sb3_env_checker_accepts_the_single_env(sb3):
    env = gymnasium.make("brachia/Swing-v0").unwrapped
    sb3.common.env_checker.check_env(env, warn=True, skip_render_check=True)


def test_adapter_is_a_vec_env_with_the_env_spaces(sb3):
    venv = swing_vec_env(num_envs=3, seed=0, **SHORT)
    single = gymnasium.make("brachia/Swing-v0", **SHORT)
    assert isinstance(venv, sb3.common.vec_env.VecEnv)
    assert venv.num_envs == 3
    assert venv.observation_space == single.observation_space
    assert venv.action_space == single.action_space
    obs = venv.reset()
    assert obs.shape == (3,) + single.observation_space.shape and obs.dtype == np.float32
    assert all(venv.observation_space.contains(o) for o in obs)
    assert venv.get_attr("control_dt") == [0.01] * 3
    assert venv.env_is_wrapped(sb3.common.vec_env.VecMonitor) == [False] * 3
    assert venv.seed(5) == [5, 6, 7]
    with pytest.raises(AttributeError):
        venv.set_attr("control_dt", 0.02)
    venv.close()


def test_adapter_steps_as_dummy_vec_env_over_single_envs(sb3):
    """Copy i of the adapter seeded s is the single env seeded s + i: the adapter's observations,
    rewards, dones and end-of-episode infos equal stable-baselines3's own DummyVecEnv's."""
    n, seed = 4, 11
    venv = swing_vec_env(num_envs=n, seed=seed, **SHORT)
    ref = sb3.common.vec_env.DummyVecEnv([lambda: gymnasium.make("brachia/Swing-v0", **SHORT)] * n)
    ref.seed(seed)
    np.testing.assert_array_equal(venv.reset(), ref.reset())
    rng = np.random.default_rng(0)
    ends = {"terminated": 0, "truncated": 0}
    for _ in range(60):
        actions = rng.uniform(-1.0, 1.0, (n, 3)).astype(np.float32)
        venv.step_async(actions)
        ref.step_async(actions)
        obs, rew, done, infos = venv.step_wait()
        robs, rrew, rdone, rinfos = ref.step_wait()
        np.testing.assert_array_equal(obs, robs)
        np.testing.assert_array_equal(rew, rrew.astype(np.float32))
        np.testing.assert_array_equal(done, rdone)
        for i in np.flatnonzero(done):
            np.testing.assert_array_equal(
                infos[i]["terminal_observation"], rinfos[i]["terminal_observation"]
            )
            assert infos[i]["TimeLimit.truncated"] == rinfos[i]["TimeLimit.truncated"]
            ends["truncated" if infos[i]["TimeLimit.truncated"] else "terminated"] += 1
    assert ends["terminated"] > 0 and ends["truncated"] > 0, ends


def test_adapter_episode_info_sums_the_rewards(sb3):
    venv = swing_vec_env(num_envs=2, seed=3, **SHORT)
    venv.reset()
    rng = np.random.default_rng(1)
    totals, lengths, seen = np.zeros(2), np.zeros(2, dtype=int), 0
    for _ in range(30):
        obs, rew, done, infos = venv.step(rng.uniform(-1.0, 1.0, (2, 3)))
        totals += rew
        lengths += 1
        for i in np.flatnonzero(done):
            ep = infos[i]["episode"]
            assert ep["l"] == lengths[i] and ep["r"] == pytest.approx(totals[i], rel=1e-5, abs=1e-6)
            assert isinstance(infos[i]["captured"], bool)
            totals[i], lengths[i] = 0.0, 0
            seen += 1
        for i in np.flatnonzero(~done):
            assert "episode" not in infos[i]
    assert seen > 0


def test_a_few_ppo_steps_train_and_the_model_is_a_controller(sb3, robot, tracking_plan):
    import torch

    torch.set_num_threads(1)
    vec_env = sb3.common.vec_env
    venv = vec_env.VecNormalize(vec_env.VecMonitor(swing_vec_env(num_envs=4, seed=0)))
    model = sb3.PPO("MlpPolicy", venv, n_steps=16, batch_size=32, n_epochs=2, seed=0, device="cpu")
    before = [p.detach().clone() for p in model.policy.parameters()]
    model.learn(total_timesteps=128)
    assert model.num_timesteps >= 128
    after = list(model.policy.parameters())
    assert any(not torch.equal(a, b) for a, b in zip(before, after))

    env = gymnasium.make("brachia/Swing-v0")
    pol = EnvPolicy(lambda obs: model.predict(venv.normalize_obs(obs), deterministic=True)[0], env)
    res = brachia.track(robot, tracking_plan, controller=pol, control_dt=0.001, duration=0.05)
    tau = np.asarray(res.tau)
    assert np.all(np.isfinite(tau))
    assert np.all(tau <= np.asarray(robot.tau_max) + 1e-12)
    assert np.all(tau >= np.asarray(robot.tau_min) - 1e-12)
    # the action is held for the env's 10 ms period
    np.testing.assert_array_equal(tau[0], tau[9])
