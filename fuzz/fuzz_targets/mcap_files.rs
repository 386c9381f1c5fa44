//! Fuzzes `mcap_files`: see [`omnikin_fuzz::mcap`] for the pre-scan, the crate behind it and
//! the properties checked.
#![no_main]

use libfuzzer_sys::fuzz_target;
use omnikin_fuzz::alloc::Counting;

#[global_allocator]
static ALLOC: Counting = Counting;

fuzz_target!(|data: &[u8]| omnikin_fuzz::mcap::mcap_files(data));
