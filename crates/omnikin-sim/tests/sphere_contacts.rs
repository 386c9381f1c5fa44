//! The sphere model's roller–shell contacts (`omnikin_sim::dynamics::sphere`): normal forces
//! from the platform's Newton equation, rollers that slide at `μ N`, and the energy balance
//! with friction on. Expected values come from the parameters and the geometry, not from a
//! recorded run.

use omnikin::Twist2;
use omnikin_sim::dynamics::sphere::{SphereDynamics, SphereSim, SphereStep};

/// Wheel rates for a platform-frame twist `(v, 0, ψ̇)` with `Ω3 = 0` (paper 000 eq. 5.7).
fn rates(sim: &SphereSim, v: f64, yaw_rate: f64) -> [f64; 3] {
    sim.kinematics()
        .wheel_rates(Twist2::new(v, 0.0, yaw_rate), 0.0)
        .unwrap()
}

/// The roller force `f_i = τ_i (R − R_i)/(R κ_i)`, N, from a reported motor torque.
fn roller_force(p: &SphereDynamics, sim: &SphereSim, st: &SphereStep, i: usize) -> f64 {
    let r = p.geometry.shell_radius;
    let rw = p.geometry.wheel_radius[i];
    let kappa = rw / r * sim.kinematics().s_dot_n()[i];
    st.wheel_torques[i] / kappa * (r - rw) / r
}

#[test]
fn at_rest_each_wheel_carries_a_third_of_the_platform_weight_plus_the_preload() {
    // Σ N_i p̂_i = −m_p g γ with the three contacts at the same depth: the contact direction
    // from the shell centre makes the angle δ (the wheel-axis tilt) with the downward
    // vertical, so N = m_p g / (3 cos δ).
    for preload in [0.0, 2.5] {
        let mut p = SphereDynamics::paper_000();
        p.roller_preload = preload;
        let mut sim = SphereSim::new(p).unwrap();
        let st = sim.step(0.01, [0.0; 3]).unwrap();
        let expected = p.platform_mass * p.gravity / (3.0 * p.geometry.tilt.cos()) + preload;
        for n in st.normal_forces {
            assert!((n - expected).abs() < 1e-9 * expected, "{n} vs {expected}");
        }
        assert!(st.roller_slip.iter().all(|&b| !b) && st.lift_off.iter().all(|&b| !b));
    }
}

/// Drives the robot forward with a wheel acceleration growing linearly in time (so the roller
/// forces grow smoothly past any limit) and returns the steps.
fn growing_push(p: SphereDynamics, steps: usize) -> (SphereSim, Vec<SphereStep>) {
    let mut sim = SphereSim::new(p).unwrap();
    let dir = rates(&sim, 1.0, 0.0);
    let dt = 0.005;
    let jerk = 40.0; // m/s³ of the commanded forward speed
    let mut out = Vec::new();
    for k in 1..=steps {
        let t = k as f64 * dt;
        let v = 0.5 * jerk * t * t;
        let cmd = dir.map(|w| w * v);
        out.push(sim.step(dt, cmd).unwrap());
    }
    (sim, out)
}

#[test]
fn a_roller_starts_to_slide_where_its_force_reaches_mu_n() {
    let p = SphereDynamics::paper_000();
    assert!(p.roller_friction.is_finite());
    // The same push with rigid contacts: the first step at which some roller's force exceeds
    // μ N is where the sliding model must begin to slide (the motors' pull-out torque, 0.3 N·m,
    // is above μ N's torque for the preset, so the contact gives first).
    let rigid = p.rigid_contacts();
    let (rsim, rsteps) = growing_push(rigid, 80);
    let over = |st: &SphereStep| {
        (0..3).any(|i| {
            roller_force(&rigid, &rsim, st, i).abs() > p.roller_friction * st.normal_forces[i]
        })
    };
    let k_limit = rsteps.iter().position(over).expect("the push passes μ N");
    assert!(rsteps.iter().all(|s| s.roller_slip.iter().all(|&b| !b)));
    let (sim, steps) = growing_push(p, 80);
    let k_slip = steps
        .iter()
        .position(|s| s.roller_slip.iter().any(|&b| b))
        .expect("a roller slides");
    eprintln!(
        "rigid contacts pass μN at step {k_limit}; the sliding model slides at step {k_slip}; \
         events {:?}",
        sim.contact_events()
    );
    // The sub-step that crosses the limit lies inside the rigid run's first step over it.
    assert!(
        k_slip == k_limit || k_slip + 1 == k_limit,
        "{k_slip} vs {k_limit}"
    );
    // Before it the two runs are the same motion; after it the sliding roller's force stays
    // at the friction law's bound μ N (+ the viscous part, which the slip keeps small).
    for st in &steps[..k_slip] {
        assert!(st.sliding.iter().all(|&b| !b));
    }
    let st = &steps[k_slip + 1];
    for i in 0..3 {
        if st.sliding[i] {
            let f = roller_force(&p, &sim, st, i).abs();
            let bound = p.roller_friction * st.normal_forces[i];
            assert!(
                f <= bound * 1.05 + 0.05,
                "wheel {i}: {f} N over μN = {bound} N"
            );
        }
    }
    assert!(sim.contact_events().roller_slips.iter().sum::<u64>() >= 1);
}

#[test]
fn energy_lost_equals_the_work_of_the_contact_and_floor_forces_step_by_step() {
    // A full-speed start and a hard stop with sliding rollers, pivot friction and rolling
    // resistance: per step the change of mechanical energy equals the work the wheel forces
    // and the floor torque did. At a 1 ms sub-step: the check compares the RK4 quadrature of
    // the work with the state's, which agree to the truncation error.
    let mut p = SphereDynamics::paper_000();
    p.max_substep = 1e-3;
    let mut sim = SphereSim::new(p).unwrap();
    let go = rates(&sim, 0.4, 2.0);
    let dt = 0.01;
    let mut lost = 0.0;
    let mut worst = 0.0f64;
    let mut min_normal = f64::INFINITY;
    for k in 0..300 {
        let cmd = if k < 150 { go } else { [0.0; 3] };
        let e0 = sim.energy();
        let st = sim.step(dt, cmd).unwrap();
        let de = sim.energy() - e0;
        let work = st.contact_work + st.floor_work;
        let scale = st.contact_work.abs() + st.floor_work.abs() + 1e-9;
        let rel = (de - work).abs() / scale;
        if rel > 1e-6 {
            eprintln!(
                "k {k}: de {de:.3e} work {work:.3e} ({:.3e} + {:.3e}) rel {rel:.2e} sliding {:?} lifted {:?} slip {:?} lift {:?} pull {:?} n {:?}",
                st.contact_work,
                st.floor_work,
                st.sliding,
                st.lifted,
                st.roller_slip,
                st.lift_off,
                st.pull_out,
                st.min_normal
            );
        }
        worst = worst.max(rel);
        lost -= st.floor_work.min(0.0);
        min_normal = st.min_normal.iter().cloned().fold(min_normal, f64::min);
    }
    let ev = sim.contact_events();
    eprintln!(
        "energy balance: worst relative mismatch {worst:.2e}, floor loss {lost:.4} J, {ev:?}"
    );
    assert!(
        ev.roller_slips.iter().sum::<u64>() > 0,
        "the test needs sliding rollers"
    );
    assert!(lost > 0.0);
    // The contact never pulls: a wheel whose normal force would go negative lifted instead.
    assert!(min_normal >= 0.0, "normal force {min_normal} N");
    assert!(worst < 1e-6, "worst relative mismatch {worst}");
}

/// A full-speed 0.4 m/s start (turning at 2 rad/s) held for 1.5 s, then a hard stop, on a
/// floor of friction coefficient `mu_floor`; returns the run's steps with the energy change of
/// each.
fn hard_start_and_stop(mu_floor: f64) -> (SphereSim, Vec<(SphereStep, f64)>) {
    let mut p = SphereDynamics::paper_000();
    p.floor_friction = mu_floor;
    // The energy balance compares RK4 quadratures, a truncation-limited check: at 1 ms.
    p.max_substep = 1e-3;
    let mut sim = SphereSim::new(p).unwrap();
    let go = rates(&sim, 0.4, 2.0);
    let mut out = Vec::new();
    for k in 0..300 {
        let cmd = if k < 150 { go } else { [0.0; 3] };
        let e0 = sim.energy();
        let st = sim.step(0.01, cmd).unwrap();
        out.push((st, sim.energy() - e0));
    }
    (sim, out)
}

#[test]
fn the_shell_slides_on_the_floor_past_its_friction_cone() {
    // A floor of μ_f = 0.05 cannot carry the hard start's horizontal force (the same run on
    // a floor the shell cannot slide on needs more): the shell slides, the floor's force stays
    // on the cone |F_h| = μ_f F_z while it does, the contact point moves, and it rolls again.
    let mu_f = 0.05;
    let (_, rigid) = hard_start_and_stop(f64::INFINITY);
    let needed = rigid.iter().map(|(s, _)| s.floor_ratio).fold(0.0, f64::max);
    assert!(needed > 2.0 * mu_f, "the rolling run needs only {needed}");
    assert!(rigid.iter().all(|(s, _)| !s.floor_slip && !s.floor_sliding));
    let (sim, steps) = hard_start_and_stop(mu_f);
    let ev = sim.contact_events();
    let first = steps
        .iter()
        .position(|(s, _)| s.floor_slip)
        .expect("the shell slides");
    let sliding = steps.iter().filter(|(s, _)| s.floor_sliding).count();
    let slide_loss: f64 = steps.iter().map(|(s, _)| s.floor_slide_work).sum();
    let worst_ratio = steps.iter().map(|(s, _)| s.floor_ratio).fold(0.0, f64::max);
    eprintln!(
        "rolling needs μ {needed:.3}; on μ_f {mu_f}: first slide in step {first}, {} slides, \
         {sliding} steps end sliding, slide loss {slide_loss:.4} J, largest |F_h|/F_z {worst_ratio:.5}",
        ev.floor_slips
    );
    assert_eq!(
        first, 0,
        "the start's first step already needs more than μ_f"
    );
    assert!(ev.floor_slips >= 1 && sliding >= 1);
    // Each start counts (a step may hold more than one: slide, stick, slide again).
    assert!(ev.floor_slips >= steps.iter().filter(|(s, _)| s.floor_slip).count() as u64);
    // The floor's force never leaves the cone (to the frozen normal force's rounding).
    assert!(worst_ratio <= mu_f * (1.0 + 1e-3), "{worst_ratio}");
    // Sliding dissipates; at the end the shell rolls again.
    assert!(slide_loss > 0.0);
    assert!(!steps.last().unwrap().0.floor_sliding);
    assert!(sim.residuals().floor < 1e-12);
}

#[test]
fn energy_lost_equals_the_work_of_friction_with_the_shell_sliding_on_the_floor() {
    // As the rollers' energy test, on a floor the hard start and stop make the shell slide
    // on: each step's energy change equals the wheel forces' work plus the floor's (pivot
    // friction, rolling resistance, the sliding shell's Coulomb force, the sticking impulse)
    // to 1e-6 relative.
    let (sim, steps) = hard_start_and_stop(0.1);
    let mut worst = 0.0f64;
    for (k, (st, de)) in steps.iter().enumerate() {
        let work = st.contact_work + st.floor_work;
        let scale = st.contact_work.abs() + st.floor_work.abs() + 1e-9;
        let rel = (de - work).abs() / scale;
        if rel > 1e-6 {
            eprintln!(
                "k {k}: de {de:.3e} work {work:.3e} ({:.3e} + {:.3e}) rel {rel:.2e} floor slip {} sliding {}",
                st.contact_work, st.floor_work, st.floor_slip, st.floor_sliding
            );
        }
        worst = worst.max(rel);
    }
    let ev = sim.contact_events();
    let slide: f64 = steps.iter().map(|(s, _)| s.floor_slide_work).sum();
    let floor: f64 = steps.iter().map(|(s, _)| s.floor_work).sum();
    eprintln!(
        "floor sliding energy balance: worst relative mismatch {worst:.2e}, slide loss \
         {slide:.4} J of the floor's {floor:.4} J, {ev:?}"
    );
    assert!(ev.floor_slips > 0, "the test needs the shell to slide");
    assert!(slide > 0.0);
    assert!(worst < 1e-6, "worst relative mismatch {worst}");
}
