"""URDF import and URDF/MJCF export checked by independent libraries.

- M(q), C(q, qd) qd and G(q) of the robots in crates/core/tests/data/urdf/ (axes along x, y and a
  skew unit vector, antiparallel axes, centres of mass off the links, rotated joint frames, fixed links
  inside the chain, a zero-length link) against pinocchio on the same files, at random states, to 1e-9
  relative to the largest entry; and the positions of the chain's joints and tip in brachia's plane
  (normal to the grip's axis, y the world's +z projected) against pinocchio's frames, to the same bound.
- The exported MJCF against MuJoCo the same way, and a passive 1 s swing of the paper's robot in MuJoCo
  (RK4 at 0.1 ms) against brachia's model plant (RK4 at 0.1 ms): the end states agree to 1e-6. Both
  integrate the same equations with the same scheme and a step at which RK4's error is far below
  1e-6, so the comparison tests the equations, not the integrators.

Each library is optional: its tests are skipped when it cannot be imported.
"""

import tomllib
from pathlib import Path

import numpy as np
import pytest

import brachia

DATA = Path(__file__).resolve().parents[2] / "crates" / "core" / "tests" / "data" / "urdf"

# (file, grip joint, tip, the chain's moving joints from the grip down)
URDFS = [
    ("hook2.urdf", "hand", "hook:0,0.03,-0.05", ["hand", "elbow"]),
    ("three_link.urdf", "shoulder", "hand:0.22,0,0", ["shoulder", "elbow", "wrist"]),
    ("paper4_skew.urdf", "grip", "tip", ["grip", "j2", "j3", "j4"]),
]

# a robot with every generalised field set (the Rust tests read it too), with asymmetric torque
# limits here: an MJCF control range has two ends (a URDF's effort limit has one)
GENERAL_SYMMETRIC = (DATA.parent / "general.toml").read_text()
GENERAL = GENERAL_SYMMETRIC.replace("tau_max = [4.0, 3.0]", "tau_max = [3.5, 2.0]")
assert GENERAL != GENERAL_SYMMETRIC


def brachia_in_phi(robot, phi, phid):
    """M, C qd, G of a brachia robot in the robot's own joint angles (rates)."""
    s = robot.qd_to_urdf(np.ones(robot.n_links))
    q = robot.q_from_urdf(phi)
    qd = s * phid
    m = robot.M(q) * np.outer(s, s)
    return m, s * robot.Cqd(q, qd), s * robot.G(q)


def assert_close(a, b, what, tol=1e-9):
    scale = max(np.max(np.abs(b)), 1e-300)
    err = np.max(np.abs(a - b)) / scale
    assert err < tol, f"{what}: relative error {err:.3e}\n{a}\nvs\n{b}"


def test_joint_angle_maps_round_trip():
    r = brachia.Robot.from_urdf(DATA / "hook2.urdf", grip="hand", tip="hook")
    phi = np.array([0.3, -1.1])
    assert np.allclose(r.q_to_urdf(r.q_from_urdf(phi)), phi, atol=1e-15)
    # a whole trajectory at once, row by row the same
    rows = np.array([[0.3, -1.1], [-0.2, 0.7], [1.0, 0.0]])
    whole = r.q_to_urdf(r.q_from_urdf(rows))
    assert whole.shape == rows.shape
    for k in range(len(rows)):
        assert np.array_equal(r.q_from_urdf(rows)[k], r.q_from_urdf(rows[k]))
    assert np.allclose(whole, rows, atol=1e-15)
    assert r.qd_to_urdf(rows).shape == rows.shape
    with pytest.raises(brachia.BrachiaError):
        r.q_to_urdf(np.zeros((3, 5)))
    with pytest.raises(brachia.BrachiaError):
        r.q_to_urdf(np.zeros((2, 2, 2)))


REFUSALS = tomllib.loads((DATA / "refusals.toml").read_text())["case"]


@pytest.mark.parametrize("case", REFUSALS, ids=[c["what"] for c in REFUSALS])
def test_refusals_name_the_urdf_element(case, tmp_path):
    """The table the library and the command line refuse (refusals.toml), refused from Python."""
    text = (DATA / "hook2.urdf").read_text()
    for old, new in case.get("replace", []):
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "edited.urdf"
    path.write_text(text)
    with pytest.raises(brachia.BrachiaError) as e:
        brachia.Robot.from_urdf(
            path,
            grip=case.get("grip", "hand"),
            tip=case.get("tip", "hook"),
            passive=case.get("passive", []),
            ignore=case.get("ignore", []),
        )
    assert case["names"] in str(e.value) and "edited.urdf" in str(e.value)


def test_export_round_trip_in_python():
    r = brachia.Robot.from_toml_str(GENERAL, "general.toml")
    text = r.to_urdf()
    assert "<robot" in text and 'name="grip"' in text
    assert "<mujoco" in r.to_mjcf()


def pin_config(pin, model, names, phi, phid):
    q = pin.neutral(model)
    v = np.zeros(model.nv)
    for name, a, w in zip(names, phi, phid):
        jid = model.getJointId(name)
        j = model.joints[jid]
        if j.nq == 2:  # continuous: (cos, sin)
            q[j.idx_q : j.idx_q + 2] = [np.cos(a), np.sin(a)]
        else:
            q[j.idx_q] = a
        v[j.idx_v] = w
    return q, v


def tip_point(tip):
    link, _, point = tip.partition(":")
    return link, (np.array([float(v) for v in point.split(",")]) if point else np.zeros(3))


@pytest.mark.parametrize("file,grip,tip,joints", URDFS)
def test_imported_dynamics_match_pinocchio(file, grip, tip, joints):
    pin = pytest.importorskip("pinocchio")
    robot = brachia.Robot.from_urdf(DATA / file, grip=grip, tip=tip)
    model = pin.buildModelFromUrdf(str(DATA / file))
    data = model.createData()
    n = robot.n_links
    assert model.nv == n == len(joints)
    # brachia's joint k is the URDF joint joints[k]; its velocity in pinocchio's vector
    assert all(model.existJointName(nm) for nm in joints)
    iv = [model.joints[model.getJointId(nm)].idx_v for nm in joints]
    assert sorted(iv) == list(range(n))
    gid = model.getJointId(grip)
    link, point = tip_point(tip)
    fid = model.getFrameId(link, pin.BODY)
    rng = np.random.default_rng(3)
    for _ in range(20):
        phi = rng.uniform(-3.0, 3.0, n)
        phid = rng.uniform(-4.0, 4.0, n)
        q, v = pin_config(pin, model, joints, phi, phid)
        m = pin.crba(model, data, q)
        m = np.triu(m) + np.triu(m, 1).T
        g = pin.computeGeneralizedGravity(model, data, q)
        c = pin.nonLinearEffects(model, data, q, v) - g
        mb, cb, gb = brachia_in_phi(robot, phi, phid)
        assert_close(mb, m[np.ix_(iv, iv)], f"{file} M")
        assert_close(cb, c[iv], f"{file} C qd")
        assert_close(gb, g[iv], f"{file} G")
        # kinematics: the joints and the tip in the plane normal to the grip's axis
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        # the grip's axis in the world: the angular part of its column of the Jacobian
        jac = pin.computeJointJacobian(model, data, q, gid)
        axis = data.oMi[gid].rotation @ jac[3:, model.joints[gid].idx_v]
        zp = np.array([0.0, 0.0, 1.0]) - axis * axis[2]
        ey = zp / np.linalg.norm(zp)
        ex = np.cross(ey, axis)
        o = data.oMi[gid].translation
        pts = [data.oMi[model.getJointId(nm)].translation for nm in joints]
        pts.append(data.oMf[fid].act(point))
        plane = np.array([[(p - o) @ ex, (p - o) @ ey] for p in pts])
        qb = robot.q_from_urdf(phi)
        mine = np.vstack([robot.joint_positions(qb)[:n], robot.ee_position(qb)])
        assert_close(mine, plane, f"{file} joint and tip positions")


def mujoco_state(mujoco, model, data, phi, phid):
    data.qpos[:] = phi
    data.qvel[:] = phid
    mujoco.mj_forward(model, data)
    m = np.zeros((model.nv, model.nv))
    if hasattr(data, "qM"):  # MuJoCo 3: the sparse matrix is data.qM
        mujoco.mj_fullM(model, m, data.qM)
    else:  # MuJoCo 4: mj_fullM reads the data itself
        mujoco.mj_fullM(model, data, m)
    return m, data.qfrc_bias.copy()


@pytest.mark.parametrize("which", ["paper", "general"])
def test_exported_mjcf_matches_mujoco(which):
    mujoco = pytest.importorskip("mujoco")
    robot = (
        brachia.Robot.paper()
        if which == "paper"
        else brachia.Robot.from_toml_str(GENERAL, "general.toml")
    )
    model = mujoco.MjModel.from_xml_string(robot.to_mjcf())
    data = mujoco.MjData(model)
    n = robot.n_links
    assert model.nv == n and model.nu == n - 1
    rng = np.random.default_rng(5)
    for _ in range(20):
        phi = rng.uniform(-3.0, 3.0, n)
        phid = rng.uniform(-4.0, 4.0, n)
        m, bias = mujoco_state(mujoco, model, data, phi, phid)
        _, g = mujoco_state(mujoco, model, data, phi, np.zeros(n))
        mb, cb, gb = brachia_in_phi(robot, phi, phid)
        assert_close(mb, m, f"{which} M")
        assert_close(gb, g, f"{which} G")
        assert_close(cb, bias - g, f"{which} C qd")
    # the actuators: joints 2..n, their control ranges the torque limits
    lo, hi = model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1]
    s = robot.qd_to_urdf(np.ones(n))[1:]
    tl = np.where(s > 0, robot.tau_min, -robot.tau_max)
    th = np.where(s > 0, robot.tau_max, -robot.tau_min)
    assert np.allclose(lo, tl) and np.allclose(hi, th)


def test_passive_swing_in_mujoco_matches_the_model_plant():
    mujoco = pytest.importorskip("mujoco")
    robot = brachia.Robot.paper()
    model = mujoco.MjModel.from_xml_string(robot.to_mjcf())
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    model.opt.timestep = 1e-4
    data = mujoco.MjData(model)
    q0 = np.array([-2.35, 0.0, -1.55, 0.0])
    data.qpos[:] = robot.q_to_urdf(q0)
    data.qvel[:] = 0.0
    steps = 10000
    for _ in range(steps):
        mujoco.mj_step(model, data)
    plant = brachia.ModelPlant(robot, np.concatenate([q0, np.zeros(4)]))
    for _ in range(steps):
        plant.step(np.zeros(3), 1e-4)
    x = plant.state()
    assert abs(data.time - 1.0) < 1e-9 and abs(plant.time - 1.0) < 1e-9
    err_q = np.max(np.abs(robot.q_to_urdf(x[:4]) - data.qpos))
    err_qd = np.max(np.abs(robot.qd_to_urdf(x[4:]) - data.qvel))
    assert err_q < 1e-6 and err_qd < 1e-6, (err_q, err_qd)
    # and the swing moved: the comparison is not of two resting chains
    assert np.max(np.abs(x[:4] - q0)) > 0.1
