//! The transient term of a grey-box model on one non-periodic record (McKelvey eqs. 4–5 in
//! discrete time, 9–10 for a continuous-time model of sampled band-limited data), built
//! from the denominator the model exposes ([`GreyBox::denominator`]).
//!
//! The modelled output is Ŷ_k = G(θ, ω_k) U_k + T(θ, t, ω_k) with, for z_k = e^{iω_kTs},
//!
//! ```text
//! discrete time (eqs. 4–5):     T_k = Σ_{j=1}^{n} t_j z_k^{−(j−1)} / A(θ, z_k⁻¹),
//! sampled continuous time (eqs. 9–10):
//!                               T_k = Σ_{j=1}^{n} t_j z_k^{−(j−1)} / Πᵢ (1 − e^{pᵢ(θ)Ts} z_k⁻¹),
//! ```
//!
//! n the degree of the denominator, pᵢ(θ) the roots of D(θ, s). The tⱼ enter linearly
//! (∂T/∂tⱼ = z^{−(j−1)}/A); the model parameters enter through A, whose derivatives come
//! from the dual-number evaluation of its coefficients. In continuous time the poles are
//! the eigenvalues of the (scaled) companion matrix of D, computed in f64, and their
//! derivatives follow from D(θ, pᵢ(θ)) = 0 (implicit function theorem):
//!
//! ```text
//! ∂pᵢ/∂θⱼ = −(∂D/∂θⱼ)(pᵢ) / (∂D/∂s)(pᵢ),
//! ```
//!
//! which needs simple poles (a repeated pole makes ∂D/∂s vanish; the Jacobian is then not
//! finite and the criteria report a numerical failure). Coefficients of D that are exactly
//! zero at the low end are structural roots at s = 0 (an integrator), with zero derivative.

use super::{AutoDiff, Dual, GreyBox};
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// The transient term of an [`AutoDiff`] model (see [`AutoDiff::with_transient`] and
/// [`AutoDiff::with_sampled_transient`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Transient {
    /// Discrete time (McKelvey eqs. 4–5): T = (Σⱼ tⱼ z^{−(j−1)})/A(θ, z⁻¹), n = `order`
    /// coefficients tⱼ.
    Discrete {
        /// n, the degree of A in z⁻¹.
        order: usize,
    },
    /// A continuous-time model of data sampled at `ts` (McKelvey eqs. 9–10):
    /// T = (Σⱼ tⱼ z^{−(j−1)})/Πᵢ(1 − e^{pᵢTs} z⁻¹) over the n = `order` poles pᵢ of G.
    Sampled {
        /// n, the degree of D in s.
        order: usize,
        /// The sample time Ts (s) of the record.
        ts: f64,
    },
}

impl Transient {
    /// n, the number of transient coefficients tⱼ.
    pub fn order(&self) -> usize {
        match self {
            Self::Discrete { order } | Self::Sampled { order, .. } => *order,
        }
    }
}

/// The denominator of the transient as a function of x = z⁻¹, for one θ, in duals.
enum DualDenominator<T: Real, const N: usize> {
    /// A(x) = Σ_k a_k x^k.
    Coefficients(Vec<Dual<T, N>>),
    /// Πᵢ (1 − qᵢ x), qᵢ = e^{pᵢTs}.
    Poles(Vec<Complex<Dual<T, N>>>),
}

impl<T: Real, const N: usize> DualDenominator<T, N> {
    fn eval(&self, x: Complex<Dual<T, N>>) -> Complex<Dual<T, N>> {
        let zero = Dual::constant(T::zero());
        let one = Complex::new(Dual::constant(T::one()), zero);
        match self {
            Self::Coefficients(a) => a.iter().rev().fold(Complex::new(zero, zero), |acc, c| {
                acc * x + Complex::new(*c, zero)
            }),
            Self::Poles(q) => q.iter().fold(one, |acc, qi| acc * (one - *qi * x)),
        }
    }
}

/// Roots of Σ_k c_k s^k (ascending, c_n ≠ 0) in f64: low-order coefficients that are exactly
/// zero give roots at s = 0 (flagged structural); the rest are the eigenvalues of the
/// companion matrix of the polynomial in x = s/ρ, ρ = |c₀/c_n|^{1/n'} (balanced scale).
fn poles_f64(c: &[f64]) -> Result<Vec<(Complex<f64>, bool)>> {
    let bad = || FdidError::Numerical {
        what: format!("denominator coefficients {c:?}: not finite or zero leading coefficient"),
    };
    let n = c.len().saturating_sub(1);
    if c.iter().any(|v| !v.is_finite()) || n == 0 || c[n] == 0.0 {
        return Err(bad());
    }
    let zeros = c.iter().take_while(|v| **v == 0.0).count();
    let rest = &c[zeros..];
    let m = rest.len() - 1;
    let mut out: Vec<(Complex<f64>, bool)> = vec![(Complex::new(0.0, 0.0), true); zeros];
    if m == 0 {
        return Ok(out);
    }
    let rho = (rest[0] / rest[m]).abs().powf(1.0 / m as f64);
    if !(rho.is_finite() && rho > 0.0) {
        return Err(bad());
    }
    // monic in x: x^m + Σ_{k<m} (c_k ρ^k / (c_m ρ^m)) x^k
    let lead = rest[m] * rho.powi(m as i32);
    let mut comp = DMatrix::<f64>::zeros(m, m);
    for k in 0..m {
        comp[(0, k)] = -rest[m - 1 - k] * rho.powi((m - 1 - k) as i32) / lead;
        if k + 1 < m {
            comp[(k + 1, k)] = 1.0;
        }
    }
    let roots = crate::roots::eigenvalues(comp)?;
    out.extend(roots.into_iter().map(|x| (x * rho, false)));
    Ok(out)
}

impl<G: GreyBox> AutoDiff<G> {
    /// The same discrete-time model with the transient term of one non-periodic record
    /// (McKelvey eqs. 4–5): Ŷ = G U + T with
    ///
    /// ```text
    /// T(θ, t, z) = (t₁ + t₂ z⁻¹ + … + t_n z^{−(n−1)}) / A(θ, z⁻¹),
    /// ```
    ///
    /// A = Σ_k a_k(θ) z^{−k} the denominator of [`GreyBox::denominator`] and n its degree
    /// (a model with a numerator of higher degree than A pads A with zero coefficients up to
    /// the state dimension). θ gains [t₁ … t_n] at its end. With the DFT of
    /// [`crate::TimeData::dft`] the leakage of a record from any initial state has exactly
    /// this form (the 1/√N of eq. 4 is absorbed in t), so noise-free data give the exact θ.
    ///
    /// ```
    /// use fdid::prelude::*;
    /// use fdid::greybox::{AutoDiff, DualScalar, GreyBox};
    /// use fdid::estimate::greybox::fit_ml_from;
    ///
    /// /// G(z⁻¹) = g/(1 − a z⁻¹), θ = [ln g, a], Ts = 1 ms.
    /// #[derive(Clone)]
    /// struct Lag;
    /// impl GreyBox for Lag {
    ///     fn n_params(&self) -> usize {
    ///         2
    ///     }
    ///     fn response<S: DualScalar>(&self, theta: &[S], x: Complex<S>) -> Complex<S> {
    ///         let one = Complex::new(S::one(), S::zero());
    ///         (one - x * theta[1]).inv() * theta[0].exp()
    ///     }
    ///     fn sample_time(&self) -> Option<f64> {
    ///         Some(1e-3)
    ///     }
    ///     fn denominator<S: DualScalar>(&self, theta: &[S]) -> Option<Vec<S>> {
    ///         Some(vec![S::one(), -theta[1]])
    ///     }
    /// }
    ///
    /// // y[t] = 0.9 y[t−1] + 2 u[t] from y[−1] = 5: a record that is not periodic
    /// let u: Vec<f64> = (0..64).map(|t| ((t * 7919) % 13) as f64 - 6.0).collect();
    /// let mut y = vec![0.0; 64];
    /// let mut prev = 5.0;
    /// for t in 0..64 {
    ///     y[t] = 0.9 * prev + 2.0 * u[t];
    ///     prev = y[t];
    /// }
    /// let data = TimeData::new(u, y, 1e-3).unwrap().dft();
    /// let model = AutoDiff::new(Lag).with_transient().unwrap();
    /// // θ = [ln g, a, t₁]
    /// let fit = fit_ml_from(&model, &data, &[1.0, 0.5, 0.0]).unwrap();
    /// assert!((fit.theta()[0].exp() - 2.0).abs() < 1e-9);
    /// assert!((fit.theta()[1] - 0.9).abs() < 1e-9);
    /// ```
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] (name `"transient"`) for a continuous-time model (use
    /// [`AutoDiff::with_sampled_transient`]), a model whose [`GreyBox::denominator`] is
    /// `None`, or a denominator of degree zero.
    pub fn with_transient(mut self) -> Result<Self> {
        if self.model.sample_time().is_none() {
            return Err(FdidError::InvalidArgument {
                name: "transient",
                value: "continuous-time model".into(),
                reason: "a continuous-time model needs the sample time of the record: use \
                         with_sampled_transient(ts)"
                    .into(),
            });
        }
        let order = self.denominator_degree()?;
        self.transient = Some(Transient::Discrete { order });
        Ok(self)
    }

    /// The same continuous-time model with the transient term of a record sampled at `ts`
    /// under band-limited excitation (McKelvey eqs. 9–10): Ŷ = G(iω) U + T with
    ///
    /// ```text
    /// T(θ, t, z) = (t₁ + t₂ z⁻¹ + … + t_n z^{−(n−1)}) / Πᵢ (1 − e^{pᵢ(θ)Ts} z⁻¹),
    /// z = e^{iωTs},
    /// ```
    ///
    /// pᵢ(θ) the n roots of the denominator D(θ, s) of [`GreyBox::denominator`] (the poles of
    /// G, assumed simple). θ gains [t₁ … t_n] at its end.
    ///
    /// ```
    /// use fdid::prelude::*;
    /// use fdid::greybox::{AutoDiff, physical::MassSpringDamper};
    /// let model = AutoDiff::new(MassSpringDamper::new()).with_sampled_transient(0.01).unwrap();
    /// // [ln m, ln c, ln k, t₁, t₂]
    /// assert_eq!(ModelStructure::<f64>::n_params(&model), 5);
    /// ```
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] for `ts` not positive and finite, a discrete-time
    /// model (name `"transient"`: use [`AutoDiff::with_transient`]), a model whose
    /// denominator is `None` or of degree zero.
    pub fn with_sampled_transient(mut self, ts: f64) -> Result<Self> {
        crate::data::check_ts(ts)?;
        if let Some(mts) = self.model.sample_time() {
            return Err(FdidError::InvalidArgument {
                name: "transient",
                value: format!("discrete-time model (Ts = {mts})"),
                reason: "a discrete-time model takes its transient from its own sample time: \
                         use with_transient()"
                    .into(),
            });
        }
        let order = self.denominator_degree()?;
        self.transient = Some(Transient::Sampled { order, ts });
        Ok(self)
    }

    /// The same model without a transient term.
    #[must_use]
    pub fn without_transient(mut self) -> Self {
        self.transient = None;
        self
    }

    /// The transient term, if any.
    pub fn transient(&self) -> Option<Transient> {
        self.transient
    }

    /// Number of transient coefficients tⱼ at the end of θ (0 without a transient term).
    pub fn n_transient(&self) -> usize {
        self.transient.map_or(0, |t| t.order())
    }

    /// The degree of the model's denominator (its coefficient count at θ = 0, minus one).
    fn denominator_degree(&self) -> Result<usize> {
        let p = self.model.n_params();
        match self.model.denominator::<f64>(&vec![0.0; p]) {
            Some(c) if c.len() >= 2 => Ok(c.len() - 1),
            Some(c) => Err(FdidError::InvalidArgument {
                name: "transient",
                value: format!("denominator of degree {}", c.len().saturating_sub(1)),
                reason: "a model without poles has no transient term".into(),
            }),
            None => Err(FdidError::InvalidArgument {
                name: "transient",
                value: "no denominator".into(),
                reason: "the model does not expose its denominator (GreyBox::denominator), \
                         which the transient term needs"
                    .into(),
            }),
        }
    }

    /// The sample time of the transient's z = e^{iωTs}: the model's own (discrete time) or
    /// the record's (sampled continuous time).
    pub(super) fn transient_ts(&self) -> Option<f64> {
        match self.transient? {
            Transient::Discrete { .. } => self.model.sample_time(),
            Transient::Sampled { ts, .. } => Some(ts),
        }
    }

    /// Checks the data against the sampled transient's Ts: no mixed sample times, the
    /// data's Ts (if any) equal to it, every ω at or below π/Ts.
    pub(super) fn check_sampled_data<T: Real>(&self, data: &FrequencyData<T>) -> Result<()> {
        let Some(Transient::Sampled { ts, .. }) = self.transient else {
            return Ok(());
        };
        super::check_sample_time(ts, data)
    }

    /// T and the Jacobian columns `first .. first + min(N, p − first)` (full θ, p = model
    /// parameters + n) with N-component duals; NaN when the denominator cannot be
    /// evaluated (wrong length, non-finite coefficients, failed root finding).
    #[inline(never)]
    pub(super) fn transient_pass<T: Real, const N: usize>(
        &self,
        first: usize,
        theta: &[T],
        omega: &[T],
        t: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) {
        let (Some(tr), Some(ts)) = (self.transient, self.transient_ts()) else {
            return super::fill_nan(t, Some(jac));
        };
        let p = theta.len();
        let seeded: Vec<Dual<T, N>> = theta
            .iter()
            .enumerate()
            .map(|(j, v)| match j.checked_sub(first) {
                Some(i) => Dual::variable(*v, i),
                None => Dual::constant(*v),
            })
            .collect();
        let (model_theta, coeffs) = seeded.split_at(self.model.n_params());
        let Some(den) = self.dual_denominator(tr, ts, model_theta) else {
            return super::fill_nan(t, Some(jac));
        };
        let cols = N.min(p.saturating_sub(first));
        let zero = Dual::constant(T::zero());
        let tsr = T::lit(ts);
        for (k, w) in omega.iter().enumerate() {
            let (s, c) = Float::sin_cos(*w * tsr);
            let x = Complex::new(Dual::constant(c), Dual::constant(-s));
            let num = coeffs
                .iter()
                .rev()
                .fold(Complex::new(zero, zero), |acc, tj| {
                    acc * x + Complex::new(*tj, zero)
                });
            let r = num / den.eval(x);
            t[k] = Complex::new(r.re.re, r.im.re);
            for i in 0..cols {
                jac[(k, first + i)] = Complex::new(r.re.eps[i], r.im.eps[i]);
            }
        }
    }

    /// The transient's denominator at θ (model part, seeded duals), or `None` when the
    /// model's coefficients are missing, of the wrong count or have no simple roots.
    fn dual_denominator<T: Real, const N: usize>(
        &self,
        tr: Transient,
        ts: f64,
        theta: &[Dual<T, N>],
    ) -> Option<DualDenominator<T, N>> {
        let c = self.model.denominator(theta)?;
        if c.len() != tr.order() + 1 {
            return None;
        }
        if matches!(tr, Transient::Discrete { .. }) {
            return Some(DualDenominator::Coefficients(c));
        }
        let values: Vec<f64> = c.iter().map(|v| v.re.to_f64_lossless()).collect();
        let poles = poles_f64(&values).ok()?;
        let zero = Dual::constant(T::zero());
        let tsr = Dual::constant(T::lit(ts));
        let mut q = Vec::with_capacity(poles.len());
        for (pole, structural) in poles {
            let pt = Complex::new(T::lit(pole.re), T::lit(pole.im));
            let mut dual = Complex::new(Dual::constant(pt.re), Dual::constant(pt.im));
            if !structural {
                // ∂D/∂θ at s = p (ε-parts) and ∂D/∂s (values), by Horner
                let pd = Complex::new(Dual::constant(pt.re), Dual::constant(pt.im));
                let dd = c.iter().rev().fold(Complex::new(zero, zero), |acc, ck| {
                    acc * pd + Complex::new(*ck, zero)
                });
                let ds = c.iter().enumerate().skip(1).rev().fold(
                    Complex::new(T::zero(), T::zero()),
                    |acc, (k, ck)| {
                        acc * pt + Complex::new(ck.re * T::from_usize_lossy(k), T::zero())
                    },
                );
                let inv = -ds.inv();
                for i in 0..N {
                    let dp = Complex::new(dd.re.eps[i], dd.im.eps[i]) * inv;
                    dual.re.eps[i] = dp.re;
                    dual.im.eps[i] = dp.im;
                }
            }
            q.push((dual * tsr).exp());
        }
        Some(DualDenominator::Poles(q))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poles_of_scaled_and_integrating_polynomials() {
        // 2 (s + 1)(s + 1000) s: c = [0, 2000, 2002, 2]
        let r = poles_f64(&[0.0, 2000.0, 2002.0, 2.0]).unwrap();
        assert_eq!(r.len(), 3);
        assert!(r[0].1 && r[0].0.norm() == 0.0);
        let mut re: Vec<f64> = r[1..].iter().map(|(p, _)| p.re).collect();
        re.sort_by(f64::total_cmp);
        assert!((re[0] + 1000.0).abs() < 1e-10 && (re[1] + 1.0).abs() < 1e-13);
        assert!(poles_f64(&[1.0, 0.0]).is_err());
        assert!(poles_f64(&[1.0, f64::NAN, 1.0]).is_err());
    }
}
