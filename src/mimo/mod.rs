//! Multi-input multi-output models with poles common to every entry: vector fitting's
//! multiport form fitted to frequency response matrices ([`fit_common_poles`]), its real
//! state-space realisation, the modes with their shapes, a passivity check, and the
//! stabilisation diagram over a range of orders ([`stabilisation_diagram`]).
//!
//! A structure tested with one shaker and many accelerometers, an n-port network or a
//! process with several actuators has one set of poles (its modes); fitting the entries
//! one by one gives each its own, spurious, poles. Here every entry shares them:
//!
//! 1. **Pole relocation** (Sanathanan–Koerner as vector fitting, McKelvey eq. 41):
//!    relaxed vector fitting with the fast block solution — one QR per entry, then one
//!    small least squares for the shared denominator — so the cost grows linearly with
//!    the number of entries. Unweighted entries that the ML will fit are relocated as
//!    their leading real orthonormal combinations, dropping directions that hold at most
//!    10⁻⁶ of the data's energy (the same least squares up to that share: a reciprocal
//!    4-port's 16 entries are 10 directions and noise).
//! 2. **Maximum likelihood** (McKelvey eq. 23, output error, weighted by the entries'
//!    variances): Levenberg–Marquardt over the poles alone with the residues eliminated
//!    by variable projection, with the poles' asymptotic covariance (eq. 32).
//!
//! In z the common-denominator form B_ij(z⁻¹)/A(z⁻¹) with any numerator degree is fitted
//! by [`fit_common_denominator`]; [`CommonPoleOptions::full_covariance`] weights by the
//! outputs' full noise covariance.
//!
//! ```
//! use fdid::prelude::*;
//! use fdid::data::FrfMatrix;
//! use fdid::mimo::{CommonPoleOptions, fit_common_poles};
//!
//! // two outputs of one input sharing the poles −0.1 ± 2i and −1
//! let omega: Vec<f64> = (1..=80).map(|k| 0.05 * k as f64).collect();
//! let p = Complex::new(-0.1, 2.0);
//! let g = |r: Complex<f64>, r1: f64, w: f64| {
//!     let s = Complex::new(0.0, w);
//!     r / (s - p) + r.conj() / (s - p.conj()) + r1 / (s + 1.0)
//! };
//! let g1: Vec<_> = omega.iter().map(|w| g(Complex::new(1.0, 0.5), 2.0, *w)).collect();
//! let g2: Vec<_> = omega.iter().map(|w| g(Complex::new(-0.3, 1.0), 0.5, *w)).collect();
//! let data = FrfMatrix::from_entries(omega, 2, 1, vec![g1, g2], None).unwrap();
//! let fit = fit_common_poles(&data, 3, &CommonPoleOptions::default()).unwrap();
//! let pair = fit.model.poles.pairs[0];
//! assert!((pair - p).norm() < 1e-8);
//! ```

mod arc_basis;
mod common_denominator;
mod correlated;
mod errors_in_variables;
mod matrix_fraction;
mod model;
mod passivity;
mod passivity_enforcement;
mod poles;
mod sigma_blocks;
mod stabilisation;
mod start;
mod state_space;
mod thin_qr;
mod varpro;
mod vector_fit;

pub use common_denominator::fit_common_denominator;
pub use matrix_fraction::MatrixFraction;
pub use model::{CommonPoleModel, Mode};
pub use passivity::{PASSIVITY_TOLERANCE, Passivity, passivity};
pub use passivity_enforcement::{Enforcement, enforce_passivity};
pub use poles::PoleSet;
pub use stabilisation::{
    DiagramPole, PhysicalMode, PoleMark, StabilisationDiagram, StabilityTolerances,
    diagram_of_fits, mac, stabilisation_diagram,
};
pub use state_space::StateSpace;

use crate::data::{FrfMatrix, MimoSpectra};
use crate::error::{FdidError, Result};
use crate::model::Domain;
use crate::problem::NonlinearProblem;
use crate::scalar::Real;
use crate::solver::{GramLevenbergMarquardt, LevenbergMarquardt, Solver};
use nalgebra::DMatrix;
use num_traits::Float;
use vector_fit::{Weighted, model_of, relocation_loop};

/// Settings of [`fit_common_poles`].
///
/// | setting | default | meaning |
/// |---|---|---|
/// | `domain` | [`Domain::Continuous`] | poles in s (x = iω) or z (x = e^{iωTs}) |
/// | `direct` | false | estimate a direct term D (biproper entries) |
/// | `stable` | false | reflect unstable poles at every relocation and keep the ML step only when it stays stable |
/// | `relocations` | 30 | cap on the pole relocations |
/// | `ml` | true | refine by maximum likelihood (variable projection) |
/// | `transient` | true | estimate the transient of a finite record ([`fit_common_poles_spectra`] only: an FRF matrix has none) |
/// | `full_covariance` | false | weight by the outputs' full noise covariance when the data carry it (see below) |
///
/// With `full_covariance`, the maximum likelihood weights each line's residual vector r_k
/// of correlated blocks by the inverse of their noise covariance, Σ_k r_kᴴ C_k⁻¹ r_k — the
/// columns of an FRF matrix with [`FrfMatrix::with_covariances`], the outputs of a record
/// averaged over P > ny + 1 periods ([`crate::data::MimoNoise`]) — and the blocks'
/// residues are estimated jointly; otherwise (and in the relocation that starts it) by
/// the diagonal of C_k alone. When the outputs' noise is correlated and the model is
/// right this lowers the poles' variance (to 0.54 of the diagonal weighting's with
/// ρ = 0.95 in the Monte Carlo test). It is off by default because on measured data
/// model errors often dominate the residual and do not share the noise's correlation:
/// on the F-16's three accelerometers (nonlinear distortion at 7.3 Hz) the weighting
/// C⁻¹ magnifies them, and the common-pole `diagnose` keeps adding pairs at 7.1–7.6 Hz
/// up to 30 poles instead of stopping at 20.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CommonPoleOptions<T: Real> {
    /// s or z.
    pub domain: Domain<T>,
    /// Estimate a direct term.
    pub direct: bool,
    /// Return a stable model by construction.
    pub stable: bool,
    /// Cap on the relocation iterations.
    pub relocations: usize,
    /// Refine the relocated poles by maximum likelihood.
    pub ml: bool,
    /// Estimate the transient term of a finite record (spectra only).
    pub transient: bool,
    /// Weight by the full noise covariance of correlated outputs when the data carry it.
    pub full_covariance: bool,
}

impl<T: Real> Default for CommonPoleOptions<T> {
    fn default() -> Self {
        Self {
            domain: Domain::Continuous,
            direct: false,
            stable: false,
            relocations: 30,
            ml: true,
            transient: true,
            full_covariance: false,
        }
    }
}

/// The result of [`fit_common_poles`].
#[derive(Debug, Clone, PartialEq)]
pub struct CommonPoleFit<T: Real> {
    /// The fitted model.
    pub model: CommonPoleModel<T>,
    /// The weighted cost Σ_e Σ_k w²_e,k |G_e,k − Ĝ_e,k|² of the model (for spectra
    /// Σ_i Σ_k |Y_i,k − Ŷ_i,k|², Ŷ with the transient).
    pub cost: T,
    /// Each fitted block's part of the cost: per entry (column by column) for an FRF
    /// matrix, per output for spectra.
    pub costs: Vec<T>,
    /// Each block's residual power without the weights, Σ_k |G_e,k − Ĝ_e,k|² (spectra:
    /// |Y_i,k − Ŷ_i,k|²), in the data's units: equal to `costs` for an unweighted fit.
    pub residual_power: Vec<T>,
    /// The cost after pole relocation, before maximum likelihood.
    pub relocation_cost: T,
    /// Relocations made.
    pub relocations: usize,
    /// Whether the maximum-likelihood step was run and kept, and why not otherwise.
    pub ml: MlOutcome,
    /// Covariance of the pole parameters [real poles…, Re p, Im p of each pair…] in
    /// physical units (rad/s in s), from the variable-projection Jacobian (McKelvey
    /// eq. 32) scaled by the residual variance estimated as V/(M − P) (M real residuals,
    /// P parameters; 1/2 when the entries' variances weight the fit and the model fits to
    /// the noise level, larger when it does not, so a misfit widens the bounds).
    pub pole_covariance: Option<DMatrix<T>>,
    /// Lines and entries fitted.
    pub lines: usize,
    /// Entries of the model (ny·nu).
    pub entries: usize,
    /// True when the entries' variances weighted the fit.
    pub weighted: bool,
    /// True when the full noise covariance of correlated blocks weighted the fit
    /// ([`CommonPoleOptions::full_covariance`]): `cost` is then Σ_k r_kᴴC_k⁻¹r_k and
    /// `costs` splits it by the rows of the whitened residual (block i's residual given
    /// the blocks before it in its column or record).
    pub correlated: bool,
}

/// What became of the maximum-likelihood refinement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MlOutcome {
    /// Not requested.
    Skipped,
    /// Run and kept (`converged` false when its budget stopped it).
    Kept {
        /// Met the convergence test.
        converged: bool,
    },
    /// Run but not kept: it raised the cost or failed.
    Failed,
    /// Run but not kept: it moved a pole out of the stable region under `stable`.
    Unstable,
}

impl<T: Real> CommonPoleFit<T> {
    /// Root-mean-square error over every entry and line, unweighted, against `data`.
    pub fn rms(&self, data: &FrfMatrix<T>) -> T {
        let g = self.model.response(data.omega());
        let mut sum = T::zero();
        for (e, entry) in data.entries().iter().enumerate() {
            let (i, j) = data.position(e);
            for (k, h) in entry.y().iter().enumerate() {
                sum += (*h - g[k][(i, j)]).norm_sqr();
            }
        }
        Float::sqrt(sum / T::from_usize_lossy(data.len() * data.entries().len()))
    }

    /// Standard deviations of the natural frequency (Hz) and damping of each pole slot
    /// (real poles, then pairs, as [`PoleSet::slots`]), to first order from
    /// [`CommonPoleFit::pole_covariance`]; `None` without it or for a discrete-time model.
    pub fn mode_std(&self) -> Option<Vec<(T, T)>> {
        let cov = self.pole_covariance.as_ref()?;
        if self.model.domain != Domain::Continuous {
            return None;
        }
        let poles = &self.model.poles;
        let nr = poles.real.len();
        let two_pi = T::two_pi();
        let mut out: Vec<(T, T)> = (0..nr)
            .map(|t| (Float::sqrt(Float::abs(cov[(t, t)])) / two_pi, T::zero()))
            .collect();
        for (m, p) in poles.pairs.iter().enumerate() {
            let t = nr + 2 * m;
            let w = p.norm();
            // ∂|p|/∂(a, b) = (a, b)/|p|;  ∂ζ/∂(a, b) = (−b², ab)/|p|³ for ζ = −a/|p|
            let gf = [p.re / w, p.im / w];
            let w3 = w * w * w;
            let gz = [-(p.im * p.im) / w3, p.re * p.im / w3];
            let quad = |g: [T; 2]| {
                let mut v = T::zero();
                for a in 0..2 {
                    for b in 0..2 {
                        v += g[a] * cov[(t + a, t + b)] * g[b];
                    }
                }
                Float::sqrt(Float::abs(v))
            };
            out.push((quad(gf) / two_pi, quad(gz)));
        }
        Some(out)
    }
}

/// Fits a common-pole model of `order` poles to every entry of `data`: pole relocation
/// from lightly damped starting poles spread over the band where the entries vary, then (by default) maximum
/// likelihood by variable projection; see the [module documentation](self).
///
/// # Errors
/// `order` 0, a discrete-time domain with lines beyond the Nyquist frequency, too few
/// lines (2L < 2n + 1 + D), non-positive variances, a singular basis (e.g. poles that
/// coincide) in the first relocation.
pub fn fit_common_poles<T: Real>(
    data: &FrfMatrix<T>,
    order: usize,
    options: &CommonPoleOptions<T>,
) -> Result<CommonPoleFit<T>> {
    check_order_and_grid(data.omega(), order, options)?;
    errors_in_variables::reweighted(data, order, None, options)
}

/// [`fit_common_poles`] with the relocation started from the poles `start` (rad/s in s,
/// z in z; its order is the model's) instead of poles placed from the data: a warm start,
/// e.g. a fitted model's poles with a pair added where a resonance is missing
/// ([`crate::workflow::diagnose_common_poles`] refits from both).
///
/// ```
/// use fdid::data::FrfMatrix;
/// use fdid::mimo::{CommonPoleOptions, PoleSet, fit_common_poles_from};
/// use fdid::prelude::*;
///
/// // two entries sharing the poles −0.1 ± 2i
/// let omega: Vec<f64> = (1..=100).map(|k| 0.04 * k as f64).collect();
/// let p = Complex::new(-0.1, 2.0);
/// let entry = |r: f64| -> Vec<Complex<f64>> {
///     omega
///         .iter()
///         .map(|w| {
///             let s = Complex::new(0.0, *w);
///             Complex::new(r, 0.0) / (s - p) + Complex::new(r, 0.0) / (s - p.conj())
///         })
///         .collect()
/// };
/// let data = FrfMatrix::from_entries(omega.clone(), 2, 1, vec![entry(1.0), entry(-0.5)], None)?;
/// let start = PoleSet { real: vec![], pairs: vec![Complex::new(-0.2, 2.2)] };
/// let fit = fit_common_poles_from(&data, &start, &CommonPoleOptions::default())?;
/// assert!((fit.model.poles.pairs[0] - p).norm() < 1e-9);
/// # Ok::<(), fdid::FdidError>(())
/// ```
///
/// # Errors
/// As [`fit_common_poles`]; non-finite starting poles, or a pair with Im p ≤ 0
/// ([`FdidError::InvalidArgument`]).
pub fn fit_common_poles_from<T: Real>(
    data: &FrfMatrix<T>,
    start: &PoleSet<T>,
    options: &CommonPoleOptions<T>,
) -> Result<CommonPoleFit<T>> {
    let order = start.order();
    check_order_and_grid(data.omega(), order, options)?;
    let finite = start.real.iter().all(|r| r.is_finite())
        && start
            .pairs
            .iter()
            .all(|p| p.re.is_finite() && p.im.is_finite());
    if !finite || start.pairs.iter().any(|p| !(p.im > T::zero())) {
        return Err(FdidError::InvalidArgument {
            name: "start",
            value: format!("{:?} {:?}", start.real, start.pairs),
            reason: "starting poles are finite, one member with Im p > 0 per pair".into(),
        });
    }
    errors_in_variables::reweighted(data, order, Some(start), options)
}

/// One common-pole fit of an FRF matrix weighted as it stands (its variances, or its
/// covariances under `full_covariance`), from `start` or from spread poles.
fn fit_matrix<T: Real>(
    data: &FrfMatrix<T>,
    order: usize,
    start: Option<&PoleSet<T>>,
    options: &CommonPoleOptions<T>,
) -> Result<CommonPoleFit<T>> {
    let weighted = Weighted::new(data, options.domain, options.direct)?;
    let whitening = options
        .full_covariance
        .then(|| correlated::Whitening::of_matrix(data))
        .flatten();
    fit_weighted(&weighted, order, options, start, whitening.as_ref())
}

/// Fits a common-pole model of `order` poles to the spectra of a record with several
/// inputs and outputs: every output explained by every input through the same poles,
///
/// ```text
/// Y_i(ω_k) = Σ_j G_ij(x_k) U_j(ω_k) + T_i(x_k) + V_i(ω_k),
/// G_ij(x) = Σ_m R_m,ij/(x − p_m) (+ D_ij),   T_i(x) = Σ_m t_m,i x_T/(x − p_m),
/// ```
///
/// (McKelvey eq. 4 per output, with the transient T of the finite record, x_T = z in z
/// and 1 in s, when `options.transient`), by pole relocation on Y_i σ ≈ Σ_j N_ij U_j + T_i
/// (eq. 41) and output-error maximum likelihood (eq. 23) with the residues and
/// transients eliminated by variable projection. The inputs need not be separated by
/// experiment: this is how a record in which several actuators act at once (the CD
/// player arm) is identified without a frequency response matrix. The outputs are
/// weighted equally (no noise variances: scale the outputs to comparable noise first).
///
/// ```
/// use fdid::data::MimoSpectra;
/// use fdid::mimo::{CommonPoleOptions, fit_common_poles_spectra};
/// use fdid::prelude::*;
///
/// // y(t) = 0.8 y(t−1) + u1(t−1) − 0.5 u2(t−1): one pole at 0.8 shared by both inputs
/// let n = 256;
/// let u1: Vec<f64> = (0..n).map(|t| ((t * 7919 % 101) as f64 / 50.0) - 1.0).collect();
/// let u2: Vec<f64> = (0..n).map(|t| ((t * 104729 % 97) as f64 / 48.0) - 1.0).collect();
/// let mut y = vec![0.0; n];
/// for t in 1..n {
///     y[t] = 0.8 * y[t - 1] + u1[t - 1] - 0.5 * u2[t - 1];
/// }
/// let data = MimoSpectra::from_time(vec![u1, u2], vec![y], 1.0).unwrap();
/// let options = CommonPoleOptions { domain: Domain::Discrete { ts: 1.0 }, ..Default::default() };
/// let fit = fit_common_poles_spectra(&data, 1, &options).unwrap();
/// assert!((fit.model.poles.real[0] - 0.8).abs() < 1e-9);
/// let r = &fit.model.residues[0];
/// assert!((r[(0, 0)].re - 1.0).abs() < 1e-8 && (r[(0, 1)].re + 0.5).abs() < 1e-8);
/// ```
///
/// # Errors
/// As [`fit_common_poles`], with too few lines counted against every block's linear
/// parameters (2L ≥ nu(n + D) + n + n + 1 with a transient).
pub fn fit_common_poles_spectra<T: Real>(
    data: &MimoSpectra<T>,
    order: usize,
    options: &CommonPoleOptions<T>,
) -> Result<CommonPoleFit<T>> {
    check_order_and_grid(data.omega(), order, options)?;
    let weighted = Weighted::from_spectra(data, options.domain, options.direct, options.transient)?;
    let whitening = options
        .full_covariance
        .then(|| correlated::Whitening::of_spectra(data))
        .flatten();
    fit_weighted(&weighted, order, options, None, whitening.as_ref())
}

/// Checks the order (at least one pole) and, in z, that no line lies beyond Nyquist.
fn check_order_and_grid<T: Real>(
    omega: &[T],
    order: usize,
    options: &CommonPoleOptions<T>,
) -> Result<()> {
    if order == 0 {
        return Err(FdidError::InvalidArgument {
            name: "order",
            value: "0".into(),
            reason: "a common-pole model needs at least one pole".into(),
        });
    }
    if let Domain::Discrete { ts } = options.domain {
        let nyquist = T::pi() / ts;
        let top = omega.iter().copied().fold(T::zero(), Float::max);
        if top > nyquist * (T::one() + T::lit(1e-9)) {
            return Err(FdidError::InvalidArgument {
                name: "ts",
                value: format!("{ts}"),
                reason: format!(
                    "lines up to {} Hz lie beyond the Nyquist frequency {} Hz",
                    top / T::two_pi(),
                    nyquist / T::two_pi()
                ),
            });
        }
    }
    Ok(())
}

/// Relocation and maximum likelihood on the weighted blocks; with `whitening` (correlated
/// blocks, [`CommonPoleOptions::full_covariance`]) the cost and ML are the joint ones.
fn fit_weighted<T: Real>(
    weighted: &Weighted<T>,
    order: usize,
    options: &CommonPoleOptions<T>,
    start: Option<&PoleSet<T>>,
    whitening: Option<&correlated::Whitening<T>>,
) -> Result<CommonPoleFit<T>> {
    let lines = weighted.lines();
    let needed = weighted.linear_parameters(order) + order + 1;
    if 2 * lines < needed {
        return Err(FdidError::TooFewFrequencies {
            lines,
            equations: 2 * lines,
            parameters: needed,
        });
    }
    // with ML to follow, the relocations run on the entries' leading directions (the
    // same least squares up to a share of 10⁻⁶ of the data); the ML fits every entry
    let compressed = (options.ml && whitening.is_none())
        .then(|| weighted.compressed())
        .flatten();
    let vector_fit::Relocated {
        poles,
        coeffs,
        costs,
        relocations,
    } = relocation_loop(
        compressed.as_ref().unwrap_or(weighted),
        options.domain,
        order,
        options.stable,
        options.relocations,
        start.map(|p| p.scaled(T::one() / weighted.scale)),
        options.ml,
    )?;
    let joint = whitening.map(|whitening| correlated::JointVarPro {
        data: weighted,
        whitening,
        n_real: poles.real.len(),
        order,
    });
    let separate = varpro::VarPro {
        data: weighted,
        n_real: poles.real.len(),
        order,
    };
    let problem: &(dyn NonlinearProblem<T> + Sync) = match &joint {
        Some(j) => j,
        None => &separate,
    };
    let linear_fit = |p: &PoleSet<T>| match &joint {
        Some(j) => j.linear_fit(p),
        None => weighted.linear_fit(p),
    };
    // with correlated blocks the relocation's diagonal weights only start the search (the
    // cost is the full-covariance one), and a compressed relocation fitted fewer blocks:
    // the linear fit of every block at the relocated poles runs beside the ML from them
    let refit = joint.is_some() || compressed.is_some();
    let start_theta = poles.theta();
    let (relocated_fit, solved) = crate::linalg::parallel::join(
        || match refit {
            true => linear_fit(&poles).map(Some),
            false => Ok(None),
        },
        || {
            options.ml.then(|| {
                GramLevenbergMarquardt::default()
                    .solve_damped(problem, &start_theta)
                    .or_else(|_| LevenbergMarquardt::default().solve(problem, Some(&start_theta)))
            })
        },
    );
    let (coeffs, costs) = relocated_fit?.unwrap_or((coeffs, costs));
    let relocation_cost = vector_fit::total(&costs);
    let mut fit = CommonPoleFit {
        model: model_of(weighted, options.domain, &poles, &coeffs),
        cost: relocation_cost,
        costs,
        residual_power: Vec::new(),
        relocation_cost,
        relocations,
        ml: MlOutcome::Skipped,
        pole_covariance: None,
        lines,
        entries: weighted.ny * weighted.nu,
        weighted: weighted.w.is_some(),
        correlated: joint.is_some(),
    };
    let mut final_poles = poles.clone();
    let mut final_coeffs = coeffs;
    if let Some(solved) = solved {
        fit.ml = MlOutcome::Failed;
        // the linear fit at the ML's poles and the normal equations there (the poles'
        // covariance when they are kept) in parallel
        let mut normal = None;
        if let Ok(solution) = solved {
            let candidate = PoleSet::from_theta(poles.real.len(), &solution.theta);
            if options.stable && !candidate.is_stable(unit(options.domain)) {
                fit.ml = MlOutcome::Unstable;
            } else {
                let (fitted, at_candidate) = crate::linalg::parallel::join(
                    || linear_fit(&candidate),
                    || normal_matrix(problem, &candidate),
                );
                if let Ok((c, costs)) = fitted
                    && vector_fit::total(&costs) <= relocation_cost
                {
                    fit.model = model_of(weighted, options.domain, &candidate, &c);
                    final_coeffs = c;
                    fit.cost = vector_fit::total(&costs);
                    fit.costs = costs;
                    fit.ml = MlOutcome::Kept {
                        converged: solution.converged(),
                    };
                    final_poles = candidate;
                    normal = Some(at_candidate);
                }
            }
        }
        let normal = normal.unwrap_or_else(|| normal_matrix(problem, &final_poles));
        fit.pole_covariance = normal.and_then(|n| covariance(n, order, &fit, weighted));
    }
    fit.residual_power = match weighted.w {
        None => fit.costs.clone(),
        Some(_) => weighted.residual_power(&final_poles, &final_coeffs),
    };
    fit.model.check()?;
    Ok(fit)
}

/// The domain of the fitting variable (its stability region is the physical one's).
fn unit<T: Real>(domain: Domain<T>) -> Domain<T> {
    match domain {
        Domain::Continuous => Domain::Continuous,
        Domain::Discrete { .. } => Domain::Discrete { ts: T::one() },
    }
}

/// The Gram matrix JᵀJ of the ML problem at `poles` and its number of residuals; `None`
/// when the evaluation fails.
fn normal_matrix<T: Real>(
    problem: &dyn NonlinearProblem<T>,
    poles: &PoleSet<T>,
) -> Option<(DMatrix<T>, usize)> {
    let theta = poles.theta();
    let m = problem.n_residuals();
    let mut r = vec![T::zero(); m];
    let mut jac = DMatrix::zeros(0, 0);
    let mut gram = DMatrix::zeros(0, 0);
    let mut grad = nalgebra::DVector::zeros(0);
    problem
        .normal_equations_into(&theta, &mut r, &mut jac, &mut gram, &mut grad)
        .then_some((gram, m))
}

/// The poles' covariance s²(JᵀJ)⁻¹ at the final poles, in physical units, from the
/// Gram matrix and residual count of [`normal_matrix`] there.
fn covariance<T: Real>(
    (gram, m): (DMatrix<T>, usize),
    order: usize,
    fit: &CommonPoleFit<T>,
    data: &Weighted<T>,
) -> Option<DMatrix<T>> {
    let params = order + data.h.len() * data.linear_parameters(order);
    // V/(M − P): 1/2 when weighted by the true variances and the model fits to the noise
    // level, larger (and honest) when it does not
    if m <= params {
        return None;
    }
    let s2 = fit.cost / T::from_usize_lossy(m - params);
    let inverse = gram.try_inverse()?;
    let scale2 = data.scale * data.scale;
    let cov = inverse * (s2 * scale2);
    cov.iter().all(|v| Float::is_finite(*v)).then_some(cov)
}
