//! Periodic records with several inputs and outputs (`MimoSpectra::from_periods`, `fdid
//! fit --input u1,u2 --output y1,y2 --periods P --skip-periods K`): the spectra averaged
//! over the periods, the ny × ny output noise covariance between periods against the
//! simulated one, the fit weighted by the output variances, and the refusals.

use super::mimo::{Case, Draw, pole_error};
use super::mimo_records::{TS, simulate, z_model};
use fdid::data::MimoSpectra;
use fdid::mimo::{CommonPoleOptions, fit_common_poles_spectra};
use fdid::prelude::*;

const CASE: Case = Case {
    seed: 7,
    ny: 2,
    nu: 2,
    pairs: 2,
    real: 1,
};
/// Samples per period, periods in the record (the first is dropped as a transient).
const M: usize = 256;
const PERIODS: usize = 9;
/// Output noise: e₁ = σa, e₂ = σ(ρa + √(1 − ρ²)b) with a, b independent, unit variance.
const SIGMA: f64 = 0.02;
const RHO: f64 = 0.6;

/// A periodic record of [`CASE`]: two inputs repeating one random period, the outputs
/// from random initial states with correlated noise; returns (u, y).
fn periodic_record() -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let model = z_model(&CASE, true);
    let mut d = Draw(0x00c0_ffee);
    let u: Vec<Vec<f64>> = (0..CASE.nu)
        .map(|_| {
            let period: Vec<f64> = (0..M).map(|_| d.signed()).collect();
            period.iter().cycle().take(M * PERIODS).copied().collect()
        })
        .collect();
    let mut y = simulate(&model, &u, &mut d);
    // unit-variance noise: uniform on ±√3
    let s3 = 3f64.sqrt();
    let (first, second) = y.split_at_mut(1);
    for (y1, y2) in first[0].iter_mut().zip(second[0].iter_mut()) {
        let (a, b) = (s3 * d.signed(), s3 * d.signed());
        *y1 += SIGMA * a;
        *y2 += SIGMA * (RHO * a + (1.0 - RHO * RHO).sqrt() * b);
    }
    (u, y)
}

fn steady(x: &[Vec<f64>]) -> Vec<Vec<f64>> {
    x.iter().map(|c| c[M..].to_vec()).collect()
}

/// The covariance of the averaged outputs matches the simulated noise: σ²/P on the
/// diagonal (a white sequence of variance σ² has that variance on every DFT line) and
/// correlation ρ between the outputs, each averaged over the lines.
#[test]
fn output_noise_covariance_between_periods() {
    let (u, y) = periodic_record();
    let kept = PERIODS - 1;
    let s = MimoSpectra::from_periods(steady(&u), steady(&y), TS, kept).unwrap();
    assert_eq!(s.len(), M / 2 + 1);
    let noise = s.noise().expect("noise from 8 periods");
    assert_eq!(noise.periods(), kept);
    let lines = 1..M / 2; // DC and Nyquist are real lines
    let count = lines.len() as f64;
    let expected = SIGMA * SIGMA / kept as f64;
    let (mut v0, mut v1, mut rho) = (0.0, 0.0, 0.0);
    for k in lines {
        let c = noise.output_covariance(k);
        v0 += c[(0, 0)].re / count;
        v1 += c[(1, 1)].re / count;
        rho += c[(0, 1)].re / (c[(0, 0)].re * c[(1, 1)].re).sqrt() / count;
        // Hermitian
        assert!((c[(0, 1)] - c[(1, 0)].conj()).norm() <= 1e-15 * c[(0, 0)].re);
    }
    // 127 lines × 7 degrees of freedom: the means are within a few per cent
    for (name, v) in [("output 1", v0), ("output 2", v1)] {
        assert!(
            (v / expected - 1.0).abs() < 0.1,
            "{name}: {v:e} vs {expected:e}"
        );
    }
    assert!((rho - RHO).abs() < 0.05, "correlation {rho}");
    assert_eq!(noise.output_variance(1).len(), s.len());
    // the inputs repeat exactly: no input noise
    assert!(noise.input_variance(0).iter().all(|v| *v < 1e-25));
    // the band keeps the noise of its lines
    let (band, first) = band_and_first_line(&s);
    assert_eq!(
        band.noise().unwrap().output_covariance(0),
        noise.output_covariance(first)
    );
}

/// Input noise seen by the output: one input, u = a repeating period + n, two outputs
/// y₁ = 0.5 n + e₁ and y₂ = e₂ (e independent of n), 8 periods of 256 samples. The
/// output–input cross covariance between periods, averaged over the lines, is 0.5 of the
/// input variance for y₁ and zero for y₂ (within 0.05 of the input variance); band
/// selection keeps it.
#[test]
fn output_input_cross_covariance_between_periods() {
    let periods = 8;
    let mut d = Draw(0x0dd_ba11);
    let period: Vec<f64> = (0..M).map(|_| d.signed()).collect();
    let n: Vec<f64> = (0..M * periods).map(|_| 0.1 * d.signed()).collect();
    let u: Vec<f64> = (0..M * periods).map(|t| period[t % M] + n[t]).collect();
    let y1: Vec<f64> = (0..M * periods)
        .map(|t| 0.5 * n[t] + 0.05 * d.signed())
        .collect();
    let y2: Vec<f64> = (0..M * periods).map(|_| 0.05 * d.signed()).collect();
    let s = MimoSpectra::from_periods(vec![u], vec![y1, y2], TS, periods).unwrap();
    let noise = s.noise().unwrap();
    let lines = 1..M / 2;
    let count = lines.len() as f64;
    let (mut ratio1, mut ratio2) = (0.0, 0.0);
    for k in lines {
        let c = noise.cross_covariance(k);
        let var_u = noise.input_variance(0)[k];
        ratio1 += c[(0, 0)].re / var_u / count;
        ratio2 += c[(1, 0)].re / var_u / count;
    }
    assert!((ratio1 - 0.5).abs() < 0.05, "c_y1u / var_u = {ratio1}");
    assert!(ratio2.abs() < 0.05, "c_y2u / var_u = {ratio2}");
    let (band, first) = band_and_first_line(&s);
    assert_eq!(
        band.noise().unwrap().cross_covariance(0),
        noise.cross_covariance(first)
    );
}

/// The 0.2–0.8 Hz band of `s` and the index in `s` of its first line.
fn band_and_first_line(s: &MimoSpectra<f64>) -> (MimoSpectra<f64>, usize) {
    let band = s.band_hz(0.2, 0.8).unwrap();
    let first = s
        .omega()
        .iter()
        .position(|w| *w == band.omega()[0])
        .unwrap();
    (band, first)
}

/// The record averaged over its periods (DC dropped) and its common-pole fit with a
/// direct term (weighted by the full output covariance when `full_covariance`), whose
/// poles are checked to 1 % of the truth.
fn fit_averaged_record(
    full_covariance: bool,
) -> (MimoSpectra<f64>, fdid::mimo::CommonPoleFit<f64>) {
    let (u, y) = periodic_record();
    let s = MimoSpectra::from_periods(steady(&u), steady(&y), TS, PERIODS - 1).unwrap();
    let keep: Vec<bool> = s.omega().iter().map(|w| *w > 0.0).collect();
    let s = s.select_lines(&keep).unwrap();
    let model = z_model(&CASE, true);
    let options = CommonPoleOptions {
        domain: Domain::Discrete { ts: TS },
        direct: true,
        full_covariance,
        ..CommonPoleOptions::default()
    };
    let fit = fit_common_poles_spectra(&s, model.order(), &options).unwrap();
    let err = pole_error(&model.poles, &fit.model.poles);
    assert!(err < 0.01, "pole error {err:e}");
    (s, fit)
}

/// The averaged record is fitted weighted by the output variances: the poles are found
/// and the weighted cost per complex equation is near the 1.17 that the inverse of a
/// variance estimated with 7 complex degrees of freedom gives (ν/(ν − 2), ν = 14).
#[test]
fn weighted_fit_of_the_averaged_record() {
    let (s, fit) = fit_averaged_record(false);
    assert!(fit.weighted && !fit.correlated);
    let per_equation = fit.cost / (s.len() * s.ny()) as f64;
    // the unweighted residual power is the noise of the mean, σ²/8 per line and output
    let power = fit.residual_power.iter().sum::<f64>() / (s.len() * s.ny()) as f64;
    let noise = SIGMA * SIGMA / (PERIODS - 1) as f64;
    assert!(
        (0.6..1.2).contains(&(power / noise)),
        "residual power {power:e} vs {noise:e}"
    );
    assert!(
        (0.85..1.5).contains(&per_equation),
        "weighted cost per line and output {per_equation}"
    );
}

/// The same record weighted by the full 2 × 2 output covariance between periods (the
/// noise is correlated, ρ = 0.6): the poles are found and the cost per complex equation
/// is above one, as the inverse of a 2 × 2 covariance estimated with ν = 7 complex degrees
/// of freedom inflates it (ν/(ν − ny) = 1.4 for Gaussian noise, 1.29 with the 39 fitted
/// parameters taken off; 1.12 measured with this uniform noise, whose sample covariance
/// spreads less).
#[test]
fn full_covariance_fit_of_the_averaged_record() {
    let (s, fit) = fit_averaged_record(true);
    assert!(fit.correlated);
    let per_equation = fit.cost / (s.len() * s.ny()) as f64;
    assert!(
        (1.0..1.8).contains(&per_equation),
        "whitened cost per line and output {per_equation}"
    );
}

#[test]
fn inputs_that_do_not_repeat_are_refused_naming_the_input() {
    let (mut u, y) = periodic_record();
    let mut d = Draw(99);
    for v in u[1].iter_mut() {
        *v = d.signed();
    }
    let err = MimoSpectra::from_periods(u, y, TS, PERIODS)
        .unwrap_err()
        .to_string();
    assert!(err.contains("input 2") && err.contains("repeat"), "{err}");
}

#[cfg(feature = "cli")]
fn csv(u: &[Vec<f64>], y: &[Vec<f64>]) -> String {
    let mut text = String::from("t,u1,u2,y1,y2\n");
    for t in 0..u[0].len() {
        text += &format!(
            "{},{},{},{},{}\n",
            t as f64 * TS,
            u[0][t],
            u[1][t],
            y[0][t],
            y[1][t]
        );
    }
    text
}

#[cfg(feature = "cli")]
#[test]
fn command_averages_the_periods_and_reports_the_noise() {
    use crate::cli_common::{Scratch, fdid, json_of, stderr};
    let (u, y) = periodic_record();
    let scratch = Scratch::new("mimo_periodic");
    let path = scratch.file("record.csv", &csv(&u, &y));
    let path = path.to_str().unwrap();
    let order = z_model(&CASE, true).order().to_string();
    let base = [
        "fit",
        path,
        "--input",
        "u1,u2",
        "--output",
        "y1,y2",
        "--domain",
        "z",
        "--na",
        &order,
        "--nb",
        &order,
        "--transient",
    ];
    let mut args = base.to_vec();
    args.extend(["--periods", "9", "--skip-periods", "1", "--json"]);
    let v = json_of(&fdid(&args));
    assert_eq!(v["noise"]["periods"], 8);
    assert_eq!(v["weighted"], true);
    let rho = v["noise"]["output_correlation"][0][1].as_f64().unwrap();
    // mean |ρ| over the lines: near 0.6 (|·| of a sample correlation is biased up a bit)
    assert!((0.55..0.75).contains(&rho), "{rho}");
    assert_eq!(v["lines"], M / 2);
    // errors in the data's units (not weighted): at the noise of the mean, σ/√8
    let floor = SIGMA / 8f64.sqrt();
    let rms = v["rms_error"].as_f64().unwrap();
    assert!(
        (0.7 * floor..1.2 * floor).contains(&rms),
        "rms error {rms:e}, noise {floor:e}"
    );
    for output in v["output_errors"].as_array().unwrap() {
        let explained = output["explained"].as_f64().unwrap();
        assert!(explained > 0.95, "{output}");
    }
    // refusals: realisations, skip without periods, periods not dividing the record
    for (extra, says) in [
        (vec!["--realisations", "3"], "--realisations"),
        (vec!["--skip-periods", "1"], "needs --periods"),
        (vec!["--periods", "7"], "not a whole number of 7 periods"),
    ] {
        let mut args = base.to_vec();
        args.extend(extra);
        let out = fdid(&args);
        assert!(!out.status.success());
        assert!(stderr(&out).contains(says), "{}", stderr(&out));
    }
}
