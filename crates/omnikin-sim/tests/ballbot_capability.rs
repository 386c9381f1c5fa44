//! The balancing ballbot's command limits against its 3D model (issue 31, observation 4): a
//! yaw rate it cannot hold is refused, naming the limit, and it holds every yaw rate and speed
//! the check accepts (other sensor-noise seeds than the check's own).

use omnikin::Twist2;
use omnikin::description::RobotDescription;
use omnikin::runtime::BalanceRuntimeConfig;
use omnikin_sim::dynamics::ballbot::capability::{
    Limit, check_limits, hold, hold_seconds, largest_accepted,
};

/// The preset's balance runtime configuration, its lean limit (rad) and lean margin.
fn preset() -> (BalanceRuntimeConfig<f64>, f64, f64) {
    let d = RobotDescription::preset("ballbot").unwrap();
    let c = d.balance_config::<f64>().unwrap();
    let (a_max, tilt_deg, margin) = d.lean_acceleration_limit().unwrap();
    (
        BalanceRuntimeConfig::new(c, a_max),
        tilt_deg.to_radians(),
        margin,
    )
}

#[test]
fn a_yaw_rate_it_cannot_hold_is_refused_naming_the_limit() {
    let (mut cfg, max_tilt, margin) = preset();
    // The case: `robot --plant dynamic` used to accept 10 rad/s, and the model falls.
    let fell = hold(&cfg, Twist2::new(0.0, 0.0, 10.0), 6.0, 1);
    assert!(fell.max_tilt > max_tilt, "{fell:?}");
    cfg.max_yaw_rate = 10.0;
    let e = check_limits(&cfg, max_tilt, margin).unwrap_err();
    assert_eq!(e.limit, Limit::YawRate);
    assert!(e.largest > 0.5 && e.largest < 10.0, "{e:?}");
    let msg = e.to_string();
    assert!(
        msg.contains("max_yaw_rate 10 rad/s") && msg.contains("holds at most"),
        "{msg}"
    );
}

#[test]
fn it_holds_every_yaw_rate_and_speed_it_accepts() {
    let (cfg, max_tilt, margin) = preset();
    // The library's defaults (1 rad/s, 1 m/s) pass.
    check_limits(&cfg, max_tilt, margin).unwrap();
    for (limit, upper) in [(Limit::YawRate, 10.0), (Limit::Speed, 2.0)] {
        let largest = largest_accepted(&cfg, limit, upper, max_tilt, margin);
        assert!(largest > 0.0, "{limit:?}");
        // The largest accepted limit passes the check itself…
        let mut c = cfg;
        match limit {
            Limit::YawRate => c.max_yaw_rate = largest,
            Limit::Speed => c.max_speed = largest,
        }
        check_limits(&c, max_tilt, margin).unwrap();
        // …and the robot holds it and every smaller command, whatever the sensor noise.
        for f in [0.25, 0.5, 0.75, 1.0] {
            let v = f * largest;
            let twist = match limit {
                Limit::YawRate => Twist2::new(0.0, 0.0, v),
                Limit::Speed => Twist2::new(v, 0.0, 0.0),
            };
            for seed in [1, 2] {
                let run = hold(&c, twist, hold_seconds(&c, limit, v), seed);
                assert!(
                    run.max_tilt <= max_tilt,
                    "{limit:?} {v}: tilt {}° (seed {seed})",
                    run.max_tilt.to_degrees()
                );
            }
        }
        println!("{limit:?}: largest accepted {largest:.3}");
    }
}
