//! `fit_spec` on random systems (noise-free recovery with and without a delay), its bad
//! inputs, the calibration of each detector on correct models, the delay's Monte Carlo
//! spread against its predicted standard deviation, and the JSON form of a report.
use crate::common;
use fdid::estimate::Method;

use common::{Noise, random_dt_system, rel_rms};
use fdid::prelude::*;
use fdid::workflow::detectors::{
    Added, ColoredNoise, MissingResonance, OrderIncrease, TimeDelay, Transient,
};
use fdid::workflow::{Context, Detector, ModelSpec, Workflow, fit_spec};
use quickcheck::TestResult;
use rand::{Rng, SeedableRng, rngs::StdRng};

/// The sample time `random_dt_system(seed, …)` draws first.
fn dt_ts(seed: u64) -> f64 {
    let mut rng = StdRng::seed_from_u64(seed);
    [0.001, 0.01, 0.1, 1.0][rng.gen_range(0..4usize)]
}

fn data_of(omega: &[f64], g: &[Complex<f64>], ts: f64) -> FrequencyData<f64> {
    let u = vec![Complex::new(1.0, 0.0); omega.len()];
    FrequencyData::new(omega.to_vec(), g.to_vec(), u, Some(ts)).unwrap()
}

#[test]
fn noise_free_recovery_on_random_systems() {
    fn prop(seed: u64, na: u8) -> TestResult {
        let na = (na % 3 + 1) as usize;
        let sys = random_dt_system(seed, na, na);
        let ts = dt_ts(seed);
        let g = sys.frf();
        let data = data_of(&sys.omega, &g, ts);
        let Ok(fit) = fit_spec(&ModelSpec::discrete(na, na, ts), &data) else {
            return TestResult::failed();
        };
        let err = rel_rms(&fit.response, &g);
        if err > 1e-8 {
            println!("seed {seed} na {na}: relative error {err:e}");
        }
        TestResult::from_bool(err < 1e-8)
    }
    crate::common::seeded(0xbf36613f)
        .tests(30)
        .quickcheck(prop as fn(u64, u8) -> TestResult);
}

#[test]
fn noise_free_delay_recovery_on_random_systems() {
    fn prop(seed: u64, frac: u8) -> TestResult {
        let sys = random_dt_system(seed, 2, 2);
        let ts = dt_ts(seed);
        let tau = (1.0 + f64::from(frac % 20) / 10.0) * ts;
        let g: Vec<Complex<f64>> = sys
            .frf()
            .iter()
            .zip(&sys.omega)
            .map(|(g, w)| g * Complex::new(0.0, -w * tau).exp())
            .collect();
        let data = data_of(&sys.omega, &g, ts);
        let spec = ModelSpec {
            delay: true,
            ..ModelSpec::discrete(2, 2, ts)
        };
        let Ok(fit) = fit_spec(&spec, &data) else {
            return TestResult::failed();
        };
        let err = rel_rms(&fit.response, &g);
        // a delay of whole samples trades with the numerator: compare responses
        if err > 1e-8 {
            println!(
                "seed {seed} tau {tau}: relative error {err:e}, delay {:?}",
                fit.delay
            );
        }
        TestResult::from_bool(err < 1e-8)
    }
    crate::common::seeded(0xc83151a9)
        .tests(20)
        .quickcheck(prop as fn(u64, u8) -> TestResult);
}

#[test]
fn bad_specs_are_typed_errors() {
    let omega: Vec<f64> = (1..=20).map(|k| k as f64 * 0.1).collect();
    let g = vec![Complex::new(1.0, 0.0); 20];
    let data = data_of(&omega, &g, 1.0);
    let eiv_noise = ModelSpec {
        noise_order: Some(1),
        criterion: Method::Eiv,
        ..ModelSpec::discrete(1, 1, 1.0)
    };
    match fit_spec(&eiv_noise, &data) {
        Err(FdidError::InvalidArgument { name, .. }) => assert_eq!(name, "noise_order"),
        other => panic!("{other:?}"),
    }
    let no_ts = FrequencyData::new(omega.clone(), g.clone(), g.clone(), None).unwrap();
    let ct_transient = ModelSpec {
        transient: true,
        ..ModelSpec::continuous(2, 1)
    };
    match fit_spec(&ct_transient, &no_ts) {
        Err(FdidError::InvalidArgument { name, .. }) => assert_eq!(name, "transient"),
        other => panic!("{other:?}"),
    }
    let bad_ts = ModelSpec {
        domain: Domain::Discrete { ts: -1.0 },
        ..ModelSpec::discrete(1, 1, 1.0)
    };
    assert!(fit_spec(&bad_ts, &data).is_err());
    // EIV without input noise variances
    let eiv = ModelSpec {
        criterion: Method::Eiv,
        ..ModelSpec::discrete(1, 1, 1.0)
    };
    assert!(fit_spec(&eiv, &data).is_err());
}

const B2: [f64; 3] = [0.2, 0.3, 0.1];
const A2: [f64; 3] = [1.0, -1.2, 0.72];

fn g2(w: f64) -> Complex<f64> {
    let zi = Complex::new(0.0, -w).exp();
    let p = |c: &[f64]| {
        c.iter()
            .rev()
            .fold(Complex::new(0.0, 0.0), |s, v| s * zi + *v)
    };
    p(&B2) / p(&A2)
}

/// 120 lines of G2 U + noise (variance `var`, given when `known`), random-phase input.
fn lines(seed: u64, var: f64, known: bool, tau: f64) -> FrequencyData<f64> {
    let n = 120;
    let mut noise = Noise::new(seed);
    let omega: Vec<f64> = (1..=n)
        .map(|k| k as f64 * std::f64::consts::PI / (n + 1) as f64)
        .collect();
    let u: Vec<Complex<f64>> = omega
        .iter()
        .map(|_| Complex::from_polar(1.0, 6.0 * noise.gauss()))
        .collect();
    let y: Vec<Complex<f64>> = omega
        .iter()
        .zip(&u)
        .map(|(w, u)| g2(*w) * Complex::new(0.0, -w * tau).exp() * u + noise.complex(var))
        .collect();
    let data = FrequencyData::new(omega, y, u, Some(1.0)).unwrap();
    if known {
        data.with_noise(NoiseVariances::output_only(vec![var; n]))
            .unwrap()
    } else {
        data
    }
}

/// Each detector's rejection rate at α = 0.05 on fits of the correct model: at most α
/// plus three binomial standard errors.
#[test]
fn detectors_are_calibrated_on_correct_models() {
    let alpha = 0.05;
    let seeds = 200;
    let limit = alpha + 3.0 * (alpha * (1.0 - alpha) / seeds as f64).sqrt();
    let detectors: [(&dyn Detector, bool, bool); 6] = [
        (&TimeDelay, true, true),
        (&OrderIncrease(Added::Pole), true, true),
        (&OrderIncrease(Added::Zero), false, true),
        (&MissingResonance, true, true),
        (&Transient, true, false),
        (&ColoredNoise, false, false),
    ];
    for (detector, known, periodic) in detectors {
        let ctx = Context {
            periodic,
            time_record: true,
            alpha,
            ..Context::periodic(alpha)
        };
        let mut fired = 0;
        for seed in 0..seeds {
            let data = lines(1000 + seed, 1e-3, known, 0.0);
            let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
            let finding = detector.detect(&data, &fit, &ctx).unwrap();
            assert!((0.0..=1.0).contains(&finding.p_value));
            if finding.p_value < alpha {
                fired += 1;
            }
        }
        let rate = fired as f64 / seeds as f64;
        println!(
            "{}: false-alarm rate {rate} over {seeds} seeds",
            detector.effect()
        );
        assert!(rate <= limit, "{}: {rate}", detector.effect());
    }
}

/// The delay estimate over noise realisations: bias and sample std against the std
/// predicted by the fit's covariance.
#[test]
fn delay_monte_carlo_matches_predicted_std() {
    let tau = 2.3;
    let runs = 100;
    let spec = ModelSpec {
        delay: true,
        ..ModelSpec::discrete(2, 2, 1.0)
    };
    let (mut est, mut pred) = (vec![], vec![]);
    for seed in 0..runs {
        let fit = fit_spec(&spec, &lines(2000 + seed, 1e-2, true, tau)).unwrap();
        let (t, s) = fit.delay.unwrap();
        est.push(t);
        pred.push(s.unwrap());
    }
    let mean = est.iter().sum::<f64>() / runs as f64;
    let std = (est.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / (runs - 1) as f64).sqrt();
    let predicted = pred.iter().sum::<f64>() / runs as f64;
    let bias = mean - tau;
    println!(
        "delay {tau}: bias {bias:e}, sample std {std:e}, predicted std {predicted:e}, ratio {}",
        std / predicted
    );
    assert!(bias.abs() < 3.0 * std / (runs as f64).sqrt() + 1e-3 * std);
    assert!(
        (0.75..1.3).contains(&(std / predicted)),
        "{}",
        std / predicted
    );
}

#[cfg(feature = "serde")]
#[test]
fn report_serialises_to_the_json_contract() {
    let data = lines(7, 1e-3, true, 2.0);
    let report = Workflow::default()
        .run(
            &data,
            ModelSpec::discrete(2, 2, 1.0),
            Context::periodic(0.05),
        )
        .unwrap();
    let v = serde_json::to_value(&report).unwrap();
    assert_eq!(v["effects"][0], "time_delay");
    let step = &v["steps"][0];
    assert_eq!(step["effect"], "time_delay");
    for key in ["p_value", "cost_before", "cost_after", "lr_p"] {
        assert!(step[key].is_number(), "{key}");
    }
    assert!(step["detail"]["slope"].is_number());
    assert!(v["consistent_with_noise"].is_boolean());
    assert!(v["final"]["cost"].is_number());
    assert_eq!(v["final"]["spec"]["delay"], true);
    // the detail round-trips
    let back: fdid::workflow::Report = serde_json::from_value(v).unwrap();
    assert_eq!(back.steps, report.steps);
}

/// Detection power of the delay against its size (in samples) and of a missing resonance
/// against its peak height (in noise standard deviations): 100 seeds per point.
/// Run with `cargo test --release --all-features --test suite workflow_spec:: -- --ignored --nocapture`.
#[test]
#[ignore]
fn power_table() {
    let seeds = 100;
    println!("delay (samples) | P(time_delay first)");
    for tau in [0.01, 0.02, 0.05, 0.1, 0.2, 0.5] {
        let mut hits = 0;
        for seed in 0..seeds {
            let report = Workflow::default()
                .run(
                    &lines(3000 + seed, 1e-3, true, tau),
                    ModelSpec::discrete(2, 2, 1.0),
                    Context::periodic(0.05),
                )
                .unwrap();
            if report.effects.first() == Some(&fdid::workflow::Effect::TimeDelay) {
                hits += 1;
            }
        }
        println!("{tau} | {}", hits as f64 / seeds as f64);
    }
    println!("resonance peak (noise std) | P(missing_resonance first)");
    let (r, th) = (0.98f64, 2.0f64);
    let mode = |w: f64, gain: f64| {
        let zi = Complex::new(0.0, -w).exp();
        zi * gain / (Complex::new(1.0, 0.0) - zi * (2.0 * r * th.cos()) + zi * zi * (r * r))
    };
    let var: f64 = 1e-3;
    for height in [1.0, 2.0, 3.0, 5.0, 8.0] {
        // the mode's peak |.| = height σ
        let gain = height * var.sqrt() / mode(th, 1.0).norm();
        let mut hits = 0;
        for seed in 0..seeds {
            let base = lines(4000 + seed, var, true, 0.0);
            let y: Vec<Complex<f64>> = base
                .y()
                .iter()
                .zip(base.u().iter().zip(base.omega()))
                .map(|(y, (u, w))| y + mode(*w, gain) * u)
                .collect();
            let data = FrequencyData::new(base.omega().to_vec(), y, base.u().to_vec(), Some(1.0))
                .unwrap()
                .with_noise(base.noise().unwrap().clone())
                .unwrap();
            let report = Workflow::default()
                .run(
                    &data,
                    ModelSpec::discrete(2, 2, 1.0),
                    Context::periodic(0.05),
                )
                .unwrap();
            if report.effects.first() == Some(&fdid::workflow::Effect::MissingResonance) {
                hits += 1;
            }
        }
        println!("{height} | {}", hits as f64 / seeds as f64);
    }
    println!("extra real pole p (truth G2/(1 − p z⁻¹)) | P(missing_pole first)");
    for pole in [0.05, 0.1, 0.2, 0.4] {
        let mut hits = 0;
        for seed in 0..seeds {
            let base = lines(5000 + seed, 1e-3, true, 0.0);
            let y: Vec<Complex<f64>> = base
                .u()
                .iter()
                .zip(base.omega())
                .zip(base.y())
                .map(|((u, w), y)| {
                    let zi = Complex::new(0.0, -w).exp();
                    let g = g2(*w);
                    // the noise of `base` plus the change of the response
                    y + (g / (Complex::new(1.0, 0.0) - zi * pole) - g) * u
                })
                .collect();
            let data = FrequencyData::new(base.omega().to_vec(), y, base.u().to_vec(), Some(1.0))
                .unwrap()
                .with_noise(base.noise().unwrap().clone())
                .unwrap();
            let report = Workflow::default()
                .run(
                    &data,
                    ModelSpec::discrete(2, 2, 1.0),
                    Context::periodic(0.05),
                )
                .unwrap();
            if report.effects.first() == Some(&fdid::workflow::Effect::MissingPole) {
                hits += 1;
            }
        }
        println!("{pole} | {}", hits as f64 / seeds as f64);
    }
}
