"""An adapter that stable-baselines3 accepts as a ``VecEnv``: ``brachia.sb3.swing_vec_env(...)``.

Nothing here imports stable-baselines3 (or torch) until ``swing_vec_env`` is called. The adapter runs
the Rust vector env in same-step autoreset, as stable-baselines3 expects: a finished copy is reset at
once, its last observation is in ``infos[i]["terminal_observation"]``, and a time-limit end sets
``infos[i]["TimeLimit.truncated"]``.

    from stable_baselines3 import PPO
    from brachia.sb3 import swing_vec_env
    venv = swing_vec_env(num_envs=16, seed=0)
    PPO("MlpPolicy", venv).learn(1_000_000)
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np


class SwingVecEnvCore:
    """The part of the adapter that needs no stable-baselines3: ``reset``, ``step_async``,
    ``step_wait`` and the attribute calls, over ``brachia.vector.SwingVectorEnv``."""

    def __init__(self, num_envs: int = 8, seed: int | None = None, **env_kwargs: Any) -> None:
        from .vector import SwingVectorEnv

        env_kwargs["autoreset_mode"] = "same-step"
        self.venv = SwingVectorEnv(num_envs, **env_kwargs)
        self.num_envs = self.venv.num_envs
        self.observation_space = self.venv.single_observation_space
        self.action_space = self.venv.single_action_space
        self._seed = seed
        self._actions: np.ndarray | None = None
        self._episode_returns = np.zeros(self.num_envs)
        self._episode_lengths = np.zeros(self.num_envs, dtype=np.int64)

    def reset(self) -> np.ndarray:
        obs, _ = self.venv.reset(seed=self._seed)
        self._seed = None
        self._episode_returns[:] = 0.0
        self._episode_lengths[:] = 0
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions, dtype=np.float32).reshape(self.num_envs, -1)

    def step_wait(self):
        obs, rewards, terminated, truncated, infos = self.venv.step(self._actions)
        dones = terminated | truncated
        self._episode_returns += rewards
        self._episode_lengths += 1
        out: list[dict] = [{} for _ in range(self.num_envs)]
        final = infos.get("final_obs")
        for i in np.flatnonzero(dones):
            d = out[i]
            d["terminal_observation"] = final[i] if final is not None else obs[i]
            d["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            d["captured"] = bool(infos["capture"][i] > 0.0)
            d["episode"] = {
                "r": float(self._episode_returns[i]),
                "l": int(self._episode_lengths[i]),
            }
            self._episode_returns[i] = 0.0
            self._episode_lengths[i] = 0
        return obs, rewards.astype(np.float32), dones, out

    def close(self) -> None:
        self.venv.close()

    def seed(self, seed: int | None = None) -> list[int | None]:
        self._seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def _indices(self, indices: None | int | Sequence[int]) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, int):
            return [indices]
        return list(indices)

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        value = getattr(self.venv, attr_name)
        return [value for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        raise AttributeError(
            f"set_attr({attr_name!r}): the copies of a Swing vector env share their settings; "
            "make a new one"
        )

    def env_method(self, method_name: str, *args: Any, indices=None, **kwargs: Any) -> list[Any]:
        raise AttributeError(
            f"env_method({method_name!r}): the copies run in Rust and have no Python methods"
        )

    def env_is_wrapped(self, wrapper_class: type, indices=None) -> list[bool]:
        return [False for _ in self._indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None for _ in range(self.num_envs)]


_CLASS: type | None = None


def swing_vec_env(num_envs: int = 8, seed: int | None = None, **env_kwargs: Any):
    """A stable-baselines3 ``VecEnv`` of ``num_envs`` Swing-v0 copies (arguments of
    ``brachia.envs.SwingEnv``); imports stable-baselines3 now (it must be installed)."""
    global _CLASS
    if _CLASS is None:
        try:
            from stable_baselines3.common.vec_env import VecEnv
        except ImportError as e:
            raise ImportError(
                "brachia.sb3.swing_vec_env needs stable-baselines3: pip install stable-baselines3"
            ) from e

        class SwingSB3VecEnv(SwingVecEnvCore, VecEnv):
            """Swing-v0 copies as a stable-baselines3 ``VecEnv``."""

            def __init__(self, num_envs: int, seed: int | None, **kw: Any) -> None:
                SwingVecEnvCore.__init__(self, num_envs, seed, **kw)
                VecEnv.__init__(self, self.num_envs, self.observation_space, self.action_space)

            seed = SwingVecEnvCore.seed
            reset = SwingVecEnvCore.reset

        _CLASS = SwingSB3VecEnv
    return _CLASS(num_envs, seed, **env_kwargs)
