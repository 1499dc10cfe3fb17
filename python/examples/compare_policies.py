"""Score a policy trained by train_ppo.py with the robustness benchmark beside a random policy, the MPC
as a Python callable, and the built-in MPC, MPC + re-planning and TVLQR, on the same draws.

    python python/examples/compare_policies.py [--model runs/ppo] [--out runs/ppo/benchmark]

Every controller runs the benchmark of scenarios/tracking.toml (the paper's V-B swing): the
disturbance sweeps and the Monte Carlo draws of ``brachia benchmark`` (docs/robustness.md), scored
by the same success rule. The trained policy and the random one act in the environment's terms
(``brachia.policy.EnvPolicy``: Swing-v0's observation, actions in [-1, 1] scaled to torques, held for
the 10 ms control period); the random policy draws uniform actions. ``mpc-python`` is the MPC called
from Python each control period; it scores as the built-in ``mpc`` row by row.

Every run is judged by the one capture rule (docs/limits.md "Success"): the plant's hand within 2 cm
of the bar and no faster than 0.5 m/s, at any time of the run; the run is scored up to its capture.
The environment ends an episode by the same rule, and each policy is also scored in the
environment's own terms (capture within the 3 s limit): ``--env-episodes`` episodes of Swing-v0 per
policy, undisturbed and under the benchmark's Monte Carlo mismatch on the model plant (every link
mass x U(0.85, 1.15), sensor noise 0.002 rad), written to ``env_scores.md``. ``--also NAME=DIR``
scores further trained policies (e.g. one trained under disturbances) beside the first.

Writes ``scorecard.json``, ``runs.csv``, ``summary.md`` and ``env_scores.md`` into ``--out`` and
prints the summaries.
"""

from __future__ import annotations

import argparse
import json
import pickle
import sys
import time
from pathlib import Path

import gymnasium
import numpy as np

import brachia
from brachia.policy import EnvPolicy
from train_ppo import evaluate

#: The benchmark's Monte Carlo mismatch and sensor noise, drawn per episode, for the in-env scores.
MISMATCH = {"mass_scale": [{"uniform": [0.85, 1.15]}] * 4, "noise_q_std": 0.002}

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "tracking.toml"


def write_benchmark(out: Path, card: dict) -> None:
    """Write the files of ``brachia benchmark`` from the dict of ``brachia.benchmark`` into ``out``:
    ``scorecard.json`` (with its ``schema_version``), ``runs.csv`` (its schema line first) and
    ``summary.md``; ``brachia view out`` reads them back."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "scorecard.json").write_text(json.dumps(card["scorecard"], indent=2) + "\n")
    (out / "runs.csv").write_text(card["runs_csv"])
    (out / "summary.md").write_text(card["summary_md"])


class MpcPolicy:
    """The MPC as a Python callable; ``reset()`` before each run, as a fresh MPC would be."""

    def __init__(self, robot: brachia.Robot, plan: brachia.Plan, settings) -> None:
        self.mpc = brachia.Mpc(robot, plan, settings)

    def reset(self) -> None:
        self.mpc.reset()

    def __call__(self, t: float, x: np.ndarray) -> np.ndarray:
        return self.mpc.control(t, x)


class RandomActions:
    """Uniform random actions in [-1, 1], the same sequence in every run (reseeded by ``reset``)."""

    def __init__(self, dim: int, seed: int) -> None:
        self.dim, self.seed = dim, seed
        self.rng = np.random.default_rng(seed)

    def reset(self) -> None:
        self.rng = np.random.default_rng(self.seed)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return self.rng.uniform(-1.0, 1.0, self.dim)


class Resettable(EnvPolicy):
    """``EnvPolicy`` whose ``reset`` also resets the wrapped policy (when it has one)."""

    def __init__(self, policy, env, inner=None) -> None:
        super().__init__(policy, env)
        self.inner = inner

    def reset(self) -> None:
        super().reset()
        if self.inner is not None and hasattr(self.inner, "reset"):
            self.inner.reset()


def trained_policy(model_dir: Path):
    """``obs -> action`` of the PPO model in ``model_dir`` (with its observation statistics)."""
    from stable_baselines3 import PPO

    model = PPO.load(model_dir / "model.zip", device="cpu")
    with (model_dir / "vecnormalize.pkl").open("rb") as f:
        norm = pickle.load(f)

    def act(obs: np.ndarray) -> np.ndarray:
        return model.predict(norm.normalize_obs(obs), deterministic=True)[0]

    return act


def env_scores(acts: dict, episodes: int, seed: int) -> str:
    """The in-env table: the trained policies ``acts`` (name -> ``obs -> action``) and a random
    policy, undisturbed and with ``MISMATCH``."""
    rng = np.random.default_rng(seed)

    def rand(obs: np.ndarray) -> np.ndarray:
        return rng.uniform(-1.0, 1.0, (len(obs), 3)).astype(np.float32)

    lines = [
        f"| policy | episodes | disturbances | captured % | capture time (s) | return "
        "| energy, eq. 18 (J) | positive work (J) | final distance (m) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name, pol in [*acts.items(), ("random", rand)]:
        for label, dist in (("none", None), ("mass x U(0.85, 1.15), noise", MISMATCH)):
            e = evaluate(pol, episodes, seed, dist)
            t = "-" if e["capture_time_s"] is None else f"{e['capture_time_s']:.2f}"
            lines.append(
                f"| {name} | {episodes} | {label} | {100 * e['capture_rate']:.1f} | {t} | "
                f"{e['return']:.2f} | {e['energy_j']:.2f} | {e['positive_work_j']:.2f} | {e['final_distance_m']:.3f} |"
            )
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--model",
        type=Path,
        default=ROOT / "python" / "examples" / "swing_ppo",
        help="train_ppo.py's output folder (default: the policy trained for docs/rl.md)",
    )
    ap.add_argument(
        "--also",
        action="append",
        default=[],
        metavar="NAME=DIR",
        help="another train_ppo.py output folder, scored as NAME (repeatable)",
    )
    ap.add_argument("--out", type=Path, default=None, help="default: MODEL/benchmark")
    ap.add_argument("--levels", type=int, default=3, help="levels per sweep")
    ap.add_argument("--monte-carlo", type=int, default=6, help="Monte Carlo runs (rapier plant)")
    ap.add_argument("--family-runs", type=int, default=1, help="runs of each other Monte Carlo family")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--torch-threads", type=int, default=1)
    ap.add_argument("--env-episodes", type=int, default=256, help="episodes of the in-env scores")
    args = ap.parse_args()
    out = args.out or args.model / "benchmark"

    import torch

    torch.set_num_threads(args.torch_threads)
    scenario = brachia.Scenario.from_toml(SCENARIO)
    plan = scenario.plan()
    if not plan.converged:
        print(f"the scenario's plan did not converge: {plan.status}", file=sys.stderr)
        return 1
    env = gymnasium.make("brachia/Swing-v0", scenario=SCENARIO)
    acts = {"ppo": trained_policy(args.model)}
    for spec in args.also:
        name, _, folder = spec.partition("=")
        if not name or not folder:
            print(f"--also {spec!r}: expected NAME=DIR", file=sys.stderr)
            return 2
        acts[name] = trained_policy(Path(folder))
    rand = RandomActions(env.action_space.shape[0], args.seed)
    controllers = {
        **{name: EnvPolicy(a, env) for name, a in acts.items()},
        "random": Resettable(rand, env, inner=rand),
        "mpc-python": MpcPolicy(scenario.robot, plan, scenario.mpc_settings),
    }
    t0 = time.perf_counter()
    card = brachia.benchmark(
        SCENARIO,
        controllers=controllers,
        builtin=["mpc", "mpc+replan", "tvlqr"],
        levels=args.levels,
        monte_carlo_runs=args.monte_carlo,
        family_runs=args.family_runs,
        seed=args.seed,
    )
    if "plan_status" in card:
        print(f"the scenario's plan did not converge: {card['plan_status']}", file=sys.stderr)
        return 1
    write_benchmark(out, card)
    print(card["summary_md"])
    print(f"benchmark: {time.perf_counter() - t0:.0f} s")
    table = env_scores(acts, args.env_episodes, args.seed)
    (out / "env_scores.md").write_text(table)
    print(table)
    print(f"written to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
