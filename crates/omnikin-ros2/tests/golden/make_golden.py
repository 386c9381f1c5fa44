"""Writes cdr.json: each message of tests/messages.rs encoded by `rosbags` (an independent CDR
and type-hash implementation), with the RIHS01 hash rosbags computes for its type.

    pip install rosbags && python make_golden.py > cdr.json

`crates/omnikin-py/tests/test_ros2_messages.py` runs this again in CI and requires the same
output, so the fixture cannot drift from what rosbags says."""

import json

from rosbags.typesys import Stores, get_typestore

ts = get_typestore(Stores.ROS2_JAZZY)
T = ts.types


def header(sec, nanosec, frame):
    return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec),
                                    frame_id=frame)


def v3(x, y, z):
    return T["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)


def quat(x, y, z, w):
    return T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)


def twist(a, b):
    return T["geometry_msgs/msg/Twist"](linear=v3(*a), angular=v3(*b))


def messages():
    import numpy as np
    cov36 = np.array([0.001 * (i + 1) if i % 7 == 0 else 0.0 for i in range(36)])
    yield "geometry_msgs/msg/Twist", twist((0.25, -0.1, 0.0), (0.0, 0.0, 0.5))
    yield "geometry_msgs/msg/TwistStamped", T["geometry_msgs/msg/TwistStamped"](
        header=header(12, 500_000_000, "base_link"), twist=twist((0.1, 0.0, 0.0), (0.0, 0.0, -0.2)))
    yield "nav_msgs/msg/Odometry", T["nav_msgs/msg/Odometry"](
        header=header(3, 250_000_000, "odom"), child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](
            pose=T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=1.5, y=-0.5, z=0.0),
                                             orientation=quat(0.0, 0.0, 0.3826834323650898, 0.9238795325112867)),
            covariance=cov36),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=twist((0.2, 0.05, 0.0), (0.0, 0.0, 0.1)),
                                                         covariance=cov36 * 2.0))
    tf = T["geometry_msgs/msg/TransformStamped"]
    yield "tf2_msgs/msg/TFMessage", T["tf2_msgs/msg/TFMessage"](transforms=[
        tf(header=header(3, 250_000_000, "odom"), child_frame_id="base_link",
           transform=T["geometry_msgs/msg/Transform"](translation=v3(1.5, -0.5, 0.0),
                                                      rotation=quat(0.0, 0.0, 0.3826834323650898, 0.9238795325112867))),
        tf(header=header(3, 250_000_000, "base_link"), child_frame_id="platform",
           transform=T["geometry_msgs/msg/Transform"](translation=v3(0.0, 0.0, 0.15), rotation=quat(0.0, 0.0, 0.0, 1.0))),
    ])
    yield "sensor_msgs/msg/JointState", T["sensor_msgs/msg/JointState"](
        header=header(7, 1, ""), name=["wheel_1", "wheel_2", "wheel_3"],
        position=np.array([0.5, -1.25, 3.0]), velocity=np.array([1.0, 2.0, -3.0]), effort=np.array([], dtype=float))
    yield "sensor_msgs/msg/Imu", T["sensor_msgs/msg/Imu"](
        header=header(9, 999_999_999, "imu"), orientation=quat(0.0, 0.0, 0.0, 1.0),
        orientation_covariance=np.array([-1.0] + [0.0] * 8),
        angular_velocity=v3(0.01, -0.02, 0.5), angular_velocity_covariance=np.array([1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-4]),
        linear_acceleration=v3(0.1, 0.0, 9.81), linear_acceleration_covariance=np.array([0.01, 0, 0, 0, 0.01, 0, 0, 0, 0.01]))
    ps = T["geometry_msgs/msg/PoseStamped"]
    pose = T["geometry_msgs/msg/Pose"]
    pt = T["geometry_msgs/msg/Point"]
    yield "nav_msgs/msg/Path", T["nav_msgs/msg/Path"](header=header(2, 5, "odom"), poses=[
        ps(header=header(2, 5, "odom"), pose=pose(position=pt(x=0.0, y=0.0, z=0.0), orientation=quat(0.0, 0.0, 0.0, 1.0))),
        ps(header=header(2, 5, "odom"), pose=pose(position=pt(x=0.5, y=0.25, z=0.0),
                                                   orientation=quat(0.0, 0.0, 0.3826834323650898, 0.9238795325112867)))])
    kv = T["diagnostic_msgs/msg/KeyValue"]
    yield "diagnostic_msgs/msg/DiagnosticArray", T["diagnostic_msgs/msg/DiagnosticArray"](
        header=header(5, 0, ""), status=[
            T["diagnostic_msgs/msg/DiagnosticStatus"](level=2, name="omnikin: mode", message="e-stop",
                                                      hardware_id="sim", values=[kv(key="fault", value="none"),
                                                                                 kv(key="watchdog", value="ok")])])


out = {name: {"hash": ts.hash_rihs01(name), "cdr": bytes(ts.serialize_cdr(m, name)).hex()}
       for name, m in messages()}
print(json.dumps(out, indent=1, sort_keys=True))
