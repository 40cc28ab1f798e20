//! Maximum likelihood of the common poles when the noise of several blocks is correlated:
//! the outputs of a record seen by several sensors, or the outputs of one input column of
//! a frequency response matrix. Each line's residual vector is whitened by the inverse
//! Cholesky factor of its covariance, so the residues of the blocks are estimated jointly.

use super::poles::PoleSet;
use super::thin_qr::{ThinQr, at_b};
use super::vector_fit::Weighted;
use crate::data::{FrfMatrix, MimoSpectra};
use crate::error::Result;
use crate::problem::NonlinearProblem;
use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DVector};
use num_traits::Float;

/// The whitening of groups of blocks whose noise is correlated: for group g (its blocks
/// in the order of its covariance's rows) and line k, W_g,k with W C Wᴴ = I for the
/// group's ny × ny noise covariance C_g,k, lower triangular (W = L⁻¹ for C = L Lᴴ).
#[derive(Debug, Clone)]
pub(crate) struct Whitening<T: Real> {
    pub groups: Vec<Vec<usize>>,
    pub factors: Vec<Vec<DMatrix<Complex<T>>>>,
}

impl<T: Real> Whitening<T> {
    /// The whitening of `groups` from the covariance `covariance(g, k)` of group g at
    /// each of `lines` lines; `None` when a group has a single block (nothing to gain
    /// over the diagonal weights) or a covariance is not positive definite.
    ///
    /// Each block's variance is floored at 10⁻¹² of its largest over the lines (as the
    /// diagonal weights are), the covariance is scaled to its correlation matrix R =
    /// D^{-1/2} C D^{-1/2}, loaded by 10⁻⁹ on the diagonal, and factored R = L_R L_Rᴴ:
    /// W = L_R⁻¹ D^{-1/2}.
    pub(crate) fn new<'c>(
        groups: Vec<Vec<usize>>,
        lines: usize,
        covariance: impl Fn(usize, usize) -> &'c DMatrix<Complex<T>>,
    ) -> Option<Self>
    where
        T: 'c,
    {
        if groups.iter().all(|g| g.len() < 2) {
            return None;
        }
        let mut factors = Vec::with_capacity(groups.len());
        for (g, blocks) in groups.iter().enumerate() {
            let n = blocks.len();
            let floor: Vec<T> = (0..n)
                .map(|i| {
                    let top = (0..lines)
                        .map(|k| covariance(g, k)[(i, i)].re)
                        .fold(T::zero(), Float::max);
                    top * T::lit(1e-12)
                })
                .collect();
            if floor
                .iter()
                .any(|f| !(*f > T::zero() && Float::is_finite(*f)))
            {
                return None;
            }
            let group: Option<Vec<_>> = (0..lines)
                .map(|k| inverse_factor(covariance(g, k), &floor))
                .collect();
            factors.push(group?);
        }
        Some(Self { groups, factors })
    }
}

impl<T: Real> Whitening<T> {
    /// The whitening of an FRF matrix's columns (each column's ny entries), when it
    /// carries covariances ([`FrfMatrix::with_covariances`]).
    pub(crate) fn of_matrix(data: &FrfMatrix<T>) -> Option<Self> {
        if !data.has_covariances() {
            return None;
        }
        let ny = data.ny();
        let groups = (0..data.nu())
            .map(|j| (j * ny..(j + 1) * ny).collect())
            .collect();
        Self::new(groups, data.len(), |j, k| {
            data.covariance(j, k).expect("checked")
        })
    }

    /// The whitening of a record's outputs by their covariance between periods; only
    /// when that sample covariance (rank P − 1 at most) is of full rank with room to
    /// spare, P > ny + 1.
    pub(crate) fn of_spectra(data: &MimoSpectra<T>) -> Option<Self> {
        let noise = data.noise()?;
        if noise.periods() <= data.ny() + 1 {
            return None;
        }
        Self::new(vec![(0..data.ny()).collect()], data.len(), |_, k| {
            noise.output_covariance(k)
        })
    }
}

/// W = L_R⁻¹ D^{-1/2} for one covariance (see [`Whitening::new`]).
fn inverse_factor<T: Real>(c: &DMatrix<Complex<T>>, floor: &[T]) -> Option<DMatrix<Complex<T>>> {
    let n = c.nrows();
    let d: Vec<T> = (0..n)
        .map(|i| Float::sqrt(Float::max(c[(i, i)].re, floor[i])))
        .collect();
    let load = T::lit(1e-9);
    let r = DMatrix::from_fn(n, n, |i, j| {
        if i == j {
            Complex::new(T::one() + load, T::zero())
        } else {
            c[(i, j)] / Complex::new(d[i] * d[j], T::zero())
        }
    });
    if r.iter().any(|v| !(v.re.is_finite() && v.im.is_finite())) {
        return None;
    }
    let l = nalgebra::Cholesky::new(r)?.l();
    let identity = DMatrix::<Complex<T>>::identity(n, n);
    let l_inv = l.solve_lower_triangular(&identity)?;
    Some(DMatrix::from_fn(n, n, |i, j| {
        l_inv[(i, j)] / Complex::new(d[j], T::zero())
    }))
}

/// The joint least squares of one group at one set of poles: the thin QR of the whitened
/// regressor, its solution (each block's linear parameters) and the whitened residual.
struct GroupFit<T: Real> {
    qr: ThinQr<T>,
    coeffs: Vec<DVector<T>>,
    residual: DVector<T>,
}

/// The output-error ML cost with correlated blocks and the linear parameters eliminated,
///
/// ```text
/// V(θ) = Σ_g Σ_k r_g,kᴴ C_g,k⁻¹ r_g,k = Σ_g ‖P⊥_g W_g (h_g − A_g c_g)‖²,
/// ```
///
/// (McKelvey eq. 23 with the ny × ny noise covariance of each line in place of the
/// scalar variance), r_g,k the residuals of group g's blocks at line k. Whitening mixes
/// the blocks of a group, so their residues are estimated together: the whitened
/// regressor of group g has the rows (k, i) and the column blocks i′ = W_g,k[i, i′]·A_k
/// (A the regressor shared by the blocks, as in [`super::varpro::VarPro`]). Kaufman's
/// Jacobian is −P⊥ D with D's row (k, i) = Σ_i′ W_g,k[i, i′] (Ψ C_i′)_k, Ψ the derivative
/// basis and C_i′ block i′'s coefficient matrix.
pub(crate) struct JointVarPro<'a, T: Real> {
    pub data: &'a Weighted<T>,
    pub whitening: &'a Whitening<T>,
    pub n_real: usize,
    pub order: usize,
}

impl<T: Real> JointVarPro<'_, T> {
    /// The whitened regressor and target of group g.
    fn system(&self, g: usize, a: &DMatrix<Complex<T>>) -> (DMatrix<T>, DVector<T>) {
        let blocks = &self.whitening.groups[g];
        let factors = &self.whitening.factors[g];
        let (l, m) = a.shape();
        let n = blocks.len();
        let mut b = DMatrix::zeros(2 * l * n, n * m);
        let mut target = DVector::zeros(2 * l * n);
        for k in 0..l {
            let w = &factors[k];
            for i in 0..n {
                let row = 2 * (k * n + i);
                let mut t = Complex::new(T::zero(), T::zero());
                for (i2, block) in blocks.iter().enumerate().take(i + 1) {
                    let wi = w[(i, i2)];
                    t += wi * self.data.h[*block][k];
                    for c in 0..m {
                        let v = wi * a[(k, c)];
                        b[(row, i2 * m + c)] = v.re;
                        b[(row + 1, i2 * m + c)] = v.im;
                    }
                }
                target[row] = t.re;
                target[row + 1] = t.im;
            }
        }
        (b, target)
    }

    /// The joint least squares of group g.
    fn group_fit(&self, g: usize, a: &DMatrix<Complex<T>>) -> Result<GroupFit<T>> {
        let (b, target) = self.system(g, a);
        let qr = ThinQr::new(b)?;
        let (x, residual) = qr.least_squares(&DMatrix::from_column_slice(
            target.len(),
            1,
            target.as_slice(),
        ))?;
        let m = a.ncols();
        let coeffs = (0..self.whitening.groups[g].len())
            .map(|i| DVector::from_fn(m, |c, _| x[(i * m + c, 0)]))
            .collect();
        Ok(GroupFit {
            qr,
            coeffs,
            residual: residual.column(0).into_owned(),
        })
    }

    /// Every block's linear parameters at the poles (in the fitting variable) and its part
    /// of the cost: the whitened residuals of its rows, Σ_k |(W_g,k r_g,k)_i|², which sum
    /// to V (block i's residual given the blocks before it in its group, by the
    /// triangular W).
    pub(crate) fn linear_fit(&self, poles: &PoleSet<T>) -> Result<(Vec<DVector<T>>, Vec<T>)> {
        let a = self.data.regressor(poles);
        let blocks = self.data.h.len();
        let mut coeffs = vec![DVector::zeros(0); blocks];
        let mut costs = vec![T::zero(); blocks];
        for (g, members) in self.whitening.groups.iter().enumerate() {
            let fit = self.group_fit(g, &a)?;
            let n = members.len();
            for (i, block) in members.iter().enumerate() {
                coeffs[*block] = fit.coeffs[i].clone();
                costs[*block] = (0..self.data.lines()).fold(T::zero(), |s, k| {
                    let row = 2 * (k * n + i);
                    s + fit.residual[row] * fit.residual[row]
                        + fit.residual[row + 1] * fit.residual[row + 1]
                });
            }
        }
        Ok((coeffs, costs))
    }

    /// The residual rows of group g start here.
    fn offset(&self, g: usize) -> usize {
        let before: usize = self.whitening.groups[..g].iter().map(Vec::len).sum();
        2 * self.data.lines() * before
    }

    /// r(θ) into `r` and, when `jac` is given, Kaufman's Jacobian; false when the basis
    /// is numerically singular or a value is not finite.
    fn evaluate(&self, theta: &[T], r: &mut [T], mut jac: Option<&mut DMatrix<T>>) -> bool {
        let poles = PoleSet::from_theta(self.n_real, theta);
        let a = self.data.regressor(&poles);
        let psi = jac
            .is_some()
            .then(|| self.data.derivative_regressor(&poles));
        let lines = self.data.lines();
        for (g, blocks) in self.whitening.groups.iter().enumerate() {
            let Ok(fit) = self.group_fit(g, &a) else {
                return false;
            };
            let start = self.offset(g);
            let rows = fit.residual.len();
            r[start..start + rows].copy_from_slice(fit.residual.as_slice());
            let (Some(jac), Some(psi)) = (jac.as_mut(), psi.as_ref()) else {
                continue;
            };
            // D_i′ = Ψ C_i′ per block, then mixed by the whitening
            let derivatives: Vec<DMatrix<Complex<T>>> = fit
                .coeffs
                .iter()
                .map(|c| {
                    let stack = self.data.coefficient_stack(&poles, c.as_slice());
                    psi * stack.map(|v| Complex::new(v, T::zero()))
                })
                .collect();
            let n = blocks.len();
            let p = self.order;
            let mut d = DMatrix::zeros(rows, p);
            for k in 0..lines {
                let w = &self.whitening.factors[g][k];
                for i in 0..n {
                    let row = 2 * (k * n + i);
                    for j in 0..p {
                        let v = (0..=i).fold(Complex::new(T::zero(), T::zero()), |s, i2| {
                            s + w[(i, i2)] * derivatives[i2][(k, j)]
                        });
                        d[(row, j)] = v.re;
                        d[(row + 1, j)] = v.im;
                    }
                }
            }
            let projected = &d - &fit.qr.q * at_b(&fit.qr.q, &d);
            jac.view_mut((start, 0), (rows, p)).copy_from(&(-projected));
        }
        r.iter().all(|v| Float::is_finite(*v))
            && jac.is_none_or(|j| j.iter().all(|v| Float::is_finite(*v)))
    }
}

impl<T: Real> NonlinearProblem<T> for JointVarPro<'_, T> {
    fn n_params(&self) -> usize {
        self.order
    }

    fn n_residuals(&self) -> usize {
        2 * self.data.lines() * self.data.h.len()
    }

    fn residuals_into(&self, theta: &[T], r: &mut [T]) -> bool {
        self.evaluate(theta, r, None)
    }

    fn jacobian_into(&self, theta: &[T], r: &mut [T], jac: &mut DMatrix<T>) -> bool {
        self.evaluate(theta, r, Some(jac))
    }
}
