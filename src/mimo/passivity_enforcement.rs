//! Passivity enforcement of a scattering model by perturbation of its residues.

use super::CommonPoleFit;
use super::model::CommonPoleModel;
use super::passivity::{PASSIVITY_TOLERANCE, Passivity, frequency_grid, passivity};
use crate::data::FrfMatrix;
use crate::error::{FdidError, Result};
use crate::linalg::nonnegative_qp::nonnegative_qp;
use crate::scalar::Complex;
use nalgebra::{DMatrix, DVector};
use std::collections::BTreeSet;

/// How far below 1 each enforced singular value is placed, so that the linearised step
/// leaves the check's tolerance ([`PASSIVITY_TOLERANCE`]) to the second-order terms.
const MARGIN: f64 = 1e-5;

/// Singular values within this distance below 1 at a constrained frequency are
/// constrained too (they would cross 1 under a step that lowers the largest).
const NEAR: f64 = 1e-2;

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
    /// perturbed one (the perturbation did not converge or changed more, see
    /// [`enforce_passivity`]).
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
/// Each iteration adds the local maxima of σ_max above 1 on the grid to the constrained
/// frequencies (those of earlier iterations stay, so that a violation pushed down stays
/// down), linearises there every singular value above 0.99, σ_i(S + ΔS) ≈ σ_i +
/// Re(u_iᴴ ΔS(iω_k) v_i) with the singular vectors u_i, v_i of S(iω_k), and solves the
/// quadratic programme with inequality constraints
///
/// ```text
/// min Σ_l ‖ΔS(iω_l)‖²_F   subject to   σ_i,k + Re(u_iᴴ ΔS(iω_k) v_i) ≤ 1 − 10⁻⁵,
/// ΔS(x) = ΔD + Σ_m ΔR_m/(x − p_m) (+ conjugates),
/// ```
///
/// in the real parameters of the ΔR_m. The objective (over the lines and, with a total
/// weight of a tenth of theirs, the check's grid) is the same for every entry: one QR
/// factor R of the column-scaled basis, not its Gram matrix (a fitted model's basis is
/// ill-conditioned). The programme is solved through its dual, a non-negative
/// quadratic programme in the constraints' multipliers (active set), min_{λ≥0}
/// ½λᵀ(FFᵀ)λ + dᵀλ with F the constraints in the orthonormal coordinates R·x. Each step is
/// halved until the largest singular value on the grid drops; the iterations stop when
/// the grid has no violation, no step helps, or after 40. Should the perturbation change
/// the model more than scaling S by (1 − 10⁻⁵)/σ_max, or not converge, that scaled
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
    let ny = model.ny();
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
    // the grid depends on the poles only, which the enforcement keeps
    let grid = frequency_grid(&current, f_max_hz, points);
    let objective = Objective::new(&current, omega, &grid)?;
    let nb = objective.scale.len();
    let mut iterations = 0;
    // the grid points constrained so far: each iteration adds the peaks of the
    // violations and keeps the earlier ones, so that a violation pushed down stays down
    let mut constrained = BTreeSet::new();
    while iterations < MAX_ITERATIONS {
        let largest = largest_singular_values(&current, &grid);
        let peaks = violation_peaks(&largest);
        if peaks.is_empty() {
            break;
        }
        iterations += 1;
        constrained.extend(peaks);
        let (c, d) = constraints(&current, &grid, &constrained, nb);
        let x = objective.least_change(&c, &d)?;
        // the linearised step, halved until the largest singular value on the grid
        // drops (at most 6 times); none that does ends the iterations
        let worst = largest.iter().copied().fold(0.0, f64::max);
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
    // 1 − (1 − 10⁻⁵)/σ_max: the fallback when the perturbation changed the model more
    // than that, or did not converge
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

/// The objective of the enforcement, Σ_lines ‖ΔS‖²_F plus the check's grid with a total
/// weight of one line in ten (a change where no line was fitted is not free: it makes
/// new violations there), as ‖R D x_e‖² per entry: R the triangular factor of the real
/// basis (lines and weighted grid stacked, columns scaled to unit norm by D⁻¹, with a
/// ridge of 10⁻⁶ of a column's norm). The factor, not the Gram matrix: a fitted model's
/// nearby poles make the basis ill-conditioned, and its Gram matrix loses the least
/// change to rounding (on a 50-pole 4-port the Gram-form step changed the model more
/// than a uniform scaling would).
struct Objective {
    r: DMatrix<f64>,
    scale: Vec<f64>,
}

impl Objective {
    fn new(model: &CommonPoleModel<f64>, omega: &[f64], grid: &[f64]) -> Result<Self> {
        let lines = basis(model, omega);
        let on_grid = basis(model, grid);
        let nb = lines.ncols();
        let out_of_band = (0.1 * omega.len() as f64 / grid.len().max(1) as f64).sqrt();
        let weights = vec![out_of_band; grid.len()];
        let mut a = DMatrix::<f64>::zeros(2 * (omega.len() + grid.len()) + nb, nb);
        a.rows_mut(0, 2 * omega.len())
            .copy_from(&crate::linalg::stack_rows(&lines, None));
        a.rows_mut(2 * omega.len(), 2 * grid.len())
            .copy_from(&crate::linalg::stack_rows(&on_grid, Some(&weights)));
        let scale = crate::linalg::equilibrate_columns(&mut a);
        let last = a.nrows() - nb;
        for i in 0..nb {
            a[(last + i, i)] = 1e-6;
        }
        let r = a.qr().r();
        if (0..nb).any(|i| !(r[(i, i)].abs() > 0.0) || !r[(i, i)].is_finite()) {
            return Err(FdidError::Singular {
                what: "the objective of the passivity enforcement",
                condition: f64::INFINITY,
            });
        }
        Ok(Self { r, scale })
    }

    /// The least change x (every entry's `nb` coefficients) with C x ≤ d: in y_e = R D x_e
    /// the objective is ‖y‖² and the constraints F y ≤ d with F_e = C_e D⁻¹R⁻¹, so
    /// y = −Fᵀλ for the λ ≥ 0 minimising ½λᵀ(FFᵀ)λ + dᵀλ (the dual).
    fn least_change(&self, c: &DMatrix<f64>, d: &DVector<f64>) -> Result<DVector<f64>> {
        let nb = self.scale.len();
        let entries = c.ncols() / nb;
        // Fᵀ, entry by entry: R⁻ᵀ D⁻¹ C_eᵀ
        let mut ft = DMatrix::<f64>::zeros(entries * nb, c.nrows());
        for e in 0..entries {
            let mut block = c.columns(e * nb, nb).transpose();
            for (i, s) in self.scale.iter().enumerate() {
                block.row_mut(i).unscale_mut(*s);
            }
            let solved = self
                .r
                .tr_solve_upper_triangular(&block)
                .ok_or(FdidError::Singular {
                    what: "the objective of the passivity enforcement",
                    condition: f64::INFINITY,
                })?;
            ft.rows_mut(e * nb, nb).copy_from(&solved);
        }
        let lambda = nonnegative_qp(&ft.tr_mul(&ft), d)?;
        let y = -(ft * lambda);
        let mut x = DVector::<f64>::zeros(entries * nb);
        for e in 0..entries {
            let solved = self
                .r
                .solve_upper_triangular(&y.rows(e * nb, nb).into_owned())
                .ok_or(FdidError::Singular {
                    what: "the objective of the passivity enforcement",
                    condition: f64::INFINITY,
                })?;
            for i in 0..nb {
                x[e * nb + i] = solved[i] / self.scale[i];
            }
        }
        Ok(x)
    }
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

/// σ_max(S(iω)) at each grid frequency.
fn largest_singular_values(model: &CommonPoleModel<f64>, grid: &[f64]) -> Vec<f64> {
    let responses = model.response(grid);
    crate::linalg::parallel::map_indices(responses.len(), |k| {
        responses[k]
            .singular_values_unordered()
            .iter()
            .copied()
            .fold(0.0, f64::max)
    })
}

/// The linearised constraints at the grid points `at` (indices into `grid`): one row per
/// singular value σ_i above 1 − [`NEAR`] at each point, σ_i(S + ΔS) ≈ σ_i +
/// Re(u_iᴴ ΔS v_i) ≤ 1 − [`MARGIN`], as C x ≤ d over every entry's `nb` coefficients
/// (entry e = i + j·ny, column by column).
fn constraints(
    model: &CommonPoleModel<f64>,
    grid: &[f64],
    at: &BTreeSet<usize>,
    nb: usize,
) -> (DMatrix<f64>, DVector<f64>) {
    let ny = model.ny();
    let entries = ny * model.nu();
    let omega: Vec<f64> = at.iter().map(|k| grid[*k]).collect();
    let responses = model.response(&omega);
    let phi = basis(model, &omega);
    let svds = crate::linalg::parallel::map_indices(responses.len(), |k| {
        nalgebra::SVD::new(responses[k].clone(), true, true)
    });
    let mut rows: Vec<Vec<f64>> = vec![];
    let mut bounds = vec![];
    for (point, svd) in svds.iter().enumerate() {
        let (Some(u), Some(vt)) = (svd.u.as_ref(), svd.v_t.as_ref()) else {
            continue;
        };
        for (s, sigma) in svd.singular_values.iter().enumerate() {
            if *sigma <= 1.0 - NEAR {
                continue;
            }
            let mut row = vec![0.0; entries * nb];
            // v = (vᴴ)ᴴ: the conjugate of the row of Vᴴ
            for (j, vj) in vt.row(s).iter().map(|v| v.conj()).enumerate() {
                for (i, ui) in u.column(s).iter().enumerate() {
                    let w = ui.conj() * vj;
                    let e = i + j * ny;
                    for b in 0..nb {
                        row[e * nb + b] = (w * phi[(point, b)]).re;
                    }
                }
            }
            rows.push(row);
            bounds.push(1.0 - MARGIN - sigma);
        }
    }
    let c = DMatrix::from_fn(rows.len(), entries * nb, |r, col| rows[r][col]);
    (c, DVector::from_vec(bounds))
}

/// The grid indices where σ_max exceeds 1 + tolerance and is a local maximum along the
/// grid (the peak of each violation band).
fn violation_peaks(s: &[f64]) -> Vec<usize> {
    let limit = 1.0 + PASSIVITY_TOLERANCE;
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
