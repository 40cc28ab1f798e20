//! A work budget for the iterative solvers of one thread: [`within`] runs a computation
//! with a budget of multiply-adds; every Levenberg–Marquardt evaluation and every
//! fixed-point solve charges its cost (rows·p² for a solve of `rows` real equations in
//! `p` unknowns), and once the budget is spent each iterative solver stops at its best
//! point so far with [`Termination::MaxIterations`](super::Termination::MaxIterations).
//! Any finite chain of fits therefore ends soon after the budget is spent, whatever the
//! data size or the number of restarts, and deterministically (the charges do not depend
//! on timing).

use std::cell::Cell;

thread_local! {
    /// The work left on this thread (`None`: no budget).
    static LEFT: Cell<Option<f64>> = const { Cell::new(None) };
    /// Whether a solver stopped because the budget was spent.
    static STOPPED: Cell<bool> = const { Cell::new(false) };
}

/// Runs `f` with a budget of `work` multiply-adds of the iterative solvers on this thread,
/// and tells whether a solver stopped because it was spent. Budgets nest: an inner one
/// runs within what the outer one has left, and the outer one is charged what the inner
/// one used.
///
/// ```
/// use fdid::solver::work;
/// let (value, stopped) = work::within(1e9, || 2 + 2);
/// assert_eq!((value, stopped), (4, false));
/// ```
pub fn within<R>(work: f64, f: impl FnOnce() -> R) -> (R, bool) {
    let outer = LEFT.get();
    let outer_stopped = STOPPED.replace(false);
    let budget = outer.map_or(work, |o| o.min(work));
    LEFT.set(Some(budget));
    let value = f();
    let used = budget - LEFT.get().unwrap_or(budget);
    let stopped = STOPPED.get();
    LEFT.set(outer.map(|o| o - used));
    STOPPED.set(outer_stopped || stopped);
    (value, stopped)
}

/// The work left on this thread's budget (`None`: no budget).
pub(crate) fn left() -> Option<f64> {
    LEFT.get()
}

/// Runs `f` on this thread with `budget` as its whole budget (`None`: none), whatever
/// budget the thread had before, which is restored afterwards unchanged; returns the
/// value and the work `f` charged. The budget left at a fork ([`left`]) carried to another
/// thread, whose work the forking thread then [`charge`]s.
pub(crate) fn detached<R>(budget: Option<f64>, f: impl FnOnce() -> R) -> (R, f64) {
    /// Restores the thread's budget when dropped (also on a panic).
    struct Restore(Option<f64>, bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            LEFT.set(self.0);
            STOPPED.set(self.1);
        }
    }
    let _restore = Restore(LEFT.replace(budget), STOPPED.replace(false));
    let value = f();
    let used = budget.map_or(0.0, |b| b - LEFT.get().unwrap_or(b));
    (value, used)
}

/// Charges `work` to this thread's budget; false (and the budget marked as spent) when
/// there is a budget and nothing is left after the charge.
pub(crate) fn charge(work: f64) -> bool {
    match LEFT.get() {
        None => true,
        Some(left) => {
            let left = left - work;
            LEFT.set(Some(left));
            let ok = left > 0.0;
            if !ok {
                STOPPED.set(true);
            }
            ok
        }
    }
}

/// Whether this thread runs within a budget that is spent: a search that makes many fits
/// (each with non-iterative stages the budget does not stop) ends at its best so far.
pub(crate) fn spent() -> bool {
    LEFT.get().is_some_and(|left| left <= 0.0)
}

/// The cost of one solve of `rows` real equations in `p` unknowns.
pub(crate) fn solve_cost(rows: usize, p: usize) -> f64 {
    rows as f64 * (p * p) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn detached_work_runs_on_its_own_budget_and_reports_its_charge() {
        let ((), stopped) = within(10.0, || {
            assert!(charge(3.0));
            let (ok, used) = detached(left(), || charge(5.0) && charge(1.0));
            assert!(ok);
            assert_eq!(used, 6.0);
            assert_eq!(
                left(),
                Some(7.0),
                "the thread's budget is restored unchanged"
            );
            let (ok, used) = detached(Some(2.0), || charge(5.0));
            assert!(!ok && used == 5.0);
            assert!(
                !spent(),
                "a spent detached budget does not spend the thread's"
            );
            let (ok, used) = detached(None, || charge(1e300));
            assert!(ok && used == 0.0);
            assert!(
                charge(6.0),
                "the forking thread charges what its forks used"
            );
            assert!(!charge(1.0));
        });
        assert!(stopped);
    }

    #[test]
    fn charges_stop_at_the_budget_and_nest() {
        assert!(charge(1e300), "no budget: every charge passes");
        let ((), stopped) = within(10.0, || {
            assert!(charge(4.0) && charge(4.0));
            assert!(!charge(4.0));
            assert!(!charge(1.0), "stays spent");
            assert!(spent());
        });
        assert!(stopped);
        let ((), stopped) = within(10.0, || {
            let ((), inner) = within(100.0, || assert!(charge(6.0)));
            assert!(!inner);
            assert!(!charge(6.0), "the inner charge counts in the outer budget");
        });
        assert!(stopped);
        assert_eq!(LEFT.get(), None);
        let ((), stopped) = within(10.0, || assert!(charge(9.0)));
        assert!(!stopped);
    }
}
