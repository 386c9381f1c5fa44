//! Value parsers for command-line numbers: finite scalars and comma-separated triples, with
//! messages that say what was expected.

use std::str::FromStr;

/// Parses a finite `f64` (rejects `NaN`, `inf`).
pub fn finite_f64(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("expected a number, got \"{s}\""))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("must be a finite number, got \"{s}\""))
    }
}

/// An angle flag (`--heading`, `--yaw`), rad: finite and within
/// ±[`omnikin_plan::limits::MAX_HEADING`] (a heading of 1e308 rad has no direction left in
/// it, and was used as one).
pub fn angle_rad(s: &str) -> Result<f64, String> {
    let v = finite_f64(s)?;
    let max = omnikin_plan::limits::MAX_HEADING;
    if v.abs() <= max {
        Ok(v)
    } else {
        Err(format!(
            "{} rad is outside the plausible range [-{max:e}, {max:e}] rad",
            num(v)
        ))
    }
}

/// A finite number within `[min, max]` (`unit` in the message): the edge check of every
/// duration, rate and count-like float flag whose value becomes a wait or a schedule.
pub fn in_range(s: &str, min: f64, max: f64, unit: &str) -> Result<f64, String> {
    let v = finite_f64(s)?;
    if (min..=max).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "must be between {min} and {max} {unit}, got {}",
            s.trim()
        ))
    }
}

/// `drive --timeout`: 0.01 to 3600 s.
pub fn timeout_s(s: &str) -> Result<f64, String> {
    in_range(s, 0.01, 3600.0, "s")
}

/// `drive --heartbeat`, `robot --telemetry-rate`: 0.1 to 1000 Hz.
pub fn message_rate_hz(s: &str) -> Result<f64, String> {
    in_range(s, 0.1, 1000.0, "Hz")
}

/// `drive velocity --for`, `drive telemetry --for`: 0 to 604800 s (one week).
pub fn run_for_s(s: &str) -> Result<f64, String> {
    in_range(s, 0.0, 604_800.0, "s")
}

/// `drive plan --start-tolerance`, `console --start-tolerance`: 0 to 1000 m.
pub fn start_tolerance_m(s: &str) -> Result<f64, String> {
    in_range(s, 0.0, 1000.0, "m")
}

/// `robot --rate`: the control rate, 1 to 10000 Hz.
pub fn control_rate_hz(s: &str) -> Result<f64, String> {
    in_range(s, 1.0, 10_000.0, "Hz")
}

/// `robot --time-scale`: 0.01 to 1000 times real time.
pub fn time_scale(s: &str) -> Result<f64, String> {
    in_range(s, 0.01, 1000.0, "times real time")
}

/// The largest `--threads` (more only costs memory: each worker reserves its stack).
pub const MAX_THREADS: usize = 256;

/// `--threads`: 1 to [`MAX_THREADS`] worker threads.
pub fn threads(s: &str) -> Result<usize, String> {
    let n: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("expected a whole number of threads, got \"{s}\""))?;
    if (1..=MAX_THREADS).contains(&n) {
        Ok(n)
    } else {
        Err(format!(
            "must be between 1 and {MAX_THREADS} (the limit on worker threads), got {n}"
        ))
    }
}

pub use omnikin_host::operator::duration;

/// Three finite numbers given as `A,B,C` (the components of one quantity: model torques, a
/// body wrench, a pose; the flag's value name says which).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triple(pub [f64; 3]);

impl FromStr for Triple {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let parts: Vec<&str> = s.split(',').collect();
        if parts.len() != 3 {
            return Err(format!(
                "expected three comma-separated numbers like 1.2,-0.5,3, got {} in \"{s}\"",
                parts.len()
            ));
        }
        let mut out = [0.0; 3];
        for (i, p) in parts.iter().enumerate() {
            out[i] = finite_f64(p).map_err(|e| format!("item {}: {e}", i + 1))?;
        }
        Ok(Triple(out))
    }
}

/// One finite number per wheel (or module), given as `A,B,C,…`: 1 to
/// [`omnikin::MAX_WHEELS`] values. The robot's wheel count is checked by [`List::exactly`].
#[derive(Clone, Debug, PartialEq)]
pub struct List(pub Vec<f64>);

impl FromStr for List {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        // Bounded before splitting: a list is never longer than the most wheels of any kind.
        let parts: Vec<&str> = s.splitn(omnikin::MAX_WHEELS + 1, ',').collect();
        if parts.len() > omnikin::MAX_WHEELS {
            return Err(format!(
                "expected at most {} comma-separated numbers (one per wheel), got more",
                omnikin::MAX_WHEELS
            ));
        }
        let mut out = Vec::with_capacity(parts.len());
        for (i, p) in parts.iter().enumerate() {
            out.push(finite_f64(p).map_err(|e| format!("item {}: {e}", i + 1))?);
        }
        Ok(List(out))
    }
}

impl List {
    /// The values, or an error naming `flag`, the expected count and the robot.
    pub fn exactly(&self, n: usize, flag: &str, robot: &str) -> anyhow::Result<&[f64]> {
        if self.0.len() == n {
            Ok(&self.0)
        } else {
            anyhow::bail!(
                "{flag}: expected {n} values (one per wheel of {robot}, in the robot file's order), got {}",
                self.0.len()
            )
        }
    }
}

/// A number for a message: plain, or `1e300` style when tiny or huge, so that a bad value of
/// 1e308 is not quoted as a 309-digit number.
pub use omnikin_io::num;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triples() {
        assert_eq!(
            "-1.2,0.5,-3".parse::<Triple>().unwrap().0,
            [-1.2, 0.5, -3.0]
        );
        assert_eq!(" 1, 2 ,3".parse::<Triple>().unwrap().0, [1.0, 2.0, 3.0]);
        assert!("1,2".parse::<Triple>().unwrap_err().contains("got 2"));
        assert!("1,x,3".parse::<Triple>().unwrap_err().contains("item 2"));
        assert!("1,NaN,3".parse::<Triple>().unwrap_err().contains("finite"));
        assert!(finite_f64("inf").is_err());
        assert_eq!(finite_f64("-0.1").unwrap(), -0.1);
    }

    #[test]
    fn lists() {
        assert_eq!(
            "1,-2,3,4".parse::<List>().unwrap().0,
            vec![1.0, -2.0, 3.0, 4.0]
        );
        assert!(
            "1,2,3,4,5,6,7"
                .parse::<List>()
                .unwrap_err()
                .contains("at most 6")
        );
        assert!("1,,3".parse::<List>().unwrap_err().contains("item 2"));
        let l = "1,2,3".parse::<List>().unwrap();
        let e = l
            .exactly(4, "--wheel-rates", "mecanum")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("expected 4 values") && e.contains("got 3"),
            "{e}"
        );
        assert_eq!(l.exactly(3, "--x", "kiwi").unwrap(), &[1.0, 2.0, 3.0]);
    }

    #[test]
    fn ranges_and_durations() {
        assert_eq!(timeout_s("3").unwrap(), 3.0);
        for bad in ["1e300", "0", "-1", "NaN", "inf", "0.001"] {
            let e = timeout_s(bad).unwrap_err();
            assert!(
                e.contains("0.01 and 3600") || e.contains("finite"),
                "{bad}: {e}"
            );
        }
        assert!(message_rate_hz("1e-300").is_err());
        assert!(control_rate_hz("1e9").is_err());
        assert!(time_scale("1e-300").is_err());
        assert!(threads("100000").unwrap_err().contains("256"));
        assert!(threads("0").is_err());
        assert_eq!(threads("4").unwrap(), 4);
        assert!(duration("--x", 1e300).is_err());
        assert!(duration("--x", -1.0).is_err());
        assert!(duration("--x", f64::NAN).is_err());
        assert_eq!(duration("--x", 0.5).unwrap().as_millis(), 500);
    }
}
