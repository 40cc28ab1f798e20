//! Guarded normal equations: the Gram matrix JᵀJ of a tall real matrix, equilibrated to a
//! unit diagonal and factored by Cholesky only when it is well conditioned.
//!
//! The crate's rule is "QR/SVD, never the normal equations" wherever accuracy matters:
//! forming JᵀJ squares the condition number, so a solve through it loses twice the digits
//! a QR loses. These kernels are used only where that loss cannot reach a result:
//!
//! - the *step* of a Gauss–Newton / Levenberg–Marquardt iteration
//!   ([`crate::solver::GramLevenbergMarquardt`]): the fixed point of the iteration is set by the
//!   residuals and the gradient Jᵀr, which are computed directly; an inexact step only
//!   slows convergence near the optimum, it does not move it;
//! - the linear solves of Sanathanan–Koerner relocations that are followed by maximum
//!   likelihood (they only produce its start);
//! - the covariance of [`crate::Fit`], which needs a few significant digits, not fifteen.
//!
//! In every case the equilibrated Gram matrix Gₛ = D⁻¹JᵀJD⁻¹ (D = diag ‖J_j‖) is used only
//! when its Cholesky factorisation succeeds and its 1-norm condition number
//! κ₁(Gₛ) = ‖Gₛ‖₁‖Gₛ⁻¹‖₁ is at most [`max_condition`] (10⁸ in f64, 10³ in f32): then the
//! solve keeps at least about half the digits of the scalar type, and the caller falls back
//! to the QR path otherwise.

use crate::recycle;
use crate::scalar::Real;
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use num_traits::Float;

/// The largest κ₁ of the equilibrated Gram matrix accepted: 10⁸ for f64, 10³ for f32
/// (κ·ε ≈ 2·10⁻⁸ and 1.2·10⁻⁴).
pub(crate) fn max_condition<T: Real>() -> T {
    if T::default_epsilon() < T::lit(1e-10) {
        T::lit(1e8)
    } else {
        T::lit(1e3)
    }
}

/// Work space for G = JᵀJ and g = Jᵀr of an m × p matrix (reused across iterations).
#[derive(Debug, Clone)]
pub(crate) struct GramWork<T: Real> {
    /// JᵀJ (p × p).
    pub g: DMatrix<T>,
}

impl<T: Real> GramWork<T> {
    pub(crate) fn new(p: usize) -> Self {
        Self {
            g: DMatrix::zeros(p, p),
        }
    }

    /// Forms G = JᵀJ ([`gram_into`]).
    pub(crate) fn gram(&mut self, jac: &DMatrix<T>) {
        let p = jac.ncols();
        if self.g.shape() != (p, p) {
            self.g = DMatrix::zeros(p, p);
        }
        gram_into(jac, &mut self.g, false);
    }

    /// Jᵀv (column dot products of J, contiguous in memory).
    pub(crate) fn tr_mul(jac: &DMatrix<T>, v: &[T], out: &mut DVector<T>) {
        let v = nalgebra::DVectorView::from_slice(v, jac.nrows());
        out.gemv_tr(T::one(), jac, &v, T::zero());
    }
}

/// G = JᵀJ (`accumulate`: G += JᵀJ) into `g` (p × p, p = J's column count): in f64 and
/// f32, the register-tiled column dot products of [`super::gram_kernel`] (J read in place,
/// the upper triangle computed, the same bits on every processor); for another scalar
/// type, one blocked matrix product (nalgebra's gemm) of a transposed *view* of J with J,
/// so no copy of J is made, or column dot products when p ≤ 5 or J has at most 5 rows,
/// below nalgebra's threshold for the blocked product. The view must not reach
/// nalgebra's column-by-column fallback of gemm below that threshold: it bounds its loop
/// over a strided column by the length of the underlying slice, not by the column's, and
/// writes past the result (a 2 × p block of one line's rows did).
pub(crate) fn gram_into<T: Real>(jac: &DMatrix<T>, g: &mut DMatrix<T>, accumulate: bool) {
    let (m, p) = jac.shape();
    debug_assert_eq!(g.shape(), (p, p));
    if super::gram_kernel::gram_columns(jac.as_slice(), m, p, g.as_mut_slice(), accumulate) {
        return;
    }
    let beta = if accumulate { T::one() } else { T::zero() };
    // nalgebra's blocked-product threshold (`SMALL_DIM` of its gemm)
    const SMALL_DIM: usize = 5;
    if p <= SMALL_DIM || m <= SMALL_DIM {
        g.gemm_tr(T::one(), jac, jac, beta);
        return;
    }
    let jt =
        nalgebra::DMatrixView::<T, Dyn, Dyn>::from_slice_with_strides(jac.as_slice(), p, m, m, 1);
    g.gemm(T::one(), &jt, jac, beta);
}

/// The equilibrated Gram matrix Gₛ = D⁻¹GD⁻¹ with its Cholesky factor, when well
/// conditioned.
#[derive(Debug, Clone)]
pub(crate) struct ScaledCholesky<T: Real> {
    /// D = √diag G.
    pub d: Vec<T>,
    /// Gₛ (unit diagonal).
    pub gs: DMatrix<T>,
    /// Cholesky factor of Gₛ.
    pub chol: Cholesky<T, Dyn>,
    /// κ₁(Gₛ).
    #[cfg_attr(not(test), allow(dead_code))]
    pub condition: T,
}

/// D = √diag `g` and Gₛ = D⁻¹gD⁻¹ (unit diagonal) of a square `g`; `None` when it is empty,
/// a diagonal entry is zero or not finite, or an entry of Gₛ is not finite.
pub(crate) fn equilibrated<T: Real>(g: &DMatrix<T>) -> Option<(Vec<T>, DMatrix<T>)> {
    let p = g.nrows();
    if p == 0 || g.ncols() != p {
        return None;
    }
    let mut d = Vec::with_capacity(p);
    for j in 0..p {
        let v = g[(j, j)];
        if !(v > T::zero() && Float::is_finite(v)) {
            return None;
        }
        d.push(Float::sqrt(v));
    }
    let gs = DMatrix::from_fn(p, p, |i, j| {
        if i == j {
            T::one()
        } else {
            g[(i, j)] / (d[i] * d[j])
        }
    });
    if gs.iter().any(|v| !Float::is_finite(*v)) {
        return None;
    }
    Some((d, gs))
}

/// Equilibrates the symmetric positive semi-definite `g` and factors it; `None` when a
/// diagonal entry is zero or not finite, when Cholesky fails, or when κ₁(Gₛ) exceeds
/// `max_cond`.
pub(crate) fn scaled_cholesky<T: Real>(g: &DMatrix<T>, max_cond: T) -> Option<ScaledCholesky<T>> {
    let (d, gs) = equilibrated(g)?;
    let chol = Cholesky::new(gs.clone())?;
    let inv = chol.inverse();
    let norm1 = |m: &DMatrix<T>| {
        m.column_iter()
            .map(|c| c.iter().fold(T::zero(), |s, v| s + Float::abs(*v)))
            .fold(T::zero(), Float::max)
    };
    let condition = norm1(&gs) * norm1(&inv);
    if !(condition <= max_cond) {
        return None;
    }
    Some(ScaledCholesky {
        d,
        gs,
        chol,
        condition,
    })
}

/// Least squares min ‖Aθ − b‖² through the guarded normal equations (see the module
/// documentation); `None` when the equilibrated Gram matrix is not accepted, so that the
/// caller uses [`super::least_squares`]. Returns θ and the residual norm² (computed from
/// the residual itself, not from the normal equations).
pub(crate) fn least_squares_gram<T: Real>(
    a: &DMatrix<T>,
    b: &DVector<T>,
    max_cond: T,
) -> Option<(DVector<T>, T)> {
    let (m, p) = a.shape();
    if p == 0 || m < p || b.len() != m {
        return None;
    }
    let mut work = GramWork::new(p);
    work.gram(a);
    let sc = scaled_cholesky(&work.g, max_cond)?;
    let mut atb = DVector::zeros(p);
    GramWork::tr_mul(a, b.as_slice(), &mut atb);
    for (v, d) in atb.iter_mut().zip(&sc.d) {
        *v /= *d;
    }
    let y = sc.chol.solve(&atb);
    let theta = DVector::from_iterator(p, y.iter().zip(&sc.d).map(|(v, d)| *v / *d));
    if theta.iter().any(|v| !Float::is_finite(*v)) {
        return None;
    }
    let mut r = b.clone();
    r.gemv(-T::one(), a, &theta, T::one());
    Some((theta, r.norm_squared()))
}

/// Lines per block of the accumulated normal equations for `p` columns: about 4 096/p
/// (at least 64), so that a block's real-stacked rows (2·lines × p) and the complex
/// values they come from (about 64 kB each) stay in cache, while the blocks stay long
/// enough for the blocked product.
pub(crate) fn block_lines(p: usize) -> usize {
    (4_096 / p.max(1)).max(64)
}

/// True for problems of `n` lines and `p` parameters small enough (n·p ≤ 8 192) that their
/// N × p matrices stay in cache: forming them costs less there than evaluating the model
/// block by block, twice where a second pass needs the Jacobian again. The bound keeps each
/// such complex matrix within 128 KiB, the allocator's usual threshold for mapping fresh
/// pages: larger ones, allocated anew by every fit, can cost a page fault per 4 KiB
/// touched (measured: about 80 faults, a tenth of the time, in an order-4 fit of 2 000
/// lines at the former bound of 32 768).
pub(crate) fn small_problem(n: usize, p: usize) -> bool {
    n.saturating_mul(p) <= 8_192
}

/// [`least_squares_gram`] for the real-stacked, line-weighted system of a complex
/// regressor R (N × q) with the coefficient `normalising` fixed to one: with
/// Rᵂ = diag(w) R and c = θ with 1 inserted at `normalising`, minimise
///
/// ```text
/// ‖Rᵂ c‖² = ‖Aθ − b‖²,   A = the real-stacked other columns of Rᵂ, b = −(its normalising column),
/// ```
///
/// without forming A: AᵀA and Aᵀb are accumulated over blocks of lines, each block's
/// stacked rows formed in a small buffer. The residual norm² is computed
/// from the residuals w_k R_k c themselves. `None` under the conditions of
/// [`least_squares_gram`] (then solve the stacked system by QR).
pub(crate) fn regressor_least_squares_gram<T: Real>(
    regressor: &DMatrix<crate::scalar::Complex<T>>,
    w: Option<&[T]>,
    normalising: usize,
    max_cond: T,
) -> Option<(DVector<T>, T)> {
    let (n, q) = regressor.shape();
    let fill = |k0: usize, rows: &mut DMatrix<crate::scalar::Complex<T>>| {
        rows.copy_from(&regressor.rows(k0, rows.nrows()));
    };
    let mut blocks = GramBlocks::default();
    let theta = lines_least_squares_gram(n, q, fill, w, normalising, max_cond, &mut blocks)?;
    let cost = lines_least_squares_cost(n, q, fill, w, normalising, &theta, &mut blocks);
    Some((theta, cost))
}

/// The block buffers of [`lines_least_squares_gram`] and [`lines_least_squares_cost`],
/// kept by a caller that solves many systems of one shape (the Sanathanan–Koerner
/// relocations of a fit) instead of allocating and zeroing these buffers of some 60 KiB
/// each at every solve (3 % of an order-4 fit of 2 000 lines).
pub(crate) struct GramBlocks<T: Real> {
    /// The buffers of the full blocks and of a last, shorter one.
    bufs: [GramBlock<T>; 2],
    wb: Vec<T>,
}

impl<T: Real> Drop for GramBlocks<T> {
    /// Gives the block buffers back for the next fit's ([`crate::recycle`]).
    fn drop(&mut self) {
        for b in &mut self.bufs {
            recycle::keep_matrix(&mut b.block);
            recycle::keep_matrix(&mut b.rhs);
            recycle::keep_matrix(&mut b.rows);
        }
    }
}

/// One block's stacked rows, right-hand side and complex regressor rows.
struct GramBlock<T: Real> {
    block: DMatrix<T>,
    rhs: DVector<T>,
    rows: DMatrix<crate::scalar::Complex<T>>,
}

impl<T: Real> Default for GramBlocks<T> {
    fn default() -> Self {
        let buf = || GramBlock {
            block: DMatrix::zeros(0, 0),
            rhs: DVector::zeros(0),
            rows: DMatrix::zeros(0, 0),
        };
        Self {
            bufs: [buf(), buf()],
            wb: Vec::new(),
        }
    }
}

/// [`regressor_least_squares_gram`] with the rows of R produced block by block by
/// `fill(k0, rows)` (the lines k0 … k0 + `rows.nrows()` − 1 of the N × q regressor), so
/// that R itself is never formed; returns θ only (the residual norm² is
/// [`lines_least_squares_cost`]). The blocks are formed in `blocks`, whose rows `fill`
/// must write in full (they hold an earlier block's).
#[allow(clippy::too_many_arguments)]
pub(crate) fn lines_least_squares_gram<T: Real>(
    n: usize,
    q: usize,
    mut fill: impl FnMut(usize, &mut DMatrix<crate::scalar::Complex<T>>),
    w: Option<&[T]>,
    normalising: usize,
    max_cond: T,
    blocks: &mut GramBlocks<T>,
) -> Option<DVector<T>> {
    if q < 2 || normalising >= q || 2 * n < q - 1 || w.is_some_and(|w| w.len() != n) {
        return None;
    }
    let p = q - 1;
    // AᵀA and Aᵀb over blocks of the stacked rows (b apart from A: a q-th column in the
    // blocked product would cost a whole extra tile of its kernel)
    let mut g = DMatrix::zeros(p, p);
    let mut atb = DVector::zeros(p);
    let lines = block_lines(p);
    let wb = &mut blocks.wb;
    for k0 in (0..n).step_by(lines) {
        let len = lines.min(n - k0);
        let GramBlock { block, rhs, rows } = &mut blocks.bufs[usize::from(len < lines)];
        if block.shape() != (2 * len, p) || rows.shape() != (len, q) {
            let zero = crate::scalar::Complex::new(T::zero(), T::zero());
            recycle::refill(block, 2 * len, p, T::zero());
            recycle::refill(rhs, 2 * len, 1, T::zero());
            recycle::refill(rows, len, q, zero);
        }
        fill(k0, rows);
        wb.clear();
        match w {
            Some(w) => wb.extend_from_slice(&w[k0..k0 + len]),
            None => wb.resize(len, T::one()),
        }
        // rows 0..len: real parts, len..2len: imaginary parts (the order of rows does not
        // change AᵀA and Aᵀb)
        for (j, src) in rows.as_slice().chunks_exact(len).enumerate() {
            let (col, sign) = match j.cmp(&normalising) {
                std::cmp::Ordering::Less => (
                    &mut block.as_mut_slice()[j * 2 * len..(j + 1) * 2 * len],
                    T::one(),
                ),
                std::cmp::Ordering::Equal => (rhs.as_mut_slice(), -T::one()),
                std::cmp::Ordering::Greater => (
                    &mut block.as_mut_slice()[(j - 1) * 2 * len..j * 2 * len],
                    T::one(),
                ),
            };
            let (cr, ci) = col.split_at_mut(len);
            for (((r, i), v), wk) in cr.iter_mut().zip(ci.iter_mut()).zip(src).zip(wb.iter()) {
                let s = *wk * sign;
                *r = v.re * s;
                *i = v.im * s;
            }
        }
        gram_into(block, &mut g, true);
        atb.gemv_tr(T::one(), block, rhs, T::one());
    }
    let sc = scaled_cholesky(&g, max_cond)?;
    for (v, d) in atb.iter_mut().zip(&sc.d) {
        *v /= *d;
    }
    let y = sc.chol.solve(&atb);
    let theta = DVector::from_iterator(p, y.iter().zip(&sc.d).map(|(v, d)| *v / *d));
    theta.iter().all(|v| Float::is_finite(*v)).then_some(theta)
}

/// The residual norm² ‖Rᵂ c‖² of θ from [`lines_least_squares_gram`], with the rows of R
/// produced again block by block by `fill` in the buffers `blocks`.
pub(crate) fn lines_least_squares_cost<T: Real>(
    n: usize,
    q: usize,
    mut fill: impl FnMut(usize, &mut DMatrix<crate::scalar::Complex<T>>),
    w: Option<&[T]>,
    normalising: usize,
    theta: &DVector<T>,
    blocks: &mut GramBlocks<T>,
) -> T {
    let c = with_normalising(theta, normalising);
    let lines = block_lines(q.saturating_sub(1));
    let mut e = Vec::new();
    let mut cost = T::zero();
    for k0 in (0..n).step_by(lines) {
        let len = lines.min(n - k0);
        let rows = &mut blocks.bufs[usize::from(len < lines)].rows;
        if rows.shape() != (len, q) {
            let zero = crate::scalar::Complex::new(T::zero(), T::zero());
            recycle::refill(rows, len, q, zero);
        }
        fill(k0, rows);
        e.clear();
        e.resize(len, crate::scalar::Complex::new(T::zero(), T::zero()));
        for (col, cj) in rows.as_slice().chunks_exact(len).zip(&c) {
            for (e, v) in e.iter_mut().zip(col) {
                *e += *v * *cj;
            }
        }
        cost += weighted_norm_sqr(&e, w.map_or(&[][..], |w| &w[k0..k0 + len]));
    }
    cost
}

/// c: θ with the coefficient one inserted at `normalising`.
fn with_normalising<T: Real>(theta: &DVector<T>, normalising: usize) -> Vec<T> {
    let mut c = Vec::with_capacity(theta.len() + 1);
    c.extend_from_slice(&theta.as_slice()[..normalising]);
    c.push(T::one());
    c.extend_from_slice(&theta.as_slice()[normalising..]);
    c
}

/// Σ_k |w_k e_k|² (w empty: unit weights).
fn weighted_norm_sqr<T: Real>(e: &[crate::scalar::Complex<T>], w: &[T]) -> T {
    if w.is_empty() {
        e.iter().fold(T::zero(), |s, v| s + v.norm_sqr())
    } else {
        e.iter()
            .zip(w)
            .fold(T::zero(), |s, (v, w)| s + (*v * *w).norm_sqr())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::lcg;

    /// A tall matrix with columns of very different scales (equilibration must absorb them).
    fn tall(m: usize, p: usize, seed: u64) -> DMatrix<f64> {
        let mut s = seed;
        DMatrix::from_fn(m, p, |_, j| lcg(&mut s) * 10f64.powi(j as i32 - 3))
    }

    #[test]
    fn gram_matches_the_direct_product() {
        // m ≤ 5 with p > 5: the last block of a blocked pass can hold one or two lines
        for (m, p) in [
            (1, 8),
            (2, 8),
            (4, 12),
            (5, 6),
            (6, 6),
            (7, 3),
            (9, 5),
            (12, 6),
            (400, 11),
            (1000, 21),
        ] {
            let j = tall(m, p, 3 + m as u64);
            let mut w = GramWork::new(1);
            w.gram(&j);
            let direct = j.transpose() * &j;
            let err = (&w.g - &direct).norm() / direct.norm();
            assert!(err < 1e-14, "{m}×{p}: {err:e}");
            let mut acc = direct.clone();
            gram_into(&j, &mut acc, true);
            let err = (&acc - &direct * 2.0).norm() / direct.norm();
            assert!(err < 1e-14, "{m}×{p} accumulated: {err:e}");
            let v: Vec<f64> = (0..m).map(|k| (k as f64).sin()).collect();
            let mut out = DVector::zeros(p);
            GramWork::tr_mul(&j, &v, &mut out);
            let direct = j.transpose() * DVector::from_vec(v);
            assert!((&out - &direct).norm() <= 1e-13 * direct.norm());
        }
    }

    #[test]
    fn gram_least_squares_matches_qr_when_well_conditioned() {
        let a = tall(500, 9, 17);
        let mut s = 5;
        let b = DVector::from_fn(500, |_, _| lcg(&mut s));
        let (x, r) = least_squares_gram(&a, &b, 1e8).expect("well conditioned");
        let (xq, rq) = crate::linalg::least_squares(a.clone(), b.clone(), 1e3).expect("qr");
        assert!((&x - &xq).norm() <= 1e-10 * xq.norm(), "{x} vs {xq}");
        assert!((r - rq).abs() <= 1e-10 * rq);
        // f32 on the same problem, with the f32 guard
        let a32 = a.map(|v| v as f32);
        let b32 = b.map(|v| v as f32);
        let (x32, _) = least_squares_gram(&a32, &b32, max_condition::<f32>()).expect("f32");
        let e = x32.map(f64::from) - &xq;
        assert!(e.norm() <= 1e-3 * xq.norm(), "f32 error {}", e.norm());
    }

    #[test]
    fn regressor_gram_equals_the_stacked_system() {
        let (n, q) = (700, 8);
        let mut s = 41;
        let reg = DMatrix::from_fn(n, q, |_, j| {
            crate::scalar::Complex::new(lcg(&mut s), lcg(&mut s)) * 10f64.powi(j as i32 - 4)
        });
        let w: Vec<f64> = (0..n).map(|k| 1.0 + 0.5 * (k as f64).sin()).collect();
        for (norm, w) in [
            (0, Some(w.as_slice())),
            (3, None),
            (q - 1, Some(w.as_slice())),
        ] {
            let mut a = DMatrix::zeros(0, 0);
            let mut b = DVector::zeros(0);
            crate::linalg::normalised_into(&reg, w, norm, &mut a, &mut b);
            let (x, r) = least_squares_gram(&a, &b, 1e8).expect("stacked");
            let (xr, rr) = regressor_least_squares_gram(&reg, w, norm, 1e8).expect("blocks");
            assert!((&x - &xr).norm() <= 1e-12 * x.norm(), "{x} vs {xr}");
            assert!((r - rr).abs() <= 1e-12 * r);
        }
        assert!(regressor_least_squares_gram(&reg, Some(&w[1..]), 0, 1e8).is_none());
        assert!(
            regressor_least_squares_gram(&reg.columns(0, 1).into_owned(), None, 0, 1e8).is_none()
        );
    }

    #[test]
    fn ill_conditioned_or_rank_deficient_is_refused() {
        // two nearly parallel columns: κ(A) ≈ 1e6, κ(Gₛ) ≈ 1e12 > 1e8
        let mut a = tall(300, 4, 9);
        for k in 0..300 {
            a[(k, 3)] = a[(k, 2)] * 1e2 + 1e-6 * a[(k, 0)];
        }
        let b = DVector::from_element(300, 1.0);
        assert!(least_squares_gram(&a, &b, 1e8).is_none());
        // exactly zero column
        let mut z = tall(50, 3, 1);
        z.column_mut(1).fill(0.0);
        assert!(least_squares_gram(&z, &DVector::from_element(50, 1.0), 1e8).is_none());
        // a moderately conditioned one passes in f64 but not with the f32 guard
        let mut c = tall(300, 4, 9);
        for k in 0..300 {
            c[(k, 3)] = c[(k, 2)] * 1e2 + 1e-1 * c[(k, 3)];
        }
        let g = c.transpose() * &c;
        let sc = scaled_cholesky(&g, 1e8).expect("κ below 1e8");
        assert!(sc.condition > 1e3, "κ = {}", sc.condition);
        assert!(scaled_cholesky(&g.map(|v| v as f32), max_condition::<f32>()).is_none());
    }
}
