"""`omnikin.Link` drives `omnikin robot --sim` from Python with the code `omnikin drive` runs:
each action confirmed by the robot, the telemetry in the columns of `drive --out`, a plan
uploaded and followed, refusals raised."""

import socket
import subprocess

import numpy as np
import pytest

import omnikin



def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def sim_robot(cli):
    """`omnikin robot --sim --robot kiwi` at 8× real time on a free loopback port."""
    addr = f"127.0.0.1:{free_port()}"
    p = subprocess.Popen(
        [str(cli.path), "robot", "--sim", "--robot", "kiwi", "--listen", addr,
         "--time-scale", "8", "--max-time", "60"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )
    try:
        yield addr
    finally:
        p.kill()
        p.wait(timeout=10)


def test_a_link_drives_the_simulated_robot_and_records_what_drive_records(cli, sim_robot, tmp_path):
    with omnikin.Link(sim_robot, heartbeat_hz=100, timeout_s=2.0) as link:
        info = link.info()
        assert info["kind"] == "omni" and info["plan_capacity"] > 0 and info["rate_hz"] > 0
        link.telemetry()  # the handshake's frames
        link.velocity(0.2, 0.0, 0.5, 0.3)
        t = link.telemetry()
        assert "velocity" in t["mode"] and t["mode"][-1] == "idle", set(t["mode"])
        # The robot moved forward and turned (8× real time: about 2.4 s of robot time).
        assert t["x"][-1] > 0.05 and t["heading"][-1] > 0.2, (t["x"][-1], t["heading"][-1])
        assert np.all(np.diff(t["t"]) > 0)
        assert link.frames >= len(t["t"]) > 20

        # The e-stop latches: a velocity command is refused until clear.
        link.estop()
        with pytest.raises(RuntimeError, match="did not take the command"):
            link.velocity(0.1, 0.0, 0.0, 0.2)
        link.clear()
        link.velocity(0.0, 0.1, 0.0, 0.2)

        # A plan from omnikin.plan: uploaded in chunks and followed to its end.
        square = omnikin.plan("kiwi", "square", side=0.4, speed=0.2)
        r = link.run_plan(square, set_pose=True)
        assert not r["streamed"] and r["points"] >= 2 and r["chunks"] >= 1
        end = (square["x"][-1], square["y"][-1])
        assert np.hypot(r["end_pose"][0] - end[0], r["end_pose"][1] - end[1]) < 0.02, r
        assert r["max_deviation"] < 0.05, r
        t = link.telemetry()
        assert "trajectory" in t["mode"]
        columns = list(t)
    # The same columns as `omnikin drive telemetry --out` writes.
    out = tmp_path / "drive.csv"
    cli.run("drive", "--connect", sim_robot, "--heartbeat", "100", "--timeout", "2",
            "telemetry", "--out", out, "--for", "0.2")
    assert columns == list(read_csv_header(out))


def read_csv_header(path):
    with open(path) as f:
        return f.readline().strip().split(",")


def test_a_plan_far_from_the_robot_is_refused_without_set_pose(sim_robot):
    with omnikin.Link(sim_robot, heartbeat_hz=100, timeout_s=2.0) as link:
        far = omnikin.plan("kiwi", "waypoints", points=[[1.0, 1.0], [1.4, 1.0]], max_speed=0.2)
        with pytest.raises(ValueError, match="from the plan's start"):
            link.run_plan(far, set_pose=False)
        link.close()
        with pytest.raises(RuntimeError, match="closed"):
            link.stop()


def test_no_robot_is_an_error_within_the_timeout():
    addr = f"127.0.0.1:{free_port()}"
    with pytest.raises(RuntimeError, match="did not answer|no answer|within"):
        omnikin.Link(addr, timeout_s=0.3)
    for bad in (0.0, -1.0, float("nan"), 1e300, 1e-300):
        with pytest.raises(ValueError, match="heartbeat_hz must be in"):
            omnikin.Link(addr, heartbeat_hz=bad)
    for bad in (0.0, float("inf"), 1e300):
        with pytest.raises(ValueError, match="timeout_s must be in"):
            omnikin.Link(addr, timeout_s=bad)


def test_the_docs_example_drives_a_simulated_robot(sim_robot):
    import pathlib
    import re

    docs = pathlib.Path(__file__).resolve().parents[3] / "docs" / "python.md"
    section = docs.read_text().split("## Driving a robot")[1].split("\n## ")[0].split("\n### ")[0]
    (code,) = re.findall(r"```py\n(.*?)```", section, flags=re.S)
    assert '"127.0.0.1:7700"' in code
    scope: dict = {}
    exec(compile(code.replace("127.0.0.1:7700", sim_robot), "docs/python.md", "exec"), scope)
    assert scope["done"]["max_deviation"] < 0.05
    assert {"velocity", "trajectory", "idle"} <= set(scope["t"]["mode"])
