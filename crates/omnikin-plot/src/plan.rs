//! The `--plot` figure of a plan (SVG): the path with direction arrows (and the map's shapes
//! for `plan goal` and `plan waypoints --map`), the wheel rates over
//! time (one series per wheel), and the steer rates (one series per steer motor of robots
//! with steering) or the speed and yaw rate.

use std::path::Path as FsPath;

use anyhow::Result;
use omnikin_plan::map::{Map, Shape};
use omnikin_plan::{Plan, RobotModel};

use crate::{Arrow, PALETTE, Series};

/// Draws the plan to `svg` (.svg, .png or .pdf; errors name `flag`) under `title`: the path
/// with direction arrows and `map`'s shapes (left), wheel rates over time (top right), steer
/// rates (robots with steering) or speed and yaw rate (bottom right).
///
/// # Errors
/// An unknown extension or a file that cannot be written.
pub fn plan_figure(
    flag: &str,
    svg: &FsPath,
    title: &str,
    plan: &Plan,
    robot: &RobotModel,
    map: Option<&Map>,
) -> Result<()> {
    crate::svg_file(flag, svg, (1300, 640), |root| {
        draw_plan(root, title, plan, robot, map)
    })
}

/// The outlines of a map's shapes (closed polylines; circles as 72-gons), keep-out first.
fn map_outlines(map: &Map) -> Vec<Series> {
    let outline = |shape: &Shape| -> Vec<(f64, f64)> {
        match shape {
            Shape::Circle { centre, radius } => (0..=72)
                .map(|k| {
                    let a = std::f64::consts::TAU * f64::from(k) / 72.0;
                    (centre[0] + radius * a.cos(), centre[1] + radius * a.sin())
                })
                .collect(),
            Shape::Polygon(v) => v.iter().chain(v.first()).map(|p| (p[0], p[1])).collect(),
        }
    };
    let mut out: Vec<Series> = map
        .keep_out
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let label = if i == 0 { "keep-out" } else { "" };
            Series::solid(label, outline(&o.shape), PALETTE[1])
        })
        .collect();
    if let Some(k) = &map.keep_in {
        out.push(Series::dashed("keep-in", outline(&k.shape), PALETTE[2]));
    }
    out
}

fn draw_plan(
    root: &crate::Area,
    title: &str,
    plan: &Plan,
    robot: &RobotModel,
    map: Option<&Map>,
) -> Result<()> {
    use plotters::prelude::*;
    root.fill(&WHITE).map_err(crate::draw_err)?;
    let root = root
        .titled(&crate::svg_text(title), ("sans-serif", 22))
        .map_err(crate::draw_err)?;
    let (left, right) = root.split_horizontally(600);
    let (top, bottom) = right.split_vertically(305);
    let s = &plan.samples;
    let xy: Vec<(f64, f64)> = s.iter().map(|p| (p.pose.x, p.pose.y)).collect();
    // Arrows at ~12 evenly spaced points along the path (by arc length), pointing along the
    // velocity there.
    let total = plan.path_length();
    let mut arrows = Vec::new();
    let mut next = total / 24.0;
    let mut acc = 0.0;
    for w in s.windows(2) {
        acc += (w[1].pose.x - w[0].pose.x).hypot(w[1].pose.y - w[0].pose.y);
        if acc >= next && total > 0.0 {
            let v = (w[1].twist.vx, w[1].twist.vy);
            if v.0.hypot(v.1) > 1e-9 {
                arrows.push(Arrow {
                    at: (w[1].pose.x, w[1].pose.y),
                    dir: v,
                    color: PALETTE[3],
                });
            }
            next += total / 12.0;
        }
    }
    crate::xy_panel(
        &left,
        "path (world frame), arrows = direction of motion",
        "x [m]",
        "y [m]",
        &std::iter::once(Series::solid("planned path r_C", xy, PALETTE[0]))
            .chain(map.map(map_outlines).unwrap_or_default())
            .collect::<Vec<_>>(),
        &[],
        &arrows,
    )?;
    let t: Vec<f64> = s.iter().map(|p| p.t).collect();
    let n = plan.wheels;
    let wheels: Vec<Series> = (0..n)
        .map(|i| {
            Series::solid(
                format!("w{}", i + 1),
                t.iter()
                    .zip(s)
                    .map(|(&t, p)| (t, p.wheel_rates[i]))
                    .collect(),
                PALETTE[i % PALETTE.len()],
            )
        })
        .collect();
    let steered = robot.steerable();
    crate::time_panel(
        &top,
        if steered { "roll rates" } else { "wheel rates" },
        "rate [rad/s]",
        &wheels,
        &[],
        robot.limits.max_wheel_rate.map(|l| (l, "±max_wheel_rate")),
    )?;
    if steered {
        let steer: Vec<Series> = (0..n)
            .map(|i| {
                Series::solid(
                    format!("sd{}", i + 1),
                    t.iter()
                        .zip(s)
                        .map(|(&t, p)| (t, p.steer.map_or(0.0, |(_, r)| r[i])))
                        .collect(),
                    PALETTE[(i + 3) % PALETTE.len()],
                )
            })
            .collect();
        crate::time_panel(
            &bottom,
            "steer rates",
            "steer rate [rad/s]",
            &steer,
            &[],
            robot.limits.max_steer_rate.map(|l| (l, "±max_steer_rate")),
        )?;
    } else {
        let speed = Series::solid(
            "speed |v| [m/s]",
            t.iter()
                .zip(s)
                .map(|(&t, p)| (t, p.twist.vx.hypot(p.twist.vy)))
                .collect(),
            PALETTE[4],
        );
        let yaw = Series::solid(
            "yaw rate [rad/s]",
            t.iter()
                .zip(s)
                .map(|(&t, p)| (t, p.twist.yaw_rate))
                .collect(),
            PALETTE[5],
        );
        crate::time_panel(
            &bottom,
            "speed and yaw rate",
            "[m/s], [rad/s]",
            &[speed, yaw],
            &[],
            None,
        )?;
    }
    Ok(())
}
