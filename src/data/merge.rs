//! Merging the frequency-domain data of several experiments into one data set.

use crate::data::{FrequencyData, NoiseVariances};
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};

/// Merges experiments into one data set: the union of all lines, sorted by frequency.
///
/// With experiments `e = 0, …, E−1` holding lines `(ω_{e,k}, Y_{e,k}, U_{e,k})`, the
/// result holds every line once, ordered by `ω` with a *stable* sort: lines at equal
/// frequencies keep the order of the experiments (then of the lines within one
/// experiment). Equal frequencies from different experiments are kept as separate lines.
///
/// - Sample time: `Some(Ts)` when every experiment has the same `Some(Ts)`, otherwise
///   `None` (the merged data then need a continuous-time model).
/// - Noise: kept (merged line by line) when every experiment has noise (co)variances,
///   absent when none has.
///
/// # Errors
/// - [`FdidError::TooShort`] for an empty slice;
/// - [`FdidError::InvalidArgument`] named `"experiments"` when only some experiments have
///   noise (co)variances (the message names the first one without).
pub fn merge<T: Real>(experiments: &[FrequencyData<T>]) -> Result<FrequencyData<T>> {
    let first = experiments.first().ok_or(FdidError::TooShort {
        what: "experiments",
        needed: 1,
        got: 0,
    })?;
    let with_noise = experiments.iter().filter(|e| e.noise().is_some()).count();
    if with_noise != 0 && with_noise != experiments.len() {
        let missing = experiments
            .iter()
            .position(|e| e.noise().is_none())
            .unwrap_or(0);
        return Err(FdidError::InvalidArgument {
            name: "experiments",
            value: format!("experiment {missing} has no noise (co)variances"),
            reason: format!(
                "{with_noise} of {} experiments have noise (co)variances: either all or none must",
                experiments.len()
            ),
        });
    }
    let ts = match first.ts() {
        Some(t) if experiments.iter().all(|e| e.ts() == Some(t)) => Some(t),
        _ => None,
    };

    // (experiment, line) pairs, stably sorted by frequency.
    let mut order: Vec<(usize, usize)> = experiments
        .iter()
        .enumerate()
        .flat_map(|(e, d)| (0..d.len()).map(move |k| (e, k)))
        .collect();
    order.sort_by(|a, b| {
        let wa = experiments[a.0].omega()[a.1];
        let wb = experiments[b.0].omega()[b.1];
        wa.partial_cmp(&wb).unwrap_or(std::cmp::Ordering::Equal)
    });

    let total = order.len();
    let mut omega = Vec::with_capacity(total);
    let mut y = Vec::with_capacity(total);
    let mut u = Vec::with_capacity(total);
    let mut noise = (with_noise != 0).then(|| NoiseVariances {
        var_y: Vec::with_capacity(total),
        var_u: Vec::with_capacity(total),
        cov_yu: Vec::<Complex<T>>::with_capacity(total),
    });
    for &(e, k) in &order {
        let d = &experiments[e];
        omega.push(d.omega()[k]);
        y.push(d.y()[k]);
        u.push(d.u()[k]);
        if let (Some(acc), Some(n)) = (noise.as_mut(), d.noise()) {
            acc.var_y.push(n.var_y[k]);
            acc.var_u.push(n.var_u[k]);
            acc.cov_yu.push(n.cov_yu[k]);
        }
    }
    let mut merged = FrequencyData::from_parts_unchecked(omega, y, u, noise, ts);
    if ts.is_none()
        && experiments
            .iter()
            .any(|e| e.ts().is_some() || e.mixed_sample_times())
    {
        merged = merged.mark_mixed_sample_times();
    }
    // sample variances in every experiment: keep the smallest degrees of freedom (the most
    // inflated cost); any experiment with exact variances gives none
    match experiments.iter().map(|e| e.variance_dof()).min().flatten() {
        Some(dof) if merged.noise().is_some() => merged.with_variance_dof(dof),
        _ => Ok(merged),
    }
}
