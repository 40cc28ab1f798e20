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

#[path = "../tests/common/measurement.rs"]
mod measurement;
#[path = "common/progress.rs"]
mod progress;

use fdid::workflow::{Detail, Effect};
use measurement::{CLEAN, Sim, run};

const RUNS: u64 = 50;

/// Fraction of runs naming `effect` first, and the mean of the `value` of the detail of the
/// first step naming it.
fn power(
    sim: &Sim,
    effect: Effect,
    value: fn(&Detail) -> Option<f64>,
    seed0: u64,
) -> (f64, Option<f64>) {
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
            .and_then(|s| value(&s.detail))
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
        let (p, _) = power(
            &sim,
            Effect::InputNoise,
            |d| Some(d.input_noise()?.input_to_output),
            1_000,
        );
        println!("  {snr:>5.1} dB: {p:.2}");
    }
    println!("nonlinear distortion (P = 6): c -> distortion/noise (dB), named first");
    for c in [0.0005, 0.001, 0.0015, 0.002, 0.003, 0.005, 0.007] {
        let sim = Sim { cubic: c, ..CLEAN };
        let (p, db) = power(
            &sim,
            Effect::NonlinearDistortion,
            |d| d.nonlinear_distortion()?.distortion_to_noise_db,
            2_000,
        );
        let db = db.map_or("—".to_string(), |v| format!("{v:.1}"));
        println!("  c = {c}: {db} dB, {p:.2}");
    }
    println!("(distortion/noise: mean over the runs that named the effect)");
    println!("time variation (P = 6): total drift of a1 -> skirt/noise (dB), named first");
    for drift in [0.002, 0.005, 0.01, 0.015, 0.02, 0.03, 0.05] {
        let sim = Sim { drift, ..CLEAN };
        // the default workflow's time-variation detector runs both tests
        let (p, db) = power(
            &sim,
            Effect::TimeVariation,
            |d| d.time_variation_tests()?.skirt?.skirt_to_noise_db,
            3_000,
        );
        let db = db.map_or("—".to_string(), |v| format!("{v:.1}"));
        println!("  drift {drift}: {db} dB, {p:.2}");
    }
}
