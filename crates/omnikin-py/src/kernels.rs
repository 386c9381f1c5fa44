//! Row-parallel kernels: a per-row function over `N` rows into one row-major output buffer,
//! run without the GIL on rayon's pool in chunks (small inputs on the calling thread); the
//! error of the first failing row is reported.

use rayon::prelude::*;
use std::sync::Mutex;

/// Rows per parallel task.
const CHUNK: usize = 8192;

/// Fills `out` (`n * width` values) with `f(i, &mut out[i*width..][..width])` for every row
/// `i`; the error of the lowest failing row, with its index, if any.
pub fn map_rows<F>(n: usize, width: usize, f: F) -> Result<Vec<f64>, (usize, String)>
where
    F: Fn(usize, &mut [f64]) -> Result<(), String> + Sync,
{
    let mut out = vec![0.0; n * width];
    if width == 0 || n == 0 {
        return Ok(out);
    }
    let first: Mutex<Option<(usize, String)>> = Mutex::new(None);
    let run = |c: usize, chunk: &mut [f64]| {
        for (j, row) in chunk.chunks_mut(width).enumerate() {
            let i = c * CHUNK + j;
            if let Err(e) = f(i, row) {
                let mut g = first.lock().unwrap_or_else(|p| p.into_inner());
                if g.as_ref().is_none_or(|(k, _)| i < *k) {
                    *g = Some((i, e));
                }
                return;
            }
        }
    };
    if n <= CHUNK {
        run(0, &mut out);
    } else {
        out.par_chunks_mut(CHUNK * width)
            .enumerate()
            .for_each(|(c, chunk)| run(c, chunk));
    }
    match first.into_inner().unwrap_or_else(|p| p.into_inner()) {
        Some(e) => Err(e),
        None => Ok(out),
    }
}

/// Splits rows of `a + b` values into two buffers of `a` and `b` values per row.
pub fn split(v: &[f64], a: usize, b: usize) -> (Vec<f64>, Vec<f64>) {
    let n = v.len() / (a + b).max(1);
    let (mut x, mut y) = (Vec::with_capacity(n * a), Vec::with_capacity(n * b));
    for r in v.chunks(a + b) {
        x.extend_from_slice(&r[..a]);
        y.extend_from_slice(&r[a..]);
    }
    (x, y)
}
