//! The rows of the output-error Jacobian written in one pass
//! ([`super::ModelStructure::stacked_jacobian_into`]): s_k·(∂G/∂θ_j·U_k) real-stacked,
//! s_k = −w_k (−1 without weights), either each value rounded as the three passes round
//! it (∂G/∂θ, then ∂Ŷ/∂θ = ∂G/∂θ·U, then the weighted stacking: [`StackedRows::write`]),
//! or as φ_j·(f_k·U_k·s_k) from a factor f_k of the line scaled once
//! ([`StackedRows::scaled`], [`StackedRows::write_scaled`]): one complex product a value
//! instead of two and a scaling, within a few units of rounding of the first.

use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;

/// The inputs and scaling of one pass over N lines.
pub(crate) struct StackedRows<'a, T: Real> {
    u: &'a [Complex<T>],
    weight: Option<&'a [T]>,
}

impl<'a, T: Real> StackedRows<'a, T> {
    /// The pass over `omega`'s N lines, when N > 0 and U, the weights, `g` (N) and `jac`
    /// (2N × `p`) agree with it; `None` otherwise.
    pub(crate) fn new(
        omega: &[T],
        u: &'a [Complex<T>],
        weight: Option<&'a [T]>,
        g: &[Complex<T>],
        jac: &DMatrix<T>,
        p: usize,
    ) -> Option<Self> {
        let n = omega.len();
        let fits = n > 0
            && u.len() == n
            && g.len() == n
            && weight.is_none_or(|w| w.len() == n)
            && jac.shape() == (2 * n, p);
        fits.then_some(Self { u, weight })
    }

    /// Writes (`d`·U_k)·s_k, d = ∂G(ω_k)/∂θ_j, into the row pair `out` of line k.
    #[inline]
    pub(crate) fn write(&self, out: &mut [T], d: Complex<T>, k: usize) {
        let v = d * self.u[k];
        let s = self.sign_weight(k);
        out[0] = v.re * s;
        out[1] = v.im * s;
    }

    /// (`f`·U_k)·s_k: a factor of line k's row pair scaled once, so that each of the
    /// line's values φ_j·f·U_k·s_k costs one complex product (see
    /// [`StackedRows::write_scaled`]).
    #[inline]
    pub(crate) fn scaled(&self, f: Complex<T>, k: usize) -> Complex<T> {
        (f * self.u[k]).scale(self.sign_weight(k))
    }

    /// Writes `p`·`scaled` (a factor from [`StackedRows::scaled`]) into the row pair `out`.
    #[inline]
    pub(crate) fn write_scaled(out: &mut [T], p: Complex<T>, scaled: Complex<T>) {
        let v = p * scaled;
        out[0] = v.re;
        out[1] = v.im;
    }

    /// s_k as the stacking of ∂Ŷ/∂θ rounds it: sign times weight.
    #[inline]
    fn sign_weight(&self, k: usize) -> T {
        let minus_one = -T::one();
        self.weight.map_or(minus_one, |w| minus_one * w[k])
    }
}
