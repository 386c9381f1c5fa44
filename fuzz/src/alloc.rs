//! A counting global allocator: every fuzz target installs it to check that a decoder's
//! memory is bounded by its input (text parsers) or that it allocates nothing at all (the
//! `no_std` link codec).
//!
//! It also refuses any request that would take the live heap above [`HARD_CAP`]: the
//! allocation fails, Rust aborts with "memory allocation failed", and libFuzzer records the
//! input as a crash — long before the machine runs out of memory.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

/// Largest live heap a target may reach, bytes (1 GiB).
pub const HARD_CAP: usize = 1 << 30;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static COUNT: AtomicUsize = AtomicUsize::new(0);

/// The allocator: `#[global_allocator] static A: Counting = Counting;` in each target.
pub struct Counting;

fn reserve(n: usize) -> bool {
    let live = LIVE.fetch_add(n, Relaxed).saturating_add(n);
    if live > HARD_CAP {
        LIVE.fetch_sub(n, Relaxed);
        return false;
    }
    PEAK.fetch_max(live, Relaxed);
    COUNT.fetch_add(1, Relaxed);
    true
}

fn release(n: usize) {
    LIVE.fetch_sub(n, Relaxed);
}

// SAFETY: every call forwards to `System` with the caller's layout; the counters only decide
// whether to forward and never touch the memory.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !reserve(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's contract for `alloc`.
        let p = unsafe { System.alloc(layout) };
        if p.is_null() {
            release(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !reserve(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's contract for `alloc_zeroed`.
        let p = unsafe { System.alloc_zeroed(layout) };
        if p.is_null() {
            release(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract for `dealloc`.
        unsafe { System.dealloc(ptr, layout) };
        release(layout.size());
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // Counted as old + new while the copy may exist (the worst case of a moving realloc).
        if !reserve(new_size) {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's contract for `realloc`.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if p.is_null() {
            release(new_size);
        } else {
            release(layout.size());
        }
        p
    }
}

/// What a closure allocated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Usage {
    /// Highest live heap above the level at the start, bytes.
    pub peak: usize,
    /// Allocation calls (`alloc`, `alloc_zeroed`, `realloc`).
    pub allocations: usize,
}

/// Runs `f` and reports its heap use (single-threaded targets: the counters are global).
pub fn measure<R>(f: impl FnOnce() -> R) -> (R, Usage) {
    let base = LIVE.load(Relaxed);
    PEAK.store(base, Relaxed);
    COUNT.store(0, Relaxed);
    let r = f();
    let usage = Usage {
        peak: PEAK.load(Relaxed).saturating_sub(base),
        allocations: COUNT.load(Relaxed),
    };
    (r, usage)
}

/// The heap a text parser may use for an input of `len` bytes: 256 bytes per input byte plus
/// 1 MiB. Generous (a row of `0,1` is 4 bytes and becomes a row vector of 16 bytes, twice
/// over while a vector grows), but linear: it catches a parser that allocates by a number it
/// read instead of by what it has seen.
pub fn text_budget(len: usize) -> usize {
    len.saturating_mul(256).saturating_add(1 << 20)
}

/// The heap the TOML parser may use for an input of `len` bytes: 1 KiB per input byte plus
/// 1 MiB. Nested inline tables (`a={b={c={…`) cost the `toml` crate about 1 KB of heap per
/// input byte (CI found 1 387 bytes taking 1.47 MB, past [`text_budget`]); still linear, and
/// the tools read TOML files of at most 1 MiB (`omnikin::description::MAX_TOML_BYTES`).
pub fn toml_budget(len: usize) -> usize {
    len.saturating_mul(1024).saturating_add(1 << 20)
}
