//! The input's noise of an FRF matrix column (errors in variables), in FRF units.

use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DVector};

/// The noise of the measured input of one column of an FRF matrix at one line, scaled to
/// the FRF: with the column measured as Ĝ = Y/U from averaged spectra whose noise δY, δU
/// has the output covariance C_Y, the output–input covariance c_YU (ny) and the input
/// variance σ²_U,
///
/// ```text
/// δĜ ≈ (δY − G δU)/U,
/// Cov(δĜ) = C − c Gᴴ − G cᴴ + G Gᴴ s,   C = C_Y/|U|²,  c = c_YU/|U|²,  s = σ²_U/|U|²
/// ```
///
/// (first order in the noise; McKelvey's errors-in-variables weight with one input). C is
/// the covariance attached by [`crate::data::FrfMatrix::with_covariances`]; this holds c
/// and s. An input sensor's noise that does not drive the system adds G Gᴴ s, largest
/// at the resonances; input noise that drives the system (δY = G δU + e) cancels.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct InputNoise<T: Real> {
    /// c = c_YU/|U|² (ny).
    pub cross: DVector<Complex<T>>,
    /// s = σ²_U/|U|².
    pub relative_variance: T,
}

impl<T: Real> InputNoise<T> {
    /// Cov(δĜ) = C − c gᴴ − g cᴴ + g gᴴ s for the column's response `g` (ny) and its
    /// output covariance `c` (ny × ny).
    pub fn covariance_at(
        &self,
        output_covariance: &DMatrix<Complex<T>>,
        g: &DVector<Complex<T>>,
    ) -> DMatrix<Complex<T>> {
        let cross_g = &self.cross * g.adjoint();
        output_covariance - &cross_g - cross_g.adjoint()
            + g * g.adjoint() * Complex::new(self.relative_variance, T::zero())
    }
}
