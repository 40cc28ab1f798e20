//! Independent fits of one workflow step on rayon's threads (with the `rayon` feature),
//! each under the thread settings of the step, so that the outcome does not depend on
//! which thread ran which fit.
//!
//! A fit reads three settings of its thread: the work budget ([`crate::solver::work`]),
//! the relocation starts ([`crate::estimate::without_relocation`]) and the memo of
//! [`super::spec::memoised`]. Every item gets the settings of the forking thread at the
//! fork — the budget left then, the relocation setting, a copy of the memo — whichever
//! thread runs it, the forking one included. Afterwards the forking thread is charged the
//! work of all items, and its memo gains the fits they made, in item order. Items report
//! no progress lines (other threads have no sink).
//!
//! One difference from running the items one after the other: each item has the whole
//! budget left at the fork, not what the items before it left, so a step of m items may
//! use up to m times what was left. With the budget not reached (the normal case) the
//! outcomes are those of the items run one after the other.

use super::spec::{Memo, memo_copy, memo_merge, with_memo};
use crate::estimate::multistart::{relocation_off, with_relocation_off};
use crate::solver::work;

/// `items.iter().map(f)` collected in order, the items run in parallel under the
/// forking thread's settings (see the module docs).
pub(crate) fn map_forked<I, R, F>(items: &[I], f: F) -> Vec<R>
where
    I: Sync,
    R: Send,
    F: Fn(&I) -> R + Sync + Send,
{
    let budget = work::left();
    let off = relocation_off();
    let memo = memo_copy();
    let kept = memo.as_ref().map_or(0, Vec::len);
    let done: Vec<(R, f64, Option<Memo>)> =
        crate::linalg::parallel::map_indices(items.len(), |i| {
            crate::progress::silenced(|| {
                with_relocation_off(off, || {
                    let ((value, memo), used) =
                        work::detached(budget, || with_memo(memo.clone(), || f(&items[i])));
                    (value, used, memo)
                })
            })
        });
    let mut values = Vec::with_capacity(done.len());
    let mut used = 0.0;
    for (value, work, memo) in done {
        values.push(value);
        used += work;
        if let Some(mut memo) = memo {
            memo_merge(memo.split_off(kept.min(memo.len())));
        }
    }
    work::charge(used);
    values
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::FrequencyData;
    use crate::estimate::ModelSpec;
    use crate::scalar::Complex;
    use crate::workflow::spec::{fit_spec, memoised};

    #[test]
    fn forked_items_see_the_forking_settings_and_hand_back_their_work() {
        let omega: Vec<f64> = (1..=30).map(|k| 0.3 * k as f64).collect();
        let frf = omega
            .iter()
            .map(|w| Complex::new(1.0, 0.0) / Complex::new(1.0, *w))
            .collect();
        let data = FrequencyData::from_frf(omega, frf, None).unwrap();
        let specs: Vec<ModelSpec> = (1..=4).map(|n| ModelSpec::continuous(n, n - 1)).collect();
        let ((), stopped) = work::within(1e12, || {
            memoised(|| {
                crate::estimate::without_relocation(|| {
                    let first = fit_spec(&specs[0], &data).unwrap();
                    let before = work::left().unwrap();
                    let seen = map_forked(&specs, |s| {
                        assert!(relocation_off(), "the relocation setting is carried");
                        assert_eq!(work::left(), Some(before), "the budget left is carried");
                        let memo = memo_copy().expect("a memo is carried");
                        assert!(!memo.is_empty());
                        fit_spec(s, &data).map(|f| f.cost)
                    });
                    assert_eq!(seen[0].as_ref().unwrap(), &first.cost);
                    assert!(work::left().unwrap() < before, "the items' work is charged");
                    // every item's fit is remembered once, in item order
                    let memo = memo_copy().unwrap();
                    assert_eq!(memo.len(), specs.len());
                    for (e, s) in memo.iter().zip(&specs) {
                        assert_eq!(&e.0, s);
                    }
                    // a refit is the remembered one, at no work
                    let at = work::left();
                    assert_eq!(
                        fit_spec(&specs[3], &data).unwrap().cost,
                        *seen[3].as_ref().unwrap()
                    );
                    assert_eq!(work::left(), at);
                })
            })
        });
        assert!(!stopped);
        assert!(!relocation_off(), "the setting is restored");
    }
}
