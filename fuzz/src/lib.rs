//! Fuzz harnesses for every omnikin decoder, shared by the targets in `fuzz_targets/` and the
//! seed generator `gen_corpus`: the counting allocator ([`alloc`]), the link fix-up harness
//! ([`link`]), the file parsers ([`text`]), `omnikin convert`'s MCAP pre-scan ([`mcap`]), the ROS 2 CDR messages ([`ros2`]) and the seed corpora ([`seeds`]).

pub mod alloc;
pub mod link;
pub mod mcap;
pub mod ros2;
pub mod seeds;
pub mod text;

/// The telemetry schema the MCAP `/link` encoder and decoder ([`mcap::foxglove`],
/// [`mcap::proto`]) derive their counters from, compiled here from its source as they are.
#[path = "../../crates/omnikin-io/src/telemetry_schema.rs"]
#[allow(dead_code)]
pub mod telemetry_schema;
