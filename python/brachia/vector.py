"""The vector form of ``brachia/Swing-v0``: every copy stepped in one call, in parallel in Rust.

``SwingVectorEnv(num_envs, ...)`` takes the arguments of ``brachia.envs.SwingEnv`` (but
``render_mode`` and ``reward_fn``) and follows Gymnasium's ``VectorEnv`` API with autoreset
(``autoreset_mode="next-step"``, Gymnasium's default, or ``"same-step"``). Copy ``i`` of an env reset
with ``seed`` is the single env reset with ``seed + i``: the same episodes, bit for bit. Also made by
``gymnasium.make_vec("brachia/Swing-v0", num_envs, vectorization_mode="vector_entry_point")``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

try:
    import gymnasium
    from gymnasium import spaces
    from gymnasium.vector.utils import batch_space
except ImportError as e:  # pragma: no cover - depends on the environment
    raise ImportError(
        "brachia.vector needs Gymnasium: pip install gymnasium (brachia itself works without it)"
    ) from e

from ._brachia import SwingBatchCore
from .envs import _SEED_SPAN, _check_seed

try:
    from gymnasium.vector import AutoresetMode
except ImportError:  # pragma: no cover - Gymnasium 1.0 names the modes by strings
    AutoresetMode = None

_MODES = {"next-step": "NEXT_STEP", "same-step": "SAME_STEP"}


class SwingVectorEnv(gymnasium.vector.VectorEnv):
    """``num_envs`` copies of ``brachia/Swing-v0`` stepped together in Rust (GIL released)."""

    metadata = {"render_modes": [], "autoreset_mode": None}

    def __init__(
        self,
        num_envs: int,
        scenario: Any = None,
        plant: str | None = None,
        disturbances: dict | None = None,
        autoreset_mode: Any = "next-step",
        **settings: Any,
    ) -> None:
        mode = getattr(autoreset_mode, "value", autoreset_mode)
        mode = {"NextStep": "next-step", "SameStep": "same-step"}.get(mode, mode)
        if mode not in _MODES:
            raise ValueError(
                f"autoreset_mode = {autoreset_mode!r}: expected 'next-step' or 'same-step'"
            )
        integer = isinstance(num_envs, (int, np.integer)) and not isinstance(num_envs, bool)
        if not integer or num_envs < 1:
            raise ValueError(f"num_envs = {num_envs!r}: expected an integer >= 1")
        settings.pop("render_mode", None)
        self._core = SwingBatchCore(
            int(num_envs), scenario, plant, settings, disturbances, 0, mode
        )
        spec = self._core.spec()
        self._spec = spec
        self.num_envs = int(num_envs)
        self.autoreset_mode_name = mode
        named = getattr(AutoresetMode, _MODES[mode]) if AutoresetMode is not None else mode
        self.metadata = {**self.metadata, "autoreset_mode": named}
        self.single_observation_space = spaces.Box(
            np.asarray(spec["obs_low"], dtype=np.float32),
            np.asarray(spec["obs_high"], dtype=np.float32),
            dtype=np.float32,
        )
        self.single_action_space = spaces.Box(-1.0, 1.0, (spec["action_dim"],), dtype=np.float32)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.control_dt = float(spec["settings"]["control_dt"])
        self._needs_seed = True
        self._np_random = None

    @property
    def settings(self) -> dict:
        """The environments' settings (control period, limits, reward weights, ...)."""
        return dict(self._spec["settings"])

    @property
    def episodes(self) -> list[dict]:
        """Every copy's current episode: seed, disturbances (ranges drawn), time."""
        return self._core.episodes()

    def reset(self, *, seed: int | list | None = None, options: dict | None = None):
        """Reset every copy: copy ``i`` reseeded with ``seed + i`` (a list must be consecutive
        seeds); ``options={"disturbances": {...}}`` for these episodes."""
        if isinstance(seed, (list, tuple)):
            if len(seed) != self.num_envs or any(
                s is None or s != seed[0] + i for i, s in enumerate(seed)
            ):
                raise ValueError(
                    f"seed = {seed!r}: a list of seeds must be [s, s + 1, ..., s + "
                    f"{self.num_envs - 1}] (copy i is seeded with s + i); or pass one integer"
                )
            seed = seed[0]
        self._np_random, _ = gymnasium.utils.seeding.np_random(
            _check_seed(seed) if seed is not None else None
        )
        rust_seed = _check_seed(seed)
        if rust_seed is None and self._needs_seed:
            rust_seed = int(self._np_random.integers(_SEED_SPAN))
        self._needs_seed = False
        options = dict(options or {})
        dist = options.pop("disturbances", None)
        if options:
            raise ValueError(
                f"options: unknown keys {sorted(options)}; the one option is 'disturbances'"
            )
        obs = self._core.reset(rust_seed, dist)
        seeds = np.array([e["seed"] for e in self._core.episodes()], dtype=np.uint64)
        return obs, {"episode_seed": seeds, "_episode_seed": np.ones(self.num_envs, dtype=bool)}

    def step(self, actions):
        obs, rewards, terminated, truncated, terms, final_obs, ended = self._core.step(actions)
        mask = np.ones(self.num_envs, dtype=bool)
        infos: dict[str, Any] = {}
        for k, v in terms.items():
            infos[k] = v
            infos["_" + k] = mask
        if self.autoreset_mode_name == "same-step" and ended.any():
            fo = np.full(self.num_envs, None, dtype=object)
            for i in np.flatnonzero(ended):
                fo[i] = final_obs[i]
            infos["final_obs"] = fo
            infos["_final_obs"] = ended
        return obs, rewards, terminated, truncated, infos

    def close_extras(self, **kwargs: Any) -> None:
        self._core = None
