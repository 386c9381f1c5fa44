//! How the cost of `plan`, `simulate`, `evaluate` and `reproduce` grows with path length,
//! sample rate and trial count: each command run as a user runs it (the release binary, its
//! files on disk), wall time per run, on a log-log figure with the fitted slope of each series
//! (the slope between the two largest sizes of each: 1 = linear).
//!
//! ```text
//! cargo bench -p omnikin-cli --bench scaling             # every size, ≈ 2 min on 2 cores
//! cargo bench -p omnikin-cli --bench scaling -- --test   # the smallest size of each (CI runs
//!                                                          # it as `cargo test --bench scaling -- --test`)
//! cargo bench -p omnikin-cli --bench scaling -- --out DIR
//! ```
//!
//! Writes `scaling.csv` (`series,variable,value,seconds`) and `scaling.svg` into `--out`
//! (default `target/tmp/scaling`), and prints a table with each series' slope. The inputs are
//! made here: a random walk of waypoints 0.5 m apart (fixed seed) planned as a time-optimal
//! quintic spline for the `sphere-omni` preset, `examples/profiles/noisy.toml` as the
//! simulation's disturbances. Timings are of one machine and its load: read the slopes.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use plotters::prelude::*;

const BIN: &str = env!("CARGO_BIN_EXE_omnikin");
const ROBOT: &str = "sphere-omni";

/// One measured point of a series.
struct Point {
    series: &'static str,
    variable: &'static str,
    value: f64,
    seconds: f64,
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let quick = args.iter().any(|a| a == "--test");
    let out = args
        .iter()
        .position(|a| a == "--out")
        .and_then(|i| args.get(i + 1))
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_TARGET_TMPDIR")).join("scaling"));
    if let Err(e) = run(&out, quick) {
        eprintln!("scaling: {e}");
        std::process::exit(1);
    }
}

fn run(out: &Path, quick: bool) -> Result<(), String> {
    let work = out.join("work");
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    let noisy = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/profiles/noisy.toml");
    let pick = |all: &[f64]| -> Vec<f64> {
        if quick {
            all[..1].to_vec()
        } else {
            all.to_vec()
        }
    };
    let mut points = Vec::new();
    // One series: `run(size)` returns (the size as plotted, wall time).
    let mut series = |name: &'static str,
                      variable: &'static str,
                      sizes: &[f64],
                      run: &dyn Fn(f64) -> Result<(f64, f64), String>|
     -> Result<(), String> {
        for size in pick(sizes) {
            let (value, seconds) = run(size)?;
            points.push(Point {
                series: name,
                variable,
                value,
                seconds,
            });
        }
        Ok(())
    };
    // The plans the other commands read, made once (untimed) when a series first needs them.
    let wp20 = waypoints(&work, 20)?;
    let plan_of = |n: usize, rate: f64| -> Result<PathBuf, String> {
        let plan = work.join(format!("plan-{n}-{rate}.csv"));
        if !plan.exists() {
            let wp = if n == 20 {
                wp20.clone()
            } else {
                waypoints(&work, n)?
            };
            plan_file(&wp, rate, &plan)?;
        }
        Ok(plan)
    };

    // plan: waypoints at 100 Hz, and 20 waypoints at every rate (timed from scratch).
    series(
        "plan vs path length (100 Hz)",
        "waypoints",
        &[10.0, 20.0, 40.0, 80.0, 160.0, 320.0, 640.0],
        &|n| {
            let wp = waypoints(&work, n as usize)?;
            Ok((
                n,
                time(|| plan_file(&wp, 100.0, &work.join("plan-timed.csv")))?,
            ))
        },
    )?;
    series(
        "plan vs rate (20 waypoints)",
        "rate_hz",
        &[10.0, 100.0, 1000.0, 10000.0],
        &|rate| {
            Ok((
                rate,
                time(|| plan_file(&wp20, rate, &work.join("plan-timed.csv")))?,
            ))
        },
    )?;

    // simulate: trials on the 20-waypoint plan; path length and rate at 20 trials.
    let sim = work.join("sim");
    series(
        "simulate vs trials",
        "trials",
        &[1.0, 10.0, 100.0, 1000.0],
        &|trials| {
            let plan = plan_of(20, 100.0)?;
            Ok((
                trials,
                time(|| simulate(&plan, &noisy, trials as u64, &sim))?,
            ))
        },
    )?;
    series(
        "simulate vs path length (20 trials)",
        "waypoints",
        &[10.0, 20.0, 40.0, 80.0, 160.0],
        &|n| {
            let plan = plan_of(n as usize, 100.0)?;
            Ok((n, time(|| simulate(&plan, &noisy, 20, &sim))?))
        },
    )?;
    series(
        "simulate vs rate (20 trials)",
        "rate_hz",
        &[10.0, 100.0, 1000.0, 10000.0],
        &|rate| {
            let plan = plan_of(20, rate)?;
            Ok((rate, time(|| simulate(&plan, &noisy, 20, &sim))?))
        },
    )?;

    // evaluate: one run of n rows against its plan (the plan itself as the track).
    series(
        "evaluate vs rows",
        "rows",
        &[20.0, 200.0, 2000.0, 20000.0],
        &|rate| {
            let plan = plan_of(20, rate)?;
            let rows = count_rows(&plan)? as f64;
            Ok((rows, time(|| evaluate(&plan, &work.join("eval")))?))
        },
    )?;

    // reproduce: the kinematic profiles at every trial count and plan rate.
    let rep = work.join("reproduce");
    series(
        "reproduce vs trials (3 profiles)",
        "trials",
        &[10.0, 100.0, 1000.0],
        &|trials| Ok((trials, time(|| reproduce(trials as u64, 100.0, &rep))?)),
    )?;
    series(
        "reproduce vs plan rate (10 trials)",
        "rate_hz",
        &[25.0, 100.0, 400.0, 1600.0],
        &|rate| Ok((rate, time(|| reproduce(10, rate, &rep))?)),
    )?;

    let csv = out.join("scaling.csv");
    let mut text = String::from("series,variable,value,seconds\n");
    for p in &points {
        text += &format!("{},{},{},{:.6}\n", p.series, p.variable, p.value, p.seconds);
    }
    std::fs::write(&csv, text).map_err(|e| format!("{}: {e}", csv.display()))?;
    println!(
        "{:<38} {:>10} {:>12}  slope (log-log)",
        "series", "value", "seconds"
    );
    for name in series_names(&points) {
        let pts: Vec<&Point> = points.iter().filter(|p| p.series == name).collect();
        let slope = fit_slope(&pts);
        for (i, p) in pts.iter().enumerate() {
            let slope = if i == 0 {
                slope.map_or("-".into(), |s| format!("{s:.2}"))
            } else {
                String::new()
            };
            println!(
                "{:<38} {:>10} {:>12.4}  {slope}",
                if i == 0 { name } else { "" },
                p.value,
                p.seconds
            );
        }
    }
    if !quick {
        let svg = out.join("scaling.svg");
        figure(&points, &svg)?;
        println!("wrote {} and {}", csv.display(), svg.display());
    } else {
        println!(
            "wrote {} (quick mode: smallest size of each series, no figure)",
            csv.display()
        );
    }
    Ok(())
}

/// Wall time (s) of `f`, which must succeed: the faster of two runs when the first takes
/// under 2 s (a short run is easily disturbed), else the one run.
fn time(f: impl Fn() -> Result<(), String>) -> Result<f64, String> {
    let once = || -> Result<f64, String> {
        let t = Instant::now();
        f()?;
        Ok(t.elapsed().as_secs_f64())
    };
    let first = once()?;
    if first < 2.0 {
        Ok(first.min(once()?))
    } else {
        Ok(first)
    }
}

/// Runs the omnikin binary with `args`, stdout to `stdout` (or discarded).
fn omnikin(args: &[&str], stdout: Option<&Path>) -> Result<(), String> {
    let mut cmd = Command::new(BIN);
    cmd.args(args).stderr(std::process::Stdio::null());
    match stdout {
        Some(p) => {
            let f = std::fs::File::create(p).map_err(|e| format!("{}: {e}", p.display()))?;
            cmd.stdout(f);
        }
        None => {
            cmd.stdout(std::process::Stdio::null());
        }
    }
    let status = cmd.status().map_err(|e| format!("{BIN}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("omnikin {} failed ({status})", args.join(" ")))
    }
}

fn plan_file(waypoints: &Path, rate: f64, out: &Path) -> Result<(), String> {
    let rate = rate.to_string();
    let wp = waypoints.to_string_lossy();
    let args = [
        "plan",
        "waypoints",
        &wp,
        "--robot",
        ROBOT,
        "--path",
        "spline",
        "--time-optimal",
        "--rate",
        &rate,
    ];
    omnikin(&args, Some(out))
}

fn simulate(plan: &Path, profile: &Path, trials: u64, out: &Path) -> Result<(), String> {
    let (plan, profile, out) = (
        plan.to_string_lossy(),
        profile.to_string_lossy(),
        out.to_string_lossy(),
    );
    let trials = trials.to_string();
    let args = [
        "simulate",
        &plan,
        "--robot",
        ROBOT,
        "--disturbances",
        &profile,
        "--trials",
        &trials,
        "--seed",
        "1",
        "--out",
        &out,
        "--force",
    ];
    omnikin(&args, None)
}

fn evaluate(plan: &Path, out: &Path) -> Result<(), String> {
    let (plan, out) = (plan.to_string_lossy(), out.to_string_lossy());
    omnikin(
        &["evaluate", "--plan", &plan, &plan, "--out", &out, "--force"],
        None,
    )
}

fn reproduce(trials: u64, rate: f64, out: &Path) -> Result<(), String> {
    let (trials, rate, out) = (trials.to_string(), rate.to_string(), out.to_string_lossy());
    let args = [
        "reproduce",
        "sphere-2019",
        "--profiles",
        "ideal,hardware,spin-slip",
        "--trials",
        &trials,
        "--rate",
        &rate,
        "--out",
        &out,
        "--force",
    ];
    omnikin(&args, None)
}

/// A random walk of `n` waypoints 0.5 m apart, turning by at most ±1.2 rad per leg (fixed
/// seed), written as `waypoints-n.csv`.
fn waypoints(dir: &Path, n: usize) -> Result<PathBuf, String> {
    let path = dir.join(format!("waypoints-{n}.csv"));
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let (mut x, mut y, mut a) = (0.0_f64, 0.0_f64, 0.0_f64);
    let mut text = String::from("x,y\n");
    for _ in 0..n {
        text += &format!("{x:.4},{y:.4}\n");
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let u = (state >> 11) as f64 / (1_u64 << 53) as f64;
        a += (2.0 * u - 1.0) * 1.2;
        x += 0.5 * a.cos();
        y += 0.5 * a.sin();
    }
    std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path)
}

fn count_rows(path: &Path) -> Result<usize, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(text.lines().count().saturating_sub(1))
}

fn series_names(points: &[Point]) -> Vec<&'static str> {
    let mut names: Vec<&'static str> = Vec::new();
    for p in points {
        if !names.contains(&p.series) {
            names.push(p.series);
        }
    }
    names
}

/// The growth exponent of a series: the slope of log(seconds) against log(value) between its
/// two largest sizes, where the work itself, not process start-up and file set-up, dominates
/// (1 = linear, 2 = quadratic); `None` for a series of one point.
fn fit_slope(points: &[&Point]) -> Option<f64> {
    let [.., a, b] = points else { return None };
    Some((b.seconds / a.seconds).ln() / (b.value / a.value).ln())
}

/// One log-log panel per series, 4 × 2, with the fitted slope in each title.
fn figure(points: &[Point], path: &Path) -> Result<(), String> {
    let names = series_names(points);
    let root = SVGBackend::new(path, (1600, 760)).into_drawing_area();
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled(
            "omnikin: wall time per command against input size (log-log)",
            ("sans-serif", 20),
        )
        .map_err(|e| err(&e))?;
    let panels = root.split_evenly((2, 4));
    for (panel, name) in panels.iter().zip(names) {
        let pts: Vec<&Point> = points.iter().filter(|p| p.series == name).collect();
        let (x0, x1) = bounds(pts.iter().map(|p| p.value));
        let (y0, y1) = bounds(pts.iter().map(|p| p.seconds));
        let slope = fit_slope(&pts).map_or(String::new(), |s| format!(", slope {s:.2}"));
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("{name}{slope}"), ("sans-serif", 14))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc(pts[0].variable)
            .y_desc("wall time, s")
            .x_label_formatter(&|v| number(*v))
            .y_label_formatter(&|v| number(*v))
            .light_line_style(TRANSPARENT)
            .label_style(("sans-serif", 11))
            .draw()
            .map_err(|e| err(&e))?;
        // Linear growth through the largest size, for reference.
        let (first, last) = (pts[0], pts[pts.len() - 1]);
        let linear = [
            (first.value, last.seconds * first.value / last.value),
            (last.value, last.seconds),
        ];
        chart
            .draw_series(LineSeries::new(
                linear,
                RGBColor(150, 150, 150).stroke_width(1),
            ))
            .map_err(|e| err(&e))?
            .label("linear")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], RGBColor(150, 150, 150)));
        let line: Vec<(f64, f64)> = pts.iter().map(|p| (p.value, p.seconds)).collect();
        chart
            .draw_series(LineSeries::new(line.clone(), BLUE.stroke_width(2)))
            .map_err(|e| err(&e))?
            .label("measured")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLUE.stroke_width(2)));
        chart
            .draw_series(
                line.iter()
                    .map(|&(x, y)| Circle::new((x, y), 3, BLUE.filled())),
            )
            .map_err(|e| err(&e))?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(RGBColor(200, 200, 200))
            .label_font(("sans-serif", 11))
            .draw()
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))
}

/// A log axis range of whole decades around the values.
fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, 0.0_f64), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    (
        10_f64.powf(lo.log10().floor()),
        10_f64.powf(hi.log10().ceil()),
    )
}

/// An axis label: `0.01`, `1`, `1000`, `1e6` (three significant digits at most).
fn number(v: f64) -> String {
    if v >= 1.0e5 {
        format!("{v:.0e}")
    } else {
        let s = format!("{:.3}", v);
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s.is_empty() { "0".into() } else { s.into() }
    }
}
