//! Unit tests of the planner's internals: the heading unwrap series, the cell search, the
//! reachability step against a brute-force LP, and the time-optimal pass with stored and
//! rebuilt cell constraints.

use super::*;
use cells::{cell, cell_from};
use geometry::Hint;
use proptest::prelude::*;
use time_optimal::{CellConstraints, time_optimal_storing};

/// Brute force: the largest x ∈ [0, x_cap] for which the y-interval is non-empty, from
/// every pair of a lower and an upper bound (y ≥ 0 and y ≤ y_max included).
fn largest_start_pairwise(c: &CellConstraints, x_cap: f64, y_max: f64) -> f64 {
    let mut lower: Vec<(f64, f64)> = vec![(0.0, 0.0)];
    let mut upper: Vec<(f64, f64)> = vec![(y_max, 0.0)];
    for i in 0..c.n {
        lower.push((-c.hi[i], c.slope[i]));
        upper.push((c.hi[i], c.slope[i]));
    }
    let mut best = x_cap.min(c.x_max);
    for &(la, lb) in &lower {
        for &(ua, ub) in &upper {
            if lb - ub > 0.0 {
                best = best.min((ua - la) / (lb - ub));
            }
        }
    }
    best.max(0.0)
}

#[test]
fn heading_increment_series_is_accurate_to_rounding() {
    // Near the series' largest argument (|δ| just below 0.2 rad, |sin δ| ≈ 0.199, where the
    // first term left out, a₁₂ x²⁵, is ≈ 2e-20) and for small headings, so rounding is
    // ≈ 1e-16: the answer must be within 4e-16 of ψ + δ.
    for &psi in &[0.0, 0.3, -0.7, 1.0] {
        for &delta in &[
            0.1999, -0.1999, 0.15, 0.0999, -0.0999, 0.08, -0.05, 0.01, 1e-9,
        ] {
            let (s, c) = f64::sin_cos(psi);
            let (sd, cd) = f64::sin_cos(psi + delta);
            let got = Hint {
                psi,
                cs: Some([c, s]),
                piece: None,
            }
            .unwrap([cd, sd]);
            assert!(
                (got - (psi + delta)).abs() <= 4e-16,
                "ψ {psi} δ {delta}: {got} vs {}",
                psi + delta
            );
        }
    }
}

#[test]
fn the_linear_inverse_matches_the_core_for_every_kind_without_steering() {
    // Every preset: kinds without steering get a matrix that reproduces the core inverse
    // kinematics of world twists at any heading to 1e-13; steerable kinds get none.
    for (name, _) in omnikin::description::PRESETS {
        let robot = RobotModel::from_description(
            &omnikin::description::RobotDescription::preset(name).expect("preset"),
        )
        .expect("model");
        let m = geometry::linear_inverse(&robot);
        assert_eq!(m.is_some(), !robot.steerable(), "{name}");
        let Some(m) = m else { continue };
        for i in 0..300 {
            let x = i as f64;
            let heading = 9.0 * (0.31 * x).sin();
            let dq = [
                (1.7 * x).cos() * 2.0,
                (0.9 * x).sin(),
                3.0 * (1.3 * x).cos(),
            ];
            let (s, c) = heading.sin_cos();
            let got = m.wheel_rates([c, s], dq).expect("finite");
            let want = robot
                .model
                .inverse(
                    omnikin::Twist2::new(dq[0], dq[1], dq[2]).to_robot(heading),
                    &omnikin::Actuators::zero(),
                )
                .expect("inverse")
                .wheel_rates;
            for w in 0..omnikin::MAX_WHEELS {
                assert!(
                    (got[w] - want[w]).abs() <= 1e-13 * (1.0 + want[w].abs()),
                    "{name} wheel {w}: {} vs {}",
                    got[w],
                    want[w]
                );
            }
        }
    }
}

#[test]
fn time_optimal_timing_is_the_same_with_stored_and_rebuilt_cells() {
    let wps: Vec<[f64; 2]> = (0..8)
        .map(|k| [0.5 * k as f64, 0.4 * (0.9 * k as f64).sin()])
        .collect();
    let path = Path::spline(&wps).expect("spline");
    let heading = HeadingLaw::Tangent { offset: 0.3 };
    for name in ["sphere-omni", "caster3", "mecanum", "swerve4"] {
        let robot = RobotModel::from_description(
            &omnikin::description::RobotDescription::preset(name).expect("preset"),
        )
        .expect("model");
        let heading_cs = [0.3_f64.cos(), 0.3_f64.sin()];
        let opts = PlanOptions {
            timing: Timing::TimeOptimal {
                limits: MotionLimits {
                    max_speed: 0.6,
                    max_accel: 1.0,
                    ..MotionLimits::default()
                },
            },
            on_limit: OnLimit::Retime,
            rate: 100.0,
            initial_steer: InitialSteer::Aligned,
        };
        let ctx = Ctx {
            path: &path,
            heading: &heading,
            robot: &robot,
            heading_cs,
            set_point: robot.model.kind().steer_is_set_point(),
            grid_tol: grid::grid_tol(&opts.timing),
            grid_max: grid::grid_max(&opts.timing),
            linear: geometry::linear_inverse(&robot),
        };
        let moves = build_moves(&ctx, &opts).expect("moves");
        for mv in &moves {
            let (v, a, user) = user_limits(&robot, &opts, &mv.kind);
            let (kept, who_kept) =
                time_optimal_storing(&robot, mv, v, a, user, usize::MAX).expect("timing");
            let (rebuilt, who_rebuilt) =
                time_optimal_storing(&robot, mv, v, a, user, 0).expect("timing");
            let (MoveTiming::Grid { x: x1, t: t1 }, MoveTiming::Grid { x: x2, t: t2 }) =
                (kept, rebuilt)
            else {
                panic!("grid timings expected")
            };
            assert!(x1.len() > 16);
            assert_eq!(x1, x2, "{name}");
            assert_eq!(t1, t2, "{name}");
            assert_eq!(who_kept, who_rebuilt, "{name}");
        }
    }
}

proptest! {
    /// The forward-stepping cell search answers as the bisection does, wherever it starts.
    /// (`from` stays below the node count so that exact ties ahead of it are queried.)
    #[test]
    fn cell_from_matches_cell(
        steps in proptest::collection::vec(1e-3_f64..1.0, 1..40),
        x in prop_oneof![-1.0_f64..45.0, Just(f64::NAN), Just(f64::INFINITY)],
        from in 0usize..50,
    ) {
        let mut sig = vec![0.0];
        for h in steps {
            sig.push(sig[sig.len() - 1] + h);
        }
        // Arbitrary points, and every node ahead of the start (exact ties included).
        let nodes = (0..12).map(|j| sig[(from + j) % sig.len()]);
        for q in std::iter::once(x).chain(nodes) {
            prop_assert_eq!(cell_from(&sig, q, from), cell(&sig, q), "x {}", q);
        }
    }

    /// The heading increment between neighbouring grid nodes (series of `asin`) agrees with
    /// `atan2` to rounding, near and far from the hint, wrapped or not.
    #[test]
    fn heading_unwrap_matches_atan2(
        psi in -20.0_f64..20.0,
        delta in prop_oneof![-0.22_f64..0.22, -3.1_f64..3.1],
    ) {
        let (s, c) = psi.sin_cos();
        let hint = Hint { psi, cs: Some([c, s]), piece: None };
        let (sd, cd) = (psi + delta).sin_cos();
        let got = hint.unwrap([cd, sd]);
        let want = Hint::angle(psi).unwrap([cd, sd]);
        prop_assert!((got - want).abs() < 1e-13, "{} vs {}", got, want);
        prop_assert!((got - (psi + delta)).abs() < 1e-12, "{} vs {}", got, psi + delta);
    }

    #[test]
    fn reachability_step_matches_the_pairwise_lp(
        rows in proptest::collection::vec(
            (-50.0..50.0_f64, -50.0..50.0_f64, 0.1..100.0_f64), 1..13),
        x_cap in 0.0..20.0_f64,
        y_max in 0.0..20.0_f64,
    ) {
        let mut c = CellConstraints::new();
        for (k, &(cy, cx, bound)) in rows.iter().enumerate() {
            c.add(cy, cx, bound, k as u8);
        }
        let (x, _) = c.largest_start(x_cap, y_max);
        let want = largest_start_pairwise(&c, x_cap, y_max);
        prop_assert!((x - want).abs() <= 1e-9 * (1.0 + want), "{x} vs {want}");
        // And the forward step from there finds an admissible end value.
        let (y, _) = c.largest_end(x, y_max);
        prop_assert!(y >= 0.0 && y <= y_max * (1.0 + 1e-12) + 1e-12);
        for i in 0..c.n {
            let tol = 1e-7 * (1.0 + c.hi[i].abs() + (c.slope[i] * x).abs());
            prop_assert!(y <= c.hi[i] + c.slope[i] * x + tol, "upper {i}");
            prop_assert!(y >= -c.hi[i] + c.slope[i] * x - tol, "lower {i}");
        }
    }
}

/// A refined grid copies the nodes of the stretches it keeps ([`Ctx::refine`]) and, in the
/// stretches it refines, the old nodes the new ones fall on; it must equal the grid built
/// afresh from the kinematics on the same cells, for a robot without steering
/// and for one whose steer angles carry over from stretch to stretch (a caster; a swerve
/// move is cut at every waypoint of a spline, one stretch each).
#[test]
fn a_refined_grid_equals_one_built_afresh() {
    let w = crate::waypoints::Waypoints::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/waypoints.toml"),
    )
    .expect("examples/waypoints.toml");
    let path = Path::spline(&w.points).expect("path");
    let heading = HeadingLaw::Tangent { offset: 0.0 };
    for name in ["kiwi", "mecanum", "caster3"] {
        let robot = RobotModel::from_description(
            &omnikin::description::RobotDescription::preset(name).expect("preset"),
        )
        .expect("model");
        let opts = PlanOptions {
            timing: Timing::TimeOptimal {
                limits: MotionLimits {
                    max_speed: 2.0,
                    max_accel: 4.0,
                    ..MotionLimits::default()
                },
            },
            on_limit: OnLimit::Retime,
            rate: 100.0,
            initial_steer: InitialSteer::Aligned,
        };
        let ctx = context(&path, &heading, &robot, &opts);
        let moves = build_moves(&ctx, &opts).expect("moves");
        let mut compared = 0;
        for mv in moves.iter().filter(|m| m.cells.len() > 1) {
            // Every other stretch refined, the first kept.
            let js: Vec<usize> = (1..mv.cells.len()).step_by(2).collect();
            let Some(refined) = ctx.refine(mv, &js, 4).expect("refine") else {
                continue;
            };
            let fresh = ctx
                .grid_on(
                    mv.kind.clone(),
                    mv.len,
                    mv.psi[0],
                    mv.gamma[0],
                    refined.bounds.clone(),
                    refined.cells.clone(),
                    None,
                )
                .expect("grid");
            assert_eq!(refined.cells, fresh.cells, "{name}");
            assert_eq!(refined.sig, fresh.sig, "{name}");
            // The headings up to rounding: a refined stretch keeps the old nodes that fall on
            // its new ones (robots without steering), whose headings were unwrapped from a
            // neighbour one old cell away instead of one new cell.
            for (p, q) in refined.psi.iter().zip(&fresh.psi) {
                assert!(
                    (p - q).abs() <= 4.0 * f64::EPSILON * p.abs().max(1.0),
                    "{name}"
                );
            }
            assert_eq!(refined.psi.len(), fresh.psi.len(), "{name}");
            assert_eq!(refined.a, fresh.a, "{name}");
            assert_eq!(refined.b_in, fresh.b_in, "{name}");
            assert_eq!(refined.b_out, fresh.b_out, "{name}");
            assert_eq!(refined.piece, fresh.piece, "{name}");
            assert_eq!(
                format!("{:?}", refined.gamma),
                format!("{:?}", fresh.gamma),
                "{name}"
            );
            compared += 1;
        }
        assert!(compared > 0, "{name}: no move with stretches to refine");
    }
}

/// `A'` from the configuration's derivatives (what the between-sample check uses for robots
/// without steering) is the central difference of the exact `A` over ±1e-5, on every travel
/// move of the shipped waypoints as a spline and as a filleted polyline, under each heading
/// law, for two robots without steering.
#[test]
fn the_rate_of_a_from_the_derivatives_is_its_difference() {
    let w = crate::waypoints::Waypoints::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/waypoints.toml"),
    )
    .expect("examples/waypoints.toml");
    let profile = crate::heading::HeadingProfile::new(&[(0.0, 0.3), (0.9, -0.4), (2.2, 1.1)])
        .expect("profile");
    let opts = PlanOptions {
        timing: Timing::TimeOptimal {
            limits: MotionLimits::default(),
        },
        on_limit: OnLimit::Retime,
        rate: 100.0,
        initial_steer: InitialSteer::Aligned,
    };
    let mut compared = 0;
    let mut largest = 0.0_f64;
    for name in ["kiwi", "sphere-omni"] {
        let robot = RobotModel::from_description(
            &omnikin::description::RobotDescription::preset(name).expect("preset"),
        )
        .expect("model");
        for path in [
            Path::spline(&w.points).expect("spline"),
            Path::polyline(&w.points, crate::path::Corners::Fillet { radius: 0.15 })
                .expect("fillet"),
        ] {
            for heading in [
                HeadingLaw::Constant(0.4),
                HeadingLaw::Tangent { offset: 0.2 },
                HeadingLaw::Profile(profile.clone()),
            ] {
                let ctx = context(&path, &heading, &robot, &opts);
                for mv in build_moves(&ctx, &opts).expect("moves") {
                    for k in 0..mv.sig.len() - 1 {
                        let h = mv.sig[k + 1] - mv.sig[k];
                        let d = 1e-5_f64.min(0.02 * h);
                        for f in [0.1, 0.5, 0.9] {
                            let sigma = mv.sig[k] + f * h;
                            let (a, b) = ctx.a_and_rate_at(&mv, k, sigma, d).expect("exact");
                            let lo = ctx.a_at(&mv, k, sigma - d).expect("lo");
                            let hi = ctx.a_at(&mv, k, sigma + d).expect("hi");
                            let at = ctx.a_at(&mv, k, sigma).expect("at");
                            for ch in 0..robot.channels() {
                                let fd = (hi[ch] - lo[ch]) / (2.0 * d);
                                assert!(
                                    (a[ch] - at[ch]).abs() <= 1e-12 * (1.0 + at[ch].abs()),
                                    "{name} {heading:?}: A {} vs {} at {sigma}",
                                    a[ch],
                                    at[ch]
                                );
                                assert!(
                                    (b[ch] - fd).abs() <= 1e-5 * (1.0 + fd.abs()),
                                    "{name} {heading:?} channel {ch}: A' {} vs the difference \
                                     {fd} at {sigma} of a move of {}",
                                    b[ch],
                                    mv.len
                                );
                                largest = largest.max(fd.abs());
                            }
                            compared += 1;
                        }
                    }
                }
            }
        }
    }
    assert!(
        compared > 1000 && largest > 1.0,
        "{compared} points, largest |A'| {largest}"
    );
}
