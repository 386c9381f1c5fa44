//! Row-parallel kernels: a per-row function over `N` rows writing into one or two row-major
//! output buffers (e.g. wheel rates and steer rates), run without the GIL on rayon's pool in
//! chunks (small inputs on the calling thread); the error of the first failing row is
//! reported. Each output is written once, in place: on large inputs the first touch of fresh
//! output memory costs as much as the kinematics, so there is no second pass.

use rayon::prelude::*;
use std::sync::Mutex;

/// Outputs from this size on are backed by transparent huge pages where the kernel has them.
const HUGE_FROM_BYTES: usize = 4 << 20;

/// `len` zeros for an output buffer. A large one is fresh memory from the kernel (calloc
/// maps it untouched), and writing it costs one page fault per 4 KiB page: at 10^6 caster3
/// rows (48 MB of output) about 19 ms, three times the kinematics. On Linux its 2 MiB-aligned
/// interior is marked `MADV_HUGEPAGE` first, so it faults in 2 MiB pages (a hint: where huge
/// pages are disabled nothing changes; the contents are zeros either way).
fn zeroed(len: usize) -> Vec<f64> {
    let v = vec![0.0; len];
    let bytes = len * std::mem::size_of::<f64>();
    #[cfg(target_os = "linux")]
    if bytes >= HUGE_FROM_BYTES {
        const HUGE: usize = 2 << 20;
        let start = (v.as_ptr() as usize).div_ceil(HUGE) * HUGE;
        let end = (v.as_ptr() as usize + bytes) / HUGE * HUGE;
        if end > start {
            // SAFETY: [start, end) lies within `v`'s allocation, which is live and not yet
            // shared; MADV_HUGEPAGE changes how its pages are backed, never their contents.
            unsafe {
                libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = bytes;
    v
}

/// Rows per parallel task.
pub const CHUNK: usize = 8192;

/// The lowest failing row and its error.
pub type RowError = (usize, String);

/// Fills `a` (`n * wa` values) and `b` (`n * wb`, may be 0 wide) chunk by chunk:
/// `f(first_row, &mut a_chunk, &mut b_chunk)` for consecutive chunks of up to [`CHUNK`] rows
/// (so a caller can enter the robot's concrete kind once per chunk, not once per row); `f`
/// returns the error of the first failing row of its chunk.
pub fn map_chunks2<F>(
    n: usize,
    wa: usize,
    wb: usize,
    f: F,
) -> Result<(Vec<f64>, Vec<f64>), RowError>
where
    F: Fn(usize, &mut [f64], &mut [f64]) -> Result<(), RowError> + Sync,
{
    let mut a = zeroed(n * wa);
    let mut b = zeroed(n * wb);
    if n == 0 || wa == 0 {
        return Ok((a, b));
    }
    let first: Mutex<Option<RowError>> = Mutex::new(None);
    let run = |c: usize, ca: &mut [f64], cb: &mut [f64]| {
        if let Err((i, e)) = f(c * CHUNK, ca, cb) {
            let mut g = first.lock().unwrap_or_else(|p| p.into_inner());
            if g.as_ref().is_none_or(|(k, _)| i < *k) {
                *g = Some((i, e));
            }
        }
    };
    if n <= CHUNK {
        run(0, &mut a, &mut b);
    } else {
        let chunks = n.div_ceil(CHUNK);
        let bs: Vec<&mut [f64]> = if wb > 0 {
            b.chunks_mut(CHUNK * wb).collect()
        } else {
            (0..chunks).map(|_| <&mut [f64]>::default()).collect()
        };
        a.par_chunks_mut(CHUNK * wa)
            .zip(bs.into_par_iter())
            .enumerate()
            .for_each(|(c, (ca, cb))| run(c, ca, cb));
    }
    match first.into_inner().unwrap_or_else(|p| p.into_inner()) {
        Some(e) => Err(e),
        None => Ok((a, b)),
    }
}

/// Fills `a` (`n * wa` values) and `b` (`n * wb`, may be 0 wide) with
/// `f(i, &mut a[i*wa..][..wa], &mut b[i*wb..][..wb])` for every row `i`.
pub fn map_rows2<F>(n: usize, wa: usize, wb: usize, f: F) -> Result<(Vec<f64>, Vec<f64>), RowError>
where
    F: Fn(usize, &mut [f64], &mut [f64]) -> Result<(), String> + Sync,
{
    map_chunks2(n, wa, wb, |start, ca, cb| {
        let rows = ca.len() / wa;
        for j in 0..rows {
            let i = start + j;
            let ra = &mut ca[j * wa..(j + 1) * wa];
            let rb = &mut cb[j * wb..(j + 1) * wb];
            f(i, ra, rb).map_err(|e| (i, e))?;
        }
        Ok(())
    })
}

/// [`map_rows2`] with one output.
pub fn map_rows<F>(n: usize, width: usize, f: F) -> Result<Vec<f64>, RowError>
where
    F: Fn(usize, &mut [f64]) -> Result<(), String> + Sync,
{
    map_rows2(n, width, 0, |i, a, _| f(i, a)).map(|(a, _)| a)
}
