//! The streaming camera's statistics: rate, latency, noise σ, dropouts, the outage window and
//! seeding, all of the one `sensors::CameraProfile` (paper 000's video: 25 frames/s, 40 ms,
//! 2 mm) with its `CameraGaps`.

use omnikin_sim::camera::Camera;
use omnikin_sim::sensors::{CameraGaps, CameraProfile, SimulatedFix};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Runs the camera for `secs` at 1 kHz over a truth moving at 0.3 m/s along x; every delivered
/// fix with the time it was seen.
fn run(profile: CameraProfile, gaps: CameraGaps, seed: u64, secs: f64) -> Vec<(f64, SimulatedFix)> {
    let mut cam = Camera::new(profile, gaps, ChaCha8Rng::seed_from_u64(seed)).unwrap();
    let mut out = Vec::new();
    let n = (secs * 1000.0).round() as usize;
    for i in 0..=n {
        let t = i as f64 / 1000.0;
        cam.capture(t, 0.3 * t, 0.0, 0.0);
        while let Some(f) = cam.deliver(t) {
            out.push((t, f));
        }
    }
    out
}

#[test]
fn rate_latency_and_noise_match_the_profile() {
    let p = CameraProfile::paper_000();
    let fixes = run(p, CameraGaps::default(), 1, 40.0);
    // Frames at 0, 0.04, …, 40 s: 1001, less the one still in flight (40 ms latency).
    assert_eq!(fixes.len(), 1000);
    for (k, (t_seen, f)) in fixes.iter().enumerate() {
        assert!((f.t - k as f64 * 0.04).abs() < 1e-9, "frame {k} at {}", f.t);
        assert!((f.arrival - f.t - p.latency).abs() < 1e-12);
        // Seen on the first 1 ms step at or after its arrival.
        assert!(
            *t_seen >= f.arrival - 1e-9 && *t_seen < f.arrival + 1e-3,
            "{t_seen} {f:?}"
        );
        assert!(f.heading.is_none() && !f.outlier);
    }
    let errs: Vec<f64> = fixes.iter().map(|(_, f)| f.x - 0.3 * f.t).collect();
    let n = errs.len() as f64;
    let mean = errs.iter().sum::<f64>() / n;
    let sd = (errs.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
    // The σ of n ≈ 1000 samples has a relative sd of 1/√(2n) ≈ 2.2 %: 4 sd is 9 %; the
    // mean's sd is σ/√n ≈ 0.06 mm: 4 sd is 0.25 mm.
    assert!((sd / p.noise_std - 1.0).abs() < 0.09, "sd {sd}");
    assert!(mean.abs() < 2.5e-4, "mean {mean}");
}

#[test]
fn dropouts_lose_their_share_of_frames() {
    let gaps = CameraGaps {
        dropout_probability: 0.3,
        outage: None,
    };
    let fixes = run(CameraProfile::paper_000(), gaps, 3, 40.0);
    // 1000 frames, each kept with p = 0.7: mean 700, sd √(1000·0.21) ≈ 14.5; 4 sd ≈ 58.
    assert!((642..=758).contains(&fixes.len()), "{} fixes", fixes.len());
}

#[test]
fn outage_window_delivers_nothing_and_seed_is_deterministic() {
    let gaps = CameraGaps {
        dropout_probability: 0.0,
        outage: Some([2.0, 4.0]),
    };
    let p = CameraProfile::paper_000();
    let a = run(p, gaps, 7, 6.0);
    assert!(a.iter().all(|(_, f)| f.t < 2.0 - 1e-9 || f.t >= 4.0 - 1e-9));
    // Frames at 0..1.96 s (50) and 4.0..5.96 s (50); the one at 6.0 s is still in flight.
    assert_eq!(a.len(), 100);
    assert_eq!(a, run(p, gaps, 7, 6.0));
    assert_ne!(a, run(p, gaps, 8, 6.0));
    // The outage takes frames away without shifting the noise of the others.
    let full = run(p, CameraGaps::default(), 7, 6.0);
    let kept: Vec<_> = full
        .iter()
        .filter(|(_, f)| f.t < 2.0 - 1e-9 || f.t >= 4.0 - 1e-9)
        .cloned()
        .collect();
    assert_eq!(a, kept);
}

#[test]
fn bad_profiles_name_the_key() {
    let p = CameraProfile {
        period: 0.0,
        ..CameraProfile::paper_000()
    };
    let e = Camera::new(p, CameraGaps::default(), ChaCha8Rng::seed_from_u64(0)).unwrap_err();
    assert!(e.starts_with("camera.period"), "{e}");
    let g = CameraGaps {
        dropout_probability: 1.5,
        outage: None,
    };
    let e = Camera::new(CameraProfile::paper_000(), g, ChaCha8Rng::seed_from_u64(0)).unwrap_err();
    assert!(e.starts_with("camera_gaps.dropout_probability"), "{e}");
    let g = CameraGaps {
        dropout_probability: 0.0,
        outage: Some([3.0, 1.0]),
    };
    let e = Camera::new(CameraProfile::paper_000(), g, ChaCha8Rng::seed_from_u64(0)).unwrap_err();
    assert!(
        e.contains("camera_gaps.outage") && e.contains("after end"),
        "{e}"
    );
}
