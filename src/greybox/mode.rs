//! Augmentations that compose with any model structure: flexible modes (resonance–
//! antiresonance pairs) as a [`GreyBox`], and the product G_A·G_B of two models.
//!
//! A second mass coupled by a compliant shaft multiplies the rigid-body response by a
//! unit-DC-gain factor with an antiresonance and a resonance (see
//! [`super::physical::TwoMassDrive`]: ω₁/τ = 1/((J₁ + J₂)s) · F(s) without friction). The
//! discrepancy workflow ([`crate::workflow::Workflow::run_model`]) adds such a factor to a
//! user's model when it names a missing resonance.
use super::{DualScalar, GreyBox, Parameter, PhysicalParameters, Slot, fill_nan};
use crate::data::FrequencyData;
use crate::error::Result;
use crate::model::ModelStructure;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;

/// n flexible modes, each a resonance–antiresonance pair of unit DC gain:
///
/// ```text
/// F(s) = Π_i (1 + 2ζ_{z,i} s/ω_{z,i} + (s/ω_{z,i})²) / (1 + 2ζ_{p,i} s/ω_{p,i} + (s/ω_{p,i})²)
///      = Π_i (s² + 2ζ_z ω_z s + ω_z²)/(s² + 2ζ_p ω_p s + ω_p²) · ω_p²/ω_z²,
/// θ = [ln ω_{z,1}, ln ζ_{z,1}, ln ω_{p,1}, ln ζ_{p,1}, …]
/// ```
///
/// (ω in rad/s, ζ without unit), evaluated at s = iω (a continuous-time factor; the
/// frequency response of a discrete-time model times F is a valid description of the data
/// on (0, π/Ts), exact for a sampled system only when the mode lies well below Nyquist).
/// The log parameters keep every mode stable (ζ_p > 0) and minimum phase (ζ_z > 0). With
/// no modes F = 1 and θ is empty.
///
/// **Identifiability.** ω_z = ω_p with ζ_z = ζ_p gives F = 1 whatever their common value:
/// start a fit with the antiresonance away from the resonance. A pure resonance without an
/// antiresonance (a load-side output) is the limit ω_z → ∞, which the log parameter
/// approaches only slowly.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::greybox::{AutoDiff, FlexibleModes};
/// let modes = AutoDiff::new(FlexibleModes::new(1));
/// // antiresonance at 30 rad/s, resonance at 50 rad/s, both with ζ = 0.02
/// let theta = [30f64.ln(), 0.02f64.ln(), 50f64.ln(), 0.02f64.ln()];
/// let f = modes.evaluate(&theta, &[0.0, 30.0, 50.0]).unwrap();
/// assert!((f[0] - Complex::new(1.0, 0.0)).norm() < 1e-12); // unit DC gain
/// assert!(f[1].norm() < f[0].norm() && f[2].norm() > 10.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct FlexibleModes {
    modes: usize,
}

impl FlexibleModes {
    /// `modes` resonance–antiresonance pairs (4 parameters each).
    pub fn new(modes: usize) -> Self {
        Self { modes }
    }

    /// The number of modes.
    pub fn modes(&self) -> usize {
        self.modes
    }

    /// θ of one mode from its physical values [ω_z, ζ_z, ω_p, ζ_p] (the logarithms).
    ///
    /// # Errors
    /// [`crate::FdidError::InvalidArgument`] naming the value when one is not finite and
    /// positive.
    pub fn mode_theta(omega_z: f64, zeta_z: f64, omega_p: f64, zeta_p: f64) -> Result<[f64; 4]> {
        let p = mode_parameters(1);
        Ok([
            p[0].theta(omega_z)?,
            p[1].theta(zeta_z)?,
            p[2].theta(omega_p)?,
            p[3].theta(zeta_p)?,
        ])
    }
}

/// The parameters of `modes` modes: `omega_z1`, `zeta_z1`, `omega_p1`, `zeta_p1`, ….
fn mode_parameters(modes: usize) -> Vec<Parameter> {
    (1..=modes)
        .flat_map(|i| {
            [
                Parameter::log(&format!("omega_z{i}"), "rad/s"),
                Parameter::log(&format!("zeta_z{i}"), "1"),
                Parameter::log(&format!("omega_p{i}"), "rad/s"),
                Parameter::log(&format!("zeta_p{i}"), "1"),
            ]
        })
        .collect()
}

impl GreyBox for FlexibleModes {
    fn n_params(&self) -> usize {
        4 * self.modes
    }

    /// Π (1 + 2ζ_z s/ω_z + (s/ω_z)²)/(1 + 2ζ_p s/ω_p + (s/ω_p)²).
    fn response<S: DualScalar>(&self, theta: &[S], s: Complex<S>) -> Complex<S> {
        let one = Complex::new(S::one(), S::zero());
        let two = S::lit(2.0);
        theta.chunks_exact(4).fold(one, |g, m| {
            let (wz, zz, wp, zp) = (m[0].exp(), m[1].exp(), m[2].exp(), m[3].exp());
            let (xz, xp) = (s / wz, s / wp);
            let num = one + xz * (two * zz) + xz * xz;
            let den = one + xp * (two * zp) + xp * xp;
            g * num / den
        })
    }

    /// Π (1 + 2ζ_p s/ω_p + (s/ω_p)²), expanded (degree 2·modes; `None` without a mode).
    fn denominator<S: DualScalar>(&self, theta: &[S]) -> Option<Vec<S>> {
        if self.modes == 0 {
            return None;
        }
        let two = S::lit(2.0);
        Some(theta.chunks_exact(4).fold(vec![S::one()], |d, m| {
            let (wp, zp) = (m[2].exp(), m[3].exp());
            let f = [S::one(), two * zp / wp, S::one() / (wp * wp)];
            let mut out = vec![S::zero(); d.len() + 2];
            for (i, a) in d.iter().enumerate() {
                for (j, b) in f.iter().enumerate() {
                    out[i + j] += *a * *b;
                }
            }
            out
        }))
    }

    fn parameters(&self) -> Vec<Parameter> {
        mode_parameters(self.modes)
    }
}

/// The product of two models (series connection), θ = [θ_A…, θ_B…]:
///
/// ```text
/// G(θ, ω) = G_A(θ_A, ω) · G_B(θ_B, ω),
/// ∂G/∂θ_A = G_B ∂G_A/∂θ_A,   ∂G/∂θ_B = G_A ∂G_B/∂θ_B   (product rule)
/// ```
///
/// **Transient.** A's transient term T_A (McKelvey eqs. 4, 9) is kept as it is,
/// Ŷ = G_A G_B U + T_A (∂T/∂θ_B = 0), B's is dropped: exact when B = 1 (e.g.
/// [`FlexibleModes`] with no mode) and for periodic data (no transient); for a
/// non-periodic record with B ≠ 1 the transient of the series connection has another
/// shape, which this product does not model.
///
/// A θ of the wrong length makes the response NaN, as for [`super::AutoDiff`].
///
/// ```
/// use fdid::prelude::*;
/// use fdid::greybox::{AutoDiff, FlexibleModes, Product, physical::MassSpringDamper};
/// let model = Product::new(AutoDiff::new(MassSpringDamper::new()), AutoDiff::new(FlexibleModes::new(1)));
/// assert_eq!(ModelStructure::<f64>::n_params(&model), 7);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Product<A, B> {
    first: A,
    second: B,
}

impl<A, B> Product<A, B> {
    /// G_A · G_B.
    pub fn new(first: A, second: B) -> Self {
        Self { first, second }
    }

    /// A.
    pub fn first(&self) -> &A {
        &self.first
    }

    /// B.
    pub fn second(&self) -> &B {
        &self.second
    }
}

impl<T: Real, A: ModelStructure<T>, B: ModelStructure<T>> ModelStructure<T> for Product<A, B> {
    fn n_params(&self) -> usize {
        self.first.n_params() + self.second.n_params()
    }

    /// G_A G_B (NaN for a θ of the wrong length).
    fn response_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        let pa = self.first.n_params();
        if theta.len() != pa + self.second.n_params() {
            return fill_nan(out, None);
        }
        let mut gb = vec![Complex::new(T::zero(), T::zero()); out.len()];
        self.first.response_into(&theta[..pa], omega, out);
        self.second.response_into(&theta[pa..], omega, &mut gb);
        for (o, b) in out.iter_mut().zip(&gb) {
            *o *= *b;
        }
    }

    /// G and ∂G/∂θ by the product rule (NaN for a θ of the wrong length).
    fn jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) {
        let (pa, pb) = (self.first.n_params(), self.second.n_params());
        let n = omega.len();
        if theta.len() != pa + pb || jac.shape() != (n, pa + pb) {
            return fill_nan(g, Some(jac));
        }
        let zero = Complex::new(T::zero(), T::zero());
        let (mut ga, mut gb) = (vec![zero; n], vec![zero; n]);
        let mut ja = DMatrix::from_element(n, pa, zero);
        let mut jb = DMatrix::from_element(n, pb, zero);
        self.first
            .jacobian_into(&theta[..pa], omega, &mut ga, &mut ja);
        self.second
            .jacobian_into(&theta[pa..], omega, &mut gb, &mut jb);
        for k in 0..n {
            g[k] = ga[k] * gb[k];
            for j in 0..pa {
                jac[(k, j)] = ja[(k, j)] * gb[k];
            }
            for j in 0..pb {
                jac[(k, pa + j)] = jb[(k, j)] * ga[k];
            }
        }
    }

    /// A's transient T_A(θ_A) (see the type's docs).
    fn transient_into(
        &self,
        theta: &[T],
        omega: &[T],
        t: &mut [Complex<T>],
        jac: Option<&mut DMatrix<Complex<T>>>,
    ) -> bool {
        let (pa, pb) = (self.first.n_params(), self.second.n_params());
        if theta.len() != pa + pb {
            return false;
        }
        match jac {
            None => self.first.transient_into(&theta[..pa], omega, t, None),
            Some(jac) => {
                let zero = Complex::new(T::zero(), T::zero());
                let mut ja = DMatrix::from_element(omega.len(), pa, zero);
                let has = self
                    .first
                    .transient_into(&theta[..pa], omega, t, Some(&mut ja));
                if has {
                    jac.fill(zero);
                    jac.columns_mut(0, pa).copy_from(&ja);
                }
                has
            }
        }
    }

    /// Both models' checks and at least as many real equations as p_A + p_B.
    fn check_data(&self, data: &FrequencyData<T>) -> Result<()> {
        self.first.check_data(data)?;
        self.second.check_data(data)?;
        crate::model::check_line_count(self.n_params(), data.len())
    }
}

/// The number of free parameters of a described model.
fn free_count<M: PhysicalParameters>(model: &M) -> usize {
    model
        .physical_parameters()
        .iter()
        .filter(|(_, s)| matches!(s, Slot::Free(_)))
        .count()
}

impl<A: PhysicalParameters, B: PhysicalParameters> PhysicalParameters for Product<A, B> {
    /// A's parameters, then B's with their free indices after A's.
    fn physical_parameters(&self) -> Vec<(Parameter, Slot)> {
        let shift = free_count(&self.first);
        let mut params = self.first.physical_parameters();
        params.extend(
            self.second
                .physical_parameters()
                .into_iter()
                .map(|(p, s)| match s {
                    Slot::Free(i) => (p, Slot::Free(i + shift)),
                    fixed => (p, fixed),
                }),
        );
        params
    }

    fn check_theta(&self, theta: &[f64]) -> Result<()> {
        let pa = free_count(&self.first).min(theta.len());
        self.first.check_theta(&theta[..pa])?;
        self.second.check_theta(&theta[pa..])
    }
}
