//! The Gram matrix G = JᵀJ of a tall column-major matrix by column dot products in
//! register tiles: only the upper triangle of tiles is computed (G is symmetric), J is read
//! in place (no packed copies), and the 16 dot products of a 4 × 4 tile are accumulated
//! in vector registers, for f64 and f32.
//!
//! **One summation order on every path.** Each dot product Σᵣ aᵣbᵣ of m rows is summed in
//! W lanes, W = 4 for f64 and 8 for f32 (one 256-bit register): lane l takes the rows
//! l, l + W, l + 2W, … below m − m mod W in turn, each by one fused multiply-add
//! (aᵣbᵣ + s rounded once) from zero; the lanes are added pairwise,
//! (s₀ + s₁) + (s₂ + s₃) (and so on for eight); then the last m mod W rows are added in
//! turn, each by a fused multiply-add. The three paths ([`super::simd::SimdPath`]) compute
//! exactly these operations and so give the same bits: the scalar path with `mul_add`,
//! AVX2 with one register a dot product, AVX-512 with two dot products a register (their
//! lanes side by side, each in the order above).
//!
//! For the tall, narrow blocks of the accumulated normal equations (a few hundred rows,
//! p ≲ 30 columns) this does about half the arithmetic of a general matrix product and
//! none of its packing.

use super::simd::{self, SimdPath};
use crate::scalar::Real;
use num_traits::Float;
use std::any::TypeId;

/// Columns per tile side: a tile is the 4 × 4 block of G between two groups of 4 columns.
const TILE: usize = 4;

/// The 4 × 4 dot products of the columns `a` with the columns `b` (all of length m).
type Dots<E> = [[E; TILE]; TILE];

/// G (`accumulate`: G +=) JᵀJ for J with `m` rows and `p` columns stored column by column in
/// `j` (length m·p), into the column-major p × p `g` (both triangles written), on the
/// active [`SimdPath`]. `false` (nothing written) for a scalar type other than f64 and
/// f32; the caller then forms the product otherwise.
pub(crate) fn gram_columns<T: Real>(
    j: &[T],
    m: usize,
    p: usize,
    g: &mut [T],
    accumulate: bool,
) -> bool {
    gram_columns_on(simd::active(), j, m, p, g, accumulate)
}

/// [`gram_columns`] on `path` (which the processor must support).
fn gram_columns_on<T: Real>(
    path: SimdPath,
    j: &[T],
    m: usize,
    p: usize,
    g: &mut [T],
    accumulate: bool,
) -> bool {
    debug_assert_eq!(j.len(), m * p);
    debug_assert_eq!(g.len(), p * p);
    debug_assert!(path.is_supported());
    if let (Some(j), Some(g)) = (cast::<T, f64>(j), cast_mut::<T, f64>(g)) {
        match path {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the path is supported by the processor (checked where it is chosen)
            SimdPath::Avx512 => unsafe { f64_kernels::avx512::gram(j, m, p, g, accumulate) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above
            SimdPath::Avx2 => unsafe { f64_kernels::avx2::gram(j, m, p, g, accumulate) },
            _ => tiles(j, m, p, g, accumulate, tile_scalar::<f64, 4>),
        }
        return true;
    }
    if let (Some(j), Some(g)) = (cast::<T, f32>(j), cast_mut::<T, f32>(g)) {
        match path {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above
            SimdPath::Avx512 => unsafe { f32_kernels::avx512::gram(j, m, p, g, accumulate) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above
            SimdPath::Avx2 => unsafe { f32_kernels::avx2::gram(j, m, p, g, accumulate) },
            _ => tiles(j, m, p, g, accumulate, tile_scalar::<f32, 8>),
        }
        return true;
    }
    false
}

/// `s` as a slice of `E` when `T` is `E`.
fn cast<T: 'static, E: 'static>(s: &[T]) -> Option<&[E]> {
    // SAFETY: T is E (checked), so the slice is a slice of E
    (TypeId::of::<T>() == TypeId::of::<E>())
        .then(|| unsafe { std::slice::from_raw_parts(s.as_ptr().cast::<E>(), s.len()) })
}

/// `s` as a mutable slice of `E` when `T` is `E`.
fn cast_mut<T: 'static, E: 'static>(s: &mut [T]) -> Option<&mut [E]> {
    // SAFETY: T is E (checked), so the slice is a slice of E
    (TypeId::of::<T>() == TypeId::of::<E>())
        .then(|| unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast::<E>(), s.len()) })
}

/// The tiles of the upper triangle of G, each from `tile`; a last group of fewer than 4
/// columns repeats its last column (the repeats are computed and not stored).
#[inline(always)]
fn tiles<E: Float>(
    j: &[E],
    m: usize,
    p: usize,
    g: &mut [E],
    accumulate: bool,
    tile: impl Fn(&[&[E]; TILE], &[&[E]; TILE]) -> Dots<E>,
) {
    if p == 0 {
        return;
    }
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

/// The dot product from its `W` lane sums and the rows from `from` on: the lanes added
/// pairwise, then the rows in turn, each by a fused multiply-add. Every path ends with
/// this same code.
#[inline(always)]
fn finish<E: Float, const W: usize>(mut lanes: [E; W], a: &[E], b: &[E], from: usize) -> E {
    let mut n = W;
    while n > 1 {
        for i in 0..n / 2 {
            lanes[i] = lanes[2 * i] + lanes[2 * i + 1];
        }
        n /= 2;
    }
    let mut d = lanes[0];
    for (x, y) in a[from..].iter().zip(&b[from..]) {
        d = x.mul_add(*y, d);
    }
    d
}

/// A tile's dot products in plain arithmetic, lane by lane in the order of the vector
/// paths.
fn tile_scalar<E: Float, const W: usize>(a: &[&[E]; TILE], b: &[&[E]; TILE]) -> Dots<E> {
    let m = a[0].len();
    let body = m - m % W;
    let mut acc = [[[E::zero(); W]; TILE]; TILE];
    for r in (0..body).step_by(W) {
        for (acc_i, ai) in acc.iter_mut().zip(a) {
            let ai = &ai[r..r + W];
            for (acc_ij, bj) in acc_i.iter_mut().zip(b) {
                for ((s, x), y) in acc_ij.iter_mut().zip(ai).zip(&bj[r..r + W]) {
                    *s = x.mul_add(*y, *s);
                }
            }
        }
    }
    std::array::from_fn(|i| std::array::from_fn(|k| finish(acc[i][k], a[i], b[k], body)))
}

/// A path's entry `gram` ([`gram_columns`] on it): its `tile` over the tiles of G, compiled
/// for the target features `$feature`.
macro_rules! gram_entry {
    ($elem:ty, $feature:literal) => {
        /// [`super::super::gram_columns`] on this path.
        #[target_feature(enable = $feature)]
        pub(in super::super) fn gram(
            j: &[$elem],
            m: usize,
            p: usize,
            g: &mut [$elem],
            accumulate: bool,
        ) {
            tiles(j, m, p, g, accumulate, |a, b| tile(a, b));
        }
    };
}

/// The AVX2 and AVX-512 kernels of one element type: `$w` elements in a 256-bit register.
macro_rules! vector_kernels {
    ($module:ident, $elem:ty, $w:literal, $v256:ident, $v512:ident, $zero256:ident,
     $zero512:ident, $load:ident, $fma256:ident, $fma512:ident, $store256:ident,
     $store512:ident, $widen:expr, $pair:expr) => {
        #[cfg(target_arch = "x86_64")]
        mod $module {
            /// One register a dot product.
            pub(super) mod avx2 {
                use super::super::{Dots, TILE, finish, tiles};
                use std::arch::x86_64::*;

                gram_entry!($elem, "avx2,fma");

                /// A tile as two halves of 4 × 2 dot products: 8 accumulators, the 4
                /// columns of `a` and one of `b` fit in the 16 registers (a whole tile's
                /// 16 accumulators do not, and spill).
                #[inline]
                #[target_feature(enable = "avx2,fma")]
                fn tile(a: &[&[$elem]; TILE], b: &[&[$elem]; TILE]) -> Dots<$elem> {
                    let m = a[0].len();
                    let body = m - m % $w;
                    let mut dots = [[0.0; TILE]; TILE];
                    for half in 0..2 {
                        let b = [b[2 * half], b[2 * half + 1]];
                        let mut acc: [[$v256; 2]; TILE] = [[$zero256(); 2]; TILE];
                        for r in (0..body).step_by($w) {
                            // SAFETY: r + W ≤ body ≤ m, the length of every column
                            let (va, vb): ([$v256; TILE], [$v256; 2]) = unsafe {
                                (
                                    std::array::from_fn(|t| $load(a[t].as_ptr().add(r))),
                                    std::array::from_fn(|t| $load(b[t].as_ptr().add(r))),
                                )
                            };
                            for (acc_i, ai) in acc.iter_mut().zip(&va) {
                                for (acc_ij, bj) in acc_i.iter_mut().zip(&vb) {
                                    *acc_ij = $fma256(*ai, *bj, *acc_ij);
                                }
                            }
                        }
                        for (i, acc_i) in acc.iter().enumerate() {
                            for (k, v) in acc_i.iter().enumerate() {
                                let mut lanes = [0.0; $w];
                                // SAFETY: `lanes` holds one register
                                unsafe { $store256(lanes.as_mut_ptr(), *v) };
                                dots[i][2 * half + k] = finish(lanes, a[i], b[k], body);
                            }
                        }
                    }
                    dots
                }
            }

            /// Two dot products a register: a column of the tile's first group in both
            /// halves, two columns of its second group side by side.
            pub(super) mod avx512 {
                use super::super::{Dots, TILE, finish, tiles};
                use std::arch::x86_64::*;

                gram_entry!($elem, "avx512f,avx2,fma");

                #[inline]
                #[target_feature(enable = "avx512f,avx2,fma")]
                fn tile(a: &[&[$elem]; TILE], b: &[&[$elem]; TILE]) -> Dots<$elem> {
                    let m = a[0].len();
                    let body = m - m % $w;
                    let mut acc: [[$v512; TILE / 2]; TILE] = [[$zero512(); TILE / 2]; TILE];
                    let widen: fn($v256) -> $v512 = $widen;
                    let pair: fn($v256, $v256) -> $v512 = $pair;
                    for r in (0..body).step_by($w) {
                        // SAFETY: r + W ≤ body ≤ m, the length of every column
                        let (va, vb): ([$v512; TILE], [$v512; TILE / 2]) = unsafe {
                            (
                                std::array::from_fn(|t| widen($load(a[t].as_ptr().add(r)))),
                                std::array::from_fn(|h| {
                                    pair(
                                        $load(b[2 * h].as_ptr().add(r)),
                                        $load(b[2 * h + 1].as_ptr().add(r)),
                                    )
                                }),
                            )
                        };
                        for (acc_i, ai) in acc.iter_mut().zip(&va) {
                            for (acc_ih, bh) in acc_i.iter_mut().zip(&vb) {
                                *acc_ih = $fma512(*ai, *bh, *acc_ih);
                            }
                        }
                    }
                    let mut dots = [[0.0; TILE]; TILE];
                    for (i, acc_i) in acc.iter().enumerate() {
                        for (h, v) in acc_i.iter().enumerate() {
                            let mut lanes = [[0.0; $w]; 2];
                            // SAFETY: `lanes` holds one register
                            unsafe { $store512(lanes.as_mut_ptr().cast(), *v) };
                            for (half, l) in lanes.into_iter().enumerate() {
                                let k = 2 * h + half;
                                dots[i][k] = finish(l, a[i], b[k], body);
                            }
                        }
                    }
                    dots
                }
            }
        }
    };
}

vector_kernels!(
    f64_kernels,
    f64,
    4,
    __m256d,
    __m512d,
    _mm256_setzero_pd,
    _mm512_setzero_pd,
    _mm256_loadu_pd,
    _mm256_fmadd_pd,
    _mm512_fmadd_pd,
    _mm256_storeu_pd,
    _mm512_storeu_pd,
    |v| _mm512_broadcast_f64x4(v),
    |lo, hi| _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(lo), hi)
);
vector_kernels!(
    f32_kernels,
    f32,
    8,
    __m256,
    __m512,
    _mm256_setzero_ps,
    _mm512_setzero_ps,
    _mm256_loadu_ps,
    _mm256_fmadd_ps,
    _mm512_fmadd_ps,
    _mm256_storeu_ps,
    _mm512_storeu_ps,
    |v| _mm512_castpd_ps(_mm512_broadcast_f64x4(_mm256_castps_pd(v))),
    |lo, hi| {
        _mm512_castpd_ps(_mm512_insertf64x4::<1>(
            _mm512_castpd256_pd512(_mm256_castps_pd(lo)),
            _mm256_castps_pd(hi),
        ))
    }
);

#[cfg(test)]
mod tests {
    use super::*;

    /// G from the definition, column dot products in row order, in f64.
    fn reference<E: Float>(j: &[E], m: usize, p: usize) -> Vec<f64> {
        let mut g = vec![0.0; p * p];
        for i in 0..p {
            for k in 0..p {
                g[i + k * p] = (0..m)
                    .map(|r| j[r + i * m].to_f64().unwrap() * j[r + k * m].to_f64().unwrap())
                    .sum();
            }
        }
        g
    }

    /// Uniform values in [−0.5, 0.5) from a fixed seed.
    fn values<E: Float>(n: usize, seed: u64) -> Vec<E> {
        let mut seed = seed;
        (0..n)
            .map(|_| {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                E::from((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5).unwrap()
            })
            .collect()
    }

    /// Every supported path against the definition (to `tol`) and against the scalar path
    /// (bit for bit), writing and accumulating, for many shapes.
    fn check_every_shape<E: Real>(tol: f64) {
        for p in 1..=11 {
            for m in [0, 1, 3, 7, 8, 9, 15, 16, 17, 64, 130] {
                let j: Vec<E> = values(m * p, (7 * p + m) as u64);
                let want = reference(&j, m, p);
                let mut scalar = vec![E::nan(); p * p];
                assert!(gram_columns_on(
                    SimdPath::Scalar,
                    &j,
                    m,
                    p,
                    &mut scalar,
                    false
                ));
                for (x, y) in scalar.iter().zip(&want) {
                    let x = x.to_f64().unwrap();
                    assert!(
                        (x - y).abs() <= tol * (1.0 + y.abs()),
                        "m {m} p {p}: {x} vs {y}"
                    );
                }
                let mut twice = scalar.clone();
                assert!(gram_columns_on(
                    SimdPath::Scalar,
                    &j,
                    m,
                    p,
                    &mut twice,
                    true
                ));
                for (x, y) in twice.iter().zip(&scalar) {
                    assert_eq!(*x, *y + *y, "m {m} p {p}: accumulating adds it once more");
                }
                for path in SimdPath::supported() {
                    let mut g = vec![E::nan(); p * p];
                    assert!(gram_columns_on(path, &j, m, p, &mut g, false));
                    let bits = |v: &[E]| {
                        v.iter()
                            .map(|x| x.to_f64().unwrap().to_bits())
                            .collect::<Vec<_>>()
                    };
                    assert_eq!(bits(&g), bits(&scalar), "{path}: m {m} p {p}");
                    assert!(gram_columns_on(path, &j, m, p, &mut g, true));
                    assert_eq!(bits(&g), bits(&twice), "{path}: m {m} p {p}, accumulated");
                }
            }
        }
    }

    #[test]
    fn every_path_gives_the_scalar_bits_in_f64() {
        check_every_shape::<f64>(1e-13);
    }

    #[test]
    fn every_path_gives_the_scalar_bits_in_f32() {
        check_every_shape::<f32>(1e-5);
    }

    /// The summation order of the module documentation, written out for one dot product:
    /// a change of lanes, tree or tail order on any path fails here.
    #[test]
    fn the_documented_order() {
        for (m, seed) in [(23, 1u64), (4, 2), (3, 3), (41, 4)] {
            let a: Vec<f64> = values(m, seed);
            let b: Vec<f64> = values(m, seed + 10);
            let body = m - m % 4;
            let mut lanes = [0.0f64; 4];
            for r in 0..body {
                lanes[r % 4] = a[r].mul_add(b[r], lanes[r % 4]);
            }
            let mut want = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
            for r in body..m {
                want = a[r].mul_add(b[r], want);
            }
            // J = [a b]: G₀₁ is a·b
            let j: Vec<f64> = a.iter().chain(&b).copied().collect();
            for path in SimdPath::supported() {
                let mut g = vec![0.0; 4];
                gram_columns_on(path, &j, m, 2, &mut g, false);
                assert_eq!(g[2].to_bits(), want.to_bits(), "{path}, m {m}");
            }
        }
    }

    /// Values whose sum depends on its order (cancelling terms of very different sizes):
    /// the paths agree on these too.
    #[test]
    fn order_sensitive_sums_agree() {
        let m = 203;
        let j: Vec<f64> = (0..3 * m)
            .map(|i| {
                let x = ((i * 7919) % 1013) as f64 - 506.0;
                x * 10f64.powi((i % 17) as i32 - 8)
            })
            .collect();
        let mut scalar = vec![0.0; 9];
        gram_columns_on(SimdPath::Scalar, &j, m, 3, &mut scalar, false);
        for path in SimdPath::supported() {
            let mut g = vec![0.0; 9];
            gram_columns_on(path, &j, m, 3, &mut g, false);
            assert_eq!(g, scalar, "{path}");
        }
    }

    #[test]
    fn no_columns_write_nothing() {
        let mut g: Vec<f64> = vec![];
        assert!(gram_columns::<f64>(&[], 5, 0, &mut g, false));
    }
}
