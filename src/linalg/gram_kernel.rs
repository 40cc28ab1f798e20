//! The Gram matrix G = JᵀJ of a tall column-major matrix by column dot products in
//! register tiles: only the upper triangle of tiles is computed (G is symmetric), J is read
//! in place (no packed copies), and the 16 dot products of a tile are accumulated in
//! vector registers, 8 (AVX-512) or 4 (AVX2 + FMA) rows at a time, the instruction set
//! chosen at run time. For f64 on x86-64; elsewhere the caller forms the product.
//!
//! For the tall, narrow blocks of the accumulated normal equations (a few hundred rows,
//! p ≲ 30 columns) this does about half the arithmetic of a general matrix product and
//! none of its packing.

use crate::scalar::Real;

/// Columns per tile side: a tile is the 4 × 4 block of G between two groups of 4 columns.
const TILE: usize = 4;

/// The 4 × 4 dot products of the columns `a` with the columns `b` (all of length m).
type Dots = [[f64; TILE]; TILE];

/// G (`accumulate`: G +=) JᵀJ for J with `m` rows and `p` columns stored column by column in
/// `j` (length m·p), into the column-major p × p `g` (both triangles written). `false`
/// (nothing written) where no vector kernel runs: a scalar type other than f64, or a
/// processor without AVX2 and FMA; the caller then forms the product otherwise.
pub(crate) fn gram_columns<T: Real>(
    j: &[T],
    m: usize,
    p: usize,
    g: &mut [T],
    accumulate: bool,
) -> bool {
    debug_assert_eq!(j.len(), m * p);
    debug_assert_eq!(g.len(), p * p);
    if std::any::TypeId::of::<T>() != std::any::TypeId::of::<f64>() || p == 0 {
        return false;
    }
    // SAFETY: T is f64 (checked above), so the slices are slices of f64
    let (j, g) = unsafe {
        (
            std::slice::from_raw_parts(j.as_ptr().cast::<f64>(), j.len()),
            std::slice::from_raw_parts_mut(g.as_mut_ptr().cast::<f64>(), g.len()),
        )
    };
    run(j, m, p, g, accumulate)
}

#[cfg(target_arch = "x86_64")]
fn run(j: &[f64], m: usize, p: usize, g: &mut [f64], accumulate: bool) -> bool {
    if std::arch::is_x86_feature_detected!("avx512f") && !force_avx2() {
        // SAFETY: the feature the function is compiled for was detected above
        unsafe { avx512::gram(j, m, p, g, accumulate) };
        return true;
    }
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: as above
        unsafe { avx2::gram(j, m, p, g, accumulate) };
        return true;
    }
    false
}

#[cfg(not(target_arch = "x86_64"))]
fn run(_: &[f64], _: usize, _: usize, _: &mut [f64], _: bool) -> bool {
    false
}

/// The AVX2 kernel even where AVX-512 is available (the unit tests run both).
#[cfg(target_arch = "x86_64")]
fn force_avx2() -> bool {
    #[cfg(test)]
    {
        tests::FORCE_AVX2.with(std::cell::Cell::get)
    }
    #[cfg(not(test))]
    {
        false
    }
}

/// The tiles of the upper triangle of G, each from `tile`; a last group of fewer than 4
/// columns repeats its last column (the repeats are computed and not stored).
#[inline(always)]
fn tiles(
    j: &[f64],
    m: usize,
    p: usize,
    g: &mut [f64],
    accumulate: bool,
    tile: impl Fn(&[&[f64]; TILE], &[&[f64]; TILE]) -> Dots,
) {
    let column = |c: usize| &j[c * m..(c + 1) * m];
    let group = |k: usize| -> [usize; TILE] { std::array::from_fn(|t| (k * TILE + t).min(p - 1)) };
    let groups = p.div_ceil(TILE);
    for gi in 0..groups {
        let ci = group(gi);
        let a = ci.map(column);
        for gj in gi..groups {
            let cj = group(gj);
            let dots = tile(&a, &cj.map(column));
            for (ti, &i) in ci.iter().enumerate() {
                for (tj, &k) in cj.iter().enumerate() {
                    if i != gi * TILE + ti || k != gj * TILE + tj || (gi == gj && k < i) {
                        continue;
                    }
                    let v = dots[ti][tj];
                    let upper = i + k * p;
                    g[upper] = if accumulate { g[upper] + v } else { v };
                    if i != k {
                        g[k + i * p] = g[upper];
                    }
                }
            }
        }
    }
}

/// The rows from `from` on (past the last full vector), added to a tile's dot products.
#[inline(always)]
fn tail(a: &[&[f64]; TILE], b: &[&[f64]; TILE], from: usize, dots: &mut Dots) {
    for (di, ai) in dots.iter_mut().zip(a) {
        for (d, bj) in di.iter_mut().zip(b) {
            *d += ai[from..]
                .iter()
                .zip(&bj[from..])
                .map(|(x, y)| x * y)
                .sum::<f64>();
        }
    }
}

/// A kernel for one vector width: `$lanes` rows of a tile's columns per vector register,
/// the 16 accumulators of a tile in registers.
macro_rules! vector_kernel {
    ($module:ident, $feature:literal, $lanes:literal, $vec:ident, $zero:ident, $load:ident,
     $fma:ident, $store:ident) => {
        #[cfg(target_arch = "x86_64")]
        mod $module {
            use super::{Dots, TILE, tail, tiles};
            use std::arch::x86_64::*;

            /// [`super::gram_columns`] for f64.
            #[target_feature(enable = $feature)]
            pub(super) fn gram(j: &[f64], m: usize, p: usize, g: &mut [f64], accumulate: bool) {
                tiles(j, m, p, g, accumulate, |a, b| tile(a, b));
            }

            #[inline]
            #[target_feature(enable = $feature)]
            fn tile(a: &[&[f64]; TILE], b: &[&[f64]; TILE]) -> Dots {
                let m = a[0].len();
                let body = m - m % $lanes;
                let mut acc: [[$vec; TILE]; TILE] = [[$zero(); TILE]; TILE];
                for r in (0..body).step_by($lanes) {
                    // SAFETY: r + $lanes ≤ body ≤ m, the length of every column
                    let (va, vb): ([$vec; TILE], [$vec; TILE]) = unsafe {
                        (
                            std::array::from_fn(|t| $load(a[t].as_ptr().add(r))),
                            std::array::from_fn(|t| $load(b[t].as_ptr().add(r))),
                        )
                    };
                    for (acc_i, ai) in acc.iter_mut().zip(&va) {
                        for (acc_ij, bj) in acc_i.iter_mut().zip(&vb) {
                            *acc_ij = $fma(*ai, *bj, *acc_ij);
                        }
                    }
                }
                let mut dots = [[0.0; TILE]; TILE];
                for (di, acc_i) in dots.iter_mut().zip(&acc) {
                    for (d, v) in di.iter_mut().zip(acc_i) {
                        let mut lanes = [0.0f64; $lanes];
                        // SAFETY: `lanes` holds one vector
                        unsafe { $store(lanes.as_mut_ptr(), *v) };
                        *d = lanes.iter().sum();
                    }
                }
                tail(a, b, body, &mut dots);
                dots
            }
        }
    };
}

vector_kernel!(
    avx512,
    "avx512f",
    8,
    __m512d,
    _mm512_setzero_pd,
    _mm512_loadu_pd,
    _mm512_fmadd_pd,
    _mm512_storeu_pd
);
vector_kernel!(
    avx2,
    "avx2,fma",
    4,
    __m256d,
    _mm256_setzero_pd,
    _mm256_loadu_pd,
    _mm256_fmadd_pd,
    _mm256_storeu_pd
);

#[cfg(test)]
mod tests {
    use super::*;

    thread_local! {
        /// Runs the AVX2 kernel where AVX-512 is available.
        pub(super) static FORCE_AVX2: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    }

    /// G from the definition, column dot products in row order.
    fn reference(j: &[f64], m: usize, p: usize) -> Vec<f64> {
        let mut g = vec![0.0; p * p];
        for i in 0..p {
            for k in 0..p {
                g[i + k * p] = (0..m).map(|r| j[r + i * m] * j[r + k * m]).sum();
            }
        }
        g
    }

    fn check_every_shape() {
        let mut seed = 7u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for p in 1..=11 {
            for m in [0, 1, 3, 7, 8, 9, 17, 64, 130] {
                let j: Vec<f64> = (0..m * p).map(|_| next()).collect();
                let want = reference(&j, m, p);
                let mut g = vec![f64::NAN; p * p];
                if !gram_columns(&j, m, p, &mut g, false) {
                    return; // no vector kernel on this processor
                }
                for (x, y) in g.iter().zip(&want) {
                    assert!(
                        (x - y).abs() <= 1e-13 * (1.0 + y.abs()),
                        "m {m} p {p}: {x} vs {y}"
                    );
                }
                // accumulating adds the product once more
                assert!(gram_columns(&j, m, p, &mut g, true));
                for (x, y) in g.iter().zip(&want) {
                    assert!(
                        (x - 2.0 * y).abs() <= 1e-13 * (1.0 + y.abs()),
                        "m {m} p {p}"
                    );
                }
            }
        }
    }

    #[test]
    fn matches_the_definition_for_every_shape() {
        check_every_shape();
    }

    #[test]
    fn the_avx2_kernel_matches_the_definition() {
        FORCE_AVX2.with(|f| f.set(true));
        check_every_shape();
        FORCE_AVX2.with(|f| f.set(false));
    }

    #[test]
    fn other_scalar_types_are_left_to_the_caller() {
        let mut g = vec![0.0f32; 4];
        assert!(!gram_columns(&[1.0f32; 6], 3, 2, &mut g, false));
        assert_eq!(g, vec![0.0; 4]);
    }
}
