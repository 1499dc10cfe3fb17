"""A sweep of the newer Python surfaces written as an outside user would try them: the learning
environments (settings, disturbances, reset options, actions of every wrong kind, vector envs of 0 or
a million copies), ``brachia.benchmark(family_runs=...)``, ``Robot.from_urdf`` on hostile files, and
``track`` with a Python controller that returns the wrong thing or raises. Each bad input is refused
with ``BrachiaError`` or ``ValueError`` naming the argument, fast (before any episode, run or plan),
and nothing returns NaN.

Units: s, m, rad, N m.
"""

import math
import os
import time

import numpy as np
import pytest

import brachia

gymnasium = pytest.importorskip("gymnasium")

HOOK = "crates/core/tests/data/urdf/hook2.urdf"


def refused(call, *words):
    """``call()`` raises ValueError (BrachiaError is one) naming every word, within 1 s."""
    start = time.perf_counter()
    with pytest.raises(ValueError) as e:
        call()
    took = time.perf_counter() - start
    msg = str(e.value)
    for w in words:
        assert w in msg, f"{w!r} not in {msg!r}"
    assert took < 1.0, f"the refusal took {took:.2f} s"
    return msg


# ---------------------------------------------------------------------------------------------
# The Gymnasium environment: settings and disturbances


@pytest.mark.parametrize(
    "settings, words",
    [
        ({"control_dt": 0.0}, ["control_dt"]),
        ({"control_dt": float("nan")}, ["control_dt"]),
        ({"control_dt": -0.01}, ["control_dt"]),
        ({"control_dt": 1.0}, ["control_dt"]),
        ({"control_dt": 0.0015}, ["control_dt"]),
        ({"plant_dt": 0.0}, ["plant_dt"]),
        ({"plant_dt": 1e-300}, ["plant_dt"]),
        ({"time_limit_s": 0.0}, ["time_limit_s"]),
        ({"time_limit_s": 1e9}, ["time_limit_s"]),
        ({"time_limit_s": float("inf")}, ["time_limit_s"]),
        # the capture rule is the benchmark's, not a setting of the environment
        ({"capture_speed_m_s": 0.5}, ["capture_speed_m_s"]),
        ({"max_rate_rad_s": -1.0}, ["max_rate_rad_s"]),
        ({"gravity_boost": 2.0}, ["gravity_boost"]),
        ({"reward": {"capture": float("nan")}}, ["capture"]),
        ({"reward": {"bonus": 1.0}}, ["bonus"]),
    ],
)
def test_env_settings_are_refused_before_any_episode(settings, words):
    refused(lambda: gymnasium.make("brachia/Swing-v0", **settings), *words)


@pytest.mark.parametrize(
    "dist, words",
    [
        ({"mass_scale": {"uniform": [2.0, 1.0]}}, ["mass_scale"]),
        ({"mass_scale": {"uniform": [float("nan"), 1.0]}}, ["mass_scale"]),
        ({"mass_scale": [{"uniform": [0.01, 1.0]}, 1.0, 1.0, 1.0]}, ["mass_scale"]),
        ({"mass_scale": "heavy"}, ["mass_scale"]),
        ({"coulomb_nm": 1e9}, ["coulomb_nm"]),
        ({"coulomb_nm": {"uniform": [0.0, float("inf")]}}, ["coulomb_nm"]),
        ({"start_offset": [float("nan")] * 8}, ["start_offset"]),
        ({"pushes": [{"t_s": 100.0, "link": 4, "point_m": 0.1, "impulse_n_s": [0.0, 0.2]}]}, ["t_s"]),
        ({"pushes": [{"t_s": 0.5, "link": 9, "point_m": 0.1, "impulse_n_s": [0.0, 0.2]}]}, ["link"]),
        ({"pushes": [{"t_s": 0.5, "link": 4, "point_m": 0.1, "impulse_n_s": [0.0, 0.2, 0.5]}]}, ["pushes", "exactly 2"]),
        ({"wind": 1.0}, ["wind"]),
    ],
)
def test_env_disturbances_are_refused_at_construction_and_at_reset(dist, words):
    refused(lambda: gymnasium.make("brachia/Swing-v0", disturbances=dist), *words)
    env = gymnasium.make("brachia/Swing-v0")
    refused(lambda: env.reset(seed=0, options={"disturbances": dist}), *words)
    # the refused options changed nothing: the next episode runs
    obs, _ = env.reset(seed=0)
    assert np.all(np.isfinite(obs))


@pytest.mark.parametrize("seed", [-1, 2.5, "7", 2**64, float("nan")])
def test_reset_seeds_that_are_not_unsigned_integers_are_refused(seed):
    env = gymnasium.make("brachia/Swing-v0")
    refused(lambda: env.reset(seed=seed), "seed")


def test_reset_options_with_unknown_keys_are_refused():
    env = gymnasium.make("brachia/Swing-v0")
    refused(lambda: env.reset(seed=0, options={"disturbance": {}}), "disturbance")


# ---------------------------------------------------------------------------------------------
# Actions


@pytest.fixture()
def env():
    e = gymnasium.make("brachia/Swing-v0")
    e.reset(seed=3)
    return e


@pytest.mark.parametrize(
    "action, words",
    [
        (np.array([np.nan, 0.0, 0.0], dtype=np.float32), ["action"]),
        (np.array([np.inf, 0.0, 0.0]), ["action"]),
        (np.zeros(2, dtype=np.float32), ["action"]),
        (np.zeros((3, 3), dtype=np.float32), ["action"]),
        (np.zeros(4, dtype=np.float32), ["action"]),
        (np.array(["a", "b", "c"]), ["action"]),
        (np.array([1 + 1j, 0, 0]), ["action"]),
    ],
)
def test_actions_of_the_wrong_kind_are_refused(env, action, words):
    refused(lambda: env.step(action), *words)


def test_a_big_endian_action_steps_as_the_native_one():
    a = gymnasium.make("brachia/Swing-v0")
    b = gymnasium.make("brachia/Swing-v0")
    a.reset(seed=5)
    b.reset(seed=5)
    act = np.array([0.3, -0.2, 0.5])
    for _ in range(5):
        oa = a.step(act.astype(np.float32))[0]
        ob = b.step(act.astype(">f4"))[0]
        assert np.array_equal(oa, ob)


def test_a_list_action_steps_as_an_array(env):
    obs = env.step([0.1, 0.0, -0.1])[0]
    assert np.all(np.isfinite(obs))


# ---------------------------------------------------------------------------------------------
# Vector environments


@pytest.mark.parametrize("n", [0, -1, 65_537, 1_000_000, 2.5, True])
def test_vector_env_sizes_outside_the_limit_are_refused_at_once(n):
    refused(
        lambda: gymnasium.make_vec("brachia/Swing-v0", num_envs=n, vectorization_mode="vector_entry_point"),
        "num_envs",
    )


def test_vector_env_actions_of_the_wrong_shape_or_value_are_refused():
    v = gymnasium.make_vec("brachia/Swing-v0", num_envs=2, vectorization_mode="vector_entry_point")
    v.reset(seed=1)
    refused(lambda: v.step(np.zeros((3, 3), dtype=np.float32)), "action")
    refused(lambda: v.step(np.zeros(3, dtype=np.float32)), "action")
    bad = np.zeros((2, 3), dtype=np.float32)
    bad[1, 2] = np.nan
    refused(lambda: v.step(bad), "action")
    # the vector env still steps
    obs = v.step(np.zeros((2, 3), dtype=np.float32))[0]
    assert obs.shape[0] == 2 and np.all(np.isfinite(obs))


def test_a_one_copy_vector_env_runs():
    v = gymnasium.make_vec("brachia/Swing-v0", num_envs=1, vectorization_mode="vector_entry_point")
    obs, _ = v.reset(seed=2)
    assert obs.shape[0] == 1
    obs = v.step(np.zeros((1, 3), dtype=np.float32))[0]
    assert np.all(np.isfinite(obs))


# ---------------------------------------------------------------------------------------------
# brachia.benchmark(family_runs=..., seed=...)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"family_runs": -1}, ["family_runs"]),
        ({"family_runs": 10_001}, ["family_runs"]),
        ({"family_runs": 2.5}, ["family_runs", "whole number"]),
        ({"family_runs": "3"}, ["family_runs", "whole number"]),
        ({"family_runs": float("nan")}, ["family_runs", "whole number"]),
        ({"family_runs": True}, ["family_runs", "whole number"]),
        ({"monte_carlo_runs": 10**7}, ["monte_carlo_runs"]),
        ({"levels": 1}, ["levels"]),
        ({"seed": -1}, ["seed"]),
        ({"seed": 2**64}, ["seed"]),
        ({"sweeps": ["wind"]}, ["wind"]),
        ({"builtin": ["lqr"]}, ["lqr"]),
    ],
)
def test_benchmark_counts_and_seeds_are_refused_before_any_run(root, kwargs, words):
    sc = str(root / "scenarios" / "tracking.toml")
    refused(lambda: brachia.benchmark(sc, **kwargs), *words)


# ---------------------------------------------------------------------------------------------
# Robot.from_urdf


def hook_text(root):
    return (root / HOOK).read_text()


@pytest.mark.parametrize(
    "edit, words",
    [
        (('<mass value="0.9"/>', '<mass value="nan"/>'), ["arm", "mass"]),
        (('<mass value="0.9"/>', '<mass value="-0.9"/>'), ["arm", "mass"]),
        (('ixx="0.009"', 'ixx="-0.009"'), ["forearm", "inertia"]),
        (('<axis xyz="-1 0 0"/>', '<axis xyz="0 1 0"/>'), ["elbow", "axis"]),
        (('effort="6"', 'effort="0"'), ["elbow", "effort"]),
        (('type="revolute"', 'type="prismatic"'), ["elbow", "Prismatic"]),
        (("</robot>", ""), []),
    ],
)
def test_from_urdf_refuses_a_damaged_file_naming_the_element(tmp_path, root, edit, words):
    f = tmp_path / "robot.urdf"
    f.write_text(hook_text(root).replace(*edit, 1))
    refused(lambda: brachia.Robot.from_urdf(f, "hand", "hook"), str(f), *words)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"grip": "nope", "tip": "hook"}, ["nope"]),
        ({"grip": "hand", "tip": "nope"}, ["nope"]),
        ({"grip": "hand", "tip": "hook:nan,0,0"}, ["tip"]),
        ({"grip": "hand", "tip": "hook:0,0"}, ["tip"]),
        ({"grip": "hand", "tip": "hook", "passive": ["nope"]}, ["nope"]),
        ({"grip": "hand", "tip": "hook", "ignore": ["nope"]}, ["nope"]),
        ({"grip": "hand", "tip": "hook", "gravity": float("nan")}, ["gravity"]),
        ({"grip": "hand", "tip": "hook", "gravity": -9.81}, ["gravity"]),
        ({"grip": "hand", "tip": "hook", "gravity": 1e300}, ["gravity"]),
    ],
)
def test_from_urdf_refuses_hostile_arguments(root, kwargs, words):
    refused(lambda: brachia.Robot.from_urdf(root / HOOK, **kwargs), *words)


def test_from_urdf_refuses_what_is_not_a_file(tmp_path):
    refused(lambda: brachia.Robot.from_urdf(tmp_path, "hand", "hook"), str(tmp_path))
    refused(lambda: brachia.Robot.from_urdf("/dev/zero", "hand", "hook"), "/dev/zero")
    refused(lambda: brachia.Robot.from_urdf(tmp_path / "nope.urdf", "hand", "hook"), "nope.urdf")
    loop = tmp_path / "loop.urdf"
    os.symlink(loop, loop)
    refused(lambda: brachia.Robot.from_urdf(loop, "hand", "hook"), "loop.urdf")
    fifo = tmp_path / "fifo.urdf"
    os.mkfifo(fifo)
    refused(lambda: brachia.Robot.from_urdf(fifo, "hand", "hook"), "fifo.urdf")


def test_from_urdf_refuses_a_chain_of_100000_links_fast(tmp_path):
    parts = ['<?xml version="1.0"?>\n<robot name="chain">\n<link name="world"/>\n']
    for k in range(1, 100_001):
        parent = "world" if k == 1 else f"l{k - 1}"
        parts.append(
            f'<joint name="j{k}" type="revolute"><origin xyz="0 0 -0.1"/><parent link="{parent}"/>'
            f'<child link="l{k}"/><axis xyz="0 1 0"/><limit effort="5" velocity="10"/></joint>\n'
            f'<link name="l{k}"><inertial><mass value="0.1"/><inertia ixx="0.001" ixy="0" ixz="0" '
            'iyy="0.001" iyz="0" izz="0.001"/></inertial></link>\n'
        )
    parts.append("</robot>\n")
    f = tmp_path / "chain.urdf"
    f.write_text("".join(parts))
    refused(lambda: brachia.Robot.from_urdf(f, "j1", "l100000"), str(f))


# ---------------------------------------------------------------------------------------------
# track(controller=callable)


@pytest.mark.parametrize(
    "policy, words",
    [
        (lambda t, x: np.zeros(2), ["policy", "3 values"]),
        (lambda t, x: np.zeros((3, 1)), ["policy", "3 values"]),
        (lambda t, x: np.array([np.nan, 0.0, 0.0]), ["policy", "finite"]),
        (lambda t, x: np.array([np.inf, 0.0, 0.0]), ["policy", "finite"]),
        (lambda t, x: "torque", ["policy", "number"]),
        (lambda t, x: None, ["policy"]),
    ],
)
def test_a_python_controller_returning_the_wrong_thing_is_refused(robot, tracking_plan, policy, words):
    with pytest.raises(ValueError) as e:
        brachia.track(robot, tracking_plan, controller=policy, duration=0.05)
    for w in words:
        assert w in str(e.value), str(e.value)


def test_a_python_controller_that_raises_reaches_the_caller(robot, tracking_plan):
    class Boom(RuntimeError):
        pass

    def policy(t, x):
        if t > 0.01:
            raise Boom("the policy failed")
        return np.zeros(3)

    with pytest.raises(Boom):
        brachia.track(robot, tracking_plan, controller=policy, duration=0.05)


def test_a_big_endian_controller_output_is_read_as_the_native_one(robot, tracking_plan):
    def native(t, x):
        return np.array([0.1, -0.2, 0.3])

    def swapped(t, x):
        return np.array([0.1, -0.2, 0.3]).astype(">f8")

    a = brachia.track(robot, tracking_plan, controller=native, duration=0.05)
    b = brachia.track(robot, tracking_plan, controller=swapped, duration=0.05)
    assert np.array_equal(a.x, b.x)
    assert not math.isnan(float(np.asarray(a.x).sum()))


# ---------------------------------------------------------------------------------------------
# Objects used from several threads


def test_an_env_stepped_from_several_threads_never_panics():
    import threading

    env = gymnasium.make("brachia/Swing-v0")
    env.reset(seed=0)
    errors = []

    def worker():
        try:
            for _ in range(50):
                obs = env.step(np.zeros(3, dtype=np.float32))[0]
                assert np.all(np.isfinite(obs))
        except BaseException as e:  # noqa: BLE001 - a PanicException is a BaseException
            errors.append(e)

    threads = [threading.Thread(target=worker) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for e in errors:
        assert "Panic" not in type(e).__name__, repr(e)
        assert "Already borrowed" not in str(e), repr(e)
        # a refusal says what is wrong (an episode that ended) in words
        assert isinstance(e, (ValueError, RuntimeError)), repr(e)


def test_urdf_robots_load_from_several_threads_at_once(root):
    import threading

    out, errors = [], []

    def worker():
        try:
            out.append(brachia.Robot.from_urdf(root / HOOK, "hand", "hook:0,0.03,-0.05"))
        except BaseException as e:  # noqa: BLE001
            errors.append(e)

    threads = [threading.Thread(target=worker) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    q = np.array([-2.3, -0.6])
    m0 = out[0].M(q)
    assert all(np.array_equal(r.M(q), m0) for r in out)
