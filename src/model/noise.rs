//! A parametric noise model H = C/D in z⁻¹ (McKelvey eqs. 19–20) and the composed model
//! [`WithNoiseModel`] whose parameter vector holds both the system and the noise model.

use super::{ModelStructure, PolesZeros};
use crate::basis::PolyBasis;
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::roots::roots;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// A monic discrete-time noise model, the H of Y = G U + H E (McKelvey eqs. 19–20):
///
/// ```text
/// H(z) = C(z⁻¹)/D(z⁻¹) = (1 + c₁z⁻¹ + … + c_nc z⁻ⁿᶜ)/(1 + d₁z⁻¹ + … + d_nd z⁻ⁿᵈ),
/// η = [c₁ … c_nc, d₁ … d_nd],   z = e^{iωTs},
/// ```
///
/// with the analytic log-derivatives ∂log H/∂cᵢ = z⁻ⁱ/C and ∂log H/∂dᵢ = −z⁻ⁱ/D. The
/// paper asks for H stable and inversely stable (all roots of C and D inside the unit
/// circle); [`NoiseModel::stabilised`] makes it so. As in the paper (section 2), the noise
/// is always described in discrete time, also when the system G is continuous.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct NoiseModel<T: Real> {
    nc: usize,
    nd: usize,
    ts: T,
}

impl<T: Real> NoiseModel<T> {
    /// The structure with numerator order `nc`, denominator order `nd` and sample time `ts`
    /// (s); its parameters are η = [c₁ … c_nc, d₁ … d_nd] (η = 0 is H = 1).
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] named `ts` when `ts` is not positive and finite.
    pub fn new(nc: usize, nd: usize, ts: T) -> Result<Self> {
        if !(Float::is_finite(ts) && ts > T::zero() && Float::is_finite(T::pi() / ts)) {
            return Err(FdidError::InvalidArgument {
                name: "ts",
                value: format!("{ts}"),
                reason: "the sample time must be positive and finite".into(),
            });
        }
        Ok(Self { nc, nd, ts })
    }

    /// The structure and its parameters from given polynomials C = [1, c₁, …, c_nc] and
    /// D = [1, d₁, …, d_nd] (ascending powers of z⁻¹).
    ///
    /// # Errors
    /// An empty polynomial, a leading coefficient other than 1 ("noise model must be
    /// monic"), non-finite coefficients, or a bad `ts`.
    pub fn from_polynomials(c: &[T], d: &[T], ts: T) -> Result<(Self, Vec<T>)> {
        for (name, p) in [("c", c), ("d", d)] {
            crate::error::check_finite(name, p)?;
            match p.first() {
                Some(v) if *v == T::one() => {}
                other => {
                    return Err(FdidError::InvalidArgument {
                        name,
                        value: format!("{:?}", other.map(|v| v.to_f64_lossless())),
                        reason: "noise model must be monic: the leading (z⁰) coefficient \
                                 must be 1"
                            .into(),
                    });
                }
            }
        }
        let model = Self::new(c.len() - 1, d.len() - 1, ts)?;
        let eta = c[1..].iter().chain(&d[1..]).copied().collect();
        Ok((model, eta))
    }

    /// Numerator order nc.
    pub fn nc(&self) -> usize {
        self.nc
    }

    /// Denominator order nd.
    pub fn nd(&self) -> usize {
        self.nd
    }

    /// Sample time Ts (s) of z = e^{iωTs}.
    pub fn ts(&self) -> T {
        self.ts
    }

    /// Number of noise parameters nc + nd.
    pub fn n_params(&self) -> usize {
        self.nc + self.nd
    }

    /// The polynomials C = [1, c₁ …] and D = [1, d₁ …] (ascending powers of z⁻¹) of η.
    pub fn polynomials(&self, eta: &[T]) -> (Vec<T>, Vec<T>) {
        let mut c = vec![T::one()];
        c.extend_from_slice(&eta[..self.nc]);
        let mut d = vec![T::one()];
        d.extend_from_slice(&eta[self.nc..self.nc + self.nd]);
        (c, d)
    }

    /// C(z⁻¹) and D(z⁻¹) at ω, with the powers z⁻ⁱ (i = 0 … max(nc, nd)) in `pw`.
    #[inline]
    fn eval_cd(&self, eta: &[T], omega: T, pw: &mut [Complex<T>]) -> (Complex<T>, Complex<T>) {
        let zinv = Complex::new(T::zero(), -omega * self.ts).exp();
        pw[0] = Complex::new(T::one(), T::zero());
        for i in 1..pw.len() {
            pw[i] = pw[i - 1] * zinv;
        }
        let mut c = pw[0];
        for i in 1..=self.nc {
            c += pw[i] * eta[i - 1];
        }
        let mut d = pw[0];
        for i in 1..=self.nd {
            d += pw[i] * eta[self.nc + i - 1];
        }
        (c, d)
    }

    fn powers(&self) -> Vec<Complex<T>> {
        vec![Complex::new(T::zero(), T::zero()); self.nc.max(self.nd) + 1]
    }

    /// Writes H(η, ω_k) = C/D at z = e^{iω_kTs} into `out` (same length as `omega`).
    pub fn response_into(&self, eta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        let mut pw = self.powers();
        for (w, h) in omega.iter().zip(out.iter_mut()) {
            let (c, d) = self.eval_cd(eta, *w, &mut pw);
            *h = c / d;
        }
    }

    /// H(η, ω_k) as a new vector.
    pub fn response(&self, eta: &[T], omega: &[T]) -> Vec<Complex<T>> {
        let mut h = vec![Complex::new(T::zero(), T::zero()); omega.len()];
        self.response_into(eta, omega, &mut h);
        h
    }

    /// Writes H(η, ω_k) into `h` and the analytic log-derivatives
    /// `dlog[(k, i)] = ∂log H(η, ω_k)/∂ηᵢ` (z⁻ⁱ/C for cᵢ, −z⁻ⁱ/D for dᵢ) into `dlog`
    /// (`omega.len() × (nc + nd)`).
    pub fn log_jacobian_into(
        &self,
        eta: &[T],
        omega: &[T],
        h: &mut [Complex<T>],
        dlog: &mut DMatrix<Complex<T>>,
    ) {
        let mut pw = self.powers();
        for (k, w) in omega.iter().enumerate() {
            let (c, d) = self.eval_cd(eta, *w, &mut pw);
            let (ic, id) = (c.inv(), d.inv());
            h[k] = c * id;
            for i in 1..=self.nc {
                dlog[(k, i - 1)] = pw[i] * ic;
            }
            for i in 1..=self.nd {
                dlog[(k, self.nc + i - 1)] = -(pw[i] * id);
            }
        }
    }

    /// Roots of C in z (the zeros of H; roots at z = 0 left out).
    ///
    /// # Errors
    /// Non-finite η, eigenvalue failure.
    pub fn zeros(&self, eta: &[T]) -> Result<Vec<Complex<T>>> {
        roots(
            &PolyBasis::DelayPowers { ts: self.ts },
            &self.polynomials(eta).0,
        )
    }

    /// Roots of D in z (the poles of H; roots at z = 0 left out).
    ///
    /// # Errors
    /// As [`NoiseModel::zeros`].
    pub fn poles(&self, eta: &[T]) -> Result<Vec<Complex<T>>> {
        roots(
            &PolyBasis::DelayPowers { ts: self.ts },
            &self.polynomials(eta).1,
        )
    }

    /// True when every root of C and D is strictly inside the unit circle (H stable and
    /// inversely stable, as the paper's model set requires).
    ///
    /// # Errors
    /// As [`NoiseModel::zeros`].
    pub fn is_stable_and_inversely_stable(&self, eta: &[T]) -> Result<bool> {
        let inside = |r: Vec<Complex<T>>| r.iter().all(|z| z.norm() < T::one());
        Ok(inside(self.zeros(eta)?) && inside(self.poles(eta)?))
    }

    /// η with every root r of C and of D outside the unit circle reflected to 1/r̄, so that
    /// H is stable and inversely stable and still monic.
    ///
    /// On |z| = 1 the factor 1 − r z⁻¹ becomes 1 − z⁻¹/r̄, of magnitude |1 − r z⁻¹|/|r|, so the
    /// reflection scales |H(e^{iωTs})| by one constant Π_C |r|⁻¹ · Π_D |r| (reflected roots) at every
    /// frequency. The concentrated criterion (McKelvey eq. 26) is invariant under H ↦ κH
    /// (λ̂ of eq. 25 absorbs κ², the mean-log term gives it back), so the reflected η has
    /// the same W(θ) and the same λ̂·|H|², the noise spectrum. Roots on the unit circle
    /// cannot be reflected and are kept.
    ///
    /// # Errors
    /// As [`NoiseModel::zeros`].
    pub fn stabilised(&self, eta: &[T]) -> Result<Vec<T>> {
        let basis = PolyBasis::DelayPowers { ts: self.ts };
        let reflect = |r: Vec<Complex<T>>, n: usize| -> Vec<T> {
            let r: Vec<Complex<T>> = r
                .into_iter()
                .map(|z| {
                    if z.norm() > T::one() {
                        z.conj().inv()
                    } else {
                        z
                    }
                })
                .collect();
            basis.from_roots(&r, n)
        };
        let (c, d) = self.polynomials(eta);
        let zc = self.zeros(eta)?;
        let zd = self.poles(eta)?;
        let c = if zc.iter().any(|z| z.norm() > T::one()) {
            reflect(zc, self.nc)
        } else {
            c
        };
        let d = if zd.iter().any(|z| z.norm() > T::one()) {
            reflect(zd, self.nd)
        } else {
            d
        };
        Ok(c[1..].iter().chain(&d[1..]).copied().collect())
    }
}

/// A system model `M` with a noise model [`NoiseModel`] (McKelvey eq. 20):
/// Y = G(θ_G) U + H(η) E, with θ = [θ_G …, c₁ … c_nc, d₁ … d_nd].
///
/// As a [`ModelStructure`] it is G: the response and transient of `M`, with zero Jacobian
/// columns for the noise parameters; H(θ, ω) is available through
/// [`WithNoiseModel::noise_response`]. The noise parameters enter only through the
/// criterion, [`crate::criterion::NoiseModelMl`].
///
/// ```
/// use fdid::prelude::*;
/// use fdid::model::{NoiseModel, WithNoiseModel};
/// let ts = 0.1;
/// let g = Rational::discrete(1, 0, ts).unwrap();
/// let (h, eta) = NoiseModel::from_polynomials(&[1.0, 0.5], &[1.0, -0.9], ts).unwrap();
/// let model = WithNoiseModel::new(g, h);
/// let theta: [f64; 4] = [-0.5, 1.0, eta[0], eta[1]];
/// assert_eq!(model.n_params(), 4);
/// // H(z = 1) = 1.5 / 0.1
/// let h0 = model.noise_response(&theta, &[0.0]);
/// assert!((h0[0].re - 15.0).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct WithNoiseModel<M> {
    system: M,
    noise: NoiseModelParts,
}

/// The noise structure stored scalar-free so that `WithNoiseModel<M>` has one type
/// parameter (its sample time is kept as `f64`, converted exactly from `T`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(try_from = "StoredNoise"))]
struct NoiseModelParts {
    nc: usize,
    nd: usize,
    ts: f64,
}

/// The stored fields of [`NoiseModelParts`], checked by [`NoiseModel::new`] and the degree
/// limit on reading.
#[cfg(feature = "serde")]
#[derive(serde::Deserialize)]
struct StoredNoise {
    nc: usize,
    nd: usize,
    ts: f64,
}

#[cfg(feature = "serde")]
impl TryFrom<StoredNoise> for NoiseModelParts {
    type Error = FdidError;

    fn try_from(s: StoredNoise) -> Result<Self> {
        super::check_degrees(s.nc, s.nd)?;
        let checked = NoiseModel::new(s.nc, s.nd, s.ts)?;
        Ok(Self {
            nc: checked.nc,
            nd: checked.nd,
            ts: checked.ts,
        })
    }
}

impl<M> WithNoiseModel<M> {
    /// Composes the system model `system` with the noise model `noise`.
    pub fn new<T: Real>(system: M, noise: NoiseModel<T>) -> Self {
        Self {
            system,
            noise: NoiseModelParts {
                nc: noise.nc,
                nd: noise.nd,
                ts: noise.ts.to_f64_lossless(),
            },
        }
    }

    /// The system model.
    pub fn system(&self) -> &M {
        &self.system
    }

    /// The noise model structure.
    pub fn noise<T: Real>(&self) -> NoiseModel<T> {
        NoiseModel {
            nc: self.noise.nc,
            nd: self.noise.nd,
            ts: T::lit(self.noise.ts),
        }
    }

    /// Number of noise parameters nc + nd (the last entries of θ).
    pub fn n_noise_params(&self) -> usize {
        self.noise.nc + self.noise.nd
    }
}

impl<M> WithNoiseModel<M> {
    /// Splits θ into the system part θ_G and the noise part η.
    ///
    /// # Panics
    /// When θ is shorter than nc + nd.
    pub fn split<'t, T>(&self, theta: &'t [T]) -> (&'t [T], &'t [T]) {
        theta.split_at(theta.len() - self.n_noise_params())
    }

    /// H(θ, ω_k) = C/D at z = e^{iω_kTs}.
    pub fn noise_response<T: Real>(&self, theta: &[T], omega: &[T]) -> Vec<Complex<T>> {
        self.noise::<T>().response(self.split(theta).1, omega)
    }
}

impl<T: Real, M: ModelStructure<T>> ModelStructure<T> for WithNoiseModel<M> {
    /// The system model's stability ([`ModelStructure::stable_at`]); H = C/D is kept
    /// stable by reflection ([`NoiseModel::stabilised`]), which leaves the criterion
    /// unchanged.
    fn stable_at(&self, theta: &[T]) -> Option<bool> {
        self.system.stable_at(&theta[..self.system.n_params()])
    }

    /// The system part stabilised, the noise parameters kept.
    fn stabilised(&self, theta: &[T]) -> Option<Result<Vec<T>>> {
        let p = self.system.n_params();
        let system = self.system.stabilised(&theta[..p])?;
        Some(system.map(|mut t| {
            t.extend_from_slice(&theta[p..]);
            t
        }))
    }

    fn n_params(&self) -> usize {
        self.system.n_params() + self.n_noise_params()
    }

    fn has_transient(&self) -> bool {
        self.system.has_transient()
    }

    /// The system's map, and 1 for the monic noise model's parameters.
    fn normalisation_map(&self, output: T, input: T) -> Option<Vec<T>> {
        let mut d = self.system.normalisation_map(output, input)?;
        d.extend(std::iter::repeat_n(T::one(), self.n_noise_params()));
        Some(d)
    }

    fn response_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        self.system
            .response_into(&theta[..self.system.n_params()], omega, out);
    }

    fn jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) {
        let p = self.system.n_params();
        let mut inner = DMatrix::zeros(omega.len(), p);
        self.system.jacobian_into(&theta[..p], omega, g, &mut inner);
        jac.fill(Complex::new(T::zero(), T::zero()));
        jac.columns_mut(0, p).copy_from(&inner);
    }

    fn transient_into(
        &self,
        theta: &[T],
        omega: &[T],
        t: &mut [Complex<T>],
        jac: Option<&mut DMatrix<Complex<T>>>,
    ) -> bool {
        let p = self.system.n_params();
        match jac {
            None => self.system.transient_into(&theta[..p], omega, t, None),
            Some(jac) => {
                let mut inner = DMatrix::zeros(omega.len(), p);
                let has = self
                    .system
                    .transient_into(&theta[..p], omega, t, Some(&mut inner));
                if has {
                    jac.fill(Complex::new(T::zero(), T::zero()));
                    jac.columns_mut(0, p).copy_from(&inner);
                }
                has
            }
        }
    }

    /// The system's checks, plus: the data carry the noise model's sample time; at least
    /// nc + nd + 1 lines (the noise model and λ are identified from |Y − Ŷ|² alone, one
    /// real number per line); 2·lines ≥ p in total.
    fn check_data(&self, data: &FrequencyData<T>) -> Result<()> {
        self.system.check_data(data)?;
        let ts = data.ts().ok_or_else(|| FdidError::InvalidArgument {
            name: "ts",
            value: "none".into(),
            reason: "a noise model H(z) is discrete time: the data need a sample time".into(),
        })?;
        let own = T::lit(self.noise.ts);
        if Float::abs(ts - own) > own * T::lit(crate::data::SAMPLE_TIME_TOLERANCE) {
            return Err(FdidError::InvalidArgument {
                name: "ts",
                value: format!("{ts}"),
                reason: format!("the data's sample time differs from the noise model's ({own})"),
            });
        }
        let lines = data.len();
        let needed = self.n_noise_params() + 1;
        if lines < needed {
            return Err(FdidError::TooFewFrequencies {
                lines,
                equations: lines,
                parameters: needed,
            });
        }
        super::check_line_count(self.n_params(), lines)
    }
}

impl<T: Real, M: PolesZeros<T> + ModelStructure<T>> PolesZeros<T> for WithNoiseModel<M> {
    fn poles(&self, theta: &[T]) -> Result<Vec<Complex<T>>> {
        self.system.poles(&theta[..self.system.n_params()])
    }

    fn zeros(&self, theta: &[T]) -> Result<Vec<Complex<T>>> {
        self.system.zeros(&theta[..self.system.n_params()])
    }

    fn gain(&self, theta: &[T]) -> T {
        self.system.gain(&theta[..self.system.n_params()])
    }
}
