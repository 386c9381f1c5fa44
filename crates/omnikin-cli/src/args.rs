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

/// Three finite numbers given as `A,B,C` (one per wheel).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triple(pub [f64; 3]);

impl FromStr for Triple {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let parts: Vec<&str> = s.split(',').collect();
        if parts.len() != 3 {
            return Err(format!(
                "expected three comma-separated numbers like 1.2,-0.5,3 (one per wheel), got {} in \"{s}\"",
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
}
