//! A plan as the link carries it: its samples decimated to the points a robot's plan buffer
//! holds (f32 on the wire).

use omnikin::link::WirePoint;
use omnikin_plan::Plan;

/// The plan's points, decimated evenly (keeping the last) to at most `cap`.
pub fn plan_points(plan: &Plan, cap: usize) -> Vec<WirePoint> {
    let n = plan.samples.len();
    let step = n.div_ceil(cap.max(2) - 1).max(1);
    let mut idx: Vec<usize> = (0..n).step_by(step).collect();
    if idx.last() != Some(&(n - 1)) {
        idx.push(n - 1);
    }
    idx.iter()
        .map(|&i| {
            let p = &plan.samples[i];
            WirePoint {
                t: p.t as f32,
                pose: [p.pose.x as f32, p.pose.y as f32, p.pose.heading as f32],
                twist: [
                    p.twist.vx as f32,
                    p.twist.vy as f32,
                    p.twist.yaw_rate as f32,
                ],
            }
        })
        .collect()
}
