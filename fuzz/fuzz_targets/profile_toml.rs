//! Fuzzes `profile_toml`: see [`omnikin_fuzz::text::profile_toml`] for the parsers and the properties checked.
#![no_main]

use libfuzzer_sys::fuzz_target;
use omnikin_fuzz::alloc::Counting;

#[global_allocator]
static ALLOC: Counting = Counting;

fuzz_target!(|data: &[u8]| omnikin_fuzz::text::profile_toml(data));
