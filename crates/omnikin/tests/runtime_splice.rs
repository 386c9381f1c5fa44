//! Splicing a running plan (`Command::PlanSplice`): the replacement of a plan's future,
//! uploaded into the buffer's free part while the plan runs, takes over at its first point's
//! time without a stop; a late, discontinuous or too large splice is refused and the old plan
//! goes on. The runtime drives an ideal board (motors turn exactly as commanded).

use omnikin::runtime::hal::{EncoderAngles, Encoders, Imu, ImuSample, MotorCommand, MotorOutputs};
use omnikin::runtime::{
    Command, CommandError, Config, Mode, PlanPoint, Runtime, Status, plan_reference,
};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{MAX_WHEELS, Pose2, Robot, Twist2};

/// The ideal board: encoders read what the motors turned.
#[derive(Default)]
struct Board {
    wheel: [f64; MAX_WHEELS],
}

impl Encoders<f64> for Board {
    type Error = &'static str;
    fn read(&mut self) -> Result<EncoderAngles<f64>, Self::Error> {
        Ok(EncoderAngles {
            wheel: self.wheel,
            steer: [0.0; MAX_WHEELS],
        })
    }
}
impl Imu<f64> for Board {
    type Error = &'static str;
    fn read(&mut self) -> Result<Option<ImuSample<f64>>, Self::Error> {
        Ok(None)
    }
}
impl MotorOutputs<f64> for Board {
    type Error = &'static str;
    fn set_rates(&mut self, _: &MotorCommand<f64>) -> Result<(), Self::Error> {
        Ok(())
    }
}

const DT: f64 = 0.01;
const DT_US: u64 = 10_000;
/// Plan sample period, s.
const STEP: f64 = 0.05;
/// A buffer of 128 points: plan A (81 points) and a 51-point splice wrap around its end.
const CAP: usize = 128;

struct Rig {
    rt: Runtime<f64, CAP>,
    board: Board,
    now: u64,
    log: Vec<Status<f64>>,
}

impl Rig {
    fn new() -> Self {
        let robot = Robot::Sphere(SphereOmni::new(SphereParams::preset()).unwrap());
        Self {
            rt: Runtime::new(robot, Config::new(100.0), Pose2::default()).unwrap(),
            board: Board::default(),
            now: 0,
            log: vec![],
        }
    }
    fn cmd(&mut self, c: Command<'_, f64>) -> Result<(), CommandError> {
        self.rt.handle(c, self.now)
    }
    /// One cycle with a heartbeat, then the ideal plant turns the wheels for DT.
    fn step(&mut self) -> Status<f64> {
        self.cmd(Command::Heartbeat).unwrap();
        self.rt.cycle(
            self.now,
            &mut self.board,
            &mut Board::default(),
            &mut Board::default(),
        );
        let st = self.rt.status();
        for i in 0..MAX_WHEELS {
            self.board.wheel[i] += st.motors.wheel[i] * DT;
        }
        self.now += DT_US;
        self.log.push(st);
        st
    }
    /// Cycles until the plan time reaches `t` (s).
    fn run_to(&mut self, t: f64) {
        while self.rt.status().plan_time < t - 1e-9 {
            self.step();
        }
    }
    /// Cycles until the runtime is idle again (at most 10 s).
    fn run_out(&mut self) {
        for _ in 0..1000 {
            if self.step().mode == Mode::Idle {
                return;
            }
        }
        panic!("the robot did not come to rest");
    }
    /// `PlanBegin` or `PlanSplice` of `pts`, its chunks of 8 points, and its start.
    fn upload(
        &mut self,
        id: u16,
        pts: &[PlanPoint<f64>],
        splice: bool,
    ) -> Result<(), CommandError> {
        let len = pts.len() as u16;
        self.upload_with(
            if splice {
                Command::PlanSplice { id, len }
            } else {
                Command::PlanBegin { id, len }
            },
            id,
            pts,
        )
    }
    /// `begin` (a begin or splice of `pts` as plan `id`), its chunks of 8 points, and its start.
    fn upload_with(
        &mut self,
        begin: Command<'_, f64>,
        id: u16,
        pts: &[PlanPoint<f64>],
    ) -> Result<(), CommandError> {
        self.cmd(begin)?;
        for (k, c) in pts.chunks(8).enumerate() {
            self.cmd(Command::PlanChunk {
                id,
                offset: (k * 8) as u16,
                points: c,
            })?;
        }
        self.cmd(Command::PlanStart { id })
    }
}

/// Samples the robot-frame twist `twist(t)` from `t0` to `t1` every [`STEP`] from `pose`, the
/// poses integrated exactly (fine sub-steps), velocities in the world frame.
fn sample(
    twist: impl Fn(f64) -> Twist2<f64>,
    t0: f64,
    t1: f64,
    pose: Pose2<f64>,
) -> Vec<PlanPoint<f64>> {
    let n = ((t1 - t0) / STEP).round() as usize;
    let mut pose = pose;
    let mut pts = vec![];
    for k in 0..=n {
        let t = t0 + k as f64 * STEP;
        pts.push(PlanPoint {
            t,
            pose,
            twist: twist(t).to_world(pose.heading),
        });
        let h = STEP / 100.0;
        for j in 0..100 {
            pose = omnikin::se2::integrate(pose, twist(t + (j as f64 + 0.5) * h), h);
        }
    }
    pts
}

/// Plan A: 4 s rest to rest (sin² speed profile), 0.15 m/s forward and 0.4 rad/s at its peak
/// (t = 2 s), 81 points.
fn plan_a() -> Vec<PlanPoint<f64>> {
    let twist = |t: f64| {
        let s = (core::f64::consts::PI * t / 4.0).sin();
        Twist2::new(0.15 * s * s, 0.02 * s, 0.4 * s * s)
    };
    sample(twist, 0.0, 4.0, Pose2::default())
}

/// A replacement of A's future from its point at `t_s` (A's peak: the same twist there, the
/// same zero acceleration) to rest at `t_s + 2.5` s, bending left: a sideways bump of
/// 0.1 m/s peak. 51 points.
fn splice_b(a: &[PlanPoint<f64>], t_s: f64) -> Vec<PlanPoint<f64>> {
    let k = (t_s / STEP).round() as usize;
    assert!((a[k].t - t_s).abs() < 1e-9 && (t_s - 2.0).abs() < 1e-9);
    let twist = |t: f64| {
        let u = core::f64::consts::PI * (t - t_s);
        let c = (core::f64::consts::FRAC_PI_2 + u / 5.0).sin();
        let bump = (u / 2.5).sin();
        Twist2::new(0.15 * c * c, 0.02 * c + 0.1 * bump * bump, 0.4 * c * c)
    };
    sample(twist, t_s, t_s + 2.5, a[k].pose)
}

/// Largest change of the world velocity between consecutive points, per second: the plan's
/// own acceleration.
fn plan_accel(pts: &[PlanPoint<f64>]) -> f64 {
    pts.windows(2)
        .map(|w| {
            let (a, b) = (w[0].twist, w[1].twist);
            (b.vx - a.vx).hypot(b.vy - a.vy) / (w[1].t - w[0].t)
        })
        .fold(0.0, f64::max)
}

fn dist(a: Pose2<f64>, b: Pose2<f64>) -> f64 {
    (a.x - b.x).hypot(a.y - b.y)
}

#[test]
fn a_splice_takes_over_mid_plan_without_a_stop_or_a_velocity_jump() {
    let a = plan_a();
    let b = splice_b(&a, 2.0);
    let mut rig = Rig::new();
    rig.upload(1, &a, false).unwrap();
    // At 1 s A is at its point 20: 128 − (81 − 20) = 67 free slots for B's 51 (B wraps around
    // the ring's end into A's first points, already passed).
    rig.run_to(1.0);
    rig.upload(2, &b, true).unwrap();
    assert_eq!(rig.rt.status().plan.id, 2);
    // A late copy of the splice's begin neither clears nor disarms it.
    rig.cmd(Command::PlanSplice { id: 2, len: 51 }).unwrap();
    rig.run_out();
    // Never stopped before B's end: trajectory mode all the way to B's last time.
    let end = rig
        .log
        .iter()
        .position(|s| s.mode != Mode::Trajectory)
        .unwrap();
    assert!(
        rig.log[end - 1].plan_time >= b[b.len() - 1].t - DT - 1e-9,
        "left trajectory mode at plan time {}",
        rig.log[end - 1].plan_time
    );
    // It went B's way: B's end, 0.125 m left of A's.
    let last = rig.log.last().unwrap();
    assert!(
        dist(last.pose, b[b.len() - 1].pose) < 2e-3,
        "{:?}",
        last.pose
    );
    assert!(dist(a[a.len() - 1].pose, b[b.len() - 1].pose) > 0.1);
    // No jump: the reference moves by at most the plans' top speed per cycle, the body
    // velocity changes by at most the plans' own acceleration (1 % for the sampling).
    let top = a
        .iter()
        .chain(&b)
        .map(|p| p.twist.vx.hypot(p.twist.vy))
        .fold(0.0, f64::max);
    let acc = plan_accel(&a).max(plan_accel(&b));
    for w in rig.log[..end].windows(2) {
        let step = dist(w[0].reference, w[1].reference);
        assert!(
            step <= top * DT * 1.01,
            "reference step {step} at {}",
            w[1].plan_time
        );
        let (c0, c1) = (w[0].command, w[1].command);
        let dv = (c1.vx - c0.vx).hypot(c1.vy - c0.vy) / DT;
        assert!(
            dv <= acc * 1.01 + 0.02,
            "velocity change {dv} m/s² at {}",
            w[1].plan_time
        );
    }
    // The ideal plant tracks both plans closely (a jump would show as a tracking error).
    let worst = rig
        .log
        .iter()
        .map(|s| dist(s.pose, s.reference))
        .fold(0.0, f64::max);
    assert!(worst < 2e-3, "tracking error {worst} m");
}

#[test]
fn a_late_splice_is_refused_and_the_old_plan_goes_on() {
    let a = plan_a();
    let b = splice_b(&a, 2.0);
    let mut rig = Rig::new();
    rig.upload(1, &a, false).unwrap();
    rig.run_to(2.2);
    match rig.upload(2, &b, true) {
        Err(CommandError::SpliceOutside { at, now, end }) => {
            assert_eq!((at, end), (2.0, 4.0));
            assert!(now > 2.0, "{now}");
        }
        other => panic!("{other:?}"),
    }
    rig.run_out();
    let last = rig.log.last().unwrap();
    assert!(
        dist(last.pose, a[a.len() - 1].pose) < 2e-3,
        "{:?}",
        last.pose
    );
    assert!(
        !rig.log
            .iter()
            .any(|s| s.mode == Mode::Stopping && s.plan_time < 4.0 - DT)
    );
}

#[test]
fn a_splice_off_the_running_plan_is_refused_and_the_old_plan_goes_on() {
    let a = plan_a();
    let mut b = splice_b(&a, 2.0);
    // 2 mm sideways at its start: beyond the 1e-3 of the f32 wire's rounding.
    for p in &mut b {
        p.pose.y += 2e-3;
    }
    let mut rig = Rig::new();
    rig.upload(1, &a, false).unwrap();
    rig.run_to(1.0);
    match rig.upload(2, &b, true) {
        Err(CommandError::OverLimit {
            field: "splice.y_jump",
            value,
            limit,
        }) => assert!(
            (value - 2e-3).abs() < 1e-9 && limit == 1e-3,
            "{value} {limit}"
        ),
        other => panic!("{other:?}"),
    }
    b[0].pose.y -= 2e-3;
    b[0].twist.vx += 0.01;
    let e = rig.upload(3, &b, true);
    assert!(
        matches!(
            e,
            Err(CommandError::OverLimit {
                field: "splice.vx_jump",
                ..
            })
        ),
        "{e:?}"
    );
    rig.run_out();
    let last = rig.log.last().unwrap();
    assert!(
        dist(last.pose, a[a.len() - 1].pose) < 2e-3,
        "{:?}",
        last.pose
    );
}

#[test]
fn a_splice_that_would_overflow_the_buffer_is_refused_and_the_old_plan_goes_on() {
    let a = plan_a();
    let b = splice_b(&a, 2.0);
    let mut rig = Rig::new();
    // No plan running: nothing to splice into; the running plan's id is not a splice's.
    assert_eq!(
        rig.cmd(Command::PlanSplice { id: 9, len: 2 }),
        Err(CommandError::NothingToSplice)
    );
    rig.upload(1, &a, false).unwrap();
    assert!(matches!(
        rig.cmd(Command::PlanSplice { id: 1, len: 51 }),
        Err(CommandError::OutOfRange {
            field: "splice.id",
            ..
        })
    ));
    // At 0.2 s A is at its point 4: 128 − (81 − 4) = 51 free slots; at 0.1 s only 49.
    rig.run_to(0.1);
    let free = CAP - (a.len() - 2);
    assert_eq!(
        rig.upload(2, &b, true),
        Err(CommandError::SpliceNoRoom { len: 51, free })
    );
    assert_eq!(rig.rt.mode(), Mode::Trajectory);
    rig.run_out();
    let last = rig.log.last().unwrap();
    assert!(
        dist(last.pose, a[a.len() - 1].pose) < 2e-3,
        "{:?}",
        last.pose
    );
}

/// An operator's splice between two of the running plan's points: its first point from
/// `plan_reference` (the runtime's own interpolation), the rest B's curve from there.
#[test]
fn a_splice_between_plan_points_starts_on_the_plan_reference() {
    let a = plan_a();
    let t_s = 2.025;
    let (pose, twist) = plan_reference(&a, t_s).unwrap();
    let mut b = splice_b(&a, 2.0);
    for p in &mut b {
        p.t += t_s - 2.0;
        p.pose.x += pose.x - a[40].pose.x;
        p.pose.y += pose.y - a[40].pose.y;
        p.pose.heading += pose.heading - a[40].pose.heading;
    }
    b[0] = PlanPoint {
        t: t_s,
        pose,
        twist,
    };
    let mut rig = Rig::new();
    rig.upload(1, &a, false).unwrap();
    rig.run_to(1.0);
    rig.upload(2, &b, true).unwrap();
    rig.run_out();
    let last = rig.log.last().unwrap();
    assert!(
        dist(last.pose, b[b.len() - 1].pose) < 2e-3,
        "{:?}",
        last.pose
    );
    // The nearest sample instead (A's point at 2.0 s, 3.7 mm behind): refused.
    let mut rig = Rig::new();
    rig.upload(1, &a, false).unwrap();
    rig.run_to(1.0);
    b[0].pose = a[40].pose;
    let e = rig.upload(3, &b, true);
    assert!(
        matches!(
            e,
            Err(CommandError::OverLimit {
                field: "splice.x_jump",
                ..
            })
        ),
        "{e:?}"
    );
}

/// After a drift — here the estimate set 6 cm to the side of the reference at 1.9 s, as a fix
/// would move it — a splice planned from where the robot is (`PlanSpliceRebased`: B moved by
/// the error seen when it was asked for) is taken at 2.0 s without a stop: the tracking error
/// is zero at the switch, the offset left by the prediction (the position loop closed part of
/// the gap meanwhile) fades out no faster than `max_correction`, and the robot ends at the
/// moved B's end. The same points as a plain splice are refused (off the reference), and a
/// re-based splice whose heading jumps is refused too.
#[test]
fn a_rebased_splice_starts_where_the_robot_is_with_zero_tracking_error_at_the_switch() {
    let a = plan_a();
    let mut rig = Rig::new();
    rig.upload(1, &a, false).unwrap();
    rig.run_to(1.9);
    let st = rig.rt.status();
    rig.cmd(Command::SetPose(Pose2::new(
        st.pose.x,
        st.pose.y + 0.06,
        st.pose.heading,
    )))
    .unwrap();
    rig.step();
    let st = rig.rt.status();
    let e = [st.pose.x - st.reference.x, st.pose.y - st.reference.y];
    assert!((e[1] - 0.06).abs() < 0.01, "{e:?}");
    let mut b = splice_b(&a, 2.0);
    for p in &mut b {
        p.pose.x += e[0];
        p.pose.y += e[1];
    }
    let plain = rig.upload(2, &b, true);
    assert!(
        matches!(
            plain,
            Err(CommandError::OverLimit {
                field: "splice.y_jump",
                ..
            })
        ),
        "{plain:?}"
    );
    let mut turned = b.clone();
    turned[0].pose.heading += 0.01;
    let len = b.len() as u16;
    let e3 = rig.upload_with(Command::PlanSpliceRebased { id: 3, len }, 3, &turned);
    assert!(
        matches!(
            e3,
            Err(CommandError::OverLimit {
                field: "splice.heading_jump",
                ..
            })
        ),
        "{e3:?}"
    );
    rig.upload_with(Command::PlanSpliceRebased { id: 4, len }, 4, &b)
        .unwrap();
    let from = rig.log.len();
    rig.run_out();
    let log = &rig.log[from..];
    let switch = log.iter().position(|s| s.plan_time >= 2.0 - 1e-9).unwrap();
    let before = &log[switch - 1];
    let at = &log[switch];
    assert!(
        dist(before.pose, before.reference) > 0.03,
        "the drift was still there before the switch: {}",
        dist(before.pose, before.reference)
    );
    assert!(
        dist(at.pose, at.reference) < 1e-9,
        "tracking error at the switch {}",
        dist(at.pose, at.reference)
    );
    // The position loop stops pulling towards A (its correction, at most `max_correction`,
    // goes), the fade's velocity comes in (at most `max_correction`), B's own change: the
    // command moves by no more than that in the cycle.
    let mc = Config::<f64>::new(100.0).max_correction;
    let acc = plan_accel(&a).max(plan_accel(&b));
    let (c0, c1) = (before.command, at.command);
    let dv = (c1.vx - c0.vx).hypot(c1.vy - c0.vy);
    assert!(dv <= 2.0 * mc + acc * DT * 1.01, "command step {dv} m/s");
    // Never stopped: trajectory mode to B's end, the body speed never below B's speed less
    // `max_correction` around the switch.
    let end = log.iter().position(|s| s.mode != Mode::Trajectory).unwrap();
    assert!(log[end - 1].plan_time >= b[b.len() - 1].t - DT - 1e-9);
    for s in &log[switch.saturating_sub(10)..switch + 50] {
        let (_, twist) = plan_reference(&b, s.plan_time.max(2.0)).unwrap();
        let v = s.command.vx.hypot(s.command.vy);
        assert!(
            v >= twist.vx.hypot(twist.vy) - 2.0 * mc,
            "speed {v} m/s at {}",
            s.plan_time
        );
    }
    // Tracking stays tight after the switch — within the lag the slew leaves while the body
    // sheds the pull towards A at its acceleration limit (`Δv²/(2a)`), and the 2 mm of a
    // plain splice — and the robot ends at the moved B's end.
    let slew = Config::<f64>::new(100.0).slew.accel;
    // The body's velocity before the switch (B's plus the pull towards A) against B's at the
    // switch: the target's step the slew sheds.
    let (_, vb) = plan_reference(&b, 2.0).unwrap();
    let shed = (before.command.vx - vb.vx).hypot(before.command.vy - vb.vy);
    let worst = log[switch..]
        .iter()
        .map(|s| dist(s.pose, s.reference))
        .fold(0.0, f64::max);
    assert!(
        worst < shed * shed / (2.0 * slew) + 2e-3,
        "tracking error after the switch {worst} m (velocity shed {shed} m/s)"
    );
    let last = log.last().unwrap();
    assert!(
        dist(last.pose, b[b.len() - 1].pose) < 2e-3,
        "ended at {:?}, B's end {:?}",
        last.pose,
        b[b.len() - 1].pose
    );
    // The offset the re-base took: what the position loop closed between the ask and the
    // switch (under 10 cm/s for 0.1 s).
    let o = dist(at.reference, plan_reference(&b, at.plan_time).unwrap().0);
    eprintln!(
        "drift {:.4} m before the switch, re-base offset {o:.4} m, command step {dv:.4} m/s, \
         tracking error after {worst:.2e} m",
        dist(before.pose, before.reference)
    );
    assert!(o > 0.0 && o <= mc * 0.1 + 1e-3, "offset {o} m");
}
