//! Rational transfer-function models G = B/A in s (continuous time) or z⁻¹ (discrete time).

use super::kept_basis::{BasisTable, KeptBasis, TableRun};
use super::kept_grid::KeptGrid;
use super::stacked_rows::StackedRows;
use super::{EquationError, ModelStructure, PolesZeros};
use crate::basis::PolyBasis;
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::roots::roots;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// Time domain of a model.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Domain<T: Real> {
    /// Continuous time: G evaluated at s = iω.
    Continuous,
    /// Discrete time with sample time `ts` (s): G evaluated at z = e^{iωTs}.
    Discrete {
        /// Sample time (s).
        ts: T,
    },
}

/// A rational model G(θ) = B(θ)/A(θ).
///
/// **Continuous time, partial fractions** ([`Rational::partial_fractions`], chosen by
/// [`Rational::continuous`] when nb ≥ na − 1): A and B are rational functions over fixed
/// basis poles, D = 1 + Σ dₙφₙ and N = Σ cₙφₙ (vector fitting's barycentric form).
///
/// **Continuous time, polynomial** (McKelvey eq. 7; [`Rational::polynomial`]): A(s) of
/// degree `na` and B(s) of degree `nb`, both expanded in the basis φₙ(s) orthonormal on the
/// data grid ([`PolyBasis::Orthonormal`]):
///
/// ```text
/// A(s) = φ_na(s) + Σ_{n<na} aₙ φₙ(s),   B(s) = Σ_{n≤nb} bₙ φₙ(s),
/// θ = [a₀ … a_{na−1}, b₀ … b_nb].
/// ```
///
/// `nb = na` gives a direct feedthrough, `nb < na` a strictly proper model; `nb > na`
/// (improper, e.g. an impedance R + sL) is allowed.
///
/// **Discrete time** (McKelvey eq. 3), the digital-filter convention:
///
/// ```text
/// A(z⁻¹) = 1 + a₁z⁻¹ + … + a_na z⁻ⁿᵃ,   B(z⁻¹) = b₀ + b₁z⁻¹ + … + b_nb z⁻ⁿᵇ,
/// θ = [a₁ … a_na, b₀ … b_nb].
/// ```
///
/// The Jacobian is analytic: ∂G/∂bₙ = φₙ/A, ∂G/∂aₙ = −G φₙ/A.
///
/// A deserialised model is rebuilt from its orders, basis and transient and checked against
/// the stored numerator map ([`Rational::try_from`] of the stored fields): an edited or
/// corrupted file is an error, not a model that panics or answers wrongly.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(try_from = "Stored<T>"))]
pub struct Rational<T: Real> {
    na: usize,
    nb: usize,
    basis: PolyBasis<T>,
    /// For a partial-fraction model with nb < na − 1: the n × (nb + 1) orthonormal map Z
    /// from θ's numerator part to c₁…c_n (c₀ = 0), spanning the c with vanishing Markov
    /// parameters cᵀQᵏb, k < na − nb − 1 (relative degree na − nb).
    numerator_map: Option<DMatrix<T>>,
    /// Z of `numerator_map` as its Householder reflectors, which give ψ = φZ in O(m·n)
    /// per line (see [`crate::linalg::householder`]); `None` in a model read from a file written
    /// without them, which then applies Z as a matrix.
    #[cfg_attr(feature = "serde", serde(default))]
    numerator_reflectors: Option<crate::linalg::householder::Complement<T>>,
    /// Sample time of the transient term, when the model has one.
    transient: Option<T>,
    /// The grid of the first data checked ([`ModelStructure::check_data`]), with z⁻¹ on
    /// it for a model that samples.
    #[cfg_attr(feature = "serde", serde(skip))]
    grid: KeptGrid<T>,
    /// The basis values on `grid` ([`Rational::tabulated`]); not cloned.
    #[cfg_attr(feature = "serde", serde(skip))]
    table: KeptBasis<T>,
}

/// A pole p with its sensitivities ∂p/∂θᵢ to the denominator parameters
/// ([`Rational::pole_sensitivities`]).
pub(crate) type PoleSensitivity<T> = (Complex<T>, Vec<Complex<T>>);

impl<T: Real> Rational<T> {
    /// A continuous-time model with denominator degree `na` and numerator degree `nb` for
    /// data on the frequency grid `omega` (rad/s), in the best-conditioned form the orders
    /// allow:
    /// - `nb = na` or `nb = na − 1` (`na ≥ 1`): the partial-fraction (barycentric) form of
    ///   [`Rational::partial_fractions_on`], whose basis poles the [`crate::Pipeline`] moves
    ///   to the estimated poles — accurate to machine precision at order 20 over several
    ///   decades;
    /// - otherwise: polynomials in the basis orthonormal on the grid
    ///   ([`Rational::polynomial`]), adequate up to about order 10 over two decades.
    ///
    /// # Errors
    /// No positive frequency, or too few distinct frequencies for the degrees.
    pub fn continuous(na: usize, nb: usize, omega: &[T]) -> Result<Self> {
        if na >= 1 && nb <= na {
            Self::partial_fractions_on(na, nb, omega)
        } else {
            Self::polynomial(na, nb, omega)
        }
    }

    /// A continuous-time model with A and B expanded in the polynomial basis orthonormal on
    /// the frequency grid `omega` (rad/s) — normally the data's. Any orders; the dynamic
    /// range of a polynomial over a wide band limits it to about order 10 over two decades
    /// in f64.
    ///
    /// # Errors
    /// No positive frequency, or too few distinct frequencies for the degrees.
    pub fn polynomial(na: usize, nb: usize, omega: &[T]) -> Result<Self> {
        crate::error::check_finite("omega", omega)?;
        super::check_degrees(na, nb)?;
        let basis = PolyBasis::orthonormal(omega, na.max(nb))?;
        Ok(Self {
            na,
            nb,
            basis,
            numerator_map: None,
            numerator_reflectors: None,
            transient: None,
            grid: KeptGrid::default(),
            table: KeptBasis::default(),
        })
    }

    /// A discrete-time model with sample time `ts` (s), A of degree `na` and B of degree
    /// `nb` in z⁻¹.
    ///
    /// # Errors
    /// `ts ≤ 0` or not finite; a degree above `usize::MAX / 8`
    /// ([`FdidError::InvalidArgument`] naming it).
    pub fn discrete(na: usize, nb: usize, ts: T) -> Result<Self> {
        super::check_degrees(na, nb)?;
        Ok(Self {
            na,
            nb,
            basis: PolyBasis::delay_powers(ts)?,
            numerator_map: None,
            numerator_reflectors: None,
            transient: None,
            grid: KeptGrid::default(),
            table: KeptBasis::default(),
        })
    }

    /// Denominator degree.
    pub fn na(&self) -> usize {
        self.na
    }

    /// Numerator degree.
    pub fn nb(&self) -> usize {
        self.nb
    }

    /// The polynomial basis.
    pub fn basis(&self) -> &PolyBasis<T> {
        &self.basis
    }

    /// The same model with a transient term for data from one non-periodic record
    /// (McKelvey eqs. 4–5): the modelled output is Ŷ = G U + T with
    ///
    /// ```text
    /// T(z) = (t₁ + t₂z⁻¹ + … + t_n z⁻⁽ⁿ⁻¹⁾) / A(z⁻¹),   n = max(na, nb),
    /// ```
    ///
    /// sharing the poles of G; θ gains [t₁ … t_n] at its end. With the DFT of
    /// [`crate::TimeData::dft`] (samples t = 0 … N − 1) the term z C(zI − A)⁻¹(x₀ − x_N)/√N
    /// of the leakage is exactly of this form, so G is recovered exactly from noise-free
    /// data of any stable system with any initial state. The 1/√N of eq. 4 is absorbed in
    /// t. The equation error A Y − B U − t stays linear, so Levy, SK and TLS estimate t too.
    ///
    /// # Errors
    /// A continuous-time model (use [`Rational::with_sampled_transient`]).
    pub fn with_transient(mut self) -> Result<Self> {
        let PolyBasis::DelayPowers { ts } = self.basis else {
            return Err(FdidError::InvalidArgument {
                name: "transient",
                value: "continuous-time model".into(),
                reason: "a continuous-time model needs the sample time of the record: use \
                         with_sampled_transient(ts)"
                    .into(),
            });
        };
        self.transient = Some(ts);
        Ok(self)
    }

    /// The same continuous-time partial-fraction model with the transient term of sampled
    /// data from a band-limited (multisine) experiment, McKelvey eqs. 9–10: Ŷ = G_c(iω) U +
    /// T with the discrete-time transient
    ///
    /// ```text
    /// T = Σⱼ tⱼ χⱼ(z) / D(s),   χ for a basis pole q: 1/(1 − e^{qTs} z⁻¹)
    /// ```
    ///
    /// (a complex pair gives the real and imaginary combinations of its two fractions),
    /// z = e^{iωTs}, s = iω; θ gains na coefficients at its end. When the basis poles are
    /// the poles of G (where the [`crate::Pipeline`]'s relocation puts them) D ≡ 1 and T is
    /// exactly t_c(z)/a_cd(z) of eq. 10; the equation error D Y − N U − Σ tⱼχⱼ stays linear.
    ///
    /// # Errors
    /// Not a partial-fraction model, or `ts` not positive and finite.
    pub fn with_sampled_transient(mut self, ts: T) -> Result<Self> {
        crate::data::check_ts(ts)?;
        if !matches!(self.basis, PolyBasis::PartialFractions { .. }) {
            return Err(FdidError::InvalidArgument {
                name: "transient",
                value: format!("{:?} model", self.domain()),
                reason: "the sampled continuous-time transient needs the partial-fraction form \
                         (Rational::continuous with nb ≤ na); a discrete-time model uses \
                         with_transient()"
                    .into(),
            });
        }
        self.transient = Some(ts);
        Ok(self)
    }

    /// Number of transient coefficients (0 without a transient term).
    pub fn n_transient(&self) -> usize {
        match (&self.transient, &self.basis) {
            (None, _) => 0,
            (Some(_), PolyBasis::DelayPowers { .. }) => self.na.max(self.nb),
            (Some(_), _) => self.na,
        }
    }

    /// The sample time of the transient term, if the model has one.
    pub fn transient_ts(&self) -> Option<T> {
        self.transient
    }

    /// z⁻¹ = e^{−iωTs} of the transient term (sample time `ts`) at ω, where `phi` holds
    /// the basis values at ω ([`PolyBasis::eval_at`]): for powers of z⁻¹ with the same
    /// sample time, φ₁ itself.
    /// `kept` is z⁻¹ at ω when it is known ([`Rational::kept_zinv`]).
    fn transient_variable(
        &self,
        ts: T,
        omega: T,
        phi: &[Complex<T>],
        kept: Option<Complex<T>>,
    ) -> Complex<T> {
        match (&self.basis, phi.get(1)) {
            (PolyBasis::DelayPowers { ts: t }, Some(zinv)) if *t == ts => *zinv,
            _ => kept.unwrap_or_else(|| crate::basis::delay_variable(omega, ts)),
        }
    }

    /// The sample time of the z⁻¹ of the model's evaluations: the basis' (powers of z⁻¹) or
    /// else the sampled transient's; `None` for a continuous-time model without transient.
    fn delay_ts(&self) -> Option<T> {
        match &self.basis {
            PolyBasis::DelayPowers { ts } => Some(*ts),
            _ => self.transient,
        }
    }

    /// z⁻¹ = e^{−iωTs} (Ts of [`Rational::delay_ts`]) on the lines `omega` from the grid
    /// kept by [`ModelStructure::check_data`], when the lines are a run of it; `None` when
    /// each line computes its own.
    pub(crate) fn kept_zinv(&self, omega: &[T]) -> Option<&[Complex<T>]> {
        self.grid.run(self.delay_ts()?, omega)
    }

    /// The basis values φ on the lines `omega` from the model's table
    /// ([`super::kept_basis`]) when the lines are a run of the grid kept by
    /// [`ModelStructure::check_data`]: for consecutive lines the table of the whole grid,
    /// for every m-th line that of every m-th line of the grid (the lines of the first such
    /// run's residue), each built by the first call that reads it; with `psi`, also the
    /// numerator basis ψ ([`Rational::numerator_basis`]) when it is not a slice of φ.
    /// `None` (each line computes its own) off the grid, on a second lattice of every m-th
    /// line, and above [`super::kept_basis::MAX_VALUES`] values.
    pub(crate) fn tabulated(&self, omega: &[T], psi: bool) -> Option<TableRun<'_, T>> {
        let (grid, run) = self.grid.lines(omega)?;
        let zero = Complex::new(T::zero(), T::zero());
        // the lines `first`, `first + step`, … (`count` of them) of the grid
        let phi = |first: usize, step: usize, count: usize| {
            // z⁻¹ as the evaluations on the grid read it
            let kept = self.kept_zinv(grid);
            BasisTable::build(count, self.na.max(self.nb) + 1, |k, phi| {
                let line = first + k * step;
                self.basis
                    .eval_at_known(grid[line], kept.map(|z| z[line]), phi);
            })
        };
        let psi = (psi && self.reflected()).then_some(|phi: &BasisTable<T>| {
            let (mut scratch, mut psi) = (self.zero_phi(), vec![zero; self.nb + 1]);
            BasisTable::build(phi.lines_count(), self.nb + 1, |k, line| {
                scratch.copy_from_slice(phi.line(k));
                line.copy_from_slice(self.numerator_basis(&mut scratch, &mut psi));
            })
        });
        self.table.run(run, grid.len(), phi, psi)
    }

    /// φ at the evaluation's line `k` (frequency `omega`, z⁻¹ `kept` when known): read
    /// from `run` when there is one, else computed into `scratch`.
    #[inline]
    fn phi_at<'a>(
        &self,
        run: Option<TableRun<'a, T>>,
        k: usize,
        omega: T,
        kept: Option<Complex<T>>,
        scratch: &'a mut [Complex<T>],
    ) -> &'a [Complex<T>] {
        match run {
            Some(run) => run.phi(k),
            None => {
                self.basis.eval_at_known(omega, kept, scratch);
                scratch
            }
        }
    }

    /// [`ModelStructure::jacobian_into`] from a table run (`g` and `jac` of its lines):
    /// G, −G/A and 1/A line by line, then the Jacobian column by column,
    /// ∂G/∂aⱼ = −φⱼ G/A and ∂G/∂bⱼ = ψⱼ/A, with the same values as line by line. False,
    /// with nothing written, when ψ is neither a slice of φ nor in a table (the caller
    /// then goes line by line).
    fn jacobian_from_table(
        &self,
        theta: &[T],
        c: &[T],
        run: TableRun<'_, T>,
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) -> bool {
        let zero = Complex::new(T::zero(), T::zero());
        let (n, na, off) = (jac.nrows(), self.na, self.a_offset());
        let Some((psi, at)) = self.numerator_lines(run, n) else {
            return false;
        };
        let factors = self.table_factors(theta, c, run, g);
        let mut cols = jac.as_mut_slice().chunks_exact_mut(n);
        for (j, col) in cols.by_ref().take(na).enumerate() {
            for ((d, f), p) in col.iter_mut().zip(&factors).zip(run.phi_lines(n)) {
                *d = p[off + j] * f.0;
            }
        }
        for (j, col) in cols.by_ref().take(self.nb + 1).enumerate() {
            for ((d, f), p) in col.iter_mut().zip(&factors).zip(psi.clone()) {
                *d = p[at + j] * f.1;
            }
        }
        // the transient coefficients do not enter G
        for col in cols {
            col.fill(zero);
        }
        true
    }

    /// G into `g` and, line by line, the factors (−G/A, 1/A) of the Jacobian
    /// ∂G/∂aⱼ = φⱼ·(−G/A), ∂G/∂bⱼ = ψⱼ·(1/A) from the φ of a table run (`g.len()` lines).
    fn table_factors(
        &self,
        theta: &[T],
        c: &[T],
        run: TableRun<'_, T>,
        g: &mut [Complex<T>],
    ) -> Vec<(Complex<T>, Complex<T>)> {
        let n = g.len();
        g.iter_mut()
            .zip(run.phi_lines(n))
            .map(|(g, p)| {
                let (a, b) = self.ab_at(theta, c, p);
                let inv_a = crate::scalar::recip(a);
                let gk = b * inv_a;
                *g = gk;
                (-gk * inv_a, inv_a)
            })
            .collect()
    }

    /// ψ of the first `lines` lines of a table run, with the index of ψ₀ in each slice:
    /// the ψ table's lines, or φ's when ψ is a slice of φ; `None` when ψ is reflected and
    /// has no table.
    fn numerator_lines<'a>(
        &self,
        run: TableRun<'a, T>,
        lines: usize,
    ) -> Option<(std::slice::ChunksExact<'a, Complex<T>>, usize)> {
        if self.reflected() {
            run.psi_lines(lines).map(|l| (l, 0))
        } else {
            Some((run.phi_lines(lines), self.b_offset()))
        }
    }

    /// The Levy rows of a model without transient from a table run (`out` of the run's
    /// lines, `y` and `u` theirs), column by column: φⱼY and −ψⱼU, with the same values as
    /// line by line. False, with nothing written, when ψ is neither a slice of φ nor in a
    /// table.
    fn rows_from_table(
        &self,
        run: TableRun<'_, T>,
        y: &[Complex<T>],
        u: &[Complex<T>],
        out: &mut DMatrix<Complex<T>>,
    ) -> bool {
        let n = out.nrows();
        let (None, Some((psi, at))) = (self.transient, self.numerator_lines(run, n)) else {
            return false;
        };
        let mut cols = out.as_mut_slice().chunks_exact_mut(n);
        for (j, col) in cols.by_ref().take(self.na + 1).enumerate() {
            for ((d, y), p) in col.iter_mut().zip(y).zip(run.phi_lines(n)) {
                *d = p[j] * *y;
            }
        }
        for (j, col) in cols.take(self.nb + 1).enumerate() {
            for ((d, u), p) in col.iter_mut().zip(u).zip(psi.clone()) {
                *d = -(p[at + j] * *u);
            }
        }
        true
    }

    /// Whether ψ is φ reflected or mapped ([`Rational::numerator_basis`]), not a slice of
    /// it.
    fn reflected(&self) -> bool {
        self.numerator_reflectors.is_some() || self.numerator_map.is_some()
    }

    /// ψ at the evaluation's line `k` ([`Rational::numerator_basis`] of the line's φ):
    /// from the run's ψ table, a slice of its φ, or computed from φ in `phi` (the line's φ,
    /// which the reflections overwrite) into `psi`.
    #[inline]
    fn numerator_at<'a>(
        &self,
        run: Option<TableRun<'a, T>>,
        k: usize,
        phi: &'a mut [Complex<T>],
        psi: &'a mut [Complex<T>],
    ) -> &'a [Complex<T>] {
        match run {
            Some(run) if !self.reflected() => {
                let off = self.b_offset();
                &run.phi(k)[off..=off + self.nb]
            }
            Some(run) => match run.psi(k) {
                Some(psi) => psi,
                None => {
                    phi.copy_from_slice(run.phi(k));
                    self.numerator_basis(phi, psi)
                }
            },
            None => self.numerator_basis(phi, psi),
        }
    }

    /// The transient basis values χⱼ at the variable z⁻¹ = `zinv` of
    /// [`Rational::transient_variable`] (see [`Rational::with_transient`] and
    /// [`Rational::with_sampled_transient`]).
    fn transient_basis(&self, ts: T, zinv: Complex<T>, chi: &mut [Complex<T>]) {
        let one = Complex::new(T::one(), T::zero());
        match &self.basis {
            PolyBasis::PartialFractions { poles } => {
                let mut j = 0;
                for q in poles {
                    let f = (one - (*q * ts).exp() * zinv).inv();
                    if q.im == T::zero() {
                        chi[j] = f;
                        j += 1;
                    } else {
                        let fc = (one - (q.conj() * ts).exp() * zinv).inv();
                        chi[j] = f + fc;
                        chi[j + 1] = (f - fc) * Complex::new(T::zero(), T::one());
                        j += 2;
                    }
                }
            }
            _ => {
                let mut p = one;
                for c in chi.iter_mut() {
                    *c = p;
                    p *= zinv;
                }
            }
        }
    }

    /// A continuous-time model in the barycentric (vector-fitting) form with basis poles
    /// `poles` (real ones, and one member with im > 0 of each complex pair):
    ///
    /// ```text
    /// G(s) = N(s)/D(s),  D(s) = 1 + Σ_{n≥1} dₙ φₙ(s),  N(s) = Σ cₙ φₙ(s),
    /// θ = [d₁ … d_na, c_{na−nb} … c_na],
    /// ```
    ///
    /// with φₙ the partial fractions of [`PolyBasis::PartialFractions`]; `na` is the number
    /// of basis functions besides φ₀ (a pair counts twice) and `nb ≤ na` the degree of the
    /// numerator of G: `nb = na` gives a direct feedthrough (c₀ free), `nb = na − 1` a
    /// strictly proper model (c₀ = 0), and `nb < na − 1` in addition constrains the first
    /// Markov parameters cᵀQᵏb (k < na − nb − 1) of the numerator to zero, so that G has
    /// relative degree na − nb; θ then holds the nb + 1 coordinates of c in an orthonormal
    /// basis of that subspace. The poles of G are the zeros of D. With basis poles close to the poles of G the columns of the Jacobian are
    /// nearly orthogonal, which keeps high orders over many decades well conditioned; see
    /// [`Rational::relocated`] and [`crate::Pipeline`] for the relocation iterations that put
    /// them there.
    ///
    /// # Errors
    /// Invalid basis poles (see [`PolyBasis::partial_fractions`]), `nb > na`, or no pole.
    pub fn partial_fractions(poles: Vec<Complex<T>>, nb: usize) -> Result<Self> {
        let basis = PolyBasis::partial_fractions(poles)?;
        let na = basis.max_degree();
        if na == 0 || nb > na {
            return Err(FdidError::InvalidArgument {
                name: "nb",
                value: format!("{nb} (na = {na})"),
                reason: "the partial-fraction form needs at least one pole and nb ≤ na".into(),
            });
        }
        let numerator_reflectors = if nb + 1 < na {
            Some(basis.markov_complement(na - nb - 1)?)
        } else {
            None
        };
        Ok(Self {
            na,
            nb,
            basis,
            numerator_map: numerator_reflectors.as_ref().map(|c| c.basis()),
            numerator_reflectors,
            transient: None,
            grid: KeptGrid::default(),
            table: KeptBasis::default(),
        })
    }

    /// A partial-fraction model (see [`Rational::partial_fractions`]) with `na` starting
    /// basis poles spread log-uniformly over the positive frequencies of `omega` (rad/s),
    /// lightly damped (qₖ = −ωₖ/100 ± iωₖ), plus one real pole −ω_max when `na` is odd: the
    /// usual vector-fitting start.
    ///
    /// # Errors
    /// `na = 0`, `nb` not in {na − 1, na}, no positive frequency; a degree above
    /// 2·`omega.len()` ([`FdidError::TooFewFrequencies`]: no fit on the grid can succeed).
    pub fn partial_fractions_on(na: usize, nb: usize, omega: &[T]) -> Result<Self> {
        crate::error::check_finite("omega", omega)?;
        let Some((lo, hi)) = positive_band(omega) else {
            return Err(FdidError::InvalidArgument {
                name: "omega",
                value: format!("max {}", omega.iter().copied().fold(T::zero(), Float::max)),
                reason: "a continuous-time model needs at least one positive frequency".into(),
            });
        };
        super::check_degrees_on_grid(na, nb, omega.len())?;
        let poles = log_spread_poles(na, lo, hi, T::lit(0.01));
        Self::partial_fractions(poles, nb)
    }

    /// The same kind of partial-fraction model with its basis poles moved to the poles of
    /// θ, unstable ones reflected into the left half-plane (the pole relocation step of
    /// vector fitting; with the denominator D = A/Π(s − qⱼ), one Levy solve in the new basis
    /// is one Sanathanan–Koerner iteration). `None` for the polynomial bases.
    /// This is [`EquationError::relocated`].
    fn relocate(&self, theta: &[T]) -> Option<Result<Self>> {
        let PolyBasis::PartialFractions { .. } = self.basis else {
            return None;
        };
        Some(self.poles(theta).and_then(|p| {
            let mut basis_poles = vec![];
            for q in p {
                let q = if q.re > T::zero() {
                    Complex::new(-q.re, q.im)
                } else {
                    q
                };
                // real eigenvalues come out with im exactly zero from the real Schur form
                if q.im > T::zero() {
                    basis_poles.push(q);
                } else if q.im == T::zero() {
                    let re = if q.re == T::zero() {
                        -T::default_epsilon()
                    } else {
                        q.re
                    };
                    basis_poles.push(Complex::new(re, T::zero()));
                }
            }
            // a pole of the pair with im < 0 alone (its partner lost to rounding) would
            // silently lower the order: refuse the relocation instead
            let order: usize = basis_poles
                .iter()
                .map(|q| if q.im > T::zero() { 2 } else { 1 })
                .sum();
            if order != self.na {
                return Err(FdidError::Numerical {
                    what: format!(
                        "pole relocation: the estimate's poles give a basis of order {order}, not {}",
                        self.na
                    ),
                });
            }
            let mut m = Self::partial_fractions(basis_poles, self.nb)?;
            m.transient = self.transient;
            // z⁻¹ of the transient depends on Ts and ω only
            m.grid = self.grid.clone();
            Ok(m)
        }))
    }

    /// Continuous or discrete time.
    pub fn domain(&self) -> Domain<T> {
        match self.basis {
            PolyBasis::Orthonormal { .. } | PolyBasis::PartialFractions { .. } => {
                Domain::Continuous
            }
            PolyBasis::DelayPowers { ts } => Domain::Discrete { ts },
        }
    }

    /// True for bases normalised by their constant coefficient (z⁻¹ powers, partial
    /// fractions), false for the orthonormal basis (normalised by the leading one).
    fn constant_normalised(&self) -> bool {
        !matches!(self.basis, PolyBasis::Orthonormal { .. })
    }

    /// Index of the first numerator basis function (1 for a strictly proper
    /// partial-fraction model, else 0).
    fn b_offset(&self) -> usize {
        match self.basis {
            PolyBasis::PartialFractions { .. } => self.na - self.nb,
            _ => 0,
        }
    }

    /// Numerator coefficients over the full basis (zeros below the offset, or c = [0, Z θ_b]
    /// for a constrained partial-fraction numerator).
    fn b_in_basis(&self, b: &[T]) -> Vec<T> {
        if let Some(z) = &self.numerator_map {
            let mut full = vec![T::zero()];
            full.extend(
                (0..z.nrows()).map(|k| (0..z.ncols()).fold(T::zero(), |s, j| s + z[(k, j)] * b[j])),
            );
            return full;
        }
        let mut full = vec![T::zero(); self.b_offset()];
        full.extend_from_slice(b);
        full
    }

    /// The nb + 1 numerator basis values ψⱼ from the basis values φ: φ shifted by the
    /// offset, or ψⱼ = Σ_k φ_{k+1} Z_kj for a constrained partial-fraction numerator, by its
    /// reflectors in `phi` itself (then overwritten) or with Z in `psi`.
    #[inline]
    fn numerator_basis<'a>(
        &self,
        phi: &'a mut [Complex<T>],
        psi: &'a mut [Complex<T>],
    ) -> &'a [Complex<T>] {
        match (&self.numerator_reflectors, &self.numerator_map) {
            (Some(c), _) => {
                let m = c.rank();
                c.reflect_row(&mut phi[1..=c.dim()]);
                &phi[1 + m..=c.dim()]
            }
            (None, Some(z)) => {
                for (p, zj) in psi.iter_mut().zip(z.column_iter()) {
                    *p = phi[1..]
                        .iter()
                        .zip(zj.iter())
                        .fold(Complex::new(T::zero(), T::zero()), |s, (f, z)| s + *f * *z);
                }
                psi
            }
            (None, None) => {
                let off = self.b_offset();
                &phi[off..=off + self.nb]
            }
        }
    }

    /// The complex frequency variable at ω (s = iω or z = e^{iωTs}).
    pub fn variable(&self, omega: T) -> Complex<T> {
        self.basis.variable(omega)
    }

    /// Splits θ into the full denominator coefficients (normalising one included) and the
    /// numerator coefficients, in the basis.
    ///
    /// # Panics
    /// Never for `theta.len() == n_params()`; shorter θ is padded with zeros.
    pub fn coefficients(&self, theta: &[T]) -> (Vec<T>, Vec<T>) {
        let na = self.na;
        let get = |i: usize| theta.get(i).copied().unwrap_or_else(T::zero);
        let mut a = Vec::with_capacity(na + 1);
        if self.constant_normalised() {
            a.push(T::one());
            a.extend((0..na).map(get));
        } else {
            a.extend((0..na).map(get));
            a.push(T::one());
        }
        let b = (na..na + self.nb + 1).map(get).collect();
        (a, b)
    }

    /// θ from full denominator and numerator coefficients (the denominator is rescaled so
    /// that its normalising coefficient is one; transient coefficients, if any, are zero).
    ///
    /// # Errors
    /// Wrong lengths, or a zero normalising coefficient.
    pub fn theta_from_polys(&self, a: &[T], b: &[T]) -> Result<Vec<T>> {
        if a.len() != self.na + 1 || b.len() != self.nb + 1 {
            return Err(FdidError::LengthMismatch {
                what: "polynomial coefficients (a, b)",
                expected: self.na + self.nb + 2,
                got: a.len() + b.len(),
            });
        }
        let mut c = a.to_vec();
        c.extend_from_slice(b);
        c.extend(std::iter::repeat_n(T::zero(), self.n_transient()));
        self.theta_from_coefficients(&c)
            .ok_or_else(|| FdidError::InvalidArgument {
                name: "a",
                value: format!("{:?}", a),
                reason: "the normalising coefficient of the denominator is zero".into(),
            })
    }

    /// Monomial coefficients (ascending powers of s, or of z⁻¹) of A and B. Exact in exact
    /// arithmetic but ill-conditioned for high orders over wide bands: for display.
    pub fn monomial_coefficients(&self, theta: &[T]) -> (Vec<T>, Vec<T>) {
        let (a, b) = self.coefficients(theta);
        (
            self.basis.to_monomial(&a),
            self.basis.to_monomial(&self.b_in_basis(&b)),
        )
    }

    /// True when every pole is strictly stable (Re p < 0, or |p| < 1).
    ///
    /// # Errors
    /// As [`PolesZeros::poles`].
    pub fn is_stable(&self, theta: &[T]) -> Result<bool> {
        let poles = self.poles(theta)?;
        Ok(match self.basis {
            PolyBasis::DelayPowers { .. } => poles.iter().all(|p| p.norm() < T::one()),
            _ => poles.iter().all(|p| p.re < T::zero()),
        })
    }

    /// Each pole p of θ (in the model's variable, s or z) with its sensitivities ∂p/∂θᵢ to
    /// the na denominator parameters (the numerator and the transient do not move the
    /// poles). From A(p; θ) = Σⱼ aⱼφⱼ(p) = 0, ∂p/∂θᵢ = −φ_{i+o}(p)/A′(p), with φ_{i+o} the
    /// basis function θᵢ multiplies in A (o = 1 for the constant-normalised bases) and
    /// A′ = Σⱼ aⱼφⱼ′ from the basis derivatives ([`PolyBasis::eval_with_derivative_into`]:
    /// exact also where a partial-fraction basis has a pole next to p, as after a
    /// relocation). `None` when the poles cannot be computed or a sensitivity is not
    /// finite (a double pole, whose position θ does not determine to first order).
    pub(crate) fn pole_sensitivities(&self, theta: &[T]) -> Option<Vec<PoleSensitivity<T>>> {
        let poles = self.poles(theta).ok()?;
        let (a, _) = self.coefficients(theta);
        let zero = Complex::new(T::zero(), T::zero());
        let (mut phi, mut dphi) = (vec![zero; a.len()], vec![zero; a.len()]);
        let off = self.a_offset();
        poles
            .into_iter()
            .map(|p| {
                self.basis.eval_with_derivative_into(p, &mut phi, &mut dphi);
                let slope = dphi.iter().zip(&a).fold(zero, |s, (d, c)| s + *d * *c);
                let d: Vec<Complex<T>> = (0..self.na).map(|i| -phi[i + off] / slope).collect();
                d.iter()
                    .all(|v| Float::is_finite(v.re) && Float::is_finite(v.im))
                    .then_some((p, d))
            })
            .collect()
    }

    /// Reflects unstable poles into the stable region, keeping |G(iω)| (or |G(e^{iωTs})|)
    /// unchanged: p ↦ −p̄ in s, p ↦ 1/p̄ in z (with B scaled by 1/|p| to keep the
    /// magnitude). The denominator is rebuilt from its roots by multiplying factors in the
    /// basis, never through monomials of the orthonormal expansion.
    ///
    /// # Errors
    /// As [`PolesZeros::poles`]; a pole at z = 0 cannot be reflected and is kept.
    pub fn reflect_unstable(&self, theta: &[T]) -> Result<Vec<T>> {
        let poles = self.poles(theta)?;
        let (_, mut b) = self.coefficients(theta);
        let mut gain_fix = T::one();
        let reflected: Vec<Complex<T>> = poles
            .iter()
            .map(|p| match self.basis {
                PolyBasis::Orthonormal { .. } | PolyBasis::PartialFractions { .. }
                    if p.re > T::zero() =>
                {
                    Complex::new(-p.re, p.im)
                }
                PolyBasis::DelayPowers { .. } if p.norm() > T::one() => {
                    gain_fix /= p.norm();
                    p.conj().inv()
                }
                _ => *p,
            })
            .collect();
        let a = self.basis.from_roots(&reflected, self.na);
        for v in b.iter_mut() {
            *v *= gain_fix;
        }
        let mut out = self.theta_from_polys(&a, &b)?;
        let nt = self.n_transient();
        let (lo, hi) = (out.len() - nt, theta.len().saturating_sub(nt));
        out[lo..].copy_from_slice(&theta[hi..hi + nt]);
        Ok(out)
    }

    /// θ with every pole strictly stable: θ itself when it is, else
    /// [`Rational::reflect_unstable`] with the poles on the boundary (Re p = 0, |p| = 1),
    /// which reflection leaves in place, moved inside by a relative margin √ε:
    /// p ↦ p − √ε·max(|p|, 1) in s, p ↦ p(1 − √ε) in z.
    ///
    /// # Errors
    /// As [`PolesZeros::poles`] and [`Rational::theta_from_polys`].
    pub fn stabilised(&self, theta: &[T]) -> Result<Vec<T>> {
        if self.is_stable(theta)? {
            return Ok(theta.to_vec());
        }
        let poles = self.poles(theta)?;
        let (_, mut b) = self.coefficients(theta);
        let margin = Float::sqrt(T::default_epsilon());
        let mut gain_fix = T::one();
        let moved: Vec<Complex<T>> = poles
            .iter()
            .map(|p| match self.basis {
                PolyBasis::DelayPowers { .. } => {
                    let r = p.norm();
                    if r > T::one() {
                        gain_fix /= r;
                        p.conj().inv()
                    } else if r == T::one() {
                        *p * (T::one() - margin)
                    } else {
                        *p
                    }
                }
                _ if p.re > T::zero() => Complex::new(-p.re, p.im),
                _ if p.re == T::zero() => {
                    Complex::new(-margin * Float::max(p.norm(), T::one()), p.im)
                }
                _ => *p,
            })
            .collect();
        let a = self.basis.from_roots(&moved, self.na);
        for v in b.iter_mut() {
            *v *= gain_fix;
        }
        let mut out = self.theta_from_polys(&a, &b)?;
        let nt = self.n_transient();
        let (lo, hi) = (out.len() - nt, theta.len().saturating_sub(nt));
        out[lo..].copy_from_slice(&theta[hi..hi + nt]);
        Ok(out)
    }

    /// The numerator's coefficients over the whole basis, c = [0…, θ_b] or [0, Zθ_b]
    /// ([`Rational::b_in_basis`]), for [`Rational::ab_at`].
    fn numerator_coefficients(&self, theta: &[T]) -> Vec<T> {
        self.b_in_basis(&theta[self.na..=self.na + self.nb])
    }

    /// A and B from the basis values `phi` at a line and the numerator coefficients `c`
    /// of [`Rational::numerator_coefficients`]: B = Σ cₙφₙ.
    #[inline]
    fn ab_at(&self, theta: &[T], c: &[T], phi: &[Complex<T>]) -> (Complex<T>, Complex<T>) {
        let zero = Complex::new(T::zero(), T::zero());
        let na = self.na;
        let dot = |phi: &[Complex<T>], c: &[T]| {
            phi.iter().zip(c).fold(zero, |s, (p, c)| {
                Complex::new(s.re + p.re * *c, s.im + p.im * *c)
            })
        };
        let a = if self.constant_normalised() {
            phi[0] + dot(&phi[1..=na], &theta[..na])
        } else {
            dot(&phi[..na], &theta[..na]) + phi[na]
        };
        (a, dot(&phi[..c.len()], c))
    }

    fn zero_phi(&self) -> Vec<Complex<T>> {
        vec![Complex::new(T::zero(), T::zero()); self.na.max(self.nb) + 1]
    }

    /// Offset of the free denominator parameters in the basis index (0 for the orthonormal
    /// basis, 1 for the constant-normalised ones).
    fn a_offset(&self) -> usize {
        usize::from(self.constant_normalised())
    }
}

impl<T: Real> ModelStructure<T> for Rational<T> {
    /// [`Rational::is_stable`]; false when the poles cannot be computed.
    fn stable_at(&self, theta: &[T]) -> Option<bool> {
        Some(self.is_stable(theta).unwrap_or(false))
    }

    /// [`Rational::stabilised`].
    fn stabilised(&self, theta: &[T]) -> Option<Result<Vec<T>>> {
        Some(Rational::stabilised(self, theta))
    }

    fn n_params(&self) -> usize {
        self.na + self.nb + 1 + self.n_transient()
    }

    fn has_transient(&self) -> bool {
        self.transient.is_some()
    }

    /// Denominator 1, numerator c_u/c_y, transient 1/c_y (B and T are linear in their
    /// parameters; A is monic).
    fn normalisation_map(&self, output: T, input: T) -> Option<Vec<T>> {
        let mut d = vec![T::one(); self.na];
        d.extend(std::iter::repeat_n(input / output, self.nb + 1));
        d.extend(std::iter::repeat_n(T::one() / output, self.n_transient()));
        Some(d)
    }

    fn response_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        let mut phi = self.zero_phi();
        let c = self.numerator_coefficients(theta);
        let kept = self.kept_zinv(omega);
        let run = self.tabulated(omega, false);
        for (k, (w, o)) in omega.iter().zip(out.iter_mut()).enumerate() {
            let p = self.phi_at(run, k, *w, kept.map(|z| z[k]), &mut phi);
            let (a, b) = self.ab_at(theta, &c, p);
            *o = b * crate::scalar::recip(a);
        }
    }

    fn jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) {
        let mut phi = self.zero_phi();
        let mut psi = vec![Complex::new(T::zero(), T::zero()); self.nb + 1];
        let na = self.na;
        let off = self.a_offset();
        let n = jac.nrows();
        if n == 0 {
            return;
        }
        let c = self.numerator_coefficients(theta);
        let kept = self.kept_zinv(omega);
        let run = self.tabulated(omega, true);
        if let Some(run) = run
            && self.jacobian_from_table(theta, &c, run, g, jac)
        {
            return;
        }
        let mut cols: Vec<&mut [Complex<T>]> = jac.as_mut_slice().chunks_exact_mut(n).collect();
        // the transient coefficients do not enter G
        for col in cols[na + self.nb + 1..].iter_mut() {
            col.fill(Complex::new(T::zero(), T::zero()));
        }
        for (k, (w, g)) in omega.iter().zip(g.iter_mut()).enumerate() {
            let p = self.phi_at(run, k, *w, kept.map(|z| z[k]), &mut phi);
            let (a, b) = self.ab_at(theta, &c, p);
            let inv_a = crate::scalar::recip(a);
            let gk = b * inv_a;
            *g = gk;
            let minus_g_over_a = -gk * inv_a;
            for (col, p) in cols[..na].iter_mut().zip(&p[off..]) {
                col[k] = *p * minus_g_over_a;
            }
            let psi = self.numerator_at(run, k, &mut phi, &mut psi);
            for (col, p) in cols[na..].iter_mut().zip(psi) {
                col[k] = *p * inv_a;
            }
        }
    }

    /// From the basis tables (see [`ModelStructure::stacked_jacobian_into`]): the factors
    /// −G/A·U_k·s_k and U_k·s_k/A line by line, then column by column the values
    /// φ_j·(−G/A·U_k·s_k) and ψ_j·(U_k·s_k/A), one complex product each (within a few
    /// units of rounding of the three passes' (∂G/∂θ_j·U_k)·s_k); false, with nothing
    /// written, for a model with a transient, off a run of the kept grid, or when ψ has no
    /// lines.
    fn stacked_jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        u: &[Complex<T>],
        weight: Option<&[T]>,
        g: &mut [Complex<T>],
        jac: &mut DMatrix<T>,
    ) -> bool {
        let n = omega.len();
        let rows = StackedRows::new(omega, u, weight, g, jac, self.n_params());
        let Some(rows) = rows.filter(|_| self.transient.is_none()) else {
            return false;
        };
        let Some(run) = self.tabulated(omega, true) else {
            return false;
        };
        let Some((psi, at)) = self.numerator_lines(run, n) else {
            return false;
        };
        let mut factors = self.table_factors(theta, &self.numerator_coefficients(theta), run, g);
        // −G/A·U_k·s_k and U_k·s_k/A, once a line
        for (k, f) in factors.iter_mut().enumerate() {
            *f = (rows.scaled(f.0, k), rows.scaled(f.1, k));
        }
        let (na, off) = (self.na, self.a_offset());
        let mut cols = jac.as_mut_slice().chunks_exact_mut(2 * n);
        for (j, col) in cols.by_ref().take(na).enumerate() {
            let lines = col.chunks_exact_mut(2).zip(&factors).zip(run.phi_lines(n));
            for ((out, f), p) in lines {
                StackedRows::write_scaled(out, p[off + j], f.0);
            }
        }
        for (j, col) in cols.enumerate() {
            let lines = col.chunks_exact_mut(2).zip(&factors).zip(psi.clone());
            for ((out, f), p) in lines {
                StackedRows::write_scaled(out, p[at + j], f.1);
            }
        }
        true
    }

    /// T(θ, ω) = Σⱼ tⱼ χⱼ(z)/A(θ, ω), z = e^{iωTs}, for a model with a transient term (see
    /// [`Rational::with_transient`]).
    fn transient_into(
        &self,
        theta: &[T],
        omega: &[T],
        t: &mut [Complex<T>],
        mut jac: Option<&mut DMatrix<Complex<T>>>,
    ) -> bool {
        let Some(ts) = self.transient else {
            return false;
        };
        let nt = self.n_transient();
        let first_t = self.na + self.nb + 1;
        let mut phi = self.zero_phi();
        let mut chi = vec![Complex::new(T::zero(), T::zero()); nt];
        let off = self.a_offset();
        let c = self.numerator_coefficients(theta);
        let kept = self.kept_zinv(omega);
        let run = self.tabulated(omega, false);
        for (k, w) in omega.iter().enumerate() {
            let zinv = kept.map(|z| z[k]);
            let phi = self.phi_at(run, k, *w, zinv, &mut phi);
            let (a, _) = self.ab_at(theta, &c, phi);
            let zinv = self.transient_variable(ts, *w, phi, zinv);
            self.transient_basis(ts, zinv, &mut chi);
            let inv_a = a.inv();
            let num = chi
                .iter()
                .zip(&theta[first_t..])
                .fold(Complex::new(T::zero(), T::zero()), |s, (c, t)| s + *c * *t);
            let tk = num * inv_a;
            t[k] = tk;
            if let Some(jac) = jac.as_deref_mut() {
                let minus_t_over_a = -tk * inv_a;
                for j in 0..self.na {
                    jac[(k, j)] = phi[j + off] * minus_t_over_a;
                }
                for j in self.na..first_t {
                    jac[(k, j)] = Complex::new(T::zero(), T::zero());
                }
                for (j, c) in chi.iter().enumerate() {
                    jac[(k, first_t + j)] = *c * inv_a;
                }
            }
        }
        true
    }

    fn check_data(&self, data: &FrequencyData<T>) -> Result<()> {
        super::check_line_count(self.n_params(), data.len())?;
        if data.mixed_sample_times()
            && (self.transient.is_some() || self.domain() != Domain::Continuous)
        {
            return Err(FdidError::InvalidArgument {
                name: "ts",
                value: "several".into(),
                reason: "the data merge experiments with different sample times: only a \
                         continuous-time model without a sampled transient fits them"
                    .into(),
            });
        }
        if let (Some(ts), PolyBasis::PartialFractions { .. }) = (self.transient, &self.basis) {
            data.check_sampled_grid(ts, "transient")?;
        }
        if let PolyBasis::DelayPowers { ts } = &self.basis {
            data.check_sampled_grid(*ts, "model")?;
        }
        self.grid.keep(self.delay_ts(), data.shared_omega());
        Ok(())
    }
}

impl<T: Real> EquationError<T> for Rational<T> {
    /// See [`Rational::partial_fractions`]: basis poles moved to the poles of θ (unstable
    /// ones reflected); `None` for the polynomial bases.
    fn relocated(&self, theta: &[T]) -> Option<Result<Self>> {
        self.relocate(theta)
    }

    fn normalising_index(&self) -> usize {
        if self.constant_normalised() {
            0
        } else {
            self.na
        }
    }

    /// c = [A coefficients (na + 1, basis order), B coefficients (nb + 1), transient
    /// coefficients], R_k = [φ₀ Y_k … φ_na Y_k, −ψ₀ U_k … −ψ_nb U_k, −χ₁ … −χ_nt]: the
    /// transient T = t/A enters the equation error A Y − B U − t linearly.
    fn regressor_into(&self, data: &FrequencyData<T>, out: &mut DMatrix<Complex<T>>) {
        self.regressor_lines_into(data, 0, out);
    }

    fn regressor_lines_into(
        &self,
        data: &FrequencyData<T>,
        k0: usize,
        out: &mut DMatrix<Complex<T>>,
    ) {
        let mut phi = self.zero_phi();
        let mut psi = vec![Complex::new(T::zero(), T::zero()); self.nb + 1];
        let mut chi = vec![Complex::new(T::zero(), T::zero()); self.n_transient()];
        let na = self.na;
        let lines = k0..k0 + out.nrows();
        let (omega, y, u) = (
            &data.omega()[lines.clone()],
            &data.y()[lines.clone()],
            &data.u()[lines],
        );
        let len = out.nrows();
        if len == 0 {
            return;
        }
        let kept = self.kept_zinv(omega);
        let run = self.tabulated(omega, true);
        if let Some(run) = run
            && self.rows_from_table(run, y, u, out)
        {
            return;
        }
        // the columns of the block, written line by line
        let mut cols: Vec<&mut [Complex<T>]> = out.as_mut_slice().chunks_exact_mut(len).collect();
        for (k, ((w, y), u)) in omega.iter().zip(y).zip(u).enumerate() {
            let zinv = kept.map(|z| z[k]);
            let p = self.phi_at(run, k, *w, zinv, &mut phi);
            let zinv = self
                .transient
                .map(|ts| self.transient_variable(ts, *w, p, zinv));
            for (col, p) in cols[..=na].iter_mut().zip(p) {
                col[k] = *p * *y;
            }
            let psi = self.numerator_at(run, k, &mut phi, &mut psi);
            for (col, p) in cols[na + 1..].iter_mut().zip(psi) {
                col[k] = -(*p * *u);
            }
            if let (Some(ts), Some(zinv)) = (self.transient, zinv) {
                self.transient_basis(ts, zinv, &mut chi);
                for (col, c) in cols[na + self.nb + 2..].iter_mut().zip(&chi) {
                    col[k] = -*c;
                }
            }
        }
    }

    fn denominator_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        let mut phi = self.zero_phi();
        let c = self.numerator_coefficients(theta);
        let kept = self.kept_zinv(omega);
        let run = self.tabulated(omega, false);
        for (k, (w, o)) in omega.iter().zip(out.iter_mut()).enumerate() {
            let p = self.phi_at(run, k, *w, kept.map(|z| z[k]), &mut phi);
            *o = self.ab_at(theta, &c, p).0;
        }
    }

    fn response_and_denominator_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        a: &mut [Complex<T>],
    ) {
        let mut phi = self.zero_phi();
        let c = self.numerator_coefficients(theta);
        let kept = self.kept_zinv(omega);
        let run = self.tabulated(omega, false);
        for (k, ((w, g), a)) in omega.iter().zip(g.iter_mut()).zip(a.iter_mut()).enumerate() {
            let p = self.phi_at(run, k, *w, kept.map(|z| z[k]), &mut phi);
            let (den, num) = self.ab_at(theta, &c, p);
            *g = num * crate::scalar::recip(den);
            *a = den;
        }
    }
}

impl<T: Real> PolesZeros<T> for Rational<T> {
    fn poles(&self, theta: &[T]) -> Result<Vec<Complex<T>>> {
        let (a, _) = self.coefficients(theta);
        roots(&self.basis, &a)
    }

    /// The roots of B, found from B's coefficients scaled by a power of two (the roots do
    /// not depend on B's scale, so a gain near the type's limits does not overflow them).
    fn zeros(&self, theta: &[T]) -> Result<Vec<Complex<T>>> {
        let (_, b) = self.coefficients(theta);
        let c = crate::data::power_of_two_factor(b.iter().copied());
        let b: Vec<T> = b.iter().map(|v| *v * c).collect();
        roots(&self.basis, &self.b_in_basis(&b))
    }

    /// The gain, linear in B: found from B scaled by a power of two c and divided by c.
    fn gain(&self, theta: &[T]) -> T {
        let (a, b) = self.coefficients(theta);
        let c = crate::data::power_of_two_factor(b.iter().copied());
        let b: Vec<T> = b.iter().map(|v| *v * c).collect();
        self.gain_of(&a, &b) / c
    }
}

impl<T: Real> Rational<T> {
    /// The gain of coefficients `a` (denominator) and `b` (numerator, in θ's form).
    fn gain_of(&self, a: &[T], b: &[T]) -> T {
        match &self.basis {
            PolyBasis::DelayPowers { .. } => {
                // the first coefficient the root finder does not treat as zero
                let tol = T::default_epsilon()
                    * T::lit(8.0)
                    * Float::sqrt(b.iter().fold(T::zero(), |s, v| s + *v * *v));
                b.iter()
                    .copied()
                    .find(|v| Float::abs(*v) > tol)
                    .unwrap_or_else(T::zero)
            }
            PolyBasis::PartialFractions { .. } => {
                // D·Π(s − q) is monic; N·Π(s − q) leads with c₀, or with its first Markov
                // parameter when strictly proper
                crate::roots::partial_fraction_leading(&self.basis, &self.b_in_basis(b))
                    .unwrap_or_else(T::zero)
            }
            PolyBasis::Orthonormal { scale, gamma } => {
                // leading coefficient of φ_n is 1/(ω_s^n Π_{j≤n} γ_j); use the degrees that
                // survive trimming in the root finder
                let deg = |c: &[T]| {
                    let norm = Float::sqrt(c.iter().fold(T::zero(), |s, v| s + *v * *v));
                    let tol = norm * T::default_epsilon() * T::lit(8.0);
                    let mut n = c.len();
                    while n > 0 && Float::abs(c[n - 1]) <= tol {
                        n -= 1;
                    }
                    n.saturating_sub(1)
                };
                let (da, db) = (deg(a), deg(b));
                let mut k = b[db] / a[da];
                // ratio of leading coefficients: Π_{j≤db} 1/(ω_s γ_j) / Π_{j≤da} 1/(ω_s γ_j)
                if da > db {
                    for g in &gamma[db..da] {
                        k *= *scale * *g;
                    }
                } else {
                    for g in &gamma[da..db] {
                        k /= *scale * *g;
                    }
                }
                k
            }
        }
    }
}

/// The smallest positive and the largest frequency of `omega`, when some is positive.
pub(crate) fn positive_band<T: Real>(omega: &[T]) -> Option<(T, T)> {
    let lo = omega
        .iter()
        .copied()
        .filter(|w| *w > T::zero())
        .fold(T::infinity(), Float::min);
    let hi = omega.iter().copied().fold(T::zero(), Float::max);
    (hi > T::zero()).then_some((lo, hi))
}

/// Starting basis poles of order `na` over [lo, hi] (rad/s): ⌊na/2⌋ poles −ζωₖ + iωₖ (the
/// upper halves of the pairs) with ωₖ spread log-uniformly from lo to hi (√(lo·hi) for a
/// single pair), plus the real pole −hi when `na` is odd.
pub(crate) fn log_spread_poles<T: Real>(na: usize, lo: T, hi: T, zeta: T) -> Vec<Complex<T>> {
    let pairs = na / 2;
    let (llo, lhi) = (Float::ln(lo), Float::ln(hi));
    let mut poles: Vec<Complex<T>> = (0..pairs)
        .map(|k| {
            let f = if pairs == 1 {
                T::lit(0.5)
            } else {
                T::from_usize_lossy(k) / T::from_usize_lossy(pairs - 1)
            };
            let w = Float::exp(llo + (lhi - llo) * f);
            Complex::new(-w * zeta, w)
        })
        .collect();
    if na % 2 == 1 {
        poles.push(Complex::new(-hi, T::zero()));
    }
    poles
}

/// The fields of a [`Rational`] as stored, before [`Rational::try_from`] checks them.
#[cfg(feature = "serde")]
#[derive(serde::Deserialize)]
pub struct Stored<T: Real> {
    na: usize,
    nb: usize,
    basis: PolyBasis<T>,
    numerator_map: Option<DMatrix<T>>,
    #[serde(default)]
    numerator_reflectors: Option<crate::linalg::householder::Complement<T>>,
    transient: Option<T>,
}

#[cfg(feature = "serde")]
impl<T: Real> TryFrom<Stored<T>> for Rational<T> {
    type Error = FdidError;

    /// Rebuilds the model from the stored orders, basis and transient by the constructors
    /// ([`Rational::discrete`], [`Rational::partial_fractions`], the orthonormal basis'
    /// recurrence checked for finite positive coefficients), and requires a stored numerator
    /// map or reflectors to equal the rebuilt ones (relative 10⁻⁹).
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] naming the field that is inconsistent.
    fn try_from(stored: Stored<T>) -> Result<Self> {
        let bad = |name: &'static str, value: String, reason: &str| FdidError::InvalidArgument {
            name,
            value,
            reason: reason.into(),
        };
        let Stored {
            na,
            nb,
            basis,
            numerator_map,
            numerator_reflectors,
            transient,
        } = stored;
        let rebuilt = match basis {
            PolyBasis::DelayPowers { ts } => {
                let model = Self::discrete(na, nb, ts)?;
                match transient {
                    None => model,
                    Some(t) if t == ts => model.with_transient()?,
                    Some(t) => {
                        return Err(bad(
                            "transient",
                            format!("{t}"),
                            "the transient's sample time must equal the model's",
                        ));
                    }
                }
            }
            PolyBasis::Orthonormal { scale, gamma } => {
                super::check_degrees(na, nb)?;
                if !(scale > T::zero() && Float::is_finite(scale)) {
                    return Err(bad(
                        "basis scale",
                        format!("{scale}"),
                        "must be positive and finite",
                    ));
                }
                if let Some((i, g)) = gamma
                    .iter()
                    .enumerate()
                    .find(|(_, g)| !(**g > T::zero() && Float::is_finite(**g)))
                {
                    return Err(bad(
                        "basis gamma",
                        format!("{g} at entry {i}"),
                        "recurrence coefficients must be positive and finite",
                    ));
                }
                if gamma.len() < na.max(nb) {
                    return Err(bad(
                        "basis gamma",
                        format!("{} coefficients", gamma.len()),
                        &format!("the degrees na = {na}, nb = {nb} need {}", na.max(nb)),
                    ));
                }
                if transient.is_some() {
                    return Err(bad(
                        "transient",
                        "present".into(),
                        "a polynomial continuous-time model has no transient term",
                    ));
                }
                Self {
                    na,
                    nb,
                    basis: PolyBasis::Orthonormal { scale, gamma },
                    numerator_map: None,
                    numerator_reflectors: None,
                    transient: None,
                    grid: KeptGrid::default(),
                    table: KeptBasis::default(),
                }
            }
            PolyBasis::PartialFractions { poles } => {
                let model = Self::partial_fractions(poles, nb)?;
                if model.na != na {
                    return Err(bad(
                        "na",
                        na.to_string(),
                        &format!("the basis poles give na = {}", model.na),
                    ));
                }
                match transient {
                    None => model,
                    Some(ts) => model.with_sampled_transient(ts)?,
                }
            }
        };
        let close = |a: &[T], b: &[T]| {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|(x, y)| Float::abs(*x - *y) <= T::lit(1e-9) * (T::one() + Float::abs(*y)))
        };
        if let Some(z) = &numerator_map {
            let same = rebuilt
                .numerator_map
                .as_ref()
                .is_some_and(|r| r.shape() == z.shape() && close(z.as_slice(), r.as_slice()));
            if !same {
                return Err(bad(
                    "numerator_map",
                    format!("{}x{}", z.nrows(), z.ncols()),
                    "not the map of the basis poles and degrees",
                ));
            }
        }
        if let Some(c) = &numerator_reflectors
            && rebuilt
                .numerator_reflectors
                .as_ref()
                .is_none_or(|r| !r.same_as(c, T::lit(1e-9)))
        {
            return Err(bad(
                "numerator_reflectors",
                format!("dimension {}, {} reflectors", c.dim(), c.rank()),
                "not the reflectors of the basis poles and degrees",
            ));
        }
        Ok(rebuilt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pole of `poles` nearest to `p`.
    fn nearest(poles: &[Complex<f64>], p: Complex<f64>) -> Complex<f64> {
        *poles
            .iter()
            .min_by(|a, b| (**a - p).norm().total_cmp(&(**b - p).norm()))
            .unwrap()
    }

    #[test]
    fn pole_sensitivities_match_differences_of_the_poles_in_every_basis() {
        let omega: Vec<f64> = (1..=50).map(|k| 0.2 * k as f64).collect();
        let cases = [
            (
                Rational::partial_fractions_on(4, 3, &omega).unwrap(),
                vec![0.3, -0.2, 0.1, 0.05],
            ),
            (
                Rational::polynomial(3, 2, &omega).unwrap(),
                vec![0.8, 1.3, 0.6],
            ),
            (
                Rational::discrete(3, 2, 0.1).unwrap(),
                vec![-1.2, 0.61, -0.09],
            ),
            // a relocated basis: its poles within 10⁻⁷ of the roots of A
            (
                Rational::partial_fractions(
                    vec![Complex::new(-0.3, 2.0), Complex::new(-0.05, 7.0)],
                    3,
                )
                .unwrap(),
                vec![1e-7, -2e-7, 1e-7, 3e-7],
            ),
        ];
        for (model, a) in cases {
            let mut theta = a.clone();
            theta.extend(std::iter::repeat_n(1.0, model.nb() + 1));
            let sens = model.pole_sensitivities(&theta).expect("sensitivities");
            assert_eq!(sens.len(), model.na());
            for (i, _) in a.iter().enumerate() {
                let h = 1e-6;
                let (mut up, mut down) = (theta.clone(), theta.clone());
                up[i] += h;
                down[i] -= h;
                let (pu, pd) = (model.poles(&up).unwrap(), model.poles(&down).unwrap());
                for (p, d) in &sens {
                    let fd = (nearest(&pu, *p) - nearest(&pd, *p)) / (2.0 * h);
                    assert!(
                        (fd - d[i]).norm() <= 1e-5 * (1.0 + fd.norm()),
                        "{:?} pole {p}: ∂p/∂θ{i} {} against the difference {fd}",
                        model.basis(),
                        d[i]
                    );
                }
            }
        }
    }
}
