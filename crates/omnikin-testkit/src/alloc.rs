//! The counting global allocator: the system allocator, with per-thread counters of the
//! allocations (and reallocations) made and of the heap bytes in use (allocated minus freed).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

thread_local! {
    /// Allocations and reallocations made by this thread.
    static ALLOCS: Cell<usize> = const { Cell::new(0) };
    /// Heap bytes in use by this thread (allocated minus freed by it; may go negative when
    /// it frees memory another thread allocated).
    static IN_USE: Cell<isize> = const { Cell::new(0) };
}

/// Counts one allocation of `bytes` (negative: freed). `try_with`: nothing is counted during
/// the thread's teardown; a const-initialised `Cell` allocates nothing when first used.
fn count(calls: usize, bytes: isize) {
    let _ = ALLOCS.try_with(|c| c.set(c.get() + calls));
    let _ = IN_USE.try_with(|c| c.set(c.get() + bytes));
}

/// The system allocator with per-thread counters; install it in a test binary with
/// `#[global_allocator] static GLOBAL: omnikin_testkit::Counting = omnikin_testkit::Counting;`.
/// Without that line the counters stay at zero.
pub struct Counting;

// SAFETY: every call forwards to `System` with the caller's arguments unchanged; the counters
// never touch the memory.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count(1, layout.size() as isize);
        // SAFETY: the caller's contract for `GlobalAlloc::alloc`, forwarded unchanged.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        count(0, -(layout.size() as isize));
        // SAFETY: `ptr` came from `alloc` (or `realloc`) above with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count(1, new_size as isize - layout.size() as isize);
        // SAFETY: the caller's contract for `GlobalAlloc::realloc`, forwarded unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Runs `f` and returns the number of allocations (and reallocations) this thread made in
/// it, with `f`'s result (kept from being optimised away by `black_box`).
pub fn allocations<R>(f: impl FnOnce() -> R) -> (usize, R) {
    let before = ALLOCS.with(Cell::get);
    let r = std::hint::black_box(f());
    (ALLOCS.with(Cell::get) - before, r)
}

/// Allocations (and reallocations) this thread has made since it started: for a test that
/// reads the count before and after a stretch of statements.
pub fn allocation_count() -> usize {
    ALLOCS.with(Cell::get)
}

/// Heap bytes in use by this thread (allocated minus freed by it since it started).
pub fn in_use() -> isize {
    IN_USE.with(Cell::get)
}
