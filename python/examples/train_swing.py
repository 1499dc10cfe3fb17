"""Train a policy on brachia/Swing-v0 with stable-baselines3 PPO, save it, and score it with the
robustness benchmark beside a random policy and the built-in controllers (MPC, MPC + re-planning,
TVLQR).

Needs stable-baselines3 (and so torch), installed by the user:

    pip install ./python[gym] stable-baselines3
    python python/examples/train_swing.py --steps 1000000 --envs 16 --out swing_ppo.zip

The environment is the paper's V-B swing (scenarios/tracking.toml) at a 10 ms control period; the
scored runs use the scenario's 1 ms loop, the policy's action held for 10 ms (brachia.policy.EnvPolicy).
Training prints the mean episode return and capture rate every ``--log-every`` steps.
"""

import argparse
import time
from pathlib import Path

import numpy as np

import brachia
from brachia.policy import EnvPolicy
from brachia.sb3 import swing_vec_env

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "tracking.toml"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1_000_000, help="environment steps of training")
    ap.add_argument("--envs", type=int, default=16, help="copies in the vector env")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("swing_ppo.zip"), help="where the model goes")
    ap.add_argument("--log-every", type=int, default=50_000)
    ap.add_argument("--levels", type=int, default=3, help="benchmark levels per sweep")
    ap.add_argument("--monte-carlo", type=int, default=6, help="benchmark Monte Carlo runs")
    args = ap.parse_args()

    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback

    class Log(BaseCallback):
        """Mean return and capture rate of the episodes ended since the last line."""

        def __init__(self) -> None:
            super().__init__()
            self.returns: list[float] = []
            self.captures: list[bool] = []
            self.next = args.log_every
            self.t0 = time.perf_counter()

        def _on_step(self) -> bool:
            for info in self.locals["infos"]:
                if "episode" in info:
                    self.returns.append(info["episode"]["r"])
                    self.captures.append(info.get("captured", False))
            if self.num_timesteps >= self.next and self.returns:
                rate = self.num_timesteps / (time.perf_counter() - self.t0)
                print(
                    f"{self.num_timesteps:>9d} steps  return {np.mean(self.returns):8.3f}  "
                    f"captured {100 * np.mean(self.captures):5.1f} %  ({rate:.0f} steps/s)",
                    flush=True,
                )
                self.returns.clear()
                self.captures.clear()
                self.next += args.log_every
            return True

    venv = swing_vec_env(num_envs=args.envs, seed=args.seed, scenario=SCENARIO)
    model = PPO("MlpPolicy", venv, seed=args.seed, verbose=0, n_steps=256, batch_size=1024)
    model.learn(total_timesteps=args.steps, callback=Log())
    model.save(args.out)
    print(f"saved {args.out}")

    import gymnasium

    env = gymnasium.make("brachia/Swing-v0", scenario=SCENARIO)
    rng = np.random.default_rng(args.seed)
    scorecard = brachia.benchmark(
        SCENARIO,
        controllers={
            "ppo": EnvPolicy(model, env),
            "random": EnvPolicy(lambda obs: rng.uniform(-1, 1, 3), env),
        },
        builtin=["mpc", "mpc+replan", "tvlqr"],
        levels=args.levels,
        monte_carlo_runs=args.monte_carlo,
        seed=args.seed,
    )
    if "plan_status" in scorecard:
        raise SystemExit(f"the scenario's plan did not converge: {scorecard['plan_status']}")
    print(scorecard["summary_md"])


if __name__ == "__main__":
    main()
