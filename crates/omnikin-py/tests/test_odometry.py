"""odometry against `omnikin odometry` on the same logs (sensor logs of `omnikin simulate
--emit-sensors`): the poses CSV's columns equal to 1e-12, the summary the CLI prints, the
CLI's errors; the log and fixes as CSV paths and as dicts of columns."""

import re
import warnings

import numpy as np
import pytest

import omnikin
from conftest import read_csv
from test_plan_sim import assert_table


@pytest.fixture(scope="module")
def logs(cli, tmp_path_factory):
    """Sensor logs of one trial per robot: {robot: directory}."""
    d = tmp_path_factory.mktemp("odometry")
    out = {}
    for robot in ["kiwi", "caster3", "sphere-omni"]:
        plan = d / f"{robot}.csv"
        cli.run("plan", "circle", "--robot", robot, "--omega", "1", "--ramp", "0.5", "--out", plan)
        sim = d / f"sim-{robot}"
        cli.run("simulate", plan, "--robot", robot, "--trials", "1", "--seed", "3",
                "--emit-sensors", "--out", sim)
        out[robot] = sim / "sensors" / "trial-000"
    return out


CASES = [
    ("kiwi", [], {}),
    ("kiwi", ["--fixes"], {}),
    ("caster3", ["--fixes", "--imu"], {"imu": True}),
    ("caster3", ["--initial-pose", "0.1,-0.2,0.3", "--fix-std", "0.02"],
     {"initial_pose": (0.1, -0.2, 0.3), "fix_std": 0.02}),
    ("sphere-omni", ["--imu", "--gyro-bias", "0.001"], {"imu": True, "gyro_bias": 0.001}),
]


@pytest.mark.parametrize("robot, flags, kw", CASES)
def test_odometry_matches_cli(cli, tmp_path, logs, robot, flags, kw):
    d = logs[robot]
    log, fixes = d / "encoders.csv", d / "fixes.csv"
    args = []
    for f in flags:
        args += [f, fixes] if f == "--fixes" else [f]
    out = tmp_path / "poses.csv"
    p = cli.run("odometry", log, "--robot", robot, *args, "--out", out)
    want = read_csv(out)
    fx = fixes if "--fixes" in flags else None
    cli_warnings = [l[len("warning: "):] for l in p.stderr.splitlines() if l.startswith("warning: ")]
    as_dicts = (read_csv(log), None if fx is None else read_csv(fx))
    for files, (log_arg, fixes_arg) in [(True, (str(log), fx and str(fx))), (False, as_dicts)]:
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            got = omnikin.odometry(robot, log_arg, fixes=fixes_arg, **kw)
        assert_table(got["poses"], want)
        # Fixes rejected as outliers warn as the CLI warns (a dict names its table "fixes").
        msgs = [str(x.message) for x in w]
        if files:
            assert msgs == cli_warnings
        else:
            assert len(msgs) == len(cli_warnings)
    s = got["summary"]
    printed = p.stderr
    assert f"{s['samples']} samples over {s['duration_s']:.3f} s" in printed
    assert f"odometry path {s['path_length_m']:.4f} m" in printed
    e = s["end"]
    assert f"end pose x {e['x']:.4f} m, y {e['y']:.4f} m, heading {e['heading']:.4f} rad" in printed
    assert f"heading from {s['heading_source']}" in printed
    if fx is None:
        assert s["fixes"] is None and got["fixes"] == []
        # Without fixes the fused pose is the odometry.
        assert_table(got["odometry"], got["poses"])
    else:
        f = s["fixes"]
        assert (f"fixes: {f['accepted']} fused, {f['rejected']} rejected as outliers, "
                f"{f['too_late']} arrived too late (> --max-latency), {f['after_log']} after the log"
                ) in printed
        assert f"recoveries: {f['reinitialised']} re-initialised, {f['inflated']} inflated" in printed
        if f["wheel_scale"] is not None:
            k = f["wheel_scale"]
            assert f"estimated wheel scale {k['value']:.5f} ± {k['std']:.5f}" in printed
        assert len(got["fixes"]) == len(read_csv(fx)["t"])
        # Fused fixes: plain, the one that set the pose, and the ones that ended a recovery.
        fused = ("accepted", "initialised", "reinitialised", "inflated")
        assert sum(r["result"] in fused for r in got["fixes"]) == f["accepted"]
        assert sum(r["result"] == "too_late" for r in got["fixes"]) == f["too_late"]
        # The odometry columns are the pure wheel odometry: what the CLI gives without fixes.
        plain = tmp_path / "plain.csv"
        cli.run("odometry", log, "--robot", robot, *[a for a in args if a not in ("--fixes", fixes)],
                "--out", plain)
        w = read_csv(plain)
        np.testing.assert_allclose(got["odometry"]["x"], w["x"], rtol=0, atol=1e-12)


def test_odometry_errors_are_the_clis(cli, tmp_path, logs):
    log = logs["kiwi"] / "encoders.csv"
    bad = tmp_path / "bad.csv"
    t = read_csv(log)
    t["q2"][5] = np.inf
    with open(bad, "w") as f:
        f.write(",".join(t) + "\n")
        for row in zip(*t.values()):
            f.write(",".join(repr(float(v)) for v in row) + "\n")
    for robot, path in [("caster3", log), ("kiwi", bad)]:
        want = cli.error("odometry", path, "--robot", robot, "--out", tmp_path / "o.csv")
        with pytest.raises(ValueError) as e:
            omnikin.odometry(robot, str(path))
        assert str(e.value) == want
    # A dict names the table "log"; its line is the row + 1.
    with pytest.raises(ValueError, match=re.escape("log:7:")):
        omnikin.odometry("kiwi", t)
    no_imu = {k: v for k, v in read_csv(log).items() if k not in ("gyro_z", "yaw")}
    with pytest.raises(ValueError, match="imu"):
        omnikin.odometry("kiwi", no_imu, imu=True)
    with pytest.raises(ValueError, match="same length"):
        omnikin.odometry("kiwi", {"t": [0.0, 1.0], "q1": [0.0]})


@pytest.mark.parametrize("flags, kw", [
    (["--max-latency", "0.05"], {"max_latency": 0.05}),
    (["--no-wheel-scale-state", "--no-gyro-bias-state"],
     {"estimate_wheel_scale": False, "estimate_gyro_bias": False}),
    (["--recovery-count", "2", "--recovery-spread", "0.2"],
     {"recovery_count": 2, "recovery_spread": 0.2}),
])
def test_odometry_filter_options_are_the_clis(cli, tmp_path, logs, flags, kw):
    """The filter's options (latency window, bias/scale states, recovery) as the CLI's flags."""
    d = logs["caster3"]
    log, fixes = d / "encoders.csv", d / "fixes.csv"
    out = tmp_path / "poses.csv"
    p = cli.run("odometry", log, "--robot", "caster3", "--fixes", fixes, "--imu", *flags,
                "--out", out)
    got = omnikin.odometry("caster3", str(log), fixes=str(fixes), imu=True, **kw)
    assert_table(got["poses"], read_csv(out))
    f = got["summary"]["fixes"]
    assert f"{f['too_late']} arrived too late" in p.stderr
    if kw.get("estimate_wheel_scale") is False:
        assert f["wheel_scale"] is None and f["gyro_bias_rad_s"] is None
    if "max_latency" in kw:
        # The simulated camera is late by more than 50 ms: some fixes miss the window.
        assert f["too_late"] > 0


def test_odometry_filter_option_errors(logs):
    log = str(logs["kiwi"] / "encoders.csv")
    for kw, field in [({"recovery_count": 0}, "recovery_count"), ({"max_latency": -1.0}, "max_latency"),
                      ({"recovery_spread": float("nan")}, "recovery_spread")]:
        with pytest.raises(ValueError, match=field):
            omnikin.odometry("kiwi", log, **kw)


def test_simulated_sensor_logs_feed_odometry(logs):
    """simulate(emit_sensors=True) → odometry, in memory: the logs are the CLI's files."""
    p = omnikin.plan("kiwi", "circle", omega=1.0, ramp=0.5)
    r = omnikin.simulate("kiwi", p, trials=1, seed=3, emit_sensors=True)
    s = r["sensors"][0]
    truth = s["truth"]
    start = (truth["x"][0], truth["y"][0], truth["heading"][0])
    got = omnikin.odometry("kiwi", s["encoders"], fixes=s["fixes"], initial_pose=start)
    want = omnikin.odometry("kiwi", logs["kiwi"] / "encoders.csv",
                            fixes=logs["kiwi"] / "fixes.csv", initial_pose=start)
    assert_table(got["poses"], want["poses"])
    # Odometry of an ideal plant follows the truth to encoder resolution.
    assert np.max(np.hypot(got["odometry"]["x"] - truth["x"], got["odometry"]["y"] - truth["y"])) < 0.05
