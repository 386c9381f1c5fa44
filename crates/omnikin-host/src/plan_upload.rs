//! The plan upload, once: the steps a plan goes through on its way to the robot (rest, the
//! pose set to the plan's start, `PlanBegin`, the chunks, `PlanStart`), the message each step
//! sends and the telemetry that confirms it. Stop-and-wait: the robot acknowledges every
//! plan message with telemetry; a lost chunk or a lost acknowledgement is simply re-sent
//! (chunks are idempotent, a chunk is sent from the count the robot confirmed).
//!
//! `omnikin drive plan` (blocking, [`crate::operator::Session::upload_plan`]) and the
//! console's relay (one step per telemetry frame, in its own loop) drive the same machine.

use omnikin::link::{CHUNK_POINTS, Message, Telemetry, WirePoint};
use omnikin::runtime::Mode;

/// A step of a plan upload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UploadStep {
    /// Bring the robot to rest first (teleop may have left it in velocity mode, which the
    /// heartbeats of the upload would keep alive).
    Halt,
    /// Set the robot's pose estimate to the plan's first pose (`--set-pose`).
    SetPose,
    /// Announce the plan (id, number of points).
    Begin,
    /// Send the points from this many on (the robot's confirmed count).
    Chunk(u16),
    /// Start the plan.
    Start,
}

impl UploadStep {
    /// The step's name in messages (`the robot did not confirm plan chunk`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Halt => "the stop before the upload",
            Self::SetPose => "set-pose",
            Self::Begin => "plan begin",
            Self::Chunk(_) => "plan chunk",
            Self::Start => "plan start",
        }
    }
}

/// What a telemetry frame did to an upload ([`PlanUpload::advance`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// The frame does not confirm the current step: keep sending its message.
    Waiting,
    /// The step was confirmed and the upload moved on; its next message is due.
    Moved {
        /// The pose estimate was just set to the plan's start (a jump on purpose).
        pose_set: bool,
    },
    /// The robot began the plan (or already finished it): the upload is over.
    Started,
}

/// A plan on its way to the robot.
#[derive(Clone, Debug)]
pub struct PlanUpload {
    id: u16,
    set_pose: bool,
    points: Vec<WirePoint>,
    step: UploadStep,
    chunks: u32,
}

impl PlanUpload {
    /// An upload of `points` (at most `u16::MAX`, at least one: [`crate::wire_plan::plan_points`])
    /// as plan `id`. `set_pose`: the estimate is set to the first point before the plan is
    /// sent. `halt_first`: the robot is brought to rest first (the console: teleop may be
    /// running; `drive` has just opened its session).
    pub fn new(id: u16, points: Vec<WirePoint>, set_pose: bool, halt_first: bool) -> Self {
        let step = if halt_first {
            UploadStep::Halt
        } else if set_pose {
            UploadStep::SetPose
        } else {
            UploadStep::Begin
        };
        Self {
            id,
            set_pose,
            points,
            step,
            chunks: 0,
        }
    }

    /// The plan's id on the wire.
    pub fn id(&self) -> u16 {
        self.id
    }

    /// The points being sent.
    pub fn points(&self) -> &[WirePoint] {
        &self.points
    }

    /// The current step.
    pub fn step(&self) -> UploadStep {
        self.step
    }

    /// Chunk messages confirmed so far.
    pub fn chunks(&self) -> u32 {
        self.chunks
    }

    fn len(&self) -> u16 {
        self.points.len() as u16
    }

    /// The message of the current step (sent, and re-sent until telemetry confirms it).
    pub fn message(&self) -> Message {
        match self.step {
            UploadStep::Halt => Message::Stop,
            UploadStep::SetPose => {
                let p = self.points[0].pose;
                Message::SetPose {
                    x: p[0],
                    y: p[1],
                    heading: p[2],
                }
            }
            UploadStep::Begin => Message::PlanBegin {
                id: self.id,
                len: self.len(),
            },
            UploadStep::Chunk(have) => {
                let off = usize::from(have).min(self.points.len());
                let end = (off + CHUNK_POINTS).min(self.points.len());
                let mut points = omnikin::link::heapless::Vec::new();
                for p in &self.points[off..end] {
                    // At most CHUNK_POINTS by the range: never full.
                    let _ = points.push(*p);
                }
                Message::PlanChunk {
                    id: self.id,
                    offset: have,
                    points,
                }
            }
            UploadStep::Start => Message::PlanStart { id: self.id },
        }
    }

    /// The step that `t` confirms the current one for (`None`: not confirmed), or
    /// `Some(None)` when the plan has started.
    fn next(&self, t: &Telemetry) -> Option<Option<UploadStep>> {
        let n = self.len();
        match self.step {
            UploadStep::Halt => (t.mode == Mode::Idle).then_some(Some(if self.set_pose {
                UploadStep::SetPose
            } else {
                UploadStep::Begin
            })),
            UploadStep::SetPose => {
                let p = self.points[0].pose;
                let set = (t.pose[0] - p[0]).abs() < 1e-4 && (t.pose[1] - p[1]).abs() < 1e-4;
                set.then_some(Some(UploadStep::Begin))
            }
            UploadStep::Begin => {
                (t.plan.id == self.id && t.plan.len == n).then_some(Some(UploadStep::Chunk(0)))
            }
            UploadStep::Chunk(have) => {
                let got = if t.plan.id == self.id {
                    t.plan.received
                } else {
                    0
                };
                if got >= n {
                    Some(Some(UploadStep::Start))
                } else if got > have {
                    Some(Some(UploadStep::Chunk(got)))
                } else {
                    None
                }
            }
            UploadStep::Start => (t.mode == Mode::Trajectory
                || (t.plan.done && t.plan.id == self.id))
                .then_some(None),
        }
    }

    /// Whether `t` confirms the current step (without moving on).
    pub fn confirmed_by(&self, t: &Telemetry) -> bool {
        self.next(t).is_some()
    }

    /// Moves the upload on when telemetry `t` confirms its current step.
    pub fn advance(&mut self, t: &Telemetry) -> Progress {
        match self.next(t) {
            None => Progress::Waiting,
            Some(None) => Progress::Started,
            Some(Some(step)) => {
                if matches!(self.step, UploadStep::Chunk(_)) {
                    self.chunks += 1;
                }
                let pose_set = self.step == UploadStep::SetPose;
                self.step = step;
                Progress::Moved { pose_set }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use omnikin::runtime::PlanStatus;

    fn points(n: usize) -> Vec<WirePoint> {
        (0..n)
            .map(|i| WirePoint {
                t: i as f32 * 0.1,
                pose: [i as f32 * 0.01, 0.5, 0.0],
                twist: [0.1, 0.0, 0.0],
            })
            .collect()
    }

    /// A robot that does what each message asks, answering with its telemetry.
    struct Robot {
        t: Telemetry,
        /// The points received, in place.
        got: Vec<Option<WirePoint>>,
        lose_every: usize,
        seen: usize,
    }

    impl Robot {
        fn take(&mut self, m: &Message) -> Telemetry {
            self.seen += 1;
            if self.lose_every > 0 && self.seen.is_multiple_of(self.lose_every) {
                return self.t; // the message was lost: nothing changes
            }
            match m {
                Message::Stop => self.t.mode = Mode::Idle,
                Message::SetPose { x, y, heading } => self.t.pose = [*x, *y, *heading],
                Message::PlanBegin { id, len } => {
                    self.t.plan = PlanStatus {
                        id: *id,
                        len: *len,
                        ..PlanStatus::default()
                    }
                }
                Message::PlanChunk { id, offset, points } => {
                    assert!(!points.is_empty() && points.len() <= CHUNK_POINTS);
                    if *id == self.t.plan.id && *offset <= self.t.plan.received {
                        for (i, p) in points.iter().enumerate() {
                            self.got[usize::from(*offset) + i] = Some(*p);
                        }
                        self.t.plan.received = offset + points.len() as u16;
                    }
                }
                Message::PlanStart { id }
                    if *id == self.t.plan.id && self.t.plan.received == self.t.plan.len =>
                {
                    self.t.mode = Mode::Trajectory;
                }
                _ => {}
            }
            self.t
        }
    }

    fn run(n: usize, set_pose: bool, halt: bool, lose_every: usize) -> (PlanUpload, usize) {
        let mut t = crate::test_support::telemetry(0);
        t.mode = Mode::Velocity;
        let mut robot = Robot {
            t,
            got: vec![None; n],
            lose_every,
            seen: 0,
        };
        let mut up = PlanUpload::new(7, points(n), set_pose, halt);
        for sent in 1..10_000 {
            let t = robot.take(&up.message());
            if up.advance(&t) == Progress::Started {
                assert_eq!(robot.t.plan.received as usize, n);
                let got: Vec<WirePoint> = robot.got.iter().map(|p| p.unwrap()).collect();
                assert_eq!(got, points(n), "every point, in its place");
                return (up, sent);
            }
        }
        panic!("the upload never started");
    }

    #[test]
    fn every_point_arrives_and_the_plan_starts_even_when_messages_are_lost() {
        let n = 3 * CHUNK_POINTS + 5;
        let (up, sent) = run(n, true, true, 0);
        // Halt, set-pose, begin, 4 chunks, start.
        assert_eq!(sent, 8);
        assert_eq!(up.chunks(), 4);
        let (_, lossy) = run(n, true, true, 3);
        assert!(lossy > sent, "{lossy} messages with every third lost");
    }

    #[test]
    fn the_first_step_follows_the_options() {
        assert_eq!(
            PlanUpload::new(1, points(2), false, false).step(),
            UploadStep::Begin
        );
        assert_eq!(
            PlanUpload::new(1, points(2), true, false).step(),
            UploadStep::SetPose
        );
        assert_eq!(
            PlanUpload::new(1, points(2), true, true).step(),
            UploadStep::Halt
        );
        let (_, sent) = run(2, false, false, 0);
        assert_eq!(sent, 3, "begin, one chunk, start");
    }

    #[test]
    fn telemetry_of_another_plan_confirms_nothing() {
        let mut up = PlanUpload::new(9, points(4), false, false);
        let mut t = crate::test_support::telemetry(0);
        t.plan.id = 8;
        t.plan.len = 4;
        assert!(!up.confirmed_by(&t));
        assert_eq!(up.advance(&t), Progress::Waiting);
        t.plan.id = 9;
        assert_eq!(up.advance(&t), Progress::Moved { pose_set: false });
        assert_eq!(up.step(), UploadStep::Chunk(0));
        t.plan.id = 8;
        t.plan.received = 4;
        assert_eq!(up.advance(&t), Progress::Waiting, "another plan's count");
    }
}
