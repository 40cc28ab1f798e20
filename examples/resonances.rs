//! Fit a continuous-time model with five lightly damped resonances to noisy frequency
//! response data (20 000 log-spaced lines, 40 dB SNR) with Levy → SK → ML, and compare the
//! poles with the truth.
//!
//! Run: `cargo run --release --example resonances`

#[path = "../tests/common/mod.rs"]
mod common;

use common::{Noise, b_ct10, logspace, rel_rms};
use fdid::prelude::*;
use std::time::Instant;

fn main() -> Result<()> {
    let truth = b_ct10();
    let omega = logspace(-1.0, 1.0, 20_000);
    let g0 = truth.frf(&omega);
    let rms = (g0.iter().map(|g| g.norm_sqr()).sum::<f64>() / g0.len() as f64).sqrt();
    let var = (0.01 * rms).powi(2);
    let mut noise = Noise::new(7);
    let y: Vec<Complex<f64>> = g0.iter().map(|g| g + noise.complex(var)).collect();
    let data = FrequencyData::from_frf(omega, y, None)?
        .with_noise(NoiseVariances::output_only(vec![var; g0.len()]))?;

    let model = Rational::continuous(10, 8, data.omega())?;
    let t = Instant::now();
    let fit = Pipeline::default().fit(&model, &data)?;
    let elapsed = t.elapsed();

    for stage in fit.stages() {
        println!(
            "{:>5}: cost {:.4e} after {} iterations ({:?})",
            stage.kind, stage.solution.cost, stage.solution.iterations, stage.solution.termination
        );
    }
    println!("fit time {elapsed:?}");
    println!(
        "cost {:.1} for {} lines (expected ≈ N − p/2 = {:.1} with correct noise variances)",
        fit.cost(),
        data.len(),
        data.len() as f64 - model.n_params() as f64 / 2.0
    );
    println!(
        "relative RMS error against the truth: {:.3e}",
        rel_rms(fit.response(), &g0)
    );

    let mut poles = fit.poles()?;
    poles.sort_by(|a, b| a.im.total_cmp(&b.im));
    let mut want = truth.poles();
    want.sort_by(|a, b| a.im.total_cmp(&b.im));
    println!("{:>28} {:>28}", "estimated pole", "true pole");
    for (p, w) in poles.iter().zip(&want) {
        println!(
            "{:>13.6} {:+13.6}i {:>13.6} {:+13.6}i",
            p.re, p.im, w.re, w.im
        );
    }
    Ok(())
}
