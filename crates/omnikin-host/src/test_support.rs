//! What the crate's unit tests share.

use omnikin::link::{LinkCounters, Telemetry};
use omnikin::runtime::{Faults, Mode};

/// A three-wheel robot's telemetry at robot time `time_us`: idle, at the origin, no plan,
/// every reading zero.
pub(crate) fn telemetry(time_us: u64) -> Telemetry {
    let z = [0.0f32; omnikin::MAX_WHEELS];
    Telemetry {
        time_us,
        mode: Mode::Idle,
        faults: Faults::NONE,
        fault_history: Faults::NONE,
        pose: [0.0; 3],
        twist: [0.0; 3],
        command: [0.0; 3],
        wheels: 3,
        wheel_rates: z,
        steer_rates: z,
        wheel_angles: z,
        steer_angles: z,
        gyro: [0.0; 3],
        accel: [0.0; 3],
        plan: Default::default(),
        plan_time: 0.0,
        reference: [0.0; 3],
        slip_residual: 0.0,
        rejected: 0,
        last_command_us: 0,
        link: LinkCounters::default(),
        ack_seq: 0,
        estop_seq: 0,
        clear_seq: 0,
    }
}
