//! Fuzzes `ros2_cdr`: see [`omnikin_fuzz::ros2`] for the decoding and the properties checked.
#![no_main]

use libfuzzer_sys::fuzz_target;
use omnikin_fuzz::alloc::Counting;

#[global_allocator]
static ALLOC: Counting = Counting;

fuzz_target!(|data: &[u8]| omnikin_fuzz::ros2::ros2_cdr(data));
