//! The second-order discrete-time system of the time-variation tests
//! (`tests/suite/workflow_segments.rs`, `tests/suite/workflow_tvswitch.rs`), whose a₁
//! drifts over a periodic record or jumps halfway through a non-periodic one, and its
//! simulated records.

#![allow(dead_code)]

use fdid::prelude::*;
use fdid::simulate::{OddMultisineDesign, SplitMix64};
use fdid::workflow::ModelSpec;

/// Samples per period.
pub const M: usize = 512;
/// Warm-up periods dropped before the measured ones.
pub const WARM: usize = 2;

/// A second-order discrete-time system B/A, B = b₀ + b₁z⁻¹ + b₂z⁻², A = 1 + a₁z⁻¹ + a₂z⁻².
#[derive(Debug, Clone, Copy)]
pub struct System {
    /// A's coefficients [1, a₁, a₂].
    pub a: [f64; 3],
    /// B's coefficients [b₀, b₁, b₂].
    pub b: [f64; 3],
}

/// The system of the tests: a resonance at ω ≈ 0.79 rad/sample (poles of radius 0.85).
pub const TRUTH: System = System {
    a: [1.0, -1.2, 0.72],
    b: [0.2, 0.3, 0.1],
};

/// The output of `sys` for input `u`, with a₁ + `a1(t)` at sample t.
pub fn filter(sys: &System, u: &[f64], a1: impl Fn(usize) -> f64) -> Vec<f64> {
    let mut x = vec![0.0; u.len()];
    for t in 0..u.len() {
        let at = |v: &[f64], k: usize| if t >= k { v[t - k] } else { 0.0 };
        x[t] = sys.b[0] * u[t] + sys.b[1] * at(u, 1) + sys.b[2] * at(u, 2)
            - (sys.a[1] + a1(t)) * at(&x, 1)
            - sys.a[2] * at(&x, 2);
    }
    x
}

/// A periodic record of `periods` periods (odd multisine on lines 1…150 of M = 512) of
/// `sys` with a₁ drifting linearly by `drift` over the simulated time, output noise σ;
/// its averaged spectra at the excited lines (sample noise variances).
pub fn periodic(
    sys: &System,
    periods: usize,
    drift: f64,
    sigma: f64,
    seed: u64,
) -> (TimeData<f64>, FrequencyData<f64>) {
    let design = OddMultisineDesign::new([1, 150], 3, 17).unwrap();
    let total = (WARM + periods) * M;
    let u = design
        .multisine(M as f64, 1000 + seed)
        .unwrap()
        .sample(1.0, total);
    let x = filter(sys, &u, |t| drift * (t as f64 / total as f64 - 0.5));
    let mut rng = SplitMix64::new(seed);
    let y: Vec<f64> = x[WARM * M..]
        .iter()
        .map(|v| v + sigma * rng.gaussian())
        .collect();
    let record = TimeData::new(u[WARM * M..].to_vec(), y, 1.0).unwrap();
    let all = record.average_periods(periods).unwrap();
    let keep: Vec<bool> = (0..all.len())
        .map(|k| design.excited().contains(&k))
        .collect();
    (record, all.select_lines(&keep).unwrap())
}

/// A non-periodic record of N samples of white Gaussian input through `sys` (from rest),
/// a₁ changed by `jump` from sample N/2 on, output noise σ; its DFT at lines 1 … N/2 − 1
/// (without noise variances).
pub fn non_periodic(
    sys: &System,
    n: usize,
    jump: f64,
    sigma: f64,
    seed: u64,
) -> (TimeData<f64>, FrequencyData<f64>) {
    let mut rng = SplitMix64::new(seed);
    let u: Vec<f64> = (0..n).map(|_| rng.gaussian()).collect();
    let x = filter(sys, &u, |t| if t >= n / 2 { jump } else { 0.0 });
    let y: Vec<f64> = x.iter().map(|v| v + sigma * rng.gaussian()).collect();
    let record = TimeData::new(u, y, 1.0).unwrap();
    let all = record.dft();
    let keep: Vec<bool> = (0..all.len()).map(|k| k > 0 && 2 * k < n).collect();
    (record.clone(), all.select_lines(&keep).unwrap())
}

/// The order-(2, 2) discrete-time spec with a transient term.
pub fn transient_spec() -> ModelSpec {
    ModelSpec {
        transient: true,
        ..ModelSpec::discrete(2, 2, 1.0)
    }
}
