//! Paper 000's 0.2 m circles (0.1, 0.2, 0.4, 0.5 m/s, one turn, 100 Hz plan) through the
//! shell + platform dynamic model, for a list of pivot-friction torques: the fitted/planned
//! radius of the tracked point (top of the platform), the largest tilt, the most negative shell
//! spin and the motors' pull-out events.
//!
//! ```text
//! cargo run --release -p omnikin-sim --example sphere_circles -- RAMP PULL_OUT H C_RR TAU...
//! ```
//! `RAMP`: `none` (the paper's full-speed start) or a ramp time in s; `PULL_OUT`: N·m (`inf`
//! for ideal motors); `H`: centre-of-mass depth, m; `C_RR`: rolling-resistance coefficient;
//! `TAU...`: pivot friction torques, N·m. `default` for any of the first four keeps
//! [`SphereDynamics::paper_000`]'s value.

use omnikin::description::RobotDescription;
use omnikin_plan::RobotModel;
use omnikin_plan::generators::Circle;
use omnikin_plan::planner::plan;
use omnikin_sim::dynamics::sphere::{SphereDynamics, SphereSim, SphereState};
use omnikin_sim::metrics::fit_circle;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 5 {
        eprintln!("usage: sphere_circles RAMP PULL_OUT H C_RR TAU...");
        std::process::exit(2);
    }
    let opt = |s: &str| -> Option<f64> {
        (s != "default" && s != "none").then(|| s.parse().expect("a number"))
    };
    let d = RobotDescription::preset("sphere-omni").expect("preset");
    let model = RobotModel::from_description(&d).expect("model");
    let base = SphereDynamics::paper_000();
    for tau in args[4..]
        .iter()
        .map(|a| a.parse::<f64>().expect("a torque"))
    {
        let mut p = base;
        p.pivot_friction = tau;
        p.pull_out_torque = opt(&args[1]).unwrap_or(base.pull_out_torque);
        p.com_depth = opt(&args[2]).unwrap_or(base.com_depth);
        p.rolling_resistance = opt(&args[3]).unwrap_or(base.rolling_resistance);
        let mut line = format!(
            "start {} pull-out {} h {} C_rr {} pivot {tau}:",
            args[0], p.pull_out_torque, p.com_depth, p.rolling_resistance
        );
        for k in [1.0, 2.0, 4.0, 5.0] {
            let mut c = Circle::paper(k);
            c.ramp = opt(&args[0]);
            let pl = plan(&c.path().unwrap(), &c.heading(), &model, &c.options(100.0))
                .expect("plan")
                .plan;
            let s0 = &pl.samples[0];
            let start = SphereState::at_rest(s0.pose.x, s0.pose.y, s0.pose.heading);
            let mut sim = SphereSim::with_state(p, start).expect("valid parameters");
            let mut pts = vec![[s0.pose.x, s0.pose.y]];
            let (mut tilt, mut spin, mut pull_outs) = (0.0f64, 0.0f64, 0);
            for w in pl.samples.windows(2) {
                let r = w[1].wheel_rates;
                let st = sim.step(w[1].t - w[0].t, [r[0], r[1], r[2]]).expect("step");
                pts.push(st.tracked);
                tilt = tilt.max(st.tilt);
                spin = spin.min(st.shell_spin);
                pull_outs += st.pull_out.iter().filter(|&&b| b).count();
            }
            let planned: Vec<[f64; 2]> = pl.samples.iter().map(|x| [x.pose.x, x.pose.y]).collect();
            let ratio = fit_circle(&pts).unwrap().radius / fit_circle(&planned).unwrap().radius;
            line += &format!(
                " | {:.1} m/s: {ratio:.3} (tilt ≤ {tilt:.2}, Ω3 ≥ {spin:.2}, pull-outs {pull_outs})",
                c.speed()
            );
        }
        println!("{line}");
    }
}
