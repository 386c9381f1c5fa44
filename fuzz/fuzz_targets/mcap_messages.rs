//! Fuzzes `mcap_messages`: see [`omnikin_fuzz::mcap`] for the protobuf decoding and the
//! properties checked.
#![no_main]

use libfuzzer_sys::fuzz_target;
use omnikin_fuzz::alloc::Counting;

#[global_allocator]
static ALLOC: Counting = Counting;

fuzz_target!(|data: &[u8]| omnikin_fuzz::mcap::mcap_messages(data));
