//! What the robot says at the end of an operator's action, in lines for a person: the fixes
//! forwarded, the robot's fused estimate (once fixes are in play), its mode, pose and faults,
//! and its link counters — what `omnikin drive` prints after every action.

use omnikin::link::Estimate;

use crate::operator::Session;

impl Session {
    /// The session's status in lines (empty before the first telemetry and without fixes):
    /// the fix feeder's report; `robot estimate: …` (pose ± 1σ and the wheel odometry; world
    /// frame, m and rad) once fixes are forwarded or the robot has had some; `robot t …` (robot
    /// time, mode, pose, faults, fault history); `robot link: …` (frames accepted and dropped
    /// by reason, commands rejected).
    pub fn status_lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(f) = &self.fixes {
            out.push(f.report(self.estimate.map(|e| e.fixes)));
        }
        // The estimate line once fixes are in play (this run forwards them, or the robot has
        // had some): before that the pose is the wheel odometry and the line says nothing new.
        let fixes_seen = |e: &Estimate| {
            let f = e.fixes;
            self.fixes.is_some() || f.accepted + f.rejected + f.too_late > 0
        };
        if let (Some(e), Some(t)) = (
            self.estimate.as_ref().filter(|e| fixes_seen(e)),
            &self.latest,
        ) {
            out.push(format!(
                "robot estimate: pose ({:.4} m, {:.4} m, {:.4} rad) ± ({:.4} m, {:.4} m, {:.4} rad) 1σ; wheel odometry ({:.4} m, {:.4} m, {:.4} rad)",
                t.pose[0],
                t.pose[1],
                t.pose[2],
                e.covariance[0].max(0.0).sqrt(),
                e.covariance[1].max(0.0).sqrt(),
                e.covariance[2].max(0.0).sqrt(),
                e.odometry[0],
                e.odometry[1],
                e.odometry[2]
            ));
        }
        if let Some(t) = &self.latest {
            out.push(format!(
                "robot t {:.3} s: mode {}, pose ({:.4} m, {:.4} m, {:.4} rad), faults {}, history {}",
                t.time_us as f64 * 1e-6,
                t.mode,
                t.pose[0],
                t.pose[1],
                t.pose[2],
                t.faults,
                t.fault_history
            ));
            let l = &t.link;
            out.push(format!(
                "robot link: {} frames ok, dropped {} (framing {}, crc {}, version {}, auth {}, replay {}, malformed {}, session {}, entropy {}); commands rejected {}",
                l.ok,
                l.dropped(),
                l.framing,
                l.crc,
                l.version,
                l.auth,
                l.replay,
                l.malformed,
                l.session,
                l.entropy,
                t.rejected
            ));
        }
        out
    }
}
