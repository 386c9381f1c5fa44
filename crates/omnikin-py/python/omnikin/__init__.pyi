"""Type stubs of omnikin (units SI; twists in the robot frame, positions in the world frame)."""

import os
from typing import Any, Dict, Optional, Sequence, Tuple, Union, overload, Literal

import numpy as np
import numpy.typing as npt

__version__: str

Table = Dict[str, npt.NDArray[np.float64]]
PlanLike = Union[Table, str, os.PathLike[str]]
ArrayLike = npt.ArrayLike

class Robot:
    """A robot: a preset name (sphere-omni, ballbot, caster3, kiwi, x-drive, mecanum, swerve4)
    or the path of a TOML robot file. Invalid files raise ``ValueError`` (the CLI's message)."""

    def __init__(self, name_or_path: str) -> None: ...
    @property
    def kind(self) -> str:
        """``sphere-omni``, ``ballbot``, ``caster3``, ``omni`` or ``swerve``."""
    @property
    def name(self) -> str: ...
    @property
    def source(self) -> str:
        """A file path or ``preset <name>``."""
    @property
    def wheels(self) -> int:
        """Number of wheels (swerve: modules), ``k``."""
    @property
    def motors(self) -> int: ...
    @property
    def steerable(self) -> bool: ...
    @property
    def limits(self) -> Dict[str, Optional[float]]:
        """``max_wheel_rate`` (rad/s), ``max_wheel_accel`` (rad/s²), ``max_steer_rate``,
        ``max_steer_accel``; ``None`` = unlimited."""
    @property
    def description(self) -> Dict[str, Any]:
        """The robot file (TOML) as a dict."""
    @property
    def toml(self) -> str: ...
    def inverse(
        self,
        twists: ArrayLike,
        steer: Optional[ArrayLike] = None,
        shell_spin: Optional[float] = None,
    ) -> Dict[str, npt.NDArray[np.float64]]:
        """``twists`` ``(N, 3)`` or ``(3,)``: vx, vy (m/s), yaw_rate (rad/s), robot frame.
        Returns ``wheel_rates`` ``(N, k)`` rad/s, plus ``steer_rates`` (caster3, rad/s) or
        ``steer_angles`` (swerve, rad) — the keys of ``omnikin inverse --json``."""
    @overload
    def forward(
        self,
        wheel_rates: ArrayLike,
        steer: Optional[ArrayLike] = None,
        steer_rates: Optional[ArrayLike] = None,
        shell_spin: Optional[float] = None,
        slip: Literal[False] = False,
    ) -> npt.NDArray[np.float64]:
        """Robot-frame twists ``(N, 3)`` (vx, vy m/s; yaw_rate rad/s) of ``wheel_rates``
        ``(N, k)`` rad/s at ``steer`` angles (rad) and ``steer_rates`` (rad/s, caster3)."""
    @overload
    def forward(
        self,
        wheel_rates: ArrayLike,
        steer: Optional[ArrayLike] = None,
        steer_rates: Optional[ArrayLike] = None,
        shell_spin: Optional[float] = None,
        slip: Literal[True] = ...,
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def torques(
        self,
        model: Optional[ArrayLike] = None,
        wrench: Optional[ArrayLike] = None,
        wheels: Optional[ArrayLike] = None,
        yaw: float = 0.0,
        steer: Optional[ArrayLike] = None,
    ) -> Dict[str, npt.NDArray[np.float64]]:
        """Ballbot ``model`` torques (N·m, at body yaw ``yaw`` rad) or omni/swerve body
        ``wrench`` (fx, fy N; mz N·m; robot frame) → ``wheel_torques`` ``(N, k)`` N·m; or
        ``wheels`` ``(N, k)`` → ``model_torques`` / ``wrench``."""

def plan(robot: Union[Robot, str], kind: str, **options: Any) -> Table:
    """A plan's CSV columns (``t, x, y, heading, vx, vy, yaw_rate, w1..wN[, s1..sN, sd1..sdN]``;
    world frame) for kind ``square``, ``circle``, ``waypoints`` or ``goal`` with ``omnikin plan``'s
    options."""

def simulate(
    robot: Union[Robot, str],
    plan: PlanLike,
    *,
    disturbances: Optional[Union[str, os.PathLike[str]]] = None,
    trials: Optional[int] = None,
    seed: int = 1,
    threads: Optional[int] = None,
    plant: Literal["kinematic", "dynamic"] = "kinematic",
    initial_tilt_deg: Optional[float] = None,
    push: Optional[Sequence[Sequence[float]]] = None,
    emit_sensors: bool = False,
    sensors: Optional[Union[str, os.PathLike[str]]] = None,
) -> Dict[str, Any]:
    """``{"trials": Table, "mean": Table, "metrics": dict}`` as ``omnikin simulate``'s
    ``trials.csv``, ``mean.csv`` and ``metrics.json``; ``plant="dynamic"`` (sphere-omni,
    ballbot: one trial; ballbot ``initial_tilt_deg`` toward +x, ``push`` of ``(N·s, s[, deg])``)
    adds ``"dynamics"`` or ``"cycles"``; ``emit_sensors`` (kinematic, or the sphere's dynamic
    plant) adds ``"sensors"`` (per trial:
    ``encoders``, ``truth``[, ``fixes``, ``imu``] tables)."""

def evaluate(
    plan: PlanLike,
    tracks: Any,
    *,
    motion_threshold: float = 0.005,
    align_position: bool = True,
    tracking_offset: Optional[Sequence[float]] = None,
) -> Dict[str, Any]:
    """``{"runs": Table, "mean": Table, "metrics": dict}`` as ``omnikin evaluate``'s
    ``runs.csv``, ``mean.csv`` and ``metrics.json``."""

def odometry(
    robot: Union[Robot, str],
    log: Union[Table, str, os.PathLike[str]],
    *,
    fixes: Optional[Union[Table, str, os.PathLike[str]]] = None,
    imu: bool = False,
    counts_per_rev: Optional[int] = None,
    initial_pose: Optional[Sequence[float]] = None,
    fix_std: float = 0.01,
    fix_heading_std: float = 0.05,
    gyro_bias: float = 0.0,
    max_latency: float = 1.0,
    estimate_gyro_bias: bool = True,
    estimate_wheel_scale: bool = True,
    recovery_count: int = 5,
    recovery_spread: float = 0.05,
    tilt_compensation: bool = True,
    slip_yaw_rate: Optional[float] = None,
    slip_residual: Optional[float] = None,
    collision_decel: Optional[float] = None,
) -> Dict[str, Any]:
    """``{"poses": Table, "odometry": Table, "fixes": list, "summary": dict}`` as ``omnikin
    odometry``: ``poses`` the ``--out`` CSV's ``t, x, y, heading`` (world frame; s, m, rad),
    ``odometry`` the pure wheel odometry; ``log`` / ``fixes`` dicts of columns or CSV paths."""

_Tables = Union[
    Dict[str, npt.ArrayLike], str, os.PathLike[str],
    Sequence[Union[Dict[str, npt.ArrayLike], str, os.PathLike[str]]],
]

def identify(
    robot: Union[Robot, str, os.PathLike[str]],
    encoders: _Tables,
    *,
    fixes: Optional[_Tables] = None,
    tracked: Optional[_Tables] = None,
    imu: Optional[_Tables] = None,
) -> Dict[str, Any]:
    """The ``omnikin identify --json`` object as a dict plus ``estimates`` and ``sigma`` (name →
    value / 1σ of the fitted parameters), ``table`` (the CLI's table) and ``robot_file`` (the
    identified robot file's text); one reference (``fixes`` or ``tracked``) per encoder log, each
    log a CSV path or a dict of columns."""

def pose_error(
    truth: Any,
    estimates: Any,
    *,
    align: str = "none",
    rpe_time: Optional[float] = None,
    rpe_distance: Optional[float] = None,
) -> Dict[str, Any]: ...

def read_mcap(path: Union[str, os.PathLike[str]]) -> Dict[str, Dict[str, Any]]: ...

def write_mcap(path: Union[str, os.PathLike[str]], tables: Dict[str, Dict[str, Any]]) -> int: ...

class Link:
    def __init__(
        self,
        connect: str,
        *,
        key: Optional[Union[str, os.PathLike[str]]] = ...,
        heartbeat_hz: float = ...,
        timeout_s: float = ...,
        mcap: Optional[Union[str, os.PathLike[str]]] = ...,
        keep_rows: int = ...,
    ) -> None: ...
    def info(self) -> Dict[str, Any]: ...
    def velocity(self, vx: float, vy: float, yaw_rate: float, duration: float, *, world: bool = ...) -> None: ...
    def listen(self, duration: float) -> None: ...
    def stop(self) -> None: ...
    def estop(self) -> None: ...
    def clear(self) -> None: ...
    def run_plan(self, plan_: PlanLike, *, set_pose: bool = ..., start_tolerance: float = ...) -> Dict[str, Any]: ...
    def telemetry(self) -> Dict[str, Any]: ...
    @property
    def frames(self) -> int: ...
    def close(self) -> None: ...
    def __enter__(self) -> "Link": ...
    def __exit__(self, *exc: Any) -> bool: ...

class SimRobot:
    def __init__(
        self,
        robot: Union[str, os.PathLike[str]],
        *,
        listen: str = ...,
        key: Optional[Union[str, os.PathLike[str]]] = ...,
        plant: str = ...,
        disturbances: Optional[str] = ...,
        seed: int = ...,
        rate: Optional[float] = ...,
        telemetry_rate: float = ...,
        watchdog: float = ...,
        time_scale: float = ...,
        max_time: Optional[float] = ...,
        max_speed: Optional[float] = ...,
        max_yaw_rate: Optional[float] = ...,
        max_accel: Optional[float] = ...,
        max_yaw_accel: Optional[float] = ...,
        max_jerk: Optional[float] = ...,
        gyro_heading: bool = ...,
        log: Optional[Union[str, os.PathLike[str]]] = ...,
        mcap: Optional[Union[str, os.PathLike[str]]] = ...,
    ) -> None: ...
    @property
    def address(self) -> Optional[str]: ...
    @property
    def running(self) -> bool: ...
    def stop(self) -> Optional[Dict[str, Any]]: ...
    def wait(self) -> Optional[Dict[str, Any]]: ...
    def __enter__(self) -> "SimRobot": ...
    def __exit__(self, *exc: Any) -> bool: ...
