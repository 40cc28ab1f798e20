//! The common-denominator (matrix-fraction) estimator in z: every entry of a frequency
//! response matrix is a ratio of polynomials in z⁻¹ with one denominator shared by all,
//! of any numerator degree (the relative degrees of single-channel fits).

use super::poles::PoleSet;
use super::thin_qr::{ThinQr, at_b, r_factor};
use super::vector_fit::Weighted;
use super::{CommonPoleFit, CommonPoleModel, CommonPoleOptions, MlOutcome, check_order_and_grid};
use crate::data::FrfMatrix;
use crate::error::{FdidError, Result};
use crate::model::Domain;
use crate::problem::NonlinearProblem;
use crate::scalar::{Complex, Real};
use crate::solver::{GramLevenbergMarquardt, LevenbergMarquardt, Solver};
use nalgebra::{DMatrix, DVector};
use num_traits::Float;

/// Fits G_ij(z) = B_ij(z⁻¹)/A(z⁻¹) to every entry of `data`, with
///
/// ```text
/// A(z⁻¹) = 1 + a_1 z⁻¹ + … + a_na z⁻ⁿᵃ   (shared),   B_ij(z⁻¹) = b_0 + b_1 z⁻¹ + … + b_nb z⁻ⁿᵇ,
/// ```
///
/// nb ≤ na — McKelvey's polynomial model (eq. 14) per entry with the denominator shared,
/// the left matrix-fraction form A(z⁻¹)⁻¹B(z⁻¹) with A = a·I; the single-channel
/// `--domain z --na N --nb M` structure for every entry. On the unit circle the powers of
/// z⁻¹ are an orthogonal basis, so the monomial coefficients are well conditioned here
/// (unlike in s).
///
/// 1. **Levy and Sanathanan–Koerner** (McKelvey eqs. 39 and 41) with the fast block
///    solution: per entry, the weighted equations v_k (B(ξ_k) − h_k A(ξ_k)) ≈ 0 (ξ = z⁻¹,
///    v = w/|A_prev|) lose their b by one QR, leaving an (na + 1)-row block in a; the
///    stacked blocks give a by one small least squares. Unstable roots of A are reflected
///    (p → 1/p̄) at every iteration under `options.stable`.
/// 2. **Maximum likelihood** (eq. 23, weighted by the entries' variances) by variable
///    projection over a: the numerators are eliminated, r_e = W(h_e − Φ b_e/A), and
///    Kaufman's Jacobian column j is P⊥ W ξʲ ĥ_e/A (ĥ_e = Φb_e/A the model). The poles'
///    covariance follows from that of a (eq. 32, s² = V/(M − P)) through the roots'
///    sensitivities ∂p/∂a_j = −p^{na−j}/A_z′(p), A_z(z) = zⁿᵃA(z⁻¹).
///
/// The fitted model is returned in partial fractions (its poles are the roots of A_z, its
/// residues N(p)/A_z′(p), its direct term b_0): [`CommonPoleModel::matrix_fraction`]
/// gives the polynomial form back, with b_{nb+1…na} zero to rounding.
///
/// ```
/// use fdid::data::FrfMatrix;
/// use fdid::mimo::{CommonPoleOptions, fit_common_denominator};
/// use fdid::prelude::*;
///
/// // two entries over A = 1 − 1.2 z⁻¹ + 0.5 z⁻², numerators of degree 0 (relative degree 2 in z)
/// let omega: Vec<f64> = (1..=60).map(|k| k as f64 * 3.0 / 60.0).collect();
/// let entry = |b0: f64| -> Vec<Complex<f64>> {
///     omega
///         .iter()
///         .map(|w| {
///             let xi = Complex::new(0.0, -w).exp();
///             Complex::new(b0, 0.0) / (1.0 - 1.2 * xi + 0.5 * xi * xi)
///         })
///         .collect()
/// };
/// let data = FrfMatrix::from_entries(omega.clone(), 2, 1, vec![entry(1.0), entry(-0.3)], Some(1.0))?;
/// let options = CommonPoleOptions { domain: Domain::Discrete { ts: 1.0 }, ..Default::default() };
/// let fit = fit_common_denominator(&data, 2, 0, &options)?;
/// let mf = fit.model.matrix_fraction();
/// assert!((mf.denominator[1] + 1.2).abs() < 1e-10 && (mf.denominator[2] - 0.5).abs() < 1e-10);
/// assert!(mf.numerators[1][2].abs() < 1e-10); // b_2 = 0: the relative degree is kept
/// # Ok::<(), fdid::FdidError>(())
/// ```
///
/// # Errors
/// A continuous-time domain, na = 0 or nb > na ([`FdidError::InvalidArgument`]); lines
/// beyond Nyquist, too few lines (2L < na + nb + 2), non-positive variances; a singular
/// least squares.
pub fn fit_common_denominator<T: Real>(
    data: &FrfMatrix<T>,
    na: usize,
    nb: usize,
    options: &CommonPoleOptions<T>,
) -> Result<CommonPoleFit<T>> {
    let Domain::Discrete { .. } = options.domain else {
        return Err(FdidError::InvalidArgument {
            name: "domain",
            value: "s".into(),
            reason: "the common-denominator estimator is in z⁻¹ (in s use the partial \
                     fractions of fit_common_poles)"
                .into(),
        });
    };
    if nb > na {
        return Err(FdidError::InvalidArgument {
            name: "nb",
            value: nb.to_string(),
            reason: format!("the numerators' degree is at most na = {na}"),
        });
    }
    check_order_and_grid(data.omega(), na, options)?;
    let lines = data.len();
    if 2 * lines < na + nb + 2 {
        return Err(FdidError::TooFewFrequencies {
            lines,
            equations: 2 * lines,
            parameters: na + nb + 2,
        });
    }
    let weighted = Weighted::new(data, options.domain, false)?;
    let problem = Polynomial {
        xi: weighted.x.iter().map(|x| x.conj()).collect(),
        data: &weighted,
        na,
        nb,
    };
    let (a, relocations) = problem.sanathanan_koerner(options)?;
    let (b, costs) = problem.linear_fit(&a)?;
    let relocation_cost = super::vector_fit::total(&costs);
    let mut best = (a.clone(), b, costs, MlOutcome::Skipped);
    if options.ml {
        let solved = GramLevenbergMarquardt::default()
            .solve(&problem, Some(&a))
            .or_else(|_| LevenbergMarquardt::default().solve(&problem, Some(&a)));
        best.3 = MlOutcome::Failed;
        if let Ok(solution) = solved {
            let stable = problem
                .poles(&solution.theta)
                .is_ok_and(|p| p.is_stable(options.domain));
            if options.stable && !stable {
                best.3 = MlOutcome::Unstable;
            } else if let Ok((b, costs)) = problem.linear_fit(&solution.theta)
                && super::vector_fit::total(&costs) <= relocation_cost
            {
                best = (
                    solution.theta.clone(),
                    b,
                    costs,
                    MlOutcome::Kept {
                        converged: solution.converged(),
                    },
                );
            }
        }
    }
    let (a, b, costs, ml) = best;
    let model = problem.model(&a, &b, options.domain)?;
    let cost = super::vector_fit::total(&costs);
    let pole_covariance = options
        .ml
        .then(|| problem.pole_covariance(&a, cost, data.entries().len()))
        .flatten();
    let residual_power = match weighted.w {
        None => costs.clone(),
        Some(_) => problem.residual_power(&a, &b),
    };
    model.check()?;
    Ok(CommonPoleFit {
        model,
        cost,
        costs,
        residual_power,
        relocation_cost,
        relocations,
        ml,
        pole_covariance,
        lines,
        entries: data.entries().len(),
        weighted: weighted.w.is_some(),
        correlated: false,
    })
}

/// The polynomial model's data: ξ_k = z_k⁻¹ on the unit circle, the entries' responses
/// and weights, and the degrees.
struct Polynomial<'a, T: Real> {
    xi: Vec<Complex<T>>,
    data: &'a Weighted<T>,
    na: usize,
    nb: usize,
}

impl<T: Real> Polynomial<'_, T> {
    /// ξ_kʲ for j in `from..=to`, one row per line.
    fn powers(&self, from: usize, to: usize) -> DMatrix<Complex<T>> {
        DMatrix::from_fn(self.xi.len(), to + 1 - from, |k, j| {
            powi(self.xi[k], from + j)
        })
    }

    /// A(ξ_k) = 1 + Σ a_j ξ_kʲ on every line.
    fn denominator(&self, a: &[T]) -> Vec<Complex<T>> {
        self.xi
            .iter()
            .map(|x| {
                // Horner in ξ: ((a_na ξ + a_{na−1}) ξ + …) ξ + 1
                let mut v = Complex::new(T::zero(), T::zero());
                for c in a.iter().rev() {
                    v = (v + *c) * *x;
                }
                v + T::one()
            })
            .collect()
    }

    fn weight(&self, e: usize, k: usize) -> T {
        self.data.weight(e, k)
    }

    /// The regressor Φ/A of the numerator (L × (nb + 1)) for denominator values `den`.
    fn regressor(&self, den: &[Complex<T>]) -> DMatrix<Complex<T>> {
        let mut m = self.powers(0, self.nb);
        for (k, mut row) in m.row_iter_mut().enumerate() {
            row /= den[k];
        }
        m
    }

    /// The weighted target of entry e, real-stacked.
    fn target(&self, e: usize) -> DVector<T> {
        DVector::from_fn(2 * self.xi.len(), |r, _| {
            let v = self.data.h[e][r / 2] * self.weight(e, r / 2);
            if r % 2 == 0 { v.re } else { v.im }
        })
    }

    fn weights(&self, e: usize) -> Option<&[T]> {
        self.data.w.as_ref().map(|w| w[e].as_slice())
    }

    /// Every entry's numerator for the denominator a, by least squares (one QR shared
    /// without weights), and each entry's weighted cost.
    fn linear_fit(&self, a: &[T]) -> Result<(Vec<DVector<T>>, Vec<T>)> {
        let m = self.regressor(&self.denominator(a));
        let shared = match self.data.w {
            None => Some(ThinQr::new(crate::linalg::stack_rows(&m, None))?),
            Some(_) => None,
        };
        let mut coeffs = Vec::with_capacity(self.data.h.len());
        let mut costs = Vec::with_capacity(self.data.h.len());
        for e in 0..self.data.h.len() {
            let own;
            let qr = match &shared {
                Some(q) => q,
                None => {
                    own = ThinQr::new(crate::linalg::stack_rows(&m, self.weights(e)))?;
                    &own
                }
            };
            let t = self.target(e);
            let (x, r) = qr.least_squares(&DMatrix::from_column_slice(t.len(), 1, t.as_slice()))?;
            coeffs.push(x.column(0).into_owned());
            costs.push(r.norm_squared());
        }
        Ok((coeffs, costs))
    }

    /// Each entry's residual power without the weights.
    fn residual_power(&self, a: &[T], b: &[DVector<T>]) -> Vec<T> {
        let m = self.regressor(&self.denominator(a));
        b.iter()
            .zip(&self.data.h)
            .map(|(b, h)| {
                let fit = &m * b.map(|v| Complex::new(v, T::zero()));
                h.iter()
                    .zip(fit.iter())
                    .fold(T::zero(), |s, (h, f)| s + (*h - *f).norm_sqr())
            })
            .collect()
    }

    /// One Levy (no previous denominator) or Sanathanan–Koerner step: the new a.
    fn linearised_step(&self, previous: Option<&[T]>) -> Result<Vec<T>> {
        let na = self.na;
        let sk: Vec<T> = match previous {
            Some(a) => self
                .denominator(a)
                .iter()
                .map(|v| T::one() / v.norm())
                .collect(),
            None => vec![T::one(); self.xi.len()],
        };
        let phi = self.powers(0, self.nb);
        let psi = self.powers(1, na);
        let mut blocks: Vec<DMatrix<T>> = Vec::with_capacity(self.data.h.len());
        for (e, h) in self.data.h.iter().enumerate() {
            let v: Vec<T> = (0..self.xi.len())
                .map(|k| self.weight(e, k) * sk[k])
                .collect();
            let qr = ThinQr::new(crate::linalg::stack_rows(&phi, Some(&v)))?;
            // −h A(ξ) = −h − Σ a_j h ξʲ: the a-columns and the right-hand side h
            let mut x = DMatrix::from_fn(self.xi.len(), na + 1, |k, j| {
                if j < na { -(h[k] * psi[(k, j)]) } else { h[k] }
            });
            for (k, mut row) in x.row_iter_mut().enumerate() {
                row *= Complex::new(v[k], T::zero());
            }
            let x = crate::linalg::stack_rows(&x, None);
            let projected = &x - &qr.q * at_b(&qr.q, &x);
            blocks.push(r_factor(projected));
        }
        let rows: usize = blocks.iter().map(DMatrix::nrows).sum();
        let mut stacked = DMatrix::zeros(rows, na + 1);
        let mut at = 0;
        for b in &blocks {
            stacked.view_mut((at, 0), b.shape()).copy_from(b);
            at += b.nrows();
        }
        let lhs = stacked.columns(0, na).into_owned();
        let rhs = stacked.columns(na, 1).into_owned();
        let (x, _) = ThinQr::new(lhs)?.least_squares(&rhs)?;
        Ok(x.column(0).iter().copied().collect())
    }

    /// Levy, then SK iterations (unstable roots reflected under `stable`) until the
    /// output-error cost changes by less than 10⁻⁹ relatively or `options.relocations`
    /// iterations; the a of least cost and the iterations made.
    fn sanathanan_koerner(&self, options: &CommonPoleOptions<T>) -> Result<(Vec<T>, usize)> {
        let stabilise = |a: Vec<T>| -> Result<Vec<T>> {
            if !options.stable {
                return Ok(a);
            }
            let poles = self.poles(&a)?;
            Ok(if poles.is_stable(options.domain) {
                a
            } else {
                coefficients_of(&poles.reflected(options.domain))
            })
        };
        let mut a = stabilise(self.linearised_step(None)?)?;
        let cost_of = |a: &[T]| {
            self.linear_fit(a)
                .map(|(_, c)| super::vector_fit::total(&c))
        };
        let mut cost = cost_of(&a)?;
        let mut best = (a.clone(), cost);
        let tolerance = T::lit(1e-9);
        let mut done = 0;
        for _ in 0..options.relocations {
            let next = match self.linearised_step(Some(&a)).and_then(&stabilise) {
                Ok(n) => n,
                Err(FdidError::Singular { .. }) => break,
                Err(e) => return Err(e),
            };
            done += 1;
            let previous = cost;
            a = next;
            cost = cost_of(&a)?;
            if cost < best.1 {
                best = (a.clone(), cost);
            }
            if Float::abs(previous - cost) <= tolerance * Float::max(cost, T::min_positive_value())
            {
                break;
            }
        }
        Ok((best.0, done))
    }

    /// The roots of A_z(z) = zⁿᵃ + a_1 zⁿᵃ⁻¹ + … + a_na: the eigenvalues of its companion.
    fn poles(&self, a: &[T]) -> Result<PoleSet<T>> {
        let n = a.len();
        let companion = DMatrix::from_fn(n, n, |i, j| {
            if i == 0 {
                -a[j]
            } else if i == j + 1 {
                T::one()
            } else {
                T::zero()
            }
        });
        let poles = PoleSet::from_eigenvalues(&crate::roots::eigenvalues(companion)?);
        poles.check_finite()?;
        Ok(poles)
    }

    /// The model in partial fractions: the roots p of A_z, the residues N(p)/A_z′(p) with
    /// N(z) = b_0 zⁿᵃ + … + b_nb zⁿᵃ⁻ⁿᵇ, and the direct term b_0.
    fn model(&self, a: &[T], b: &[DVector<T>], domain: Domain<T>) -> Result<CommonPoleModel<T>> {
        let poles = self.poles(a)?;
        if poles.order() != self.na {
            return Err(FdidError::Numerical {
                what: "roots of the common denominator".into(),
            });
        }
        let (ny, nu) = (self.data.ny, self.data.nu);
        let zero = Complex::new(T::zero(), T::zero());
        let na = self.na;
        let numerator = |b: &DVector<T>, p: Complex<T>| {
            b.iter()
                .enumerate()
                .fold(zero, |s, (j, c)| s + powi(p, na - j) * *c)
        };
        let residues = poles
            .slots()
            .iter()
            .map(|p| {
                let d = slope(a, *p);
                DMatrix::from_fn(ny, nu, |i, j| {
                    let r = numerator(&b[j * ny + i], *p) / d;
                    if p.im == T::zero() {
                        Complex::new(r.re, T::zero())
                    } else {
                        r
                    }
                })
            })
            .collect();
        let direct = DMatrix::from_fn(ny, nu, |i, j| b[j * ny + i][0]);
        Ok(CommonPoleModel {
            domain,
            poles,
            residues,
            direct: Some(direct),
        })
    }

    /// The poles' covariance [real…, Re p, Im p of each pair…] from a's, s²(JᵀJ)⁻¹ with
    /// s² = V/(M − P), through ∂p/∂a_j = −p^{na−j}/A_z′(p).
    fn pole_covariance(&self, a: &[T], cost: T, entries: usize) -> Option<DMatrix<T>> {
        let m = self.n_residuals();
        let params = self.na + entries * (self.nb + 1);
        if m <= params {
            return None;
        }
        let mut r = vec![T::zero(); m];
        let mut jac = DMatrix::zeros(m, self.na);
        if !self.jacobian_into(a, &mut r, &mut jac) {
            return None;
        }
        let s2 = cost / T::from_usize_lossy(m - params);
        let cov_a = jac.tr_mul(&jac).try_inverse()? * s2;
        let poles = self.poles(a).ok()?;
        let na = self.na;
        let mut g = DMatrix::zeros(poles.order(), na);
        let mut row = 0;
        for p in poles.slots() {
            let d = slope(a, p);
            for j in 0..na {
                let dp = -powi(p, na - j - 1) / d;
                g[(row, j)] = dp.re;
                if p.im != T::zero() {
                    g[(row + 1, j)] = dp.im;
                }
            }
            row += if p.im == T::zero() { 1 } else { 2 };
        }
        let cov = &g * cov_a * g.transpose();
        cov.iter().all(|v| Float::is_finite(*v)).then_some(cov)
    }
}

/// zⁿ for n ≥ 0.
fn powi<T: Real>(z: Complex<T>, n: usize) -> Complex<T> {
    (0..n).fold(Complex::new(T::one(), T::zero()), |v, _| v * z)
}

/// A_z′(p) = na pⁿᵃ⁻¹ + Σ_{j<na} (na − j) a_j pⁿᵃ⁻ʲ⁻¹ for A_z(z) = zⁿᵃ + a_1 zⁿᵃ⁻¹ + … + a_na.
fn slope<T: Real>(a: &[T], p: Complex<T>) -> Complex<T> {
    let na = a.len();
    let mut v = powi(p, na - 1) * T::from_usize_lossy(na);
    for (j, c) in a.iter().enumerate().take(na - 1) {
        let power = na - (j + 1);
        v += powi(p, power - 1) * (*c * T::from_usize_lossy(power));
    }
    v
}

/// The monic A(z⁻¹) coefficients [a_1, …, a_n] of the poles: the product of their real
/// factors z − p and z² − 2 Re p z + |p|².
fn coefficients_of<T: Real>(poles: &PoleSet<T>) -> Vec<T> {
    let mut c = vec![T::one()];
    let mut times = |factor: &[T]| {
        let mut next = vec![T::zero(); c.len() + factor.len() - 1];
        for (i, x) in c.iter().enumerate() {
            for (j, y) in factor.iter().enumerate() {
                next[i + j] += *x * *y;
            }
        }
        c = next;
    };
    for r in &poles.real {
        times(&[T::one(), -*r]);
    }
    for p in &poles.pairs {
        times(&[T::one(), -(p.re + p.re), p.norm_sqr()]);
    }
    c[1..].to_vec()
}

impl<T: Real> NonlinearProblem<T> for Polynomial<'_, T> {
    fn n_params(&self) -> usize {
        self.na
    }

    fn n_residuals(&self) -> usize {
        2 * self.xi.len() * self.data.h.len()
    }

    fn residuals_into(&self, theta: &[T], r: &mut [T]) -> bool {
        self.evaluate(theta, r, None)
    }

    fn jacobian_into(&self, theta: &[T], r: &mut [T], jac: &mut DMatrix<T>) -> bool {
        self.evaluate(theta, r, Some(jac))
    }
}

impl<T: Real> Polynomial<'_, T> {
    /// r(θ) and, when asked, Kaufman's Jacobian, entry by entry; false when singular or
    /// not finite.
    fn evaluate(&self, a: &[T], r: &mut [T], mut jac: Option<&mut DMatrix<T>>) -> bool {
        let den = self.denominator(a);
        let m = self.regressor(&den);
        let rows = 2 * self.xi.len();
        let psi = self.powers(1, self.na);
        let shared = match self.data.w {
            None => match ThinQr::new(crate::linalg::stack_rows(&m, None)) {
                Ok(q) => Some(q),
                Err(_) => return false,
            },
            Some(_) => None,
        };
        for e in 0..self.data.h.len() {
            let own;
            let qr = match &shared {
                Some(q) => q,
                None => match ThinQr::new(crate::linalg::stack_rows(&m, self.weights(e))) {
                    Ok(q) => {
                        own = q;
                        &own
                    }
                    Err(_) => return false,
                },
            };
            let t = DMatrix::from_column_slice(rows, 1, self.target(e).as_slice());
            let Ok((x, res)) = qr.least_squares(&t) else {
                return false;
            };
            r[e * rows..(e + 1) * rows].copy_from_slice(res.as_slice());
            let Some(jac) = jac.as_mut() else { continue };
            // ĥ = Φb/A; column j: P⊥ W ξʲ ĥ/A
            let b = x.column(0).map(|v| Complex::new(v, T::zero()));
            let model = &m * b;
            let d = DMatrix::from_fn(self.xi.len(), self.na, |k, j| {
                psi[(k, j)] * model[k] / den[k]
            });
            let d = crate::linalg::stack_rows(&d, self.weights(e));
            let projected = &d - &qr.q * at_b(&qr.q, &d);
            jac.view_mut((e * rows, 0), (rows, self.na))
                .copy_from(&projected);
        }
        r.iter().all(|v| Float::is_finite(*v))
            && jac.is_none_or(|j| j.iter().all(|v| Float::is_finite(*v)))
    }
}
