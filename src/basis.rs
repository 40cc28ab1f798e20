//! Bases for the numerator and denominator of rational models.
//!
//! Raw monomials sⁿ are hopelessly ill-conditioned over several decades of frequency.
//! Three bases are offered ([`PolyBasis`]):
//! - **partial fractions** over basis poles (vector fitting's barycentric form): numerator
//!   and denominator are rational functions sharing the basis poles; with those poles moved
//!   to the model's poles the basis functions are nearly orthogonal on the data, at any
//!   order and bandwidth;
//! - polynomials in s **orthonormal on the data's frequency grid** (Forsythe polynomials,
//!   built by the Stieltjes procedure), for improper models;
//! - powers of z⁻¹ for discrete time, already orthogonal on the unit circle.
//!
//! ## The orthonormal basis in s
//! Let x = ω/ω_s with ω_s the largest frequency. The points ±x_k with equal weights define
//! a symmetric discrete measure, whose orthonormal polynomials pₙ satisfy a three-term
//! recurrence without diagonal term, x pₙ = γₙ₊₁ pₙ₊₁ + γₙ pₙ₋₁, and have the parity of n.
//! The functions φₙ(s) = iⁿ pₙ(−i s/ω_s) are then *real* polynomials in s of degree n with
//!
//! ```text
//! φ₀ = 1,   φ₁ = (s/ω_s)/γ₁,   φₙ₊₁(s) = ((s/ω_s) φₙ(s) + γₙ φₙ₋₁(s)) / γₙ₊₁,
//! ```
//!
//! and |φₙ(iω_k)| = |pₙ(x_k)|, orthonormal over the data. A real coefficient vector c gives
//! the real polynomial P(s) = Σ cₙ φₙ(s), so physical (real-coefficient) models are kept.

use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// A basis {φ₀, …, φ_d} of real polynomials, evaluated at the model's complex frequency
/// variable (s = iω or z⁻¹ = e^{−iωTs}).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum PolyBasis<T: Real> {
    /// Orthonormal polynomials in s for a continuous-time model (see the module docs).
    Orthonormal {
        /// Frequency scale ω_s (rad/s).
        scale: T,
        /// Recurrence coefficients γ₁ … γ_d (all positive).
        gamma: Vec<T>,
    },
    /// Powers of z⁻¹ for a discrete-time model with sample time `ts`.
    DelayPowers {
        /// Sample time (s).
        ts: T,
    },
    /// Partial fractions in s with fixed basis poles qⱼ (the barycentric form of vector
    /// fitting): φ₀ = 1, φ = 1/(s − q) for a real q, and for a complex pair (q, q̄) the two
    /// real rational functions 1/(s − q) + 1/(s − q̄) and i/(s − q) − i/(s − q̄).
    /// A "polynomial" Σ cₙ φₙ is then a rational function with poles at the qⱼ; the ratio of
    /// two of them is a rational model whose poles are the zeros of the denominator.
    PartialFractions {
        /// Basis poles: real ones (im = 0) and one member (im > 0) of each complex pair.
        poles: Vec<Complex<T>>,
    },
}

impl<T: Real> PolyBasis<T> {
    /// Builds the orthonormal basis up to `degree` on the frequency grid `omega` (rad/s).
    ///
    /// # Errors
    /// No positive frequency, or too few distinct frequencies for the degree
    /// (2·#distinct positive lines + 1 if ω = 0 is present must exceed `degree`).
    pub fn orthonormal(omega: &[T], degree: usize) -> Result<Self> {
        let scale = omega.iter().fold(T::zero(), |m, w| Float::max(m, *w));
        if !(scale > T::zero()) || !Float::is_finite(scale) {
            return Err(FdidError::InvalidArgument {
                name: "omega",
                value: format!("max {scale}"),
                reason: "a continuous-time basis needs at least one positive, finite frequency"
                    .into(),
            });
        }
        if degree >= 2 * omega.len() {
            // never enough points: fail before allocating for `degree`
            return Err(FdidError::TooFewFrequencies {
                lines: omega.len(),
                equations: 2 * omega.len(),
                parameters: degree.saturating_add(1),
            });
        }
        // symmetric discrete measure: points ±x_k, equal weights summing to one
        let x: Vec<T> = omega.iter().map(|w| *w / scale).collect();
        let n = T::from_usize_lossy(x.len());
        // p_{n-1}, p_n at the points x_k (>= 0); by parity the −x_k half mirrors it.
        let mut prev = vec![T::zero(); x.len()];
        let mut cur = vec![T::one(); x.len()];
        let mut gamma = Vec::with_capacity(degree);
        let tiny = T::default_epsilon() * T::lit(64.0);
        for k in 0..degree {
            let g_prev = if k == 0 { T::zero() } else { gamma[k - 1] };
            // q = x p_k − γ_k p_{k−1}
            let mut norm2 = T::zero();
            let next: Vec<T> = x
                .iter()
                .zip(cur.iter().zip(&prev))
                .map(|(xi, (c, p))| {
                    let q = *xi * *c - g_prev * *p;
                    norm2 += q * q;
                    q
                })
                .collect();
            let g = Float::sqrt(norm2 / n);
            if !(g > tiny) {
                return Err(FdidError::TooFewFrequencies {
                    lines: omega.len(),
                    equations: 2 * omega.len(),
                    parameters: degree + 1,
                });
            }
            gamma.push(g);
            prev = cur;
            cur = next.into_iter().map(|q| q / g).collect();
        }
        Ok(Self::Orthonormal { scale, gamma })
    }

    /// The discrete-time basis z⁻ⁿ for sample time `ts`.
    ///
    /// # Errors
    /// `ts ≤ 0` or not finite.
    pub fn delay_powers(ts: T) -> Result<Self> {
        if !(ts > T::zero()) || !Float::is_finite(ts) {
            return Err(FdidError::InvalidArgument {
                name: "ts",
                value: format!("{ts}"),
                reason: "the sample time must be positive and finite".into(),
            });
        }
        Ok(Self::DelayPowers { ts })
    }

    /// Partial fractions with the given basis poles (real ones, and one member of each
    /// complex pair with im > 0).
    ///
    /// # Errors
    /// Non-finite poles, a pole on the imaginary axis (it would make the basis infinite at a
    /// data frequency), or repeated poles.
    pub fn partial_fractions(poles: Vec<Complex<T>>) -> Result<Self> {
        for (i, q) in poles.iter().enumerate() {
            if !(Float::is_finite(q.re) && Float::is_finite(q.im)) || q.im < T::zero() {
                return Err(FdidError::InvalidArgument {
                    name: "basis pole",
                    value: format!("{q} at entry {i}"),
                    reason: "basis poles must be finite, given once per conjugate pair (im ≥ 0)"
                        .into(),
                });
            }
            if q.re == T::zero() {
                return Err(FdidError::InvalidArgument {
                    name: "basis pole",
                    value: format!("{q} at entry {i}"),
                    reason: "a basis pole on the imaginary axis".into(),
                });
            }
            for (j, r) in poles[..i].iter().enumerate() {
                if (*q - *r).norm() <= T::default_epsilon() * q.norm() {
                    return Err(FdidError::InvalidArgument {
                        name: "basis pole",
                        value: format!("{q} at entries {j} and {i}"),
                        reason: "repeated basis poles".into(),
                    });
                }
            }
        }
        Ok(Self::PartialFractions { poles })
    }

    /// Number of basis functions besides φ₀ that a partial-fraction basis holds (a complex
    /// pair counts twice).
    fn fraction_count(poles: &[Complex<T>]) -> usize {
        poles
            .iter()
            .map(|q| if q.im == T::zero() { 1 } else { 2 })
            .sum()
    }

    /// Highest degree the basis can evaluate (`usize::MAX` for powers of z⁻¹).
    pub fn max_degree(&self) -> usize {
        match self {
            Self::Orthonormal { gamma, .. } => gamma.len(),
            Self::DelayPowers { .. } => usize::MAX,
            Self::PartialFractions { poles } => Self::fraction_count(poles),
        }
    }

    /// The real state-space realisation (Q, b) of the partial fractions: φ₁…φ_n of
    /// [`PolyBasis::PartialFractions`] are the entries of (sI − Q)⁻¹b. A real pole q gives
    /// Q = q, b = 1; a pair σ ± iω gives the block [[σ, ω], [−ω, σ]] with b = [2, 0].
    /// `None` for the polynomial bases.
    pub fn realisation(&self) -> Option<(nalgebra::DMatrix<T>, nalgebra::DVector<T>)> {
        let Self::PartialFractions { poles } = self else {
            return None;
        };
        let n = Self::fraction_count(poles);
        let mut q = nalgebra::DMatrix::zeros(n, n);
        let mut b = nalgebra::DVector::zeros(n);
        let mut i = 0;
        for p in poles {
            if p.im == T::zero() {
                q[(i, i)] = p.re;
                b[i] = T::one();
                i += 1;
            } else {
                q[(i, i)] = p.re;
                q[(i + 1, i + 1)] = p.re;
                q[(i, i + 1)] = p.im;
                q[(i + 1, i)] = -p.im;
                b[i] = T::lit(2.0);
                i += 2;
            }
        }
        Some((q, b))
    }

    /// The complex frequency variable at angular frequency ω: s = iω (continuous time) or
    /// z = e^{iωTs} (discrete time).
    pub fn variable(&self, omega: T) -> Complex<T> {
        match self {
            Self::Orthonormal { .. } | Self::PartialFractions { .. } => {
                Complex::new(T::zero(), omega)
            }
            Self::DelayPowers { ts } => Complex::new(T::zero(), omega * *ts).exp(),
        }
    }

    /// [`PolyBasis::eval_into`] at the variable of angular frequency ω: for
    /// [`PolyBasis::DelayPowers`] the powers of z⁻¹ = e^{−iωTs} from one `sin_cos`, without
    /// forming z and dividing by it.
    #[inline]
    pub fn eval_at(&self, omega: T, out: &mut [Complex<T>]) {
        self.eval_at_known(omega, None, out);
    }

    /// [`PolyBasis::eval_at`] with z⁻¹ = e^{−iωTs} of [`PolyBasis::DelayPowers`] given when
    /// it is known (`zinv`, the value of [`delay_variable`]); the other bases ignore it.
    #[inline]
    pub(crate) fn eval_at_known(&self, omega: T, zinv: Option<Complex<T>>, out: &mut [Complex<T>]) {
        match self {
            Self::DelayPowers { ts } => {
                let Some(first) = out.first_mut() else {
                    return;
                };
                *first = Complex::new(T::one(), T::zero());
                delay_powers(zinv.unwrap_or_else(|| delay_variable(omega, *ts)), out);
            }
            _ => self.eval_into(self.variable(omega), out),
        }
    }

    /// Writes φ₀(v) … φ_d(v) into `out` (length d + 1) for the variable `v` returned by
    /// [`PolyBasis::variable`] (or any complex s / z).
    pub fn eval_into(&self, v: Complex<T>, out: &mut [Complex<T>]) {
        let Some(first) = out.first_mut() else {
            return;
        };
        *first = Complex::new(T::one(), T::zero());
        match self {
            Self::Orthonormal { scale, gamma } => {
                let x = v / *scale;
                for k in 1..out.len() {
                    let back = if k >= 2 {
                        out[k - 2] * gamma[k - 2]
                    } else {
                        Complex::new(T::zero(), T::zero())
                    };
                    out[k] = (x * out[k - 1] + back) / gamma[k - 1];
                }
            }
            Self::DelayPowers { .. } => {
                let zinv = v.inv();
                for k in 1..out.len() {
                    out[k] = out[k - 1] * zinv;
                }
            }
            Self::PartialFractions { poles } => partial_fraction_terms(poles, v, out, |t| t),
        }
    }

    /// Writes φ₀(v) … φ_d(v) into `phi` (as [`PolyBasis::eval_into`]) and their
    /// derivatives dφⱼ/dv into `dphi` (the same length): for z⁻¹ powers d(z⁻ᵏ)/dz =
    /// −k·z⁻ᵏ⁻¹; for partial fractions d(1/(v − q))/dv = −1/(v − q)²; for the orthonormal
    /// basis the recurrence differentiated, dφₖ = (φₖ₋₁/ω_s + x·dφₖ₋₁ + γₖ₋₂·dφₖ₋₂)/γₖ₋₁.
    pub fn eval_with_derivative_into(
        &self,
        v: Complex<T>,
        phi: &mut [Complex<T>],
        dphi: &mut [Complex<T>],
    ) {
        self.eval_into(v, phi);
        let zero = Complex::new(T::zero(), T::zero());
        let Some(first) = dphi.first_mut() else {
            return;
        };
        *first = zero;
        match self {
            Self::Orthonormal { scale, gamma } => {
                let x = v / *scale;
                for k in 1..dphi.len().min(phi.len()) {
                    let back = if k >= 2 {
                        dphi[k - 2] * gamma[k - 2]
                    } else {
                        zero
                    };
                    dphi[k] = (phi[k - 1] / *scale + x * dphi[k - 1] + back) / gamma[k - 1];
                }
            }
            Self::DelayPowers { .. } => {
                let zinv = v.inv();
                for k in 1..dphi.len().min(phi.len()) {
                    dphi[k] = -phi[k] * zinv * T::from_usize_lossy(k);
                }
            }
            Self::PartialFractions { poles } => {
                partial_fraction_terms(poles, v, dphi, |t| -(t * t));
            }
        }
    }

    /// Coefficients of degree ≤ `n` in this basis of the polynomial with roots `r`, normalised
    /// like a denominator (constant coefficient one in z⁻¹ and for partial fractions, leading
    /// coefficient one for the orthonormal basis); for partial fractions the "polynomial" is
    /// Π(s − rᵢ)/Π(s − qⱼ). The product is formed factor by factor in the basis itself, never
    /// through monomials of the orthonormal expansion; the roots are expected to be `n`
    /// values closed under conjugation.
    /// (conjugate pairs are multiplied together so the arithmetic stays real).
    pub fn from_roots(&self, r: &[Complex<T>], n: usize) -> Vec<T> {
        // real quadratic and linear factors
        let mut factors: Vec<(T, T, bool)> = vec![]; // (c1, c0, quadratic): x² + c1 x + c0 or x + c0
        let mut used = vec![false; r.len()];
        let tol = T::lit(1e3) * T::default_epsilon();
        for i in 0..r.len() {
            if used[i] {
                continue;
            }
            used[i] = true;
            let scale = Float::max(r[i].norm(), T::one());
            if Float::abs(r[i].im) <= tol * scale {
                factors.push((T::zero(), -r[i].re, false));
            } else {
                // find its conjugate
                let mate = (0..r.len()).filter(|j| !used[*j]).min_by(|x, y| {
                    let dx = (r[*x] - r[i].conj()).norm();
                    let dy = (r[*y] - r[i].conj()).norm();
                    dx.partial_cmp(&dy).unwrap_or(std::cmp::Ordering::Equal)
                });
                if let Some(j) = mate {
                    used[j] = true;
                }
                factors.push((-(r[i].re + r[i].re), r[i].norm_sqr(), true));
            }
        }
        match self {
            Self::DelayPowers { .. } => {
                // A(z⁻¹) = Π (1 − p z⁻¹): in z⁻¹ the factor x + c0 becomes 1 + c0 z⁻¹
                let mut c = vec![T::one()];
                for (c1, c0, quad) in factors {
                    let add: Vec<T> = if quad {
                        vec![T::one(), c1, c0]
                    } else {
                        vec![T::one(), c0]
                    };
                    let mut next = vec![T::zero(); c.len() + add.len() - 1];
                    for (i, x) in c.iter().enumerate() {
                        for (j, y) in add.iter().enumerate() {
                            next[i + j] += *x * *y;
                        }
                    }
                    c = next;
                }
                c.resize(n + 1, T::zero());
                c
            }
            Self::PartialFractions { poles: q } => {
                // D(s) = Π(s − rᵢ)/Π(s − qⱼ) = 1 + Σ ρⱼ/(s − qⱼ), ρⱼ = Π(qⱼ − rᵢ)/Π_{l≠j}(qⱼ − q_l)
                let all_q: Vec<Complex<T>> = q
                    .iter()
                    .flat_map(|p| {
                        if p.im == T::zero() {
                            vec![*p]
                        } else {
                            vec![*p, p.conj()]
                        }
                    })
                    .collect();
                let one = Complex::new(T::one(), T::zero());
                let residue = |qj: Complex<T>| {
                    let num = r.iter().fold(one, |acc, ri| acc * (qj - *ri));
                    let den = all_q
                        .iter()
                        .filter(|ql| (**ql - qj).norm() > T::zero())
                        .fold(one, |acc, ql| acc * (qj - *ql));
                    num / den
                };
                let mut c = vec![T::one()];
                for p in q {
                    let rho = residue(*p);
                    // ρ/(s − q) + ρ̄/(s − q̄) = Re ρ · φ_a + Im ρ · φ_b
                    c.push(rho.re);
                    if p.im != T::zero() {
                        c.push(rho.im);
                    }
                }
                c.resize(n + 1, T::zero());
                c
            }
            Self::Orthonormal { scale, gamma } => {
                // work in x = s/ω_s; multiply by x using x φ_k = γ_{k+1} φ_{k+1} − γ_k φ_{k−1}
                let times_x = |c: &[T]| {
                    let mut out = vec![T::zero(); c.len() + 1];
                    for (k, ck) in c.iter().enumerate() {
                        out[k + 1] += gamma[k] * *ck;
                        if k >= 1 {
                            out[k - 1] -= gamma[k - 1] * *ck;
                        }
                    }
                    out
                };
                let mut c = vec![T::one()];
                for (c1, c0, quad) in factors {
                    let xs = times_x(&c);
                    let mut next = if quad { times_x(&xs) } else { xs.clone() };
                    let s1 = c1 / *scale;
                    let s0 = if quad {
                        c0 / (*scale * *scale)
                    } else {
                        c0 / *scale
                    };
                    if quad {
                        for (k, v) in xs.iter().enumerate() {
                            next[k] += s1 * *v;
                        }
                    }
                    for (k, v) in c.iter().enumerate() {
                        next[k] += s0 * *v;
                    }
                    c = next;
                }
                c.resize(n + 1, T::zero());
                let lead = c[n];
                c.iter().map(|v| *v / lead).collect()
            }
        }
    }

    /// For a partial-fraction basis: an orthonormal basis Z (n × (n − m)) of the
    /// coefficient vectors c ∈ ℝⁿ with cᵀQᵏb = 0 for k < m, for the realisation (Q, b) of a
    /// partial-fraction basis: the orthogonal complement of the Krylov space
    /// span{b, Q̂b, …, Q̂^{m−1}b} (Q̂ = Q/‖Q‖, built by Arnoldi with re-orthogonalisation),
    /// the last n − m columns of the Q of its Householder QR.
    ///
    /// # Errors
    /// A polynomial basis; a Krylov space that breaks down (m too large for the poles).
    pub fn markov_null_space(&self, m: usize) -> Result<DMatrix<T>> {
        Ok(self.markov_complement(m)?.basis())
    }

    /// [`PolyBasis::markov_null_space`] held as its m Householder reflectors, which map the
    /// basis values φ to ψ = φZ in O(m·n) per line.
    pub(crate) fn markov_complement(
        &self,
        m: usize,
    ) -> Result<crate::linalg::householder::Complement<T>> {
        let (q, b) = self.realisation().ok_or(FdidError::InvalidArgument {
            name: "basis",
            value: "polynomial".into(),
            reason: "Markov constraints need a partial-fraction basis".into(),
        })?;
        let n = q.nrows();
        let qn = q.norm();
        let qhat = if qn > T::zero() { q / qn } else { q };
        // Arnoldi: an orthonormal basis of the Krylov space, re-orthogonalised twice
        let mut u = DMatrix::<T>::zeros(n, m);
        let mut v = b;
        let tiny = T::lit(1e3) * T::default_epsilon();
        for j in 0..m {
            let before = v.norm();
            for _ in 0..2 {
                for i in 0..j {
                    let h = u.column(i).dot(&v);
                    v.axpy(-h, &u.column(i), T::one());
                }
            }
            let nv = v.norm();
            if !(nv > tiny * before) || !(nv > T::zero()) {
                return Err(FdidError::Singular {
                    what: "relative-degree constraints of the partial-fraction numerator \
                           (Krylov space breaks down: use a smaller relative degree na − nb)",
                    condition: (before / nv).to_f64_lossless(),
                });
            }
            v /= nv;
            u.set_column(j, &v);
            v = &qhat * &v;
        }
        crate::linalg::householder::Complement::of(&u).ok_or(FdidError::Singular {
            what: "relative-degree constraints of the partial-fraction numerator \
                   (the Krylov basis lost its rank to rounding)",
            condition: f64::INFINITY,
        })
    }

    /// Evaluates the polynomial Σ cₙ φₙ(v).
    pub fn eval_poly(&self, coeffs: &[T], v: Complex<T>) -> Complex<T> {
        let mut phi = vec![Complex::new(T::zero(), T::zero()); coeffs.len()];
        self.eval_into(v, &mut phi);
        phi.iter()
            .zip(coeffs)
            .fold(Complex::new(T::zero(), T::zero()), |acc, (p, c)| {
                acc + *p * *c
            })
    }

    /// Converts basis coefficients to monomial coefficients: in s (ascending powers) for the
    /// orthonormal basis, in z⁻¹ (unchanged) for the discrete-time one.
    ///
    /// The conversion is exact in exact arithmetic, but monomial coefficients of a high-order
    /// model spanning several decades are ill-conditioned: use them for display, not for
    /// computation.
    pub fn to_monomial(&self, coeffs: &[T]) -> Vec<T> {
        match self {
            Self::DelayPowers { .. } => coeffs.to_vec(),
            Self::PartialFractions { poles } => {
                // numerator of Σ cₙ φₙ over Π(s − qⱼ), ascending powers of s
                let mul = |p: &[T], f: &[T]| {
                    let mut out = vec![T::zero(); p.len() + f.len() - 1];
                    for (i, x) in p.iter().enumerate() {
                        for (j, y) in f.iter().enumerate() {
                            out[i + j] += *x * *y;
                        }
                    }
                    out
                };
                let factors: Vec<Vec<T>> = poles
                    .iter()
                    .map(|q| {
                        if q.im == T::zero() {
                            vec![-q.re, T::one()]
                        } else {
                            vec![q.norm_sqr(), -(q.re + q.re), T::one()]
                        }
                    })
                    .collect();
                let product = |skip: Option<usize>| {
                    factors
                        .iter()
                        .enumerate()
                        .filter(|(j, _)| Some(*j) != skip)
                        .fold(vec![T::one()], |acc, (_, f)| mul(&acc, f))
                };
                let n = Self::fraction_count(poles);
                let mut out = vec![T::zero(); n + 1];
                let get = |k: usize| coeffs.get(k).copied().unwrap_or_else(T::zero);
                for (j, v) in product(None).iter().enumerate() {
                    out[j] += get(0) * *v;
                }
                let mut k = 1;
                let two = T::lit(2.0);
                for (j, q) in poles.iter().enumerate() {
                    let rest = product(Some(j));
                    let num: Vec<T> = if q.im == T::zero() {
                        vec![get(k)]
                    } else {
                        // 2c_a(s − σ) − 2c_b ω
                        vec![-two * get(k) * q.re - two * get(k + 1) * q.im, two * get(k)]
                    };
                    for (i, v) in mul(&rest, &num).iter().enumerate() {
                        out[i] += *v;
                    }
                    k += if q.im == T::zero() { 1 } else { 2 };
                }
                out.truncate(coeffs.len().max(1));
                out
            }
            Self::Orthonormal { scale, gamma } => {
                let d = coeffs.len();
                let mut out = vec![T::zero(); d];
                if d == 0 {
                    return out;
                }
                // monomial coefficients of φ_{k-1}, φ_k
                let mut prev: Vec<T> = vec![];
                let mut cur: Vec<T> = vec![T::one()];
                out[0] = coeffs[0];
                for k in 1..d {
                    let mut next = vec![T::zero(); k + 1];
                    for (j, c) in cur.iter().enumerate() {
                        next[j + 1] += *c / *scale;
                    }
                    if k >= 2 {
                        for (j, p) in prev.iter().enumerate() {
                            next[j] += gamma[k - 2] * *p;
                        }
                    }
                    for v in next.iter_mut() {
                        *v /= gamma[k - 1];
                    }
                    for (j, v) in next.iter().enumerate() {
                        out[j] += coeffs[k] * *v;
                    }
                    prev = cur;
                    cur = next;
                }
                out
            }
        }
    }
}

/// z⁻¹ = e^{−iωTs} at ω for sample time `ts`, from one [`sin_cos`].
#[inline]
pub(crate) fn delay_variable<T: Real>(omega: T, ts: T) -> Complex<T> {
    let (s, c) = sin_cos(omega * ts);
    Complex::new(c, -s)
}

/// The powers z⁻ᵏ = `zinv`ᵏ into `out[k]`, k ≥ 1, each from the one before (`out[0]` holds 1).
#[inline]
pub(crate) fn delay_powers<T: Real>(zinv: Complex<T>, out: &mut [Complex<T>]) {
    for k in 1..out.len() {
        out[k] = out[k - 1] * zinv;
    }
}

/// (sin x, cos x). For f64 and |x| ≤ [`FAST_SIN_COS_LIMIT`] (the normalised frequencies
/// ωTs of data below the Nyquist frequency, and the phases ωτ of delays) by a reduction to
/// |r| ≤ π/4, x = kπ/2 + r, with π/2 split in two (the first part with 33 significant bits,
/// so that k·π/2 is exact for |k| < 2²⁰ and x − k·π/2 exact by Sterbenz's lemma; the second
/// part's product leaves an error of about |k|·10⁻²⁶), and the Taylor series of sin r to
/// r¹⁷ and cos r to r¹⁶ (truncation below 10⁻¹⁷): within a few ulp of the correctly
/// rounded values, about three times faster than the library call that it replaces in the
/// per-line evaluation of z⁻¹ = e^{−iωTs} and of e^{−iωτ}. Otherwise, and for f32, the
/// library's `sin_cos`.
#[inline]
pub(crate) fn sin_cos<T: Real>(x: T) -> (T, T) {
    if T::default_epsilon() > T::lit(1e-10) || !(Float::abs(x) <= T::lit(FAST_SIN_COS_LIMIT)) {
        return Float::sin_cos(x);
    }
    // π/2 = PIO2_HI + PIO2_LO, PIO2_HI with 33 significant bits
    const PIO2_HI: f64 = 1.570_796_326_734_125_6;
    const PIO2_LO: f64 = 6.077_100_506_506_192e-11;
    // the nearest integer to x·2/π (|x·2/π| < 2¹⁶) by adding and removing 1.5·2⁵²: no call
    // to the library's `round` (a tie may round either way: |r| ≤ π/4 + 1 ulp still)
    let magic = T::lit(6_755_399_441_055_744.0);
    let k = (x * T::lit(std::f64::consts::FRAC_2_PI) + magic) - magic;
    let r = (x - k * T::lit(PIO2_HI)) - k * T::lit(PIO2_LO);
    let x = r * r;
    // sin r = r + r x S(x), cos r = 1 + x C(x) with x = r², S and C of degree 7 (the series
    // to r¹⁷ and r¹⁶), by Estrin's scheme (a short dependency chain)
    let estrin = |c: &[f64; 10]| {
        let t = |i: usize| T::lit(c[i]);
        let x2 = x * x;
        let x4 = x2 * x2;
        let q0 = t(1) + t(2) * x;
        let q1 = t(3) + t(4) * x;
        let q2 = t(5) + t(6) * x;
        let q3 = t(7) + t(8) * x;
        (q0 + q1 * x2) + (q2 + q3 * x2) * x4
    };
    let sin_r = r + r * x * estrin(&SIN_TAYLOR);
    let cos_r = T::one() + x * estrin(&COS_TAYLOR);
    match k.to_i32().unwrap_or(0).rem_euclid(4) {
        0 => (sin_r, cos_r),
        1 => (cos_r, -sin_r),
        2 => (-sin_r, -cos_r),
        _ => (-cos_r, sin_r),
    }
}

/// Largest |x| for which [`sin_cos`] reduces the argument itself: 2¹⁶, where |k| < 2¹⁶
/// keeps k·π/2 exact with ten bits to spare.
const FAST_SIN_COS_LIMIT: f64 = 65_536.0;

/// (−1)ⁿ/(2n+1)!, n = 0 … 9 (the series uses n = 1 … 8).
const SIN_TAYLOR: [f64; 10] = [
    1.0,
    -1.0 / 6.0,
    1.0 / 120.0,
    -1.0 / 5_040.0,
    1.0 / 362_880.0,
    -1.0 / 39_916_800.0,
    1.0 / 6_227_020_800.0,
    -1.0 / 1_307_674_368_000.0,
    1.0 / 355_687_428_096_000.0,
    -1.0 / 121_645_100_408_832_000.0,
];

/// (−1)ⁿ/(2n)!, n = 0 … 9 (the series uses n = 1 … 8).
const COS_TAYLOR: [f64; 10] = [
    1.0,
    -1.0 / 2.0,
    1.0 / 24.0,
    -1.0 / 720.0,
    1.0 / 40_320.0,
    -1.0 / 3_628_800.0,
    1.0 / 479_001_600.0,
    -1.0 / 87_178_291_200.0,
    1.0 / 20_922_789_888_000.0,
    -1.0 / 6_402_373_705_728_000.0,
];

/// Writes the partial-fraction basis terms of `poles` at `v` into `out[1..]`, each
/// t = 1/(v − q) mapped by `f`: f(t) for a real pole, f(t₁) + f(t₂) and i·(f(t₁) − f(t₂))
/// for a pair (t₂ = 1/(v − q̄)); f(t) = t gives the basis values, f(t) = −t² their
/// derivatives.
fn partial_fraction_terms<T: Real>(
    poles: &[Complex<T>],
    v: Complex<T>,
    out: &mut [Complex<T>],
    f: impl Fn(Complex<T>) -> Complex<T>,
) {
    let mut k = 1;
    let i = Complex::new(T::zero(), T::one());
    for q in poles {
        if k >= out.len() {
            break;
        }
        let t1 = f(crate::scalar::recip(v - *q));
        if q.im == T::zero() {
            out[k] = t1;
            k += 1;
        } else {
            let t2 = f(crate::scalar::recip(v - q.conj()));
            out[k] = t1 + t2;
            if k + 1 < out.len() {
                out[k + 1] = (t1 - t2) * i;
            }
            k += 2;
        }
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn sin_cos_within_a_few_ulp_of_the_library() {
        let mut worst: f64 = 0.0;
        for i in 0..=200_000 {
            let x = -4.0 + 8.0 * i as f64 / 200_000.0;
            let (s, c) = super::sin_cos(x);
            let (s0, c0) = x.sin_cos();
            worst = worst.max((s - s0).abs()).max((c - c0).abs());
        }
        assert!(worst <= 2.0 * f64::EPSILON, "worst error {worst:e}");
        // up to the limit, where |k| is large: random points and the floats nearest the
        // multiples of π/2 (|r| tiny, where a loose reduction would show)
        let mut worst: f64 = 0.0;
        let mut seed = 7u64;
        for i in 0..200_000u64 {
            // uniform in [−0.5, 0.5)
            let u = crate::test_rng::lcg(&mut seed);
            let x = if i % 2 == 0 {
                super::FAST_SIN_COS_LIMIT * 2.0 * u
            } else {
                (u * 82_000.0).round() * std::f64::consts::FRAC_PI_2
            };
            let (s, c) = super::sin_cos(x);
            let (s0, c0) = x.sin_cos();
            worst = worst.max((s - s0).abs()).max((c - c0).abs());
        }
        assert!(
            worst <= 2.0 * f64::EPSILON,
            "worst error up to 2^16 {worst:e}"
        );
        // outside the reduced range and in f32: the library's values
        assert_eq!(super::sin_cos(1e5f64), 1e5f64.sin_cos());
        assert_eq!(super::sin_cos(1.0f32), 1.0f32.sin_cos());
        let (s, c) = super::sin_cos(f64::NAN);
        assert!(s.is_nan() && c.is_nan());
    }
    use super::*;

    #[test]
    fn orthonormal_on_grid() {
        let omega: Vec<f64> = (0..400)
            .map(|k| 10f64.powf(-2.0 + 5.0 * k as f64 / 399.0))
            .collect();
        let b = PolyBasis::orthonormal(&omega, 20).unwrap();
        let mut gram = vec![vec![0.0; 21]; 21];
        let mut phi = vec![Complex::new(0.0, 0.0); 21];
        for w in &omega {
            b.eval_into(b.variable(*w), &mut phi);
            for (row, pi) in gram.iter_mut().zip(&phi) {
                for (g, pj) in row.iter_mut().zip(&phi) {
                    *g += (pi * pj.conj()).re / omega.len() as f64;
                }
            }
        }
        for (i, row) in gram.iter().enumerate() {
            for (j, g) in row.iter().enumerate() {
                // the symmetric measure makes Re⟨φi, φj⟩ = δij on the positive half
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((g - want).abs() < 1e-9, "gram[{i}][{j}] = {g}");
            }
        }
    }

    #[test]
    fn basis_is_real_polynomial_in_s() {
        let omega: Vec<f64> = (1..50).map(|k| k as f64).collect();
        let b = PolyBasis::orthonormal(&omega, 6).unwrap();
        let c = [0.3, -1.0, 2.0, 0.5, -0.25, 1.5, 0.7];
        let mono = b.to_monomial(&c);
        for s in [
            Complex::new(0.3, 2.0),
            Complex::new(-1.0, 0.5),
            Complex::new(0.0, 33.0),
        ] {
            let direct = b.eval_poly(&c, s);
            let via = mono
                .iter()
                .rev()
                .fold(Complex::new(0.0, 0.0), |acc, m| acc * s + *m);
            assert!((direct - via).norm() < 1e-9 * via.norm().max(1.0));
        }
        // real argument gives a real value
        let v = b.eval_poly(&c, Complex::new(0.7, 0.0));
        assert!(v.im.abs() < 1e-12);
    }

    #[test]
    fn partial_fractions_realisation_and_monomials() {
        let b = PolyBasis::partial_fractions(vec![
            Complex::new(-0.3, 2.0),
            Complex::new(-1.5, 0.0),
            Complex::new(-0.1, 7.0),
        ])
        .unwrap();
        assert_eq!(b.max_degree(), 5);
        let (q, bv) = b.realisation().unwrap();
        let c = [0.7, 1.0, -0.5, 2.0, 0.25, -1.25];
        let mono = b.to_monomial(&c);
        let den = b.to_monomial(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        for s in [Complex::new(0.0, 1.3), Complex::new(0.4, -2.0)] {
            let direct = b.eval_poly(&c, s);
            // c₀ + cᵀ(sI − Q)⁻¹b
            let m = nalgebra::DMatrix::<Complex<f64>>::from_fn(5, 5, |i, j| {
                let d = if i == j { s } else { Complex::new(0.0, 0.0) };
                d - Complex::new(q[(i, j)], 0.0)
            });
            let rhs = nalgebra::DVector::from_fn(5, |i, _| Complex::new(bv[i], 0.0));
            let x = m.lu().solve(&rhs).unwrap();
            let ss = (1..6).fold(Complex::new(c[0], 0.0), |acc, k| acc + x[k - 1] * c[k]);
            assert!((direct - ss).norm() < 1e-12 * direct.norm().max(1.0));
            let horner = |p: &[f64]| {
                p.iter()
                    .rev()
                    .fold(Complex::new(0.0, 0.0), |acc, m| acc * s + *m)
            };
            let via = horner(&mono) / horner(&den);
            assert!((direct - via).norm() < 1e-10 * direct.norm().max(1.0));
        }
        assert!(PolyBasis::partial_fractions(vec![Complex::new(0.0, 1.0)]).is_err());
        assert!(PolyBasis::partial_fractions(vec![Complex::new(-1.0, -1.0)]).is_err());
    }

    #[test]
    fn too_few_points() {
        assert!(matches!(
            PolyBasis::orthonormal(&[1.0, 2.0], 5),
            Err(FdidError::TooFewFrequencies { .. })
        ));
        assert!(PolyBasis::orthonormal(&[1.0, 2.0], 3).is_ok());
        assert!(PolyBasis::<f64>::orthonormal(&[0.0], 1).is_err());
        assert!(PolyBasis::delay_powers(0.0f64).is_err());
    }
}
