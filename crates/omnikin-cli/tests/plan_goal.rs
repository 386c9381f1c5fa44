//! `omnikin plan goal` across the example map and `plan waypoints --map` (issue 40): every
//! sample of the plan keeps the footprint clear of every shape (distances computed here from the
//! map file's numbers, not by omnikin_plan::map), the plan ends at the goal with its heading,
//! and bad requests are errors naming the map's line.

#[path = "common/test_dir.rs"]
mod test_dir;

use assert_cmd::Command;
use omnikin_plan::Plan;

const MAP: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../examples/maps/cluttered.toml"
);

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

/// The example map's shapes as this test reads them (one `circle = [x, y, r]` or
/// `polygon = [[x, y], …]` per line, as the file is written): circles `(x, y, r)`, polygons.
/// Circles `(x, y, r)` and polygons of the example map.
type Shapes = (Vec<[f64; 3]>, Vec<Vec<[f64; 2]>>);

fn shapes() -> Shapes {
    let (mut circles, mut polygons) = (Vec::new(), Vec::new());
    let numbers = |s: &str| -> Vec<f64> {
        s.split(['[', ']', ','])
            .map(str::trim)
            .filter(|t| !t.is_empty())
            .map(|t| t.parse().unwrap())
            .collect()
    };
    for line in std::fs::read_to_string(MAP).unwrap().lines() {
        if let Some(c) = line.strip_prefix("circle = ") {
            let v = numbers(c);
            circles.push([v[0], v[1], v[2]]);
        } else if let Some(p) = line.strip_prefix("polygon = ") {
            let v = numbers(p);
            polygons.push(v.chunks(2).map(|c| [c[0], c[1]]).collect());
        }
    }
    // The last polygon is the keep-in square, handled by `clearance` itself.
    polygons.pop();
    (circles, polygons)
}

fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let t = (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

/// Distance from `p` to the nearest shape (negative inside a polygon or circle) and to the
/// keep-in square [0, 10]².
fn clearance(p: [f64; 2]) -> f64 {
    let (circles, polygons) = shapes_cached();
    let mut d = p[0].min(p[1]).min(10.0 - p[0]).min(10.0 - p[1]);
    for c in circles {
        d = d.min((p[0] - c[0]).hypot(p[1] - c[1]) - c[2]);
    }
    for v in polygons {
        let n = v.len();
        let edge = (0..n)
            .map(|i| seg_dist(p, v[i], v[(i + 1) % n]))
            .fold(f64::INFINITY, f64::min);
        // Convex counter-clockwise polygons (the example's): inside when left of every edge.
        let inside = (0..n).all(|i| {
            let (a, b) = (v[i], v[(i + 1) % n]);
            (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) > 0.0
        });
        d = d.min(if inside { -edge } else { edge });
    }
    d
}

fn shapes_cached() -> &'static Shapes {
    static S: std::sync::OnceLock<Shapes> = std::sync::OnceLock::new();
    S.get_or_init(shapes)
}

fn run(args: &[&str]) -> (bool, Vec<u8>, String) {
    let out = omnikin().args(args).output().unwrap();
    (
        out.status.success(),
        out.stdout,
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

#[test]
fn the_goal_plan_crosses_the_example_map_clear_of_every_shape() {
    for (robot, f) in [("sphere-omni", 0.15), ("kiwi", 0.3)] {
        let fs = f.to_string();
        let (ok, out, err) = run(&[
            "plan",
            "goal",
            "--robot",
            robot,
            "--map",
            MAP,
            "--from",
            "0.5,0.5",
            "--to",
            "9.5,9.5,1.5",
            "--footprint-radius",
            &fs,
            "--rate",
            "50",
        ]);
        assert!(ok, "{robot}: {err}");
        let plan = Plan::read_csv(&out[..], "stdout").unwrap();
        for s in &plan.samples {
            let c = clearance([s.pose.x, s.pose.y]);
            assert!(
                c >= f * (1.0 - 1e-9),
                "{robot}: t = {} s at ({}, {}): {c} m from a shape",
                s.t,
                s.pose.x,
                s.pose.y
            );
        }
        let last = plan.samples.last().unwrap();
        assert!((last.pose.x - 9.5).abs() < 1e-6 && (last.pose.y - 9.5).abs() < 1e-6);
        assert!(
            (last.pose.heading - 1.5).abs() < 1e-6,
            "{robot}: ends at heading {}",
            last.pose.heading
        );
        // Longer than the straight line (the map is in the way of it) but not by much.
        let len = plan.path_length();
        let straight = 9.0 * 2f64.sqrt();
        assert!(
            len > straight + 1e-3 && len < 1.2 * straight,
            "{robot}: {len} m"
        );
        assert!(err.contains("footprint radius"), "{err}");
    }
}

#[test]
fn a_goal_in_an_obstacle_or_outside_the_keep_in_names_the_line() {
    // The first keep-out of the example is the circle at (4.65, 8.17), line 6.
    let (ok, _, err) = run(&[
        "plan",
        "goal",
        "--robot",
        "sphere-omni",
        "--map",
        MAP,
        "--from",
        "0.5,0.5",
        "--to",
        "4.65,8.17",
    ]);
    assert!(!ok);
    assert!(
        err.contains("cluttered.toml:6:") && err.contains("goal") && err.contains("inside"),
        "{err}"
    );
    let (ok, _, err) = run(&[
        "plan",
        "goal",
        "--robot",
        "sphere-omni",
        "--map",
        MAP,
        "--from",
        "0.5,0.5",
        "--to",
        "11,5",
    ]);
    assert!(!ok);
    assert!(err.contains("outside the keep_in"), "{err}");
    let (ok, _, err) = run(&[
        "plan",
        "goal",
        "--robot",
        "sphere-omni",
        "--map",
        MAP,
        "--from",
        "0.5",
        "--to",
        "1,1",
    ]);
    assert!(!ok);
    assert!(err.contains("--from: expected X,Y or X,Y,H"), "{err}");
}

#[test]
fn waypoints_through_an_obstacle_are_refused_or_repaired_with_map() {
    let dir = test_dir::TestDir::file("plan-goal-cli", "through.csv");
    // Straight through the circle at (4.65, 8.17) r 0.25.
    std::fs::write(dir.path(), "x,y\n4.0,8.17\n5.3,8.17\n").unwrap();
    let wp = dir.path().to_str().unwrap();
    let base = [
        "plan",
        "waypoints",
        wp,
        "--robot",
        "sphere-omni",
        "--map",
        MAP,
    ];
    let (ok, _, err) = run(&base);
    assert!(!ok);
    assert!(
        err.contains("cluttered.toml:6:") && err.contains("the path at s ="),
        "{err}"
    );
    let (ok, out, err) = run(&[&base[..], &["--repair"]].concat());
    assert!(ok, "{err}");
    assert!(err.contains("repaired: the path came within"), "{err}");
    assert!(
        err.contains("repaired around") && !err.contains("stop at corners"),
        "{err}"
    );
    let plan = Plan::read_csv(&out[..], "stdout").unwrap();
    for s in &plan.samples {
        assert!(
            clearance([s.pose.x, s.pose.y]) >= 0.15 * (1.0 - 1e-9),
            "t = {} s",
            s.t
        );
    }
    // Without the map the same file plans straight through the obstacle (what --map guards).
    let (ok, out, _) = run(&base[..5]);
    assert!(ok);
    let plan = Plan::read_csv(&out[..], "stdout").unwrap();
    assert!(
        plan.samples
            .iter()
            .any(|s| clearance([s.pose.x, s.pose.y]) < 0.0)
    );
}

/// `--start-velocity`: the goal plan leaves the start at the given velocity and yaw rate (its
/// first sample within 1e-9), stays clear of every shape, ends at the goal at rest, and is
/// faster than from rest; a start beyond the max speed is refused naming it and the excess;
/// `plan waypoints` takes it with `--time-optimal` only.
#[test]
fn a_goal_plan_can_start_moving() {
    let common = [
        "plan",
        "goal",
        "--robot",
        "kiwi",
        "--map",
        MAP,
        "--from",
        "0.5,0.5",
        "--to",
        "9.5,9.5,1.5",
        "--footprint-radius",
        "0.3",
        "--max-speed",
        "0.3",
    ];
    let (ok, out, err) = run(&[&common[..], &["--start-velocity", "0.2,0.1,0.05"]].concat());
    assert!(ok, "{err}");
    assert!(err.contains("from (0.2, 0.1) m/s, a lead-in of"), "{err}");
    let plan = Plan::read_csv(&out[..], "stdout").unwrap();
    let s0 = plan.samples[0];
    assert!((s0.twist.vx - 0.2).abs() < 1e-9, "{:?}", s0.twist);
    assert!((s0.twist.vy - 0.1).abs() < 1e-9, "{:?}", s0.twist);
    assert!((s0.twist.yaw_rate - 0.05).abs() < 1e-9, "{:?}", s0.twist);
    for s in &plan.samples {
        let c = clearance([s.pose.x, s.pose.y]);
        assert!(c >= 0.3 * (1.0 - 1e-9), "t = {} s: {c} m from a shape", s.t);
    }
    let last = plan.samples.last().unwrap();
    assert!((last.pose.x - 9.5).abs() < 1e-6 && (last.pose.y - 9.5).abs() < 1e-6);
    assert!((last.pose.heading - 1.5).abs() < 1e-6);
    assert!(last.twist.vx.hypot(last.twist.vy) < 1e-9);
    let (ok, rest, err) = run(&common);
    assert!(ok, "{err}");
    let rest = Plan::read_csv(&rest[..], "stdout").unwrap();
    assert!(
        plan.duration() < rest.duration(),
        "{} s moving, {} s from rest",
        plan.duration(),
        rest.duration()
    );
    let (ok, _, err) = run(&[&common[..], &["--start-velocity", "0.4,0"]].concat());
    assert!(!ok);
    assert!(
        err.contains("start speed 0.400000 m/s is above the 0.300000 m/s that max speed allows")
            && err.contains("by 33.333 %"),
        "{err}"
    );
    let (ok, _, err) = run(&[&common[..], &["--start-velocity", "0.4"]].concat());
    assert!(!ok && err.contains("expected VX,VY or VX,VY,W"), "{err}");
    // Waypoints: along the first leg; without --time-optimal refused by the argument parser.
    let dir = test_dir::TestDir::file("plan-goal-start", "wp.csv");
    std::fs::write(dir.path(), "x,y\n0,0\n1,0\n1.5,0.8\n").unwrap();
    let wp = dir.path().to_str().unwrap();
    let args = [
        "plan",
        "waypoints",
        wp,
        "--robot",
        "kiwi",
        "--corners",
        "fillet",
        "--fillet-radius",
        "0.3",
        "--max-speed",
        "1",
        "--start-velocity",
        "0.5,0",
    ];
    let (ok, _, err) = run(&args);
    assert!(!ok && err.contains("--time-optimal"), "{err}");
    let (ok, out, err) = run(&[&args[..], &["--time-optimal"]].concat());
    assert!(ok, "{err}");
    assert!(err.contains("starts moving (--start-velocity)"), "{err}");
    assert!(!err.contains("Sphere paper"), "{err}");
    let plan = Plan::read_csv(&out[..], "stdout").unwrap();
    assert!((plan.samples[0].twist.vx - 0.5).abs() < 1e-9);
    let (ok, _, err) = run(&[&args[..12], &["0.5,0.1", "--time-optimal"]].concat());
    assert!(!ok && err.contains("off the path's first tangent"), "{err}");
}
