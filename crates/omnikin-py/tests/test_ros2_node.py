"""`omnikin robot --sim --ros2` seen from an independent ROS 2 peer: a client on `eclipse-zenoh`
(no ROS installed) that speaks rmw_zenoh's wire format, with messages encoded and decoded by
`rosbags` and keys built from the RIHS01 hashes `rosbags` computes.

The client listens on a loopback TCP port and the node connects to it (two Zenoh peers, no
router). The binary must be built with the `ros2` feature (scripts/python-tests.sh does).
"""

import json
import math
import socket
import subprocess
import threading
import time

import pytest

import os  # noqa: E402

# scripts/python-tests.sh (CI) installs eclipse-zenoh and sets OMNIKIN_REQUIRE_ROS2=1: there a
# missing or broken zenoh fails the run instead of skipping the node's tests.
if os.environ.get("OMNIKIN_REQUIRE_ROS2") == "1":
    import zenoh  # noqa: E402
else:
    zenoh = pytest.importorskip("zenoh")
from rosbags.typesys import Stores, get_typestore  # noqa: E402

TS = get_typestore(Stores.ROS2_JAZZY)
Twist = TS.types["geometry_msgs/msg/Twist"]
Vector3 = TS.types["geometry_msgs/msg/Vector3"]


def register_trigger():
    """`std_srvs/srv/Trigger` as REP 2011 describes a service for its type hash: a structure
    of `request_message`, `response_message` and `event_message`, the `_Event` holding a
    `service_msgs/msg/ServiceEventInfo` and bounded sequences (<= 1) of request and response.
    rosbags' bundled ServiceEventInfo types `client_gid` as `char[16]`; rosidl's IDL has
    `uint8[16]` (`char` in a .msg is `uint8`), which is what the type hash covers."""
    from rosbags.typesys import get_types_from_msg
    from rosbags.typesys.base import Nodetype

    src = {
        "std_srvs/srv/Trigger_Request": "",
        "std_srvs/srv/Trigger_Response": "bool success\nstring message\n",
        "std_srvs/srv/Trigger_Event": "service_msgs/msg/ServiceEventInfo info\n"
        "std_srvs/srv/Trigger_Request[<=1] request\nstd_srvs/srv/Trigger_Response[<=1] response\n",
        "std_srvs/srv/Trigger": "std_srvs/srv/Trigger_Request request_message\n"
        "std_srvs/srv/Trigger_Response response_message\nstd_srvs/srv/Trigger_Event event_message\n",
    }

    def srv(o):  # rosbags names every parsed type pkg/msg/Name: put these under srv/
        if isinstance(o, str):
            return o.replace("std_srvs/srv/msg/", "std_srvs/srv/")
        if isinstance(o, (list, tuple)):
            return type(o)(srv(x) for x in o)
        return o

    types = {}
    for name, text in src.items():
        for k, v in get_types_from_msg(text, name).items():
            types[srv(k)] = srv(v)
    consts, fields = TS.fielddefs["service_msgs/msg/ServiceEventInfo"]
    uint8_gid = (Nodetype.ARRAY, ((Nodetype.BASE, ("uint8", 0)), 16))
    types["service_msgs/msg/ServiceEventInfo"] = (
        consts, [(n, uint8_gid if n == "client_gid" else d) for n, d in fields])
    del TS.fielddefs["service_msgs/msg/ServiceEventInfo"]
    TS.register(types)


register_trigger()
TRIGGER = "std_srvs/srv/Trigger"


def free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def dds(type_name: str) -> str:
    pkg, kind, name = type_name.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def key(topic: str, type_name: str, domain: int = 0) -> str:
    """rmw_zenoh's key of a topic: <domain>/<topic>/<dds type>/<RIHS01 hash>."""
    return f"{domain}/{topic.strip('/')}/{dds(type_name)}/{TS.hash_rihs01(type_name)}"


def attachment(seq: int) -> bytes:
    """rmw_zenoh's (Jazzy) attachment, written with zenoh's own serializer."""
    from zenoh.ext import Int64, z_serialize

    head = z_serialize(
        ("sequence_number", Int64(seq), "source_timestamp", Int64(time.time_ns()), "source_gid")
    ).to_bytes()
    return head + bytes(range(16))


def srv_key(name: str, domain: int = 0) -> str:
    """rmw_zenoh's key of a service's queryable: the service's DDS name and type hash."""
    return f"{domain}/{name.strip('/')}/{dds(TRIGGER)}/{TS.hash_rihs01(TRIGGER)}"


def call_trigger(client, name: str, seq: int | None):
    """A `std_srvs/srv/Trigger` call as an rmw_zenoh client makes it: a Zenoh get with the
    CDR request (encoded by rosbags) and, when `seq`, the attachment with this client's GID;
    returns the decoded response and the reply's attachment."""
    req = bytes(TS.serialize_cdr(TS.types["std_srvs/srv/Trigger_Request"](), "std_srvs/srv/Trigger_Request"))
    replies = list(client.get(srv_key(name), payload=req,
                              attachment=attachment(seq) if seq else None, timeout=5.0))
    assert len(replies) == 1 and replies[0].ok, replies
    r = replies[0].ok
    assert str(r.key_expr) == srv_key(name)
    resp = TS.deserialize_cdr(r.payload.to_bytes(), "std_srvs/srv/Trigger_Response")
    return resp, (r.attachment.to_bytes() if r.attachment is not None else None)


def yaw(q) -> float:
    return 2.0 * math.atan2(q.z, q.w)


def wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def test_a_simulated_kiwi_is_a_ros2_node_a_zenoh_client_drives(cli, tmp_path):
    help_text = cli.run("robot", "--help").stdout
    assert "--ros2" in help_text
    port = free_tcp_port()
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    client = zenoh.open(conf)
    odom_key = key("/odom", "nav_msgs/msg/Odometry")
    cmd_key = key("/cmd_vel", "geometry_msgs/msg/Twist")
    odoms = []
    lock = threading.Lock()

    def on_odom(sample):
        att = sample.attachment.to_bytes() if sample.attachment is not None else None
        msg = TS.deserialize_cdr(sample.payload.to_bytes(), "nav_msgs/msg/Odometry")
        with lock:
            odoms.append((str(sample.key_expr), msg, att))

    sub = client.declare_subscriber(odom_key, on_odom)
    others = {"tf": [], "joint_states": [], "diagnostics": []}
    types = {"tf": "tf2_msgs/msg/TFMessage", "joint_states": "sensor_msgs/msg/JointState",
             "diagnostics": "diagnostic_msgs/msg/DiagnosticArray"}

    def collect(name):
        def on(sample):
            m = TS.deserialize_cdr(sample.payload.to_bytes(), types[name])
            with lock:
                others[name].append(m)
        return on

    subs = [client.declare_subscriber(key(f"/{n}", ty), collect(n)) for n, ty in types.items()]
    clocks = []
    subs.append(client.declare_subscriber(
        key("/clock", "rosgraph_msgs/msg/Clock"),
        lambda s: clocks.append(TS.deserialize_cdr(s.payload.to_bytes(), "rosgraph_msgs/msg/Clock").clock)))
    robot = subprocess.Popen(
        [str(cli.path), "robot", "--sim", "--robot", "kiwi", "--ros2",
         "--zenoh", f"tcp/127.0.0.1:{port}", "--max-time", "16"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        # The graph: the node, its odom publisher and its cmd_vel subscription, as rmw_zenoh's
        # liveliness tokens.
        tokens = []
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            tokens = [str(r.ok.key_expr) for r in client.liveliness().get("@ros2_lv/0/**") if r.ok]
            if any("/MS/" in t for t in tokens) and any("/NN/" in t for t in tokens):
                break
            time.sleep(0.2)
        assert robot.poll() is None, robot.communicate()
        node = [t for t in tokens if "/NN/" in t]
        assert len(node) == 1 and node[0].endswith("/NN/%/%/omnikin"), tokens
        zid = node[0].split("/")[2]
        odom_tok = f"/MP/%/%/omnikin/%odom/{dds('nav_msgs/msg/Odometry')}/{TS.hash_rihs01('nav_msgs/msg/Odometry')}/"
        cmd_tok = f"/MS/%/%/omnikin/%cmd_vel/{dds('geometry_msgs/msg/Twist')}/{TS.hash_rihs01('geometry_msgs/msg/Twist')}/"
        assert any(t.startswith(f"@ros2_lv/0/{zid}/0/") and odom_tok in t for t in tokens), tokens
        assert any(cmd_tok in t for t in tokens), tokens
        for topic, ty in [("/tf", "tf2_msgs/msg/TFMessage"),
                          ("%joint_states", "sensor_msgs/msg/JointState"),
                          ("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray")]:
            name = topic.replace("/", "%")
            assert any(f"/MP/%/%/omnikin/{name}/{dds(ty)}/{TS.hash_rihs01(ty)}/" in t for t in tokens), (ty, tokens)
        # The services: SS tokens with the service type's DDS name and hash.
        for name in ["%estop", "%clear"]:
            tok = f"/SS/%/%/omnikin/{name}/std_srvs::srv::dds_::Trigger_/{TS.hash_rihs01(TRIGGER)}/"
            assert any(tok in t for t in tokens), (name, tokens)

        # cmd_vel: 7 s of one twist at 20 Hz, every other sample with rmw_zenoh's attachment,
        # and one malformed sample (counted and dropped).
        v = (0.2, 0.1, 0.3)
        twist = Twist(linear=Vector3(x=v[0], y=v[1], z=0.0), angular=Vector3(x=0.0, y=0.0, z=v[2]))
        cdr = bytes(TS.serialize_cdr(twist, "geometry_msgs/msg/Twist"))
        pub = client.declare_publisher(cmd_key)
        pub.put(b"\x00\x01\x00\x00\x01\x02")
        start = time.monotonic()
        i = 0
        while time.monotonic() - start < 7.0:
            i += 1
            if i % 2:
                pub.put(cdr, attachment=attachment(i))
            else:
                pub.put(cdr)
            time.sleep(0.05)
        # Silence: the node brings the robot to a controlled stop.
        time.sleep(2.0)
        with lock:
            got = list(odoms)
        # E-stop and clear: std_srvs/srv/Trigger calls. The e-stop's reply carries the call's
        # sequence number and this client's GID back (rmw_zenoh's attachment).
        resp, att = call_trigger(client, "/estop", 41)
        assert resp.success and "e-stop" in resp.message, resp
        assert att is not None and int.from_bytes(att[16:24], "little", signed=True) == 41, att
        assert att[-16:] == bytes(range(16)), att
        # Under the e-stop cmd_vel does not move the robot: odom stays where it is.
        with lock:
            n_before = len(odoms)
        for _ in range(20):
            pub.put(cdr)
            time.sleep(0.05)
        time.sleep(0.6)  # past --cmd-timeout: the clear below does not resume that motion
        with lock:
            held = [m for _, m, _ in odoms[n_before:]]
        assert len(held) > 50, len(held)
        p0 = held[0].pose.pose.position
        assert all(math.hypot(m.pose.pose.position.x - p0.x, m.pose.pose.position.y - p0.y) < 1e-4
                   and abs(m.twist.twist.linear.x) < 1e-6 for m in held), held[-1]
        # Clear, called without an attachment (a plain Zenoh client): a reply without one.
        resp, att = call_trigger(client, "/clear", None)
        assert resp.success and "cleared" in resp.message, resp
        assert att is None
        time.sleep(0.3)
        out, err = robot.communicate(timeout=30)
    finally:
        if robot.poll() is None:
            robot.kill()
            robot.communicate()
        sub.undeclare()
        client.close()
    assert robot.returncode == 0, err
    summary = json.loads(out)
    r = summary["ros2"]
    assert r["bad_samples"] >= 1, r
    assert r["cmd_vel"] >= 100 and 0 < r["cmd_vel_with_attachment"] < r["cmd_vel"], r
    assert r["silence_stops"] >= 1, r
    assert r["estop_requests"] == 1 and r["clear_requests"] == 1, r
    assert r["service_confirmed"] == 2 and r["service_failed"] == 0, r

    tf = others["tf"][-1].transforms[0]
    assert (tf.header.frame_id, tf.child_frame_id) == ("odom", "base_link")
    js = others["joint_states"][-1]
    assert list(js.name) == ["wheel_1", "wheel_2", "wheel_3"] and len(js.position) == 3
    levels = [(d.status[0].level, {kv.key: kv.value for kv in d.status[0].values}["mode"])
              for d in others["diagnostics"]]
    assert (2, "estop") in levels, levels
    assert levels[-1][0] == 0 and levels[-1][1] != "estop", levels

    assert got and all(k == odom_key for k, _, _ in got)
    # rmw_zenoh's attachment on every publication, the sequence counting up from 1.
    seqs = []
    for _, _, att in got:
        assert att is not None and att.startswith(b"\x0fsequence_number") and len(att) == 76
        seqs.append(int.from_bytes(att[16:24], "little", signed=True))
    assert seqs[0] >= 1 and all(b > a for a, b in zip(seqs, seqs[1:]))
    msgs = [m for _, m, _ in got]
    assert all(m.header.frame_id == "odom" and m.child_frame_id == "base_link" for m in msgs)
    # /clock (a simulated robot's) holds the stamps' time: every odom stamp is a clock tick.
    ticks = {(c.sec, c.nanosec) for c in clocks}
    assert len(ticks) >= 0.9 * len(msgs) and all(
        (m.header.stamp.sec, m.header.stamp.nanosec) in ticks for m in msgs[10:-10]), len(ticks)

    def t(m) -> float:
        return m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec

    # Steady motion: from 1 s after the robot reaches the commanded twist, 5 s.
    moving = [m for m in msgs if abs(m.twist.twist.linear.x - v[0]) < 1e-3
              and abs(m.twist.twist.angular.z - v[2]) < 1e-3]
    assert moving, "the robot never reached the commanded twist"
    t1 = t(moving[0]) + 1.0
    window = [m for m in msgs if t1 <= t(m) <= t1 + 5.0]
    # At the control rate (100 Hz): every cycle's odom arrives.
    assert len(window) >= 0.9 * 100 * 5, len(window)
    a, b = window[0], window[-1]
    dt = t(b) - t(a)
    assert abs(dt - 5.0) < 0.05, dt
    # The integrated command: a constant robot-frame twist turns the displacement with the
    # heading (exact closed form from the first pose's heading).
    h0 = yaw(a.pose.pose.orientation)
    dth = v[2] * dt
    lx = (v[0] * math.sin(dth) - v[1] * (1 - math.cos(dth))) / v[2]
    ly = (v[0] * (1 - math.cos(dth)) + v[1] * math.sin(dth)) / v[2]
    ex = a.pose.pose.position.x + math.cos(h0) * lx - math.sin(h0) * ly
    ey = a.pose.pose.position.y + math.sin(h0) * lx + math.cos(h0) * ly
    err_pos = math.hypot(b.pose.pose.position.x - ex, b.pose.pose.position.y - ey)
    assert err_pos < 0.01, (err_pos, (ex, ey), b.pose.pose.position)
    assert abs(wrap(yaw(b.pose.pose.orientation) - h0 - dth)) < 0.01
    # After cmd_vel fell silent: at rest.
    last = msgs[-1].twist.twist
    assert abs(last.linear.x) < 1e-3 and abs(last.linear.y) < 1e-3 and abs(last.angular.z) < 1e-3, last


def test_stamped_cmd_vel_in_a_namespace_and_domain(cli):
    """--stamped: cmd_vel is geometry_msgs/msg/TwistStamped; --namespace and --domain move the
    keys and tokens; the samples drive the robot (its summary counts them)."""
    port = free_tcp_port()
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    client = zenoh.open(conf)
    robot = subprocess.Popen(
        [str(cli.path), "robot", "--sim", "--robot", "mecanum", "--ros2", "--stamped",
         "--namespace", "robot1", "--domain", "7", "--zenoh", f"tcp/127.0.0.1:{port}",
         "--max-time", "4"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        ty = "geometry_msgs/msg/TwistStamped"
        want = f"/MS/%/%robot1/omnikin/%robot1%cmd_vel/{dds(ty)}/{TS.hash_rihs01(ty)}/"
        tokens = []
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and not any(want in t for t in tokens):
            tokens = [str(r.ok.key_expr) for r in client.liveliness().get("@ros2_lv/7/**") if r.ok]
            time.sleep(0.2)
        assert any(want in t for t in tokens), tokens
        Header = TS.types["std_msgs/msg/Header"]
        Time = TS.types["builtin_interfaces/msg/Time"]
        msg = TS.types[ty](
            header=Header(stamp=Time(sec=1, nanosec=2), frame_id="base_link"),
            twist=Twist(linear=Vector3(x=0.1, y=-0.1, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.0)),
        )
        cdr = bytes(TS.serialize_cdr(msg, ty))
        pub = client.declare_publisher(key("/robot1/cmd_vel", ty, domain=7))
        for i in range(20):
            pub.put(cdr, attachment=attachment(i + 1))
            time.sleep(0.05)
        out, err = robot.communicate(timeout=30)
    finally:
        if robot.poll() is None:
            robot.kill()
            robot.communicate()
        client.close()
    assert robot.returncode == 0, err
    summary = json.loads(out)
    assert summary["ros2"]["cmd_vel"] == 20 and summary["ros2"]["cmd_vel_with_attachment"] == 20, summary["ros2"]
    assert summary["ros2"]["bad_samples"] == 0
    # It moved forward and right (robot frame), 0.1 m/s each way for about a second.
    x, y = summary["pose"][0], summary["pose"][1]
    assert x > 0.05 and y < -0.05, summary["pose"]


def test_ros2_connect_bridges_a_robot_on_the_link(cli):
    """`omnikin ros2 --connect`: the node for a robot served elsewhere (here `robot --sim
    --listen`), over the link; odom arrives at the robot's telemetry rate, cmd_vel moves it."""
    port = free_tcp_port()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        udp = s.getsockname()[1]
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    client = zenoh.open(conf)
    odoms = []
    sub = client.declare_subscriber(
        key("/odom", "nav_msgs/msg/Odometry"),
        lambda s: odoms.append(TS.deserialize_cdr(s.payload.to_bytes(), "nav_msgs/msg/Odometry")),
    )
    robot = subprocess.Popen(
        [str(cli.path), "robot", "--sim", "--robot", "kiwi", "--listen", f"127.0.0.1:{udp}",
         "--max-time", "8"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    time.sleep(0.3)
    bridge = subprocess.Popen(
        [str(cli.path), "ros2", "--connect", f"127.0.0.1:{udp}", "--zenoh", f"tcp/127.0.0.1:{port}"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and not odoms:
            time.sleep(0.1)
        assert odoms, bridge.poll()
        cdr = bytes(TS.serialize_cdr(
            Twist(linear=Vector3(x=0.2, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.0)),
            "geometry_msgs/msg/Twist"))
        pub = client.declare_publisher(key("/cmd_vel", "geometry_msgs/msg/Twist"))
        for _ in range(30):
            pub.put(cdr)
            time.sleep(0.05)
        time.sleep(1.0)
        n = len(odoms)
        time.sleep(1.0)
        rate = len(odoms) - n
    finally:
        bridge.send_signal(2)
        try:
            out, err = bridge.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            bridge.kill()
            out, err = bridge.communicate()
        robot.kill()
        robot.communicate()
        sub.undeclare()
        client.close()
    # The robot's default telemetry rate, 20 Hz.
    assert 15 <= rate <= 25, rate
    assert odoms[-1].pose.pose.position.x > 0.1, odoms[-1].pose.pose.position
    # Ctrl-C is the stop asked for: the robot stopped and the session left, the counters on
    # stdout, a note (no error) and the status 128 + SIGINT, as `robot --sim` ends.
    assert bridge.returncode == 130, err
    assert "note: stopped by SIGINT" in err and "error" not in err, err
    assert json.loads(out)["ros2"]["cmd_vel"] == 30, out
