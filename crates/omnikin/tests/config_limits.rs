//! Issue 12, observation 6: `robot --rate 1e9` ran flat out without ever reaching its robot
//! time, and `--rate 1e-300` waited ~1e300 s per cycle. The control rate has a stated range,
//! checked by the runtime itself (so firmware and bindings get the same error).

use omnikin::runtime::{Config, RATE_HZ_RANGE};

#[test]
fn the_control_rate_has_a_stated_range() {
    for rate in [1e9, 1e-300, 0.5, 10_000.5, f64::NAN, 0.0, -100.0] {
        let e = Config::new(rate).validate().unwrap_err();
        assert_eq!(e.field, "rate_hz", "{rate}");
    }
    let e = Config::new(1e9).validate().unwrap_err();
    assert!(e.rule.contains("between 1 and 10000 Hz"), "{}", e.rule);
    assert_eq!(RATE_HZ_RANGE, (1.0, 10_000.0));
    for rate in [RATE_HZ_RANGE.0, 100.0, 1000.0, RATE_HZ_RANGE.1] {
        assert!(Config::new(rate).validate().is_ok(), "{rate}");
    }
    // The same rule in single precision (firmware).
    assert!(Config::new(1e9_f32).validate().is_err());
    assert!(Config::new(100.0_f32).validate().is_ok());
}
