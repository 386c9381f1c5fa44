//! The telemetry log of an operator session (`drive --out`, the console's recording): one CSV
//! row per telemetry frame, pose first (the conventions' pose CSV), then wheel rates, encoder
//! angles (so the log is an encoder log for `omnikin odometry`), mode and faults, the plan's
//! progress, the link's counters, and the robot's estimate when it sends one.

use omnikin::link::{Estimate, Telemetry};
use omnikin_io::telemetry_schema;

/// Telemetry CSV header for a robot of `wheels` wheels (`steer`: with steer motors): the
/// columns of [`omnikin_io::telemetry_schema`] (pose columns first, the pose CSV of the
/// conventions; commanded wheel rates `w1..wN`, encoder wheel angles `q1..qN` and, for kinds
/// with steer motors, steer angles `s1..sN`, so the log is an encoder log for
/// `omnikin odometry`; then the rest), then [`ESTIMATE_COLUMNS`].
pub fn telemetry_header(wheels: usize, steer: bool) -> String {
    let mut h = telemetry_schema::csv_header(wheels, steer);
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

/// One telemetry CSV row in the columns of [`telemetry_header`] without the estimate's
/// ([`estimate_cells`] adds them).
pub fn telemetry_row(t: &Telemetry, wheels: usize, steer: bool) -> String {
    telemetry_schema::csv_row(t, wheels, steer)
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
