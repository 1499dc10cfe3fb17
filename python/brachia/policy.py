"""Policies trained on ``brachia/Swing-v0`` as controllers of ``brachia.track``.

``brachia.track(robot, plan, controller=policy)`` takes any callable ``policy(t, x) -> tau`` (t in
s, x = [q, qd] float64, tau in N m for joints 2..n). ``EnvPolicy`` turns a policy that acts in the
environment's terms (scaled actions from the environment's observations) into one:

    from stable_baselines3 import PPO
    env = gymnasium.make("brachia/Swing-v0")
    model = PPO.load("swing.zip")
    result = brachia.track(robot, plan, controller=brachia.policy.EnvPolicy(model, env),
                           control_dt=env.unwrapped.control_dt)
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np


class EnvPolicy:
    """``policy(t, x) -> tau`` from an environment-trained policy.

    ``policy``: an object with ``predict(obs, deterministic=True) -> (action, state)`` (a
    stable-baselines3 model) or a callable ``obs -> action``; ``env``: the environment it was
    trained on (a ``brachia.envs.SwingEnv``, wrapped or not), whose observation (measured state,
    bar relative to the hand of the nominal robot, time left), action scaling and control period are
    reproduced. The action is held for the environment's control period (a closed loop with a
    shorter ``control_dt`` reuses it until the period has passed). ``t`` is measured from the
    start of the run, as in the environment's episodes.
    """

    def __init__(self, policy: Any, env: Any, deterministic: bool = True) -> None:
        env = getattr(env, "unwrapped", env)
        if hasattr(policy, "predict"):
            self._act: Callable[[np.ndarray], Any] = lambda obs: policy.predict(
                obs, deterministic=deterministic
            )[0]
        elif callable(policy):
            self._act = policy
        else:
            raise ValueError("policy: expected a model with predict(obs) or a callable obs -> action")
        self.robot = env.robot
        settings = env.settings
        self.control_dt = float(settings["control_dt"])
        self.time_limit_s = float(settings["time_limit_s"])
        self.target = np.asarray(env.target, dtype=float)
        space = env.observation_space
        self._low = np.asarray(space.low, dtype=np.float64)
        self._high = np.asarray(space.high, dtype=np.float64)
        lo = np.asarray(self.robot.tau_min, dtype=float)
        hi = np.asarray(self.robot.tau_max, dtype=float)
        self._mid, self._half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        self._n = len(lo) + 1
        self._t_last: float | None = None
        self._tau = np.zeros(len(lo))

    def observation(self, t: float, x: np.ndarray) -> np.ndarray:
        """The environment's observation at time ``t`` (s) for the measured state ``x``."""
        x = np.asarray(x, dtype=float)
        steps = round(self.time_limit_s / self.control_dt)
        done = min(round(t / self.control_dt), steps)
        # the hand depends on the angles modulo 2 pi: wrapped, a state that spun past the model's
        # angle limit still has a hand (the observation's angles are clipped below, as the env's)
        q = np.where(np.isfinite(x[: self._n]), x[: self._n], 0.0)
        q = np.where(np.abs(q) > np.pi, np.remainder(q + np.pi, 2 * np.pi) - np.pi, q)
        hand = np.asarray(self.robot.ee_position(q))
        obs = np.concatenate([x, self.target - hand, [(steps - done) * self.control_dt]])
        obs = np.where(np.isfinite(obs), obs, 0.0)
        return np.clip(obs, self._low, self._high).astype(np.float32)

    def reset(self) -> None:
        """Forget the held action (a new run)."""
        self._t_last = None

    def __call__(self, t: float, x: np.ndarray) -> np.ndarray:
        if self._t_last is not None and t < self._t_last:
            self._t_last = None  # a new run started
        if self._t_last is None or t - self._t_last >= self.control_dt - 1e-9:
            a = np.asarray(self._act(self.observation(t, x)), dtype=float).reshape(-1)
            self._tau = self._mid + self._half * np.clip(a, -1.0, 1.0)
            self._t_last = t
        return self._tau
