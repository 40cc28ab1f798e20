//! Independent work items on rayon's thread pool with the `rayon` feature, one after the
//! other without it.

/// `(0..n).map(f)` collected in order, the items computed in parallel with the `rayon`
/// feature. A single item is computed on the calling thread: handing it to the pool
/// would only add the hand-over (and, the first time in a process, the pool's start).
pub(crate) fn map_indices<R, F>(n: usize, f: F) -> Vec<R>
where
    R: Send,
    F: Fn(usize) -> R + Sync + Send,
{
    #[cfg(feature = "rayon")]
    if n > 1 {
        use rayon::prelude::*;
        return (0..n).into_par_iter().map(f).collect();
    }
    (0..n).map(f).collect()
}

/// `(a(), b())`, the two computed in parallel with the `rayon` feature.
pub(crate) fn join<A, B, RA, RB>(a: A, b: B) -> (RA, RB)
where
    A: FnOnce() -> RA + Send,
    B: FnOnce() -> RB + Send,
    RA: Send,
    RB: Send,
{
    #[cfg(feature = "rayon")]
    {
        rayon::join(a, b)
    }
    #[cfg(not(feature = "rayon"))]
    {
        (a(), b())
    }
}

#[cfg(test)]
mod tests {
    use super::map_indices;

    #[test]
    fn keeps_the_order_of_the_items() {
        let squares = map_indices(1000, |k| k * k);
        assert!(squares.iter().enumerate().all(|(k, s)| *s == k * k));
        assert!(map_indices(0, |k| k).is_empty());
    }

    #[test]
    fn joins_both_results() {
        assert_eq!(super::join(|| 2 + 2, || "b"), (4, "b"));
    }
}
