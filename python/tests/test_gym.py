"""brachia/Swing-v0 and its vector env: Gymnasium's checker on both plants, the reset/step contract,
termination and truncation, seeding, randomised disturbances, the vector env against single envs,
rendering, the SB3 adapter's core and policies as controllers. Needs gymnasium (not torch)."""

import subprocess
import sys

import numpy as np
import pytest

import brachia

gymnasium = pytest.importorskip("gymnasium")
from gymnasium.utils.env_checker import check_env  # noqa: E402

from brachia.envs import SwingEnv  # noqa: E402
from brachia.policy import EnvPolicy  # noqa: E402
from brachia.sb3 import SwingVecEnvCore  # noqa: E402
from brachia.vector import SwingVectorEnv  # noqa: E402

RANGES = {
    "mass_scale": [{"uniform": [0.9, 1.1]}, 1.0, 1.0, {"uniform": [0.8, 1.2]}],
    "noise_q_std": {"uniform": [0.0, 0.002]},
    "actuation_delay_s": 0.01,
}


def capture_scenario(tmp_path, root, offset=0.01):
    """A scenario whose bar is `offset` m right of the hand at rest (captured on the first step)."""
    q0 = [-2.35, 0.0, -1.55, 0.0]
    hand = brachia.Robot.paper().ee_position(q0)
    path = tmp_path / "capture.toml"
    path.write_text(
        f'params = "{(root / "params" / "paper.toml").as_posix()}"\n'
        f"[task]\nq0 = {q0}\ntarget = [{hand[0] + offset}, {hand[1]}]\n"
    )
    return path


def rollout(env, seed, steps, options=None):
    """Observations, rewards and flags of `steps` steps of seeded random actions (reset on end)."""
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed, options=options)
    out = [obs.tobytes()]
    for _ in range(steps):
        a = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        obs, r, te, tr, _ = env.step(a)
        out.append((obs.tobytes(), r, te, tr))
        if te or tr:
            obs, _ = env.reset()
            out.append(obs.tobytes())
    return out


def test_make_finds_the_env_after_import():
    env = gymnasium.make("brachia/Swing-v0")
    assert isinstance(env.unwrapped, SwingEnv)
    assert env.observation_space.dtype == np.float32 and env.observation_space.shape == (11,)
    assert env.action_space.dtype == np.float32 and env.action_space.shape == (3,)
    assert np.all(env.action_space.low == -1) and np.all(env.action_space.high == 1)
    assert np.all(np.isfinite(env.observation_space.low))
    assert np.all(np.isfinite(env.observation_space.high))
    vec = gymnasium.make_vec("brachia/Swing-v0", num_envs=2, vectorization_mode="vector_entry_point")
    assert isinstance(vec, SwingVectorEnv) and vec.num_envs == 2


@pytest.mark.parametrize("plant", ["model", "rapier"])
def test_env_checker_passes(plant):
    env = gymnasium.make("brachia/Swing-v0", plant=plant, render_mode="rgb_array")
    check_env(env.unwrapped, skip_render_check=False)


def test_first_observation_is_the_start_state_and_the_bar_from_the_hand():
    env = SwingEnv()
    obs, info = env.reset(seed=3)
    q0 = np.array([-2.35, 0.0, -1.55, 0.0])
    np.testing.assert_allclose(obs[:4], q0, atol=1e-6)
    np.testing.assert_array_equal(obs[4:8], 0.0)
    hand = brachia.Robot.paper().ee_position(q0)
    np.testing.assert_allclose(obs[8:10], np.array([0.8, 0.0]) - hand, atol=1e-6)
    assert obs[10] == pytest.approx(3.0)
    assert info["episode_seed"] == env.episode["seed"]


def test_same_seed_same_episode_bit_for_bit():
    for kw in [{}, {"disturbances": RANGES}, {"plant": "rapier", "time_limit_s": 0.3}]:
        a = rollout(SwingEnv(**kw), seed=11, steps=60)
        b = rollout(SwingEnv(**kw), seed=11, steps=60)
        assert a == b
        c = rollout(SwingEnv(**kw), seed=12, steps=60)
        if kw.get("disturbances"):
            assert a != c  # other draws, other noise


def test_actions_scale_the_torque_range_and_are_clipped():
    env = SwingEnv(reward={"positive_work": 0.0, "progress": 0.0, "energy": 1.0})
    env.reset(seed=0)
    _, r_one, *_ = env.step(np.ones(3, dtype=np.float32))
    env.reset(seed=0)
    _, r_big, *_ = env.step(np.full(3, 7.0))
    assert r_one == r_big  # clipped to 1: the same torque
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros(3))
    assert info["energy_j"] == 0.0  # the paper robot's range is symmetric: action 0 is no torque


def test_bad_actions_and_options_are_refused():
    env = SwingEnv()
    env.reset(seed=0)
    with pytest.raises(brachia.BrachiaError, match="action"):
        env.step(np.zeros(2))
    with pytest.raises(brachia.BrachiaError, match=r"action\[1\]"):
        env.step(np.array([0.0, np.nan, 0.0]))
    with pytest.raises(ValueError, match="unknown keys"):
        env.reset(options={"bogus": 1})
    with pytest.raises(ValueError, match="seed"):
        env.reset(seed=-1)
    with pytest.raises(brachia.BrachiaError, match="control_dt"):
        SwingEnv(control_dt=0.0105)
    with pytest.raises(brachia.BrachiaError, match="plant"):
        SwingEnv(plant="mujoco")


def test_capture_terminates_with_the_bonus(tmp_path, root):
    env = SwingEnv(scenario=capture_scenario(tmp_path, root))
    env.reset(seed=0)
    obs, r, te, tr, info = env.step(np.zeros(3))
    assert te and not tr and info["captured"]
    assert info["distance_m"] <= brachia.SUCCESS_RADIUS_M
    assert r == pytest.approx(10.0 + 5.0 * info["progress_m"])
    with pytest.raises(brachia.BrachiaError, match="reset"):
        env.step(np.zeros(3))
    # 3 cm away is outside the success radius: no capture
    env = SwingEnv(scenario=capture_scenario(tmp_path, root, offset=0.03))
    env.reset(seed=0)
    assert not env.step(np.zeros(3))[2]


def test_leaving_the_limits_terminates_with_the_penalty():
    env = SwingEnv(max_rate_rad_s=0.5)
    env.reset(seed=0)
    for k in range(100):
        obs, r, te, tr, info = env.step(np.ones(3))
        if te:
            break
    assert te and info["out_of_limits"] and not info["captured"]
    assert r < -4.0
    assert env.observation_space.contains(obs)


def test_time_limit_truncates():
    env = SwingEnv(time_limit_s=0.05)
    obs, _ = env.reset(seed=0)
    flags = [env.step(np.zeros(3))[2:4] for _ in range(5)]
    assert flags[:4] == [(False, False)] * 4 and flags[4] == (False, True)
    assert env.episode["t"] == pytest.approx(0.05)


def test_randomised_disturbances_are_drawn_per_episode_within_their_ranges():
    env = SwingEnv(disturbances=RANGES)
    draws = []
    for k in range(20):
        _, info = env.reset(seed=100 + k) if k == 0 else env.reset()
        d = info["disturbances"]
        assert 0.9 <= d["mass_scale"][0] <= 1.1 and 0.8 <= d["mass_scale"][3] <= 1.2
        assert d["mass_scale"][1:3] == [1.0, 1.0]
        assert 0.0 <= d["noise_q_std"] <= 0.002 and d["actuation_delay_s"] == 0.01
        draws.append((d["mass_scale"][0], d["noise_q_std"], d["seed"]))
    assert len(set(draws)) == 20
    # options set one episode's disturbances; the next reset is back to the env's
    _, info = env.reset(options={"disturbances": {"mass_scale": [2.0, 1.0, 1.0, 1.0]}})
    assert info["disturbances"]["mass_scale"] == [2.0, 1.0, 1.0, 1.0]
    assert env.episode["disturbances"]["actuation_delay_s"] == 0.0
    _, info = env.reset()
    assert 0.9 <= info["disturbances"]["mass_scale"][0] <= 1.1


def test_a_heavier_plant_swings_differently():
    base = rollout(SwingEnv(), seed=5, steps=30)
    heavy = rollout(SwingEnv(disturbances={"mass_scale": [1.5, 1.0, 1.0, 1.0]}), seed=5, steps=30)
    assert base[0] == heavy[0] and base[5] != heavy[5]


def test_bad_ranges_are_refused_before_any_episode():
    with pytest.raises(brachia.BrachiaError, match=r"mass_scale\[0\].uniform"):
        SwingEnv(disturbances={"mass_scale": [{"uniform": [1.2, 0.8]}, 1, 1, 1]})
    with pytest.raises(brachia.BrachiaError, match=r"mass_scale\[0\]"):
        SwingEnv(disturbances={"mass_scale": [{"uniform": [0.5, 20.0]}, 1, 1, 1]})
    with pytest.raises(brachia.BrachiaError, match="unknown field"):
        SwingEnv(disturbances={"mass_scal": [1, 1, 1, 1]})
    env = SwingEnv()
    with pytest.raises(brachia.BrachiaError, match="noise_q_std"):
        env.reset(options={"disturbances": {"noise_q_std": -1.0}})


@pytest.mark.parametrize("mode", ["next-step", "same-step"])
def test_vector_env_equals_single_envs_stepped_one_by_one(mode):
    kw = {"disturbances": RANGES, "time_limit_s": 0.08}
    m, steps = 3, 20
    vec = SwingVectorEnv(m, autoreset_mode=mode, **kw)
    singles = [SwingEnv(**kw) for _ in range(m)]
    obs, _ = vec.reset(seed=40)
    for i, e in enumerate(singles):
        o, _ = e.reset(seed=40 + i)
        assert o.tobytes() == obs[i].tobytes()
    rng = np.random.default_rng(0)
    pending = [False] * m
    ended_any = False
    for _ in range(steps):
        a = rng.uniform(-1, 1, (m, 3)).astype(np.float32)
        obs, rew, te, tr, info = vec.step(a)
        for i, e in enumerate(singles):
            if pending[i]:  # next-step autoreset: this step is the reset
                o, _ = e.reset()
                r, t1, t2 = 0.0, False, False
                pending[i] = False
            else:
                o, r, t1, t2, _ = e.step(a[i])
                if t1 or t2:
                    ended_any = True
                    if mode == "next-step":
                        pending[i] = True
                    else:
                        assert info["final_obs"][i].tobytes() == o.tobytes()
                        o, _ = e.reset()
            assert o.tobytes() == obs[i].tobytes()
            assert (r, t1, t2) == (rew[i], te[i], tr[i])
    assert ended_any
    assert vec.observation_space.contains(obs)


def test_vector_env_refuses_bad_actions_without_stepping():
    vec = SwingVectorEnv(2)
    vec.reset(seed=0)
    t0 = [e["t"] for e in vec.episodes]
    with pytest.raises(brachia.BrachiaError, match="actions"):
        vec.step(np.zeros((3, 3)))
    with pytest.raises(brachia.BrachiaError, match=r"actions\[1, 2\]"):
        vec.step(np.array([[0, 0, 0], [0, 0, np.inf]], dtype=np.float32))
    assert [e["t"] for e in vec.episodes] == t0


def test_render_draws_the_pose():
    env = SwingEnv(render_mode="rgb_array", render_size=(200, 150))
    env.reset(seed=0)
    img = env.render()
    assert img.shape == (150, 200, 3) and img.dtype == np.uint8
    assert (img < 200).any() and (img == 255).any()  # ink on a white page
    assert SwingEnv().render() is None


def test_sb3_core_reports_terminal_observations():
    core = SwingVecEnvCore(num_envs=2, seed=1, time_limit_s=0.03)
    obs = core.reset()
    assert obs.shape == (2, 11)
    for k in range(3):
        core.step_async(np.zeros((2, 3)))
        obs, rew, dones, infos = core.step_wait()
    assert dones.all()
    for d in infos:
        assert d["TimeLimit.truncated"] and d["terminal_observation"].shape == (11,)
        assert d["episode"]["l"] == 3
    assert obs[0, 10] == pytest.approx(0.03)  # the new episode's time left


def test_importing_the_adapter_imports_neither_sb3_nor_torch():
    # a fresh interpreter: other tests run in this one may have imported stable_baselines3
    code = (
        "import sys, brachia, brachia.sb3;"
        "assert 'stable_baselines3' not in sys.modules and 'torch' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_a_callable_is_a_controller(tracking_plan, robot):
    calls = []

    def zero(t, x):
        calls.append(t)
        return np.zeros(3)

    res = brachia.track(robot, tracking_plan, controller=zero, control_dt=0.01, duration=0.1)
    assert len(calls) == 10 and calls[0] == 0.0
    np.testing.assert_array_equal(res.tau, 0.0)
    # the same free motion as the model plant stepped by hand
    plant = brachia.ModelPlant(robot, res.x[0])
    for _ in range(10):
        plant.step(np.zeros(3), 0.01)
    np.testing.assert_allclose(res.x[-1], plant.state(), rtol=0, atol=1e-12)

    def broken(t, x):
        if t > 0.03:
            raise KeyError("policy failed")
        return np.zeros(3)

    with pytest.raises(KeyError, match="policy failed"):
        brachia.track(robot, tracking_plan, controller=broken, control_dt=0.01, duration=0.1)
    with pytest.raises(brachia.BrachiaError, match="policy"):
        brachia.track(robot, tracking_plan, controller=lambda t, x: np.zeros(2), duration=0.01)


def test_env_policy_sees_what_the_env_sees_and_acts_the_same(tracking_plan, robot):
    env = SwingEnv()
    obs, _ = env.reset(seed=0)
    actions = np.random.default_rng(1).uniform(-1, 1, (8, 3)).astype(np.float32)
    seen = []

    def scripted(o):
        seen.append(o)
        return actions[len(seen) - 1]

    pol = EnvPolicy(scripted, env)
    assert pol(0.0, env.episode["true_state"]) is not None
    np.testing.assert_array_equal(seen[0], obs)
    for k in range(1, 8):
        obs, *_ = env.step(actions[k - 1])
        pol(k * env.control_dt, np.asarray(env.episode["true_state"]))
        np.testing.assert_allclose(seen[k], obs, rtol=0, atol=1e-6)
    # in a closed loop at 1 ms the action is held for the env's 10 ms period
    seen.clear()
    pol = EnvPolicy(lambda o: (seen.append(o), np.ones(3))[1], env)
    res = brachia.track(robot, tracking_plan, controller=pol, control_dt=0.001, duration=0.05)
    assert len(seen) == 5
    np.testing.assert_allclose(res.tau[0], robot.tau_max)


class MpcPolicy:
    """The MPC as a Python callable (reset before each benchmark run, as a fresh MPC would be)."""

    def __init__(self, robot, plan, settings):
        self.mpc = brachia.Mpc(robot, plan, settings)

    def reset(self):
        self.mpc.reset()

    def __call__(self, t, x):
        return self.mpc.control(t, x)


def runs_by_controller(csv):
    schema, *lines = csv.strip().splitlines()
    assert schema == "# brachia runs schema 2"
    head = lines[0].split(",")
    rows = [dict(zip(head, line.split(","))) for line in lines[1:]]
    out = {}
    for r in rows:
        out.setdefault(r["controller"], []).append(r)
    return out


def test_benchmark_scores_python_policies_beside_the_builtin_mpc(scenario, tracking_plan, robot):
    rng = np.random.default_rng(0)

    def random_policy(t, x):
        return rng.uniform(-10.0, 10.0, 3)

    policies = {
        "mpc-python": MpcPolicy(robot, tracking_plan, scenario.mpc_settings),
        "random": random_policy,
    }
    out = brachia.benchmark(
        scenario, controllers=policies, builtin=["mpc"], levels=2, monte_carlo_runs=0,
        family_runs=0, sweeps=["mass"],
    )
    names = [c["controller"] for c in out["scorecard"]["controllers"]]
    assert names == ["mpc", "mpc-python", "random"]
    runs = runs_by_controller(out["runs_csv"])
    assert len(runs["mpc"]) == len(runs["mpc-python"]) == len(runs["random"]) == 2
    # the MPC through the Python path scores as the built-in one on the same draws
    for a, b in zip(runs["mpc"], runs["mpc-python"]):
        assert (a["level"], a["seed"]) == (b["level"], b["seed"])
        assert a["success"] == b["success"] and a["final_error_m"] == b["final_error_m"]
        assert a["energy_j"] == b["energy_j"]
    assert runs["mpc"][0]["level"] == "0" and runs["mpc"][0]["success"] == "1"  # undisturbed
    assert all(r["success"] == "0" for r in runs["random"])
    assert "random" in out["summary_md"]


def test_benchmark_refuses_taken_names_and_raises_a_policy_error(scenario):
    with pytest.raises(brachia.BrachiaError, match="controllers"):
        brachia.benchmark(scenario, controllers={"mpc": lambda t, x: np.zeros(3)},
                          builtin=[], levels=2, monte_carlo_runs=0, sweeps=["mass"])

    def broken(t, x):
        raise ZeroDivisionError("policy failed")

    with pytest.raises(ZeroDivisionError, match="policy failed"):
        brachia.benchmark(scenario, controllers={"broken": broken}, builtin=[], levels=2,
                          monte_carlo_runs=0, sweeps=["mass"])
