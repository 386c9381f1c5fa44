"""The ROS 2 message fixture of crates/omnikin-ros2 (tests/golden/cdr.json: CDR bytes and
RIHS01 type hashes that the Rust tests must reproduce) is what `rosbags`, an independent ROS 2
message implementation, writes today: its generator runs again here and must print the same."""

import json
import subprocess
import sys

from conftest import ROOT

GOLDEN = ROOT / "crates" / "omnikin-ros2" / "tests" / "golden"


def test_the_fixture_is_what_rosbags_writes():
    out = subprocess.run([sys.executable, str(GOLDEN / "make_golden.py")], capture_output=True,
                         text=True, check=True).stdout
    assert json.loads(out) == json.loads((GOLDEN / "cdr.json").read_text())


def test_the_message_definitions_are_what_rosbags_writes(tmp_path):
    # src/msgdef/*.msg are the MCAP `ros2msg` schemas of `--mcap-profile ros2`.
    subprocess.run([sys.executable, str(GOLDEN / "make_msgdef.py"), str(tmp_path)], check=True)
    ours = ROOT / "crates" / "omnikin-ros2" / "src" / "msgdef"
    made = sorted(p.name for p in tmp_path.iterdir())
    assert made == sorted(p.name for p in ours.iterdir())
    for name in made:
        assert (tmp_path / name).read_text() == (ours / name).read_text(), name
