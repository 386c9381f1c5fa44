"""`robot --sim --mcap` logs are standard MCAP: the PyPI `mcap` reader with
`mcap-protobuf-support` (which builds each message type from the FileDescriptorSet in the
file's schema records, as Foxglove does) reads every channel into DataFrame-ready columns
that agree with the robot's CSV log (issue 33)."""

import csv
import math
import pathlib
import re
import socket
import subprocess
import pytest

import mcap.reader as mcap_reader
import mcap_protobuf.decoder as mcap_protobuf


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def columns(path) -> dict:
    """Every message of an MCAP file, decoded, as columns per topic: `t` (log time, s) and
    one list per field the messages carry (repeated fields as tuples)."""
    out: dict = {}
    with open(path, "rb") as f:
        reader = mcap_reader.make_reader(f, decoder_factories=[mcap_protobuf.DecoderFactory()])
        for schema, channel, message, proto in reader.iter_decoded_messages():
            assert channel.message_encoding == "protobuf", channel.topic
            assert schema.encoding == "protobuf", schema.name
            assert proto.DESCRIPTOR.full_name == schema.name
            cols = out.setdefault(channel.topic, {"t": []})
            cols["t"].append(message.log_time / 1e9)
            # The message's own timestamp is its log time.
            stamp = proto.timestamp.seconds * 10**9 + proto.timestamp.nanos
            assert stamp == message.log_time, channel.topic
            for field, value in flat(proto):
                cols.setdefault(field, []).append(value)
    return out


def flat(proto, prefix=""):
    """(dotted name, value) of the fields of a message, nested messages flattened."""
    for desc in proto.DESCRIPTOR.fields:
        name = prefix + desc.name
        value = getattr(proto, desc.name)
        if desc.name == "timestamp":
            continue
        # `is_repeated` since protobuf 5 (`label` is gone in 7).
        repeated = desc.is_repeated if hasattr(desc, "is_repeated") else desc.label == 3
        if repeated:
            if desc.message_type is None:
                yield name, tuple(value)
        elif desc.message_type is not None:
            yield from flat(value, name + ".")
        else:
            yield name, value


def read_log(path) -> dict:
    """The robot's CSV log as columns (numbers where a column is numeric, e.g. not `mode`)."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    out = {}
    for c in rows[0]:
        try:
            out[c] = [float(r[c]) for r in rows]
        except ValueError:
            out[c] = [r[c] for r in rows]
    return out


def yaw(qz: float, qw: float) -> float:
    return 2.0 * math.atan2(qz, qw)


def test_robot_mcap_reads_into_columns_with_the_standard_readers(cli, tmp_path):
    log, mcap = tmp_path / "robot.csv", tmp_path / "robot.mcap"
    addr = f"127.0.0.1:{free_port()}"
    robot = subprocess.Popen(
        [str(cli.path), "robot", "--sim", "--robot", "kiwi", "--listen", addr,
         "--time-scale", "8", "--max-time", "16", "--log", str(log), "--mcap", str(mcap)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )
    try:
        cli.run("drive", "--connect", addr, "--heartbeat", "100", "--timeout", "2",
                "velocity", "--vx", "0.2", "--yaw-rate", "0.5", "--for", "0.3")
        _, err = robot.communicate(timeout=30)
    finally:
        if robot.poll() is None:
            robot.kill()
    assert robot.returncode == 0, err
    rows = read_log(log)
    cols = columns(mcap)
    assert {"/pose", "/tf", "/truth", "/wheels", "/link", "/events"} <= set(cols)
    pose = cols["/pose"]
    n = len(rows["t"])
    assert n > 100 and len(pose["t"]) == n
    for c in ("pose.position.x", "pose.position.y", "pose.orientation.z", "pose.orientation.w"):
        assert len(pose[c]) == n, c
    moved = 0.0
    for i in range(n):
        assert abs(pose["t"][i] - rows["t"][i]) < 1e-9
        assert abs(pose["pose.position.x"][i] - rows["x"][i]) < 2e-6
        assert abs(pose["pose.position.y"][i] - rows["y"][i]) < 2e-6
        h = yaw(pose["pose.orientation.z"][i], pose["pose.orientation.w"][i])
        d = (h - rows["heading"][i] + math.pi) % (2 * math.pi) - math.pi
        assert abs(d) < 2e-6
        moved = max(moved, math.hypot(rows["x"][i], rows["y"][i]))
    assert moved > 0.02, "the robot moved"
    tf = cols["/tf"]
    assert set(tf["parent_frame_id"]) == {"world"} and set(tf["child_frame_id"]) == {"base"}
    # omnikin's own schemas: wheel rates (float, one per wheel) and the link counters.
    wheels = cols["/wheels"]
    assert all(len(c) == 3 for c in wheels["commanded"])
    for c, r in zip(wheels["commanded"], zip(rows["w1"], rows["w2"], rows["w3"])):
        assert all(abs(a - b) <= 1e-6 * max(1.0, abs(b)) for a, b in zip(c, r))
    link = cols["/link"]
    assert list(link["ok"]) == [int(x) for x in rows["rx_ok"]]
    levels = set(cols["/events"]["level"])
    assert levels <= {2, 3, 4}, levels
    # docs/python.md's example, run on this log: the same poses, as a DataFrame.
    poses = run_the_docs_example(mcap)
    assert list(poses.columns) == ["t", "x", "y"] and len(poses) == n
    assert max(abs(a - b) for a, b in zip(poses["x"], rows["x"])) < 2e-6


def docs_block(section: str, needle: str) -> str:
    """The ```py block of `section` that contains `needle`."""
    blocks = [b for b in re.findall(r"```py\n(.*?)```", section, re.S) if needle in b]
    assert len(blocks) == 1, needle
    return blocks[0]


def run_the_docs_example(mcap):
    """Runs the Python block of docs/python.md's "Reading the robot's logs" on `mcap` (fenced
    as ```py, so test_readme's run of the page's self-contained ```python blocks skips it)."""
    docs = pathlib.Path(__file__).resolve().parents[3] / "docs" / "python.md"
    section = docs.read_text().split("## Reading the robot's logs", 1)[1]
    code = docs_block(section, "make_reader")
    assert '"robot.mcap"' in code
    scope: dict = {}
    exec(code.replace('"robot.mcap"', repr(str(mcap))), scope)
    return scope["poses"]


def test_a_ros2_profile_log_is_a_ros2_bag_rosbags_decodes(cli, tmp_path):
    # `--mcap-profile ros2`: MCAP's ROS 2 profile. Checked with rosbags, an independent ROS 2
    # message implementation: each schema is its `.msg` text, each type hash its RIHS01, each
    # message decodes, and the values are the robot's CSV log.
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_JAZZY)
    log, mcap = tmp_path / "robot.csv", tmp_path / "robot.mcap"
    addr = f"127.0.0.1:{free_port()}"
    robot = subprocess.Popen(
        [str(cli.path), "robot", "--sim", "--robot", "swerve4", "--listen", addr,
         "--time-scale", "8", "--max-time", "16", "--log", str(log), "--mcap", str(mcap),
         "--mcap-profile", "ros2"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )
    try:
        cli.run("drive", "--connect", addr, "--heartbeat", "100", "--timeout", "2",
                "velocity", "--vx", "0.2", "--yaw-rate", "0.5", "--for", "0.3")
        cli.run("drive", "--connect", addr, "--timeout", "2", "estop")
        _, err = robot.communicate(timeout=30)
    finally:
        if robot.poll() is None:
            robot.kill()
    assert robot.returncode == 0, err
    rows = read_log(log)
    n = len(rows["t"])
    topics: dict = {}
    with open(mcap, "rb") as f:
        reader = mcap_reader.make_reader(f)
        assert reader.get_header().profile == "ros2"
        for schema, channel, message in reader.iter_messages():
            assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            text, _ = ts.generate_msgdef(schema.name, ros_version=2)
            assert schema.data.decode() == text, schema.name
            assert channel.metadata["topic_type_hash"] == ts.hash_rihs01(schema.name)
            assert "reliability: 1" in channel.metadata["offered_qos_profiles"]
            m = ts.deserialize_cdr(message.data, schema.name)
            topics.setdefault(channel.topic, []).append((message.log_time, m))
    assert {"/odom", "/tf", "/truth", "/joint_states", "/diagnostics"} <= set(topics)
    odom = topics["/odom"]
    assert len(odom) == n
    for i, (ns, m) in enumerate(odom):
        assert m.header.stamp.sec * 10**9 + m.header.stamp.nanosec == ns
        assert abs(ns / 1e9 - rows["t"][i]) < 1e-9
        assert (m.header.frame_id, m.child_frame_id) == ("odom", "base_link")
        p = m.pose.pose
        assert abs(p.position.x - rows["x"][i]) < 2e-6 and abs(p.position.y - rows["y"][i]) < 2e-6
        d = (yaw(p.orientation.z, p.orientation.w) - rows["heading"][i] + math.pi) % (2 * math.pi) - math.pi
        assert abs(d) < 2e-6
    # Driven forward at 0.2 m/s: the odometry's twist is in the robot frame.
    assert max(m.twist.twist.linear.x for _, m in odom) > 0.1
    truth = topics["/truth"]
    assert all(abs(m.pose.pose.position.x - rows["true_x"][i]) < 2e-6 for i, (_, m) in enumerate(truth))
    joints = topics["/joint_states"][-1][1]
    assert joints.name == [f"wheel_{i}" for i in range(1, 5)] + [f"steer_{i}" for i in range(1, 5)]
    assert len(joints.velocity) == 8
    levels = [s.level for _, m in topics["/diagnostics"] for s in m.status]
    assert 2 in levels, "the e-stop is an ERROR"


def test_a_simulated_ros2_bag_has_the_plan_as_a_path(cli, tmp_path):
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_JAZZY)
    plan, mcap = tmp_path / "plan.csv", tmp_path / "sim.mcap"
    cli.run("plan", "circle", "--robot", "kiwi", "--radius", "0.5", "--omega", "1", "--out", str(plan))
    cli.run("simulate", str(plan), "--robot", "kiwi", "--trials", "1", "--out", str(tmp_path / "sim"),
            "--mcap", str(mcap), "--mcap-profile", "ros2")
    rows = read_log(plan)
    with open(mcap, "rb") as f:
        msgs = [(c.topic, ts.deserialize_cdr(m.data, s.name))
                for s, c, m in mcap_reader.make_reader(f).iter_messages()]
    paths = [m for t, m in msgs if t == "/plan"]
    assert len(paths) == 1 and paths[0].header.frame_id == "odom"
    poses = paths[0].poses
    assert len(poses) == len(rows["t"])
    assert all(abs(p.pose.position.x - x) < 1e-12 for p, x in zip(poses, rows["x"]))
    assert any(t.endswith("/odom") for t, _ in msgs)


def test_read_mcap_gives_what_convert_writes_and_what_the_standard_reader_decodes(cli, tmp_path):
    """`omnikin.read_mcap` on a `simulate --mcap` log: the same tables as `omnikin convert
    --csv` (the same reader, held to it cell by cell), and poses that agree with the PyPI
    `mcap` reader's independent decoding; a truncated copy gives its first messages and a
    warning; a missing file is a ValueError naming it."""
    import warnings

    import numpy as np

    import omnikin

    plan = tmp_path / "plan.csv"
    cli.run("plan", "square", "--robot", "kiwi", "--side", "0.5", "--speed", "0.3",
            "--rate", "50", "--out", str(plan))
    log = tmp_path / "sim.mcap"
    cli.run("simulate", str(plan), "--robot", "kiwi", "--trials", "2", "--threads", "1",
            "--out", str(tmp_path / "out"), "--mcap", str(log), "--mcap-trials", "2")
    got = omnikin.read_mcap(log)
    csv_dir = tmp_path / "csv"
    cli.run("convert", str(log), "--csv", str(csv_dir))
    files = {p.name: p for p in csv_dir.iterdir()}
    assert sorted(files) == sorted(t.strip("/").replace("/", "-") + ".csv" for t in got)
    for topic, cols in got.items():
        with open(files[topic.strip("/").replace("/", "-") + ".csv"], newline="") as f:
            rows = list(csv.reader(f))
        assert list(cols) == rows[0], topic
        for i, name in enumerate(rows[0]):
            want = [r[i] for r in rows[1:]]
            have = cols[name]
            if isinstance(have, list):
                assert have == want, (topic, name)
            else:
                assert have.dtype == np.float64 and len(have) == len(want), (topic, name)
                for a, b in zip(have, want):
                    assert (b == "" and math.isnan(a)) or a == float(b), (topic, name, a, b)
    # Independent decoding of the same file (protobuf through the file's descriptors).
    ref = columns(log)
    pose = got["/pose"]
    assert len(pose["t"]) == len(ref["/pose"]["t"]) > 50
    assert np.allclose(pose["x"], ref["/pose"]["pose.position.x"], atol=1e-9)
    assert np.allclose(pose["t"], ref["/pose"]["t"], atol=1e-9)
    assert "/trial-001/pose" in got
    # docs/python.md's read_mcap example, run on this log.
    docs = pathlib.Path(__file__).resolve().parents[3] / "docs" / "python.md"
    section = docs.read_text().split("## Reading the robot's logs", 1)[1]
    scope: dict = {}
    exec(docs_block(section, "read_mcap").replace('"robot.mcap"', repr(str(log))), scope)
    assert scope["pose"]["x"] is not None and len(scope["pose"]["t"]) == len(pose["t"])
    # A copy cut in its last third: the messages before the cut, and a warning that says so.
    data = log.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 2 // 3])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        part = omnikin.read_mcap(cut)
    assert any("ends early or is damaged" in str(w.message) for w in caught), caught
    assert 0 < len(part["/pose"]["t"]) <= len(pose["t"])
    missing = tmp_path / "missing.mcap"
    try:
        omnikin.read_mcap(missing)
    except ValueError as e:
        assert "missing.mcap" in str(e)
    else:
        raise AssertionError("a missing file was read")


def test_write_mcap_writes_back_what_read_mcap_read(tmp_path):
    """`omnikin.write_mcap` of `omnikin.read_mcap`'s tables gives a file that reads back to the
    same tables, cell for cell (floats exactly, NaN as NaN, text as text), on a log with every
    kind of channel the robot and the operator write; bad tables are refused by channel and
    nothing is written; an existing file is never replaced."""
    import numpy as np

    import omnikin

    robot_log, operator_log = tmp_path / "robot.mcap", tmp_path / "drive.mcap"
    with omnikin.SimRobot("swerve4", time_scale=8, mcap=robot_log) as robot:
        with omnikin.Link(robot.address, heartbeat_hz=100, timeout_s=2.0, mcap=operator_log) as link:
            link.run_plan(omnikin.plan("swerve4", "waypoints", points=[[0, 0], [0.3, 0], [0.3, 0.3]]))
            link.estop()
            link.clear()
    for log in (robot_log, operator_log):
        got = omnikin.read_mcap(log)
        assert {"/pose", "/tf", "/wheels", "/link", "/events"} <= set(got), sorted(got)
        again = tmp_path / ("again-" + log.name)
        n = omnikin.write_mcap(again, got)
        plans = got.get("/plan", {"i": []})
        rows = sum(len(c["t"]) for topic, c in got.items() if topic != "/plan")
        assert n == rows + sum(1 for i in plans["i"] if i == 0), (n, rows)
        back = omnikin.read_mcap(again)
        assert sorted(back) == sorted(got)
        for topic, cols in got.items():
            assert list(back[topic]) == list(cols), topic
            for name, want in cols.items():
                have = back[topic][name]
                if isinstance(want, list):
                    assert have == want, (topic, name)
                else:
                    assert np.array_equal(have, want, equal_nan=True), (topic, name)
    assert "/truth" in omnikin.read_mcap(robot_log) and "/plan" in omnikin.read_mcap(operator_log)

    # docs/python.md's write_mcap example on the robot's log: the messages between 1 s and 3 s.
    docs = pathlib.Path(__file__).resolve().parents[3] / "docs" / "python.md"
    section = docs.read_text().split("## Reading the robot's logs", 1)[1]
    code = docs_block(section, "omnikin.write_mcap(")
    window_file = tmp_path / "robot-1s-3s.mcap"
    scope = {"omnikin": omnikin, "logs": omnikin.read_mcap(robot_log)}
    exec(code.replace('"robot-1s-3s.mcap"', repr(str(window_file))), scope)
    window = omnikin.read_mcap(window_file)
    kept = {t for t, c in scope["logs"].items() if t != "/plan" and np.any((c["t"] >= 1.0) & (c["t"] < 3.0))}
    assert set(window) == kept and {"/pose", "/wheels"} <= kept  # a topic with no message there has no channel
    for topic, cols in window.items():
        assert np.all((cols["t"] >= 1.0) & (cols["t"] < 3.0)), topic
        assert len(cols["t"]) == np.count_nonzero(
            (scope["logs"][topic]["t"] >= 1.0) & (scope["logs"][topic]["t"] < 3.0)
        ), topic

    out = tmp_path / "bad.mcap"
    pose = {"t": [0.0, 0.1], "x": [0.0, 1.0], "y": [0.0, 0.0], "heading": [0.0, 0.0]}
    for tables, message in [
        ({"/odom": pose}, '"/odom": not an omnikin topic'),
        ({"/pose": {"t": [0.0], "x": [0.0]}}, "/pose.*heading"),
        ({"/pose": dict(pose, x=[0.0])}, "different lengths"),
        ({"/pose": dict(pose, x=["a", "b"])}, "channel /pose:2"),
    ]:
        with pytest.raises(ValueError, match=message):
            omnikin.write_mcap(out, tables)
        assert not out.exists()
    assert omnikin.write_mcap(out, {"/pose": pose, "/trial-001/pose": pose}) == 4
    with pytest.raises(ValueError, match="exists"):
        omnikin.write_mcap(out, {"/pose": pose})
