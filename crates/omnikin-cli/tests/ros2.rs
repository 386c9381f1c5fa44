//! `omnikin robot --ros2` and `omnikin ros2` in a binary built without the `ros2` feature:
//! the flags exist and say how to get the node. With the feature (`cargo test -p omnikin-cli
//! --features ros2 --test ros2`), a signal ends `ros2 --connect` cleanly; the node is tested
//! from an independent Zenoh peer in `crates/omnikin-py/tests/test_ros2_node.py`, the formats
//! it writes in `omnikin-ros2`'s `rmw` tests.

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

/// Ctrl-C (SIGINT) or SIGTERM on `ros2 --connect`: the stop asked for, carried out — the robot
/// told to stop and the session left, the node's counters on stdout, a note and no error on
/// stderr (a receive cut short by the signal is the same stop, not a link error), and the
/// status 128 + the signal, as `robot --sim` ends. No Zenoh peer is needed: the node keeps
/// trying to connect in the background while it serves the robot.
#[cfg(feature = "ros2")]
#[test]
fn ros2_connect_stops_cleanly_on_sigint_and_sigterm() {
    use std::process::{Command as Std, Stdio};
    use std::time::{Duration, Instant};

    const BIN: &str = env!("CARGO_BIN_EXE_omnikin");
    for (sig, status) in [("INT", 130), ("TERM", 143)] {
        let port = std::net::UdpSocket::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let zenoh = std::net::TcpListener::bind("127.0.0.1:0").unwrap(); // bound, never accepting
        let zport = zenoh.local_addr().unwrap().port();
        drop(zenoh); // nothing listens there now
        let addr = format!("127.0.0.1:{port}");
        let mut robot = Std::new(BIN)
            .args(["robot", "--sim", "--robot", "kiwi", "--listen", &addr])
            .args(["--max-time", "30"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(300));
        let bridge = Std::new(BIN)
            .args(["ros2", "--connect", &addr])
            .args(["--zenoh", &format!("tcp/127.0.0.1:{zport}")])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Serving: the robot's 20 Hz telemetry becomes odom for over a second.
        std::thread::sleep(Duration::from_millis(2000));
        assert!(
            Std::new("kill")
                .arg(format!("-{sig}"))
                .arg(bridge.id().to_string())
                .status()
                .unwrap()
                .success()
        );
        let start = Instant::now();
        let mut bridge = bridge;
        let code = loop {
            if let Some(s) = bridge.try_wait().unwrap() {
                break s.code();
            }
            if start.elapsed() > Duration::from_secs(10) {
                let _ = bridge.kill();
                let _ = robot.kill();
                panic!("SIG{sig}: ros2 --connect did not stop");
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        let out = bridge.wait_with_output().unwrap();
        let _ = robot.kill();
        let _ = robot.wait();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(code, Some(status), "SIG{sig}: {stderr}");
        assert!(
            stderr.contains(&format!("note: stopped by SIG{sig}")),
            "{stderr}"
        );
        assert!(!stderr.contains("error"), "{stderr}");
        let summary: serde_json::Value =
            serde_json::from_slice(&out.stdout).expect("the counters are printed");
        let odom = summary["ros2"]["odom"].as_u64().unwrap();
        assert!(odom >= 20, "SIG{sig}: only {odom} odom published");
    }
}
