"""Train stable-baselines3 PPO on brachia/Swing-v0 (the paper's V-B swing) and log the training curve.

Needs stable-baselines3 (and so torch), installed by the user:

    pip install ./python[gym] stable-baselines3
    python python/examples/train_ppo.py --steps 1000000 --out runs/ppo
    python python/examples/compare_policies.py --model runs/ppo

``--disturbances FILE`` trains (and evaluates) under a ``[disturbances]`` table with ranges, drawn
anew for every episode (``monte_carlo_disturbances.json``: the benchmark's Monte Carlo families on the
model plant; ``benchmark_disturbances.json``: every disturbance at once).

The environment is Swing-v0 at its defaults (scenarios/tracking.toml, model plant, 10 ms control
period, 1 ms plant step, the default reward and limits), ``--envs`` copies of the Rust vector env
behind the stable-baselines3 adapter (``brachia.sb3.swing_vec_env``), observations and rewards
normalised by ``VecNormalize`` (running mean and variance). PPO runs with stable-baselines3's
defaults except the rollout length (``--n-steps`` per copy) and the minibatch (``--batch-size``).
Torch uses one thread (``--torch-threads``); the vector env steps its copies on every core.

Writes into ``--out``: ``model.zip`` (the policy), ``vecnormalize.pkl`` (the observation statistics
the policy needs), ``curve.csv`` (one row every ``--log-every`` steps: the training episodes that
ended since the last row, and a deterministic evaluation of the current policy on
``--eval-episodes`` fixed episodes beside a random policy on the same episodes) and
``settings.json`` (the command's arguments and the library versions).
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from pathlib import Path
from typing import Callable, TextIO

import numpy as np

from brachia.sb3 import swing_vec_env
from brachia.vector import SwingVectorEnv

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "tracking.toml"
EVAL_SEED = 10_000_000

#: The first line of ``curve.csv`` (``# brachia KIND schema N``, KIND the file name without ``.csv``,
#: as in every CSV file brachia writes; docs/formats.md).
CURVE_SCHEMA_LINE = "# brachia curve schema 1"

CURVE_COLUMNS = [
    "steps",
    "wall_s",
    "steps_per_s",
    "train_episodes",
    "train_return",
    "train_capture_rate",
    "train_length",
    "eval_return",
    "eval_capture_rate",
    "eval_final_distance_m",
    "eval_min_distance_m",
    "eval_positive_work_j",
    "random_return",
    "random_capture_rate",
    "random_final_distance_m",
    "random_min_distance_m",
]


def open_curve(path: Path) -> tuple[TextIO, csv.DictWriter]:
    """Open the training curve ``path`` for writing: its schema line (``CURVE_SCHEMA_LINE``, as every
    brachia CSV file starts) and header written; rows go through the returned writer."""
    f = path.open("w", newline="")
    f.write(CURVE_SCHEMA_LINE + "\n")
    writer = csv.DictWriter(f, fieldnames=CURVE_COLUMNS)
    writer.writeheader()
    return f, writer


def evaluate(
    act: Callable[[np.ndarray], np.ndarray],
    episodes: int,
    seed: int,
    disturbances: dict | None = None,
) -> dict:
    """One episode on each of ``episodes`` copies (copy i seeded ``seed + i``; ``disturbances`` in
    the scenario's schema, drawn per episode), actions from ``act(obs batch) -> action batch``: the
    mean return, capture rate, final and closest distance of the hand to the bar (m), positive work
    and signed work by eq. 18 (J) and the mean time of the captures (s)."""
    env = SwingVectorEnv(
        episodes, scenario=SCENARIO, disturbances=disturbances, autoreset_mode="next-step"
    )
    obs, _ = env.reset(seed=seed)
    n = episodes
    ret, work, energy, steps = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    final, closest = np.full(n, np.nan), np.full(n, np.inf)
    captured = np.zeros(n, dtype=bool)
    live = np.ones(n, dtype=bool)
    while live.any():
        obs, reward, terminated, truncated, info = env.step(act(obs))
        ret[live] += reward[live]
        steps[live] += 1
        work[live] += info["positive_work_j"][live]
        energy[live] += info["energy_j"][live]
        closest[live] = np.minimum(closest[live], info["distance_m"][live])
        ended = live & (terminated | truncated)
        final[ended] = info["distance_m"][ended]
        captured[ended] = terminated[ended] & (info["capture"][ended] > 0)
        live &= ~ended
    env.close()
    return {
        "return": float(ret.mean()),
        "capture_rate": float(captured.mean()),
        "final_distance_m": float(final.mean()),
        "min_distance_m": float(closest.mean()),
        "positive_work_j": float(work.mean()),
        "energy_j": float(energy.mean()),
        "capture_time_s": float(steps[captured].mean() * env.control_dt) if captured.any() else None,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1_000_000, help="environment steps of training")
    ap.add_argument("--envs", type=int, default=16, help="copies in the vector env")
    ap.add_argument("--n-steps", type=int, default=256, help="PPO rollout length per copy")
    ap.add_argument("--batch-size", type=int, default=256, help="PPO minibatch")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("runs/ppo"), help="output folder")
    ap.add_argument("--log-every", type=int, default=50_000, help="steps between curve rows")
    ap.add_argument("--eval-episodes", type=int, default=32)
    ap.add_argument("--torch-threads", type=int, default=1)
    ap.add_argument(
        "--disturbances",
        type=Path,
        default=None,
        help="a JSON file of the scenario's [disturbances] schema (ranges allowed), drawn anew for "
        "every training and evaluation episode (e.g. python/examples/benchmark_disturbances.json)",
    )
    args = ap.parse_args()
    disturbances = json.loads(args.disturbances.read_text()) if args.disturbances else None

    import stable_baselines3
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecNormalize

    torch.set_num_threads(args.torch_threads)
    args.out.mkdir(parents=True, exist_ok=True)
    settings = {k: str(v) if isinstance(v, Path) else v for k, v in vars(args).items()}
    settings["stable_baselines3"] = stable_baselines3.__version__
    settings["torch"] = torch.__version__
    (args.out / "settings.json").write_text(json.dumps(settings, indent=2) + "\n")

    venv = VecNormalize(
        swing_vec_env(
            num_envs=args.envs, seed=args.seed, scenario=SCENARIO, disturbances=disturbances
        )
    )
    model = PPO(
        "MlpPolicy",
        venv,
        n_steps=args.n_steps,
        batch_size=args.batch_size,
        seed=args.seed,
        device="cpu",
        verbose=0,
    )

    rng = np.random.default_rng(args.seed)
    random_act = lambda obs: rng.uniform(-1.0, 1.0, (len(obs), 3)).astype(np.float32)  # noqa: E731
    random_eval = evaluate(random_act, args.eval_episodes, EVAL_SEED, disturbances)

    def policy_act(obs: np.ndarray) -> np.ndarray:
        return model.predict(venv.normalize_obs(obs), deterministic=True)[0]

    curve_file, writer = open_curve(args.out / "curve.csv")

    class Curve(BaseCallback):
        """A curve row every ``--log-every`` steps."""

        def __init__(self) -> None:
            super().__init__()
            self.returns: list[float] = []
            self.lengths: list[int] = []
            self.captures: list[bool] = []
            self.next = 0
            self.last = -1
            self.t0 = time.perf_counter()

        def row(self) -> None:
            wall = time.perf_counter() - self.t0
            ev = evaluate(policy_act, args.eval_episodes, EVAL_SEED, disturbances)
            mean = lambda v: float(np.mean(v)) if v else float("nan")  # noqa: E731
            r = {
                "steps": self.num_timesteps,
                "wall_s": round(wall, 1),
                "steps_per_s": round(self.num_timesteps / wall) if wall > 0 else 0,
                "train_episodes": len(self.returns),
                "train_return": mean(self.returns),
                "train_capture_rate": mean(self.captures),
                "train_length": mean(self.lengths),
            }
            for prefix, e in (("eval", ev), ("random", random_eval)):
                r.update({f"{prefix}_{k}": v for k, v in e.items() if f"{prefix}_{k}" in CURVE_COLUMNS})
            writer.writerow(r)
            curve_file.flush()
            print(
                f"{r['steps']:>9d} steps {wall:7.0f} s  train return {r['train_return']:7.3f} "
                f"captured {r['train_capture_rate']:.3f} | eval return {ev['return']:7.3f} "
                f"captured {ev['capture_rate']:.3f} final {ev['final_distance_m']:.3f} m "
                f"closest {ev['min_distance_m']:.3f} m",
                flush=True,
            )
            self.returns.clear()
            self.lengths.clear()
            self.captures.clear()
            self.next += args.log_every
            self.last = self.num_timesteps

        def _on_step(self) -> bool:
            for info in self.locals["infos"]:
                if "episode" in info:
                    self.returns.append(info["episode"]["r"])
                    self.lengths.append(info["episode"]["l"])
                    self.captures.append(info.get("captured", False))
            if self.num_timesteps >= self.next:
                self.row()
            return True

        def _on_training_end(self) -> None:
            if self.num_timesteps > self.last:
                self.row()
            model.save(args.out / "model.zip")
            venv.save(str(args.out / "vecnormalize.pkl"))

    class Checkpoint(BaseCallback):
        """Save the model and statistics with every curve row (a stopped run keeps its latest)."""

        def __init__(self) -> None:
            super().__init__()
            self.next = args.log_every

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next:
                model.save(args.out / "model.zip")
                venv.save(str(args.out / "vecnormalize.pkl"))
                self.next += args.log_every
            return True

    model.learn(total_timesteps=args.steps, callback=[Curve(), Checkpoint()])
    curve_file.close()
    print(f"saved {args.out / 'model.zip'} and {args.out / 'vecnormalize.pkl'}; curve {args.out / 'curve.csv'}")


if __name__ == "__main__":
    main()
