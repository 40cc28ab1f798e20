//! Linear-algebra kernels shared by the models, criteria and solvers: dense least squares
//! by QR and SVD ([`least_squares`]), a never-panicking SVD, the guarded normal equations
//! over blocks of lines (`gram`), Householder reflectors (`householder`), the eigenvalues
//! of a real matrix (`eigenvalues`), independent items in parallel (`parallel`) and the
//! choice of vector instructions ([`simd`]).
//!
//! **One answer on every processor.** A kernel that picks its instructions at run time
//! (the Gram matrix JᵀJ of the normal equations, on the scalar, AVX2 or AVX-512 path)
//! computes the same operations in the same order on every path: each dot product in
//! W lanes (W = 4 for f64, 8 for f32: one 256-bit register), lane l taking rows
//! l, l + W, … in turn by fused multiply-adds from zero, the lanes added pairwise
//! ((s₀ + s₁) + (s₂ + s₃), …), then the last rows in turn by fused multiply-adds. A wider
//! register holds several such dot products side by side, never more lanes of one. A fit
//! (θ, cost, stages, every decision of the pipeline and the workflow) is therefore the same
//! bits whatever the processor; `FDID_SIMD=scalar|avx2|avx512` ([`simd`]) forces a path to
//! check it. The kernels compiled for every processor alike (the finiteness tests, the
//! whiteness test's lanes) fix their lanes in the source and are the same by construction.
//! The dependencies' own run-time choices (rustfft's FFTs, nalgebra's matrix products
//! through matrixmultiply, the C library's elementary functions) are the same on every
//! processor with AVX2 and FMA, with or without AVX-512; on an x86-64 processor without
//! them they round differently (relative differences near 10⁻¹⁰ in a report, the same
//! decisions).

pub(crate) mod eigenvalues;
pub(crate) mod gram;
mod gram_kernel;
pub(crate) mod householder;
mod lstsq;
pub(crate) mod nonnegative_qp;
pub(crate) mod parallel;
pub mod simd;

pub use lstsq::least_squares;
pub(crate) use lstsq::{check_shape, equilibrate_columns, svd_of_r};

use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DVector};

/// Copies complex rows into real-stacked form: row k becomes rows 2k (real part) and 2k + 1
/// (imaginary part), each scaled by `weight[k]`.
pub(crate) fn stack_rows<T: Real>(m: &DMatrix<Complex<T>>, weight: Option<&[T]>) -> DMatrix<T> {
    let (n, p) = m.shape();
    let mut out = DMatrix::<T>::zeros(2 * n, p);
    for j in 0..p {
        for k in 0..n {
            let w = weight.map_or(T::one(), |w| w[k]);
            let v = m[(k, j)];
            out[(2 * k, j)] = v.re * w;
            out[(2 * k + 1, j)] = v.im * w;
        }
    }
    out
}

/// The SVD of `m` (U and/or Vᵀ on request) in at most `max_niter` iterations, with the
/// singular values in no particular order; `None` when `m` is empty, when the iteration
/// does not converge or when a singular value is not finite. The entries below
/// max|mᵢⱼ|·ε² are first set to zero ([`flush_negligible`]). Unlike nalgebra's ordered
/// SVD, whose sort panics on a NaN singular value (which its iteration can produce on
/// rank-deficient or badly scaled factors), it never panics.
pub(crate) fn try_svd<T: Real>(
    mut m: DMatrix<T>,
    compute_u: bool,
    compute_v: bool,
    max_niter: usize,
) -> Option<nalgebra::SVD<T, nalgebra::Dyn, nalgebra::Dyn>> {
    if m.is_empty() {
        return None;
    }
    flush_negligible(&mut m);
    let eps = T::default_epsilon();
    let svd = nalgebra::SVD::try_new_unordered(m, compute_u, compute_v, eps, max_niter)?;
    svd.singular_values
        .iter()
        .all(|s| num_traits::Float::is_finite(*s))
        .then_some(svd)
}

/// Sets to zero the entries of `m` below max|mᵢⱼ|·ε², before an SVD. nalgebra's SVD can
/// produce NaN singular values (and then panic while sorting them) on matrices whose
/// entries reach down to the underflow range next to entries of order one; the
/// perturbation, of norm at most √(mn)·max|mᵢⱼ|·ε², is far below the SVD's own backward
/// error ε‖m‖, so the factorisation is unchanged to rounding.
fn flush_negligible<T: Real>(m: &mut DMatrix<T>) {
    let max = m.iter().fold(T::zero(), |a, v| {
        num_traits::Float::max(a, num_traits::Float::abs(*v))
    });
    let eps = T::default_epsilon();
    let tiny = max * eps * eps;
    for v in m.iter_mut() {
        if num_traits::Float::abs(*v) < tiny {
            *v = T::zero();
        }
    }
}

/// The real-stacked system A θ ≈ b of a homogeneous regressor with one coefficient fixed
/// to one (A the other columns, b = −(normalising column)), from a regressor,
/// per-line weights and the normalising column, written into `a` (2N × (q − 1)) and `b`
/// (2N), which are resized when their shapes differ.
pub(crate) fn normalised_into<T: Real>(
    regressor: &DMatrix<Complex<T>>,
    w: Option<&[T]>,
    normalising: usize,
    a: &mut DMatrix<T>,
    b: &mut DVector<T>,
) {
    let (n, p) = regressor.shape();
    if a.shape() != (2 * n, p - 1) {
        *a = DMatrix::zeros(2 * n, p - 1);
    }
    if b.len() != 2 * n {
        *b = DVector::zeros(2 * n);
    }
    if n == 0 {
        return;
    }
    // column by column: a column of R (contiguous) into its stacked column of A or into b
    let mut cols = a.as_mut_slice().chunks_exact_mut(2 * n);
    for (j, src) in regressor.as_slice().chunks_exact(n).enumerate() {
        let dst = if j == normalising {
            b.as_mut_slice()
        } else {
            match cols.next() {
                Some(col) => col,
                None => return,
            }
        };
        let sign = if j == normalising {
            -T::one()
        } else {
            T::one()
        };
        match w {
            Some(w) => {
                for ((out, v), wk) in dst.chunks_exact_mut(2).zip(src).zip(w) {
                    let v = *v * *wk;
                    out[0] = sign * v.re;
                    out[1] = sign * v.im;
                }
            }
            None => {
                for (out, v) in dst.chunks_exact_mut(2).zip(src) {
                    out[0] = sign * v.re;
                    out[1] = sign * v.im;
                }
            }
        }
    }
}
