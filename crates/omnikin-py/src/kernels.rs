//! Row-parallel kernels: a per-row function over `N` rows writing into one or two row-major
//! output buffers (e.g. wheel rates and steer rates), run without the GIL on rayon's pool in
//! chunks (small inputs on the calling thread); the error of the first failing row is
//! reported. Each output is written once, in place: on large inputs the first touch of fresh
//! output memory costs as much as the kinematics, so there is no second pass.

use rayon::prelude::*;
use std::sync::Mutex;

/// Rows per parallel task.
const CHUNK: usize = 8192;

/// The lowest failing row and its error.
type RowError = (usize, String);

/// Fills `a` (`n * wa` values) and `b` (`n * wb`, may be 0 wide) with
/// `f(i, &mut a[i*wa..][..wa], &mut b[i*wb..][..wb])` for every row `i`.
pub fn map_rows2<F>(n: usize, wa: usize, wb: usize, f: F) -> Result<(Vec<f64>, Vec<f64>), RowError>
where
    F: Fn(usize, &mut [f64], &mut [f64]) -> Result<(), String> + Sync,
{
    let mut a = vec![0.0; n * wa];
    let mut b = vec![0.0; n * wb];
    if n == 0 || wa == 0 {
        return Ok((a, b));
    }
    let first: Mutex<Option<RowError>> = Mutex::new(None);
    let run = |c: usize, ca: &mut [f64], cb: &mut [f64]| {
        let rows = ca.len() / wa;
        for j in 0..rows {
            let i = c * CHUNK + j;
            let ra = &mut ca[j * wa..(j + 1) * wa];
            let rb = &mut cb[j * wb..(j + 1) * wb];
            if let Err(e) = f(i, ra, rb) {
                let mut g = first.lock().unwrap_or_else(|p| p.into_inner());
                if g.as_ref().is_none_or(|(k, _)| i < *k) {
                    *g = Some((i, e));
                }
                return;
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

/// [`map_rows2`] with one output.
pub fn map_rows<F>(n: usize, width: usize, f: F) -> Result<Vec<f64>, RowError>
where
    F: Fn(usize, &mut [f64]) -> Result<(), String> + Sync,
{
    map_rows2(n, width, 0, |i, a, _| f(i, a)).map(|(a, _)| a)
}
