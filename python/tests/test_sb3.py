"""The stable-baselines3 adapter (brachia.sb3) and the policy adapter (brachia.policy), without torch.

stable-baselines3 cannot be imported without torch, so the adapter is tested against a stand-in of
its `stable_baselines3.common.vec_env.VecEnv`: an abstract base class with the documented abstract
VecEnv methods (reset, step_async, step_wait, close, get_attr, set_attr, env_method, env_is_wrapped),
its constructor `VecEnv(num_envs, observation_space, action_space)` and `step` (step_async, then
step_wait). A class that leaves one of them abstract cannot be made; `seed` is checked as well.
"""

import abc
import sys
import types

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

import brachia  # noqa: E402
import brachia.sb3  # noqa: E402
from brachia.envs import SwingEnv  # noqa: E402
from brachia.policy import EnvPolicy  # noqa: E402

VECENV_METHODS = [
    "reset",
    "step_async",
    "step_wait",
    "close",
    "get_attr",
    "set_attr",
    "env_method",
    "env_is_wrapped",
]


class StandInVecEnv(abc.ABC):
    """The documented VecEnv contract: the constructor, the abstract methods, step()."""

    def __init__(self, num_envs, observation_space, action_space):
        self.num_envs = num_envs
        self.observation_space = observation_space
        self.action_space = action_space

    def step(self, actions):
        self.step_async(actions)
        return self.step_wait()


for _name in VECENV_METHODS:
    setattr(StandInVecEnv, _name, abc.abstractmethod(lambda self, *a, **k: None))
StandInVecEnv.__abstractmethods__ = frozenset(VECENV_METHODS)


@pytest.fixture
def stand_in(monkeypatch):
    """stable_baselines3.common.vec_env with the stand-in VecEnv, and a fresh adapter class."""
    mods = {}
    for name in ["stable_baselines3", "stable_baselines3.common", "stable_baselines3.common.vec_env"]:
        mods[name] = types.ModuleType(name)
    mods["stable_baselines3.common.vec_env"].VecEnv = StandInVecEnv
    for name, m in mods.items():
        monkeypatch.setitem(sys.modules, name, m)
    monkeypatch.setattr(brachia.sb3, "_CLASS", None)
    yield


def test_the_adapter_is_a_vecenv(stand_in):
    venv = brachia.sb3.swing_vec_env(num_envs=3, seed=5, time_limit_s=0.05)
    assert isinstance(venv, StandInVecEnv)
    assert venv.num_envs == 3
    assert venv.observation_space.shape == (11,) and venv.action_space.shape == (3,)
    obs = venv.reset()
    assert obs.shape == (3, 11) and obs.dtype == np.float32
    assert venv.observation_space.contains(obs[0])
    rng = np.random.default_rng(0)
    dones_seen = 0
    for _ in range(6):
        obs, rew, dones, infos = venv.step(rng.uniform(-1, 1, (3, 3)))
        assert obs.shape == (3, 11) and rew.shape == (3,) and rew.dtype == np.float32
        assert dones.shape == (3,) and dones.dtype == bool and len(infos) == 3
        for i in np.flatnonzero(dones):
            dones_seen += 1
            d = infos[i]
            assert d["terminal_observation"].shape == (11,)
            assert d["TimeLimit.truncated"] is True and d["episode"]["l"] == 5
            # the copy was reset at once: its time left is the whole limit again
            assert obs[i, 10] == pytest.approx(0.05)
    assert dones_seen == 3
    assert venv.get_attr("num_envs") == [3, 3, 3] and venv.get_attr("num_envs", 1) == [3]
    assert venv.env_is_wrapped(gym.Wrapper) == [False] * 3
    assert venv.seed(7) == [7, 8, 9]
    with pytest.raises(AttributeError):
        venv.set_attr("control_dt", 0.02)
    with pytest.raises(AttributeError):
        venv.env_method("render")
    venv.close()


def test_the_same_seed_gives_the_same_rollout(stand_in):
    def rollout():
        venv = brachia.sb3.swing_vec_env(num_envs=2, seed=11, disturbances={"mass_scale": [{"uniform": [0.9, 1.1]}] * 4})
        out = [venv.reset()]
        for k in range(4):
            out.append(venv.step(np.full((2, 3), 0.1 * k))[0])
        return np.stack(out)

    np.testing.assert_array_equal(rollout(), rollout())


def test_without_stable_baselines3_the_adapter_says_what_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "stable_baselines3", None)
    monkeypatch.setattr(brachia.sb3, "_CLASS", None)
    with pytest.raises(ImportError, match="pip install stable-baselines3"):
        brachia.sb3.swing_vec_env(num_envs=1)


class PredictModel:
    """An SB3-like model: predict(obs, deterministic) -> (action, state)."""

    def __init__(self):
        self.calls = []

    def predict(self, obs, deterministic=False):
        self.calls.append((np.array(obs), deterministic))
        return np.full(3, -0.5, dtype=np.float32), None


def test_a_model_with_predict_is_a_controller(tracking_plan, robot):
    env = SwingEnv(control_dt=0.02)
    model = PredictModel()
    pol = EnvPolicy(model, env)
    res = brachia.track(robot, tracking_plan, controller=pol, control_dt=0.001, duration=0.1)
    # held for the env's 20 ms period: 5 decisions in 0.1 s, deterministic ones
    assert len(model.calls) == 5 and all(d for _, d in model.calls)
    lo, hi = np.asarray(robot.tau_min), np.asarray(robot.tau_max)
    np.testing.assert_allclose(res.tau[:-1], np.tile(0.5 * (lo + hi) - 0.25 * (hi - lo), (100, 1)))
    # the first observation is the env's at the plan's start state
    obs, _ = env.reset(seed=0)
    np.testing.assert_allclose(model.calls[0][0], obs, atol=1e-6)
    # a new run starts afresh (time goes back): the first call decides again
    model.calls.clear()
    brachia.track(robot, tracking_plan, controller=pol, control_dt=0.001, duration=0.01)
    assert len(model.calls) == 1
    with pytest.raises(ValueError, match="predict"):
        EnvPolicy(object(), env)
