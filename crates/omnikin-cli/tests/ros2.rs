//! `omnikin robot --ros2` and `omnikin ros2` in a binary built without the `ros2` feature:
//! the flags exist and say how to get the node. With the feature, the node is tested from an
//! independent Zenoh peer in `crates/omnikin-py/tests/test_ros2_node.py`; the formats it writes
//! in `omnikin-ros2`'s `rmw` tests.

use assert_cmd::Command;
use predicates::str::contains;

#[cfg(not(feature = "ros2"))]
#[test]
fn without_the_feature_the_node_names_the_build_that_has_it() {
    Command::cargo_bin("omnikin")
        .unwrap()
        .args(["robot", "--sim", "--robot", "kiwi", "--ros2"])
        .assert()
        .failure()
        .stderr(contains("--features ros2"));
    Command::cargo_bin("omnikin")
        .unwrap()
        .args(["ros2", "--connect", "127.0.0.1:7000"])
        .assert()
        .failure()
        .stderr(contains("--features ros2"));
}

#[test]
fn robot_needs_listen_unless_it_is_a_ros2_node() {
    Command::cargo_bin("omnikin")
        .unwrap()
        .args(["robot", "--sim", "--robot", "kiwi"])
        .assert()
        .failure()
        .stderr(contains("--listen"));
}
