//! Fitting many independent frequency responses with one [`Pipeline`].
//!
//! Each data set is fitted on its own, exactly as [`Pipeline::fit`] would fit it; the
//! results come back in the order of the input, one [`Result`] per item, so a data set
//! that cannot be fitted (too few lines for the model, a singular problem) does not stop
//! the others.
//!
//! With the cargo feature `rayon` the items are distributed over rayon's thread pool (the
//! global one, or the pool of an enclosing [`rayon::ThreadPool::install`]); without it they
//! are fitted one after the other. Every fit is deterministic and independent of the others,
//! so both give bit-identical results; [`fit_many_sequential`] and [`fit_each_sequential`]
//! are the sequential versions whatever the features.

use super::{FurtherStarts, Pipeline};
use crate::data::FrequencyData;
use crate::error::Result;
use crate::fit::Fit;
use crate::scalar::Real;

/// Fits every data set of `data` with the same `model` structure, in parallel with the
/// `rayon` feature: item `k` of the result is `pipeline.fit(model, &data[k])`.
///
/// A discrete-time [`crate::Rational`] does not depend on the frequency grid, so one model
/// serves data sets of different grids; a continuous-time one is built for a grid (its
/// basis), see [`fit_each`] to give each data set its own model.
///
/// ```
/// use fdid::estimate::batch::fit_many;
/// use fdid::prelude::*;
///
/// // noise-free FRFs of G(z) = b / (1 - a z^-1) (Ts = 1); the third is too short to fit
/// let frf = |a: f64, b: f64, lines: usize| {
///     let omega: Vec<f64> = (0..lines).map(|k| 3.0 * k as f64 / lines as f64).collect();
///     let g = omega
///         .iter()
///         .map(|w| Complex::new(b, 0.0) / (1.0 - Complex::new(0.0, -w).exp() * a))
///         .collect();
///     FrequencyData::from_frf(omega, g, Some(1.0)).unwrap()
/// };
/// let data = vec![frf(0.5, 1.0, 50), frf(0.9, 2.0, 80), frf(0.7, 1.0, 1), frf(-0.3, 0.5, 40)];
/// let model = Rational::discrete(1, 1, 1.0).unwrap(); // b0 + b1 z^-1 over 1 + a1 z^-1
/// let fits = fit_many(&Pipeline::default(), &model, &data);
/// assert_eq!(fits.len(), 4);
/// let pole = |k: usize| fits[k].as_ref().unwrap().poles().unwrap()[0];
/// assert!((pole(0) - Complex::new(0.5, 0.0)).norm() < 1e-9);
/// assert!((pole(1) - Complex::new(0.9, 0.0)).norm() < 1e-9);
/// // one line gives 2 real equations for 3 parameters: an error, the others are fitted
/// assert!(matches!(fits[2], Err(FdidError::TooFewFrequencies { .. })));
/// assert!((pole(3) - Complex::new(-0.3, 0.0)).norm() < 1e-9);
/// ```
pub fn fit_many<T, M>(
    pipeline: &Pipeline,
    model: &M,
    data: &[FrequencyData<T>],
) -> Vec<Result<Fit<T, M>>>
where
    T: Real,
    M: FurtherStarts<T> + Send + Sync,
{
    #[cfg(feature = "rayon")]
    {
        use rayon::prelude::*;
        data.par_iter().map(|d| pipeline.fit(model, d)).collect()
    }
    #[cfg(not(feature = "rayon"))]
    {
        fit_many_sequential(pipeline, model, data)
    }
}

/// [`fit_many`] one item after the other, whatever the features.
pub fn fit_many_sequential<T, M>(
    pipeline: &Pipeline,
    model: &M,
    data: &[FrequencyData<T>],
) -> Vec<Result<Fit<T, M>>>
where
    T: Real,
    M: FurtherStarts<T> + Send + Sync,
{
    data.iter().map(|d| pipeline.fit(model, d)).collect()
}

/// Fits each `(model, data)` pair, in parallel with the `rayon` feature: item `k` of the
/// result is `pipeline.fit(&items[k].0, &items[k].1)`. Use it when the models differ, e.g.
/// continuous-time models built for each data set's grid by [`crate::Rational::continuous`].
///
/// ```
/// use fdid::estimate::batch::fit_each;
/// use fdid::prelude::*;
///
/// // G(s) = 1 / (s + p) for p = 1, 2, 3 on grids of 40, 60 and 80 lines
/// let items: Vec<_> = (1..=3)
///     .map(|p| {
///         let omega: Vec<f64> = (1..=20 * (p + 1)).map(|k| 0.1 * k as f64).collect();
///         let g = omega
///             .iter()
///             .map(|w| Complex::new(1.0, 0.0) / (Complex::new(0.0, *w) + p as f64))
///             .collect();
///         let model = Rational::continuous(1, 0, &omega).unwrap();
///         (model, FrequencyData::from_frf(omega, g, None).unwrap())
///     })
///     .collect();
/// let fits = fit_each(&Pipeline::default(), &items);
/// for (p, fit) in (1..=3).zip(&fits) {
///     let pole = fit.as_ref().unwrap().poles().unwrap()[0];
///     assert!((pole + p as f64).norm() < 1e-9);
/// }
/// ```
pub fn fit_each<T, M>(
    pipeline: &Pipeline,
    items: &[(M, FrequencyData<T>)],
) -> Vec<Result<Fit<T, M>>>
where
    T: Real,
    M: FurtherStarts<T> + Send + Sync,
{
    #[cfg(feature = "rayon")]
    {
        use rayon::prelude::*;
        items.par_iter().map(|(m, d)| pipeline.fit(m, d)).collect()
    }
    #[cfg(not(feature = "rayon"))]
    {
        fit_each_sequential(pipeline, items)
    }
}

/// [`fit_each`] one item after the other, whatever the features.
pub fn fit_each_sequential<T, M>(
    pipeline: &Pipeline,
    items: &[(M, FrequencyData<T>)],
) -> Vec<Result<Fit<T, M>>>
where
    T: Real,
    M: FurtherStarts<T> + Send + Sync,
{
    items.iter().map(|(m, d)| pipeline.fit(m, d)).collect()
}
