//! Monte Carlo over the estimators of McKelvey's *Frequency domain identification methods*:
//! for each, simulated records of a known system, `R` noisy runs, and one table of the
//! bias, the RMSE and the standard deviation predicted by `Fit::covariance`
//! (Cov θ̂ = (λ/2)(JᵀJ)⁻¹, eqs. 32–34).
//!
//! Cases (all discrete-time ones share G(z) = (0.5 + 0.3z⁻¹)/(1 − 1.5z⁻¹ + 0.7z⁻²), poles
//! 0.75 ± 0.37i, DC gain 4):
//! 1. output-error ML (eq. 23, `Pipeline`) on a periodic record, P = 8 periods averaged, the
//!    sample variances of the mean as known output noise variances;
//! 2. a non-periodic record of N = 256 samples from a random initial state, ML with and
//!    without the transient term of eqs. 4–5 (`Rational::with_transient`);
//! 3. a continuous-time modal model, ZOH-sampled (section 2.3), with and without the
//!    transient (`fit_modal`);
//! 4. ML with a noise model H = C/D (eq. 26, `fit_noise_model`) against flat-weighted ML
//!    (eq. 25) on coloured noise;
//! 5. errors-in-variables ML (eq. 42, `fit_eiv`) against output-error ML with noise on the
//!    measured input.
//!
//! Columns: `bias/SE` is (mean − true)/(sample std/√R); `pred std` is the mean over the
//! runs of the predicted std (`Fit::theta_std`, or the delta method on `Fit::covariance`
//! for the DC gain); `RMSE/pred` near 1 means the predicted uncertainty describes the
//! actual error, far above 1 a bias or an optimistic covariance.
//!
//! Measured with 1000 runs (about 14 s in release): OE ML with P = 8 sample variances has
//! no bias (|bias/SE| ≤ 1.2) and RMSE/pred 1.16–1.20, the 1.18 expected from the sample
//! variances (known variances would give 1); with the transient term the N = 256 record
//! gives RMSE/pred 0.95–1.06 and no bias, without it a1, a2 are biased by ≈ 12 SE and
//! RMSE/pred is 9–16; the ZOH modal model with transient: RMSE/pred 0.98–1.04, without it
//! the real pole is −0.468 instead of −0.3; the noise model: RMSE/pred 0.97–1.03, flat ML
//! has about 2× its RMSE (DC gain) and an optimistic predicted std (RMSE/pred 2.5 for the
//! DC gain); EIV: no bias, RMSE/pred 1.16–1.19 (1.18 expected), OE with input noise: DC
//! gain 3.953 (bias −18 SE), RMSE/pred 21–37.
//!
//! Run: `cargo run --release --example mckelvey_montecarlo [-- runs]` (default 1000 runs).

#[path = "common/progress.rs"]
mod progress;

use fdid::criterion::interior_lines;
use fdid::estimate::{ModalOptions, fit_modal};
use fdid::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

type C = Complex<f64>;

/// A(z⁻¹) of the discrete-time system.
const A: [f64; 3] = [1.0, -1.5, 0.7];
/// B(z⁻¹) of the discrete-time system.
const B: [f64; 2] = [0.5, 0.3];
/// Sample time of the discrete-time cases (s).
const TS: f64 = 0.01;

// ---------------------------------------------------------------------------------------
// The table
// ---------------------------------------------------------------------------------------

/// One row: a parameter of one estimator on one case.
struct McRow {
    estimator: &'static str,
    case: &'static str,
    parameter: &'static str,
    truth: f64,
    mean: f64,
    bias_se: f64,
    rmse: f64,
    predicted: f64,
}

/// The Monte Carlo table.
#[derive(Default)]
struct McTable {
    rows: Vec<McRow>,
}

/// Per run, the estimates of the reported parameters and their predicted stds.
#[derive(Default)]
struct Runs {
    values: Vec<Vec<f64>>,
    stds: Vec<Vec<f64>>,
}

impl Runs {
    fn push(&mut self, values: Vec<f64>, stds: Vec<f64>) {
        self.values.push(values);
        self.stds.push(stds);
    }
}

impl McTable {
    /// Adds one row per parameter from the runs of `estimator` on `case`.
    fn add(
        &mut self,
        estimator: &'static str,
        case: &'static str,
        names: &[&'static str],
        truth: &[f64],
        runs: &Runs,
    ) {
        let r = runs.values.len() as f64;
        for (i, (name, t)) in names.iter().zip(truth).enumerate() {
            let v: Vec<f64> = runs.values.iter().map(|x| x[i]).collect();
            let mean = v.iter().sum::<f64>() / r;
            let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (r - 1.0)).sqrt();
            let rmse = (v.iter().map(|x| (x - t).powi(2)).sum::<f64>() / r).sqrt();
            let predicted = runs.stds.iter().map(|s| s[i]).sum::<f64>() / r;
            self.rows.push(McRow {
                estimator,
                case,
                parameter: name,
                truth: *t,
                mean,
                bias_se: (mean - t) / (sd / r.sqrt()),
                rmse,
                predicted,
            });
        }
    }

    fn print(&self) {
        println!(
            "{:<17} | {:<22} | {:<9} | {:>9} | {:>9} | {:>8} | {:>9} | {:>9} | {:>9}",
            "estimator",
            "case",
            "parameter",
            "true",
            "mean",
            "bias/SE",
            "RMSE",
            "pred std",
            "RMSE/pred"
        );
        println!("{}", "-".repeat(127));
        let mut last = ("", "");
        for row in &self.rows {
            if (row.estimator, row.case) != last && !last.0.is_empty() {
                println!();
            }
            last = (row.estimator, row.case);
            println!(
                "{:<17} | {:<22} | {:<9} | {:>9.4} | {:>9.4} | {:>8.1} | {:>9.2e} | {:>9.2e} | {:>9.2}",
                row.estimator,
                row.case,
                row.parameter,
                row.truth,
                row.mean,
                row.bias_se,
                row.rmse,
                row.predicted,
                row.rmse / row.predicted
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// Simulation
// ---------------------------------------------------------------------------------------

/// Seeded Gaussian draws (Box–Muller).
struct Gauss(StdRng);

impl Gauss {
    fn new(seed: u64) -> Self {
        Gauss(StdRng::seed_from_u64(seed))
    }
    fn draw(&mut self) -> f64 {
        let u1: f64 = self.0.gen_range(f64::MIN_POSITIVE..1.0);
        let u2: f64 = self.0.r#gen();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
    fn white(&mut self, n: usize, sigma: f64) -> Vec<f64> {
        (0..n).map(|_| sigma * self.draw()).collect()
    }
}

/// y = B(q⁻¹)/A(q⁻¹) x (direct form II transposed, zero initial state, a₀ = 1).
fn lfilter(b: &[f64], a: &[f64], x: &[f64]) -> Vec<f64> {
    let n = b.len().max(a.len());
    let coef = |v: &[f64], i: usize| v.get(i).copied().unwrap_or(0.0);
    let mut z = vec![0.0; n];
    x.iter()
        .map(|xt| {
            let y = coef(b, 0) * xt + z[0];
            for i in 0..n - 1 {
                z[i] = coef(b, i + 1) * xt + z[i + 1] - coef(a, i + 1) * y;
            }
            y
        })
        .collect()
}

fn add(x: &[f64], y: &[f64]) -> Vec<f64> {
    x.iter().zip(y).map(|(a, b)| a + b).collect()
}

/// θ = [a₁, a₂, b₀, b₁] of the discrete-time system.
fn dt_truth() -> Vec<f64> {
    vec![A[1], A[2], B[0], B[1]]
}

const DT_NAMES: [&str; 5] = ["a1", "a2", "b0", "b1", "DC gain"];

/// The reported parameters of a discrete-time fit: θ₀…θ₃ and the DC gain
/// (b₀ + b₁)/(1 + a₁ + a₂), with their predicted stds (the gain's by the delta method
/// gᵀ Cov g on the leading 4 × 4 block of the covariance).
fn dt_report<M: ModelStructure<f64>>(fit: &Fit<f64, M>) -> (Vec<f64>, Vec<f64>) {
    let t = fit.theta();
    let den = 1.0 + t[0] + t[1];
    let gain = (t[2] + t[3]) / den;
    let mut values = t[..4].to_vec();
    values.push(gain);
    let Some(cov) = fit.covariance() else {
        return (values, vec![f64::NAN; 5]);
    };
    let grad = [-gain / den, -gain / den, 1.0 / den, 1.0 / den];
    let mut var_gain = 0.0;
    for i in 0..4 {
        for j in 0..4 {
            var_gain += grad[i] * cov[(i, j)] * grad[j];
        }
    }
    let mut stds: Vec<f64> = (0..4).map(|i| cov[(i, i)].sqrt()).collect();
    stds.push(var_gain.sqrt());
    (values, stds)
}

fn dt_truth_report() -> Vec<f64> {
    let mut t = dt_truth();
    t.push((B[0] + B[1]) / (A[0] + A[1] + A[2]));
    t
}

/// A periodic record of the discrete-time system: a random-phase multisine with
/// |U_k| = 1 on lines 1..=100 of M = 256 (1/√M DFT), 4 warm-up periods dropped, P periods
/// measured with white noise of std `sigma_u` on the input and `sigma_y` on the output;
/// the averaged spectra of the excited lines with their sample (co)variances of the mean.
fn periodic_record(seed: u64, periods: usize, sigma_u: f64, sigma_y: f64) -> FrequencyData<f64> {
    let (m, excited, warm) = (256usize, 100usize, 4usize);
    let mut rng = Gauss::new(seed);
    let phases: Vec<f64> = (0..excited)
        .map(|_| std::f64::consts::TAU * rng.draw())
        .collect();
    let amp = 2.0 / (m as f64).sqrt();
    let one: Vec<f64> = (0..m)
        .map(|t| {
            phases.iter().enumerate().fold(0.0, |s, (i, ph)| {
                let w = std::f64::consts::TAU * (i + 1) as f64 / m as f64;
                s + amp * (w * t as f64 + ph).cos()
            })
        })
        .collect();
    let total = (warm + periods) * m;
    let u: Vec<f64> = (0..total).map(|t| one[t % m]).collect();
    let y = lfilter(&B, &A, &u);
    let n = periods * m;
    let um = add(&u[warm * m..], &rng.white(n, sigma_u));
    let ym = add(&y[warm * m..], &rng.white(n, sigma_y));
    let all = TimeData::new(um, ym, TS)
        .and_then(|d| d.average_periods(periods))
        .expect("valid record");
    let keep: Vec<bool> = (0..all.len()).map(|k| (1..=excited).contains(&k)).collect();
    all.select_lines(&keep).expect("excited lines")
}

// ---------------------------------------------------------------------------------------
// The cases
// ---------------------------------------------------------------------------------------

/// Case 1: output-error ML on periodic data with the output variances from 8 periods.
fn case_periodic_oe(table: &mut McTable, runs: usize) -> Result<()> {
    let model = Rational::discrete(2, 1, TS)?;
    let mut est = Runs::default();
    for r in progress::runs(runs, "periodic OE") {
        let data = periodic_record(1000 + r as u64, 8, 0.0, 0.05);
        let fit = Pipeline::default().fit(&model, &data)?;
        let (v, s) = dt_report(&fit);
        est.push(v, s);
    }
    table.add(
        "OE ML (eq. 23)",
        "periodic, P=8, var_y",
        &DT_NAMES,
        &dt_truth_report(),
        &est,
    );
    Ok(())
}

/// Case 2: one non-periodic record of N = 256 samples from a random initial state (300
/// samples of earlier white input), white output noise of std 0.05 (known variance on every
/// DFT line), ML with and without the transient term.
fn case_dt_transient(table: &mut McTable, runs: usize) -> Result<()> {
    let (n, pre, sigma) = (256usize, 300usize, 0.05);
    let plain = Rational::discrete(2, 1, TS)?;
    let with = plain.clone().with_transient()?;
    let (mut est_plain, mut est_with) = (Runs::default(), Runs::default());
    for r in progress::runs(runs, "DT transient") {
        let mut rng = Gauss::new(2000 + r as u64);
        let u = rng.white(pre + n, 1.0);
        let y = lfilter(&B, &A, &u);
        let ym = add(&y[pre..], &rng.white(n, sigma));
        let dft = TimeData::new(u[pre..].to_vec(), ym, TS)?.dft();
        let data = dft.with_noise(NoiseVariances::output_only(vec![sigma * sigma; n / 2 + 1]))?;
        let fit = Pipeline::default().fit(&plain, &data)?;
        let (v, s) = dt_report(&fit);
        est_plain.push(v, s);
        let fit = Pipeline::default().fit(&with, &data)?;
        let (v, s) = dt_report(&fit);
        est_with.push(v, s);
    }
    let truth = dt_truth_report();
    table.add(
        "ML, transient",
        "N=256, random x0",
        &DT_NAMES,
        &truth,
        &est_with,
    );
    table.add(
        "ML, no transient",
        "N=256, random x0",
        &DT_NAMES,
        &truth,
        &est_plain,
    );
    Ok(())
}

/// Case 3: a continuous-time system with a real pole at −0.3 (residue 0.8) and a pair at
/// −0.08 ± 1.1i (residue 0.2 − 0.9i) and direct term 0.4, driven by a piecewise-constant
/// white input (ZOH) from a fixed initial state, Ts = 0.7 s, N = 128, white output noise of
/// std 0.03 (variance estimated); the ZOH modal model with and without the transient.
fn case_zoh_modal(table: &mut McTable, runs: usize) -> Result<()> {
    let (ts, n, sigma): (f64, usize, f64) = (0.7, 128, 0.03);
    let real: (f64, f64) = (-0.3, 0.8);
    let pair = (C::new(-0.08, 1.1), C::new(0.2, -0.9));
    let (d, x0_real, x0_pair) = (0.4, 1.5, C::new(-0.7, 1.2));
    let simulate = |u: &[f64]| -> Vec<f64> {
        let (lr, er) = ((real.0 * ts).exp(), (real.0 * ts).exp_m1() / real.0);
        let (lp, ep) = ((pair.0 * ts).exp(), ((pair.0 * ts).exp() - 1.0) / pair.0);
        let (mut xr, mut xp) = (x0_real, x0_pair);
        u.iter()
            .map(|uk| {
                let y = d * uk + real.1 * xr + 2.0 * (pair.1 * xp).re;
                xr = lr * xr + er * uk;
                xp = lp * xp + ep * uk;
                y
            })
            .collect()
    };
    let input = Gauss::new(21).white(n, 1.0);
    let clean = simulate(&input);
    let (mut est_with, mut est_plain) = (Runs::default(), Runs::default());
    let report = |fit: &Fit<f64, fdid::model::Modal<f64>>| {
        let parts = fit.model().parts(fit.theta());
        let std = fit.theta_std().unwrap_or_else(|| vec![f64::NAN; 4]);
        (
            vec![
                parts.real_poles[0],
                parts.pair_poles[0].re,
                parts.pair_poles[0].im,
            ],
            vec![std[0], std[2], std[3]],
        )
    };
    for r in progress::runs(runs, "ZOH modal") {
        let mut rng = Gauss::new(3000 + r as u64);
        let y = add(&clean, &rng.white(n, sigma));
        let data = TimeData::new(input.clone(), y, ts)?.dft();
        let opts = ModalOptions::zoh(ts).with_direct();
        let fit = fit_modal(&Pipeline::default(), &data, 1, 1, opts.with_transient())?;
        let (v, s) = report(&fit);
        est_with.push(v, s);
        let fit = fit_modal(&Pipeline::default(), &data, 1, 1, opts)?;
        let (v, s) = report(&fit);
        est_plain.push(v, s);
    }
    let names = ["p real", "Re p pair", "Im p pair"];
    let truth = [real.0, pair.0.re, pair.0.im];
    table.add(
        "modal, transient",
        "ZOH, Ts=0.7, N=128",
        &names,
        &truth,
        &est_with,
    );
    table.add(
        "modal, no trans.",
        "ZOH, Ts=0.7, N=128",
        &names,
        &truth,
        &est_plain,
    );
    Ok(())
}

/// Case 4: a periodic white input (N = 2048, one period after whole periods of warm-up)
/// and ARMA noise H = (1 + 0.5z⁻¹)/(1 − 0.9z⁻¹) with innovations of std 0.05 (|H| from 15
/// at DC to 0.26 at Nyquist); ML with the noise model against flat-weighted ML, both on
/// the lines between DC and Nyquist.
fn case_noise_model(table: &mut McTable, runs: usize) -> Result<()> {
    let (n, sigma) = (2048usize, 0.05);
    let (c, dd) = ([1.0, 0.5], [1.0, -0.9]);
    let model = Rational::discrete(2, 1, TS)?;
    let (mut est_nm, mut est_flat) = (Runs::default(), Runs::default());
    for r in progress::runs(runs, "noise model") {
        let mut rng = Gauss::new(4000 + r as u64);
        let periods = 2;
        let one = rng.white(n, 1.0);
        let u: Vec<f64> = (0..periods * n).map(|t| one[t % n]).collect();
        let e = rng.white(periods * n, sigma);
        let y = add(&lfilter(&B, &A, &u), &lfilter(&c, &dd, &e));
        let start = (periods - 1) * n;
        let data = TimeData::new(u[start..].to_vec(), y[start..].to_vec(), TS)?.dft();
        let fit = fit_noise_model(&Pipeline::default(), &model, &data, 1, 1)?;
        let (v, s) = dt_report(&fit);
        est_nm.push(v, s);
        let fit = Pipeline::default().fit(&model, &interior_lines(&data)?)?;
        let (v, s) = dt_report(&fit);
        est_flat.push(v, s);
    }
    let truth = dt_truth_report();
    table.add(
        "ML + noise model",
        "ARMA noise, N=2048",
        &DT_NAMES,
        &truth,
        &est_nm,
    );
    table.add(
        "ML, flat (eq. 25)",
        "ARMA noise, N=2048",
        &DT_NAMES,
        &truth,
        &est_flat,
    );
    Ok(())
}

/// Case 5: the periodic record of case 1 with white noise on the measured input too (input
/// SNR 10 dB on the excited lines), P = 8; errors-in-variables ML against output-error ML.
fn case_eiv(table: &mut McTable, runs: usize) -> Result<()> {
    let model = Rational::discrete(2, 1, TS)?;
    let sigma_u = 10f64.powf(-10.0 / 20.0);
    let (mut est_eiv, mut est_oe) = (Runs::default(), Runs::default());
    for r in progress::runs(runs, "EIV") {
        let data = periodic_record(5000 + r as u64, 8, sigma_u, 0.05);
        let fit = fit_eiv(&Pipeline::default(), &model, &data)?;
        let (v, s) = dt_report(&fit);
        est_eiv.push(v, s);
        let fit = Pipeline::default().fit(&model, &data)?;
        let (v, s) = dt_report(&fit);
        est_oe.push(v, s);
    }
    let truth = dt_truth_report();
    table.add(
        "EIV ML (eq. 42)",
        "input SNR 10 dB, P=8",
        &DT_NAMES,
        &truth,
        &est_eiv,
    );
    table.add(
        "OE ML (eq. 23)",
        "input SNR 10 dB, P=8",
        &DT_NAMES,
        &truth,
        &est_oe,
    );
    Ok(())
}

/// One Monte Carlo case: adds its rows for the given number of runs.
type Case = fn(&mut McTable, usize) -> Result<()>;

fn main() -> Result<()> {
    let runs: usize = match std::env::args().nth(1) {
        None => 1000,
        Some(a) => {
            a.parse()
                .ok()
                .filter(|r| *r >= 2)
                .ok_or_else(|| FdidError::InvalidArgument {
                    name: "runs",
                    value: a.clone(),
                    reason: "the number of runs must be an integer ≥ 2".into(),
                })?
        }
    };
    println!("McKelvey estimators, {runs} Monte Carlo runs per case\n");
    let mut table = McTable::default();
    let cases: [(&str, Case); 5] = [
        ("periodic OE", case_periodic_oe),
        ("DT transient", case_dt_transient),
        ("ZOH modal", case_zoh_modal),
        ("noise model", case_noise_model),
        ("EIV", case_eiv),
    ];
    let mut times = vec![];
    for (name, case) in cases {
        let t = std::time::Instant::now();
        case(&mut table, runs)?;
        times.push(format!("{name} {:.1} s", t.elapsed().as_secs_f64()));
    }
    table.print();
    // the covariance with variances estimated from P periods is optimistic on average by
    // √(ν/(ν − 2) · (P − 2)/(P − 3)), ν = 2(P − 1) (see `ErrorsInVariables`)
    let (p, nu): (f64, f64) = (8.0, 14.0);
    println!(
        "\nWith variances from P = 8 periods the expected RMSE/pred is {:.2} (known \
         variances: 1).\nTimes: {}",
        (nu / (nu - 2.0) * (p - 2.0) / (p - 3.0)).sqrt(),
        times.join(", ")
    );
    Ok(())
}
