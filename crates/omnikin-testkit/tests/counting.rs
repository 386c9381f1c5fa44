//! The counting allocator counts what a closure allocates, on this thread only.

#[global_allocator]
static GLOBAL: omnikin_testkit::Counting = omnikin_testkit::Counting;

use omnikin_testkit::{allocations, in_use};

#[test]
fn counts_allocations_and_bytes_in_use() {
    let (none, x) = allocations(|| 2 + 2);
    assert_eq!((none, x), (0, 4));
    let before = in_use();
    let (one, v) = allocations(|| Vec::<u64>::with_capacity(100));
    assert_eq!(one, 1);
    assert_eq!(in_use() - before, 800);
    drop(v);
    assert_eq!(in_use(), before);
    let (grow, _) = allocations(|| {
        let mut v = Vec::<u8>::with_capacity(1);
        v.extend_from_slice(&[0; 64]);
        v
    });
    assert_eq!(grow, 2, "an allocation and a reallocation");
}

#[test]
fn another_threads_allocations_are_not_counted() {
    let before = in_use();
    let v = std::thread::spawn(|| vec![0u8; 4096]).join().unwrap();
    // The spawn allocates a little here (handle, closure); the 4 KiB buffer is the other
    // thread's.
    assert!(in_use() - before < 4096, "{}", in_use() - before);
    drop(v);
}
