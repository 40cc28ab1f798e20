//! A model's frequency grid kept at its first data check, with z⁻¹ = e^{−iωTs} on it for a
//! model that samples, so that repeated evaluations on the grid read z⁻¹ instead of taking
//! a sine and a cosine per line, and find where their lines lie on the grid (for
//! [`super::kept_basis`]): a run of consecutive lines, or every m-th line (the fewer lines
//! the linear stages of a long record start from).

use crate::scalar::{Complex, Real};
use std::sync::{Arc, OnceLock};

/// One frequency grid with, for a sample time Ts, z⁻¹ = e^{−iωTs} on its lines; the grid
/// itself is the key: lines of an evaluation read it only when their frequencies are, bit
/// for bit, a run of consecutive lines of the grid.
///
/// The grid is the data's own buffer ([`FrequencyData::shared_omega`]), held here: lines
/// that lie in that memory are its lines, known without comparing their values (a
/// buffer kept alive and shared is not written, and no other live buffer overlaps it),
/// so that an evaluation on a long record does not read a second copy of its
/// frequencies.
///
/// [`FrequencyData::shared_omega`]: crate::data::FrequencyData
#[derive(Debug)]
struct DelayGrid<T: Real> {
    /// Ts of `zinv`; `None` when no z⁻¹ is kept (`zinv` empty).
    ts: Option<T>,
    omega: Arc<[T]>,
    zinv: Vec<Complex<T>>,
    /// The grid rises strictly, so a run's first line is found by bisection.
    rising: bool,
}

impl<T: Real> DelayGrid<T> {
    fn new(ts: Option<T>, omega: &Arc<[T]>) -> Self {
        Self {
            ts,
            omega: Arc::clone(omega),
            zinv: ts.map_or_else(Vec::new, |ts| {
                omega
                    .iter()
                    .map(|w| crate::basis::delay_variable(*w, ts))
                    .collect()
            }),
            rising: omega.windows(2).all(|w| w[0] < w[1]),
        }
    }

    /// The grid lines the lines `omega` are, when they are a (non-empty) run of this grid:
    /// consecutive lines, or (on a rising grid) every `step`-th line.
    fn lines(&self, omega: &[T]) -> Option<GridRun> {
        let first = omega.first()?;
        if let Some(start) = self.offset_of(omega) {
            return Some(GridRun { start, step: 1 });
        }
        let (start, step) = if self.rising {
            let start = self.omega.partition_point(|w| w < first);
            // the second line's place gives the step (1 for a single line)
            let step = omega.get(1).map_or(Some(1), |second| {
                let after = self.omega.get(start + 1..)?;
                Some(1 + after.partition_point(|w| w < second))
            })?;
            (start, step)
        } else {
            (0, 1)
        };
        let last = (omega.len() - 1).checked_mul(step)?.checked_add(start)?;
        let kept = self.omega.get(start..=last)?;
        // without a branch a line (a mismatch is rare, and the loop then vectorises)
        let matches = |all: bool, (a, b): (&T, &T)| all & same(*a, *b);
        let all = if step == 1 {
            kept.iter().zip(omega).fold(true, matches)
        } else {
            kept.iter().step_by(step).zip(omega).fold(true, matches)
        };
        all.then_some(GridRun { start, step })
    }

    /// The grid line where `omega` starts when `omega` lies in the grid's own memory (then
    /// a run of consecutive lines of it, whatever its values).
    fn offset_of(&self, omega: &[T]) -> Option<usize> {
        let size = size_of::<T>();
        let base = self.omega.as_ptr() as usize;
        let at = (omega.as_ptr() as usize).checked_sub(base)?;
        let start = at / size;
        (at % size == 0 && start + omega.len() <= self.omega.len()).then_some(start)
    }

    /// z⁻¹ on the lines `omega` with sample time `ts`, when they are a run of consecutive
    /// lines of this grid.
    fn run(&self, ts: T, omega: &[T]) -> Option<&[Complex<T>]> {
        if !self.ts.is_some_and(|kept| same(ts, kept)) {
            return None;
        }
        let run = self.lines(omega).filter(|r| r.step == 1)?;
        Some(&self.zinv[run.start..run.start + omega.len()])
    }
}

/// Where an evaluation's lines lie on the kept grid: grid lines `start`, `start + step`,
/// `start + 2·step`, … (`step` 1 for consecutive lines).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct GridRun {
    pub(crate) start: usize,
    pub(crate) step: usize,
}

impl GridRun {
    /// The grid lines a table for this run holds, on a grid of `n` lines: every `step`-th
    /// line from the first of the run's residue (start mod step), as (first, count) — the
    /// whole grid for consecutive lines.
    pub(crate) fn lattice(&self, n: usize) -> (usize, usize) {
        let first = self.start % self.step;
        (first, (n - first).div_ceil(self.step))
    }

    /// The table line of the run's first line, in the table of [`GridRun::lattice`].
    pub(crate) fn table_start(&self) -> usize {
        self.start / self.step
    }
}

/// The same value bit for bit (the sign of a zero included; NaN is never the same).
#[inline]
fn same<T: Real>(a: T, b: T) -> bool {
    (a == b) & (a.is_sign_negative() == b.is_sign_negative())
}

/// The [`DelayGrid`] a model keeps, set once by its first data check (see
/// [`crate::ModelStructure::check_data`]) and shared by its clones and relocations. A model
/// is equal to, and stores as, the same model without it.
#[derive(Clone, Default)]
pub(crate) struct KeptGrid<T: Real>(OnceLock<Arc<DelayGrid<T>>>);

impl<T: Real> std::fmt::Debug for KeptGrid<T> {
    /// The number of lines kept, not their values.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let lines = self.0.get().map_or(0, |g| g.omega.len());
        write!(f, "KeptGrid({lines} lines)")
    }
}

impl<T: Real> KeptGrid<T> {
    /// Keeps the grid `omega` (the buffer itself, shared), with z⁻¹ for the sample time `ts`
    /// when there is one, unless a grid is kept already.
    pub(crate) fn keep(&self, ts: Option<T>, omega: &Arc<[T]>) {
        self.0.get_or_init(|| Arc::new(DelayGrid::new(ts, omega)));
    }

    /// The kept grid and where the lines `omega` lie on it, when they are a run of it
    /// (consecutive lines or every m-th, see [`GridRun`]).
    pub(crate) fn lines(&self, omega: &[T]) -> Option<(&[T], GridRun)> {
        let grid = self.0.get()?;
        grid.lines(omega).map(|run| (&grid.omega[..], run))
    }

    /// z⁻¹ with sample time `ts` on the lines `omega` from the kept grid, when they are a
    /// run of it; `None` otherwise (the caller computes them).
    pub(crate) fn run(&self, ts: T, omega: &[T]) -> Option<&[Complex<T>]> {
        self.0.get()?.run(ts, omega)
    }
}

impl<T: Real> PartialEq for KeptGrid<T> {
    /// Always: the kept values are those any evaluation computes.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid buffer of its own (not the memory of the lines the tests look up).
    fn shared(omega: &[f64]) -> Arc<[f64]> {
        Arc::from(omega)
    }

    #[test]
    fn lines_in_the_grids_own_memory_are_its_lines_without_their_values() {
        // NaN is never the same value: lines with it are found only by where they lie
        let grid = shared(&[0.5, f64::NAN, 2.0, 3.0]);
        let kept = KeptGrid::default();
        kept.keep(None, &grid);
        let run = |start| Some(GridRun { start, step: 1 });
        assert_eq!(kept.lines(&grid[1..3]).map(|(_, l)| l), run(1));
        assert_eq!(kept.lines(&grid[3..]).map(|(_, l)| l), run(3));
        assert_eq!(
            kept.lines(&grid).map(|(g, l)| (g.len(), l)),
            Some((4, run(0).unwrap()))
        );
        let copy = grid.to_vec();
        assert!(kept.lines(&copy[1..3]).is_none());
        assert_eq!(kept.lines(&copy[..1]).map(|(_, l)| l), run(0));
    }

    #[test]
    fn a_run_of_the_grid_reads_the_kept_values() {
        let omega: Vec<f64> = (0..50).map(|k| 0.01 + 0.06 * k as f64).collect();
        let kept = KeptGrid::default();
        assert!(kept.run(0.1, &omega).is_none());
        kept.keep(Some(0.1), &shared(&omega));
        let direct: Vec<_> = omega
            .iter()
            .map(|w| crate::basis::delay_variable(*w, 0.1))
            .collect();
        assert_eq!(kept.run(0.1, &omega), Some(&direct[..]));
        assert_eq!(kept.run(0.1, &omega[7..19]), Some(&direct[7..19]));
        assert_eq!(kept.run(0.1, &omega[49..]), Some(&direct[49..]));
        // another sample time, lines off the grid, a gap, a line past its end, a changed
        // zero sign, NaN
        assert!(kept.run(0.2, &omega[3..9]).is_none());
        assert!(kept.run(0.1, &[0.5, 0.6]).is_none());
        assert!(kept.run(0.1, &[omega[2], omega[4]]).is_none());
        assert!(kept.run(0.1, &[omega[49], 3.5]).is_none());
        assert!(kept.run(0.1, &[f64::NAN]).is_none());
        let zero = KeptGrid::default();
        zero.keep(Some(0.1), &shared(&[0.0, 1.0]));
        assert!(zero.run(0.1, &[-0.0, 1.0]).is_none());
        assert!(zero.run(0.1, &[0.0, 1.0]).is_some());
        // a second grid does not replace the first
        kept.keep(Some(0.1), &shared(&[1.0, 2.0]));
        assert!(kept.run(0.1, &[1.0, 2.0]).is_none());
        assert!(kept.run(0.1, &omega).is_some());
        // a grid without a sample time finds runs but keeps no z⁻¹
        let plain = KeptGrid::default();
        plain.keep(None, &shared(&omega));
        assert!(plain.run(0.1, &omega).is_none());
        let run = |start, step| Some(GridRun { start, step });
        assert_eq!(plain.lines(&omega[7..19]).map(|(_, l)| l), run(7, 1));
        assert_eq!(
            kept.lines(&omega[3..5]).map(|(g, l)| (g.len(), l)),
            Some((50, GridRun { start: 3, step: 1 }))
        );
        // every m-th line: found with its step, and its table's lattice
        let every_third: Vec<f64> = omega[4..].iter().step_by(3).copied().collect();
        assert_eq!(plain.lines(&every_third).map(|(_, l)| l), run(4, 3));
        assert_eq!(plain.lines(&every_third[5..9]).map(|(_, l)| l), run(19, 3));
        assert_eq!(
            plain.lines(&[omega[2], omega[4]]).map(|(_, l)| l),
            run(2, 2)
        );
        assert_eq!(plain.lines(&[omega[49]]).map(|(_, l)| l), run(49, 1));
        assert_eq!(GridRun { start: 19, step: 3 }.lattice(50), (1, 17));
        assert_eq!(GridRun { start: 19, step: 3 }.table_start(), 6);
        assert_eq!(GridRun { start: 7, step: 1 }.lattice(50), (0, 50));
        // a run whose step changes, falls back, or leaves the grid; z⁻¹ only for consecutive lines
        assert!(plain.lines(&[omega[2], omega[4], omega[7]]).is_none());
        assert!(plain.lines(&[omega[4], omega[2]]).is_none());
        assert!(plain.lines(&[omega[4], omega[4]]).is_none());
        assert!(plain.lines(&[omega[40], omega[45], 3.5]).is_none());
        assert!(kept.run(0.1, &[omega[2], omega[4]]).is_none());
        // an empty run reads nothing
        assert!(kept.run(0.1, &[]).is_none());
    }

    /// A model's evaluations give the same values bit for bit before its data check
    /// (every line computes z⁻¹) and after it (runs of the grid read the kept values).
    #[test]
    fn a_checked_model_evaluates_as_an_unchecked_one() {
        use crate::data::FrequencyData;
        use crate::model::{Domain, EquationError, ModelStructure, Rational};
        use nalgebra::DMatrix;
        let ts = 0.1;
        let omega: Vec<f64> = (1..=40).map(|k| 0.7 * k as f64).collect();
        let one = vec![Complex::new(1.0, 0.5); omega.len()];
        let data = FrequencyData::new(omega.clone(), one.clone(), one, Some(ts)).unwrap();
        let pf = Rational::continuous(2, 2, &omega)
            .and_then(|m| m.with_sampled_transient(ts))
            .unwrap();
        let dt = Rational::discrete(3, 2, ts)
            .and_then(|m| m.with_transient())
            .unwrap();
        // basis tables ([`super::super::kept_basis`]): partial fractions with the numerator
        // reflected (relative degree 3) and without, the orthonormal polynomials
        let reflected = Rational::continuous(4, 1, &omega).unwrap();
        let plain = Rational::continuous(3, 2, &omega).unwrap();
        let polynomial = Rational::polynomial(2, 3, &omega).unwrap();
        for model in [pf, dt, reflected, plain, polynomial] {
            let theta: Vec<f64> = (0..model.n_params())
                .map(|j| 0.3 / (1.0 + j as f64) - 0.1)
                .collect();
            let evaluate = |m: &Rational<f64>, w: &[f64]| {
                let zero = Complex::new(0.0, 0.0);
                let (n, p) = (w.len(), m.n_params());
                let (mut g, mut jac) = (vec![zero; n], DMatrix::from_element(n, p, zero));
                m.jacobian_into(&theta, w, &mut g, &mut jac);
                let (mut t, mut tjac) = (vec![zero; n], DMatrix::from_element(n, p, zero));
                let with_t = m.transient_into(&theta, w, &mut t, Some(&mut tjac));
                assert_eq!(with_t, m.has_transient());
                let mut r = vec![zero; n];
                m.response_into(&theta, w, &mut r);
                (g, jac, t, tjac, r)
            };
            let unchecked = model.clone();
            model.check_data(&data).unwrap();
            let sampled = model.transient_ts().is_some() || model.domain() != Domain::Continuous;
            assert_eq!(model.kept_zinv(&omega[3..17]).is_some(), sampled);
            // every third line first (the table of that lattice), then a run of the grid
            // (the table of the whole grid), lines of another lattice and off the grid
            let every_third: Vec<f64> = omega[2..].iter().step_by(3).copied().collect();
            let every_other: Vec<f64> = omega.iter().step_by(2).copied().collect();
            for w in [
                &every_third[..],
                &every_third[4..9],
                &omega[3..17],
                &omega[..],
                &every_other[..],
                &[0.5, 1.4, 2.1],
            ] {
                assert_eq!(evaluate(&model, w), evaluate(&unchecked, w));
            }
            assert!(model.tabulated(&every_third[1..], true).is_some());
            assert!(model.tabulated(&every_other, true).is_none());
            let fewer = |m: &Rational<f64>| {
                let pick = |v: &[Complex<f64>]| v[2..].iter().step_by(3).copied().collect();
                let y: Vec<Complex<f64>> = pick(data.y());
                let u: Vec<Complex<f64>> = pick(data.u());
                let fewer = FrequencyData::new(every_third.clone(), u, y, Some(ts)).unwrap();
                let mut rows = DMatrix::from_element(6, m.n_coefficients(), Complex::new(0.0, 0.0));
                m.regressor_lines_into(&fewer, 5, &mut rows);
                rows
            };
            assert_eq!(fewer(&model), fewer(&unchecked));
            assert!(model.tabulated(&omega[5..9], true).is_some());
            assert!(unchecked.tabulated(&omega, true).is_none());
            assert!(model.tabulated(&[0.5, 1.4], true).is_none());
            // a clone keeps the grid, not the table, and builds its own
            assert_eq!(
                evaluate(&model.clone(), &omega),
                evaluate(&unchecked, &omega)
            );
            let mut rows =
                DMatrix::from_element(10, model.n_coefficients(), Complex::new(0.0, 0.0));
            let mut rows0 = rows.clone();
            model.regressor_lines_into(&data, 20, &mut rows);
            unchecked.regressor_lines_into(&data, 20, &mut rows0);
            assert_eq!(rows, rows0);
            let (mut a, mut a0) = (vec![Complex::new(0.0, 0.0); 40], vec![]);
            a0.resize(40, a[0]);
            model.denominator_into(&theta, &omega, &mut a);
            unchecked.denominator_into(&theta, &omega, &mut a0);
            assert_eq!(a, a0);
            let (mut g, mut g0) = (a.clone(), a.clone());
            model.response_and_denominator_into(&theta, &omega, &mut g, &mut a);
            unchecked.response_and_denominator_into(&theta, &omega, &mut g0, &mut a0);
            assert_eq!((g, a), (g0, a0));
        }
    }

    /// The 40-line grid, input, weights and data of the one-pass row tests.
    struct RowCase {
        omega: Vec<f64>,
        u: Vec<Complex<f64>>,
        weight: Vec<f64>,
        data: crate::data::FrequencyData<f64>,
    }

    const ROW_TS: f64 = 0.1;

    fn row_case() -> RowCase {
        let omega: Vec<f64> = (1..=40).map(|k| 0.7 * k as f64).collect();
        let u: Vec<Complex<f64>> = (0..40)
            .map(|k| Complex::new(1.0 + 0.1 * k as f64, 0.5 - 0.03 * k as f64))
            .collect();
        let weight: Vec<f64> = (0..40).map(|k| 0.5 + 0.07 * k as f64).collect();
        let data =
            crate::data::FrequencyData::new(omega.clone(), u.clone(), u.clone(), Some(ROW_TS))
                .unwrap();
        RowCase {
            omega,
            u,
            weight,
            data,
        }
    }

    /// How a model's one-pass rows must agree with its `jacobian_into` values.
    #[derive(Clone, Copy)]
    enum Agree {
        /// Bit for bit: each value rounded as (∂G/∂θ_j·U_k)·s_k.
        Bits,
        /// Each part within `ulps`·ε·|∂G/∂θ_j|·|U_k|·|s_k| (the products grouped otherwise).
        Ulps(f64),
    }

    /// Asserts that `model`'s one-pass rows on `omega` agree with its `jacobian_into`
    /// values times `u`, stacked and scaled by −w (or −1), as `agree` says, with and
    /// without the weights, and that a `jac` of the wrong width is refused.
    fn assert_rows_match<M: crate::model::ModelStructure<f64>>(
        model: &M,
        theta: &[f64],
        omega: &[f64],
        u: &[Complex<f64>],
        weight: &[f64],
        agree: Agree,
    ) {
        use nalgebra::DMatrix;
        let (n, p, zero) = (omega.len(), model.n_params(), Complex::new(0.0, 0.0));
        let (mut g0, mut dg) = (vec![zero; n], DMatrix::from_element(n, p, zero));
        model.jacobian_into(theta, omega, &mut g0, &mut dg);
        for weights in [None, Some(weight)] {
            let (mut g, mut jac) = (vec![zero; n], DMatrix::from_element(2 * n, p, 7.0));
            assert!(model.stacked_jacobian_into(theta, omega, u, weights, &mut g, &mut jac));
            assert_eq!(g, g0);
            for j in 0..p {
                for k in 0..n {
                    let d = dg[(k, j)] * u[k];
                    let s = weights.map_or(-1.0, |w| -w[k]);
                    let (re, im) = (jac[(2 * k, j)], jac[(2 * k + 1, j)]);
                    match agree {
                        Agree::Bits => {
                            assert_eq!(re.to_bits(), (d.re * s).to_bits());
                            assert_eq!(im.to_bits(), (d.im * s).to_bits());
                        }
                        Agree::Ulps(ulps) => {
                            let tol = ulps * f64::EPSILON * d.norm() * s.abs();
                            let err = (re - d.re * s).abs().max((im - d.im * s).abs());
                            assert!(err <= tol, "line {k}, θ_{j}: off by {err:e} > {tol:e}");
                        }
                    }
                }
            }
        }
        let (mut g, mut wrong) = (vec![zero; n], DMatrix::zeros(2 * n, p + 1));
        assert!(!model.stacked_jacobian_into(theta, omega, u, None, &mut g, &mut wrong));
    }

    /// Refuses the one-pass rows on `omega`.
    fn assert_rows_refused<M: crate::model::ModelStructure<f64>>(
        model: &M,
        theta: &[f64],
        omega: &[f64],
        u: &[Complex<f64>],
    ) {
        let (n, p) = (omega.len(), model.n_params());
        let mut g = vec![Complex::new(0.0, 0.0); n];
        let mut jac = nalgebra::DMatrix::zeros(2 * n, p);
        assert!(!model.stacked_jacobian_into(theta, omega, u, None, &mut g, &mut jac));
    }

    /// Refuses the one-pass rows of a model with a transient term on the whole case.
    fn assert_transient_refused<M: crate::model::ModelStructure<f64>>(model: &M, c: &RowCase) {
        let theta = vec![0.01; model.n_params()];
        assert_rows_refused(model, &theta, &c.omega, &c.u);
    }

    /// θ of `p` values for the row tests.
    fn row_theta(p: usize) -> Vec<f64> {
        (0..p).map(|j| 0.3 / (1.0 + j as f64) - 0.1).collect()
    }

    /// The one-pass rows of the output-error Jacobian equal ∂G/∂θ·U from `jacobian_into`,
    /// stacked and scaled by −w (or −1), to a few units of rounding (each value one
    /// complex product of the basis value and the line's scaled factor), on runs of the
    /// kept grid; elsewhere, and for a model with a transient term, the pass is refused.
    #[test]
    fn stacked_jacobian_rows_equal_the_stacked_jacobian() {
        use crate::model::{ModelStructure, Rational};
        let c = row_case();
        let models = [
            Rational::continuous(4, 1, &c.omega).unwrap(),
            Rational::continuous(3, 2, &c.omega).unwrap(),
            Rational::polynomial(2, 3, &c.omega).unwrap(),
            Rational::discrete(3, 2, ROW_TS).unwrap(),
        ];
        let lines = 5..29;
        let (w, u) = (&c.omega[lines.clone()], &c.u[lines.clone()]);
        for model in models {
            let theta = row_theta(model.n_params());
            // no table before the data check
            assert_rows_refused(&model, &theta, w, u);
            model.check_data(&c.data).unwrap();
            let weight = &c.weight[lines.clone()];
            assert_rows_match(&model, &theta, w, u, weight, Agree::Ulps(8.0));
            // not a run of the grid
            assert_rows_refused(&model, &theta, &[0.5, 1.4], &c.u[..2]);
        }
        let transient = Rational::discrete(3, 2, ROW_TS)
            .and_then(|m| m.with_transient())
            .unwrap();
        transient.check_data(&c.data).unwrap();
        assert_transient_refused(&transient, &c);
    }

    /// The delayed model's one-pass rows equal its `jacobian_into` values times U, stacked
    /// and scaled, bit for bit, with and without the inner model's tables; an inner model
    /// with a transient term refuses the pass.
    #[test]
    fn delayed_stacked_jacobian_rows_equal_the_stacked_jacobian() {
        use crate::model::{Delayed, ModelStructure, Rational};
        let c = row_case();
        let checked = Rational::continuous(3, 2, &c.omega).unwrap();
        checked.check_data(&c.data).unwrap();
        let models = [
            Delayed::new(checked),
            Delayed::new(Rational::continuous(4, 1, &c.omega).unwrap()),
            Delayed::new(Rational::discrete(3, 2, ROW_TS).unwrap()),
        ];
        for model in models {
            let p = model.n_params();
            let mut theta = row_theta(p);
            theta[p - 1] = 0.37;
            assert_rows_match(&model, &theta, &c.omega, &c.u, &c.weight, Agree::Bits);
        }
        let transient = Delayed::new(
            Rational::discrete(3, 2, ROW_TS)
                .and_then(|m| m.with_transient())
                .unwrap(),
        );
        assert_transient_refused(&transient, &c);
    }

    #[test]
    fn a_grid_that_does_not_rise_is_matched_from_its_start() {
        let omega = [3.0, 1.0, 2.0, 1.0];
        let kept = KeptGrid::default();
        kept.keep(Some(0.5f64), &shared(&omega));
        assert!(kept.run(0.5, &omega).is_some());
        assert!(kept.run(0.5, &omega[..2]).is_some());
        assert!(kept.run(0.5, &omega[1..]).is_none());
    }
}
