//! Issue 12, observations 5 and 9 at the library edge: requests whose plan would not fit in
//! memory are refused before anything is allocated, with the limit, the value the inputs
//! imply and what to change; absurd but finite parameters are refused with their range.
//! Each test here ran out of memory (or planned nonsense) before the limits existed.

use omnikin::description::RobotDescription;
use omnikin_plan::generators::{Circle, Square};
use omnikin_plan::heading::{HeadingLaw, HeadingProfile};
use omnikin_plan::limits::{
    MAX_HEADING, MAX_PLAN_GRID_CELLS, MAX_PLAN_SAMPLES, MAX_WAYPOINTS, RATE_RANGE, SPEED_RANGE,
};
use omnikin_plan::path::{Corners, Path};
use omnikin_plan::planner::{MotionLimits, OnLimit, PlanOptions, Timing, plan};
use omnikin_plan::profile::ProfileKind;
use omnikin_plan::waypoints::Waypoints;
use omnikin_plan::{PlanningError, RobotModel};

fn robot(name: &str) -> RobotModel {
    RobotModel::from_description(&RobotDescription::preset(name).unwrap()).unwrap()
}

fn plan_square(sq: Square, rate: f64) -> Result<omnikin_plan::planner::Planned, PlanningError> {
    plan(
        &sq.path()?,
        &sq.heading(),
        &robot("sphere-omni"),
        &sq.options(rate, OnLimit::Retime),
    )
}

fn plan_circle(c: Circle, rate: f64) -> Result<omnikin_plan::planner::Planned, PlanningError> {
    plan(
        &c.path()?,
        &c.heading(),
        &robot("sphere-omni"),
        &c.options(rate),
    )
}

fn out_of_range(e: &PlanningError) -> (&'static str, f64, f64, f64) {
    match e {
        PlanningError::OutOfRange {
            name,
            value,
            min,
            max,
            ..
        } => (name, *value, *min, *max),
        other => panic!("expected OutOfRange, got {other:?}"),
    }
}

#[test]
fn a_square_at_a_nanometre_per_second_is_out_of_range() {
    // `plan square --speed 1e-9`: 1.6e9 s of plan, 1.6e11 samples at 100 Hz.
    let e = plan_square(
        Square {
            speed: 1e-9,
            ..Square::paper(1.0)
        },
        100.0,
    )
    .unwrap_err();
    let (name, value, min, max) = out_of_range(&e);
    assert_eq!((name, value), ("speed", 1e-9));
    assert_eq!((min, max), SPEED_RANGE);
    let msg = e.to_string();
    assert!(
        msg.contains("speed = 1e-9 m/s") && msg.contains("[1e-4, 100]"),
        "{msg}"
    );
}

#[test]
fn a_terahertz_sampling_rate_is_out_of_range() {
    // `plan square --rate 1e12`.
    let e = plan_square(Square::paper(1.0), 1e12).unwrap_err();
    let (name, value, min, max) = out_of_range(&e);
    assert_eq!((name, value, (min, max)), ("rate", 1e12, RATE_RANGE));
}

#[test]
fn plans_over_the_sample_limit_are_refused_before_sampling() {
    // Every parameter in range, but 16 800 s × 1e5 Hz = 1.68e9 samples (≈ 230 GB).
    let e = plan_square(
        Square {
            speed: 1e-4,
            ..Square::paper(1.0)
        },
        1e5,
    )
    .unwrap_err();
    let PlanningError::TooLarge {
        items,
        needed,
        limit,
        max,
        ..
    } = &e
    else {
        panic!("expected TooLarge, got {e:?}");
    };
    assert_eq!(
        (*items, *limit, *max),
        ("samples", "MAX_PLAN_SAMPLES", MAX_PLAN_SAMPLES)
    );
    let duration = 4.0 * 0.4 / 1e-4 * 1.05;
    assert!((needed / (duration * 1e5) - 1.0).abs() < 1e-3, "{needed}");
    let msg = e.to_string();
    assert!(
        msg.contains("--rate") && msg.contains("MAX_PLAN_SAMPLES = 2000000"),
        "{msg}"
    );
}

#[test]
fn slow_requests_within_the_ranges_still_plan() {
    // The slowest allowed square, sampled at 1 Hz: 16 800 s, 16 801 samples.
    let p = plan_square(
        Square {
            speed: 1e-4,
            ..Square::paper(1.0)
        },
        1.0,
    )
    .unwrap();
    let n = p.plan.samples.len();
    assert!((16_800..=16_802).contains(&n), "{n}");
}

#[test]
fn a_circle_at_a_nanoradian_per_second_is_out_of_range() {
    // `plan circle --omega 1e-9`.
    let e = plan_circle(
        Circle {
            omega: 1e-9,
            ..Circle::paper(1.0)
        },
        100.0,
    )
    .unwrap_err();
    assert_eq!(out_of_range(&e).0, "|omega|");
}

#[test]
fn a_circle_ramp_longer_than_the_circle_is_refused() {
    // `--ramp 1e300` used to plan "successfully" into a degenerate plan.
    for ramp in [1e300, 1e4, 7.0] {
        let e = plan_circle(
            Circle {
                ramp: Some(ramp),
                ..Circle::paper(1.0) // 12.57 s at full speed: ramps of at most 6.28 s
            },
            100.0,
        )
        .unwrap_err();
        assert_eq!(out_of_range(&e).0, "ramp", "{ramp}: {e}");
    }
    let ok = plan_circle(
        Circle {
            ramp: Some(1.0),
            ..Circle::paper(1.0)
        },
        100.0,
    )
    .unwrap();
    assert!(ok.plan.samples.len() > 1000);
}

#[test]
fn a_path_too_long_for_the_grid_is_refused_before_the_grid_is_built() {
    // 30 legs of 5 km with stops: 3e6 cells of 5 cm, over MAX_PLAN_GRID_CELLS.
    let pts: Vec<[f64; 2]> = (0..31)
        .map(|k| [if k % 2 == 0 { 0.0 } else { 5000.0 }, k as f64])
        .collect();
    let path = Path::polyline(&pts, Corners::Stop).unwrap();
    let opts = PlanOptions {
        timing: Timing::Profile {
            kind: ProfileKind::Trapezoid,
            limits: MotionLimits::default(),
        },
        on_limit: OnLimit::Retime,
        rate: 100.0,
        initial_steer: omnikin_plan::planner::InitialSteer::Aligned,
    };
    let e = plan(
        &path,
        &HeadingLaw::Constant(0.0),
        &robot("sphere-omni"),
        &opts,
    )
    .unwrap_err();
    match &e {
        PlanningError::TooLarge {
            limit, max, needed, ..
        } => {
            assert_eq!((*limit, *max), ("MAX_PLAN_GRID_CELLS", MAX_PLAN_GRID_CELLS));
            assert!(*needed >= 3e6, "{needed}");
        }
        other => panic!("expected TooLarge, got {other:?}"),
    }
}

#[test]
fn a_waypoint_heading_of_1e300_names_the_line() {
    // `plan waypoints` with a heading of 1e300: the heading profile's slope made every motor
    // limit need a plan of ~1e300 s.
    let e = Waypoints::from_csv("x,y,heading\n0,0,0\n1,0,1e300\n", "w.csv")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("w.csv:3: column heading = 1e300 rad is outside the plausible range"),
        "{e}"
    );
    assert!(e.contains("MAX_HEADING"), "{e}");
    let e = Waypoints::from_toml(
        "[[waypoint]]\nx = 0.0\ny = 0.0\nheading = 0.0\n\n[[waypoint]]\nx = 1.0\ny = 0.0\nheading = -1e300\n",
        "w.toml",
    )
    .unwrap_err()
    .to_string();
    // The heading value is on line 9, below its `[[waypoint]]` header (line 6).
    assert!(e.starts_with("w.toml:9: waypoint 2: heading"), "{e}");
    let e = Waypoints::from_csv("0,0\n1e7,0\n", "w.csv")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("w.csv:2: column x = 1e7 m"), "{e}");
    // The same limit in the library type the planner uses.
    let e = HeadingProfile::new(&[(0.0, 0.0), (1.0, 2.0 * MAX_HEADING)]).unwrap_err();
    assert_eq!(out_of_range(&e).0, "heading profile heading");
    let e = HeadingLaw::Constant(1e300).validate().unwrap_err();
    assert_eq!(out_of_range(&e).0, "heading");
}

#[test]
fn waypoint_files_have_a_bounded_number_of_waypoints() {
    let mut text = String::new();
    for k in 0..=MAX_WAYPOINTS {
        text.push_str(&format!("{k},0\n"));
    }
    let e = Waypoints::from_csv(&text, "w.csv").unwrap_err().to_string();
    assert!(
        e.starts_with(&format!(
            "w.csv:{}: more than {MAX_WAYPOINTS}",
            MAX_WAYPOINTS + 1
        )),
        "{e}"
    );
    // One fewer is fine.
    let n = text.lines().count();
    let fewer: String = text.lines().take(n - 1).map(|l| format!("{l}\n")).collect();
    assert_eq!(
        Waypoints::from_csv(&fewer, "w.csv").unwrap().points.len(),
        MAX_WAYPOINTS
    );
}

#[test]
fn a_byte_order_mark_does_not_break_waypoint_files() {
    // Observation 9: a UTF-8 BOM made the header "\u{feff}x" unknown.
    let w = Waypoints::from_csv("\u{feff}x,y\n0,0\n1,0\n", "w.csv").unwrap();
    assert_eq!(w.points, vec![[0.0, 0.0], [1.0, 0.0]]);
    assert_eq!(w.lines, vec![2, 3]);
    let w = Waypoints::from_csv("\u{feff}0,0\n1,0\n", "w.csv").unwrap();
    assert_eq!(w.points.len(), 2);
    let w = Waypoints::from_toml(
        "\u{feff}[[waypoint]]\nx = 0.0\ny = 0.0\n[[waypoint]]\nx = 1.0\ny = 0.0\n",
        "w.toml",
    )
    .unwrap();
    assert_eq!(w.lines, vec![1, 4]);
}

#[test]
fn motion_limits_and_path_sizes_have_ranges() {
    let path = Path::polyline(&[[0.0, 0.0], [1.0, 0.0]], Corners::Stop).unwrap();
    let with = |limits: MotionLimits| PlanOptions {
        timing: Timing::TimeOptimal { limits },
        on_limit: OnLimit::Retime,
        rate: 100.0,
        initial_steer: omnikin_plan::planner::InitialSteer::Aligned,
    };
    let r = robot("sphere-omni");
    let law = HeadingLaw::Constant(0.0);
    for (limits, name) in [
        (
            MotionLimits {
                max_speed: 1e9,
                ..MotionLimits::default()
            },
            "max speed",
        ),
        (
            MotionLimits {
                max_accel: 1e-300,
                ..MotionLimits::default()
            },
            "max acceleration",
        ),
        (
            MotionLimits {
                max_yaw_rate: 1e300,
                ..MotionLimits::default()
            },
            "max yaw rate",
        ),
    ] {
        let e = plan(&path, &law, &r, &with(limits)).unwrap_err();
        assert_eq!(out_of_range(&e).0, name);
    }
    let e = Path::polyline(
        &[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]],
        Corners::Fillet { radius: 1e300 },
    )
    .unwrap_err();
    assert_eq!(out_of_range(&e).0, "fillet radius");
    let e = Square {
        side: 1e300,
        ..Square::paper(1.0)
    }
    .validate()
    .unwrap_err();
    assert_eq!(out_of_range(&e).0, "side");
    let e = Circle {
        turns: 1e300,
        ..Circle::paper(1.0)
    }
    .validate()
    .unwrap_err();
    assert_eq!(out_of_range(&e).0, "turns");
}

#[test]
fn a_csv_line_longer_than_the_limit_is_refused_while_streaming() {
    use omnikin_plan::Plan;
    use omnikin_plan::limits::MAX_CSV_LINE;
    use std::io::Read;
    // A file without newlines: the CSV reader grew one record to the whole file (a 4 GB
    // file aborted `simulate` and `drive plan` under a 3 GiB limit). Here 4 MiB of digits
    // after a valid header, read lazily: refused at the limit, naming it.
    let header = "t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3\n";
    let input = header.as_bytes().chain(std::io::repeat(b'1').take(4 << 20));
    let e = Plan::read_csv(input, "p.csv").unwrap_err().to_string();
    assert!(e.contains("MAX_CSV_LINE") && e.contains("p.csv"), "{e}");
    assert!(e.len() < 1000, "the message does not echo the line");
    // A header line over the limit, too.
    let e = Plan::read_csv(std::io::repeat(b'a').take(2 * MAX_CSV_LINE as u64), "h.csv")
        .unwrap_err()
        .to_string();
    assert!(e.contains("MAX_CSV_LINE"), "{e}");
    // A line just within the limit is read (and fails on its content, not its length).
    let long = format!("{header}1{}\n", ",0".repeat(9));
    assert!(Plan::read_csv(long.as_bytes(), "ok.csv").is_ok());
}
