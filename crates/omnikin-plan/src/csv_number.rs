//! How omnikin writes a floating-point number into its CSV files.
//!
//! A plan is read by the robot and by the tools, so a written number must read back to the very
//! same `f64` (round trip), and it must stay readable: Rust's `{}` prints the shortest digits
//! that round-trip but never switches to an exponent, so `cos(π/2) = 6.1e-17` comes out as
//! `0.000000000000000061232339957367660` and `1e300` as 301 digits. [`CsvFloat`] prints the
//! same shortest digits, in scientific form (`6.123233995736766e-17`) when the magnitude is
//! below [`PLAIN_MIN`] or at least [`PLAIN_MAX`], and `0` for negative zero. The value is never
//! rounded or clamped: the JSON output (serde_json, also shortest round-trip) carries the same
//! numbers, and a plan written and read again is bit for bit the plan.
//!
//! Every reader of the project's CSV files (Rust's `str::parse`, Python's `float`, pandas,
//! NumPy, C's `strtod`) accepts both forms.

use std::fmt;

/// Smallest magnitude printed without an exponent (smaller non-zero values use `e-5` form).
pub const PLAIN_MIN: f64 = 1e-4;
/// Magnitude from which values are printed with an exponent (`1e15` and above).
pub const PLAIN_MAX: f64 = 1e15;

/// An `f64` displayed as omnikin's CSV files write it: the shortest decimal that reads back to
/// the same value, scientific outside `[PLAIN_MIN, PLAIN_MAX)`, `-0` written as `0`.
/// Non-finite values print as Rust prints them (`NaN`, `inf`); the writers reject them first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CsvFloat(pub f64);

impl fmt::Display for CsvFloat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        let a = x.abs();
        if x == 0.0 {
            f.write_str("0")
        } else if a.is_finite() && !(PLAIN_MIN..PLAIN_MAX).contains(&a) {
            write!(f, "{x:e}")
        } else {
            write!(f, "{x}")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn show(x: f64) -> String {
        CsvFloat(x).to_string()
    }

    #[test]
    fn tiny_and_huge_values_use_an_exponent_and_read_back_exactly() {
        let tiny = (std::f64::consts::PI).sin(); // 1.2246467991473532e-16, not an exact zero
        assert_eq!(show(tiny), "1.2246467991473532e-16");
        assert_eq!(show(-tiny), "-1.2246467991473532e-16");
        assert_eq!(show(1e300), "1e300");
        assert_eq!(show(f64::MIN_POSITIVE), "2.2250738585072014e-308");
        for x in [
            tiny,
            -tiny,
            1e300,
            f64::MIN_POSITIVE,
            5e-324,
            f64::MAX,
            1e15,
            9.99e-5,
        ] {
            assert_eq!(
                show(x).parse::<f64>().unwrap().to_bits(),
                x.to_bits(),
                "{x}"
            );
        }
    }

    #[test]
    fn ordinary_values_stay_plain() {
        assert_eq!(show(0.1), "0.1");
        assert_eq!(show(-1.428571), "-1.428571");
        assert_eq!(show(1e-4), "0.0001");
        assert_eq!(show(123456.5), "123456.5");
        assert_eq!(show(1.0 / 3.0), "0.3333333333333333");
        assert_eq!(show(-0.0), "0");
        assert_eq!(show(0.0), "0");
    }

    #[test]
    fn every_magnitude_round_trips() {
        // A deterministic sweep over 600 decades and awkward mantissas.
        let mut x = 5e-324_f64;
        while x.is_finite() {
            for m in [1.0, 1.0 / 3.0, 0.1, 0.7, 9.999_999_999_999_999] {
                let v = x * m;
                if v.is_finite() && v != 0.0 {
                    let back: f64 = show(v).parse().unwrap();
                    assert_eq!(back.to_bits(), v.to_bits(), "{v:e} printed {}", show(v));
                    let back: f64 = show(-v).parse().unwrap();
                    assert_eq!(back.to_bits(), (-v).to_bits());
                }
            }
            x *= 7.3;
        }
    }
}
