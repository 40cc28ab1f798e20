//! Detection power of the workflow's measurement-level detectors against the effect size,
//! on simulated periodic records of y = x + c x³ + noise, x = B/A u (a₁ drifting over the
//! record), measured input u + noise (odd random-phase multisine, 50 excited lines of a
//! 512-sample period, P = 6 periods, P = 8 for the input-noise sweep), starting from the
//! correct LTI model without the effect:
//!
//! - input noise: input SNR per excited line (dB);
//! - nonlinear distortion: cubic coefficient c, reported as the measured distortion to
//!   noise ratio at the excited lines (dB, mean over the runs that computed it);
//! - time variation: total change of a₁ over the record.
//!
//! Each row gives the fraction of runs where the effect is named first (α = 0.05).
//!
//! Run: `cargo run --release --example workflow_measurement_power`

#[path = "common/progress.rs"]
mod progress;

use fdid::data::OddMultisineDesign;
use fdid::prelude::*;
use fdid::simulate::SplitMix64;
use fdid::workflow::{Context, Effect, ModelSpec, Report, Workflow};

const ALPHA: f64 = 0.05;
/// Samples per period.
const M: usize = 512;
/// The odd multisine's band (DFT lines of one period): 50 excited lines, 25 odd and 75
/// even detection lines.
const BAND: [usize; 2] = [1, 150];
/// Warm-up periods dropped before the measured ones.
const WARM: usize = 2;

/// One simulated experiment: y = x + c x³ + noise, x = B/A u with a₁ drifting linearly
/// over the record, measured input u + noise.
#[derive(Debug, Clone, Copy)]
struct Sim {
    /// Measured periods P.
    periods: usize,
    /// Output noise standard deviation (per sample, so per DFT line of one period).
    sigma_y: f64,
    /// Input SNR per excited line of one period, |U_k|²/σ_u² in dB (`None`: exact input).
    input_snr_db: Option<f64>,
    /// Cubic coefficient c of the static output nonlinearity.
    cubic: f64,
    /// Total change of a₁ over the simulated time (warm-up and measured periods).
    drift: f64,
    /// Denominator (1, a₁, a₂) and numerator (b₀, b₁, b₂) of the truth.
    a: [f64; 3],
    b: [f64; 3],
}

const CLEAN: Sim = Sim {
    periods: 6,
    sigma_y: 0.05,
    input_snr_db: None,
    cubic: 0.0,
    drift: 0.0,
    a: [1.0, -1.2, 0.72],
    b: [0.2, 0.3, 0.1],
};

/// |U_k|² of the unit-RMS multisine on the 50 excited lines (1/√M DFT).
fn line_power() -> f64 {
    M as f64 / (2.0 * 50.0)
}

/// The measured record (steady state, P periods), the averaged spectra at the excited
/// lines with their sample (co)variances, and the design.
fn simulate(sim: &Sim, seed: u64) -> (TimeData<f64>, FrequencyData<f64>) {
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

fn context(sim: &Sim, record: TimeData<f64>) -> Context {
    Context::periodic(ALPHA)
        .with_record(record, sim.periods)
        .unwrap()
}

fn run(sim: &Sim, seed: u64) -> (Report, FrequencyData<f64>) {
    let (record, data) = simulate(sim, seed);
    let report = Workflow::default()
        .run(&data, ModelSpec::discrete(2, 2, 1.0), context(sim, record))
        .unwrap();
    (report, data)
}

const RUNS: u64 = 50;

/// Fraction of runs naming `effect` first, and the mean of the first step's `key` detail.
fn power(sim: &Sim, effect: Effect, key: &str, seed0: u64) -> (f64, Option<f64>) {
    let (mut hits, mut sum, mut count) = (0, 0.0, 0);
    for r in progress::runs(RUNS, effect.as_str()) {
        let (report, _) = run(sim, seed0 + r);
        if report.effects.first() == Some(&effect) {
            hits += 1;
        }
        if let Some(v) = report
            .steps
            .iter()
            .find(|s| s.effect == effect)
            .and_then(|s| s.detail.get(key))
        {
            sum += v;
            count += 1;
        }
    }
    (
        hits as f64 / RUNS as f64,
        (count > 0).then(|| sum / count as f64),
    )
}

fn main() {
    println!("input noise (P = 8): input SNR per line (dB) -> named first");
    for snr in [50.0, 40.0, 35.0, 30.0, 25.0, 20.0, 10.0] {
        let sim = Sim {
            periods: 8,
            input_snr_db: Some(snr),
            ..CLEAN
        };
        let (p, _) = power(&sim, Effect::InputNoise, "input_to_output", 1_000);
        println!("  {snr:>5.1} dB: {p:.2}");
    }
    println!("nonlinear distortion (P = 6): c -> distortion/noise (dB), named first");
    for c in [0.0005, 0.001, 0.0015, 0.002, 0.003, 0.005, 0.007] {
        let sim = Sim { cubic: c, ..CLEAN };
        let (p, db) = power(
            &sim,
            Effect::NonlinearDistortion,
            "distortion_to_noise_db",
            2_000,
        );
        let db = db.map_or("—".to_string(), |v| format!("{v:.1}"));
        println!("  c = {c}: {db} dB, {p:.2}");
    }
    println!("(distortion/noise: mean over the runs that named the effect)");
    println!("time variation (P = 6): total drift of a1 -> skirt/noise (dB), named first");
    for drift in [0.002, 0.005, 0.01, 0.015, 0.02, 0.03, 0.05] {
        let sim = Sim { drift, ..CLEAN };
        let (p, db) = power(&sim, Effect::TimeVariation, "skirt_to_noise_db", 3_000);
        let db = db.map_or("—".to_string(), |v| format!("{v:.1}"));
        println!("  drift {drift}: {db} dB, {p:.2}");
    }
}
