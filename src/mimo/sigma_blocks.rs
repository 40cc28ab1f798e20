//! The R₂₂ blocks of the fast pole relocation when every block shares its regressor A
//! (no weights): each block's σ-columns B_e = −h_e[φ | 1] (real-stacked) projected off
//! the range of A, reduced to the triangular factor of (I − QQᵀ)B_e.

use super::thin_qr::r_factor;
use crate::linalg::parallel::map_indices;
use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DMatrixView, DVector};
use num_traits::Float;

/// Values held at once by a chunk of the Gram basis: under the allocator's reuse
/// threshold, so that the buffers of successive relocations are not mapped afresh (page
/// faults cost as much as the products on large fits).
const CHUNK_VALUES: usize = 1 << 20;

/// Parts of the packed Gram basis formed and multiplied in parallel.
const GRAM_PARTS: usize = 8;

/// Every block's R₂₂ ((n + 1) × (n + 1)) for the data `h` (one vector per block over
/// the lines), the basis φ (L × n), the orthonormal Q (2L × m) of the shared regressor
/// and the residuals of the blocks' linear fits h_e − QQᵀh_e (2L × blocks).
///
/// Fast path, matrix products only: the Gram matrix G_e = B_eᵀB_e − P_eᵀP_e with
/// P_e = QᵀB_e, whose last row and column (the σ₀ column −h_e, nearly in the range of A
/// once the model fits) are formed from that column's residual r_e = b_e − Q P_e,last
/// instead (B_eᵀr_e and r_eᵀr_e, free of the cancellation; r_e is the negated residual of
/// the block's linear fit), then R₂₂ = chol(G_e). The
/// B_eᵀB_e of all blocks are one product, |h|² times the Gram basis
/// Re(conj φ̃_i φ̃_j)(x_k) (φ̃ = [φ | 1]), a wide product several times faster than one
/// product per block; the P_e are one product per block, the blocks in parallel (one
/// task per block balances the threads and keeps each task's buffers small: on the
/// 4-port of `bench/multiport.py` 2.5 ms less than products over batches of 8 blocks,
/// whose fresh buffers cost page faults). A block takes the fast path when every other diagonal of G_e keeps at
/// least √ε of B_eᵀB_e's (so that G_e holds its entries to about √ε) and the Cholesky
/// factorisation succeeds; otherwise its projection (I − QQᵀ)B_e and their QR.
pub(crate) fn shared_blocks<T: Real>(
    h: &[Vec<Complex<T>>],
    phi: &DMatrix<Complex<T>>,
    q: &DMatrix<T>,
    fit_residuals: &DMatrix<T>,
) -> Vec<DMatrix<T>> {
    let (l, n) = phi.shape();
    let n1 = n + 1;
    let grams = block_grams(h, phi);
    let q_t = q.transpose();
    let ne = h.len();
    map_indices(ne, |e| {
        let mut sigma = DMatrix::<T>::zeros(2 * l, n1);
        fill_sigma_columns(&h[e], phi, &mut sigma, 0);
        let p = &q_t * &sigma;
        let gram = unpack(grams.row(e).iter().copied(), n1);
        // the σ₀ column's residual r_e = −(h_e − QQᵀh_e) and B_eᵀr_e
        let fit = fit_residuals.column(e);
        let r = Residual {
            norm_sqr: fit.norm_squared(),
            cross: -sigma.tr_mul(&fit),
        };
        block(sigma.columns(0, n1), p.columns(0, n1), gram, r, q)
    })
}

/// Writes the σ-columns −h_k[φ(x_k) | 1] of the data `h` (real-stacked: rows 2k and
/// 2k + 1) into the n + 1 columns of `out` from `first`, column by column (contiguous
/// writes, no index arithmetic per value: on large fits this fill costs as much as the
/// products).
pub(crate) fn fill_sigma_columns<T: Real>(
    h: &[Complex<T>],
    phi: &DMatrix<Complex<T>>,
    out: &mut DMatrix<T>,
    first: usize,
) {
    let n = phi.ncols();
    for c in 0..=n {
        let mut col = out.column_mut(first + c);
        let pairs = col.as_mut_slice().chunks_exact_mut(2);
        if c < n {
            for ((pair, f), hk) in pairs.zip(phi.column(c).iter()).zip(h) {
                let g = -(*f * *hk);
                pair[0] = g.re;
                pair[1] = g.im;
            }
        } else {
            for (pair, hk) in pairs.zip(h) {
                pair[0] = -hk.re;
                pair[1] = -hk.im;
            }
        }
    }
}

/// The σ₀ column's residual r = b − Q P_last of one block: rᵀr and Bᵀr.
struct Residual<T: Real> {
    norm_sqr: T,
    cross: DVector<T>,
}

/// One block's R₂₂ from its σ-columns B, their projection coefficients P = QᵀB, BᵀB and
/// the σ₀ column's residual.
fn block<T: Real>(
    sigma: DMatrixView<'_, T>,
    p: DMatrixView<'_, T>,
    gram: DMatrix<T>,
    residual: Residual<T>,
    q: &DMatrix<T>,
) -> DMatrix<T> {
    let n1 = sigma.ncols();
    let last = n1 - 1;
    let kept = Float::sqrt(T::default_epsilon());
    let mut g = &gram - p.transpose() * p;
    if (0..last).all(|i| g[(i, i)] >= kept * gram[(i, i)]) {
        for i in 0..last {
            g[(i, last)] = residual.cross[i];
            g[(last, i)] = residual.cross[i];
        }
        g[(last, last)] = residual.norm_sqr;
        if let Some(chol) = g.cholesky() {
            let r = chol.l().transpose();
            if r.iter().all(|v| Float::is_finite(*v)) {
                return r;
            }
        }
    }
    r_factor(sigma - q * p)
}

/// B_eᵀB_e of every block, packed (upper triangle by columns, one row per block):
/// Σ_k |h_e,k|² Re(conj φ̃_i(x_k) φ̃_j(x_k)) as the product of |h|² (blocks × L) and the
/// Gram basis (L × (n + 1)(n + 2)/2), in parallel over parts of the packed columns and,
/// within a part, over chunks of lines.
fn block_grams<T: Real>(h: &[Vec<Complex<T>>], phi: &DMatrix<Complex<T>>) -> DMatrix<T> {
    let (l, n) = phi.shape();
    let n1 = n + 1;
    let packed = n1 * (n1 + 1) / 2;
    let pairs: Vec<(usize, usize)> = (0..n1).flat_map(|j| (0..=j).map(move |i| (i, j))).collect();
    let power = DMatrix::from_fn(h.len(), l, |e, k| h[e][k].norm_sqr());
    // φ by columns (column-major storage)
    let values = phi.as_slice();
    let width = packed.div_ceil(GRAM_PARTS);
    let chunk = (CHUNK_VALUES / width).max(1);
    let parts = crate::linalg::parallel::map_indices(packed.div_ceil(width), |part| {
        let columns = &pairs[part * width..packed.min((part + 1) * width)];
        let mut out = DMatrix::<T>::zeros(h.len(), columns.len());
        for first in (0..l).step_by(chunk) {
            let len = chunk.min(l - first);
            let mut basis = DMatrix::<T>::zeros(len, columns.len());
            for (c, &(i, j)) in columns.iter().enumerate() {
                let mut column = basis.column_mut(c);
                let dst = column.as_mut_slice();
                match (i < n, j < n) {
                    (true, true) => {
                        let a = &values[i * l + first..i * l + first + len];
                        let b = &values[j * l + first..j * l + first + len];
                        for ((d, a), b) in dst.iter_mut().zip(a).zip(b) {
                            *d = a.re * b.re + a.im * b.im;
                        }
                    }
                    (true, false) => {
                        let a = &values[i * l + first..i * l + first + len];
                        for (d, a) in dst.iter_mut().zip(a) {
                            *d = a.re;
                        }
                    }
                    _ => dst.fill(T::one()),
                }
            }
            out.gemm(T::one(), &power.columns(first, len), &basis, T::one());
        }
        out
    });
    let mut grams = DMatrix::<T>::zeros(h.len(), packed);
    for (part, values) in parts.iter().enumerate() {
        grams
            .columns_mut(part * width, values.ncols())
            .copy_from(values);
    }
    grams
}

/// The symmetric n1 × n1 matrix of a packed upper triangle (by columns).
fn unpack<T: Real>(mut packed: impl Iterator<Item = T>, n1: usize) -> DMatrix<T> {
    let mut g = DMatrix::zeros(n1, n1);
    for j in 0..n1 {
        for i in 0..=j {
            let v = packed.next().unwrap_or_else(T::zero);
            g[(i, j)] = v;
            g[(j, i)] = v;
        }
    }
    g
}

#[cfg(test)]
mod tests {
    use super::*;

    /// R₂₂ by the definition: the R factor of (I − QQᵀ)B by Householder QR.
    fn reference(
        h: &[Complex<f64>],
        phi: &DMatrix<Complex<f64>>,
        q: &DMatrix<f64>,
    ) -> DMatrix<f64> {
        let (l, n) = phi.shape();
        let b = DMatrix::from_fn(2 * l, n + 1, |row, c| {
            let k = row / 2;
            let g = if c < n { -(phi[(k, c)] * h[k]) } else { -h[k] };
            if row % 2 == 0 { g.re } else { g.im }
        });
        let projected = &b - q * (q.transpose() * &b);
        projected.qr().r()
    }

    #[test]
    fn blocks_match_the_projected_qr_up_to_row_signs() {
        let l = 60;
        let poles = [
            Complex::new(-0.05, 0.3),
            Complex::new(-0.1, 0.7),
            Complex::new(-0.2, 0.0),
        ];
        let x: Vec<Complex<f64>> = (0..l)
            .map(|k| Complex::new(0.0, k as f64 / l as f64))
            .collect();
        let phi = DMatrix::from_fn(l, 3, |k, c| Complex::new(1.0, 0.0) / (x[k] - poles[c]));
        let a = DMatrix::from_fn(2 * l, 4, |row, c| {
            let v = if c < 3 {
                phi[(row / 2, c)]
            } else {
                Complex::new(1.0, 0.0)
            };
            if row % 2 == 0 { v.re } else { v.im }
        });
        let q = a.qr().q();
        // data near the model space (a rational function plus a small disturbance), and
        // far from it, in more blocks than there are threads
        let h: Vec<Vec<Complex<f64>>> = (0..11)
            .map(|e| {
                (0..l)
                    .map(|k| {
                        let model = (phi[(k, 0)] + phi[(k, 1)] * (e as f64)) * 0.3;
                        let wiggle = Complex::new((k * (e + 3)) as f64 * 0.37, 0.0).sin();
                        model + wiggle * if e % 2 == 0 { 1e-6 } else { 0.5 }
                    })
                    .collect()
            })
            .collect();
        let b = DMatrix::from_fn(2 * l, 11, |row, e| {
            let v = h[e][row / 2];
            if row % 2 == 0 { v.re } else { v.im }
        });
        let fit_residuals = &b - &q * (q.transpose() * &b);
        let blocks = shared_blocks(&h, &phi, &q, &fit_residuals);
        assert_eq!(blocks.len(), 11);
        for (e, r) in blocks.iter().enumerate() {
            let want = reference(&h[e], &phi, &q);
            for i in 0..4 {
                // rows of R are unique up to sign
                let sign = if (r[(i, i)] > 0.0) == (want[(i, i)] > 0.0) {
                    1.0
                } else {
                    -1.0
                };
                let row_err = (r.row(i) - want.row(i) * sign).amax();
                assert!(
                    row_err <= 1e-7 * want.amax(),
                    "block {e} row {i}: {row_err:e}"
                );
            }
        }
    }
}
