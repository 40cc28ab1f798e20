//! The local polynomial method (LPM): a nonparametric frequency response, its variance,
//! the output noise level and the transient of ONE non-periodic record, from local
//! polynomial fits over neighbouring DFT lines.
//!
//! Source: R. Pintelon, J. Schoukens, G. Vandersteen and K. Barbé, *Estimation of
//! nonparametric noise and FRF models for multivariable systems — Part I: Theory*,
//! Mechanical Systems and Signal Processing 24 (2010). The DFT conventions and the
//! transient term are McKelvey's (eqs. 1, 4, 15).

use crate::data::{FrequencyData, NoiseVariances};
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DVector};
use num_traits::Float;

/// Settings of the local polynomial method: the degree `R` of the local polynomials and
/// the half-width `n` of the window of `2n + 1` lines.
///
/// | name | default | meaning | range |
/// |------|---------|---------|-------|
/// | `degree` (R) | 2 | degree of the local polynomials of `G` and `T` in the line offset `r` | `R ≥ 0` |
/// | `half_width` (n) | `R + 3` | the window holds the lines `k + r`, `r = −n … n` | `q = 2n + 1 − 2(R + 1) ≥ 1` |
///
/// The default half-width `n = R + 3` leaves `q = 5` residual (complex) degrees of
/// freedom per line whatever `R`. A larger `q` lowers the variance of the noise estimate
/// (relative standard deviation `1/√q`), a smaller window lowers the bias of the
/// polynomial approximation where `G` or the transient vary quickly.
///
/// Settings are checked when they are used, by [`lpm`] / [`Lpm::estimate`].
///
/// ```
/// use fdid::data::Lpm;
///
/// let lpm = Lpm::new();
/// assert_eq!((lpm.degree(), lpm.half_width(), lpm.window(), lpm.dof()), (2, 5, 11, 5));
/// // a cubic in a 13-line window: q = 13 − 8 = 5
/// assert_eq!(Lpm::new().with_degree(3).dof(), 5);
/// // too narrow a window for the degree is rejected
/// assert!(Lpm::new().with_degree(3).with_half_width(3).validate().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Lpm {
    degree: usize,
    half_width: Option<usize>,
}

impl Default for Lpm {
    fn default() -> Self {
        Self::new()
    }
}

impl Lpm {
    /// The default settings: `R = 2`, `n = R + 3 = 5` (a window of 11 lines, `q = 5`).
    pub fn new() -> Self {
        Self {
            degree: 2,
            half_width: None,
        }
    }

    /// Sets the degree `R` of the local polynomials
    /// `G(k + r) ≈ G_k + Σ_{s=1..R} g_s r^s` and `T(k + r) ≈ T_k + Σ_{s=1..R} t_s r^s`.
    /// Unless a half-width was set, the window follows as `n = R + 3`.
    #[must_use]
    pub fn with_degree(mut self, degree: usize) -> Self {
        self.degree = degree;
        self
    }

    /// Sets the half-width `n` of the window `r = −n … n` (2n + 1 lines). It must leave
    /// `q = 2n + 1 − 2(R + 1) ≥ 1` residual degrees of freedom, i.e. `n ≥ R + 1`.
    #[must_use]
    pub fn with_half_width(mut self, half_width: usize) -> Self {
        self.half_width = Some(half_width);
        self
    }

    /// Degree `R` of the local polynomials.
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Half-width `n` of the window (`R + 3` unless set).
    pub fn half_width(&self) -> usize {
        self.half_width
            .unwrap_or_else(|| self.degree.saturating_add(3))
    }

    /// Number of lines in a window, `2n + 1`.
    pub fn window(&self) -> usize {
        self.half_width().saturating_mul(2).saturating_add(1)
    }

    /// Number of local parameters, `2(R + 1)`: the `R + 1` coefficients of `G` and the
    /// `R + 1` of `T`.
    pub fn parameters(&self) -> usize {
        self.degree.saturating_add(1).saturating_mul(2)
    }

    /// Residual degrees of freedom `q = 2n + 1 − 2(R + 1)` (zero when the window is too
    /// small, which [`Lpm::validate`] rejects).
    pub fn dof(&self) -> usize {
        self.window().saturating_sub(self.parameters())
    }

    /// Checks the settings.
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] named `"half_width"` when `n = 0` or when
    /// `q = 2n + 1 − 2(R + 1) < 1` (the message gives `R`, `n` and `q`), named `"degree"`
    /// when `R` is so large that the window size overflows.
    pub fn validate(&self) -> Result<()> {
        let n = self.half_width();
        if self.degree >= usize::MAX / 4 || n >= usize::MAX / 4 {
            return Err(FdidError::InvalidArgument {
                name: "degree",
                value: format!("R = {}, n = {n}", self.degree),
                reason: "the window size overflows".into(),
            });
        }
        if n == 0 {
            return Err(FdidError::InvalidArgument {
                name: "half_width",
                value: "0".into(),
                reason: "the window needs at least one line on each side (n ≥ 1)".into(),
            });
        }
        if self.dof() == 0 {
            return Err(FdidError::InvalidArgument {
                name: "half_width",
                value: n.to_string(),
                reason: format!(
                    "a window of 2n + 1 = {} lines leaves no residual degree of freedom for \
                     2(R + 1) = {} local parameters (degree R = {}); n must be at least R + 1",
                    self.window(),
                    self.parameters(),
                    self.degree
                ),
            });
        }
        Ok(())
    }

    /// Runs the method on `data`; the same as [`lpm`]`(data, *self)`.
    ///
    /// # Errors
    /// As [`lpm`].
    pub fn estimate<T: Real>(&self, data: &FrequencyData<T>) -> Result<LpmEstimate<T>> {
        lpm(data, *self)
    }
}

/// The result of the local polynomial method on one record: per line `k`, the frequency
/// response `Ĝ_k`, its variance, the output noise variance `σ̂²_V,k`, the transient `T̂_k`
/// and its variance, with `q` residual degrees of freedom. See [`lpm`] for the formulas.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct LpmEstimate<T: Real> {
    data: FrequencyData<T>,
    frf: Vec<Complex<T>>,
    frf_variance: Vec<T>,
    noise_variance: Vec<T>,
    transient: Vec<Complex<T>>,
    transient_variance: Vec<T>,
    settings: Lpm,
}

impl<T: Real> LpmEstimate<T> {
    /// Angular frequencies `ω_k` (rad/s), those of the data.
    pub fn omega(&self) -> &[T] {
        self.data.omega()
    }

    /// Sample time of the data, if any.
    pub fn ts(&self) -> Option<T> {
        self.data.ts()
    }

    /// Number of lines.
    pub fn len(&self) -> usize {
        self.frf.len()
    }

    /// Always false (the method needs at least one window of lines).
    pub fn is_empty(&self) -> bool {
        self.frf.is_empty()
    }

    /// The nonparametric frequency response `Ĝ_k = θ̂_0`, the constant term of the local
    /// polynomial of `G` at line `k`.
    pub fn frf(&self) -> &[Complex<T>] {
        &self.frf
    }

    /// `var(Ĝ_k) = σ̂²_V,k [(KᴴK)⁻¹]_{00}`.
    pub fn frf_variance(&self) -> &[T] {
        &self.frf_variance
    }

    /// The output noise variance `σ̂²_V,k = ‖e_k‖² / q`, on the DFT scale of the data:
    /// for white output noise of variance `σ²` and the crate's `1/√N` DFT (McKelvey eq. 1)
    /// its expectation is `σ²`; for coloured noise `v = H e` it is `|H(ω_k)|² λ` (eq. 15).
    pub fn noise_variance(&self) -> &[T] {
        &self.noise_variance
    }

    /// The transient (leakage) estimate `T̂_k = θ̂_{R+1}`, the constant term of the local
    /// polynomial of the transient at line `k`: McKelvey eq. 4's `T(e^{iω_k})/√N` (plus
    /// the noise transient `T_H/√N` of eq. 15), on the DFT scale of the data. On periodic
    /// data in steady state it is ≈ 0 (within its standard deviation).
    pub fn transient(&self) -> &[Complex<T>] {
        &self.transient
    }

    /// `var(T̂_k) = σ̂²_V,k [(KᴴK)⁻¹]_{R+1,R+1}`.
    pub fn transient_variance(&self) -> &[T] {
        &self.transient_variance
    }

    /// Residual degrees of freedom `q = 2n + 1 − 2(R + 1)` of every noise variance.
    pub fn dof(&self) -> usize {
        self.settings.dof()
    }

    /// The settings used.
    pub fn settings(&self) -> Lpm {
        self.settings
    }

    /// The data the estimate was computed from (with their own noise variances, if any).
    pub fn data(&self) -> &FrequencyData<T> {
        &self.data
    }

    /// The estimate as frequency response data: `Y_k = Ĝ_k`, `U_k = 1`, with
    /// `NoiseVariances::output_only(var(Ĝ_k))` and `variance_dof = q`.
    ///
    /// Degrees of freedom: [`FrequencyData::with_variance_dof`] counts complex degrees of
    /// freedom, `P − 1` for a sample variance over `P` periods, so that `2·dof·σ̂²/σ²` is
    /// χ² with `2·dof` degrees of freedom. The LPM residual variance is a quadratic form
    /// of rank `q` in circular complex noise, `2q σ̂²_V/σ²_V ∼ χ²(2q)`, and `var(Ĝ_k)` is a
    /// fixed multiple of it, so the mapping is `dof = q`. (Windows of neighbouring lines
    /// overlap: the variances of nearby lines are correlated, `q` describes each line.)
    ///
    /// # Errors
    /// Only if the variances are not valid noise variances, which [`lpm`] excludes.
    pub fn frf_data(&self) -> Result<FrequencyData<T>> {
        FrequencyData::from_frf(self.omega().to_vec(), self.frf.clone(), self.ts())?
            .with_noise(NoiseVariances::output_only(self.frf_variance.clone()))?
            .with_variance_dof(self.dof())
    }

    /// The data's own spectra `Y_k`, `U_k` with the LPM output noise level attached:
    /// `NoiseVariances::output_only(σ̂²_V,k)` and `variance_dof = q` (see
    /// [`LpmEstimate::frf_data`] for the mapping). This is the reference noise level for
    /// maximum-likelihood fits on the spectra of a non-periodic record; the spectra still
    /// contain the transient, so the model should carry a transient term
    /// ([`crate::Rational::with_transient`], McKelvey eq. 4). Noise variances the data
    /// already had are replaced.
    ///
    /// # Errors
    /// Only if the variances are not valid noise variances, which [`lpm`] excludes.
    pub fn spectra_data(&self) -> Result<FrequencyData<T>> {
        self.data
            .clone()
            .without_noise()
            .with_noise(NoiseVariances::output_only(self.noise_variance.clone()))?
            .with_variance_dof(self.dof())
    }
}

/// The local polynomial method on the DFT lines of one non-periodic record (all lines,
/// as from [`crate::TimeData::dft`], or a contiguous band of them; the input must be
/// broadband, e.g. random, so that `U` varies from line to line).
///
/// # Model
/// The DFT of a record of a stable system with output noise is (McKelvey eqs. 4 and 15)
/// `Y(k) = G(ω_k) U(k) + T(ω_k) + V(k)`, where `T` collects the plant and noise
/// transients (`T(e^{iω})/√N + T_H(e^{iω})/√N`), a smooth function of frequency, and `V`
/// is the noise. Around each line `k` both `G` and `T` are replaced by polynomials of
/// degree `R` in the line offset `r`:
///
/// `Y(k + r) = [G_k + Σ_{s=1..R} g_s r^s] U(k + r) + [T_k + Σ_{s=1..R} t_s r^s] + V(k + r)`,
///
/// for `r = −n … n` (at the edges of the band the window of `2n + 1` lines is shifted to
/// stay inside it, `r` still counted from `k`). Stacking the window gives
/// `Y_k = K_k θ_k + V_k` with the `(2n+1) × 2(R+1)` complex regressor
/// `K_k = [U r^0, …, U r^R, r^0, …, r^R]` and `θ_k = [G_k, g_1, …, g_R, T_k, t_1, …, t_R]`.
///
/// # Estimates
/// `θ̂_k` is the least squares solution from a Householder QR `K_k = Q R` (never the
/// normal equations):
///
/// - `Ĝ_k = θ̂_0`, `T̂_k = θ̂_{R+1}`;
/// - residual `e_k = Y_k − K_k θ̂_k`, noise variance `σ̂²_V,k = ‖e_k‖² / q`,
///   `q = 2n + 1 − 2(R + 1)`;
/// - `var(Ĝ_k) = σ̂²_V,k [(K_kᴴ K_k)⁻¹]_{00}`, with `(KᴴK)⁻¹ = R⁻¹ R⁻ᴴ`, so
///   `[(KᴴK)⁻¹]_{00} = ‖row 0 of R⁻¹‖²` (and likewise `var(T̂_k)` from row `R + 1`).
///
/// For conditioning the same polynomials are computed in a scaled basis: powers of
/// `x = (j − c)/n`, the offset from the window centre `c` (`x ∈ [−1, 1]`), with unit
/// column norms `d`. Inside the band `c = k` and the formulas above hold as written; in a
/// shifted window the values at line `k` are `aᵀθ̂` with `a = (x_k^s / d_s)_{s=0..R}` on
/// the block of `G` (or of `T`), `x_k = (k − c)/n`, and `var = σ̂²_V,k ‖aᵀ R⁻¹‖²` — the
/// same estimates in a better conditioned basis.
///
/// For circular complex white noise of variance `σ²_V` over the window, `E σ̂²_V,k = σ²_V`
/// and `2q σ̂²_V,k / σ²_V ∼ χ²(2q)`; the bias of `Ĝ_k` is of the order of the
/// `(R+1)`-th derivative of `G` and `T` over the window (Pintelon et al. 2010). With the
/// crate's `1/√N` DFT, white output noise of variance `σ²` per sample has `E|V_k|² = σ²`,
/// so `σ̂²_V` estimates `σ²` directly. Noise variances attached to `data` are ignored.
///
/// On periodic data in steady state the same fit applies unchanged: there is no leakage,
/// and the transient columns come out ≈ 0 (within their standard deviation).
///
/// # Errors
/// - the settings are invalid (see [`Lpm::validate`]);
/// - [`FdidError::TooShort`] when the data have fewer than `2n + 1` lines;
/// - [`FdidError::InvalidArgument`] named `"omega"` when the lines are not equally
///   spaced (the LPM needs consecutive DFT lines), naming the first bad line;
/// - [`FdidError::ZeroInput`] naming the first zero input line of a window whose least
///   squares problem is singular, or [`FdidError::InvalidArgument`] named `"u"` naming
///   the line whose window is singular for another reason (e.g. frequency response data,
///   `U = 1`, where `G` and `T` cannot be separated);
/// - [`FdidError::NonFinite`] if an estimate overflows.
///
/// # Example
/// ```
/// use fdid::data::{Lpm, lpm};
/// use fdid::{Complex, TimeData};
///
/// // y(t) = 0.9 y(t−1) + u(t−1), started from y(−1) = 3, driven by a pseudo-random input
/// let n = 1024;
/// let mut state = 12345u64;
/// let u: Vec<f64> = (0..n)
///     .map(|_| {
///         state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
///         (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
///     })
///     .collect();
/// let (mut y, mut prev_y, mut prev_u) = (vec![0.0; n], 3.0, 0.0);
/// for t in 0..n {
///     y[t] = 0.9 * prev_y + prev_u;
///     prev_y = y[t];
///     prev_u = u[t];
/// }
/// let data = TimeData::new(u, y, 1.0).unwrap().dft();
/// let est = lpm(&data, Lpm::new()).unwrap();
/// assert_eq!(est.dof(), 5);
/// // G(e^{iω}) = e^{−iω} / (1 − 0.9 e^{−iω}) at line 100, recovered despite the leakage
/// let z_inv = Complex::from_polar(1.0, -est.omega()[100]);
/// let g = z_inv / (1.0 - 0.9 * z_inv);
/// assert!((est.frf()[100] - g).norm() < 1e-4 * g.norm());
/// // noise-free, σ̂²_V is only the residual of the polynomial approximation
/// assert!(est.noise_variance()[100] < 1e-8 * data.y()[100].norm_sqr());
/// ```
pub fn lpm<T: Real>(data: &FrequencyData<T>, settings: Lpm) -> Result<LpmEstimate<T>> {
    settings.validate()?;
    let lines = data.len();
    let width = settings.window();
    if lines < width {
        return Err(FdidError::TooShort {
            what: "frequency lines for the LPM window of 2n + 1 lines",
            needed: width,
            got: lines,
        });
    }
    check_uniform_grid(data.omega())?;

    let mut regression = LocalRegression::new(data, &settings);
    let mut frf = Vec::with_capacity(lines);
    let mut frf_variance = Vec::with_capacity(lines);
    let mut noise_variance = Vec::with_capacity(lines);
    let mut transient = Vec::with_capacity(lines);
    let mut transient_variance = Vec::with_capacity(lines);
    for k in 0..lines {
        let line = regression.line(k)?;
        frf.push(line.frf);
        transient.push(line.transient);
        noise_variance.push(line.noise_variance);
        frf_variance.push(line.frf_variance);
        transient_variance.push(line.transient_variance);
    }
    crate::error::check_finite_complex("LPM frequency response", &frf)?;
    crate::error::check_finite_complex("LPM transient", &transient)?;
    crate::error::check_finite("LPM noise variance", &noise_variance)?;
    crate::error::check_finite("LPM frequency response variance", &frf_variance)?;
    crate::error::check_finite("LPM transient variance", &transient_variance)?;
    Ok(LpmEstimate {
        data: data.clone(),
        frf,
        frf_variance,
        noise_variance,
        transient,
        transient_variance,
        settings,
    })
}

/// The estimates of the LPM at one line.
struct LineEstimate<T: Real> {
    /// `Ĝ_k`.
    frf: Complex<T>,
    /// Its variance.
    frf_variance: T,
    /// `T̂_k`, the transient.
    transient: Complex<T>,
    /// Its variance.
    transient_variance: T,
    /// `σ̂²_V,k`, the noise variance of the residual of the window.
    noise_variance: T,
}

/// The local polynomial regression over the window of each line, with the buffers it
/// reuses from line to line.
struct LocalRegression<'a, T: Real> {
    data: &'a FrequencyData<T>,
    /// Half-width `n` and width `2n + 1` of the window.
    half: usize,
    width: usize,
    /// Parameters `2(R + 1)` and coefficients `R + 1` of one polynomial.
    cols: usize,
    order: usize,
    /// Residual degrees of freedom `q`.
    q: T,
    /// `n` in `T`: the line offsets are scaled to `[−1, 1]` by it.
    n_t: T,
    /// Conditioning threshold for the Frobenius condition number of the scaled regressor.
    max_condition: T,
    /// The regressor of the window, its columns scaled to unit norm by `scale`.
    k_mat: DMatrix<Complex<T>>,
    /// The outputs of the window.
    rhs: DVector<Complex<T>>,
    scale: Vec<T>,
}

impl<'a, T: Real> LocalRegression<'a, T> {
    fn new(data: &'a FrequencyData<T>, settings: &Lpm) -> Self {
        let width = settings.window();
        let cols = settings.parameters();
        let zero = Complex::new(T::zero(), T::zero());
        Self {
            data,
            half: settings.half_width(),
            width,
            cols,
            order: settings.degree + 1,
            q: T::from_usize_lossy(settings.dof()),
            n_t: T::from_usize_lossy(settings.half_width()),
            max_condition: T::one() / (T::lit(100.0) * T::epsilon()),
            k_mat: DMatrix::from_element(width, cols, zero),
            rhs: DVector::from_element(width, zero),
            scale: vec![T::one(); cols],
        }
    }

    /// The estimates at line `k` from its window (shifted at the ends of the band).
    fn line(&mut self, k: usize) -> Result<LineEstimate<T>> {
        let lines = self.data.len();
        let start = k.saturating_sub(self.half).min(lines - self.width);
        let centre = T::from_usize_lossy(start + self.half);
        self.fill(start, centre);
        for c in 0..self.cols {
            let norm = self.k_mat.column(c).norm();
            if !(norm > T::zero()) || !Float::is_finite(norm) {
                return Err(self.singular(k, start, f64::INFINITY));
            }
            self.scale[c] = norm;
            self.k_mat.column_mut(c).unscale_mut(norm);
        }
        let qr = self.k_mat.clone().qr();
        let r = qr.r();
        let r_inv = r
            .solve_upper_triangular(&DMatrix::identity(self.cols, self.cols))
            .ok_or_else(|| self.singular(k, start, f64::INFINITY))?;
        let condition = r.norm() * r_inv.norm();
        if !(condition <= self.max_condition) {
            return Err(self.singular(k, start, condition.to_f64_lossless()));
        }
        let mut qty = self.rhs.clone();
        qr.q_tr_mul(&mut qty);
        let theta = &r_inv * qty.rows(0, self.cols);
        let resid = &self.rhs - &self.k_mat * &theta;
        let sigma2 = resid.norm_squared() / self.q;
        // the local polynomials evaluated at line k (x_k = 0 except in shifted windows)
        let x_k = (T::from_usize_lossy(k) - centre) / self.n_t;
        let (frf, frf_variance) = self.evaluate(&theta, &r_inv, sigma2, x_k, 0);
        let (transient, transient_variance) =
            self.evaluate(&theta, &r_inv, sigma2, x_k, self.order);
        Ok(LineEstimate {
            frf,
            frf_variance,
            transient,
            transient_variance,
            noise_variance: sigma2,
        })
    }

    /// The regressor and the outputs of the window of lines `start..start + width`
    /// centred on `centre`: `U_j x^s` and `x^s` with `x` the line offset scaled to
    /// `[−1, 1]`.
    fn fill(&mut self, start: usize, centre: T) {
        let (y, u) = (self.data.y(), self.data.u());
        for (row, j) in (start..start + self.width).enumerate() {
            // offset from the window centre, scaled to [−1, 1]
            let x = (T::from_usize_lossy(j) - centre) / self.n_t;
            let mut p = T::one();
            for s in 0..self.order {
                self.k_mat[(row, s)] = u[j] * p;
                self.k_mat[(row, self.order + s)] = Complex::new(p, T::zero());
                p *= x;
            }
            self.rhs[row] = y[j];
        }
    }

    /// The local polynomial of one block (`G` from column 0, the transient from column
    /// `R + 1`) at `x_k`: value `aᵀθ̂` and variance `σ̂² ‖aᵀ R⁻¹‖²` for `a = (x_k^s / d_s)`
    /// on the block.
    fn evaluate(
        &self,
        theta: &DVector<Complex<T>>,
        r_inv: &DMatrix<Complex<T>>,
        sigma2: T,
        x_k: T,
        block: usize,
    ) -> (Complex<T>, T) {
        let mut value = Complex::new(T::zero(), T::zero());
        let mut row = r_inv.row(block) * Complex::new(T::zero(), T::zero());
        let mut p = T::one();
        for s in block..block + self.order {
            let a = p / self.scale[s];
            value += theta[s] * a;
            row += r_inv.row(s) * Complex::new(a, T::zero());
            p *= x_k;
        }
        (value, sigma2 * row.norm_squared())
    }

    /// The error of a singular regression at line `k` (window from `start`): a zero input
    /// in the window, else the conditioning.
    fn singular(&self, k: usize, start: usize, condition: f64) -> FdidError {
        let (u, omega) = (self.data.u(), self.data.omega());
        match (start..start + self.width).find(|j| u[*j].norm_sqr() == T::zero()) {
            Some(index) => FdidError::ZeroInput {
                index,
                omega: omega[index].to_f64_lossless(),
            },
            None => FdidError::InvalidArgument {
                name: "u",
                value: format!(
                    "window of line {k} (ω = {} rad/s, lines {start}..={})",
                    omega[k],
                    start + self.width - 1
                ),
                reason: format!(
                    "the local polynomial regression is singular (condition number \
                     {condition:.3e}): the input does not vary enough over the window \
                     to separate G from the transient, or the degree is too high for \
                     the precision"
                ),
            },
        }
    }
}

/// Checks that the lines are equally spaced (consecutive DFT lines): every step within
/// 0.1 % of the first step (plus rounding of `ω` in `T`); names the first bad line.
fn check_uniform_grid<T: Real>(omega: &[T]) -> Result<()> {
    let last = omega.len() - 1;
    let step = omega[1] - omega[0];
    let tol = T::lit(1e-3) * step + T::lit(8.0) * T::epsilon() * Float::abs(omega[last]);
    for (i, w) in omega.windows(2).enumerate() {
        let d = w[1] - w[0];
        if !(step > T::zero()) || !(Float::abs(d - step) <= tol) {
            return Err(FdidError::InvalidArgument {
                name: "omega",
                value: format!("step {d} rad/s from line {i} to line {}", i + 1),
                reason: format!(
                    "the local polynomial method needs equally spaced DFT lines (first step \
                     {step} rad/s)"
                ),
            });
        }
    }
    Ok(())
}
