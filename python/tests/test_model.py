"""The model through the bindings: dynamics against independent paths and physical invariants.

Independent paths: qdd from M, Cqd and G solved in numpy; inverse dynamics of the forward dynamics;
the EE Jacobian against central differences of ee_position (test code only); the EE position against
the last row of joint_positions; ModelPlant energy on a passive swing.
"""

import numpy as np
import pytest

import brachia


def random_states(robot, count, seed=1):
    rng = np.random.default_rng(seed)
    n = robot.n_links
    for _ in range(count):
        q = rng.uniform(-np.pi, np.pi, n)
        qd = rng.uniform(-3.0, 3.0, n)
        tau = rng.uniform(robot.tau_min, robot.tau_max)
        yield q, qd, tau


def test_paper_robot_shape(robot):
    assert robot.n_links == 4
    assert robot.nx == 8 and robot.nu == 3
    assert robot.lengths.shape == (4,)
    np.testing.assert_array_equal(robot.tau_max, [5.0, 5.0, 5.0])
    assert robot.params["actuators"]["tau_min"] == [-5.0, -5.0, -5.0]


def test_from_toml_equals_paper(robot, root):
    r = brachia.Robot.from_toml(root / "params" / "paper.toml")
    q = np.array([-2.0, 0.3, -1.0, 0.5])
    np.testing.assert_array_equal(r.M(q), robot.M(q))


def test_mass_matrix_symmetric_positive_definite(robot):
    for q, _, _ in random_states(robot, 20):
        m = robot.M(q)
        assert m.shape == (4, 4)
        np.testing.assert_allclose(m, m.T, rtol=0, atol=1e-12)
        assert np.linalg.eigvalsh(m).min() > 0.0


def test_forward_dynamics_solves_the_equation_of_motion(robot):
    b = np.vstack([np.zeros((1, 3)), np.eye(3)])
    for q, qd, tau in random_states(robot, 20):
        m, cqd, g = robot.M(q), robot.Cqd(q, qd), robot.G(q)
        expected = np.linalg.solve(m, b @ tau - cqd - g)
        np.testing.assert_allclose(robot.qdd(q, qd, tau), expected, rtol=1e-10, atol=1e-10)


def test_inverse_dynamics_inverts_forward_dynamics(robot):
    for q, qd, tau in random_states(robot, 10, seed=2):
        f = robot.inverse_dynamics(q, qd, robot.qdd(q, qd, tau))
        np.testing.assert_allclose(f, np.concatenate([[0.0], tau]), atol=1e-9)


def test_coriolis_is_quadratic_in_qd(robot):
    for q, qd, _ in random_states(robot, 5, seed=3):
        np.testing.assert_allclose(robot.Cqd(q, 2.0 * qd), 4.0 * robot.Cqd(q, qd), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(robot.Cqd(q, np.zeros(4)), 0.0, atol=0)


def test_gravity_is_the_gradient_of_the_potential(robot):
    # potential = energy at rest; G = dV/dq, checked by central differences in the test only
    for q, _, _ in random_states(robot, 5, seed=4):
        h = 1e-6
        num = np.array(
            [
                (robot.energy(q + h * e, np.zeros(4)) - robot.energy(q - h * e, np.zeros(4))) / (2 * h)
                for e in np.eye(4)
            ]
        )
        np.testing.assert_allclose(robot.G(q), num, rtol=1e-6, atol=1e-6)


def test_kinematics(robot):
    q = np.array([-np.pi / 2, 0.0, 0.0, 0.0])
    p = robot.joint_positions(q)
    assert p.shape == (5, 2)
    np.testing.assert_allclose(p[0], [0.0, 0.0])
    np.testing.assert_allclose(p[-1], [0.0, -robot.lengths.sum()], atol=1e-12)
    for q, qd, _ in random_states(robot, 5, seed=5):
        np.testing.assert_allclose(robot.ee_position(q), robot.joint_positions(q)[-1], atol=1e-14)
        jac = robot.ee_jacobian(q)
        assert jac.shape == (2, 4)
        h = 1e-6
        num = np.column_stack(
            [(robot.ee_position(q + h * e) - robot.ee_position(q - h * e)) / (2 * h) for e in np.eye(4)]
        )
        np.testing.assert_allclose(jac, num, rtol=1e-7, atol=1e-8)
        np.testing.assert_allclose(robot.ee_velocity(q, qd), jac @ qd, atol=1e-12)


def test_model_plant_conserves_energy_on_a_passive_swing(robot):
    x0 = np.array([-2.35, 0.0, -1.55, 0.0, 0.0, 0.0, 0.0, 0.0])
    plant = brachia.ModelPlant(robot, x0)
    e0 = plant.energy()
    assert e0 == pytest.approx(robot.energy(x0[:4], x0[4:]))
    for _ in range(1000):
        plant.step(np.zeros(3), 1e-3)
    assert plant.time == pytest.approx(1.0)
    x = plant.state()
    assert np.abs(x - x0).max() > 0.1  # it moved
    assert abs(plant.energy() - e0) < 1e-6 * max(1.0, abs(e0))


def test_model_plant_step_matches_qdd_for_a_tiny_step(robot):
    x0 = np.array([-2.0, 0.2, -1.0, 0.3, 0.1, -0.2, 0.3, 0.0])
    tau = np.array([0.5, -0.3, 1.0])
    plant = brachia.ModelPlant(robot, x0)
    dt = 1e-6
    plant.step(tau, dt)
    qdd = robot.qdd(x0[:4], x0[4:], tau)
    np.testing.assert_allclose((plant.state()[4:] - x0[4:]) / dt, qdd, rtol=1e-4, atol=1e-4)
    plant.reset(x0)
    assert plant.time == 0.0
    np.testing.assert_array_equal(plant.state(), x0)


def test_rapier_plant_agrees_with_the_model_plant(robot):
    x0 = np.array([-2.35, 0.0, -1.55, 0.0, 0.0, 0.0, 0.0, 0.0])
    model = brachia.ModelPlant(robot, x0)
    rapier = brachia.RapierPlant(robot, x0, substeps=4)
    np.testing.assert_allclose(rapier.state(), x0, atol=1e-12)
    for _ in range(200):
        model.step(np.zeros(3), 1e-3)
        rapier.step(np.zeros(3), 1e-3)
    assert rapier.time == pytest.approx(0.2)
    # the engine's first-order integrator differs from RK4, but over 0.2 s only slightly
    assert np.abs(rapier.state()[:4] - model.state()[:4]).max() < 0.05
    assert rapier.contacts() == []
    rapier.reset(x0)
    assert rapier.time == 0.0
