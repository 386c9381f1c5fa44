//! Shared by the end-to-end link tests (`robot.rs`, `link.rs`): a simulated robot process on
//! loopback UDP, the operator command, the paper's square as a plan file, CSV rows as maps.
#![allow(dead_code)] // each test binary uses its own subset

use std::collections::HashMap;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use omnikin::description::RobotDescription;
use omnikin_plan::RobotModel;
use omnikin_plan::generators::Square;
use omnikin_plan::planner::{OnLimit, plan};

pub const BIN: &str = env!("CARGO_BIN_EXE_omnikin");

pub mod test_dir;

/// A fresh directory for one test's files (`suite` keeps the test binaries apart), removed
/// when the test passes.
pub fn tmp(suite: &str, name: &str) -> test_dir::TestDir {
    test_dir::TestDir::new(suite, name)
}

pub fn free_port() -> u16 {
    std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A running `omnikin robot --sim --robot sphere-omni` (8× real time), killed on drop.
pub struct Robot {
    child: Option<Child>,
    pub addr: String,
}

impl Robot {
    pub fn start(extra: &[&str]) -> Self {
        Self::start_robot("sphere-omni", extra)
    }

    /// [`Robot::start`] of another robot (preset name or file).
    pub fn start_robot(robot: &str, extra: &[&str]) -> Self {
        let addr = format!("127.0.0.1:{}", free_port());
        let child = Command::new(BIN)
            .args(["robot", "--sim", "--robot", robot, "--listen", &addr])
            .args(["--time-scale", "8"])
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(150));
        Robot {
            child: Some(child),
            addr,
        }
    }

    pub fn socket_addr(&self) -> SocketAddr {
        self.addr.parse().unwrap()
    }

    /// Waits (bounded) for the robot to reach --max-time and returns its JSON summary.
    pub fn summary(mut self) -> serde_json::Value {
        let mut child = self.child.take().unwrap();
        let end = Instant::now() + Duration::from_secs(20);
        while child.try_wait().unwrap().is_none() {
            assert!(Instant::now() < end, "robot did not stop by itself");
            std::thread::sleep(Duration::from_millis(20));
        }
        let out = child.wait_with_output().unwrap();
        assert!(
            out.status.success(),
            "robot failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    }
}

impl Robot {
    /// Stops the robot now (SIGTERM: it ends its loop and prints its summary as at
    /// `--max-time`) and returns its JSON summary.
    #[allow(dead_code)]
    pub fn stop_summary(mut self) -> serde_json::Value {
        let child = self.child.take().unwrap();
        let _ = Command::new("kill")
            .args(["-TERM", &child.id().to_string()])
            .status();
        let out = child.wait_with_output().unwrap();
        serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
            panic!(
                "robot summary: {e}: {}",
                String::from_utf8_lossy(&out.stderr)
            )
        })
    }
}

impl Drop for Robot {
    fn drop(&mut self) {
        if let Some(c) = self.child.as_mut() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// `omnikin drive --connect ADDR --heartbeat 100 --timeout TIMEOUT ARGS…`, output echoed.
pub fn drive(addr: &str, timeout: &str, args: &[&str]) -> Output {
    let out = Command::new(BIN)
        .args(["drive", "--connect", addr, "--heartbeat", "100"])
        .args(["--timeout", timeout])
        .args(args)
        .output()
        .unwrap();
    eprintln!(
        "drive {args:?}: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The 0.1 m/s square of paper 000 (0.4 m side), sampled at 100 Hz, as a plan CSV.
pub fn square_plan(dir: &Path) -> PathBuf {
    let robot =
        RobotModel::from_description(&RobotDescription::preset("sphere-omni").unwrap()).unwrap();
    let sq = Square::paper(1.0);
    let p = plan(
        &sq.path().unwrap(),
        &sq.heading(),
        &robot,
        &sq.options(100.0, OnLimit::Retime),
    )
    .unwrap();
    let path = dir.join("square.csv");
    p.plan.save_csv(&path).unwrap();
    path
}

/// CSV rows as maps from column name to text.
pub fn read_rows(path: &Path) -> Vec<HashMap<String, String>> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let h = r.headers().unwrap().clone();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            h.iter()
                .zip(rec.iter())
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .collect()
        })
        .collect()
}

/// Column `k` of a row as a number.
pub fn num(r: &HashMap<String, String>, k: &str) -> f64 {
    r[k].parse().unwrap_or_else(|_| panic!("{k} = {:?}", r[k]))
}

/// A test operator's entropy: a xorshift generator (a test client only, never a robot).
pub struct ClockRng(pub u64);

impl omnikin::runtime::hal::Entropy for ClockRng {
    fn fill(&mut self, buf: &mut [u8]) -> Result<(), omnikin::runtime::hal::EntropyError> {
        for b in buf {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            *b = (self.0 >> 40) as u8;
        }
        Ok(())
    }
}

/// A [`ClockRng`] seeded from the clock (each run's nonces differ).
pub fn clock_rng() -> ClockRng {
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64;
    ClockRng(t | 1)
}
