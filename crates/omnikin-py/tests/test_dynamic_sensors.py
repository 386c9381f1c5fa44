"""simulate(plant="dynamic") for the sphere and the ballbot, emit_sensors, the steer-step
check and waypoints from an array, against `omnikin plan/simulate` on the same inputs (the
same columns as the CSV files, equal to 1e-12, the same metrics.json and error messages)."""

import json
import warnings

import numpy as np
import pytest

import omnikin
from conftest import ROOT, read_csv
from test_plan_sim import assert_metrics, assert_table


def cli_plan(cli, tmp_path, robot, *args):
    f = tmp_path / f"plan-{robot}.csv"
    cli.run("plan", *args, "--robot", robot, "--out", f, "--force")
    return f


def assert_sim(got, out, plan_name):
    assert_table(got["trials"], read_csv(out / "trials.csv"))
    assert_table(got["mean"], read_csv(out / "mean.csv"))
    want = json.loads((out / "metrics.json").read_text())
    assert got["metrics"]["simulation"]["plan"] == plan_name
    assert_metrics(got["metrics"], want)


def test_sphere_dynamic_matches_cli(cli, tmp_path):
    plan = cli_plan(cli, tmp_path, "sphere-omni", "circle", "--omega", "2", "--radius", "0.2")
    out = tmp_path / "sim"
    cli.run("simulate", plan, "--robot", "sphere-omni", "--plant", "dynamic", "--out", out)
    got = omnikin.simulate("sphere-omni", str(plan), plant="dynamic", trials=1)
    assert_sim(got, out, str(plan))
    # The fast circle grows (paper 000's dynamics), and the per-sample tilt is the figure's.
    assert got["metrics"]["radius_ratio"] > 1.2
    d = got["dynamics"]
    assert list(d) == ["t", "tilt", "shell_spin"]
    np.testing.assert_array_equal(d["t"], got["trials"]["t"])
    assert abs(d["tilt"].max() - got["metrics"]["simulation"]["max_tilt_rad"]) < 1e-6 + 0.05
    # A dict plan (written exactly) gives the same numbers.
    again = omnikin.simulate("sphere-omni", omnikin.plan("sphere-omni", "circle", omega=2.0),
                             plant="dynamic", trials=1)
    assert_table(again["trials"], got["trials"])


@pytest.mark.parametrize("extra, kw", [
    ([], {}),
    (["--seed", "7", "--initial-tilt-deg", "3", "--push", "5@2@45", "--push", "2@4"],
     {"seed": 7, "initial_tilt_deg": 3.0, "push": [(5, 2, 45), (2, 4)]}),
    (["--push", "200@2"], {"push": [(200.0, 2.0)]}),
])
def test_ballbot_dynamic_matches_cli(cli, tmp_path, extra, kw):
    plan = cli_plan(cli, tmp_path, "ballbot", "square", "--side", "0.5", "--speed", "0.2")
    out = tmp_path / "sim"
    cli.run("simulate", plan, "--robot", "ballbot", "--plant", "dynamic", *extra, "--out", out)
    got = omnikin.simulate("ballbot", plan, plant="dynamic", trials=1, **kw)
    assert_sim(got, out, str(plan))
    m = got["metrics"]
    c = got["cycles"]
    assert list(c) == ["t", "tilt", "x", "y"]
    assert abs(np.degrees(c["tilt"].max()) - m["max_tilt_deg"]) < 1e-9
    if kw.get("push") == [(200.0, 2.0)]:
        assert m["fallen"] and 2.0 <= m["fall_time_s"] < 3.0
    else:
        assert not m["fallen"]


def test_dynamic_errors_are_the_clis(cli, tmp_path):
    caster = cli_plan(cli, tmp_path, "caster3", "square")
    ballbot = cli_plan(cli, tmp_path, "ballbot", "square")
    for robot, plan, flags, kw in [
        ("caster3", caster, [], {}),
        ("ballbot", ballbot, ["--push", "1@100"], {"push": [(1, 100)]}),
    ]:
        want = cli.error("simulate", plan, "--robot", robot, "--plant", "dynamic", *flags,
                         "--out", tmp_path / "x")
        with pytest.raises(ValueError) as e:
            omnikin.simulate(robot, str(plan), plant="dynamic", **kw)
        assert str(e.value) == want
    with pytest.raises(ValueError, match="need a ballbot"):
        omnikin.simulate("ballbot", ballbot, initial_tilt_deg=2.0)
    with pytest.raises(ValueError, match="need a ballbot"):
        omnikin.simulate("sphere-omni", caster, plant="dynamic", push=[(1, 1)])
    with pytest.raises(ValueError, match="emit_sensors: not yet for the ballbot's dynamic plant"):
        omnikin.simulate("ballbot", ballbot, plant="dynamic", emit_sensors=True)
    with pytest.raises(ValueError, match="does not take disturbances yet"):
        omnikin.simulate("sphere-omni", caster, plant="dynamic", disturbances="d.toml")
    tilt = tmp_path / "tilt.toml"
    tilt.write_text("[tilt]\nroll = 0.1\npitch = 0.0\n")
    with pytest.raises(ValueError, match=r"sensors: \[tilt\] sets a constant platform tilt"):
        omnikin.simulate("sphere-omni", caster, plant="dynamic", emit_sensors=True,
                         sensors=str(tilt))
    with pytest.raises(ValueError, match=r"push 1: impulse 0 N·s must be in \(0, 1000\]"):
        omnikin.simulate("ballbot", ballbot, plant="dynamic", push=[(0, 1)])
    with pytest.raises(ValueError, match="push 2: expected"):
        omnikin.simulate("ballbot", ballbot, plant="dynamic", push=[(1, 1), (1,)])
    with pytest.raises(ValueError, match="initial_tilt_deg: 60° must be within ±60°"):
        omnikin.simulate("ballbot", ballbot, plant="dynamic", initial_tilt_deg=60)
    with pytest.raises(ValueError, match="plant"):
        omnikin.simulate("ballbot", ballbot, plant="rigid")
    with pytest.raises(ValueError, match="sensors: needs emit_sensors"):
        omnikin.simulate("kiwi", caster, sensors="s.toml")


@pytest.mark.parametrize("robot, sensors", [("caster3", None), ("kiwi", "imu")])
def test_emit_sensors_matches_cli(cli, tmp_path, robot, sensors):
    plan = cli_plan(cli, tmp_path, robot, "circle", "--omega", "1", "--ramp", "0.5")
    extra = []
    if sensors:
        f = tmp_path / "sensors.toml"
        f.write_text(
            "counts_per_rev = 1024\n"
            "[gyro]\nnoise_std = 0.01\nbias = 0.001\nbias_std = 0.0005\n"
            "[yaw]\nnoise_std = 0.01\nwrap = true\n"
            "[imu]\ngyro_noise_std = 0.001\ngyro_bias = [0.0, 0.0, 0.001]\n"
            "accel_noise_std = 0.01\nmag_noise_std = 0.1\nfield = [0.0, 20.0, -45.0]\n"
            "[camera]\nperiod = 0.2\nlatency = 0.05\nnoise_std = 0.002\n"
            "heading_noise_std = 0.01\noutlier_probability = 0.1\noutlier_distance = 0.3\n")
        extra = ["--sensors", f]
    out = tmp_path / "sim"
    cli.run("simulate", plan, "--robot", robot, "--trials", "3", "--seed", "5",
            "--emit-sensors", *extra, "--out", out)
    got = omnikin.simulate(robot, plan, trials=3, seed=5, emit_sensors=True,
                           sensors=extra[1] if extra else None)
    assert_table(got["trials"], read_csv(out / "trials.csv"))
    assert len(got["sensors"]) == 3
    for i, logs in enumerate(got["sensors"]):
        d = out / "sensors" / f"trial-{i:03}"
        assert sorted(logs) == sorted(p.stem for p in d.iterdir())
        for name, table in logs.items():
            assert_table(table, read_csv(d / f"{name}.csv"))
    assert "sensors" not in omnikin.simulate(robot, plan, trials=1)


def test_sphere_dynamic_emit_sensors_matches_cli(cli, tmp_path):
    """plant="dynamic" with emit_sensors: the sphere's logs (IMU on the model's tilting
    platform) equal the files of `simulate --plant dynamic --emit-sensors`, with the default
    and with a noisy profile; the IMU's gx, gy rock after the `stop` plan's stop, and
    `identify` reads the logs back (as the CLI's files)."""
    cli.run("plan", "sysid", "--robot", "sphere-omni", "--out", tmp_path / "plans", "--force")
    plan = tmp_path / "plans" / "stop.csv"
    f = tmp_path / "sensors.toml"
    f.write_text(
        "counts_per_rev = 4096\n"
        "[imu]\ngyro_noise_std = 0.002\ngyro_bias = [0.001, 0.0, 0.002]\n"
        "accel_noise_std = 0.01\nmag_noise_std = 0.1\nfield = [0.0, 20.0, -45.0]\n"
        "[camera]\nperiod = 0.1\nlatency = 0.1\nnoise_std = 0.005\n"
        "outlier_probability = 0.0\noutlier_distance = 0.5\n")
    for extra, kw in [([], {}), (["--sensors", f, "--seed", "9"], {"sensors": str(f), "seed": 9})]:
        out = tmp_path / f"sim{len(extra)}"
        cli.run("simulate", plan, "--robot", "sphere-omni", "--plant", "dynamic",
                "--emit-sensors", *extra, "--out", out)
        got = omnikin.simulate("sphere-omni", plan, plant="dynamic", emit_sensors=True, **kw)
        assert_sim(got, out, str(plan))
        assert len(got["sensors"]) == 1
        logs = got["sensors"][0]
        d = out / "sensors" / "trial-000"
        assert sorted(logs) == sorted(p.stem for p in d.iterdir())
        for name, table in logs.items():
            assert_table(table, read_csv(d / f"{name}.csv"))
        imu = logs["imu"]
        # The platform rocks after the stop: body rates about x or y of a tenth of a rad/s.
        rest = imu["t"] > plan_stop_time(got)
        assert np.abs(np.hstack([imu["gx"][rest], imu["gy"][rest]])).max() > 0.1
    assert "sensors" not in omnikin.simulate("sphere-omni", plan, plant="dynamic")


def test_sphere_pivot_friction_identified_in_memory(cli, tmp_path):
    """The loop in Python: the `spin` and `spin-stop` plans through a sphere whose floor's
    pivot friction is twice the preset's (plant="dynamic", emit_sensors=True), then
    omnikin.identify on the logs' columns: the friction within 10 % and 2σ, written into the
    identified robot file."""
    cli.run("plan", "sysid", "--robot", "sphere-omni", "--out", tmp_path / "plans", "--force")
    text = (ROOT / "robots" / "sphere-omni.toml").read_text()
    truth = tmp_path / "sphere-true.toml"
    truth.write_text(text.replace('floor = "vinyl"', 'floor = "vinyl"\npivot_friction = 0.042', 1))
    logs = [omnikin.simulate(str(truth), tmp_path / "plans" / f"{p}.csv", plant="dynamic",
                             emit_sensors=True)["sensors"][0] for p in ["spin", "spin-stop"]]
    r = omnikin.identify("sphere-omni", [l["encoders"] for l in logs],
                         fixes=[l["fixes"] for l in logs], imu=[l["imu"] for l in logs])
    v, s = r["estimates"]["dynamics.pivot_friction"], r["sigma"]["dynamics.pivot_friction"]
    assert abs(v - 0.042) < 0.1 * 0.042 and abs(v - 0.042) < 2 * s, (v, s)
    assert len(r["spin_decay"]) == 1
    assert "pivot_friction = " in r["robot_file"] and "spin's decay" in r["robot_file"]


def plan_stop_time(sim) -> float:
    """The time the plan's wheels stop for the last time (the mean's plan columns stop
    moving)."""
    m = sim["mean"]
    v = np.hypot(np.diff(m["plan_x"]), np.diff(m["plan_y"]))
    return float(m["t"][1:][v > 1e-9].max())


def test_waypoints_from_an_array_match_the_file(cli, tmp_path):
    pts = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.5], [0.5, 0.4, 1.0], [0.0, 0.6, 1.5]])
    wp = tmp_path / "wp.csv"
    np.savetxt(wp, pts, delimiter=",", header="x,y,heading", comments="")
    for p, kw in [(pts, {"path": "spline"}), (pts[:, :2], {"corners": "fillet"})]:
        f = wp if p.shape[1] == 3 else tmp_path / "wp2.csv"
        if p.shape[1] == 2:
            np.savetxt(f, p, delimiter=",", header="x,y", comments="")
        got = omnikin.plan("x-drive", "waypoints", points=p, **kw)
        flag = ["--path", "spline"] if "path" in kw else ["--corners", "fillet"]
        out = tmp_path / "plan.csv"
        cli.run("plan", "waypoints", f, "--robot", "x-drive", *flag, "--out", out, "--force")
        assert_table(got, read_csv(out))
    with pytest.raises(ValueError, match="points:2: .*repeat"):
        omnikin.plan("kiwi", "waypoints", points=[[0, 0], [0, 0], [1, 0]])
    with pytest.raises(ValueError, match=r"points: expected shape \(N, 2\) of x, y or \(N, 3\)"):
        omnikin.plan("kiwi", "waypoints", points=np.zeros((3, 4)))
    # int64 points (numpy's default for integers) plan as the same floats do.
    ints = np.array([[0, 0], [1, 0], [1, 1]])
    np.testing.assert_array_equal(
        omnikin.plan("kiwi", "waypoints", points=ints)["x"],
        omnikin.plan("kiwi", "waypoints", points=ints.astype(np.float64))["x"],
    )
    with pytest.raises(ValueError, match="file or points, not both"):
        omnikin.plan("kiwi", "waypoints", points=pts, file=str(wp))
    with pytest.raises(ValueError, match="points:3: .*not finite"):
        omnikin.plan("kiwi", "waypoints", points=[[0, 0], [1, 0], [np.nan, 1]])


@pytest.mark.parametrize("step, refused", [(0.05, False), (0.5, True)])
def test_steer_steps_are_checked_as_the_cli_checks_them(cli, tmp_path, step, refused):
    plan = cli_plan(cli, tmp_path, "swerve4", "square", "--speed", "0.2")
    p = read_csv(plan)
    # Module 1 turns by `step` between samples 10 and 11 without a steer rate for it.
    p["s1"][11:] += step
    bad = tmp_path / "bad.csv"
    with open(bad, "w") as f:
        f.write(",".join(p) + "\n")
        for row in zip(*p.values()):
            f.write(",".join(repr(float(v)) for v in row) + "\n")
    out = tmp_path / "sim"
    r = cli.run("simulate", bad, "--robot", "swerve4", "--trials", "1", "--out", out, check=False)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        if refused:
            with pytest.raises(ValueError) as e:
                omnikin.simulate("swerve4", str(bad), trials=1)
            assert r.returncode != 0
            assert "error: " + str(e.value) == r.stderr.strip().splitlines()[-1]
        else:
            got = omnikin.simulate("swerve4", str(bad), trials=1)
            assert r.returncode == 0
            assert_table(got["trials"], read_csv(out / "trials.csv"))
            warned = [str(x.message) for x in w]
            steps = [m for m in warned if "s1 steps by 0.0500 rad" in m]
            assert len(steps) == 1 and "warning: " + steps[0] in r.stderr
