//! Independent work items on rayon's thread pool with the `rayon` feature, one after the
//! other without it.

/// `(0..n).map(f)` collected in order, the items computed in parallel with the `rayon`
/// feature.
pub(crate) fn map_indices<R, F>(n: usize, f: F) -> Vec<R>
where
    R: Send,
    F: Fn(usize) -> R + Sync + Send,
{
    #[cfg(feature = "rayon")]
    {
        use rayon::prelude::*;
        (0..n).into_par_iter().map(f).collect()
    }
    #[cfg(not(feature = "rayon"))]
    {
        (0..n).map(f).collect()
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
}
