"""omnikin: kinematics, planning and simulation of omnidirectional wheeled robots.

Units are SI (m, s, rad, rad/s, N·m). Twists ``(vx, vy, yaw_rate)`` are in the robot frame
(x forward, y left, z up, counter-clockwise positive) unless a name says world; plan and
trajectory positions are in the world frame. Tables come back as dicts of 1-D numpy arrays
keyed by the CSV files' column names (``pandas.DataFrame(result)`` makes a frame of one).
"""

from __future__ import annotations

import json
import math
import os
from typing import Any, Dict, Optional, Sequence, Union

import numpy as np

from omnikin import _native
from omnikin._native import Robot, __version__

__all__ = [
    "Robot",
    "plan",
    "simulate",
    "evaluate",
    "odometry",
    "pose_error",
    "identify",
    "read_mcap",
    "write_mcap",
    "Link",
    "SimRobot",
    "__version__",
]

Table = Dict[str, np.ndarray]
PlanLike = Union[Table, str, "os.PathLike[str]"]


def _table(native: tuple) -> Table:
    columns, values = native
    return {c: values[i] for i, c in enumerate(columns)}


def _robot(robot: Union[Robot, str, "os.PathLike[str]"]) -> Robot:
    return robot if isinstance(robot, Robot) else Robot(os.fspath(robot))


def _columns(name: str, table: Table) -> tuple:
    columns = list(table)
    cols = [np.asarray(table[c], dtype=np.float64) for c in columns]
    if any(c.ndim != 1 for c in cols) or len({len(c) for c in cols}) > 1:
        raise ValueError(f"{name}: every column must be a 1-D array of the same length")
    return columns, np.array(cols).reshape(len(cols), -1)


def _table_args(name: str, table: Union[Table, str, "os.PathLike[str]", None]) -> dict:
    if table is None:
        return {}
    if isinstance(table, dict):
        return {f"{name}_columns": _columns(name, table)}
    return {f"{name}_path": os.fspath(table)}


def _plan_args(plan_: PlanLike) -> dict:
    if isinstance(plan_, dict):
        columns = list(plan_)
        values = np.array([np.asarray(plan_[c], dtype=np.float64) for c in columns])
        if values.ndim != 2:
            raise ValueError("plan: every column must be a 1-D array of the same length")
        return {"plan_columns": (columns, values)}
    return {"plan_path": os.fspath(plan_)}


def plan(robot: Union[Robot, str], kind: str, **options: Any) -> Table:
    """Plans ``kind`` ("square", "circle", "waypoints" or "goal") for ``robot`` within its motor limits,
    with the options of ``omnikin plan KIND`` (flag names with ``_`` for ``-``, same defaults):

    - every kind: ``rate`` (Hz, 100), ``initial_steer`` (steerable kinds: one angle per wheel,
      rad; default aligned with the first motion);
    - square: ``side`` (m, 0.4), ``speed`` (m/s, 0.1), ``ramp_fraction`` (0.05), ``profile``
      ("trapezoid" | "s-curve"), ``no_retime``;
    - circle: ``omega`` (rad/s, required), ``radius`` (m, 0.2), ``turns`` (1), ``ramp`` (s),
      ``face_motion``;
    - waypoints: ``file`` (CSV ``x,y[,heading]`` or TOML) or ``points`` (an ``(N, 2)`` array
      of ``x, y`` or ``(N, 3)`` of ``x, y, heading``; m, rad, world frame), ``path`` ("polyline" |
      "spline"), ``corners`` ("stop" | "fillet"), ``fillet_radius``, ``heading_law``
      ("constant" | "tangent" | "waypoints"), ``heading``, ``spin`` (rad/m),
      ``heading_offset``, ``max_speed``, ``max_accel``, ``max_jerk``, ``max_yaw_rate``,
      ``max_yaw_accel``, ``profile``, ``time_optimal``, ``no_retime``;
    - goal (``omnikin plan goal``): ``map`` (a MAP.toml path, required), ``start`` and ``goal``
      (``[x, y]`` or ``[x, y, heading]``; m, rad, world frame; required), ``footprint_radius``
      (m; default the robot file's ``footprint_radius``, else from its geometry), ``max_speed``,
      ``max_accel``, ``max_yaw_rate``, ``max_yaw_accel``: the shortest collision-free route,
      filleted, timed time-optimally;
    - waypoints (with ``time_optimal``) and goal: ``start_velocity`` (``[vx, vy]`` or
      ``[vx, vy, yaw_rate]``; world frame, m/s, rad/s): the plan starts moving, as
      ``--start-velocity`` (waypoints: along the path's first tangent; goal: the path leaves
      the start along it).

    Returns the plan CSV's columns ``t, x, y, heading, vx, vy, yaw_rate, w1..wN`` (world frame;
    s, m, rad, m/s, rad/s) and, for steerable kinds, ``s1..sN, sd1..sdN`` (rad, rad/s). A
    steer step that the steer rates do not explain is a ``UserWarning``, as ``omnikin plan``
    warns (``simulate`` refuses a step over 0.1 rad).
    """
    return _table(_native.plan_columns(_robot(robot), kind, **options))


def simulate(
    robot: Union[Robot, str],
    plan: PlanLike,
    *,
    disturbances: Optional[Union[str, "os.PathLike[str]"]] = None,
    trials: Optional[int] = None,
    seed: int = 1,
    threads: Optional[int] = None,
    plant: str = "kinematic",
    initial_tilt_deg: Optional[float] = None,
    push: Optional[Sequence[Sequence[float]]] = None,
    emit_sensors: bool = False,
    sensors: Optional[Union[str, "os.PathLike[str]"]] = None,
) -> Dict[str, Any]:
    """Runs ``plan`` (a dict from :func:`plan`, or a plan CSV path) through a plant, as
    ``omnikin simulate`` does.

    ``plant="kinematic"`` (default): the motors' motion through the forward kinematics,
    ``trials`` times (default 10) with the disturbance profile TOML ``disturbances`` (default: the ideal
    plant); the same seed gives the same numbers on any number of ``threads`` (default: all
    cores). ``emit_sensors=True`` also returns what each trial's sensors recorded (the CLI's
    ``--emit-sensors``; ``sensors``: a sensor profile TOML, default 4096-count encoders, a
    gyro, camera fixes at 10 Hz).

    ``plant="dynamic"``: the robot file's dynamics, one trial (``trials`` > 1 warns, as the
    CLI notes) — sphere-omni's shell +
    platform (deterministic), or the ballbot balanced by its controller on the 3D model
    (sensor noise seeded by ``seed``), starting ``initial_tilt_deg`` degrees toward +x and
    pushed by ``push``: a list of ``(impulse N·s, time s[, direction deg from +x])``, time from
    the start of the 1 s lead-in. A fall is a result: ``metrics["fallen"]``. With
    ``emit_sensors`` (sphere-omni only, as the CLI) the run's logs, the IMU on the model's
    tilting platform (its gyro reads the platform's body rates): what ``identify`` needs for
    the sphere's ``com_depth``, ``rolling_resistance`` and ``pivot_friction``.

    Returns ``{"trials": ..., "mean": ..., "metrics": ...}``: the columns of ``trials.csv``
    (``trial, t, x, y, heading, tracked_x, tracked_y, slip_residual, q1..qN``; world frame) and
    ``mean.csv`` (``t, x, y, x_ci95, y_ci95, plan_x, plan_y``), and ``metrics.json`` as a dict;
    with ``emit_sensors``, ``"sensors"``: one dict per trial of ``encoders``, ``truth`` and,
    when recorded, ``fixes`` and ``imu`` tables (the files under ``sensors/trial-NNN/``); for
    the dynamic plant also ``"dynamics"`` (sphere: ``t, tilt, shell_spin`` at the plan's
    samples; rad, rad/s) or ``"cycles"`` (ballbot: ``t, tilt, x, y`` per control cycle,
    closed-loop time from the start of the lead-in; s, rad, m).
    """
    if trials is None:
        trials = 10 if plant == "kinematic" else 1
    trials_, mean, metrics, extras, sensor_logs = _native.simulate_native(
        _robot(robot),
        disturbances=None if disturbances is None else os.fspath(disturbances),
        trials=trials,
        seed=seed,
        threads=threads,
        plant=plant,
        initial_tilt_deg=initial_tilt_deg,
        push=None if push is None else [[float(v) for v in p] for p in push],
        emit_sensors=emit_sensors,
        sensors=None if sensors is None else os.fspath(sensors),
        **_plan_args(plan),
    )
    out: Dict[str, Any] = {
        "trials": _table(trials_),
        "mean": _table(mean),
        "metrics": json.loads(metrics),
    }
    for name, t in extras:
        out[name] = _table(t)
    if emit_sensors:
        out["sensors"] = [{name: _table(t) for name, t in logs} for logs in sensor_logs]
    return out


def evaluate(
    plan: PlanLike,
    tracks: Union[TrackLike, Sequence[TrackLike]],
    *,
    motion_threshold: float = 0.005,
    align_position: bool = True,
    tracking_offset: Optional[Sequence[float]] = None,
) -> Dict[str, Any]:
    """The metrics of tracked runs against ``plan``, as ``omnikin evaluate``. ``tracks``: one
    run or a list of runs, each a CSV path (``str``, ``pathlib.Path``), a dict or DataFrame of
    columns ``t, x, y[, heading]`` (s, m, rad; world frame) or an ``(n, 3)``/``(n, 4)`` array,
    converted with ``numpy.asarray(..., float64)``; a table with a ``trial`` column
    (``simulate(...)["trials"]``) is one run per trial (per-run figures: ``pose_error``). ``motion_threshold`` (m) marks the start of motion,
    ``align_position`` translates each run to start at the plan's start, ``tracking_offset``
    is the marker's position ``(x, y)`` in the robot frame (m).

    Returns ``{"runs": ..., "mean": ..., "metrics": ...}``: the columns of ``runs.csv``
    (``run, t, x, y``) and ``mean.csv``, and ``metrics.json`` as a dict.
    """
    runs, mean, metrics = _native.evaluate_native(
        _estimates(tracks),
        motion_threshold=motion_threshold,
        align_position=align_position,
        tracking_offset=None if tracking_offset is None else tuple(tracking_offset),
        **_plan_args(plan),
    )
    return {"runs": _table(runs), "mean": _table(mean), "metrics": json.loads(metrics)}


def odometry(
    robot: Union[Robot, str],
    log: Union[Table, str, "os.PathLike[str]"],
    *,
    fixes: Optional[Union[Table, str, "os.PathLike[str]"]] = None,
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
    """Wheel odometry over an encoder log, fused with camera ``fixes`` when given, as
    ``omnikin odometry`` (the same pipeline, ``omnikin_sim::odometry``).

    ``log``: a dict of columns or a CSV path — ``t, q1..qN`` cumulative wheel angles (rad, or
    counts with ``counts_per_rev``), ``s1..sN`` steer angles for caster3/swerve, optional
    ``gyro_z`` (rad/s) and ``yaw`` (rad); e.g. ``simulate(..., emit_sensors=True)
    ["sensors"][0]["encoders"]``. ``fixes``: ``t, x, y`` (s, m; world frame) with optional
    ``heading`` (rad) and ``arrival`` (s). ``imu``: heading from ``yaw`` (or integrated
    ``gyro_z`` minus ``gyro_bias``) instead of the wheels. ``initial_pose``: ``(x, y, heading)``
    (m, rad); ``fix_std`` / ``fix_heading_std``: a fix's standard deviations (m, rad).
    ``max_latency``: the oldest fix (s before the latest encoder sample) still fused at its
    time; older ones count as ``too_late``. ``estimate_gyro_bias`` / ``estimate_wheel_scale``:
    the filter's bias and common wheel-scale states (the CLI's ``--no-gyro-bias-state`` /
    ``--no-wheel-scale-state`` turn them off). ``recovery_count`` rejected fixes in a row
    (1..=16) that agree within ``recovery_spread`` (m) re-initialise the filter, otherwise
    inflate its covariance. ``tilt_compensation``: with ``gyro_x, gyro_y, accel_x, accel_y,
    accel_z`` columns, the heading rate is the body rate about the vertical (the CLI's
    ``--no-tilt-compensation`` turns it off). ``slip_yaw_rate`` (rad/s), ``slip_residual``
    (m/s), ``collision_decel`` (m/s²): event thresholds overriding the robot file's
    ``[events]`` (``None``: the file's, else the default). For a
    dict, an error's line is the row + 1 (line 1 is the header).

    Returns ``{"poses": ..., "odometry": ..., "fixes": [...], "summary": {...}}``: ``poses``
    the columns of the CLI's ``--out`` CSV (``t, x, y, heading``; fused when there are fixes),
    ``odometry`` the pure wheel odometry (same columns), ``fixes`` each fix in arrival order
    with its ``result`` (``accepted``, ``rejected``, ``too_late``, ``after_log``) and
    ``mahalanobis2``, and the summary the CLI prints (``heading_source``, ``samples``,
    ``duration_s``, ``path_length_m``, ``end``, ``max_slip_m_s``/``max_slip_t_s``,
    ``mean_shell_spin_rad_s``, ``shell_spin_rad_s`` with its ``tilt`` (compensated from
    ``gyro_x, gyro_y, accel_x, accel_y, accel_z`` log columns, or why not),
    ``event_thresholds`` with their ``source`` (``option``, ``robot file`` or ``default``),
    ``fixes`` counters) as a dict. A fix rejected as an outlier
    is also a ``UserWarning``, as the CLI warns.
    """
    r = _native.odometry_native(
        _robot(robot),
        imu=imu,
        counts_per_rev=counts_per_rev,
        initial_pose=None if initial_pose is None else tuple(float(v) for v in initial_pose),
        fix_std=fix_std,
        fix_heading_std=fix_heading_std,
        gyro_bias=gyro_bias,
        max_latency=max_latency,
        estimate_gyro_bias=estimate_gyro_bias,
        estimate_wheel_scale=estimate_wheel_scale,
        recovery_count=recovery_count,
        recovery_spread=recovery_spread,
        tilt_compensation=tilt_compensation,
        slip_yaw_rate=slip_yaw_rate,
        slip_residual=slip_residual,
        collision_decel=collision_decel,
        **_table_args("log", log),
        **_table_args("fixes", fixes),
    )
    return {
        "poses": _table(r["poses"]),
        "odometry": _table(r["odometry"]),
        "fixes": json.loads(r["fixes"]),
        "summary": json.loads(r["summary"]),
    }


TrackLike = Union[Table, str, "os.PathLike[str]", np.ndarray, Any]


def _track(name: str, track: Any) -> Any:
    """A trajectory for the native module: a path, or ``(name, t, x, y, heading)`` float64
    columns from a dict or DataFrame (columns ``t, x, y`` and optional ``heading``) or from a
    2-D array of shape ``(n, 3)`` or ``(n, 4)`` (the same columns in that order)."""
    if isinstance(track, (str, os.PathLike)):
        return os.fspath(track)
    if isinstance(track, dict) or hasattr(track, "columns"):
        missing = [c for c in ("t", "x", "y") if c not in track]
        if missing:
            raise ValueError(
                f"{name}: needs columns t, x, y (optional heading); missing {', '.join(missing)}"
            )
        cols = [np.asarray(track[c], dtype=np.float64) for c in ("t", "x", "y")]
        heading = np.asarray(track["heading"], dtype=np.float64) if "heading" in track else None
        for c, v in zip(("t", "x", "y", "heading"), cols + [heading]):
            if v is not None and v.ndim != 1:
                raise ValueError(f"{name}: column {c} must be 1-D, shape (n,); got {v.shape}")
        return (name, *cols, heading)
    a = np.asarray(track, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] not in (3, 4):
        raise ValueError(
            f"{name}: an array must have shape (n, 3) or (n, 4) (columns t, x, y[, heading]); "
            f"got {a.shape}"
        )
    return (name, a[:, 0], a[:, 1], a[:, 2], a[:, 3] if a.shape[1] == 4 else None)


def _estimates(estimates: Any) -> list:
    """One trajectory or a list of them; a table with a ``trial`` column (the ``trials`` of
    ``simulate``) is one trajectory per trial."""
    if isinstance(estimates, (list, tuple)):
        return [e for i, x in enumerate(estimates) for e in _split(f"estimates[{i}]", x)]
    return _split("estimates", estimates)


def _split(name: str, track: Any) -> list:
    if (isinstance(track, dict) or hasattr(track, "columns")) and "trial" in track:
        trial = np.asarray(track["trial"], dtype=np.float64)
        out = []
        for k in np.unique(trial):
            rows = trial == k
            out.append(
                _track(
                    f"{name} trial {int(k)}",
                    {c: np.asarray(track[c])[rows] for c in ("t", "x", "y", "heading") if c in track},
                )
            )
        return out
    return [_track(name, track)]


def pose_error(
    truth: TrackLike,
    estimates: Union[TrackLike, Sequence[TrackLike]],
    *,
    align: str = "none",
    rpe_time: Optional[float] = None,
    rpe_distance: Optional[float] = None,
) -> Dict[str, Any]:
    """Estimated trajectories scored against ground truth, as ``omnikin evaluate --truth``:
    the absolute trajectory error (ATE) and the relative pose error (RPE) of Sturm et al.,
    IROS 2012 (the TUM RGB-D benchmark), on SE(2) (``omnikin_sim::pose_error``).

    ``truth`` and each estimate: a CSV path (``str`` or ``pathlib.Path``), a dict or pandas
    DataFrame with columns ``t, x, y`` (s, m, world frame) and optional ``heading`` (rad), or
    an array of shape ``(n, 3)`` or ``(n, 4)`` in that column order (several estimates: a list
    of them); values are converted with
    ``numpy.asarray(..., dtype=float64)`` (integer and float32 inputs are accepted). A table
    with a ``trial`` column (``simulate(...)["trials"]``) gives one run per trial. The truth is
    interpolated at each estimate's time. ``align``: ``"none"`` (the start pose is known) or
    ``"se2"`` (least-squares rotation and translation first). RPE over ``rpe_time`` seconds
    (default 1) or ``rpe_distance`` metres along the truth's path; it needs headings.

    Returns ``{"runs": [...], "overall": {...}, "alignment", "rpe_delta"}``: per run (``name``)
    and pooled, ``samples``, ``outside_truth``, and ``ate_m``, ``heading_error_rad``,
    ``rpe_translation_m``, ``rpe_rotation_rad`` each as ``{count, rms, mean, median, max}``
    (``None`` when not computable).
    """
    return json.loads(
        _native.pose_error_native(
            _track("truth", truth),
            _estimates(estimates),
            align=align,
            rpe_time=rpe_time,
            rpe_distance=rpe_distance,
        )
    )


Tables = Union[Table, str, "os.PathLike[str]", Sequence[Union[Table, str, "os.PathLike[str]"]]]


def _tables(name: str, tables: Optional[Tables]) -> list:
    if tables is None:
        return []
    if isinstance(tables, (dict, str, os.PathLike)):
        tables = [tables]
    return [
        (None, _columns(f"{name}[{i}]", t)) if isinstance(t, dict) else (os.fspath(t), None)
        for i, t in enumerate(tables)
    ]


def identify(
    robot: Union[Robot, str, "os.PathLike[str]"],
    encoders: Tables,
    *,
    fixes: Optional[Tables] = None,
    tracked: Optional[Tables] = None,
    imu: Optional[Tables] = None,
) -> Dict[str, Any]:
    """A robot's wheel geometry and gyro bias/scale from recorded runs, as ``omnikin identify``
    (the same fit, ``omnikin_sim::identify``; ``robot`` is the prior).

    ``encoders``: one encoder log per run (``t, q1..qN[, s1..sN][, gyro_z]``, as
    ``simulate(..., emit_sensors=True)`` and ``omnikin robot --log`` write them); a reference
    per run in the same order, either ``fixes`` (camera fixes ``t, x, y[, heading]``) or
    ``tracked`` (a tracked run ``t, x, y[, heading]``); ``imu`` optionally one IMU log per run
    whose ``gz`` is the gyro. Each log is a CSV path or a dict of columns (named
    ``encoders[i]``, ``fixes[i]``, … in errors and in the robot file's comments); a single one
    may stand for a list of one.

    Returns the CLI's ``--json`` object as a dict — ``parameters`` (each with ``name``,
    ``unit``, ``prior``, ``value``, ``sigma`` (1σ), ``status`` ``fitted``/``held`` and the
    ``reason`` when held), ``position_rms_m``, ``heading_rms_rad``, ``gyro_window_rms_rad``,
    ``condition``, ``residuals``, ``runs`` (per run its files and position residual RMS before
    and after the fit, m) — plus ``estimates`` and ``sigma`` (name → value, name → 1σ, the
    fitted parameters only), ``table`` (the text the CLI prints) and ``robot_file`` (the text of
    the identified robot file the CLI's ``--out`` writes). Bad input raises ``ValueError``
    naming the file, line and column.
    """
    if fixes is not None and tracked is not None:
        raise ValueError("give fixes or tracked, not both (one reference per run)")
    if fixes is None and tracked is None:
        raise ValueError(
            "a reference per run is needed: fixes=[...] or tracked=[...] (one per encoder log)"
        )
    name, refs = ("fixes", fixes) if tracked is None else ("tracked", tracked)
    result, table, text = _native.identify_native(
        _robot(robot), _tables("encoders", encoders), _tables(name, refs), name, _tables("imu", imu)
    )
    out = json.loads(result)
    fitted = [p for p in out["parameters"] if p["status"] == "fitted"]
    out["estimates"] = {p["name"]: p["value"] for p in fitted}
    out["sigma"] = {p["name"]: p["sigma"] for p in fitted}
    out["table"] = table
    out["robot_file"] = text
    return out


def _csv_columns(text: str) -> Dict[str, Any]:
    """A CSV table as columns: numbers as float arrays (an empty cell is NaN), text columns
    (an event's level, name and message; a transform's frame ids) as lists of str."""
    import csv
    import io

    rows = list(csv.reader(io.StringIO(text)))
    header, body = rows[0], rows[1:]
    out: Dict[str, Any] = {}
    for i, name in enumerate(header):
        cells = [r[i] if i < len(r) else "" for r in body]
        try:
            out[name] = np.array([float(c) if c != "" else np.nan for c in cells], dtype=np.float64)
        except ValueError:
            out[name] = cells
    return out


def read_mcap(path: Union[str, "os.PathLike[str]"]) -> Dict[str, Dict[str, Any]]:
    """The omnikin channels of an MCAP log as columns, by topic (``/pose``, ``/wheels``,
    ``/trial-002/pose``, ...): the tables ``omnikin convert LOG.mcap --csv DIR`` writes, with the
    same columns (poses ``t, x, y, heading`` in s, m, rad, world frame; ``/wheels`` commanded
    ``w1..wN`` rad/s then measured ``mw1..``; ``/events`` ``t, level, name, message``; see
    docs/seeing-the-robot.md). Numbers come as float arrays (an empty cell is NaN), text as lists of str.

    Reads the Foxglove profile (protobuf or JSON messages, zstd chunks) with the CLI's bounds: a
    file over 1 GiB, or a chunk that would decompress past its declared size, is an error. A
    truncated or damaged file gives the messages before the damage and a ``UserWarning``; so
    does a channel that is not omnikin's (skipped)."""
    import warnings

    channels, notes = _native.read_mcap_native(os.fspath(path))
    for note in notes:
        warnings.warn(note, UserWarning, stacklevel=2)
    return {topic: _csv_columns(text) for topic, _count, text in channels}


def write_mcap(path: Union[str, "os.PathLike[str]"], tables: Dict[str, Dict[str, Any]]) -> int:
    """Writes ``tables`` — by topic, the columns :func:`read_mcap` returns (``/pose``: ``t, x,
    y, heading``; ``/wheels``: ``t, w1.., mw1..``; ``/events``: ``t, level, name, message``;
    ``/plan``: ``t, i, x, y, heading``; ``/trial-NNN/...`` for trials) — to a new MCAP file in
    the Foxglove profile, as ``omnikin convert DIR --mcap`` writes a directory of channel CSV
    files; returns the number of messages. An existing file is never replaced. A topic that
    is not omnikin's, a table without its topic's columns or with columns of different
    lengths raises ``ValueError`` naming the channel; ``read_mcap`` of the written file gives
    the tables back."""
    import csv
    import io

    channels = []
    for topic, table in tables.items():
        if not isinstance(table, dict) or not table:
            raise ValueError(f"channel {topic!r}: expected a dict of columns")
        names = list(table)
        cols = [table[c] for c in names]
        lengths = {len(c) for c in cols}
        if len(lengths) > 1:
            raise ValueError(f"channel {topic!r}: columns of different lengths {sorted(lengths)}")
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(names)
        for row in zip(*cols):
            w.writerow(_cell(v) for v in row)
        channels.append((str(topic), buf.getvalue()))
    return _native.write_mcap_native(os.fspath(path), channels)


def _cell(v: Any) -> str:
    """A CSV cell: a float exactly (``repr``; a whole number without its ``.0``, so counters
    read back as integers), NaN as empty (as ``read_mcap`` reads it)."""
    if isinstance(v, (float, np.floating)):
        f = float(v)
        if math.isnan(f):
            return ""
        return str(int(f)) if f.is_integer() and abs(f) < 2**53 else repr(f)
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return str(v)


class Link(_native.Link):
    """An operator session with a robot — a real one, or ``omnikin robot --sim`` — the code
    ``omnikin drive`` runs: ``Link("127.0.0.1:7700", key=None, heartbeat_hz=20.0,
    timeout_s=1.0, mcap=None, keep_rows=100_000)`` opens the session (handshake, first
    telemetry; ``key`` a key file for a keyed link, ``mcap`` a log written as ``drive --mcap``
    writes it). Every action waits for the robot's telemetry to confirm it:

    * ``info()``: what the robot said in the handshake (kind, plan capacity, control rate,
      watchdog, limits).
    * ``velocity(vx, vy, yaw_rate, duration, world=False)``: m/s, m/s, rad/s in the robot frame
      (world frame with ``world=True``) for ``duration`` s, then a stop.
    * ``stop()``, ``estop()`` (latched), ``clear()``, ``listen(duration)`` (heartbeats only).
    * ``run_plan(plan, set_pose=True, start_tolerance=0.05)``: a plan (``omnikin.plan``'s
      columns or a plan CSV) held to the robot's limits, uploaded and followed to its end.
    * ``telemetry()``: the frames since the last call, as columns (the columns of ``drive
      --out``'s CSV log: ``t, x, y, heading, vx, ..., w1.., q1.., mode, ...``).
    * ``close()`` (or ``with Link(...) as link:``): leaves the session.

    A refusal by the robot or a lost link raises ``RuntimeError``; bad arguments ``ValueError``.
    Ctrl-C ends a wait with ``KeyboardInterrupt``; the robot's watchdog stops it when the
    heartbeats stop."""

    def run_plan(self, plan_: PlanLike, *, set_pose: bool = True, start_tolerance: float = 0.05) -> dict:
        """Drives ``plan_`` to its end; returns what happened (``max_deviation`` m from the
        reference while following, ``end_pose``, the upload's ``points``, ``chunks``,
        ``upload_s``; ``streamed`` for a robot that takes no plans)."""
        return self.run_plan_native(
            **_plan_args(plan_), set_pose=set_pose, start_tolerance=start_tolerance
        )

    def telemetry(self) -> Dict[str, Any]:
        """The telemetry frames since the last call as columns (float arrays; ``mode``,
        ``faults`` as lists of str). Frames beyond ``keep_rows`` since the last call were
        dropped, oldest first, with a ``UserWarning``."""
        import warnings

        text, dropped = self.take_telemetry_native()
        if dropped:
            warnings.warn(f"{dropped} telemetry frames dropped (keep_rows)", UserWarning, stacklevel=2)
        return _csv_columns(text) if text else {}


class SimRobot(_native.SimRobot):
    """A simulated robot served over the link on a thread of this process — the code
    ``omnikin robot --sim`` runs: ``SimRobot("kiwi", listen="127.0.0.1:0", time_scale=8)``
    builds it and binds the address (``127.0.0.1:0``: a free port; ``address`` says which),
    then serves until ``stop()``. Drive it with ``Link(robot.address)`` or ``omnikin drive
    --connect ADDRESS``.

    Keywords are ``omnikin robot``'s flags: ``key`` (a key file), ``plant`` (``"kinematic"``
    or ``"dynamic"``), ``disturbances`` (``"ideal"``, ``"hardware"``, ``"spin-slip"`` or a
    profile file), ``seed``, ``rate`` (control, Hz), ``telemetry_rate`` (Hz), ``watchdog`` (s),
    ``time_scale`` (robot time per wall-clock time), ``max_time`` (s of robot time, then it
    ends by itself: ``wait()``), ``max_speed``, ``max_yaw_rate``, ``max_accel``,
    ``max_yaw_accel``, ``max_jerk`` (lower than the robot file's, never higher),
    ``gyro_heading``, ``log`` (the ``--log`` CSV) and ``mcap``.

    * ``stop()``: ends the robot at its next control cycle and returns its summary (the JSON
      ``omnikin robot --max-time`` prints: ``time_s``, ``link`` counters, ``mode``, ``pose``,
      ``true_pose``, ``plan``, ``fixes``, ...) as a dict.
    * ``wait()``: the same for a robot started with ``max_time``, once it has ended.
    * ``with SimRobot(...) as robot:`` stops it on leaving; so does dropping the object.

    Bad keywords raise ``ValueError`` at once (named as ``omnikin robot``'s flags when the
    check is the robot's own, e.g. ``--max-accel`` for ``max_accel``)."""

    def stop(self) -> Optional[Dict[str, Any]]:
        """Stops the robot; its summary as a dict (``None`` if it had already ended and was
        asked before)."""
        import json

        text = self.stop_native()
        return json.loads(text) if text else None

    def wait(self) -> Optional[Dict[str, Any]]:
        """Waits for a robot started with ``max_time`` to end; its summary as a dict."""
        import json

        text = self.wait_native()
        return json.loads(text) if text else None

    def __enter__(self) -> "SimRobot":
        return self

    def __exit__(self, *exc: Any) -> bool:
        self.stop()
        return False

    def __repr__(self) -> str:
        state = "serving" if self.running else "ended"
        return f"SimRobot(address={self.address!r}, {state})"


def __dir__() -> list:
    """``dir(omnikin)``: the public names only (PEP 562), not the modules and typing names
    this file imports."""
    return sorted(__all__)
