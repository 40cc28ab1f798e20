//! The simulated periodic experiment of the workflow's measurement-level tests
//! (`tests/suite/workflow_measurement.rs`) and of their power study
//! (`examples/workflow_measurement_power.rs`): y = x + c x³ + noise, x = B/A u with a₁
//! drifting over the record, measured input u + noise, an odd random-phase multisine.

#![allow(dead_code)]

use fdid::prelude::*;
use fdid::simulate::{OddMultisineDesign, SplitMix64};
use fdid::workflow::{Context, ModelSpec, Report, Workflow};

/// Significance level of the workflow's tests.
pub const ALPHA: f64 = 0.05;

/// Samples per period.
pub const M: usize = 512;
/// The odd multisine's band (DFT lines of one period): 50 excited lines, 25 odd and 75
/// even detection lines.
pub const BAND: [usize; 2] = [1, 150];
/// Warm-up periods dropped before the measured ones.
pub const WARM: usize = 2;

/// One simulated experiment: y = x + c x³ + noise, x = B/A u with a₁ drifting linearly
/// over the record, measured input u + noise.
#[derive(Debug, Clone, Copy)]
pub struct Sim {
    /// Measured periods P.
    pub periods: usize,
    /// Output noise standard deviation (per sample, so per DFT line of one period).
    pub sigma_y: f64,
    /// Input SNR per excited line of one period, |U_k|²/σ_u² in dB (`None`: exact input).
    pub input_snr_db: Option<f64>,
    /// Cubic coefficient c of the static output nonlinearity.
    pub cubic: f64,
    /// Total change of a₁ over the simulated time (warm-up and measured periods).
    pub drift: f64,
    /// Denominator (1, a₁, a₂) of the truth.
    pub a: [f64; 3],
    /// Numerator (b₀, b₁, b₂).
    pub b: [f64; 3],
}

/// The clean experiment: 6 periods, output noise 0.05, exact input, no effect.
pub const CLEAN: Sim = Sim {
    periods: 6,
    sigma_y: 0.05,
    input_snr_db: None,
    cubic: 0.0,
    drift: 0.0,
    a: [1.0, -1.2, 0.72],
    b: [0.2, 0.3, 0.1],
};

/// |U_k|² of the unit-RMS multisine on the 50 excited lines (1/√M DFT).
pub fn line_power() -> f64 {
    M as f64 / (2.0 * 50.0)
}

/// The true FRF at ω (rad/sample).
pub fn truth(sim: &Sim, w: f64) -> Complex<f64> {
    let zi = Complex::new(0.0, -w).exp();
    let p = |c: &[f64; 3]| c[0] + zi * (c[1] + zi * c[2]);
    p(&sim.b) / p(&sim.a)
}

/// The measured record (steady state, P periods), the averaged spectra at the excited
/// lines with their sample (co)variances, and the design.
pub fn simulate(sim: &Sim, seed: u64) -> (TimeData<f64>, FrequencyData<f64>) {
    let design = OddMultisineDesign::new(BAND, 3, 17).unwrap();
    let total = (WARM + sim.periods) * M;
    let u = design
        .multisine(M as f64, 1000 + seed)
        .unwrap()
        .sample(1.0, total);
    let mut rng = SplitMix64::new(seed);
    let mut x = vec![0.0; total];
    for t in 0..total {
        let a1 = sim.a[1] + sim.drift * (t as f64 / total as f64 - 0.5);
        let at = |v: &[f64], k: usize| if t >= k { v[t - k] } else { 0.0 };
        x[t] = sim.b[0] * u[t] + sim.b[1] * at(&u, 1) + sim.b[2] * at(&u, 2)
            - a1 * at(&x, 1)
            - sim.a[2] * at(&x, 2);
    }
    let sigma_u = sim
        .input_snr_db
        .map_or(0.0, |snr| (line_power() * 10f64.powf(-snr / 10.0)).sqrt());
    let (mut um, mut ym) = (vec![], vec![]);
    for t in WARM * M..total {
        um.push(u[t] + sigma_u * rng.gaussian());
        ym.push(x[t] + sim.cubic * x[t].powi(3) + sim.sigma_y * rng.gaussian());
    }
    let record = TimeData::new(um, ym, 1.0).unwrap();
    let all = record.average_periods(sim.periods).unwrap();
    let keep: Vec<bool> = (0..all.len())
        .map(|k| design.excited().contains(&k))
        .collect();
    (record, all.select_lines(&keep).unwrap())
}

/// The workflow's context of a periodic record of `sim`.
pub fn context(sim: &Sim, record: TimeData<f64>) -> Context {
    Context::periodic(ALPHA)
        .with_record(record, sim.periods)
        .unwrap()
}

/// The workflow on `sim`'s data from the correct order-(2, 2) model, and the data.
pub fn run(sim: &Sim, seed: u64) -> (Report, FrequencyData<f64>) {
    let (record, data) = simulate(sim, seed);
    let report = Workflow::default()
        .run(&data, ModelSpec::discrete(2, 2, 1.0), context(sim, record))
        .unwrap();
    (report, data)
}
