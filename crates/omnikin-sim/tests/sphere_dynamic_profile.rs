//! The dynamic plant in Monte Carlo (`omnikin_sim::dynamics::sphere::DynamicProfile`) and its
//! one-parameter fit: identical results for any thread count, a real scatter between trials,
//! the exact profile equal to the deterministic run, a fit that meets its target, and a second
//! value in its range that, with the depth re-fitted, reaches the paper's 0.5 m/s circle.

use omnikin::description::RobotDescription;
use omnikin_plan::generators::Circle;
use omnikin_plan::{Plan, RobotModel};
use omnikin_sim::dynamics::sphere::{
    DynamicProfile, SphereDynamics, fit_com_depth, radius_ratio, simulate_plan,
};
use omnikin_sim::metrics::tracked_reference;
use omnikin_sim::{MonteCarlo, evaluate_trials, trial_rng};

fn circle(k: f64) -> Plan {
    let d = RobotDescription::preset("sphere-omni").unwrap();
    let model = RobotModel::from_description(&d).unwrap();
    let c = Circle::paper(k);
    omnikin_plan::planner::plan(&c.path().unwrap(), &c.heading(), &model, &c.options(100.0))
        .unwrap()
        .plan
}

fn run(profile: &DynamicProfile, plan: &Plan, trials: usize, threads: usize) -> MonteCarlo {
    let reference = tracked_reference(plan, [0.0; 2]);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        evaluate_trials(
            &|i| profile.trial(plan, &mut trial_rng(7, i)),
            plan.samples.len(),
            &reference,
            trials,
            &|| {},
            |_, _| Ok::<(), ()>(()),
        )
    })
    .unwrap()
}

#[test]
fn dynamic_trials_scatter_and_do_not_depend_on_the_thread_count() {
    let plan = circle(4.0);
    let profile = DynamicProfile::hardware(SphereDynamics::paper_000());
    let one = run(&profile, &plan, 5, 1);
    let three = run(&profile, &plan, 5, 3);
    assert_eq!(one.evaluation, three.evaluation);
    let bits = |mc: &MonteCarlo| {
        mc.evaluation
            .metrics
            .values()
            .into_iter()
            .map(|(_, v)| v.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&one), bits(&three));
    assert_eq!(one.figure_runs, three.figure_runs);
    // The trials differ: the per-trial draws move the runs apart by more than the 2 mm
    // tracking noise.
    let m = &one.evaluation.metrics;
    assert!(m.max_deviation_from_mean_m > 0.01, "{m:?}");
    let (a, b) = (&one.figure_runs[0].xy, &one.figure_runs[1].xy);
    let gap = a
        .iter()
        .zip(b)
        .map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1]))
        .fold(0.0, f64::max);
    assert!(gap > 0.01, "runs 0 and 1 differ by only {gap} m");
}

#[test]
fn the_exact_profile_is_the_deterministic_run() {
    let plan = circle(4.0);
    let p = SphereDynamics::paper_000();
    let t = DynamicProfile::exact(p)
        .trial(&plan, &mut trial_rng(1, 0))
        .unwrap();
    assert_eq!(t, simulate_plan(p, &plan).unwrap().trial);
}

#[test]
fn the_fit_meets_its_target_inside_its_bracket() {
    let plan = circle(4.0);
    let base = SphereDynamics {
        pivot_friction: 0.05,
        ..SphereDynamics::paper_000()
    };
    let fit = fit_com_depth(base, &plan, "circle-0.4", 1.4).unwrap();
    assert_eq!(
        (fit.name, fit.fitted_on.as_str()),
        ("com_depth", "circle-0.4")
    );
    let (lo, hi) = omnikin_sim::dynamics::sphere::monte_carlo::COM_DEPTH_BRACKET;
    assert!(fit.value > lo && fit.value < hi, "{fit:?}");
    assert!((fit.achieved_radius_ratio - 1.4).abs() < 2e-3, "{fit:?}");
    // The reported ratio is the model's at the fitted depth, and a shallower centre of mass
    // leans more and grows the circle more.
    let at = |h: f64| {
        radius_ratio(
            SphereDynamics {
                com_depth: h,
                ..base
            },
            &plan,
        )
        .unwrap()
    };
    assert_eq!(at(fit.value), fit.achieved_radius_ratio);
    assert!(at(fit.value - 0.01) > 1.4 && at(fit.value + 0.01) < 1.4);
}

/// The prior band: the same on 1 and 3 threads, p5 ≤ p95, and its draws really vary the robot
/// (the band of the 0.4 m/s circle is wider than rounding); `samples` = 0 gives none. The
/// sensitivity table's nominal row is the deterministic run of the file's robot, and a value
/// moved to an end of its range moves a figure.
#[test]
fn prior_bands_are_thread_independent_and_the_sensitivity_table_starts_at_the_file() {
    use omnikin_sim::reproduce::{deterministic_figures, prior_band, sensitivity_markdown};
    let d = RobotDescription::preset("sphere-omni").unwrap();
    let p = SphereDynamics::from_description(&d).unwrap();
    let series = omnikin_sim::reproduce::sphere_2019_series(&d, 100.0).unwrap();
    let c4 = series.iter().find(|s| s.name == "circle-0.4").unwrap();
    let band = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| prior_band(p, c4, 6, 2019))
            .unwrap()
            .unwrap()
    };
    let b1 = band(1);
    assert_eq!(b1, band(3), "thread count");
    assert_eq!(b1.samples, 6);
    let [lo, hi] = b1.radius_ratio.expect("a circle has a ratio band");
    assert!(lo.is_finite() && hi - lo > 1e-3, "{lo} .. {hi}");
    let [dlo, dhi] = b1.max_deviation_pct_of_path;
    assert!(dlo <= dhi);
    assert_eq!(prior_band(p, c4, 0, 2019).unwrap(), None);
    let sq = series.iter().find(|s| s.name == "square-0.1").unwrap();
    assert_eq!(prior_band(p, sq, 3, 1).unwrap().unwrap().radius_ratio, None);
    // The sensitivity table on two series: the nominal row is the file's deterministic run.
    let two = [series[0].clone(), c4.clone()];
    let table = sensitivity_markdown(p, &two).unwrap();
    let (d0, _) = deterministic_figures(p, &two[0]).unwrap();
    let (d1, r1) = deterministic_figures(p, c4).unwrap();
    let nominal = format!(
        "| nominal (the file) | {d0:.2} | {d1:.2} / {:.3} |",
        r1.unwrap()
    );
    assert!(table.contains(&nominal), "{nominal}\n{table}");
    let rows: Vec<&str> = table.lines().skip(3).collect();
    assert_eq!(
        rows.len(),
        2 + 2 * omnikin_sim::dynamics::sphere::priors::PRIORS.len()
    );
    // The fitted depth at the ends of its parts range moves the fitted circle's ratio the way
    // the lean law says: a deeper centre of mass leans less.
    let ratio = |prefix: &str| -> f64 {
        let row = rows.iter().find(|r| r.starts_with(prefix)).unwrap();
        let cell = row.trim_end_matches(" |").rsplit(" | ").next().unwrap();
        cell.rsplit(" / ").next().unwrap().parse().unwrap()
    };
    assert!(ratio("| `com_depth` = 0.1 m") < r1.unwrap());
    assert!(ratio("| `com_depth` = 0.06 m") > r1.unwrap());
    let pivot_low = rows
        .iter()
        .find(|r| r.starts_with("| `pivot_friction` = 0.008"))
        .unwrap();
    assert!(!pivot_low.ends_with(&nominal[nominal.find(" | ").unwrap()..]));
}

#[test]
fn the_default_2_ms_sub_step_gives_the_1_ms_figures_of_the_eight_series() {
    // The default sub-step (2 ms, for the cost) against half of it, on paper 000's eight
    // series through the preset, deterministic: each largest deviation and radius ratio within
    // 0.5 % (0.38 % seen, square-0.4's deviation).
    let d = RobotDescription::preset("sphere-omni").unwrap();
    let p = SphereDynamics::from_description(&d).unwrap();
    assert_eq!(p.max_substep, 2e-3);
    let fine = SphereDynamics {
        max_substep: 1e-3,
        ..p
    };
    let series = omnikin_sim::reproduce::sphere_2019_series(&d, 100.0).unwrap();
    assert_eq!(series.len(), 8);
    for s in &series {
        let (dev, ratio) = omnikin_sim::reproduce::deterministic_figures(p, s).unwrap();
        let (dev1, ratio1) = omnikin_sim::reproduce::deterministic_figures(fine, s).unwrap();
        eprintln!(
            "{}: 2 ms {dev:.4} % {ratio:?}, 1 ms {dev1:.4} % {ratio1:?}",
            s.name
        );
        assert!(
            (dev - dev1).abs() <= 0.005 * dev1,
            "{}: {dev} vs {dev1}",
            s.name
        );
        if let (Some(r), Some(r1)) = (ratio, ratio1) {
            assert!((r - r1).abs() <= 0.005 * r1, "{}: {r} vs {r1}", s.name);
        }
    }
}

/// docs/sphere-dynamics.md, "The 0.5 m/s circle with one fitted parameter": on the preset the
/// deterministic 0.5 m/s circle misses the paper's 1.6 ± 10 %, but one other value inside its
/// documented range (roller μ at 0.3), with `com_depth` re-fitted to the 0.4 m/s circle's 1.4,
/// puts it inside the band with the depth inside its parts range — the statement is not a sharp
/// test (the value is not shipped: it would be a second fitted parameter).
#[test]
fn a_second_value_in_its_range_with_the_depth_refitted_reaches_the_0_5_circle() {
    use omnikin_sim::dynamics::sphere::priors::{COM_DEPTH_PARTS_RANGE, PRIORS};
    use omnikin_sim::reproduce::{deterministic_figures, fit_to_paper, sphere_2019_series};
    let d = RobotDescription::preset("sphere-omni").unwrap();
    let base = SphereDynamics::from_description(&d).unwrap();
    let series = sphere_2019_series(&d, 100.0).unwrap();
    let c5 = series.iter().find(|s| s.name == "circle-0.5").unwrap();
    let ratio5 = |p: SphereDynamics| deterministic_figures(p, c5).unwrap().1.unwrap();
    let (lo, hi) = (0.9 * 1.6, 1.1 * 1.6);
    assert!(ratio5(base) > hi, "preset: {}", ratio5(base));
    let mu = PRIORS.iter().find(|p| p.key == "roller_friction").unwrap();
    let robot = mu.set(&base, mu.low);
    let fit = fit_to_paper(robot, &series).unwrap();
    assert!((fit.achieved_radius_ratio - 1.4).abs() < 2e-3, "{fit:?}");
    let (dlo, dhi) = COM_DEPTH_PARTS_RANGE;
    assert!(fit.value > dlo && fit.value < dhi, "{fit:?}");
    let r5 = ratio5(SphereDynamics {
        com_depth: fit.value,
        ..robot
    });
    assert!(r5 > lo && r5 < hi, "roller μ {}: circle-0.5 {r5}", mu.low);
}
