//! The stored form of a fusion filter state ([`super::fusion::PoseFusion`]'s history): the
//! 5-state mean and the **upper triangle** of its covariance, 20 scalars instead of 30.
//!
//! The filter keeps every covariance exactly symmetric (each prediction and update ends in
//! `(P + Pᵀ)/2`, whose two triangles are bit-for-bit equal; the inflation of a recovery scales
//! `P[i][j]` and `P[j][i]` alike), so storing one triangle loses nothing: [`Posterior::pack`]
//! followed by [`Posterior::covariance`] gives back the same matrix. In `f32` a posterior is
//! 80 bytes (5 × 4 for the mean, 15 × 4 for the triangle) instead of the 120 of a full 5 × 5
//! matrix; its time is the time of the history entry that holds it, not stored again.

use nalgebra::{SMatrix, SVector};

use crate::Real;

/// Number of states of the filter (x, y, θ, gyro bias, wheel scale).
const S: usize = 5;
/// Entries of the upper triangle of an `S × S` matrix.
const TRIANGLE: usize = S * (S + 1) / 2;

/// Index into the packed triangle (row by row, `i ≤ j`) of element `(i, j)` or `(j, i)`.
const INDEX: [[usize; S]; S] = {
    let mut t = [[0; S]; S];
    let mut k = 0;
    let mut i = 0;
    while i < S {
        let mut j = i;
        while j < S {
            t[i][j] = k;
            t[j][i] = k;
            k += 1;
            j += 1;
        }
        i += 1;
    }
    t
};

/// A filter state without its time: the mean and the covariance's upper triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Posterior<T> {
    /// Mean `(x, y, θ, b, k)`.
    pub(super) x: SVector<T, S>,
    /// Covariance, upper triangle row by row (`(0,0), (0,1), …, (0,4), (1,1), …, (4,4)`).
    tri: [T; TRIANGLE],
}

impl<T: Real> Posterior<T> {
    /// Packs mean `x` and the symmetric covariance `p` (its lower triangle is not read).
    pub(super) fn pack(x: &SVector<T, S>, p: &SMatrix<T, S, S>) -> Self {
        let mut tri = [T::zero(); TRIANGLE];
        for i in 0..S {
            for j in i..S {
                tri[INDEX[i][j]] = p[(i, j)];
            }
        }
        Self { x: *x, tri }
    }

    /// Covariance element `(i, j)` (`i, j < 5`; symmetric).
    #[inline]
    pub(super) fn cov(&self, i: usize, j: usize) -> T {
        self.tri[INDEX[i][j]]
    }

    /// The full covariance matrix.
    pub(super) fn covariance(&self) -> SMatrix<T, S, S> {
        SMatrix::from_fn(|i, j| self.cov(i, j))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_symmetric_matrix_round_trips_bit_for_bit() {
        // Distinct values everywhere: a wrong index would put one in the wrong place.
        let a = SMatrix::<f64, S, S>::from_fn(|i, j| 1.0 + i as f64 * 0.37 + j as f64 * 1.91);
        let p = (a + a.transpose()) * 0.5;
        let x = SVector::<f64, S>::from_fn(|i, _| i as f64 - 2.5);
        let q = Posterior::pack(&x, &p);
        assert_eq!(q.covariance(), p);
        assert_eq!(q.x, x);
        for i in 0..S {
            for j in 0..S {
                assert_eq!(q.cov(i, j), p[(i, j)], "({i}, {j})");
            }
        }
    }

    #[test]
    fn the_triangle_has_every_index_once() {
        let mut seen = [0; TRIANGLE];
        for i in 0..S {
            for j in i..S {
                seen[INDEX[i][j]] += 1;
            }
        }
        assert_eq!(seen, [1; TRIANGLE]);
    }

    #[test]
    fn an_f32_posterior_is_80_bytes() {
        assert_eq!(core::mem::size_of::<Posterior<f32>>(), 80);
    }
}
