"""Type stubs of brachia (the Rust extension ``brachia._brachia``). The conventions (frame, angles,
state, units) are the package's docstring (``help(brachia)``); each class and function documents
itself there too. What holds for every one of them is said here, once:

- Array arguments: real numbers in any byte order and layout (converted), checked for shape,
  finiteness and range (``|q| <= 4 pi`` rad, ``|qd| <= 1000`` rad/s, ``|tau| <= 1e6`` N m, positions
  within 1000 m); anything else raises ``BrachiaError`` (docs/python.md, "Validation").
- Threads: every object may be used from any thread; ``Mpc``, ``SwingPlanner`` and the plants run one
  call at a time (a solve releases the GIL).
- Plants (``ModelPlant``, ``RapierPlant``): a step that diverges raises ``BrachiaError`` and the plant
  refuses every use but ``reset`` from then on.
- ``_repr_html_`` (``Plan``, ``TrackResult``, ``TraverseResult``): the run page inline in Jupyter.
"""

from os import PathLike
from pathlib import Path
from typing import Any, Callable, Literal, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

ArrayLike = Union[npt.ArrayLike, Sequence[float]]
Array = npt.NDArray[np.float64]
StrPath = Union[str, PathLike[str]]
Controller = Literal["mpc", "tvlqr", "pd", "open-loop"]

SUCCESS_RADIUS_M: float
"""The capture radius, m: the plant's hand captures the bar when it is within this distance of the target
bar and no faster than ``CAPTURE_SPEED_M_S``, at any time of the run (``TrackResult.report["reaches_bar"]``,
``report["capture_t_s"]``, ``report["bar_error_m"]`` at the capture, or at the end of the swing on a miss)."""
CAPTURE_SPEED_M_S: float
"""The capture speed, m/s: the fastest hand that can capture the bar (see ``SUCCESS_RADIUS_M``)."""

class BrachiaError(ValueError):
    """Bad input: the message is the Rust library's (file, field, value, rule)."""

class Robot:
    """A validated planar n-link robot hanging from the grip point (joint 1, passive)."""

    @staticmethod
    def from_toml(path: StrPath) -> Robot:
        """Load and validate a robot parameters file (TOML)."""
    @staticmethod
    def from_toml_str(text: str, source_name: str = "<string>") -> Robot:
        """Parse and validate robot parameters from TOML text."""
    @staticmethod
    def from_urdf(
        path: StrPath,
        grip: str,
        tip: str,
        passive: Sequence[str] = (),
        ignore: Sequence[str] = (),
        gravity: float = 9.81,
    ) -> Robot:
        """Import the serial chain of a URDF file from the grip joint to the tip (``LINK`` or
        ``LINK:x,y,z``); docs/robots.md."""
    def to_urdf(self) -> str:
        """The robot as a URDF document (joints ``grip``, ``joint_2``.., tip link ``tip``)."""
    def to_mjcf(self) -> str:
        """The robot as a MuJoCo MJCF document (motors on joints 2..n)."""
    def q_from_urdf(self, q: ArrayLike) -> Array:
        """Brachia's q from the robot's own joint angles, shape (n,) or (k, n) (a trajectory)."""
    def q_to_urdf(self, q: ArrayLike) -> Array:
        """The robot's own joint angles from brachia's q, shape (n,) or (k, n) (a trajectory)."""
    def qd_to_urdf(self, qd: ArrayLike) -> Array:
        """The robot's own joint velocities from brachia's qd, shape (n,) or (k, n)."""
    @staticmethod
    def paper() -> Robot:
        """The paper's 4-link robot (Table I)."""
    @property
    def n_links(self) -> int:
        """Number of links n."""
    @property
    def nx(self) -> int:
        """State dimension 2n."""
    @property
    def nu(self) -> int:
        """Number of actuated joints n - 1."""
    @property
    def name(self) -> str:
        """The name from the parameters file."""
    @property
    def gravity(self) -> float:
        """Gravitational acceleration, m/s^2 (along -y)."""
    @property
    def lengths(self) -> Array:
        """Link lengths, m, shape (n,)."""
    @property
    def masses(self) -> Array:
        """Link masses, kg, shape (n,)."""
    @property
    def tau_min(self) -> Array:
        """Lower torque limits of joints 2..n, N m, shape (n - 1,)."""
    @property
    def tau_max(self) -> Array:
        """Upper torque limits of joints 2..n, N m, shape (n - 1,)."""
    @property
    def params(self) -> dict[str, Any]:
        """The parameters (TOML schema) as a dict."""
    def M(self, q: ArrayLike) -> Array:
        """Mass matrix M(q), shape (n, n)."""
    def Cqd(self, q: ArrayLike, qd: ArrayLike) -> Array:
        """Coriolis and centrifugal forces C(q, qd) qd, shape (n,)."""
    def G(self, q: ArrayLike) -> Array:
        """Gravity forces G(q), shape (n,)."""
    def qdd(self, q: ArrayLike, qd: ArrayLike, tau: ArrayLike) -> Array:
        """Forward dynamics M^-1 (B tau - C qd - G), shape (n,)."""
    def inverse_dynamics(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> Array:
        """Generalised forces M qdd + C qd + G, shape (n,)."""
    def joint_positions(self, q: ArrayLike) -> Array:
        """Joint positions (grip, joints 2..n, EE), m, shape (n + 1, 2)."""
    def ee_position(self, q: ArrayLike) -> Array:
        """End-effector position, m, shape (2,)."""
    def ee_velocity(self, q: ArrayLike, qd: ArrayLike) -> Array:
        """End-effector velocity J(q) qd, m/s, shape (2,)."""
    def ee_jacobian(self, q: ArrayLike) -> Array:
        """End-effector Jacobian d ee / d q, shape (2, n)."""
    def energy(self, q: ArrayLike, qd: ArrayLike) -> float:
        """Kinetic + potential energy, J."""

class Trajectory:
    """A sampled trajectory (a controller's reference)."""

    def __init__(self, t: ArrayLike, q: ArrayLike, qd: ArrayLike, tau: ArrayLike) -> None:
        """t (samples,): 2 or more times in [0, 600] s, at least 1e-6 s apart; q and qd (samples, n),
        tau (samples, n - 1)."""
    @property
    def n_links(self) -> int: ...
    @property
    def t(self) -> Array:
        """Times, s, shape (samples,)."""
    @property
    def q(self) -> Array:
        """Joint angles, rad, shape (samples, n)."""
    @property
    def qd(self) -> Array:
        """Joint velocities, rad/s, shape (samples, n)."""
    @property
    def tau(self) -> Array:
        """Torques of joints 2..n, N m, shape (samples, n - 1)."""
    @property
    def duration(self) -> float:
        """Last time minus first, s."""
    def state_at(self, t: float) -> Array:
        """[q, qd] at time t (linear interpolation, held past the ends), shape (2n,)."""
    def __len__(self) -> int: ...

class Plan:
    """A planned swing (check ``converged``). ``t``, ``q``, ``qd`` and ``tau`` are those of its 1 ms
    ``trajectory`` (see ``Trajectory``), ``ee`` the end effector along it."""

    @property
    def status(self) -> str:
        """Solver status, snake case ("solved", "max_iterations", ...)."""
    @property
    def converged(self) -> bool: ...
    @property
    def failure_message(self) -> Optional[str]: ...
    @property
    def diagnosis(self) -> Optional[dict[str, Any]]:
        """When an obstacle plan failed: the blocking obstacle and link, the verdict and what the best detour found would need."""
    @property
    def objective(self) -> float: ...
    @property
    def iterations(self) -> int: ...
    @property
    def attempts(self) -> int: ...
    @property
    def solve_time_s(self) -> float: ...
    @property
    def swing_time(self) -> float:
        """Swing time T, s."""
    @property
    def energy(self) -> float:
        """Paper eq. 18 energy, J."""
    @property
    def t(self) -> Array: ...
    @property
    def q(self) -> Array: ...
    @property
    def qd(self) -> Array: ...
    @property
    def tau(self) -> Array: ...
    @property
    def ee(self) -> Array:
        """End-effector positions, shape (samples, 2), m."""
    @property
    def trajectory(self) -> Trajectory: ...
    @property
    def knots(self) -> Trajectory:
        """The collocation points."""
    @property
    def report(self) -> dict[str, Any]:
        """The report.json of ``brachia plan``."""
    def write(self, out: StrPath, force: bool = False) -> None:
        """Write the run folder (a scenario's plan only)."""
    def _view_html(self) -> Optional[str]:
        """The run page (docs/viewer.md), None without a trajectory."""
    def _repr_html_(self) -> Optional[str]: ...

def plan(
    robot: Robot,
    task: dict[str, Any],
    settings: Optional[dict[str, Any]] = None,
    **kwargs: Any,
) -> Plan:
    """Plan an energy-optimal swing; settings = [planner] fields plus ``solver`` = [solver] fields."""

class ReplanOutcome:
    """How one plan or re-plan of a ``SwingPlanner`` ended (check ``converged``)."""

    @property
    def status(self) -> str: ...
    @property
    def converged(self) -> bool: ...
    @property
    def iterations(self) -> int: ...
    @property
    def solve_time_s(self) -> float: ...
    @property
    def objective(self) -> float: ...
    @property
    def t_start(self) -> float:
        """Absolute time of the first knot (t_now; 0 for a full plan), s."""
    @property
    def interval_s(self) -> float: ...
    @property
    def ee_final(self) -> Array:
        """End-effector position at the last knot, shape (2,), m."""
    @property
    def ee_error_m(self) -> float: ...

class SwingPlanner:
    """The persistent multiple-shooting planner: a cold plan, then warm re-plans from measured states."""

    def __init__(
        self,
        robot: Robot,
        task: dict[str, Any],
        settings: Optional[dict[str, Any]] = None,
        **kwargs: Any,
    ) -> None: ...
    def plan(self) -> Plan:
        """Cold plan of the whole swing from the task's start state."""
    def replan(self, t_now: float, x_now: ArrayLike) -> ReplanOutcome:
        """Warm re-plan from state x_now = [q, qd] (2n) at absolute time t_now (s, in [0, T))."""
    def replan_cold(self, t_now: float, x_now: ArrayLike) -> ReplanOutcome:
        """The same re-plan started cold, for comparison."""
    def current_plan(self) -> Plan:
        """The current solution as a Plan (its own clock, 0 at its first knot)."""
    @property
    def has_plan(self) -> bool: ...
    @property
    def swing_time(self) -> float:
        """The full swing time T, s."""
    @property
    def intervals(self) -> int:
        """Number of intervals K (fixed)."""
    @property
    def target(self) -> Array: ...
    def set_target(self, target: ArrayLike) -> None:
        """Move the target bar (m) for the next plan or re-plan; checked as the constructor checks the
        task's target (a refused one leaves the planner as it was)."""
    def knot_times(self) -> Array:
        """Absolute knot times, shape (K + 1,), s."""
    def knot_states(self) -> Array:
        """Knot states [q, qd], shape (K + 1, 2n)."""
    def knot_torques(self) -> Array:
        """Torques held over each interval, shape (K, n - 1), N m."""

class JointPhase:
    """One swing of a joint plan (its Plan in the grip frame of ``grip``, on its own clock)."""

    @property
    def plan(self) -> Plan: ...
    @property
    def holding_hand(self) -> int:
        """0: the chain as written holds; 1: the chain re-rooted at the other end."""
    @property
    def grip(self) -> Array:
        """The bar held, shape (2,), world, m."""
    @property
    def objective(self) -> float: ...
    @property
    def reference_objective(self) -> float: ...

class JointSwingPlan:
    """Several swings planned as one problem, and the swing-by-swing plans it started from."""

    @property
    def status(self) -> Literal["converged", "joint_failed", "reference_failed"]: ...
    @property
    def message(self) -> str: ...
    @property
    def converged(self) -> bool: ...
    @property
    def objective(self) -> Optional[float]: ...
    @property
    def reference_objective(self) -> Optional[float]: ...
    @property
    def energy(self) -> Optional[float]:
        """Paper eq. 18 over the joint plan's swings, J."""
    @property
    def reference_energy(self) -> float: ...
    @property
    def max_defect(self) -> Optional[float]: ...
    @property
    def capture_residual(self) -> Optional[tuple[float, float]]:
        """Largest capture residuals: (distance m, speed m/s)."""
    @property
    def iterations(self) -> Optional[int]: ...
    @property
    def phases(self) -> list[JointPhase]: ...
    @property
    def reference(self) -> list[Plan]: ...
    @property
    def report(self) -> dict[str, Any]:
        """The joint_swings.json of ``brachia reproduce``."""

def plan_joint_swings(
    robot: Robot,
    x0: ArrayLike,
    bars: ArrayLike,
    obstacles: Optional[list[dict[str, Any]]] = None,
    rest_at_switches: bool = False,
    settings: Optional[dict[str, Any]] = None,
    **kwargs: Any,
) -> JointSwingPlan:
    """Plan the swings from x0 (2n, holding bars[0]) through bars[1:] (world, m) as one problem."""

class Mpc:
    """The linear MPC tracker (paper Section IV)."""

    def __init__(
        self,
        robot: Robot,
        reference: Union[Plan, Trajectory],
        settings: Optional[dict[str, Any]] = None,
        **kwargs: Any,
    ) -> None: ...
    def control(self, t: float, x: ArrayLike) -> Array:
        """Torques of joints 2..n, shape (n - 1,), for state x = [q, qd] at time t."""
    def set_reference(self, reference: Union[Plan, Trajectory]) -> None:
        """Track a new reference with the same settings, in place (the QP warm start is kept)."""
    def reset(self) -> None:
        """Forget the previous solution (next call starts cold)."""
    @property
    def settings(self) -> dict[str, Any]: ...
    @property
    def last_qp_iterations(self) -> Optional[int]: ...
    @property
    def reference(self) -> Trajectory: ...

class Tvlqr:
    """Time-varying LQR along the plan (``[tracking.tvlqr]`` settings); built afresh by each ``track``."""

    def __init__(
        self,
        robot: Robot,
        reference: Union[Plan, Trajectory],
        settings: Optional[dict[str, Any]] = None,
        **kwargs: Any,
    ) -> None: ...
    @property
    def settings(self) -> dict[str, Any]: ...

class Pd:
    """PD on the actuated joints plus the planned torque (``[tracking.pd]`` settings)."""

    def __init__(
        self,
        robot: Robot,
        reference: Union[Plan, Trajectory],
        settings: Optional[dict[str, Any]] = None,
        **kwargs: Any,
    ) -> None: ...
    @property
    def settings(self) -> dict[str, Any]: ...

class OpenLoop:
    """The planned torques replayed without feedback."""

    def __init__(self, robot: Robot, reference: Union[Plan, Trajectory]) -> None: ...

class Kalman:
    """A Mpc, Tvlqr or Pd fed through the Kalman filter along its plan (``[tracking.estimator]`` settings)."""

    def __init__(
        self,
        controller: Union[Mpc, Tvlqr, Pd],
        settings: Optional[dict[str, Any]] = None,
        **kwargs: Any,
    ) -> None: ...
    @property
    def settings(self) -> dict[str, Any]: ...

class Replanning:
    """Online re-planning around the MPC (``[tracking.replan]`` settings; docs/replanning.md)."""

    def __init__(
        self,
        controller: Union[Mpc, Kalman],
        task: dict[str, Any],
        plan_settings: Optional[dict[str, Any]] = None,
        settings: Optional[dict[str, Any]] = None,
        **kwargs: Any,
    ) -> None: ...
    @property
    def settings(self) -> dict[str, Any]: ...

class Adaptive:
    """The MPC (or Replanning(Mpc)) fed the online mass estimate (``[tracking.estimate_params]`` settings)."""

    def __init__(
        self,
        controller: Union[Mpc, Replanning],
        settings: Optional[dict[str, Any]] = None,
        **kwargs: Any,
    ) -> None: ...
    @property
    def settings(self) -> dict[str, Any]: ...

ControllerObject = Union[Mpc, Tvlqr, Pd, OpenLoop, Kalman, Replanning, Adaptive]

class ModelPlant:
    """RK4 integration of the robot's model."""

    def __init__(self, robot: Robot, x0: Optional[ArrayLike] = None, substeps: int = 1) -> None: ...
    def reset(self, x: ArrayLike) -> None: ...
    def step(self, tau: ArrayLike, dt: float) -> None: ...
    def state(self) -> Array: ...
    @property
    def time(self) -> float: ...
    @property
    def substeps(self) -> int: ...
    def energy(self) -> float: ...

class RapierPlant:
    """The rapier2d physics-engine plant with contacts."""

    def __init__(
        self,
        robot: Robot,
        x0: Optional[ArrayLike] = None,
        settings: Optional[dict[str, Any]] = None,
        obstacles: Optional[list[dict[str, Any]]] = None,
        **kwargs: Any,
    ) -> None: ...
    def reset(self, x: ArrayLike) -> None: ...
    def step(self, tau: ArrayLike, dt: float) -> None: ...
    def state(self) -> Array: ...
    @property
    def time(self) -> float: ...
    def energy(self) -> float: ...
    def contacts(self) -> list[dict[str, Any]]: ...

class TrackResult:
    """A closed-loop run's log (one row per control instant)."""

    @property
    def tracked(self) -> bool: ...
    @property
    def diverged_at_s(self) -> Optional[float]:
        """Time at which the closed loop diverged (the run stopped there), else None."""
    @property
    def t(self) -> Array: ...
    @property
    def x(self) -> Array: ...
    @property
    def q(self) -> Array: ...
    @property
    def qd(self) -> Array: ...
    @property
    def tau(self) -> Array: ...
    @property
    def ee(self) -> Array: ...
    @property
    def ref_x(self) -> Array: ...
    @property
    def ref_ee(self) -> Array: ...
    @property
    def control_us(self) -> Array: ...
    @property
    def summary(self) -> Optional[dict[str, Any]]: ...
    @property
    def report(self) -> Any: ...
    @property
    def plan(self) -> Optional[Plan]: ...
    def write(self, out: StrPath, force: bool = False) -> None: ...
    def _view_html(self) -> Optional[str]:
        """The run page of a scenario's run (docs/viewer.md), else None."""
    def _repr_html_(self) -> Optional[str]: ...

def track(
    robot: Robot,
    reference: Union[Plan, Trajectory],
    controller: Union[ControllerObject, Controller, Callable[[float, Array], ArrayLike], None] = None,
    plant: Union[ModelPlant, RapierPlant, None] = None,
    duration: Optional[float] = None,
    control_dt: float = 0.001,
    noise_q_std: float = 0.0,
    noise_qd_std: float = 0.0,
    seed: int = 0,
    disturbances: Optional[dict[str, Any]] = None,
) -> TrackResult:
    """Run a controller against a plant in closed loop (``disturbances``: a scenario's [disturbances])."""

class Scenario:
    """A scenario file, loaded and validated."""

    @staticmethod
    def from_toml(path: StrPath) -> Scenario: ...
    @staticmethod
    def from_toml_str(
        text: str, base_dir: Optional[StrPath] = None, source_name: Optional[str] = None
    ) -> Scenario:
        """A scenario from TOML text (params relative to base_dir; errors name source_name)."""
    @property
    def name(self) -> str: ...
    @property
    def is_traverse(self) -> bool: ...
    @property
    def path(self) -> str: ...
    @property
    def robot(self) -> Robot: ...
    @property
    def task(self) -> dict[str, Any]: ...
    @property
    def plan_settings(self) -> dict[str, Any]: ...
    @property
    def mpc_settings(self) -> dict[str, Any]: ...
    @property
    def tracking(self) -> dict[str, Any]: ...
    @property
    def disturbances(self) -> dict[str, Any]: ...
    @property
    def plant(self) -> dict[str, Any]: ...
    def plan(self) -> Plan: ...
    def track(
        self,
        controller: Optional[Controller] = None,
        plant: Optional[Literal["model", "rapier"]] = None,
        reference: Optional[Plan] = None,
    ) -> TrackResult: ...
    def traverse(self) -> TraverseResult:
        """Run the traverse of a traverse scenario (a [ladder] section), as ``brachia traverse``."""

class TraverseResult:
    """A traverse: swings, world-frame arrays, grip switches, report, run folder and page."""

    @property
    def completed(self) -> bool: ...
    @property
    def status(self) -> str: ...
    @property
    def swings(self) -> list[dict[str, Any]]: ...
    @property
    def grip_switches(self) -> list[dict[str, Any]]: ...
    @property
    def t(self) -> Array: ...
    @property
    def swing(self) -> Array: ...
    @property
    def x(self) -> Array: ...
    @property
    def tau(self) -> Array: ...
    @property
    def ee(self) -> Array: ...
    @property
    def joints(self) -> Array:
        """World joints, shape (rows, n + 1, 2), hand A first."""
    @property
    def report(self) -> dict[str, Any]: ...
    def write(self, out: StrPath, force: bool = False) -> None: ...
    def _repr_html_(self) -> Optional[str]: ...

def traverse(scenario: Union[StrPath, Scenario]) -> TraverseResult:
    """Run a traverse scenario (a Scenario or a file) as ``brachia traverse`` does."""

def rust_mpc_step_times(
    robot: Robot,
    reference: Union[Plan, Trajectory],
    steps: int,
    dt: float = 0.001,
    settings: Optional[dict[str, Any]] = None,
) -> Array:
    """Wall time (s) of each of ``steps`` Mpc control calls made in Rust."""

def benchmark(
    scenario: Union[StrPath, Scenario],
    controllers: Optional[dict[str, Callable[[float, Array], ArrayLike]]] = None,
    builtin: Optional[list[str]] = None,
    levels: int = 3,
    monte_carlo_runs: int = 6,
    family_runs: int = 1,
    sweeps: Optional[list[str]] = None,
    seed: int = 0,
) -> dict[str, Any]:
    """The robustness benchmark with Python policies beside the built-in controllers (docs/rl.md)."""

class SwingCore:
    """The Rust side of ``brachia.envs.SwingEnv`` (use that class)."""

    def __init__(
        self,
        scenario: Union[StrPath, Scenario, None] = None,
        plant: Optional[Literal["model", "rapier"]] = None,
        settings: Optional[dict[str, Any]] = None,
        disturbances: Optional[dict[str, Any]] = None,
        seed: int = 0,
        **kwargs: Any,
    ) -> None: ...
    def spec(self) -> dict[str, Any]: ...
    def robot(self) -> Robot: ...
    def reset(self, seed: Optional[int] = None, disturbances: Optional[dict[str, Any]] = None) -> Array: ...
    def step(self, action: ArrayLike) -> tuple[Array, float, bool, bool, dict[str, Any]]: ...
    def render(self, width: int = 480, height: int = 360) -> Array: ...
    def episode(self) -> dict[str, Any]: ...

class SwingBatchCore:
    """The Rust side of ``brachia.vector.SwingVectorEnv`` (use that class)."""

    def __init__(
        self,
        num_envs: int,
        scenario: Union[StrPath, Scenario, None] = None,
        plant: Optional[Literal["model", "rapier"]] = None,
        settings: Optional[dict[str, Any]] = None,
        disturbances: Optional[dict[str, Any]] = None,
        seed: int = 0,
        autoreset: Literal["next-step", "same-step"] = "next-step",
        **kwargs: Any,
    ) -> None: ...
    def spec(self) -> dict[str, Any]: ...
    def reset(self, seed: Optional[int] = None, disturbances: Optional[dict[str, Any]] = None) -> Array: ...
    def step(self, actions: ArrayLike) -> tuple[Array, Array, Array, Array, dict[str, Array], Array, Array]: ...
    def episodes(self) -> list[dict[str, Any]]: ...

# ``view`` is written in Python (brachia/view.py, documented there)
def view(
    obj: Union[StrPath, Plan, TrackResult, TraverseResult],
    path: Optional[StrPath] = None,
    open: bool = False,
) -> Path: ...
