//! Fuzzes the link past its CRC and MAC: the input is a sequence of structured frames (header
//! fields, body bytes, corruptions to apply) that the harness fixes up into wire frames and
//! delivers to a robot-side endpoint and runtime, checking each outcome against the format's
//! reference (see [`omnikin_fuzz::link`]).
#![no_main]

use libfuzzer_sys::fuzz_target;
use omnikin_fuzz::alloc::Counting;

#[global_allocator]
static ALLOC: Counting = Counting;

fuzz_target!(|data: &[u8]| {
    omnikin_fuzz::link::run_session(data);
});
