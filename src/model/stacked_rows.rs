//! The rows of the output-error Jacobian written in one pass
//! ([`super::ModelStructure::stacked_jacobian_into`]): s_k·(∂G/∂θ_j·U_k) real-stacked,
//! s_k = −w_k (−1 without weights), each value rounded as the three passes round it
//! (∂G/∂θ, then ∂Ŷ/∂θ = ∂G/∂θ·U, then the weighted stacking).

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
        let minus_one = -T::one();
        // s_k as the stacking of ∂Ŷ/∂θ rounds it: sign times weight
        let s = self.weight.map_or(minus_one, |w| minus_one * w[k]);
        let v = d * self.u[k];
        out[0] = v.re * s;
        out[1] = v.im * s;
    }
}
