"""`omnikin.SimRobot` serves a simulated robot on a thread of the Python process — the code
`omnikin robot --sim` runs — so `omnikin.Link` (and `omnikin drive`) can drive it without the
binary; its summary, logs and refusals are the CLI's."""

import gc
import math
import pathlib
import re
import socket

import pytest

import omnikin


def test_a_link_drives_a_simulated_robot_of_this_process():
    with omnikin.SimRobot("kiwi", time_scale=8) as robot:
        assert re.fullmatch(r"127\.0\.0\.1:\d+", robot.address) and robot.running
        assert "serving" in repr(robot)
        with omnikin.Link(robot.address, heartbeat_hz=100, timeout_s=2.0) as link:
            assert link.info()["kind"] == "omni"
            link.velocity(0.2, 0.0, 0.0, 0.25)  # wall clock; robot frame: +x from heading 0
            t = link.telemetry()
        summary = robot.stop()
    assert not robot.running and "ended" in repr(robot)
    # The robot drove about 0.2 m/s along x for as long as its telemetry says it was in
    # velocity mode (robot time: 8× the wall clock, less on a loaded machine; the slew at
    # either end costs a little), and not sideways; the estimate is the wheels' odometry, the
    # truth the plant's: equal without disturbances.
    moving = [ti for ti, m in zip(t["t"], t["mode"]) if m == "velocity"]
    driven = 0.2 * (max(moving) - min(moving))
    x, y, h = summary["true_pose"]
    assert x > 0.05 and abs(x - driven) < 0.04 and abs(y) < 1e-3 and abs(h) < 1e-3, (x, driven, summary)
    assert math.dist(summary["pose"][:2], summary["true_pose"][:2]) < 1e-3
    assert summary["link"]["sessions"] == 1 and summary["link"]["ok"] > 10  # 100 Hz heartbeats for 0.25 s
    assert summary["mode"] == "idle" and summary["time_s"] > 1.0
    assert t["x"][-1] == pytest.approx(summary["pose"][0], abs=0.01)
    # A second stop has nothing more to say.
    assert robot.stop() == summary


def test_max_time_ends_the_robot_and_its_log_is_the_clis(tmp_path):
    log = tmp_path / "robot.csv"
    robot = omnikin.SimRobot("swerve4", time_scale=20, max_time=0.5, log=log)
    summary = robot.wait()
    assert summary["time_s"] == pytest.approx(0.5, abs=0.011)
    assert not robot.running
    lines = log.read_text().splitlines()
    assert lines[0].startswith("t,x,y,heading,true_x,true_y,true_heading,cmd_vx,cmd_vy,cmd_yaw_rate,w1")
    assert ",sd4," in lines[0]  # swerve: steer-rate commands too
    assert 49 <= len(lines) - 1 <= 52  # 100 Hz for 0.5 s
    # An existing log is never replaced; Python has no --force, and the error does not ask
    # for one.
    with pytest.raises(ValueError, match="log .*exists.*never replaced.*remove it first") as e:
        omnikin.SimRobot("kiwi", log=log)
    assert "--" not in str(e.value), e.value


def test_bad_keywords_are_refused_by_name():
    with pytest.raises(ValueError, match="plant must be"):
        omnikin.SimRobot("kiwi", plant="wobbly")
    for kw, value, name in [
        ("rate", 0.0, "rate"),
        ("rate", float("nan"), "rate"),
        ("telemetry_rate", 1e9, "telemetry_rate"),
        ("time_scale", 0.0, "time_scale"),
        ("watchdog", -1.0, "watchdog"),
        ("max_time", float("inf"), "max_time"),
    ]:
        with pytest.raises(ValueError, match=name):
            omnikin.SimRobot("kiwi", **{kw: value})
    # The robot file's limits: a flag above them is refused, named as the CLI names it.
    with pytest.raises(ValueError, match="--max-accel"):
        omnikin.SimRobot("kiwi", max_accel=1e6)
    # Without a key, only loopback; the errors name Python's keywords, not the CLI's flags.
    with pytest.raises(ValueError, match="listen 0.0.0.0:0: without key .* give key") as e:
        omnikin.SimRobot("kiwi", listen="0.0.0.0:0")
    assert "--" not in str(e.value), e.value
    with pytest.raises(ValueError, match="no-such-robot"):
        omnikin.SimRobot("no-such-robot")
    with pytest.raises(RuntimeError, match="max_time"):
        with omnikin.SimRobot("kiwi") as robot:
            robot.wait()


def test_a_dropped_robot_stops_and_frees_its_address():
    robot = omnikin.SimRobot("kiwi")
    host, port = robot.address.split(":")
    del robot
    gc.collect()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind((host, int(port)))  # would fail (address in use) with the robot still serving


def test_the_docs_example_runs():
    docs = pathlib.Path(__file__).resolve().parents[3] / "docs" / "python.md"
    section = docs.read_text().split("### A simulated robot in the same process")[1].split("\n## ")[0]
    (code,) = re.findall(r"```py\n(.*?)```", section, flags=re.S)
    scope: dict = {}
    exec(compile(code, "docs/python.md", "exec"), scope)
    s = scope["summary"]
    assert 0.05 < s["true_pose"][0] < 0.4 and s["link"]["ok"] > 0


def test_the_links_errors_name_pythons_keywords(tmp_path):
    short = tmp_path / "short.key"
    short.write_text("too short")
    with pytest.raises(ValueError, match=r"^key .*short.key: key must be 16 to 64 bytes") as e:
        omnikin.Link("127.0.0.1:9", key=short)
    assert "--" not in str(e.value), e.value
    with pytest.raises(ValueError, match="connect") as e:
        omnikin.Link("not-an-address")
    assert "--" not in str(e.value), e.value
    with omnikin.SimRobot("kiwi", time_scale=4) as robot:
        existing = tmp_path / "old.mcap"
        existing.write_bytes(b"keep me")
        with pytest.raises(ValueError, match="mcap .*old.mcap: exists.*remove it first") as e:
            omnikin.Link(robot.address, mcap=existing)
        assert existing.read_bytes() == b"keep me"
        assert "--" not in str(e.value), e.value
        keyed = tmp_path / "k.key"
        keyed.write_text("0123456789abcdef0123")
        # A keyed operator and a robot without a key: told to drop `key`, not `--key`.
        with pytest.raises(RuntimeError, match="sends key; drop key") as e:
            omnikin.Link(robot.address, key=keyed, timeout_s=1.0)
        assert "--" not in str(e.value), e.value


def test_a_plan_past_the_robots_body_limits_warns_as_the_cli_does(cli, tmp_path):
    """`omnikin.plan` says what `omnikin plan` says when a plan asks more than the robot's body
    limits (the paper's square at 0.3 m/s starts in 0.05 s: 6 m/s² on a 1 m/s² swerve) — the
    plan a Link then refuses to upload — and nothing for one within them."""
    import warnings

    with pytest.warns(UserWarning, match=r"the plan asks 6 m/s² of acceleration at t = 0\.04 s, more than the robot's 1 m/s²") as w:
        fast = omnikin.plan("swerve4", "square", side=0.3, speed=0.3)
    assert "omnikin.Link.run_plan refuses" in str(w[0].message)
    out = tmp_path / "sq.csv"
    r = cli.run("plan", "square", "--robot", "swerve4", "--side", "0.3", "--speed", "0.3", "--out", out)
    cli_warning = [l for l in r.stderr.splitlines() if l.startswith("warning: the plan asks")]
    assert cli_warning and cli_warning[0].split(":")[1].strip() in str(w[0].message), (cli_warning, w[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        omnikin.plan("kiwi", "waypoints", points=[[0, 0], [0.5, 0]])
    with omnikin.SimRobot("swerve4", time_scale=8) as robot, omnikin.Link(robot.address) as link:
        with pytest.raises(ValueError, match="not uploaded: the plan asks 6 m/s²"):
            link.run_plan(fast)
