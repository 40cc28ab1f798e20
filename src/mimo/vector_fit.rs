//! Vector fitting with poles common to every entry: Sanathanan–Koerner pole relocation
//! with the fast block solution, and the residue matrices by linear least squares.

use super::model::CommonPoleModel;
use super::poles::{PoleSet, basis, coefficient_matrix, derivative_basis, points, starting_poles};
use crate::data::{FrfMatrix, MimoSpectra};
use crate::error::{FdidError, Result};
use crate::model::Domain;
use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DVector};
use num_traits::Float;

/// The weighted data of a common-pole fit in the fitting variable: the points x_k (iω/ω_s
/// in s, e^{iωTs} in z), the fitted blocks — each entry's FRF of a frequency response
/// matrix, or each output's spectrum of a multi-input record — and their weights 1/σ
/// (none: unit weights).
///
/// A block is explained by the regressor A(x) c: for an FRF entry A = [φ(x) | 1] (the
/// partial fractions and the direct term); for an output of a record with inputs U_j,
/// A = [φ(x)U_1 | U_1 | … | φ(x)U_nu | U_nu | φ(x)x_T] — every input through the same
/// poles, and the transient of the finite record (McKelvey eq. 4), T(x) = Σ t_m φ_m(x)
/// x_T with x_T = z in z (I(z⁻¹)/A(z⁻¹) with deg I < n) and 1 in s.
pub(crate) struct Weighted<T: Real> {
    pub x: Vec<Complex<T>>,
    /// ω_s, the largest line's frequency (s), or 1 (z): poles and residues in the fitting
    /// variable are the physical ones divided by it.
    pub scale: T,
    pub h: Vec<Vec<Complex<T>>>,
    pub w: Option<Vec<Vec<T>>>,
    pub direct: bool,
    pub ny: usize,
    pub nu: usize,
    /// The input spectra U_j(x_k) of a multi-input record (`None`: FRF entries).
    pub inputs: Option<Vec<Vec<Complex<T>>>>,
    /// The factor x_T of the transient basis (`None`: no transient).
    pub transient: Option<Vec<Complex<T>>>,
}

impl<T: Real> Weighted<T> {
    pub(crate) fn new(data: &FrfMatrix<T>, domain: Domain<T>, direct: bool) -> Result<Self> {
        let omega = data.omega();
        let scale = fitting_scale(omega, domain)?;
        let w = if data.has_variances() {
            let mut all = Vec::with_capacity(data.entries().len());
            for (e, entry) in data.entries().iter().enumerate() {
                let var = &entry.noise().expect("checked").var_y;
                if let Some(k) = var.iter().position(|v| !(*v > T::zero())) {
                    let (i, j) = data.position(e);
                    return Err(FdidError::InvalidArgument {
                        name: "noise variance",
                        value: format!("{} at line {} of entry {}{}", var[k], k + 1, i + 1, j + 1),
                        reason: "weighting needs positive variances".into(),
                    });
                }
                all.push(var.iter().map(|v| T::one() / Float::sqrt(*v)).collect());
            }
            Some(all)
        } else {
            None
        };
        Ok(Self {
            x: points(omega, domain, scale),
            scale,
            h: data.entries().iter().map(|e| e.y().to_vec()).collect(),
            w,
            direct,
            ny: data.ny(),
            nu: data.nu(),
            inputs: None,
            transient: None,
        })
    }

    /// The blocks of a multi-input record: one per output, unweighted, with the input
    /// spectra and (when `transient`) the transient term.
    pub(crate) fn from_spectra(
        data: &MimoSpectra<T>,
        domain: Domain<T>,
        direct: bool,
        transient: bool,
    ) -> Result<Self> {
        let scale = fitting_scale(data.omega(), domain)?;
        let x = points(data.omega(), domain, scale);
        let transient = transient.then(|| match domain {
            Domain::Continuous => vec![Complex::new(T::one(), T::zero()); x.len()],
            Domain::Discrete { .. } => x.clone(),
        });
        Ok(Self {
            x,
            scale,
            h: (0..data.ny()).map(|i| data.y(i).to_vec()).collect(),
            w: None,
            direct,
            ny: data.ny(),
            nu: data.nu(),
            inputs: Some((0..data.nu()).map(|j| data.u(j).to_vec()).collect()),
            transient,
        })
    }

    pub(crate) fn lines(&self) -> usize {
        self.x.len()
    }

    pub(crate) fn weight(&self, e: usize, k: usize) -> T {
        self.w.as_ref().map_or(T::one(), |w| w[e][k])
    }

    /// The input groups of the regressor: one per input of a record, one for FRF entries.
    fn groups(&self) -> usize {
        self.inputs.as_ref().map_or(1, Vec::len)
    }

    /// The width n + D of one input group's columns for `order` poles.
    fn group_width(&self, order: usize) -> usize {
        order + usize::from(self.direct)
    }

    /// The linear parameters of one block for `order` poles: the groups' and the
    /// transient's.
    pub(crate) fn linear_parameters(&self, order: usize) -> usize {
        self.groups() * self.group_width(order) + self.transient.as_ref().map_or(0, |_| order)
    }

    /// The linear parameters of every block for the poles (in the fitting variable), by
    /// least squares (one QR shared by all blocks without weights, one per block with
    /// them), and each block's weighted cost Σ_k w²|h − ĥ|².
    pub(crate) fn linear_fit(&self, poles: &PoleSet<T>) -> Result<(Vec<DVector<T>>, Vec<T>)> {
        let a = self.regressor(poles);
        let ne = self.h.len();
        match &self.w {
            None => {
                let b = DMatrix::from_fn(2 * self.lines(), ne, |r, e| {
                    let v = self.h[e][r / 2];
                    if r % 2 == 0 { v.re } else { v.im }
                });
                let (x, costs) = shared_least_squares(crate::linalg::stack_rows(&a, None), b)?;
                Ok(((0..ne).map(|e| x.column(e).into_owned()).collect(), costs))
            }
            Some(w) => {
                let mut coeffs = Vec::with_capacity(ne);
                let mut costs = Vec::with_capacity(ne);
                for (h, w) in self.h.iter().zip(w) {
                    let b = DMatrix::from_fn(2 * self.lines(), 1, |r, _| {
                        let v = h[r / 2] * w[r / 2];
                        if r % 2 == 0 { v.re } else { v.im }
                    });
                    let (x, c) = shared_least_squares(crate::linalg::stack_rows(&a, Some(w)), b)?;
                    coeffs.push(x.column(0).into_owned());
                    costs.push(c[0]);
                }
                Ok((coeffs, costs))
            }
        }
    }

    /// The complex regressor (L × [`Weighted::linear_parameters`]): [φ(x) | 1] for FRF
    /// entries, [φU_1 | U_1 | … | φU_nu | U_nu | φx_T] for a record's outputs (the direct
    /// columns only with a direct term, the last block only with a transient).
    pub(crate) fn regressor(&self, poles: &PoleSet<T>) -> DMatrix<Complex<T>> {
        let phi = basis(&self.x, poles);
        let (l, n) = phi.shape();
        let width = self.group_width(n);
        let one = Complex::new(T::one(), T::zero());
        let mut a = DMatrix::zeros(l, self.linear_parameters(n));
        for g in 0..self.groups() {
            let u = self.inputs.as_ref().map(|u| u[g].as_slice());
            for k in 0..l {
                let uk = u.map_or(one, |u| u[k]);
                for c in 0..n {
                    a[(k, g * width + c)] = phi[(k, c)] * uk;
                }
                if self.direct {
                    a[(k, g * width + n)] = uk;
                }
            }
        }
        if let Some(xt) = &self.transient {
            let offset = self.groups() * width;
            for k in 0..l {
                for c in 0..n {
                    a[(k, offset + c)] = phi[(k, c)] * xt[k];
                }
            }
        }
        a
    }

    /// The derivative of the regressor's basis columns against the pole parameters,
    /// [ΨU_1 | … | ΨU_nu | Ψx_T] (Ψ of [`derivative_basis`]; Ψ alone for FRF entries), so
    /// that ∂(A c)/∂θ = this · [`Weighted::coefficient_stack`].
    pub(crate) fn derivative_regressor(&self, poles: &PoleSet<T>) -> DMatrix<Complex<T>> {
        let psi = derivative_basis(&self.x, poles);
        let Some(inputs) = &self.inputs else {
            return psi;
        };
        let (l, n) = psi.shape();
        let factors: Vec<&[Complex<T>]> = inputs
            .iter()
            .map(Vec::as_slice)
            .chain(self.transient.as_deref())
            .collect();
        DMatrix::from_fn(l, n * factors.len(), |k, c| {
            psi[(k, c % n)] * factors[c / n][k]
        })
    }

    /// The stacked coefficient matrices [C(c_1); …; C(c_nu); C(t)] of one block's linear
    /// parameters `c` (C of [`coefficient_matrix`]; C(c) alone for FRF entries).
    pub(crate) fn coefficient_stack(&self, poles: &PoleSet<T>, c: &[T]) -> DMatrix<T> {
        let n = poles.order();
        let width = self.group_width(n);
        let mut offsets: Vec<usize> = (0..self.groups()).map(|g| g * width).collect();
        if self.transient.is_some() && self.inputs.is_some() {
            offsets.push(self.groups() * width);
        }
        let mut stack = DMatrix::zeros(n * offsets.len(), n);
        for (b, offset) in offsets.iter().enumerate() {
            stack
                .view_mut((b * n, 0), (n, n))
                .copy_from(&coefficient_matrix(poles, &c[*offset..*offset + n]));
        }
        stack
    }

    /// One pole relocation (relaxed vector fitting, Gustavsen 2006): for every entry e the
    /// linearised equation
    ///
    /// ```text
    /// w_k [Σ c_e,m φ_m(x_k) + d_e − h_e,k (σ₀ + Σ σ_m φ_m(x_k))] ≈ 0
    /// ```
    ///
    /// (McKelvey eq. 41 with the denominator in the basis of the current poles), solved
    /// by the fast block method: a QR per entry eliminates its own c_e, d_e and leaves
    /// n + 1 rows in the shared σ (the R₂₂ block); the stacked blocks and the constraint
    /// Re Σ_k σ(x_k) = L (which keeps σ₀ free but σ nonzero) give σ by one small least
    /// squares. The new poles are the zeros of σ(x), the eigenvalues of A − b cᵀ/σ₀ of its
    /// real state-space form. The cost is linear in the number of entries.
    pub(crate) fn relocate(&self, poles: &PoleSet<T>) -> Result<PoleSet<T>> {
        let phi = basis(&self.x, poles);
        let (l, n) = phi.shape();
        let regressor = self.regressor(poles);
        let m = regressor.ncols();
        let ne = self.h.len();
        let mut stack = DMatrix::<T>::zeros(ne * (n + 1) + 1, n + 1);
        let mut norm = T::zero();
        // without weights every block shares A: one QR of it, then each block's R₂₂ is the
        // R of its σ-columns projected off the range of A (the same R₂₂ as the QR of
        // [A | B_e], at the cost of two products and a QR of half the width)
        let shared_q = match self.w {
            None => Some(crate::linalg::stack_rows(&regressor, None).qr().q()),
            Some(_) => None,
        };
        for e in 0..ne {
            let width = if shared_q.is_some() { n + 1 } else { m + n + 1 };
            let offset = width - (n + 1);
            let mut a = DMatrix::<T>::zeros(2 * l, width);
            for k in 0..l {
                let w = self.weight(e, k);
                let h = self.h[e][k] * w;
                norm += h.norm_sqr();
                if shared_q.is_none() {
                    for c in 0..m {
                        let v = regressor[(k, c)] * w;
                        a[(2 * k, c)] = v.re;
                        a[(2 * k + 1, c)] = v.im;
                    }
                }
                for c in 0..n {
                    let g = -(phi[(k, c)] * h);
                    a[(2 * k, offset + c)] = g.re;
                    a[(2 * k + 1, offset + c)] = g.im;
                }
                a[(2 * k, offset + n)] = -h.re;
                a[(2 * k + 1, offset + n)] = -h.im;
            }
            if let Some(q) = &shared_q {
                a -= q * at_b(q, &a);
            }
            let r = r_factor(a);
            stack
                .view_mut((e * (n + 1), 0), (n + 1, n + 1))
                .copy_from(&r.view((offset, offset), (n + 1, n + 1)));
        }
        let lf = T::from_usize_lossy(l);
        let beta = Float::sqrt(norm) / lf;
        let last = ne * (n + 1);
        for c in 0..n {
            let s = (0..l).fold(T::zero(), |s, k| s + phi[(k, c)].re);
            stack[(last, c)] = beta * s;
        }
        stack[(last, n)] = beta * lf;
        let mut rhs = DVector::<T>::zeros(ne * (n + 1) + 1);
        rhs[last] = beta * lf;
        let (sol, _) = crate::linalg::least_squares(stack.clone(), rhs, 1.0)?;
        let tiny = Float::sqrt(T::default_epsilon()) * T::lit(1e-1);
        let (c, s0) = if Float::abs(sol[n]) > tiny {
            (sol.rows(0, n).into_owned(), sol[n])
        } else {
            // σ₀ ≈ 0: the relaxation gives no usable zeros; fix σ₀ = 1 (classic VF)
            let a = stack.view((0, 0), (last, n)).into_owned();
            let b = -stack.view((0, n), (last, 1)).column(0).into_owned();
            let (c, _) = crate::linalg::least_squares(a, b, 1.0)?;
            (c, T::one())
        };
        zeros_of_sigma(poles, &c, s0)
    }
}

/// aᵀb through a transposed copy and a matrix product: nalgebra's `tr_mul` forms one dot
/// product per entry, while the product of two matrices runs the blocked kernels of
/// matrixmultiply, several times faster on the tall matrices of a fit.
pub(crate) fn at_b<T: Real>(a: &DMatrix<T>, b: &DMatrix<T>) -> DMatrix<T> {
    a.transpose() * b
}

/// The R factor of a tall matrix `a` (k columns) by CholeskyQR2: R₁ = chol(aᵀa),
/// a₁ = aR₁⁻¹, R = chol(a₁ᵀa₁)·R₁ — two Gram matrices and one product, all matrix
/// products (several times faster than Householder QR here), and orthogonal to working
/// precision for κ(a) up to about ε^(−1/2) (Fukaya et al. 2014). When a Cholesky
/// factorisation fails (κ beyond that), Householder QR.
fn r_factor<T: Real>(a: DMatrix<T>) -> DMatrix<T> {
    let chol_r = |a: &DMatrix<T>| -> Option<DMatrix<T>> {
        let r = at_b(a, a).cholesky()?.l().transpose();
        r.iter().all(|v| Float::is_finite(*v)).then_some(r)
    };
    let two_pass = || -> Option<DMatrix<T>> {
        let r1 = chol_r(&a)?;
        let inverse = r1.clone().try_inverse()?;
        let a1 = &a * inverse;
        let r2 = chol_r(&a1)?;
        Some(r2 * r1)
    };
    match two_pass() {
        Some(r) => r,
        None => a.qr().r(),
    }
}

/// The zeros of σ(x) = σ₀ + Σ c_m φ_m(x): the eigenvalues of A − b cᵀ/σ₀ for the real
/// realisation (A, b) of the basis — A = diag(p) for real poles and [[a, β], [−β, a]] with
/// b = [2, 0]ᵀ for a pair a ± iβ (so that cᵀ(xI − A)⁻¹b = c₁φ₁ + c₂φ₂).
fn zeros_of_sigma<T: Real>(poles: &PoleSet<T>, c: &DVector<T>, s0: T) -> Result<PoleSet<T>> {
    let n = poles.order();
    let nr = poles.real.len();
    let mut a = DMatrix::<T>::zeros(n, n);
    let mut b = DVector::<T>::zeros(n);
    for (t, p) in poles.real.iter().enumerate() {
        a[(t, t)] = *p;
        b[t] = T::one();
    }
    for (m, p) in poles.pairs.iter().enumerate() {
        let t = nr + 2 * m;
        a[(t, t)] = p.re;
        a[(t, t + 1)] = p.im;
        a[(t + 1, t)] = -p.im;
        a[(t + 1, t + 1)] = p.re;
        b[t] = T::lit(2.0);
    }
    let h = a - &b * c.transpose() / s0;
    let ev = crate::roots::eigenvalues(h)?;
    let zeros = PoleSet::from_eigenvalues(&ev);
    zeros.check_finite()?;
    Ok(zeros)
}

/// Least squares min ‖A X − B‖ for every column of B with one QR of A (columns
/// equilibrated first); returns X and each column's residual ‖·‖².
///
/// # Errors
/// Fewer rows than columns; [`FdidError::Singular`] when R has a diagonal below
/// 10³·ε times its largest (the columns are numerically dependent, e.g. two equal poles).
pub(crate) fn shared_least_squares<T: Real>(
    mut a: DMatrix<T>,
    b: DMatrix<T>,
) -> Result<(DMatrix<T>, Vec<T>)> {
    let (rows, p) = a.shape();
    if rows < p {
        return Err(FdidError::TooFewFrequencies {
            lines: rows / 2,
            equations: rows,
            parameters: p,
        });
    }
    let scale = crate::linalg::equilibrate_columns(&mut a);
    let qr = a.qr();
    let mut qtb = b;
    qr.q_tr_mul(&mut qtb);
    let r = qr.r();
    let diag: Vec<T> = (0..p).map(|i| Float::abs(r[(i, i)])).collect();
    let big = diag.iter().copied().fold(T::zero(), Float::max);
    let small = diag.iter().copied().fold(T::infinity(), Float::min);
    if !(small > big * T::default_epsilon() * T::lit(1e3)) {
        return Err(FdidError::Singular {
            what: "residue least squares (numerically dependent basis columns)",
            condition: (big / small).to_f64_lossless(),
        });
    }
    let top = qtb.rows(0, p).into_owned();
    let mut x = r
        .solve_upper_triangular(&top)
        .ok_or_else(|| FdidError::Numerical {
            what: "triangular solve of the residue least squares".into(),
        })?;
    for (j, s) in scale.iter().enumerate() {
        x.row_mut(j).unscale_mut(*s);
    }
    let costs = (0..qtb.ncols())
        .map(|c| qtb.view((p, c), (rows - p, 1)).norm_squared())
        .collect();
    Ok((x, costs))
}

/// The model in physical units from the poles and linear parameters in the fitting
/// variable: p = ω_s p', R = ω_s R' in s (x = iω/ω_s), unchanged in z.
pub(crate) fn model_of<T: Real>(
    data: &Weighted<T>,
    domain: Domain<T>,
    poles: &PoleSet<T>,
    coeffs: &[DVector<T>],
) -> CommonPoleModel<T> {
    let (ny, nu) = (data.ny, data.nu);
    let nr = poles.real.len();
    let n = poles.order();
    let width = data.group_width(n);
    let slots = nr + poles.pairs.len();
    let zero = Complex::new(T::zero(), T::zero());
    let mut residues = vec![DMatrix::from_element(ny, nu, zero); slots];
    let mut direct = data.direct.then(|| DMatrix::zeros(ny, nu));
    for (e, c) in coeffs.iter().enumerate() {
        for g in 0..data.groups() {
            // an FRF block is entry e (column by column); a record's block is output e,
            // its groups the inputs
            let (i, j) = match data.inputs {
                None => (e % ny, e / ny),
                Some(_) => (e, g),
            };
            let c = &c.as_slice()[g * width..(g + 1) * width];
            for (t, r) in residues.iter_mut().enumerate().take(nr) {
                r[(i, j)] = Complex::new(c[t] * data.scale, T::zero());
            }
            for m in 0..poles.pairs.len() {
                let (c1, c2) = (c[nr + 2 * m], c[nr + 2 * m + 1]);
                residues[nr + m][(i, j)] = Complex::new(c1, c2) * data.scale;
            }
            if let Some(d) = direct.as_mut() {
                d[(i, j)] = c[n];
            }
        }
    }
    CommonPoleModel {
        domain,
        poles: poles.scaled(data.scale),
        residues,
        direct,
    }
}

/// The outcome of [`relocation_loop`]: the poles of lowest cost (in the fitting
/// variable), their linear parameters per entry, the cost and the relocations made.
pub(crate) struct Relocated<T: Real> {
    pub poles: PoleSet<T>,
    pub coeffs: Vec<DVector<T>>,
    pub costs: Vec<T>,
    pub relocations: usize,
}

/// The sum of the blocks' costs.
pub(crate) fn total<T: Real>(costs: &[T]) -> T {
    costs.iter().fold(T::zero(), |s, c| s + *c)
}

/// The relocation loop of [`super::fit_common_poles`]: from the starting poles, relocate
/// (reflecting unstable poles when `stable`) until the weighted cost changes by less than
/// `tolerance` relatively or `iterations` relocations; returns the poles of lowest cost
/// (in the fitting variable), their linear parameters, cost and the relocations made.
pub(crate) fn relocation_loop<T: Real>(
    data: &Weighted<T>,
    domain: Domain<T>,
    order: usize,
    stable: bool,
    iterations: usize,
) -> Result<Relocated<T>> {
    let omega_min = data
        .x
        .iter()
        .map(|x| fitting_frequency(*x, domain))
        .fold(T::infinity(), Float::min);
    let omega_max = data
        .x
        .iter()
        .map(|x| fitting_frequency(*x, domain))
        .fold(T::zero(), Float::max);
    let mut poles = starting_poles(order, omega_min, omega_max, unit_domain(domain))?;
    let (mut coeffs, mut costs) = data.linear_fit(&poles)?;
    let mut cost = total(&costs);
    let mut best = (poles.clone(), coeffs.clone(), costs.clone(), cost);
    let tolerance = Float::sqrt(T::default_epsilon()) * T::lit(0.1);
    let work = crate::solver::work::solve_cost(
        2 * data.lines(),
        data.linear_parameters(order) + order + 1,
    ) * T::from_usize_lossy(data.h.len()).to_f64_lossless();
    let mut done = 0;
    for _ in 0..iterations {
        if !crate::solver::work::charge(work) {
            break;
        }
        let mut next = data.relocate(&poles)?;
        if stable {
            next = next.reflected(domain);
        }
        let previous = cost;
        done += 1;
        match data.linear_fit(&next) {
            Ok((c, v)) => {
                poles = next;
                coeffs = c;
                cost = total(&v);
                costs = v;
            }
            // two relocated poles met: keep the best model found so far
            Err(FdidError::Singular { .. }) => break,
            Err(e) => return Err(e),
        }
        if cost < best.3 {
            best = (poles.clone(), coeffs.clone(), costs.clone(), cost);
        }
        if Float::abs(previous - cost) <= tolerance * Float::max(cost, T::min_positive_value()) {
            break;
        }
    }
    Ok(Relocated {
        poles: best.0,
        coeffs: best.1,
        costs: best.2,
        relocations: done,
    })
}

/// ω_s of the fitting variable: the largest line's frequency in s, 1 in z.
fn fitting_scale<T: Real>(omega: &[T], domain: Domain<T>) -> Result<T> {
    let scale = match domain {
        Domain::Continuous => omega.iter().copied().fold(T::zero(), Float::max),
        Domain::Discrete { .. } => T::one(),
    };
    if !(scale > T::zero()) {
        return Err(FdidError::InvalidArgument {
            name: "frequencies",
            value: "0 Hz only".into(),
            reason: "a continuous-time fit needs lines above 0 Hz".into(),
        });
    }
    Ok(scale)
}

/// The frequency in the fitting variable of a point: Im x in s (x = iω/ω_s), ωTs in z.
fn fitting_frequency<T: Real>(x: Complex<T>, domain: Domain<T>) -> T {
    match domain {
        Domain::Continuous => x.im,
        Domain::Discrete { .. } => x.arg(),
    }
}

/// The domain in the fitting variable: z with unit sample time (angles ωTs), s as is.
fn unit_domain<T: Real>(domain: Domain<T>) -> Domain<T> {
    match domain {
        Domain::Continuous => Domain::Continuous,
        Domain::Discrete { .. } => Domain::Discrete { ts: T::one() },
    }
}
