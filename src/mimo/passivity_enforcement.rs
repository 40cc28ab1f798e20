//! Passivity enforcement of a scattering model by perturbation of its residues.

use super::CommonPoleFit;
use super::model::CommonPoleModel;
use super::passivity::{PASSIVITY_TOLERANCE, Passivity, frequency_grid, passivity};
use crate::data::FrfMatrix;
use crate::error::{FdidError, Result};
use crate::scalar::Complex;
use nalgebra::{DMatrix, DVector};

/// How far below 1 each enforced singular value is placed, so that the linearised step
/// leaves the check's tolerance ([`PASSIVITY_TOLERANCE`]) to the second-order terms.
const MARGIN: f64 = 1e-5;

/// Iterations of [`enforce_passivity`] before it gives up.
const MAX_ITERATIONS: usize = 40;

/// The result of [`enforce_passivity`].
#[derive(Debug, Clone, PartialEq)]
pub struct Enforcement {
    /// The model with perturbed residues (and direct term): poles unchanged.
    pub model: CommonPoleModel<f64>,
    /// The check of the model as fitted.
    pub before: Passivity<f64>,
    /// The check of the enforced model on the same kind of grid.
    pub after: Passivity<f64>,
    /// Linearised corrections made.
    pub iterations: usize,
    /// True when the returned model is S scaled by (1 − 10⁻⁵)/σ_max rather than the
    /// perturbed one (a broad violation, see [`enforce_passivity`]).
    pub scaled: bool,
    /// √(Σ‖ΔS‖²_F / Σ‖S‖²_F) over the lines given: how much the enforcement changed the
    /// model where it was fitted.
    pub relative_change: f64,
}

/// Makes a scattering model passive, σ_max(S(iω)) ≤ 1 on the check's grid
/// ([`passivity`]), by the smallest change of its residue matrices (and direct term) in
/// the least-squares sense over the fitted lines `omega` (rad/s): the residue
/// perturbation of Gustavsen and Semlyen, with the poles kept.
///
/// Each iteration linearises the largest singular value at every local maximum ω_k of
/// σ_max above 1 on the grid, σ(S + ΔS) ≈ σ + Re(u₁ᴴ ΔS(iω_k) v₁) with the singular
/// vectors u₁, v₁ of S(iω_k), and solves
///
/// ```text
/// min Σ_l ‖ΔS(iω_l)‖²_F   subject to   σ_k + Re(u₁ᴴ ΔS(iω_k) v₁) = 1 − 10⁻⁵,
/// ΔS(x) = ΔD + Σ_m ΔR_m/(x − p_m) (+ conjugates),
/// ```
///
/// a least-norm problem in the real parameters of the ΔR_m (the objective's Gram matrix,
/// over the lines and, with a total weight of a tenth of theirs, the check's grid, is the
/// same for every entry: one Cholesky factor). Each step is halved until the largest
/// singular value on the grid drops; the iterations stop when the grid has no violation,
/// no step helps, or after 40. When the violation is broad the perturbation may change
/// the model more than scaling S by (1 − 10⁻⁵)/σ_max, or not converge: then that scaled
/// model, passive on the grid, is returned (the smaller of the two changes wins).
///
/// ```
/// use fdid::mimo::{CommonPoleModel, PoleSet, enforce_passivity, passivity};
/// use fdid::prelude::*;
/// use nalgebra::DMatrix;
///
/// // a one-port S = 2.2·0.5/(s + 0.5): |S(0)| = 2.2, not passive
/// let model = CommonPoleModel {
///     domain: Domain::Continuous,
///     poles: PoleSet { real: vec![-0.5], pairs: vec![] },
///     residues: vec![DMatrix::from_element(1, 1, Complex::new(1.1, 0.0))],
///     direct: None,
/// };
/// let omega: Vec<f64> = (1..=100).map(|k| 0.05 * k as f64).collect();
/// assert!(!passivity(&model, 1.0, 400).passive());
/// let enforced = enforce_passivity(&model, &omega, 1.0, 400)?;
/// assert!(enforced.after.passive() && enforced.after.max_singular_value <= 1.0 + 1e-6);
/// # Ok::<(), fdid::FdidError>(())
/// ```
///
/// # Errors
/// A model without residues or lines; a singular objective (fewer distinct lines than
/// basis functions).
pub fn enforce_passivity(
    model: &CommonPoleModel<f64>,
    omega: &[f64],
    f_max_hz: f64,
    points: usize,
) -> Result<Enforcement> {
    let (ny, nu) = (model.ny(), model.nu());
    if ny == 0 || omega.is_empty() {
        return Err(FdidError::InvalidArgument {
            name: "model",
            value: format!("{ny} outputs, {} lines", omega.len()),
            reason: "passivity enforcement needs residues and fitted lines".into(),
        });
    }
    crate::error::check_finite("omega", omega)?;
    let before = passivity(model, f_max_hz, points);
    let mut current = model.clone();
    let lines = basis(&current, omega);
    let nb = lines.ncols();
    // the objective's Gram matrix Re(ΦᴴΦ) over the lines, plus the check's grid with a
    // total weight of one line in ten (a change where no line was fitted is not free: it
    // makes new violations there), and a relative ridge
    // the grid depends on the poles only, which the enforcement keeps
    let grid = frequency_grid(&current, f_max_hz, points);
    let on_grid = basis(&current, &grid);
    let out_of_band = 0.1 * omega.len() as f64 / on_grid.nrows().max(1) as f64;
    let mut gram = (lines.adjoint() * &lines).map(|v| v.re)
        + (on_grid.adjoint() * &on_grid).map(|v| v.re * out_of_band);
    let ridge = 1e-12 * gram.trace().max(f64::MIN_POSITIVE) / nb as f64;
    for i in 0..nb {
        gram[(i, i)] += ridge;
    }
    let chol = gram.cholesky().ok_or(FdidError::Singular {
        what: "the objective of the passivity enforcement",
        condition: f64::INFINITY,
    })?;
    let entries = ny * nu;
    let mut iterations = 0;
    while iterations < MAX_ITERATIONS {
        let triples = largest_triples(&current, &grid);
        let peaks = violation_peaks(&triples);
        if peaks.is_empty() {
            break;
        }
        iterations += 1;
        // one row per peak: ∂σ/∂x for every entry's coefficients
        let at: Vec<f64> = peaks.iter().map(|k| grid[*k]).collect();
        let phi = basis(&current, &at);
        let k_rows = peaks.len();
        let mut c = DMatrix::<f64>::zeros(k_rows, entries * nb);
        let mut rhs = DVector::<f64>::zeros(k_rows);
        for (row, &k) in peaks.iter().enumerate() {
            let (sigma, u, v) = &triples[k];
            rhs[row] = 1.0 - MARGIN - sigma;
            // entry e = i + j·ny (column by column)
            for (j, vj) in v.iter().enumerate() {
                for (i, ui) in u.iter().enumerate() {
                    let w = ui.conj() * vj;
                    let e = i + j * ny;
                    for b in 0..nb {
                        c[(row, e * nb + b)] = (w * phi[(row, b)]).re;
                    }
                }
            }
        }
        // x = H⁻¹Cᵀ y with (C H⁻¹ Cᵀ) y = rhs, H = I ⊗ G
        let mut h_inv_ct = DMatrix::<f64>::zeros(entries * nb, k_rows);
        for e in 0..entries {
            let block = c.columns(e * nb, nb).transpose();
            let solved = chol.solve(&block);
            h_inv_ct.rows_mut(e * nb, nb).copy_from(&solved);
        }
        let m = &c * &h_inv_ct;
        let (y, _) = crate::linalg::least_squares(m, rhs, 1e3)?;
        let x = h_inv_ct * y;
        // the linearised step, halved until the largest singular value on the grid
        // drops (at most 6 times); none that does ends the iterations
        let worst = triples.iter().map(|t| t.0).fold(0.0, f64::max);
        let mut step = 1.0;
        let mut moved = false;
        for _ in 0..7 {
            let mut trial = current.clone();
            apply(&mut trial, &(&x * step), nb);
            if passivity(&trial, f_max_hz, points).max_singular_value < worst {
                current = trial;
                moved = true;
                break;
            }
            step *= 0.5;
        }
        if !moved {
            break;
        }
    }
    let mut after = passivity(&current, f_max_hz, points);
    let mut relative_change = change(model, &current, omega);
    let mut scaled_instead = false;
    // S scaled by (1 − 10⁻⁵)/σ_max is passive on the grid with a relative change of
    // 1 − (1 − 10⁻⁵)/σ_max: when the violation is broad (σ_max above 1 over most of the
    // band) the perturbation can change the model more than that, or not converge
    if !before.passive() {
        let factor = (1.0 - MARGIN) / before.max_singular_value;
        let scaled_change = 1.0 - factor;
        if !after.passive() || scaled_change < relative_change {
            let mut scaled = model.clone();
            for r in scaled.residues.iter_mut() {
                *r *= Complex::new(factor, 0.0);
            }
            if let Some(d) = scaled.direct.as_mut() {
                *d *= factor;
            }
            after = passivity(&scaled, f_max_hz, points);
            relative_change = change(model, &scaled, omega);
            current = scaled;
            scaled_instead = true;
        }
    }
    Ok(Enforcement {
        model: current,
        before,
        after,
        iterations,
        scaled: scaled_instead,
        relative_change,
    })
}

/// √(Σ‖S₁ − S₀‖²_F / Σ‖S₀‖²_F) over `omega`.
fn change(s0: &CommonPoleModel<f64>, s1: &CommonPoleModel<f64>, omega: &[f64]) -> f64 {
    let (a, b) = (s0.response(omega), s1.response(omega));
    let (mut diff, mut size) = (0.0, 0.0);
    for (x, y) in a.iter().zip(&b) {
        diff += (y - x).norm_squared();
        size += x.norm_squared();
    }
    (diff / size.max(f64::MIN_POSITIVE)).sqrt()
}

/// The real basis of a residue perturbation at `omega` (rad/s), one row per frequency:
/// 1/(x − p) for a real pole; for a pair (ΔR = a + ib) the columns of a and b,
/// 1/(x − p) + 1/(x − p̄) and i(1/(x − p) − 1/(x − p̄)); then 1 for the direct term.
fn basis(model: &CommonPoleModel<f64>, omega: &[f64]) -> DMatrix<Complex<f64>> {
    let x = super::poles::points(omega, model.domain, 1.0);
    let slots = model.poles.slots();
    let nr = model.poles.real.len();
    let nb = model.poles.order() + usize::from(model.direct.is_some());
    let mut phi = DMatrix::zeros(omega.len(), nb);
    for (k, xk) in x.iter().enumerate() {
        let mut col = 0;
        for (m, p) in slots.iter().enumerate() {
            let a = (*xk - *p).inv();
            if m < nr {
                phi[(k, col)] = a;
                col += 1;
            } else {
                let b = (*xk - p.conj()).inv();
                phi[(k, col)] = a + b;
                phi[(k, col + 1)] = (a - b) * Complex::new(0.0, 1.0);
                col += 2;
            }
        }
        if model.direct.is_some() {
            phi[(k, col)] = Complex::new(1.0, 0.0);
        }
    }
    phi
}

/// Adds the perturbation `x` (entry by entry, column-major, `nb` coefficients each in the
/// order of [`basis`]) to the residues and direct term.
fn apply(model: &mut CommonPoleModel<f64>, x: &DVector<f64>, nb: usize) {
    let (ny, nu) = (model.ny(), model.nu());
    let nr = model.poles.real.len();
    let slots = model.residues.len();
    for j in 0..nu {
        for i in 0..ny {
            let e = i + j * ny;
            let mut col = e * nb;
            for m in 0..slots {
                if m < nr {
                    model.residues[m][(i, j)] += Complex::new(x[col], 0.0);
                    col += 1;
                } else {
                    model.residues[m][(i, j)] += Complex::new(x[col], x[col + 1]);
                    col += 2;
                }
            }
            if let Some(d) = model.direct.as_mut() {
                d[(i, j)] += x[col];
            }
        }
    }
}

/// The largest singular value of S(iω) at each grid frequency with its left and right
/// singular vectors.
type Triple = (f64, Vec<Complex<f64>>, Vec<Complex<f64>>);

fn largest_triples(model: &CommonPoleModel<f64>, grid: &[f64]) -> Vec<Triple> {
    let responses = model.response(grid);
    crate::linalg::parallel::map_indices(responses.len(), |k| {
        let svd = nalgebra::SVD::new(responses[k].clone(), true, true);
        let (Some(u), Some(vt)) = (svd.u.as_ref(), svd.v_t.as_ref()) else {
            return (0.0, vec![], vec![]);
        };
        let best = (0..svd.singular_values.len())
            .max_by(|a, b| svd.singular_values[*a].total_cmp(&svd.singular_values[*b]))
            .unwrap_or(0);
        let left = u.column(best).iter().copied().collect();
        // v = (vᴴ)ᴴ: the conjugate of the row of V^H
        let right = vt.row(best).iter().map(|v| v.conj()).collect();
        (svd.singular_values[best], left, right)
    })
}

/// The grid indices where σ_max exceeds 1 + tolerance and is a local maximum along the
/// grid (the peak of each violation band).
fn violation_peaks(triples: &[Triple]) -> Vec<usize> {
    let limit = 1.0 + PASSIVITY_TOLERANCE;
    let s: Vec<f64> = triples.iter().map(|t| t.0).collect();
    (0..s.len())
        .filter(|k| {
            s[*k] > limit
                && (*k == 0 || s[*k] >= s[*k - 1])
                && (*k + 1 == s.len() || s[*k] >= s[*k + 1])
        })
        .collect()
}

impl CommonPoleFit<f64> {
    /// The fit with its model replaced by `model` (the enforced model of
    /// [`enforce_passivity`]: same poles, other residues), its costs recomputed on `data`
    /// (weighted by the entries' variances when they carry them; by their diagonal alone
    /// when the fit weighted by full covariances, so `correlated` is false). The
    /// relocation figures, the ML outcome and the poles' covariance are the original fit's.
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] when `model` has other poles or shape than the fit.
    pub fn with_model(&self, model: CommonPoleModel<f64>, data: &FrfMatrix<f64>) -> Result<Self> {
        if model.poles != self.model.poles
            || model.ny() != self.model.ny()
            || model.nu() != self.model.nu()
            || model.ny() * model.nu() != data.entries().len()
        {
            return Err(FdidError::InvalidArgument {
                name: "model",
                value: format!("{} poles, {} × {}", model.order(), model.ny(), model.nu()),
                reason: "the replacement keeps the fit's poles and shape".into(),
            });
        }
        let g = model.response(data.omega());
        let weighted = data.has_variances();
        let (mut costs, mut power) = (vec![], vec![]);
        for (e, entry) in data.entries().iter().enumerate() {
            let (i, j) = data.position(e);
            let var = entry.noise().filter(|_| weighted).map(|n| &n.var_y);
            let (mut c, mut p) = (0.0, 0.0);
            for (k, h) in entry.y().iter().enumerate() {
                let r = (h - g[k][(i, j)]).norm_sqr();
                p += r;
                c += var.map_or(r, |v| r / v[k]);
            }
            costs.push(c);
            power.push(p);
        }
        Ok(Self {
            model,
            cost: costs.iter().sum(),
            costs,
            residual_power: power,
            correlated: false,
            ..self.clone()
        })
    }
}
