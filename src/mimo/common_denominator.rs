//! The common-denominator (matrix-fraction) estimator: every entry of a frequency
//! response matrix is a ratio of polynomials in z⁻¹ (or s) with one denominator shared
//! by all, of any numerator degree (the relative degrees of single-channel fits).

use super::arc_basis::ArcBasis;
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

/// Fits every entry of `data` with one denominator A of degree na and numerators of
/// degree nb ≤ na, in z and in s:
///
/// ```text
/// G_ij(z) = B_ij(z⁻¹)/A(z⁻¹),  A = 1 + a_1 z⁻¹ + … + a_na z⁻ⁿᵃ,  B_ij = b_0 + … + b_nb z⁻ⁿᵇ;
/// G_ij(s) = B_ij(s)/A(s),      deg A = na, deg B_ij = nb (relative degree na − nb),
/// ```
///
/// McKelvey's polynomial model (eq. 14) per entry with the denominator shared — the left
/// matrix-fraction form A⁻¹B with A = a·I; the single-channel `--na N --nb M` structure
/// for every entry (the partial fractions of [`super::fit_common_poles`] take relative
/// degree 0 or 1 only). A and B are computed in real polynomials q_j(ξ) orthonormal on the
/// lines (an Arnoldi recurrence; ξ = z⁻¹, or s/ω_s with ω_s the top line): the powers ξʲ
/// are nearly dependent on the short arc of the unit circle that a narrow band of
/// oversampled data covers (the F-16's 2–15 Hz at 400 Hz), and over decades in s.
///
/// 1. **Levy and Sanathanan–Koerner** (McKelvey eqs. 39 and 41) with the fast block
///    solution: per entry, the weighted equations v_k (B(ξ_k) − h_k A(ξ_k)) ≈ 0 (v =
///    w/|A_prev|) lose their numerator by one QR, leaving an (na + 1)-row block in A's
///    coefficients α; the stacked blocks give α (‖α‖ = 1) as the right singular vector
///    of their least singular value. Unstable roots are reflected (p → 1/p̄ in z, −p̄ in
///    s) at every iteration under `options.stable`.
/// 2. **Maximum likelihood** (eq. 23, weighted by the entries' variances) by variable
///    projection over α (its largest coefficient held, which fixes A's scale): the
///    numerators are eliminated, r_e = W(h_e − Q_B β_e/A), and Kaufman's Jacobian column
///    j is P⊥ W q_j ĥ_e/A (ĥ_e = Q_Bβ_e/A the model). The poles' covariance follows from
///    α's (eq. 32, s² = V/(M − P)) through the roots' sensitivities ∂r/∂α_j =
///    −q_j(r)/A′(r) (p = 1/r in z, ω_s r in s).
///
/// The roots of A are the eigenvalues of the recurrence's confederate matrix. The fitted
/// model is returned in partial fractions: in z the poles p = 1/ξ*, the residues
/// −B(ξ*)/(A′(ξ*) ξ*²) and the direct term B(0)/A(0); in s the poles ω_s r, the residues
/// ω_s B(r)/A′(r) and a direct term when nb = na (none otherwise).
/// [`CommonPoleModel::matrix_fraction`] gives the polynomial form back: in z b_{nb+1…na}
/// zero to rounding, in s the leading na − nb numerator coefficients.
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
/// Of `options`, `domain`, `stable`, `relocations` (the cap on SK iterations) and `ml`
/// apply; the numerators' degree sets the direct term (`direct` is not used), and there is
/// no transient or full-covariance weighting.
///
/// # Errors
/// na = 0 or nb > na ([`FdidError::InvalidArgument`]); lines beyond Nyquist, too few
/// lines (2L < na + nb + 2), non-positive variances; a singular least squares.
pub fn fit_common_denominator<T: Real>(
    data: &FrfMatrix<T>,
    na: usize,
    nb: usize,
    options: &CommonPoleOptions<T>,
) -> Result<CommonPoleFit<T>> {
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
    // the variable of the polynomials: z⁻¹ on the unit circle, s/ω_s on the imaginary axis
    let xi: Vec<Complex<T>> = match options.domain {
        Domain::Discrete { .. } => weighted.x.iter().map(|x| x.conj()).collect(),
        Domain::Continuous => weighted.x.clone(),
    };
    let mut problem = Polynomial {
        basis: ArcBasis::new(&xi, na)?,
        xi,
        domain: options.domain,
        data: &weighted,
        na,
        nb,
        fixed: (0, T::one()),
    };
    let (a, relocations) = problem.sanathanan_koerner(options)?;
    let (b, costs) = problem.linear_fit(&a)?;
    let relocation_cost = super::vector_fit::total(&costs);
    // the ML holds A's largest coefficient, which fixes the scale B/A leaves free
    let held = (0..a.len())
        .max_by(|i, j| {
            Float::abs(a[*i])
                .partial_cmp(&Float::abs(a[*j]))
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .unwrap_or(0);
    problem.fixed = (held, a[held]);
    let mut best = (a.clone(), b, costs, MlOutcome::Skipped);
    if options.ml {
        let start = problem.theta(&a);
        let solved = GramLevenbergMarquardt::default()
            .solve(&problem, Some(&start))
            .or_else(|_| LevenbergMarquardt::default().solve(&problem, Some(&start)));
        best.3 = MlOutcome::Failed;
        if let Ok(solution) = solved {
            let alpha = problem.alpha(&solution.theta);
            let stable = problem
                .poles(&alpha)
                .is_ok_and(|p| p.is_stable(options.domain));
            if options.stable && !stable {
                best.3 = MlOutcome::Unstable;
            } else if let Ok((b, costs)) = problem.linear_fit(&alpha)
                && super::vector_fit::total(&costs) <= relocation_cost
            {
                best = (
                    alpha,
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

/// The polynomial model's data: the lines' ξ = z⁻¹, the orthonormal basis on them, the
/// entries' responses and weights, the degrees, and the coefficient of A held fixed in
/// the maximum likelihood (index, value).
struct Polynomial<'a, T: Real> {
    xi: Vec<Complex<T>>,
    basis: ArcBasis<T>,
    domain: Domain<T>,
    data: &'a Weighted<T>,
    na: usize,
    nb: usize,
    fixed: (usize, T),
}

impl<T: Real> Polynomial<'_, T> {
    /// A(ξ_k) = Σ α_j q_j(ξ_k) on every line.
    fn denominator(&self, alpha: &[T]) -> Vec<Complex<T>> {
        let q = self.basis.on_lines(self.na);
        (0..self.xi.len())
            .map(|k| {
                alpha
                    .iter()
                    .enumerate()
                    .fold(Complex::new(T::zero(), T::zero()), |s, (j, a)| {
                        s + q[(k, j)] * *a
                    })
            })
            .collect()
    }

    fn weight(&self, e: usize, k: usize) -> T {
        self.data.weight(e, k)
    }

    fn weights(&self, e: usize) -> Option<&[T]> {
        self.data.w.as_ref().map(|w| w[e].as_slice())
    }

    /// The numerator's regressor Q_B/A (L × (nb + 1)) for denominator values `den`.
    fn regressor(&self, den: &[Complex<T>]) -> DMatrix<Complex<T>> {
        let mut m = self.basis.on_lines(self.nb);
        for (k, mut row) in m.row_iter_mut().enumerate() {
            row /= den[k];
        }
        m
    }

    /// The weighted target of entry e, real-stacked.
    fn target(&self, e: usize) -> DMatrix<T> {
        DMatrix::from_fn(2 * self.xi.len(), 1, |r, _| {
            let v = self.data.h[e][r / 2] * self.weight(e, r / 2);
            if r % 2 == 0 { v.re } else { v.im }
        })
    }

    /// The least squares of each entry's numerator for the denominator values `den`: one
    /// QR shared without weights, one per entry with them; hands each entry's factor,
    /// coefficients and residual to `sink`.
    fn each_entry(
        &self,
        den: &[Complex<T>],
        mut sink: impl FnMut(usize, &ThinQr<T>, &DMatrix<T>, &DMatrix<T>),
    ) -> Result<()> {
        let m = self.regressor(den);
        let shared = match self.data.w {
            None => Some(ThinQr::new(crate::linalg::stack_rows(&m, None))?),
            Some(_) => None,
        };
        for e in 0..self.data.h.len() {
            let own;
            let qr = match &shared {
                Some(q) => q,
                None => {
                    own = ThinQr::new(crate::linalg::stack_rows(&m, self.weights(e)))?;
                    &own
                }
            };
            let (x, r) = qr.least_squares(&self.target(e))?;
            sink(e, qr, &x, &r);
        }
        Ok(())
    }

    /// Every entry's numerator coefficients β_e for A's coefficients α, and each entry's
    /// weighted cost.
    fn linear_fit(&self, alpha: &[T]) -> Result<(Vec<DVector<T>>, Vec<T>)> {
        let mut coeffs = Vec::with_capacity(self.data.h.len());
        let mut costs = Vec::with_capacity(self.data.h.len());
        self.each_entry(&self.denominator(alpha), |_, _, x, r| {
            coeffs.push(x.column(0).into_owned());
            costs.push(r.norm_squared());
        })?;
        Ok((coeffs, costs))
    }

    /// Each entry's residual power without the weights.
    fn residual_power(&self, alpha: &[T], b: &[DVector<T>]) -> Vec<T> {
        let m = self.regressor(&self.denominator(alpha));
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

    /// One Levy (no previous denominator) or Sanathanan–Koerner step: the new α, ‖α‖ = 1.
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
        let qb = self.basis.on_lines(self.nb);
        let qa = self.basis.on_lines(na);
        let mut blocks: Vec<DMatrix<T>> = Vec::with_capacity(self.data.h.len());
        for (e, h) in self.data.h.iter().enumerate() {
            let v: Vec<T> = (0..self.xi.len())
                .map(|k| self.weight(e, k) * sk[k])
                .collect();
            let qr = ThinQr::new(crate::linalg::stack_rows(&qb, Some(&v)))?;
            let x = DMatrix::from_fn(self.xi.len(), na + 1, |k, j| -(h[k] * qa[(k, j)]));
            let x = crate::linalg::stack_rows(&x, Some(&v));
            blocks.push(r_factor(&x - &qr.q * at_b(&qr.q, &x)));
        }
        let rows: usize = blocks.iter().map(DMatrix::nrows).sum();
        let mut stacked = DMatrix::zeros(rows, na + 1);
        let mut at = 0;
        for b in &blocks {
            stacked.view_mut((at, 0), b.shape()).copy_from(b);
            at += b.nrows();
        }
        let r = if stacked.nrows() > na + 1 {
            r_factor(stacked)
        } else {
            stacked
        };
        let svd = crate::linalg::try_svd(r, false, true, 200 * (na + 1).max(10)).ok_or(
            FdidError::NotConverged {
                method: "SVD",
                reason: "no convergence for the common denominator's linearised problem".into(),
            },
        )?;
        let v_t = svd.v_t.as_ref().ok_or(FdidError::Numerical {
            what: "SVD without right singular vectors".into(),
        })?;
        let least = (0..svd.singular_values.len())
            .min_by(|a, b| {
                svd.singular_values[*a]
                    .partial_cmp(&svd.singular_values[*b])
                    .unwrap_or(std::cmp::Ordering::Equal)
            })
            .ok_or(FdidError::Numerical {
                what: "empty SVD".into(),
            })?;
        Ok(v_t.row(least).iter().copied().collect())
    }

    /// α (‖α‖ = 1) of the polynomial with the roots ξ*: the product of the factors
    /// ξ − ξ* (or 1 − ξ/ξ* when |ξ*| > 1, to keep it in range) on the lines, projected.
    fn with_roots(&self, roots: &[Complex<T>]) -> Vec<T> {
        let one = Complex::new(T::one(), T::zero());
        let f: Vec<Complex<T>> = self
            .xi
            .iter()
            .map(|x| {
                roots.iter().fold(one, |v, r| {
                    v * if r.norm() > T::one() {
                        one - *x / *r
                    } else {
                        *x - *r
                    }
                })
            })
            .collect();
        normalised(self.basis.project(&f, self.na))
    }

    /// Levy, then SK iterations (unstable roots reflected under `stable`) until the
    /// output-error cost changes by less than 10⁻⁹ relatively or `options.relocations`
    /// iterations; the α of least cost and the iterations made.
    fn sanathanan_koerner(&self, options: &CommonPoleOptions<T>) -> Result<(Vec<T>, usize)> {
        let stabilise = |a: Vec<T>| -> Result<Vec<T>> {
            if !options.stable {
                return Ok(a);
            }
            let roots = self.basis.roots(&a)?;
            let stable = |r: &Complex<T>| super::poles::stable(self.pole_of_root(*r), self.domain);
            if roots.iter().all(stable) {
                return Ok(a);
            }
            // p → 1/p̄ in z is ξ* → 1/ξ̄*; p → −p̄ in s is r → −r̄
            let reflected: Vec<Complex<T>> = roots
                .iter()
                .map(|r| match (stable(r), self.domain) {
                    (true, _) => *r,
                    (false, Domain::Discrete { .. }) => crate::scalar::recip(r.conj()),
                    (false, Domain::Continuous) => -r.conj(),
                })
                .collect();
            Ok(self.with_roots(&reflected))
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
            cost = match cost_of(&a) {
                Ok(c) => c,
                Err(FdidError::Singular { .. }) => break,
                Err(e) => return Err(e),
            };
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

    /// α from the ML parameters (the free coefficients) and the held one.
    fn alpha(&self, theta: &[T]) -> Vec<T> {
        let mut a = theta.to_vec();
        a.insert(self.fixed.0, self.fixed.1);
        a
    }

    /// The ML parameters of α: every coefficient but the held one.
    fn theta(&self, alpha: &[T]) -> Vec<T> {
        let mut t = alpha.to_vec();
        t.remove(self.fixed.0);
        t
    }

    /// The pole of a root r of A: 1/r in z (r = ξ* = 1/p), ω_s r in s.
    fn pole_of_root(&self, r: Complex<T>) -> Complex<T> {
        match self.domain {
            Domain::Discrete { .. } => crate::scalar::recip(r),
            Domain::Continuous => r * self.data.scale,
        }
    }

    /// The root of A of a pole (the inverse of [`Polynomial::pole_of_root`]).
    fn root_of_pole(&self, p: Complex<T>) -> Complex<T> {
        match self.domain {
            Domain::Discrete { .. } => crate::scalar::recip(p),
            Domain::Continuous => p / self.data.scale,
        }
    }

    /// At a root r of A: the basis q_j(r) and κ with the residue B(r)/κ and ∂p/∂α_j =
    /// −q_j(r)/κ — κ = −A′(ξ*)ξ*² in z (p = 1/ξ*), A′(r)/ω_s in s (p = ω_s r).
    fn at_root(&self, alpha: &[T], r: Complex<T>) -> (Vec<Complex<T>>, Complex<T>) {
        let (q, dq) = self.basis.at(r, self.na);
        let slope = alpha
            .iter()
            .zip(&dq)
            .fold(Complex::new(T::zero(), T::zero()), |s, (a, d)| s + *d * *a);
        let kappa = match self.domain {
            Domain::Discrete { .. } => -(slope * r * r),
            Domain::Continuous => slope / self.data.scale,
        };
        (q, kappa)
    }

    /// The poles of the roots of A.
    fn poles(&self, alpha: &[T]) -> Result<PoleSet<T>> {
        let roots = self.basis.roots(alpha)?;
        let poles: Vec<Complex<T>> = roots.iter().map(|r| self.pole_of_root(*r)).collect();
        let set = PoleSet::from_eigenvalues(&poles);
        set.check_finite()?;
        Ok(set)
    }

    /// The model in partial fractions: the poles of A's roots r, residues B(r)/κ
    /// ([`Polynomial::at_root`]), and the direct term B(0)/A(0) in z (G at z = ∞), in s
    /// β_na/α_na when nb = na (none for a strictly proper model).
    fn model(
        &self,
        alpha: &[T],
        b: &[DVector<T>],
        domain: Domain<T>,
    ) -> Result<CommonPoleModel<T>> {
        let poles = self.poles(alpha)?;
        if poles.order() != self.na {
            return Err(FdidError::Numerical {
                what: "roots of the common denominator".into(),
            });
        }
        let (ny, nu) = (self.data.ny, self.data.nu);
        let zero = Complex::new(T::zero(), T::zero());
        let value =
            |c: &DVector<T>, q: &[Complex<T>]| c.iter().zip(q).fold(zero, |s, (c, q)| s + *q * *c);
        let residues = poles
            .slots()
            .iter()
            .map(|p| {
                let (q, kappa) = self.at_root(alpha, self.root_of_pole(*p));
                DMatrix::from_fn(ny, nu, |i, j| {
                    let r = value(&b[j * ny + i], &q) / kappa;
                    if p.im == T::zero() {
                        Complex::new(r.re, T::zero())
                    } else {
                        r
                    }
                })
            })
            .collect();
        let direct = match domain {
            Domain::Discrete { .. } => {
                let (q0, _) = self.basis.at(zero, self.na);
                let a0 = alpha.iter().zip(&q0).fold(zero, |s, (a, q)| s + *q * *a);
                Some(DMatrix::from_fn(ny, nu, |i, j| {
                    (value(&b[j * ny + i], &q0) / a0).re
                }))
            }
            // the leading coefficients of B and A multiply the same q_na
            Domain::Continuous => (self.nb == self.na)
                .then(|| DMatrix::from_fn(ny, nu, |i, j| b[j * ny + i][self.na] / alpha[self.na])),
        };
        Ok(CommonPoleModel {
            domain,
            poles,
            residues,
            direct,
        })
    }

    /// The poles' covariance [real…, Re p, Im p of each pair…] from α's free part,
    /// s²(JᵀJ)⁻¹ with s² = V/(M − P), through ∂p/∂α_j = −q_j(r)/κ
    /// ([`Polynomial::at_root`]).
    fn pole_covariance(&self, alpha: &[T], cost: T, entries: usize) -> Option<DMatrix<T>> {
        let m = self.n_residuals();
        let free = self.na;
        let params = free + entries * (self.nb + 1);
        if m <= params {
            return None;
        }
        let mut r = vec![T::zero(); m];
        let mut jac = DMatrix::zeros(m, free);
        if !self.jacobian_into(&self.theta(alpha), &mut r, &mut jac) {
            return None;
        }
        let s2 = cost / T::from_usize_lossy(m - params);
        let cov_free = jac.tr_mul(&jac).try_inverse()? * s2;
        let poles = self.poles(alpha).ok()?;
        let mut g = DMatrix::zeros(poles.order(), free);
        let mut row = 0;
        for p in poles.slots() {
            let (q, kappa) = self.at_root(alpha, self.root_of_pole(p));
            let columns = (0..=self.na).filter(|j| *j != self.fixed.0);
            for (c, j) in columns.enumerate() {
                let dp = -q[j] / kappa;
                g[(row, c)] = dp.re;
                if p.im != T::zero() {
                    g[(row + 1, c)] = dp.im;
                }
            }
            row += if p.im == T::zero() { 1 } else { 2 };
        }
        let cov = &g * cov_free * g.transpose();
        cov.iter().all(|v| Float::is_finite(*v)).then_some(cov)
    }

    /// r(θ) and, when asked, Kaufman's Jacobian, entry by entry; false when singular or
    /// not finite.
    fn evaluate(&self, theta: &[T], r: &mut [T], mut jac: Option<&mut DMatrix<T>>) -> bool {
        let alpha = self.alpha(theta);
        let den = self.denominator(&alpha);
        let rows = 2 * self.xi.len();
        let qa = self.basis.on_lines(self.na);
        let m = self.regressor(&den);
        let fixed = self.fixed.0;
        let outcome = self.each_entry(&den, |e, qr, x, res| {
            r[e * rows..(e + 1) * rows].copy_from_slice(res.as_slice());
            let Some(jac) = jac.as_mut() else { return };
            // ĥ = Q_Bβ/A; column j: P⊥ W q_j ĥ/A
            let model = &m * x.column(0).map(|v| Complex::new(v, T::zero()));
            let d = DMatrix::from_fn(self.xi.len(), self.na, |k, c| {
                let j = if c < fixed { c } else { c + 1 };
                qa[(k, j)] * model[k] / den[k]
            });
            let d = crate::linalg::stack_rows(&d, self.weights(e));
            let projected = &d - &qr.q * at_b(&qr.q, &d);
            jac.view_mut((e * rows, 0), (rows, self.na))
                .copy_from(&projected);
        });
        outcome.is_ok()
            && r.iter().all(|v| Float::is_finite(*v))
            && jac.is_none_or(|j| j.iter().all(|v| Float::is_finite(*v)))
    }
}

/// `v` scaled to unit norm.
fn normalised<T: Real>(v: Vec<T>) -> Vec<T> {
    let norm = Float::sqrt(v.iter().fold(T::zero(), |s, x| s + *x * *x));
    v.into_iter().map(|x| x / norm).collect()
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
