"""``brachia/Swing-v0``: one swing of a brachiation robot from a start state to a bar (Gymnasium).

The plant is simulated in Rust (the model plant by RK4 or the rapier physics engine). See docs/rl.md
for the spaces, the reward terms, termination, randomisation and seeding.

    import gymnasium, brachia
    env = gymnasium.make("brachia/Swing-v0")                    # the paper's V-B swing
    env = gymnasium.make("brachia/Swing-v0", scenario="scenarios/obstacle.toml", plant="rapier",
                         control_dt=0.02, disturbances={"mass_scale": [{"uniform": [0.9, 1.1]}] * 4})
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

try:
    import gymnasium
    from gymnasium import spaces
except ImportError as e:  # pragma: no cover - depends on the environment
    raise ImportError(
        "brachia.envs needs Gymnasium: pip install gymnasium (brachia itself works without it)"
    ) from e

from ._brachia import SwingCore

RewardFn = Callable[[np.ndarray, np.ndarray, dict], float]

#: Largest seed Gymnasium's generator can hand to the Rust side (seeds are unsigned 64-bit there).
_SEED_SPAN = 2**63


def _check_seed(seed: Any) -> int | None:
    if seed is None:
        return None
    integer = isinstance(seed, (int, np.integer)) and not isinstance(seed, bool)
    if not integer or not 0 <= seed < 2**64:
        raise ValueError(f"seed = {seed!r}: must be None or an integer in [0, 2**64)")
    return int(seed)


class SwingEnv(gymnasium.Env):
    """One swing as a Gymnasium environment.

    Arguments (all optional): ``scenario`` (a scenario file path or a ``brachia.Scenario``; default
    the paper's V-B swing), ``plant`` (``"model"`` or ``"rapier"``; default the scenario's),
    ``render_mode`` (``None`` or ``"rgb_array"``), ``disturbances`` (the scenario's
    ``[disturbances]`` schema with ``{"uniform": [lo, hi]}`` ranges, drawn per episode; default the
    scenario's section), ``reward_fn`` (``reward_fn(obs, action, info) -> float`` replacing the
    built-in reward; ``info`` holds every term), ``render_size`` ((width, height) pixels) and the
    settings as keywords: ``control_dt`` (s, default 0.01), ``plant_dt`` (0.001), ``time_limit_s``
    (3), ``max_angle_rad`` (2 pi), ``max_rate_rad_s`` (40), ``reward`` (weights: ``capture``,
    ``progress``, ``energy``, ``positive_work``, ``out_of_limits``). An episode terminates at the
    capture by the rule every run is judged by (``brachia.SUCCESS_RADIUS_M``,
    ``brachia.CAPTURE_SPEED_M_S``; docs/limits.md "Success").
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 100}

    def __init__(
        self,
        scenario: Any = None,
        plant: str | None = None,
        render_mode: str | None = None,
        disturbances: dict | None = None,
        reward_fn: RewardFn | None = None,
        render_size: tuple[int, int] = (480, 360),
        **settings: Any,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode = {render_mode!r}: expected None or 'rgb_array'")
        if reward_fn is not None and not callable(reward_fn):
            raise ValueError("reward_fn: expected a callable reward_fn(obs, action, info) -> float")
        self._core = SwingCore(scenario, plant, settings, disturbances)
        spec = self._core.spec()
        self._spec = spec
        self.render_mode = render_mode
        self.render_size = (int(render_size[0]), int(render_size[1]))
        self.reward_fn = reward_fn
        self.control_dt = float(spec["settings"]["control_dt"])
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.control_dt)}
        self.observation_space = spaces.Box(
            np.asarray(spec["obs_low"], dtype=np.float32),
            np.asarray(spec["obs_high"], dtype=np.float32),
            dtype=np.float32,
        )
        self.action_space = spaces.Box(-1.0, 1.0, (spec["action_dim"],), dtype=np.float32)
        self._needs_seed = True

    @property
    def robot(self):
        """The nominal ``brachia.Robot`` (the observation's hand is computed with it)."""
        return self._core.robot()

    @property
    def settings(self) -> dict:
        """The environment's settings (control period, limits, reward weights, ...)."""
        return dict(self._spec["settings"])

    @property
    def target(self) -> np.ndarray:
        """The bar to catch, m (grip frame)."""
        return np.asarray(self._spec["target"])

    @property
    def episode(self) -> dict:
        """The current episode: its seed, its disturbances (ranges drawn), time, true state."""
        return self._core.episode()

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode. ``seed`` reseeds the env's generator; ``options={"disturbances": {...}}``
        sets this episode's disturbances (the ``[disturbances]`` schema with ranges)."""
        rust_seed = _check_seed(seed)
        super().reset(seed=rust_seed)
        if rust_seed is None and self._needs_seed:
            rust_seed = int(self.np_random.integers(_SEED_SPAN))
        self._needs_seed = False
        options = dict(options or {})
        dist = options.pop("disturbances", None)
        if options:
            raise ValueError(
                f"options: unknown keys {sorted(options)}; the one option is 'disturbances'"
            )
        obs = self._core.reset(rust_seed, dist)
        ep = self._core.episode()
        return obs, {"episode_seed": ep["seed"], "disturbances": ep["disturbances"]}

    def step(self, action):
        obs, reward, terminated, truncated, info = self._core.step(action)
        if self.reward_fn is not None:
            reward = float(self.reward_fn(obs, np.asarray(action), info))
        return obs, reward, terminated, truncated, info

    def render(self):
        if self.render_mode == "rgb_array":
            return self._core.render(*self.render_size)
        return None
