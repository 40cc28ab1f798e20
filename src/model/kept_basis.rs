//! A model's basis values kept on its frequency grid (the grid of
//! [`super::kept_grid::KeptGrid`]): φ₀(ω) … φ_d(ω) and the numerator basis ψ(ω) = φ(ω)Z
//! of every grid line, computed once and read by each later evaluation on a run of the
//! grid, in place of the recurrence, the powers of z⁻¹ or the partial fractions
//! 1/(s − qⱼ), and of the Householder reflections, per line. The values do not depend on
//! θ, so the Levy rows and the output-error cost of one relocation, and every residual and
//! Jacobian of the ML iterations, share one table. A model keeps a table of the whole grid
//! for runs of consecutive lines, and one of every m-th line for the runs of one such
//! lattice (the fewer lines of [`crate::estimate::Pipeline`]'s linear stages), each built
//! by the first run that reads it.

use super::kept_grid::GridRun;
use crate::scalar::{Complex, Real};
use std::sync::OnceLock;

/// The most basis values a table (φ or ψ, all lines) holds: 2²¹, 32 MiB in `f64`; a larger
/// grid or order evaluates line by line as without a table.
pub(crate) const MAX_VALUES: usize = 1 << 21;

/// Values of `width` a line (φ or ψ) on every line of a grid, line after line.
#[derive(Debug)]
pub(crate) struct BasisTable<T: Real> {
    width: usize,
    values: Vec<Complex<T>>,
}

impl<T: Real> Drop for BasisTable<T> {
    /// Gives the values' buffer back for the next table ([`crate::recycle`]).
    fn drop(&mut self) {
        crate::recycle::keep(std::mem::take(&mut self.values));
    }
}

impl<T: Real> BasisTable<T> {
    /// The table of `lines` lines of `width` values, line k written by `fill(k, values)`;
    /// `None` when it would hold more than [`MAX_VALUES`] values or none a line.
    pub(crate) fn build(
        lines: usize,
        width: usize,
        mut fill: impl FnMut(usize, &mut [Complex<T>]),
    ) -> Option<Self> {
        if width == 0 || lines.checked_mul(width)? > MAX_VALUES {
            return None;
        }
        let mut values = crate::recycle::filled(lines * width, Complex::new(T::zero(), T::zero()));
        for (k, line) in values.chunks_exact_mut(width).enumerate() {
            fill(k, line);
        }
        Some(Self { width, values })
    }

    /// The values of lines `start` … `start + lines − 1`, one slice each.
    #[inline]
    fn lines(&self, start: usize, lines: usize) -> std::slice::ChunksExact<'_, Complex<T>> {
        self.values[start * self.width..(start + lines) * self.width].chunks_exact(self.width)
    }

    /// The number of lines.
    pub(crate) fn lines_count(&self) -> usize {
        self.values.len() / self.width
    }

    /// The values of line `k`.
    #[inline]
    pub(crate) fn line(&self, k: usize) -> &[Complex<T>] {
        &self.values[k * self.width..(k + 1) * self.width]
    }
}

/// The lines of a model's tables from `start` on: line k of an evaluation is line
/// `start + k` of the grid.
#[derive(Clone, Copy)]
pub(crate) struct TableRun<'a, T: Real> {
    phi: &'a BasisTable<T>,
    psi: Option<&'a BasisTable<T>>,
    start: usize,
}

impl<'a, T: Real> TableRun<'a, T> {
    /// φ of the evaluation's line `k`.
    #[inline]
    pub(crate) fn phi(&self, k: usize) -> &'a [Complex<T>] {
        self.phi.line(self.start + k)
    }

    /// φ of the evaluation's lines 0, 1, … `lines` − 1, one slice each.
    #[inline]
    pub(crate) fn phi_lines(&self, lines: usize) -> std::slice::ChunksExact<'a, Complex<T>> {
        self.phi.lines(self.start, lines)
    }

    /// ψ of the evaluation's lines 0, 1, … `lines` − 1, when the run has a ψ table.
    #[inline]
    pub(crate) fn psi_lines(
        &self,
        lines: usize,
    ) -> Option<std::slice::ChunksExact<'a, Complex<T>>> {
        self.psi.map(|t| t.lines(self.start, lines))
    }

    /// ψ of the evaluation's line `k`, when the run has a ψ table.
    #[inline]
    pub(crate) fn psi(&self, k: usize) -> Option<&'a [Complex<T>]> {
        self.psi.map(|t| t.line(self.start + k))
    }
}

/// φ, built by the first evaluation that reads it, and ψ, built from φ by the first
/// evaluation that needs ψ (`None` inside when the model keeps none: ψ a slice of φ, or a
/// table above [`MAX_VALUES`]).
#[derive(Default)]
struct Tables<T: Real> {
    phi: OnceLock<Option<BasisTable<T>>>,
    psi: OnceLock<Option<BasisTable<T>>>,
}

impl<T: Real> Tables<T> {
    fn values(&self) -> usize {
        let count = |t: &OnceLock<Option<BasisTable<T>>>| {
            t.get()
                .and_then(Option::as_ref)
                .map_or(0, |t| t.values.len())
        };
        count(&self.phi) + count(&self.psi)
    }
}

/// The tables of a model ([`Tables`]): those of its whole kept grid, read by runs of
/// consecutive lines, and those of the lattice of every m-th line (m > 1) of its first
/// such run, read by runs on that lattice ([`GridRun::lattice`]); a run on another lattice
/// goes without. A clone starts without them, so that models kept in results (fits, memos)
/// do not hold the tables of the working models they were cloned from; a model is equal
/// to, and stores as, the same model without them.
#[derive(Default)]
pub(crate) struct KeptBasis<T: Real> {
    whole: Tables<T>,
    /// The lattice (first grid line, step) of `every_mth`, set with its φ.
    lattice: OnceLock<(usize, usize)>,
    every_mth: Tables<T>,
}

impl<T: Real> Clone for KeptBasis<T> {
    /// Without the tables (see [`KeptBasis`]).
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl<T: Real> std::fmt::Debug for KeptBasis<T> {
    /// The number of values kept, not the values.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let values = self.whole.values() + self.every_mth.values();
        write!(f, "KeptBasis({values} values)")
    }
}

impl<T: Real> PartialEq for KeptBasis<T> {
    /// Always: the kept values are those any evaluation computes.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl<T: Real> KeptBasis<T> {
    /// The tables of the grid run `run` (on a grid of `n` lines) from its first line on:
    /// φ built by `phi` on the first call for the run's lattice ([`GridRun::lattice`], whose
    /// lines it is given as (first, step, count)), and with `psi` given, ψ built by it
    /// from the φ table on the first call that gives it (each table once: later calls,
    /// from any thread, read the same table or, when its builder gave none, go without
    /// it). `None` without a φ table, or for every m-th line on another lattice than the
    /// one kept.
    pub(crate) fn run(
        &self,
        run: GridRun,
        n: usize,
        phi: impl FnOnce(usize, usize, usize) -> Option<BasisTable<T>>,
        psi: Option<impl FnOnce(&BasisTable<T>) -> Option<BasisTable<T>>>,
    ) -> Option<TableRun<'_, T>> {
        let (first, count) = run.lattice(n);
        let tables = if run.step == 1 {
            &self.whole
        } else {
            let kept = *self.lattice.get_or_init(|| (first, run.step));
            if kept != (first, run.step) {
                return None;
            }
            &self.every_mth
        };
        let phi = tables
            .phi
            .get_or_init(|| phi(first, run.step, count))
            .as_ref()?;
        let psi = psi.and_then(|build| tables.psi.get_or_init(|| build(phi)).as_ref());
        Some(TableRun {
            phi,
            psi,
            start: run.table_start(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn numbered(k: usize, line: &mut [Complex<f64>]) {
        for (j, v) in line.iter_mut().enumerate() {
            *v = Complex::new(k as f64, j as f64);
        }
    }

    #[test]
    fn a_table_holds_each_lines_values_and_refuses_too_many() {
        let t = BasisTable::build(5, 3, numbered).unwrap();
        assert_eq!(t.line(4), &[0.0, 1.0, 2.0].map(|j| Complex::new(4.0, j)));
        assert_eq!(t.line(0), &[0.0, 1.0, 2.0].map(|j| Complex::new(0.0, j)));
        assert!(BasisTable::<f64>::build(MAX_VALUES / 4 + 1, 4, numbered).is_none());
        assert!(BasisTable::<f64>::build(usize::MAX / 2, 3, numbered).is_none());
        assert!(BasisTable::<f64>::build(3, 0, numbered).is_none());
        assert!(BasisTable::<f64>::build(MAX_VALUES / 4, 4, |_, _| ()).is_some());
    }

    #[test]
    fn kept_tables_are_built_once_and_not_cloned() {
        let kept = KeptBasis::<f64>::default();
        let at = |start, step| GridRun { start, step };
        let (phis, psis) = (std::cell::Cell::new(0), std::cell::Cell::new(0));
        // line k of a table holds the grid line first + k·step
        let phi = |first: usize, step: usize, count: usize| {
            phis.set(phis.get() + 1);
            BasisTable::build(count, 2, |k, line| numbered(first + k * step, line))
        };
        let no_psi = None::<fn(&BasisTable<f64>) -> Option<BasisTable<f64>>>;
        let run = kept.run(at(1, 1), 4, phi, no_psi).unwrap();
        assert_eq!(run.phi(2)[1], Complex::new(3.0, 1.0));
        assert!(run.psi(2).is_none());
        let psi = |t: &BasisTable<f64>| {
            psis.set(psis.get() + 1);
            BasisTable::build(t.lines_count(), 1, |k, line| line[0] = t.line(k)[1] * 2.0)
        };
        let run = kept.run(at(0, 1), 4, phi, Some(psi)).unwrap();
        assert_eq!(run.psi(3), Some(&[Complex::new(6.0, 2.0)][..]));
        assert!(kept.run(at(2, 1), 4, phi, Some(psi)).is_some());
        assert_eq!((phis.get(), psis.get()), (1, 1));
        assert_eq!(format!("{kept:?}"), "KeptBasis(12 values)");
        // every third line of a 10-line grid from line 4: the lattice 1, 4, 7 (3 lines),
        // with its own tables; line k of the run is grid line 4 + 3k
        let run = kept.run(at(4, 3), 10, phi, Some(psi)).unwrap();
        assert_eq!(run.phi(0)[0], Complex::new(4.0, 0.0));
        assert_eq!(run.phi(1)[1], Complex::new(7.0, 1.0));
        assert_eq!(run.psi(1), Some(&[Complex::new(14.0, 2.0)][..]));
        assert_eq!(
            kept.run(at(1, 3), 10, phi, no_psi).unwrap().phi(0)[0].re,
            1.0
        );
        assert_eq!((phis.get(), psis.get()), (2, 2));
        // another lattice goes without; consecutive lines still read the whole grid's
        assert!(kept.run(at(2, 3), 10, phi, no_psi).is_none());
        assert!(kept.run(at(4, 2), 10, phi, no_psi).is_none());
        assert_eq!(
            kept.run(at(3, 1), 4, phi, no_psi).unwrap().phi(0)[0].re,
            3.0
        );
        assert_eq!((phis.get(), psis.get()), (2, 2));
        assert_eq!(format!("{kept:?}"), "KeptBasis(21 values)");
        assert_eq!(format!("{:?}", kept.clone()), "KeptBasis(0 values)");
        // a model without a φ table stays without one
        let none = KeptBasis::<f64>::default();
        assert!(none.run(at(0, 1), 1, |_, _, _| None, no_psi).is_none());
        let one = |_: usize, _: usize, _: usize| BasisTable::build(1, 1, numbered);
        assert!(none.run(at(0, 1), 1, one, no_psi).is_none());
    }
}
