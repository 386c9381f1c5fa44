"""Writes src/msgdef/<package>__<Name>.msg: each message type's definition with its dependencies
as MCAP's `ros2msg` schema encoding holds it (the top-level `.msg` text, then each dependency
after a line of 80 `=` and `MSG: package/Name`), made by `rosbags` (an independent
implementation, the one its rosbag2 writer uses).

    pip install rosbags && python make_msgdef.py ../../src/msgdef

`crates/omnikin-py/tests/test_ros2_messages.py` runs this again in CI into a scratch directory
and requires identical files, so the definitions cannot drift from what rosbags says."""

import pathlib
import sys

from rosbags.typesys import Stores, get_typestore

TYPES = [
    "geometry_msgs/msg/Twist",
    "geometry_msgs/msg/TwistStamped",
    "nav_msgs/msg/Odometry",
    "nav_msgs/msg/Path",
    "tf2_msgs/msg/TFMessage",
    "sensor_msgs/msg/JointState",
    "sensor_msgs/msg/Imu",
    "diagnostic_msgs/msg/DiagnosticArray",
]


def main(out: pathlib.Path) -> None:
    ts = get_typestore(Stores.ROS2_JAZZY)
    out.mkdir(parents=True, exist_ok=True)
    for t in TYPES:
        text, _ = ts.generate_msgdef(t, ros_version=2)
        pkg, _, name = t.split("/")
        (out / f"{pkg}__{name}.msg").write_text(text)


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]))
