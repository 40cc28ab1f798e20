//! The noise of a periodic record with several channels: per line, the ny × ny covariance
//! of the output spectra and the variances of the input spectra, from the spread between
//! periods.

use crate::error::Result;
use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DVector};

/// The noise of the period-averaged spectra of a [`MimoSpectra`](super::MimoSpectra)
/// (see [`MimoSpectra::from_periods`](super::MimoSpectra::from_periods)): with d_p(k) the
/// deviation of period p's output spectra Y_p(ω_k) (a vector of the ny outputs) from their
/// mean over the P periods,
///
/// ```text
/// C_Y(k) = 1/(P(P − 1)) Σ_p d_p(k) d_p(k)ᴴ        (ny × ny, Hermitian)
/// σ²_U,j(k) = 1/(P(P − 1)) Σ_p |U_j,p(k) − Ū_j(k)|²
/// C_YU(k) = 1/(P(P − 1)) Σ_p d_p(k) e_p(k)ᴴ        (ny × nu)
/// ```
///
/// (e_p(k) the deviation of period p's input spectra), the covariances of the *means*
/// (the sample covariance between periods divided by P), with P − 1 degrees of freedom.
/// The off-diagonal entries of C_Y are the correlation of the outputs' noise (one
/// disturbance seen by several sensors); the diagonal weights a fit of the outputs; the
/// input variances and C_YU are the errors-in-variables terms of the inputs.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct MimoNoise<T: Real> {
    periods: usize,
    output_covariance: Vec<DMatrix<Complex<T>>>,
    input_variance: Vec<Vec<T>>,
    /// C_YU per line (ny × nu).
    #[cfg_attr(feature = "serde", serde(default))]
    cross_covariance: Vec<DMatrix<Complex<T>>>,
}

impl<T: Real> MimoNoise<T> {
    /// The noise of the mean over P = `periods` ≥ 2 periods of the spectra `inputs[j][p]`
    /// and `outputs[i][p]` (channel, period, line), around their means `u_mean`, `y_mean`.
    pub(crate) fn between_periods(
        inputs: &[Vec<Vec<Complex<T>>>],
        outputs: &[Vec<Vec<Complex<T>>>],
        u_mean: &[Vec<Complex<T>>],
        y_mean: &[Vec<Complex<T>>],
    ) -> Result<Self> {
        let periods = outputs[0].len();
        let lines = y_mean[0].len();
        let ny = outputs.len();
        let norm = T::from_usize_lossy(periods * (periods - 1));
        let output_covariance: Vec<DMatrix<Complex<T>>> = (0..lines)
            .map(|k| {
                let c = (0..periods).fold(DMatrix::zeros(ny, ny), |c, p| {
                    let d = DVector::from_fn(ny, |i, _| outputs[i][p][k] - y_mean[i][k]);
                    c + &d * d.adjoint()
                });
                c / Complex::new(norm, T::zero())
            })
            .collect();
        let input_variance: Vec<Vec<T>> = inputs
            .iter()
            .zip(u_mean)
            .map(|(u, mean)| {
                (0..lines)
                    .map(|k| {
                        u.iter()
                            .fold(T::zero(), |s, up| s + (up[k] - mean[k]).norm_sqr())
                            / norm
                    })
                    .collect()
            })
            .collect();
        let nu = inputs.len();
        let cross_covariance: Vec<DMatrix<Complex<T>>> = (0..lines)
            .map(|k| {
                DMatrix::from_fn(ny, nu, |i, j| {
                    (0..periods).fold(Complex::new(T::zero(), T::zero()), |s, p| {
                        s + (outputs[i][p][k] - y_mean[i][k])
                            * (inputs[j][p][k] - u_mean[j][k]).conj()
                    }) / Complex::new(norm, T::zero())
                })
            })
            .collect();
        let diagonal: Vec<T> = output_covariance
            .iter()
            .flat_map(|c| c.iter().map(|v| v.norm_sqr()))
            .collect();
        crate::error::check_finite("output noise covariance between periods", &diagonal)?;
        for v in &input_variance {
            crate::error::check_finite("input noise variance between periods", v)?;
        }
        Ok(Self {
            periods,
            output_covariance,
            input_variance,
            cross_covariance,
        })
    }

    /// The periods P averaged (P − 1 degrees of freedom).
    pub fn periods(&self) -> usize {
        self.periods
    }

    /// C_Y(ω_k), the ny × ny covariance of the averaged output spectra at line k.
    ///
    /// # Panics
    /// When k is not a line.
    pub fn output_covariance(&self, k: usize) -> &DMatrix<Complex<T>> {
        &self.output_covariance[k]
    }

    /// The variance of output i's averaged spectrum on every line (the diagonal of C_Y).
    ///
    /// # Panics
    /// When i ≥ ny.
    pub fn output_variance(&self, i: usize) -> Vec<T> {
        self.output_covariance
            .iter()
            .map(|c| c[(i, i)].re)
            .collect()
    }

    /// The variance of input j's averaged spectrum on every line.
    ///
    /// # Panics
    /// When j ≥ nu.
    pub fn input_variance(&self, j: usize) -> &[T] {
        &self.input_variance[j]
    }

    /// C_YU(ω_k), the ny × nu covariance between the averaged output and input spectra at
    /// line k, 1/(P(P − 1)) Σ_p d_Y,p d_U,pᴴ (zero for a record saved without it).
    ///
    /// # Panics
    /// When k is not a line of a record that has it.
    pub fn cross_covariance(&self, k: usize) -> &DMatrix<Complex<T>> {
        &self.cross_covariance[k]
    }

    /// The noise on the lines where `keep` is true (`keep` as long as the lines).
    pub(crate) fn select(&self, keep: &[bool]) -> Self {
        let pick = |k: &usize| keep[*k];
        let lines: Vec<usize> = (0..self.output_covariance.len()).filter(pick).collect();
        Self {
            periods: self.periods,
            output_covariance: lines
                .iter()
                .map(|k| self.output_covariance[*k].clone())
                .collect(),
            input_variance: self
                .input_variance
                .iter()
                .map(|v| lines.iter().map(|k| v[*k]).collect())
                .collect(),
            cross_covariance: lines
                .iter()
                .filter_map(|k| self.cross_covariance.get(*k).cloned())
                .collect(),
        }
    }
}
