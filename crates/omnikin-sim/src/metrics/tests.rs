//! Tests of the metrics: quantiles against tables, the circle fit, the path distance, and the
//! streaming evaluation and path index against the quadratic and exhaustive oracles.

use super::evaluator::{QUERY_CHUNK, max_distance, nearest_all};
use super::*;

#[test]
fn t_quantiles_match_tables() {
    // Two-sided 95 %: df 1 → 12.706, df 2 → 4.303, df 9 → 2.262, df 29 → 2.045.
    for (n, q) in [(2, 12.706), (3, 4.303), (10, 2.262), (30, 2.045)] {
        assert!((t_quantile(0.95, n) - q).abs() < 1e-3, "n {n}");
    }
    assert!(t_quantile(0.95, 1).is_nan());
}

#[test]
fn circle_fit_recovers_a_noisy_arc() {
    let pts: Vec<[f64; 2]> = (0..200)
        .map(|k| {
            let a = k as f64 * 0.02;
            let r = 0.3 + 0.001 * ((k * 7919) % 13) as f64 / 13.0;
            [1.0 + r * a.cos(), -2.0 + r * a.sin()]
        })
        .collect();
    let c = fit_circle(&pts).unwrap();
    assert!((c.radius - 0.3005).abs() < 1e-3, "{c:?}");
    assert!(
        (c.center[0] - 1.0).abs() < 1e-3 && (c.center[1] + 2.0).abs() < 1e-3,
        "{c:?}"
    );
    assert!(fit_circle(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]).is_none());
}

#[test]
fn distance_to_a_polyline() {
    let path = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]];
    assert!((distance_to_path([0.5, 0.2], &path) - 0.2).abs() < 1e-15);
    assert!((distance_to_path([1.5, 0.5], &path) - 0.5).abs() < 1e-15);
    assert!((distance_to_path([-3.0, 4.0], &path) - 5.0).abs() < 1e-15);
}

#[test]
fn band_half_width_is_t_times_standard_error() {
    let runs: Vec<Run> = [0.0, 1.0, 2.0]
        .iter()
        .map(|&x| Run {
            xy: vec![[x, -x]],
            heading: None,
        })
        .collect();
    let m = mean_trajectory(&runs, 0.95);
    assert_eq!(m.mean[0], [1.0, -1.0]);
    // s = 1, n = 3: 4.303 / √3.
    assert!((m.half_width[0][0] - 4.302653 / 3f64.sqrt()).abs() < 1e-5);
}
/// The evaluation before the path index and the streaming passes: every sample against
/// every segment. The oracle of the property tests.
fn evaluate_quadratic(plan: &Plan, runs: &[Run]) -> (Metrics, MeanTrajectory) {
    let path: Vec<[f64; 2]> = plan.samples.iter().map(|s| [s.pose.x, s.pose.y]).collect();
    let length = plan.path_length();
    let mean = mean_trajectory(runs, 0.95);
    let (mut max_dev, mut sum_sq, mut count, mut max_track, mut max_head) =
        (0.0f64, 0.0f64, 0usize, 0.0f64, None::<f64>);
    let (mut end_sum, mut end_max) = (0.0f64, 0.0f64);
    let mut max_from_mean = 0.0f64;
    let last = path.len().saturating_sub(1);
    for r in runs {
        for (k, p) in r.xy.iter().enumerate() {
            let d = distance_to_path(*p, &path);
            max_dev = max_dev.max(d);
            sum_sq += d * d;
            count += 1;
            max_track = max_track.max((p[0] - path[k][0]).hypot(p[1] - path[k][1]));
            max_from_mean =
                max_from_mean.max((p[0] - mean.mean[k][0]).hypot(p[1] - mean.mean[k][1]));
        }
        if let Some(h) = &r.heading {
            let e = h
                .iter()
                .zip(&plan.samples)
                .map(|(h, s)| angle_diff(*h, s.pose.heading).abs())
                .fold(0.0, f64::max);
            max_head = Some(max_head.map_or(e, |m: f64| m.max(e)));
        }
        if let Some(p) = r.xy.last() {
            let e = (p[0] - path[last][0]).hypot(p[1] - path[last][1]);
            end_sum += e;
            end_max = end_max.max(e);
        }
    }
    let n = runs.len().max(1) as f64;
    let end_mean = {
        let mut m = [0.0; 2];
        for r in runs {
            if let Some(p) = r.xy.last() {
                m[0] += p[0] / n;
                m[1] += p[1] / n;
            }
        }
        m
    };
    let spread = (runs
        .iter()
        .filter_map(|r| r.xy.last())
        .map(|p| (p[0] - end_mean[0]).powi(2) + (p[1] - end_mean[1]).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let mean_max_dev = mean
        .mean
        .iter()
        .map(|p| distance_to_path(*p, &path))
        .fold(0.0, f64::max);
    let ci = mean
        .half_width
        .iter()
        .map(|h| h[0].hypot(h[1]))
        .fold(0.0, f64::max);
    let planned_circle =
        fit_circle(&path).filter(|c| c.rms_residual < 0.01 * c.radius && length > 3.0 * c.radius);
    let fitted_circle = planned_circle.and_then(|_| fit_circle(&mean.mean));
    let radius_ratio = match (planned_circle, fitted_circle) {
        (Some(p), Some(f)) => Some(f.radius / p.radius),
        _ => None,
    };
    (
        Metrics {
            runs: runs.len(),
            path_length_m: length,
            duration_s: plan.duration(),
            max_deviation_m: max_dev,
            max_deviation_pct_of_path: if length > 0.0 {
                100.0 * max_dev / length
            } else {
                0.0
            },
            rms_deviation_m: if count > 0 {
                (sum_sq / count as f64).sqrt()
            } else {
                0.0
            },
            max_plan_distance_from_run_m: runs
                .iter()
                .flat_map(|r| path.iter().map(|q| distance_to_path(*q, &r.xy)))
                .fold(0.0, f64::max),
            max_tracking_error_m: max_track,
            end_point_error_m: end_sum / n,
            max_end_point_error_m: end_max,
            max_heading_error_rad: max_head,
            mean_max_deviation_m: mean_max_dev,
            max_deviation_from_mean_m: max_from_mean,
            end_point_spread_m: spread,
            ci95_max_half_width_m: ci,
            planned_circle,
            fitted_circle,
            radius_ratio,
        },
        mean,
    )
}

use omnikin::{Pose2, Twist2};
use omnikin_plan::Sample;
use proptest::prelude::*;

fn plan_of(xy: &[[f64; 2]]) -> Plan {
    Plan {
        wheels: 3,
        samples: xy
            .iter()
            .enumerate()
            .map(|(k, p)| Sample {
                t: 0.01 * k as f64,
                pose: Pose2::new(p[0], p[1], 0.1 * k as f64),
                twist: Twist2::new(0.0, 0.0, 0.0),
                wheel_rates: [0.0; omnikin::MAX_WHEELS],
                steer: None,
            })
            .collect(),
    }
}

/// Paths the metrics meet: random walks (with repeated points and spikes), and circles of
/// several laps (points nearly equidistant from many segments), at any scale and offset.
fn path_strategy() -> impl Strategy<Value = Vec<[f64; 2]>> {
    let walk = (
        prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0, 0u8..8), 1..400),
        -3i32..4,
        prop_oneof![-1e3f64..1e3, -1e7f64..1e7],
    )
        .prop_map(|(steps, e, off)| {
            let scale = 10f64.powi(e);
            let mut p = [off, -off];
            steps
                .into_iter()
                .map(|(dx, dy, kind)| {
                    match kind {
                        0 => {}                                    // repeated point
                        1 => p = [p[0] + 50.0 * dx * scale, p[1]], // spike
                        _ => p = [p[0] + dx * scale, p[1] + dy * scale],
                    }
                    p
                })
                .collect()
        });
    let circle =
        (3usize..600, 1usize..4, 0.01f64..100.0, -10.0f64..10.0).prop_map(|(n, laps, r, c)| {
            (0..n * laps)
                .map(|k| {
                    let a = core::f64::consts::TAU * k as f64 / n as f64;
                    [c + r * a.cos(), c + r * a.sin()]
                })
                .collect()
        });
    prop_oneof![walk, circle]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// The index gives the exhaustive scan's distance bit for bit, near the path (where
    /// pruning decides), far from it, on vertices, and at the centre of circles.
    #[test]
    fn path_index_equals_the_exhaustive_scan(
        path in path_strategy(),
        queries in prop::collection::vec((0.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0, 0u8..4), 1..60),
        hint in 0usize..1000,
    ) {
        let index = PathIndex::new(&path);
        let span = path.iter().flat_map(|p| p.iter()).fold(0.0f64, |m, c| m.max(c.abs())).max(1e-3);
        let mut h = hint;
        for (f, dx, dy, kind) in queries {
            let v = path[((f * path.len() as f64) as usize).min(path.len() - 1)];
            let q = match kind {
                0 => v,
                1 => [v[0] + 1e-3 * span * dx, v[1] + 1e-3 * span * dy],
                2 => [v[0] + 3.0 * span * dx, v[1] + 3.0 * span * dy],
                _ => {
                    // The centroid: for a circle, nearly equidistant from every segment.
                    let n = path.len() as f64;
                    [path.iter().map(|p| p[0]).sum::<f64>() / n + 1e-9 * dx,
                     path.iter().map(|p| p[1]).sum::<f64>() / n]
                }
            };
            let brute = distance_to_path(q, &path);
            let (fast, seg) = index.nearest(q, h);
            prop_assert_eq!(fast.to_bits(), brute.to_bits(), "query {:?}", q);
            prop_assert_eq!(index.distance(q).to_bits(), brute.to_bits());
            h = seg;
        }
    }

    /// The early-break farthest distance is the largest exhaustive distance bit for bit: for
    /// points along the path (most searches stop early), a noisy dense copy of it (the case
    /// the early break is for), points far away and at the centroid, in any order.
    #[test]
    fn path_index_farthest_equals_the_largest_exhaustive_distance(
        path in path_strategy(),
        noise in prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0), 1..40),
        scale in prop_oneof![Just(0.0), 1e-6f64..1e-3, 1e-2f64..0.3, 1.0f64..10.0],
        dense in 1usize..6,
        reversed in any::<bool>(),
    ) {
        let index = PathIndex::new(&path);
        let n = path.len();
        // Points between the vertices (`dense` per segment), each moved by the noise.
        let mut points: Vec<[f64; 2]> = (0..(n - 1).max(1) * dense)
            .map(|j| {
                let (k, f) = (j / dense, (j % dense) as f64 / dense as f64);
                let (a, b) = (path[k.min(n - 1)], path[(k + 1).min(n - 1)]);
                let e = noise[j % noise.len()];
                [a[0] + f * (b[0] - a[0]) + scale * e.0, a[1] + f * (b[1] - a[1]) + scale * e.1]
            })
            .collect();
        let c = [
            path.iter().map(|p| p[0]).sum::<f64>() / n as f64,
            path.iter().map(|p| p[1]).sum::<f64>() / n as f64,
        ];
        points.insert(points.len() / 2, c);
        if reversed {
            points.reverse();
        }
        let brute = points.iter().map(|&q| distance_to_path(q, &path)).fold(0.0, f64::max);
        prop_assert_eq!(index.farthest(&points).to_bits(), brute.to_bits());
        prop_assert_eq!(index.farthest(&[]).to_bits(), 0.0f64.to_bits());
        // And the other way round: the path's vertices against the noisy points' polyline.
        let back = PathIndex::new(&points);
        let brute = path.iter().map(|&q| distance_to_path(q, &points)).fold(0.0, f64::max);
        prop_assert_eq!(back.farthest(&path).to_bits(), brute.to_bits());
    }

    /// The streaming two-pass evaluation equals the quadratic one, every metric bit for
    /// bit, and the mean trajectory and band too.
    #[test]
    fn streaming_evaluation_equals_the_quadratic_one(
        path in path_strategy(),
        noise in prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0), 1..50),
        runs in 1usize..5,
        lag in 0usize..30,
        headings in any::<bool>(),
    ) {
        let plan = plan_of(&path);
        let n = path.len();
        let runs: Vec<Run> = (0..runs)
            .map(|r| Run {
                xy: (0..n)
                    .map(|k| {
                        let p = path[k.saturating_sub(r * lag).min(n - 1)];
                        let e = noise[(k + r) % noise.len()];
                        [p[0] + 0.05 * e.0 * (r + 1) as f64, p[1] + 0.05 * e.1]
                    })
                    .collect(),
                heading: headings.then(|| (0..n).map(|k| 0.1 * k as f64 + 0.01 * r as f64).collect()),
            })
            .collect();
        let (want, want_mean) = evaluate_quadratic(&plan, &runs);
        let got = evaluate(&plan, &runs).unwrap();
        let bits = |m: &Metrics| m.values().into_iter().map(|(k, v)| (k, v.to_bits())).collect::<Vec<_>>();
        prop_assert_eq!(bits(&got.metrics), bits(&want));
        prop_assert_eq!(&got.metrics, &want);
        prop_assert_eq!(&got.mean, &want_mean);
        prop_assert_eq!(&mean_trajectory(&runs, 0.95), &want_mean);
    }
}

#[test]
fn a_run_that_never_moves_is_far_from_the_plan() {
    let path: Vec<[f64; 2]> = (0..=100).map(|k| [0.01 * k as f64, 0.0]).collect();
    let plan = plan_of(&path);
    let still = Run {
        xy: vec![path[0]; path.len()],
        heading: None,
    };
    let m = evaluate(&plan, &[still]).unwrap().metrics;
    // On the path all the time (the paper's deviation is 0) ...
    assert_eq!(m.max_deviation_m, 0.0);
    // ... but the plan's end is 1 m from anything the run did.
    assert!(
        (m.max_plan_distance_from_run_m - 1.0).abs() < 1e-12,
        "{m:?}"
    );
    assert!((m.end_point_error_m - 1.0).abs() < 1e-12);
    // A run that follows the plan covers it.
    let follow = Run {
        xy: path.clone(),
        heading: None,
    };
    let m = evaluate(&plan, &[follow]).unwrap().metrics;
    assert_eq!(m.max_plan_distance_from_run_m, 0.0);
}

#[test]
fn non_finite_metrics_are_named() {
    let path = [[0.0, 0.0], [1e300, 0.0], [-1e300, 1e300]];
    let plan = plan_of(&path);
    let run = Run {
        xy: vec![[1e300, 1e300], [-1e300, -1e300], [1e300, -1e300]],
        heading: None,
    };
    let m = evaluate(&plan, &[run]).unwrap().metrics;
    match m.check_finite() {
        Err(MetricsError::NonFinite { metric, value, why }) => {
            assert!(!value.is_finite());
            assert!(
                m.values()
                    .iter()
                    .any(|(k, v)| *k == metric && v.to_bits() == value.to_bits())
            );
            assert!(why.contains("overflow"), "{why}");
        }
        other => panic!("{other:?} for {m:?}"),
    }
    let fine = evaluate(
        &plan_of(&[[0.0, 0.0], [1.0, 0.0]]),
        &[Run {
            xy: vec![[0.0, 0.1], [1.0, 0.1]],
            heading: None,
        }],
    )
    .unwrap()
    .metrics;
    assert_eq!(fine.check_finite(), Ok(()));
}

/// A slowly opening spiral of 700 vertices (the chunked-query tests' smooth path).
fn spiral700() -> Vec<[f64; 2]> {
    (0..700)
        .map(|k| {
            let a = k as f64 * 0.05;
            [a.cos() * (1.0 + 0.01 * a), a.sin()]
        })
        .collect()
}

#[test]
fn parallel_chunks_of_queries_equal_the_exhaustive_scan() {
    // More points than one chunk, so several chunks run, each with its own hints.
    let path = spiral700();
    let points: Vec<[f64; 2]> = (0..3 * QUERY_CHUNK + 17)
        .map(|k| {
            let a = k as f64 * 0.0029;
            [1.1 * a.cos(), 0.9 * a.sin() + 0.001 * (k % 7) as f64]
        })
        .collect();
    let got = nearest_all(&PathIndex::new(&path), &points);
    assert_eq!(got.len(), points.len());
    for (p, (d, _)) in points.iter().zip(got) {
        assert_eq!(d.to_bits(), distance_to_path(*p, &path).to_bits());
    }
}

#[test]
fn the_parallel_farthest_distance_equals_the_exhaustive_one() {
    // More points than one chunk (each chunk starts its largest distance at 0), a noisy
    // dense polyline against a smooth one and back, and a non-finite point.
    let smooth = spiral700();
    let mut noisy: Vec<[f64; 2]> = (0..3 * QUERY_CHUNK + 17)
        .map(|k| {
            let a = k as f64 * 0.0085;
            let e = ((k * 7919) % 101) as f64 / 101.0 - 0.5;
            [
                (1.0 + 0.02 * e) * a.cos() * (1.0 + 0.01 * a),
                a.sin() + 0.02 * e,
            ]
        })
        .collect();
    let brute = |points: &[[f64; 2]], path: &[[f64; 2]]| {
        points
            .iter()
            .map(|&q| distance_to_path(q, path))
            .fold(0.0, f64::max)
    };
    let got = max_distance(&PathIndex::new(&smooth), &noisy);
    assert_eq!(got.to_bits(), brute(&noisy, &smooth).to_bits());
    let got = max_distance(&PathIndex::new(&noisy), &smooth);
    assert_eq!(got.to_bits(), brute(&smooth, &noisy).to_bits());
    assert!(got > 0.0);
    noisy[QUERY_CHUNK + 5] = [f64::NAN, 0.0];
    let got = max_distance(&PathIndex::new(&smooth), &noisy);
    assert_eq!(got.to_bits(), brute(&noisy, &smooth).to_bits());
    noisy[2 * QUERY_CHUNK] = [f64::INFINITY, 1.0];
    let got = max_distance(&PathIndex::new(&smooth), &noisy);
    assert_eq!(got.to_bits(), brute(&noisy, &smooth).to_bits());
}

#[test]
fn runs_off_the_plan_grid_are_refused() {
    let plan = plan_of(&[[0.0, 0.0], [1.0, 0.0]]);
    let short = Run {
        xy: vec![[0.0, 0.0]],
        heading: None,
    };
    assert_eq!(
        evaluate(&plan, &[short]),
        Err(MetricsError::Length {
            run: 0,
            len: 1,
            samples: 2
        })
    );
}
