"""Benchmark: environment steps per second of random actions, brachia/Swing-v0 against Gymnasium's
MuJoCo InvertedDoublePendulum-v5 and classic-control Acrobot-v1, measured in the same run.

Swing-v0 runs at its defaults (10 ms control period, the plant integrating at 1 ms underneath,
the model plant unless ``--plant rapier``), once as a single env made by ``gymnasium.make`` and once
as the 64-copy vector env (one Rust call per step for all copies, in parallel). Every env is made by
``gymnasium.make`` (with its default wrappers), stepped with pre-drawn uniform random actions and
reset when an episode ends (resets are counted in the time). Each measurement is repeated
``--rounds`` times, interleaved, and the median is reported; the ratios divide by the median of
InvertedDoublePendulum-v5. Timings on a loaded machine are inflated: compare the ratios.

    pip install "gymnasium[mujoco]"
    python python/bench/env_steps.py [--steps 20000] [--rounds 3] [--envs 64] [--plant model]
"""

import argparse
import statistics
import time

import gymnasium
import numpy as np

import brachia  # noqa: F401  (registers brachia/Swing-v0)
from brachia.vector import SwingVectorEnv


def single_rate(make, steps: int, seed: int) -> float:
    """Steps per second of one env made by `make`."""
    env = make()
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(512)]
    clock = time.perf_counter
    t0 = clock()
    for k in range(steps):
        _, _, terminated, truncated, _ = env.step(actions[k % 512])
        if terminated or truncated:
            env.reset()
    rate = steps / (clock() - t0)
    env.close()
    return rate


def vector_rate(num_envs: int, steps: int, seed: int, plant: str) -> float:
    """Environment steps per second of the Swing-v0 vector env (copies x calls / time)."""
    env = SwingVectorEnv(num_envs, plant=plant)
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(64)]
    calls = max(1, steps // num_envs)
    clock = time.perf_counter
    t0 = clock()
    for k in range(calls):
        env.step(actions[k % 64])
    rate = calls * num_envs / (clock() - t0)
    env.close()
    return rate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20000, help="env steps per measurement")
    ap.add_argument("--rounds", type=int, default=3, help="repetitions (median reported)")
    ap.add_argument("--envs", type=int, default=64, help="copies in the vector env")
    ap.add_argument("--plant", choices=["model", "rapier"], default="model")
    args = ap.parse_args()

    runs = {
        "Swing-v0 (single)": lambda s: single_rate(
            lambda: gymnasium.make("brachia/Swing-v0", plant=args.plant), args.steps, s
        ),
        f"Swing-v0 (vector, {args.envs} copies)": lambda s: vector_rate(
            args.envs, args.steps, s, args.plant
        ),
        "InvertedDoublePendulum-v5": lambda s: single_rate(
            lambda: gymnasium.make("InvertedDoublePendulum-v5"), args.steps, s
        ),
        "Acrobot-v1": lambda s: single_rate(lambda: gymnasium.make("Acrobot-v1"), args.steps, s),
    }
    rates: dict[str, list[float]] = {k: [] for k in runs}
    for r in range(args.rounds):
        for name, run in runs.items():
            rates[name].append(run(r))
    med = {k: statistics.median(v) for k, v in rates.items()}
    idp = med["InvertedDoublePendulum-v5"]
    acro = med["Acrobot-v1"]
    print(
        f"steps/s of random actions, median of {args.rounds} "
        f"(Swing-v0: {args.plant} plant, 10 ms control, 1 ms plant step)"
    )
    print(f"{'env':36s} {'steps/s':>10s} {'x IDP-v5':>9s} {'x Acrobot':>9s}")
    for name, v in med.items():
        print(f"{name:36s} {v:10.0f} {v / idp:9.2f} {v / acro:9.2f}")
    print("all rounds:", {k: [round(x) for x in v] for k, v in rates.items()})


if __name__ == "__main__":
    np.set_printoptions(precision=3)
    main()
