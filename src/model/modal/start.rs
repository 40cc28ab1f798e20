//! Starting values of a modal model: θ for given poles with the linear parameters fitted
//! by least squares, and the start from a rational fit.

use super::{Modal, ModalParts};
use crate::data::{FrequencyData, NoiseWeighting};
use crate::error::{FdidError, Result};
use crate::linalg::least_squares;
use crate::model::{Domain, ModelStructure, Output, PolesZeros, Rational};
use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DVector};
use num_traits::Float;

impl<T: Real> Modal<T> {
    /// θ for the given poles (one member per pair, or both: members with Im p < 0 are
    /// skipped) with the parameters that enter linearly — residues, d and τ — fitted by
    /// weighted linear least squares on `data`: for fixed poles Ŷ_k = G U_k + T is linear in
    /// them, so the columns of ∂Ŷ/∂θ are the regressors (QR/SVD, never the normal
    /// equations).
    ///
    /// Real poles (Im p = 0) fill the real slots and the others the pair slots.
    ///
    /// # Errors
    /// Wrong numbers of real poles or pairs for the model; data the model cannot be fitted
    /// to ([`ModelStructure::check_data`]); zero noise variances with
    /// [`NoiseWeighting::Auto`]; a singular least-squares problem.
    pub fn theta_for_poles(
        &self,
        poles: &[Complex<T>],
        data: &FrequencyData<T>,
        weighting: NoiseWeighting,
    ) -> Result<Vec<T>> {
        self.check_data(data)?;
        let reals: Vec<T> = poles
            .iter()
            .filter(|p| p.im == T::zero())
            .map(|p| p.re)
            .collect();
        let pairs: Vec<Complex<T>> = poles.iter().copied().filter(|p| p.im > T::zero()).collect();
        if reals.len() != self.n_real || pairs.len() != self.n_pairs {
            return Err(FdidError::InvalidArgument {
                name: "poles",
                value: format!("{} real, {} pairs", reals.len(), pairs.len()),
                reason: format!(
                    "the model has {} real poles and {} pairs",
                    self.n_real, self.n_pairs
                ),
            });
        }
        crate::error::check_finite_complex("poles", poles)?;
        let zero = Complex::new(T::zero(), T::zero());
        let parts = ModalParts {
            real_residues: vec![T::zero(); reals.len()],
            real_poles: reals,
            pair_residues: vec![zero; pairs.len()],
            pair_poles: pairs,
            direct: T::zero(),
            transient_real: vec![
                T::zero();
                if self.transient.is_some() {
                    self.n_real
                } else {
                    0
                }
            ],
            transient_pairs: vec![
                zero;
                if self.transient.is_some() {
                    self.n_pairs
                } else {
                    0
                }
            ],
        };
        let mut theta = self.theta_from_parts(&parts)?;
        let pole_idx = self.pole_indices();
        let linear: Vec<usize> = (0..self.n_params())
            .filter(|i| !pole_idx.contains(i))
            .collect();
        let mut out = Output::new(data.len(), self.n_params());
        if !out.evaluate(self, &theta, data, true) {
            return Err(FdidError::Numerical {
                what: "modal regressors at the given poles".into(),
            });
        }
        let weights = weighting.weights(data)?;
        let n = data.len();
        let mut a = DMatrix::<T>::zeros(2 * n, linear.len());
        let mut b = DVector::<T>::zeros(2 * n);
        for k in 0..n {
            let wk = weights.as_ref().map_or(T::one(), |w| w[k]);
            for (c, j) in linear.iter().enumerate() {
                let v = out.dyhat[(k, *j)] * wk;
                a[(2 * k, c)] = v.re;
                a[(2 * k + 1, c)] = v.im;
            }
            let y = data.y()[k] * wk;
            b[2 * k] = y.re;
            b[2 * k + 1] = y.im;
        }
        let (x, _) = least_squares(a, b, 1e3)?;
        for (c, j) in linear.iter().enumerate() {
            theta[*j] = x[c];
        }
        Ok(theta)
    }

    /// Starting values from a fitted [`Rational`] (θ_r its parameters): its poles — in s
    /// directly for a continuous-time model, s = ln(z)/Ts for a discrete-time one (the
    /// inverse of the ZOH pole map z = e^{sTs}) — then the residues, d and τ by
    /// [`Modal::theta_for_poles`].
    ///
    /// When the rational model has more real poles than this model (and too few pairs), the
    /// two closest real poles a, b become the pair (a + b)/2 ± i|a − b|/2; with too many
    /// pairs, the most damped pair σ ± iω becomes the real poles σ ± ω.
    ///
    /// # Errors
    /// A discrete-time pole on the negative real axis or at 0 (no real continuous-time
    /// pole maps to it under ZOH sampling); a rational model whose number of poles differs
    /// from [`Modal::order`]; as [`Modal::theta_for_poles`].
    pub fn start_from_rational(
        &self,
        rational: &Rational<T>,
        theta_r: &[T],
        data: &FrequencyData<T>,
        weighting: NoiseWeighting,
    ) -> Result<Vec<T>> {
        self.start_from_rational_with(rational, theta_r, data, weighting, false)
    }

    /// [`Modal::start_from_rational`]; when `lenient`, a discrete-time pole z on the
    /// negative real axis becomes the real pole s = ln|z|/Ts of the same decay rate (and
    /// z = 0 the fast pole s = ln(ε)/Ts) instead of an error.
    pub(crate) fn start_from_rational_with(
        &self,
        rational: &Rational<T>,
        theta_r: &[T],
        data: &FrequencyData<T>,
        weighting: NoiseWeighting,
        lenient: bool,
    ) -> Result<Vec<T>> {
        let raw = rational.poles(theta_r)?;
        let s_poles: Vec<Complex<T>> = match rational.domain() {
            Domain::Continuous => raw,
            Domain::Discrete { ts } => raw
                .into_iter()
                .map(|z| {
                    let on_axis = Float::abs(z.im) <= T::lit(1e3) * T::default_epsilon() * z.norm();
                    if on_axis && !(z.re > T::zero()) && lenient {
                        let m = Float::max(Float::abs(z.re), T::default_epsilon());
                        Ok(Complex::new(Float::ln(m) / ts, T::zero()))
                    } else if on_axis && !(z.re > T::zero()) {
                        Err(FdidError::InvalidArgument {
                            name: "discrete-time pole",
                            value: format!("{z}"),
                            reason: "on the negative real axis or at 0: no continuous-time \
                                     pole maps to it under ZOH sampling (s = ln(z)/Ts)"
                                .into(),
                        })
                    } else if on_axis {
                        Ok(Complex::new(Float::ln(z.re) / ts, T::zero()))
                    } else {
                        Ok(z.ln() / ts)
                    }
                })
                .collect::<Result<_>>()?,
        };
        let poles = self.assign_poles(s_poles)?;
        self.theta_for_poles(&poles, data, weighting)
    }

    /// Sorts poles into `n_real` real ones and `n_pairs` upper pair members, converting
    /// between the two kinds as [`Modal::start_from_rational`] describes.
    fn assign_poles(&self, poles: Vec<Complex<T>>) -> Result<Vec<Complex<T>>> {
        if poles.len() != self.order() {
            return Err(FdidError::InvalidArgument {
                name: "rational model",
                value: format!("{} poles", poles.len()),
                reason: format!("the modal model has order {}", self.order()),
            });
        }
        let mut reals: Vec<T> = vec![];
        let mut pairs: Vec<Complex<T>> = vec![];
        for p in poles {
            if Float::abs(p.im) <= T::lit(1e3) * T::default_epsilon() * p.norm() {
                reals.push(p.re);
            } else if p.im > T::zero() {
                pairs.push(p);
            }
        }
        while reals.len() > self.n_real && pairs.len() < self.n_pairs && reals.len() >= 2 {
            reals.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
            let i = (0..reals.len() - 1)
                .min_by(|x, y| {
                    let dx = reals[*x + 1] - reals[*x];
                    let dy = reals[*y + 1] - reals[*y];
                    dx.partial_cmp(&dy).unwrap_or(std::cmp::Ordering::Equal)
                })
                .unwrap_or(0);
            let (a, b) = (reals[i], reals[i + 1]);
            let sigma = (a + b) / T::lit(2.0);
            let half = Float::max(
                (b - a) / T::lit(2.0),
                Float::sqrt(T::default_epsilon()) * Float::max(Float::abs(sigma), T::one()),
            );
            reals.drain(i..=i + 1);
            pairs.push(Complex::new(sigma, half));
        }
        while pairs.len() > self.n_pairs && reals.len() + 2 <= self.n_real {
            let i = (0..pairs.len())
                .min_by(|x, y| {
                    let dx = pairs[*x].im / Float::abs(pairs[*x].re);
                    let dy = pairs[*y].im / Float::abs(pairs[*y].re);
                    dx.partial_cmp(&dy).unwrap_or(std::cmp::Ordering::Equal)
                })
                .unwrap_or(0);
            let p = pairs.remove(i);
            reals.extend([p.re - p.im, p.re + p.im]);
        }
        let mut out: Vec<Complex<T>> = reals
            .into_iter()
            .map(|r| Complex::new(r, T::zero()))
            .collect();
        out.extend(pairs);
        Ok(out)
    }
}
