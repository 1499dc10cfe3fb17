"""brachia: energy-optimal swings for underactuated brachiation robots, from Python.

A thin layer over the Rust library (the extension module ``brachia._brachia``): the planar n-link
model (``Robot``), the direct-collocation planner (``plan`` -> ``Plan``), the linear MPC tracker
(``Mpc``) and the other controllers of a scenario's ``[tracking]`` (``Tvlqr``, ``Pd``, ``OpenLoop``,
``Kalman``, ``Replanning``, ``Adaptive``), the persistent planner that re-plans warm from measured states (``SwingPlanner``
-> ``ReplanOutcome``), several swings of a ladder
planned as one problem (``plan_joint_swings`` -> ``JointSwingPlan``), the model and rapier plants (``ModelPlant``, ``RapierPlant``), the closed loop
(``track`` -> ``TrackResult``, with a scenario's ``[disturbances]``), scenario files and text
(``Scenario``), ladder traverses (``traverse`` -> ``TraverseResult``) and the interactive run page
(``view``; a ``Plan`` or ``TrackResult`` shows it inline in Jupyter).

Conventions (SI units throughout: m, kg, s, rad, N m, J): planar, grip point at the origin, x right,
y up, gravity along -y. ``q[0]`` is the absolute angle of link 1 from +x (counter-clockwise), ``q[i]``
(i >= 1) the angle of link i+1 relative to link i. State ``x = [q, qd]`` (2n values); torques ``tau``
of joints 2..n (n - 1 values). Arrays are float64 numpy arrays; time series are ``(samples, columns)``.

Bad input raises ``BrachiaError`` (a ``ValueError``) with the Rust library's message (file, field,
value, rule). A solve that does not converge is a ``Plan`` with its ``status``, not an exception.
See docs/python.md.
"""

from ._brachia import (
    SUCCESS_RADIUS_M,
    CAPTURE_SPEED_M_S,
    Adaptive,
    BrachiaError,
    JointPhase,
    JointSwingPlan,
    Kalman,
    ModelPlant,
    Mpc,
    OpenLoop,
    Pd,
    Plan,
    RapierPlant,
    Replanning,
    ReplanOutcome,
    Robot,
    Scenario,
    SwingBatchCore,
    SwingCore,
    SwingPlanner,
    TrackResult,
    Trajectory,
    TraverseResult,
    Tvlqr,
    benchmark,
    plan,
    plan_joint_swings,
    rust_mpc_step_times,
    track,
    traverse,
)
from .view import view

from ._registration import register_envs as _register_envs

# brachia/Swing-v0 for gymnasium.make, when Gymnasium is installed (docs/rl.md)
_register_envs()

__all__ = [
    "SUCCESS_RADIUS_M",
    "CAPTURE_SPEED_M_S",
    "Adaptive",
    "BrachiaError",
    "JointPhase",
    "JointSwingPlan",
    "Kalman",
    "ModelPlant",
    "Mpc",
    "OpenLoop",
    "Pd",
    "Plan",
    "RapierPlant",
    "Replanning",
    "ReplanOutcome",
    "Robot",
    "Scenario",
    "SwingBatchCore",
    "SwingCore",
    "SwingPlanner",
    "TrackResult",
    "Trajectory",
    "TraverseResult",
    "Tvlqr",
    "benchmark",
    "plan",
    "plan_joint_swings",
    "rust_mpc_step_times",
    "track",
    "traverse",
    "view",
]
