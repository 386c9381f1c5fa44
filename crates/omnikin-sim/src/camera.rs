//! A streaming overhead camera: the sensor of [`crate::sensors`]'s camera fixes, run step by
//! step beside a simulation that is still going (the closed loop, [`crate::closed_loop`]),
//! where [`crate::sensors::emit`] writes the fixes of a finished trial.
//!
//! It is a **user** of the one camera description, [`CameraProfile`] (frame period, latency,
//! position and heading noise, outliers) with [`CameraGaps`] (dropouts, a scheduled outage):
//! call [`Camera::capture`] with the truth at every step of the simulation; whenever the frame
//! clock (frames at `k · period`, k = 0, 1, …) says a frame is due, it takes one, stamped with
//! the time of the truth it saw, and queues it; [`Camera::deliver`] hands each fix over once
//! its `arrival = t + latency` has come — as paper 000's video tracking would reach a robot
//! through its link. Every frame draws the same six random numbers whatever becomes of it, so
//! one seed gives the same noise on the same frames whatever the gaps.

use std::collections::VecDeque;

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::sensors::{CameraGaps, CameraProfile, SensorProfile, SimulatedFix};

/// The camera: a checked profile, its own seeded random stream, and the fixes in flight.
#[derive(Clone, Debug)]
pub struct Camera {
    profile: CameraProfile,
    gaps: CameraGaps,
    rng: ChaCha8Rng,
    next_frame: u64,
    pending: VecDeque<SimulatedFix>,
}

impl Camera {
    /// A camera with `profile` and `gaps`, drawing its noise from `rng`.
    ///
    /// # Errors
    /// The sensor profile's check ([`SensorProfile::validate`]): the message names the key
    /// (`camera.period`, `camera_gaps.outage`, …), the value and the range.
    pub fn new(profile: CameraProfile, gaps: CameraGaps, rng: ChaCha8Rng) -> Result<Self, String> {
        SensorProfile {
            camera: Some(profile),
            camera_gaps: Some(gaps),
            ..SensorProfile::default()
        }
        .validate()?;
        Ok(Self {
            profile,
            gaps,
            rng,
            next_frame: 0,
            pending: VecDeque::new(),
        })
    }

    /// The camera's profile.
    pub fn profile(&self) -> &CameraProfile {
        &self.profile
    }

    /// Offers the truth — the tracked point `(x, y)` and the heading, world frame — at time
    /// `t`, s; takes a frame if one is due (at most one per call: offer the truth at least
    /// as often as the frame rate, or frames are skipped, as a camera faster than its
    /// caller's clock would drop them).
    pub fn capture(&mut self, t: f64, x: f64, y: f64, heading: f64) {
        let p = self.profile;
        let due = self.next_frame as f64 * p.period;
        if due > t + 1e-9 {
            return;
        }
        // The next frame after t (frames missed between calls are not taken).
        self.next_frame = ((t + 1e-9) / p.period).floor() as u64 + 1;
        let nx: f64 = StandardNormal.sample(&mut self.rng);
        let ny: f64 = StandardNormal.sample(&mut self.rng);
        let nh: f64 = StandardNormal.sample(&mut self.rng);
        let u_out: f64 = self.rng.random();
        let dir: f64 = self.rng.random_range(0.0..std::f64::consts::TAU);
        let u_drop: f64 = self.rng.random();
        if self.gaps.in_outage(t) || u_drop < self.gaps.dropout_probability {
            return;
        }
        let outlier = u_out < p.outlier_probability;
        let (ox, oy) = if outlier {
            (
                p.outlier_distance * dir.cos(),
                p.outlier_distance * dir.sin(),
            )
        } else {
            (0.0, 0.0)
        };
        self.pending.push_back(SimulatedFix {
            t,
            arrival: t + p.latency,
            x: x + p.noise_std * nx + ox,
            y: y + p.noise_std * ny + oy,
            heading: p.heading_noise_std.map(|s| heading + s * nh),
            outlier,
        });
    }

    /// The oldest fix whose arrival time is at or before `t`, if any (call until `None`).
    pub fn deliver(&mut self, t: f64) -> Option<SimulatedFix> {
        if self.pending.front().is_some_and(|f| f.arrival <= t + 1e-9) {
            self.pending.pop_front()
        } else {
            None
        }
    }
}
