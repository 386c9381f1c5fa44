//! Helpers shared by the omnikin crates' tests, so that each exists once: a dev-dependency
//! only, never part of a shipped crate.
//!
//! * [`Counting`], a global allocator that counts, per thread, the allocations made and the
//!   heap bytes in use, for the tests that prove a path allocates nothing (the core's control
//!   path, the kinematics, the estimator) or keeps its memory bounded (a streamed log).
//!   Per-thread counts make a test's figure independent of the harness and of other tests
//!   running beside it.
//!
//! ```text
//! #[global_allocator]
//! static GLOBAL: omnikin_testkit::Counting = omnikin_testkit::Counting;
//!
//! let (n, _) = omnikin_testkit::allocations(|| robot.inverse(twist, &current));
//! assert_eq!(n, 0);
//! ```
//!
//! Its `tests/import_cycles.rs` checks every workspace crate's files for import cycles (the list
//! of those still to untangle may only shrink).
//!
//! The robot presets are not repeated here: tests take them from
//! `omnikin::description::PRESETS`, the one table.

mod alloc;

pub use alloc::{Counting, allocation_count, allocations, in_use};
