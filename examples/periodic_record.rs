//! Identify a discrete-time system from a noisy periodic time record: average the periods
//! (which also estimates the noise variance on every line), fit Levy → SK → ML with the
//! lines weighted by those variances, and report the poles with their uncertainty and the
//! cost against its expected value.
//!
//! Run: `cargo run --release --example periodic_record`

use fdid::prelude::*;

/// y(t) = b₁u(t−1) + b₂u(t−2) − a₁y(t−1) − a₂y(t−2) with poles 0.9 e^{±0.3i}.
fn simulate(u: &[f64]) -> Vec<f64> {
    let (r, th): (f64, f64) = (0.9, 0.3);
    let (a1, a2) = (-2.0 * r * th.cos(), r * r);
    let (b1, b2) = (0.5, 0.25);
    let mut y = vec![0.0; u.len()];
    for t in 0..u.len() {
        let at = |x: &[f64], k: usize| if t >= k { x[t - k] } else { 0.0 };
        y[t] = b1 * at(u, 1) + b2 * at(u, 2) - a1 * at(&y, 1) - a2 * at(&y, 2);
    }
    y
}

/// A small deterministic pseudo-random sequence (xorshift) mapped to [−1, 1).
struct Xorshift(u64);

impl Xorshift {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

fn main() -> Result<()> {
    let (m, periods, transient) = (512, 8, 4);
    let mut rng = Xorshift(0x9e37_79b9_7f4a_7c15);
    let one_period: Vec<f64> = (0..m).map(|_| rng.next()).collect();
    // run a few extra periods first so the record is in steady state
    let u: Vec<f64> = one_period
        .iter()
        .cycle()
        .take(m * (periods + transient))
        .copied()
        .collect();
    let y_clean = simulate(&u);
    let (u, y_clean) = (&u[m * transient..], &y_clean[m * transient..]);
    let sigma = 0.05;
    let y: Vec<f64> = y_clean
        .iter()
        .map(|v| v + sigma * rng.next() * 3f64.sqrt())
        .collect();

    let record = TimeData::new(u.to_vec(), y, 1.0)?;
    let averaged = record.average_periods(periods)?;
    let data = averaged.band(1e-9, std::f64::consts::PI)?; // drop DC (Ts = 1: Nyquist is π rad/s)
    let model = Rational::discrete(2, 2, 1.0)?;
    let fit = Pipeline::default().fit(&model, &data)?;

    let n = data.len() as f64;
    let p = model.n_params() as f64;
    println!("lines {n}, parameters {p}");
    // with variances estimated from P periods (2(P − 1) real degrees of freedom per line),
    // E[1/σ̂²] = (1/σ²)·ν/(ν − 2), ν = 2(P − 1): the expected cost grows by that factor
    let nu = 2.0 * (periods as f64 - 1.0);
    let inflation = nu / (nu - 2.0);
    println!(
        "cost {:.1} (expected ≈ (N − p/2)·ν/(ν − 2) = {:.1}, ν = {nu}; ± ≈ {:.1})",
        fit.cost(),
        (n - p / 2.0) * inflation,
        n.sqrt() * inflation
    );
    let theta = fit.theta();
    let std = fit.theta_std().unwrap_or_default();
    for (i, (t, s)) in theta.iter().zip(&std).enumerate() {
        println!("theta[{i}] = {t:+.5} ± {s:.5}");
    }
    for pole in fit.poles()? {
        println!(
            "pole {:.5} {:+.5}i  (|p| = {:.5}, angle {:.5} rad; true 0.9, ±0.3)",
            pole.re,
            pole.im,
            pole.norm(),
            pole.arg()
        );
    }
    Ok(())
}
