//! The telemetry log of an operator session (`drive --out`, the console's recording): one CSV
//! row per telemetry frame, pose first (the conventions' pose CSV), then wheel rates, encoder
//! angles (so the log is an encoder log for `omnikin odometry`), mode and faults, the plan's
//! progress, the link's counters, and the robot's estimate when it sends one.

use omnikin::link::{Estimate, Telemetry};

/// Telemetry CSV header for a robot of `wheels` wheels (`steer`: with steer motors): pose
/// columns first (the pose CSV of the conventions), commanded wheel rates `w1..wN`, encoder
/// wheel angles `q1..qN` and, for kinds with steer motors, steer angles `s1..sN` (so the log
/// is an encoder log for `omnikin odometry`), then the rest.
pub fn telemetry_header(wheels: usize, steer: bool) -> String {
    let mut h = String::from("t,x,y,heading,vx,vy,yaw_rate,cmd_vx,cmd_vy,cmd_yaw_rate");
    let mut cols = |p: &str| {
        for i in 1..=wheels {
            h.push_str(&format!(",{p}{i}"));
        }
    };
    cols("w");
    cols("q");
    if steer {
        cols("s");
    }
    h.push_str(",gyro_z,mode,faults,fault_history,plan_id,plan_received,plan_len,plan_time,ref_x,ref_y,ref_heading,rejected,last_command_t,rx_ok,rx_framing,rx_crc,rx_version,rx_auth,rx_replay,rx_malformed,rx_session,rx_entropy");
    h.push_str(ESTIMATE_COLUMNS);
    h
}

/// The estimate columns at the end of a telemetry row (empty when the robot sends no
/// estimate): the uncorrected wheel odometry, the fused pose's variances, the fix counters.
pub const ESTIMATE_COLUMNS: &str = ",odo_x,odo_y,odo_heading,var_x,var_y,var_heading,fix_accepted,fix_rejected,fix_too_late,fix_recoveries,slip_events,collision_events";

/// The [`ESTIMATE_COLUMNS`] of `e` (empty cells for `None`).
pub fn estimate_cells(e: Option<&Estimate>) -> String {
    match e {
        Some(e) => format!(
            ",{},{},{},{:e},{:e},{:e},{},{},{},{},{},{}",
            e.odometry[0],
            e.odometry[1],
            e.odometry[2],
            e.covariance[0],
            e.covariance[1],
            e.covariance[2],
            e.fixes.accepted,
            e.fixes.rejected,
            e.fixes.too_late,
            e.fixes.recoveries,
            e.events.slips,
            e.events.collisions
        ),
        None => ",".repeat(12),
    }
}

/// One telemetry CSV row in the columns of [`telemetry_header`].
pub fn telemetry_row(t: &Telemetry, wheels: usize, steer: bool) -> String {
    let l = &t.link;
    let mut r = format!(
        "{:.6},{},{},{},{},{},{},{},{},{}",
        t.time_us as f64 * 1e-6,
        t.pose[0],
        t.pose[1],
        t.pose[2],
        t.twist[0],
        t.twist[1],
        t.twist[2],
        t.command[0],
        t.command[1],
        t.command[2],
    );
    let mut cols = |v: &[f32]| {
        for x in v.iter().take(wheels) {
            r.push_str(&format!(",{x}"));
        }
    };
    cols(&t.wheel_rates);
    cols(&t.wheel_angles);
    if steer {
        cols(&t.steer_angles);
    }
    r.push_str(&format!(
        ",{},{},{},{},{},{},{},{},{},{},{},{},{:.6},{},{},{},{},{},{},{},{},{}",
        t.gyro[2],
        t.mode,
        t.faults,
        t.fault_history,
        t.plan.id,
        t.plan.received,
        t.plan.len,
        t.plan_time,
        t.reference[0],
        t.reference[1],
        t.reference[2],
        t.rejected,
        t.last_command_us as f64 * 1e-6,
        l.ok,
        l.framing,
        l.crc,
        l.version,
        l.auth,
        l.replay,
        l.malformed,
        l.session,
        l.entropy,
    ));
    r
}

/// The telemetry log kept in memory (Python's `omnikin.Link`): the header and rows of the CSV
/// log, at most `cap` rows (the oldest dropped and counted), taken by [`MemoryLog::take`].
#[derive(Clone, Debug, Default)]
pub struct MemoryLog {
    /// The header, once the first frame fixed the columns.
    pub header: Option<String>,
    /// The rows since the last take, oldest first.
    pub rows: std::collections::VecDeque<String>,
    /// Most rows kept.
    pub cap: usize,
    /// Rows dropped because the cap was reached, since the last take.
    pub dropped: u64,
}

impl MemoryLog {
    /// An empty log of at most `cap` rows.
    pub fn new(cap: usize) -> Self {
        Self {
            cap,
            ..Self::default()
        }
    }

    /// Adds a row, dropping the oldest at the cap.
    pub fn push(&mut self, row: String) {
        if self.cap == 0 {
            self.dropped += 1;
            return;
        }
        if self.rows.len() == self.cap {
            self.rows.pop_front();
            self.dropped += 1;
        }
        self.rows.push_back(row);
    }

    /// The rows so far as CSV text (header first; empty before the first frame) and the
    /// number dropped; the log starts over.
    pub fn take(&mut self) -> (String, u64) {
        let mut text = String::new();
        if let Some(h) = &self.header {
            text.push_str(h);
            text.push('\n');
            for r in self.rows.drain(..) {
                text.push_str(&r);
                text.push('\n');
            }
        }
        (text, std::mem::take(&mut self.dropped))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_memory_log_keeps_the_newest_rows_and_counts_the_rest() {
        let mut m = MemoryLog::new(2);
        assert_eq!(m.take(), (String::new(), 0));
        m.header = Some("t,x".into());
        for i in 0..5 {
            m.push(format!("{i},0"));
        }
        assert_eq!(m.take(), ("t,x\n3,0\n4,0\n".to_string(), 3));
        assert_eq!(m.take(), ("t,x\n".to_string(), 0));
    }
}
