//! The measurement-level detectors of the workflow: input noise (→ errors-in-variables),
//! nonlinear distortion (the model stays the best linear approximation, the noise
//! reference becomes noise + distortion) and time variation (outside the LTI class), on
//! simulated periodic records: the hidden effect named first, false alarms on clean data,
//! coverage of the truth, a Monte Carlo of the EIV step, typed errors.
//!
//! The ignored tests run with
//! `cargo test --release --all-features --test suite workflow_measurement:: -- --ignored --nocapture`.

use crate::measurement::{ALPHA, BAND, CLEAN, M, Sim, context, run, simulate, truth};
use fdid::estimate::Method;
use fdid::prelude::*;
use fdid::simulate::OddMultisineDesign;
use fdid::workflow::detectors::{InputNoise, NonlinearDistortion, TimeVariation};
use fdid::workflow::{
    Acceptance, Context, Detector, Effect, ModelSpec, Report, Workflow, fit_spec,
};
use quickcheck::{Arbitrary, Gen, TestResult};

/// Fraction of lines where the truth lies within 2.45 σ_G of the final response
/// (|Ĝ − G|²/σ_G² ~ Exp(1) to first order: 99.75 % expected).
fn coverage(report: &Report, g: impl Fn(f64) -> Complex<f64>) -> f64 {
    let f = &report.final_fit;
    let std = f.response_std.as_ref().unwrap();
    let inside = f
        .omega
        .iter()
        .zip(f.response.iter().zip(std))
        .filter(|(w, (gh, s))| (**gh - g(**w)).norm() <= 2.45 * **s)
        .count();
    inside as f64 / f.omega.len() as f64
}

// ---------------------------------------------------------------- input noise

/// Input SNR 10 dB per line (P = 8): output-error ML is biased; `input_noise` is named
/// first, the final criterion is EIV, the final model is consistent with the noise and
/// covers the truth.
#[test]
fn hidden_input_noise_is_named_first() {
    let sim = Sim {
        periods: 8,
        input_snr_db: Some(10.0),
        ..CLEAN
    };
    let seeds = 10;
    let (mut first, mut consistent, mut only) = (0, 0, 0);
    for seed in 0..seeds {
        let (report, _) = run(&sim, 100 + seed);
        let cov = coverage(&report, |w| truth(&sim, w));
        println!(
            "seed {seed}: effects {:?} consistent {} coverage {cov:.3} detail {:?}",
            report.effects,
            report.consistent_with_noise,
            report.steps.first().map(|s| &s.detail)
        );
        if report.effects.first() == Some(&Effect::InputNoise) {
            first += 1;
            assert_eq!(report.steps[0].acceptance(), Acceptance::Criterion);
        }
        assert_eq!(report.final_fit.spec.criterion, Method::Eiv);
        assert!(cov >= 0.9, "seed {seed}: coverage {cov}");
        if report.consistent_with_noise {
            consistent += 1;
        }
        if report.effects.len() == 1 {
            only += 1;
        }
    }
    println!(
        "input noise first {first}/{seeds}, consistent {consistent}/{seeds}, no other effect {only}/{seeds}"
    );
    assert_eq!(first, seeds);
    assert!(consistent >= seeds - 2);
    assert!(only >= seeds - 2);
}

/// Monte Carlo of the input-noise step (P = 8, input SNR 10 dB). Per run, the mean
/// relative gain error d = mean_k Re((Ĝ_k − G_k)/G_k) over the lines: the output-error
/// start shrinks the gain (d < 0 by more than 3 standard errors of the MC mean: it weights
/// the lines by the output noise alone), the final EIV fit does not (|d̄| < 3 SE). The
/// EIV sample spread of Ĝ_k matches the predicted σ_G up to the factor of sample
/// variances, √(ν/(ν − 2)·(P − 2)/(P − 3)) = 1.18 for ν = 2(P − 1) (Schoukens et al.,
/// Automatica 33(6), 1997; see tests/estimators_eiv.rs), on average over the lines.
fn input_noise_monte_carlo(runs: usize) {
    let sim = Sim {
        periods: 8,
        input_snr_db: Some(10.0),
        ..CLEAN
    };
    let mut d_oe = vec![];
    let mut d_eiv = vec![];
    let mut eiv = vec![];
    let mut std = vec![];
    let mut omega = vec![];
    for r in 0..runs {
        let (report, _) = run(&sim, 5000 + r as u64);
        assert_eq!(report.final_fit.spec.criterion, Method::Eiv);
        omega = report.final_fit.omega.clone();
        let rel = |g: &[Complex<f64>]| {
            omega
                .iter()
                .zip(g)
                .map(|(w, gh)| ((gh - truth(&sim, *w)) / truth(&sim, *w)).re)
                .sum::<f64>()
                / omega.len() as f64
        };
        d_oe.push(rel(&report.initial_fit.response));
        d_eiv.push(rel(&report.final_fit.response));
        eiv.push(report.final_fit.response.clone());
        std.push(report.final_fit.response_std.clone().unwrap());
    }
    let rn = runs as f64;
    let mean_se = |d: &[f64]| {
        let m = d.iter().sum::<f64>() / rn;
        let v = d.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (rn - 1.0);
        (m, (v / rn).sqrt())
    };
    let (mo, so) = mean_se(&d_oe);
    let (me, se) = mean_se(&d_eiv);
    let n = omega.len();
    let mut ratio_sum = 0.0;
    for k in 0..n {
        let mean = eiv.iter().map(|e| e[k]).sum::<Complex<f64>>() / rn;
        let var = eiv.iter().map(|e| (e[k] - mean).norm_sqr()).sum::<f64>() / (rn - 1.0);
        let predicted = std.iter().map(|s| s[k] * s[k]).sum::<f64>() / rn;
        ratio_sum += (var / predicted).sqrt();
    }
    let ratio = ratio_sum / n as f64;
    let (p, nu) = (sim.periods as f64, 2.0 * (sim.periods as f64 - 1.0));
    let expected = (nu / (nu - 2.0) * (p - 2.0) / (p - 3.0)).sqrt();
    println!(
        "{runs} runs: relative gain error OE {mo:+.2e} ({:+.1} SE), EIV {me:+.2e} ({:+.1} SE); \
         EIV std sample/predicted {ratio:.3} (expected {expected:.3})",
        mo / so,
        me / se
    );
    assert!(mo / so < -3.0, "the output-error start shows no gain bias");
    assert!(
        (me / se).abs() < 3.0,
        "EIV gain bias {me:e} = {:.1} SE",
        me / se
    );
    let tol = 3.0 / (2.0 * (rn - 1.0)).sqrt() + 0.05;
    assert!(
        (ratio / expected - 1.0).abs() < tol,
        "std ratio {ratio:.3} vs {expected:.3} (tolerance {tol:.3})"
    );
}

#[test]
fn input_noise_monte_carlo_fast() {
    input_noise_monte_carlo(40);
}

#[test]
#[ignore = "long Monte Carlo (200 runs); see the file header"]
fn input_noise_monte_carlo_long() {
    input_noise_monte_carlo(200);
}

// ---------------------------------------------------------------- distortion

/// A cubic output nonlinearity (distortion about 10 dB above the noise at the excited
/// lines): `nonlinear_distortion` is named first, the model stays the (2, 2) linear one
/// (the best linear approximation), the effect is reported as unmodelled and the final
/// fit is judged against noise + distortion.
#[test]
fn hidden_distortion_is_named_first() {
    let sim = Sim {
        cubic: 0.007,
        ..CLEAN
    };
    let seeds = 10;
    let (mut first, mut consistent) = (0, 0);
    for seed in 0..seeds {
        let (report, _) = run(&sim, 200 + seed);
        let step = report.steps.first();
        println!(
            "seed {seed}: effects {:?} consistent {} spec ({}, {}) detail {:?}",
            report.effects,
            report.consistent_with_noise,
            report.final_fit.spec.na,
            report.final_fit.spec.nb,
            step.map(|s| &s.detail)
        );
        let v = &report.final_fit.validation;
        println!(
            "  cost {:.1} expected {:?} p {:?} whiteness p {:?}",
            v.cost, v.cost_expected, v.cost_p, v.whiteness_p
        );
        if report.effects.first() == Some(&Effect::NonlinearDistortion) {
            first += 1;
            let step = step.unwrap();
            assert_eq!(step.acceptance(), Acceptance::NoiseReference);
            let detail = step.detail.nonlinear_distortion().unwrap();
            let d = detail.distortion_to_noise_db.unwrap();
            assert!(d > 3.0 && d < 25.0, "distortion to noise {d} dB");
            assert!(detail.odd_p.unwrap() < 1e-6);
            assert!(step.cost_after < step.cost_before);
        }
        assert!(report.unmodelled.contains(&Effect::NonlinearDistortion));
        if report.consistent_with_noise {
            consistent += 1;
        }
    }
    println!(
        "distortion first {first}/{seeds}, consistent with noise + distortion {consistent}/{seeds}"
    );
    assert_eq!(first, seeds);
    assert!(consistent >= seeds - 2);
}

// ---------------------------------------------------------------- time variation

/// a₁ drifting by 0.05 over the record (the poles move by about 2 % in radius): the
/// skirts around the excited lines name `time_variation` first; the LTI model cannot absorb
/// it, the refinement stops and the effect is reported as unmodelled.
#[test]
fn hidden_time_variation_is_named_first() {
    let sim = Sim {
        drift: 0.05,
        ..CLEAN
    };
    let seeds = 10;
    let mut first = 0;
    for seed in 0..seeds {
        let (report, _) = run(&sim, 300 + seed);
        println!(
            "seed {seed}: effects {:?} consistent {} detail {:?}",
            report.effects,
            report.consistent_with_noise,
            report.steps.first().map(|s| &s.detail)
        );
        if report.effects.first() == Some(&Effect::TimeVariation) {
            first += 1;
            // the default workflow switches to the piecewise time-invariant model
            let step = report.steps.last().unwrap();
            assert_eq!(step.effect, Effect::TimeVariation);
            assert_eq!(step.acceptance(), Acceptance::Piecewise);
            assert!(step.cost_after < step.cost_before);
            let tests = step.detail.time_variation_tests().unwrap();
            assert!(tests.skirt.unwrap().skirt_ratio > 1.0);
            let tv = report.time_varying.as_ref().unwrap();
            // honest: the verdict is the segment models' own tests
            assert_eq!(
                report.consistent_with_noise,
                tv.consistent_with_noise(ALPHA)
            );
            let absorbed = !report.unmodelled.contains(&Effect::TimeVariation);
            assert_eq!(absorbed, report.consistent_with_noise);
        }
    }
    println!("time variation first {first}/{seeds}");
    assert_eq!(first, seeds);
}

// ---------------------------------------------------------------- false alarms

/// Each new detector's rejection rate on fits of the correct model to clean periodic
/// records (input noise at 80 dB SNR for the input-noise test, a negligible effect),
/// and the workflow's rate of naming any effect.
fn false_alarms(seeds: u64, limit: f64) {
    let sim = Sim {
        input_snr_db: Some(80.0),
        ..CLEAN
    };
    let detectors: [&dyn Detector; 3] = [&InputNoise, &NonlinearDistortion, &TimeVariation];
    let mut fired = [0usize; 3];
    let mut workflow = 0;
    for seed in 0..seeds {
        let (record, data) = simulate(&sim, 10_000 + seed);
        let ctx = context(&sim, record);
        let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
        for (d, n) in detectors.iter().zip(fired.iter_mut()) {
            let f = d.detect(&data, &fit, &ctx).unwrap();
            assert!(
                (0.0..=1.0).contains(&f.p_value),
                "{}: {}",
                d.effect(),
                f.p_value
            );
            if f.p_value < ALPHA {
                *n += 1;
            }
        }
        let report = Workflow::default()
            .run(&data, ModelSpec::discrete(2, 2, 1.0), ctx)
            .unwrap();
        if !report.effects.is_empty() {
            workflow += 1;
        }
    }
    for (d, n) in detectors.iter().zip(fired) {
        let rate = n as f64 / seeds as f64;
        println!("{}: false-alarm rate {rate} ({n}/{seeds})", d.effect());
        assert!(rate <= limit, "{}: {rate}", d.effect());
    }
    let rate = workflow as f64 / seeds as f64;
    println!("workflow: any effect named on {rate} ({workflow}/{seeds})");
    assert!(rate <= limit, "workflow: {rate}");
}

/// 40 seeds: each rate at most 0.15 (α = 0.05 plus 3.2 binomial standard errors).
#[test]
fn clean_records_false_alarm_rate_fast() {
    false_alarms(40, 0.15);
}

/// 200 seeds: each rate at most α + 3 binomial standard errors (0.096).
#[test]
#[ignore = "200 seeds; see the file header"]
fn clean_records_false_alarm_rate_long() {
    false_alarms(200, ALPHA + 3.0 * (ALPHA * (1.0 - ALPHA) / 200.0).sqrt());
}

/// Without the record or input noise the new detectors do not apply, so the existing
/// behaviour is kept: exact input samples (zero sample input variance) and no record.
#[test]
fn detectors_without_their_information_do_not_apply() {
    let (record, data) = simulate(&CLEAN, 1);
    let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
    let bare = Context::periodic(ALPHA);
    assert!(InputNoise.detect(&data, &fit, &bare).is_none());
    assert!(NonlinearDistortion.detect(&data, &fit, &bare).is_none());
    assert!(TimeVariation.detect(&data, &fit, &bare).is_none());
    // three periods: too few for the skirt test (P ≥ 4)
    let short = TimeData::new(
        record.u()[..3 * M].to_vec(),
        record.y()[..3 * M].to_vec(),
        1.0,
    )
    .unwrap();
    let ctx = Context::periodic(ALPHA).with_record(short, 3).unwrap();
    assert!(TimeVariation.detect(&data, &fit, &ctx).is_none());
    // a record whose period grid does not hold the fitted lines
    let other = TimeData::new(
        record.u()[..6 * 500].to_vec(),
        record.y()[..6 * 500].to_vec(),
        1.0,
    )
    .unwrap();
    let ctx = Context::periodic(ALPHA).with_record(other, 6).unwrap();
    assert!(TimeVariation.detect(&data, &fit, &ctx).is_none());
    assert!(NonlinearDistortion.detect(&data, &fit, &ctx).is_none());
    // an EIV fit: the input-noise test is done
    let noisy = Sim {
        input_snr_db: Some(10.0),
        ..CLEAN
    };
    let (_, data) = simulate(&noisy, 2);
    let spec = ModelSpec {
        criterion: Method::Eiv,
        ..ModelSpec::discrete(2, 2, 1.0)
    };
    let fit = fit_spec(&spec, &data).unwrap();
    assert!(InputNoise.detect(&data, &fit, &bare).is_none());
}

/// Bad measurement information is a typed error naming the value.
#[test]
fn bad_record_is_a_typed_error() {
    let (record, _) = simulate(&CLEAN, 3);
    for periods in [0, 1, 7] {
        match Context::periodic(ALPHA).with_record(record.clone(), periods) {
            Err(FdidError::InvalidArgument { name, value, .. }) => {
                assert_eq!(name, "periods");
                assert_eq!(value, periods.to_string());
            }
            other => panic!("periods {periods}: expected InvalidArgument, got {other:?}"),
        }
    }
    let tiny = TimeData::new(vec![0.0; 6], vec![0.0; 6], 1.0).unwrap();
    match Context::periodic(ALPHA).with_record(tiny, 2) {
        Err(FdidError::TooShort { needed, got, .. }) => assert_eq!((needed, got), (4, 3)),
        other => panic!("expected TooShort, got {other:?}"),
    }
}

// ---------------------------------------------------------------- properties

/// A random stable second-order truth (pole radius 0.5 … 0.9, angle 0.3 … 2.5 rad) and
/// a seed.
#[derive(Debug, Clone, Copy)]
struct Case {
    radius: f64,
    angle: f64,
    seed: u64,
}

impl Arbitrary for Case {
    fn arbitrary(g: &mut Gen) -> Self {
        let unit = |g: &mut Gen| (u32::arbitrary(g) as f64) / u32::MAX as f64;
        Self {
            radius: 0.5 + 0.4 * unit(g),
            angle: 0.3 + 2.2 * unit(g),
            seed: u64::arbitrary(g) % 1_000_000,
        }
    }
}

impl Case {
    fn sim(&self, base: Sim) -> Sim {
        Sim {
            a: [
                1.0,
                -2.0 * self.radius * self.angle.cos(),
                self.radius * self.radius,
            ],
            ..base
        }
    }
}

/// On random systems, each strong effect is named first: input SNR 0 dB, a cubic term
/// c x³ with c x_rms² = 0.05, a₁ drifting by 0.2; output noise 2 % of x_rms.
#[test]
fn strong_effects_are_named_first_on_random_systems() {
    fn prop(case: Case) -> TestResult {
        let cases = [
            (
                Sim {
                    periods: 8,
                    input_snr_db: Some(0.0),
                    ..CLEAN
                },
                Effect::InputNoise,
            ),
            (
                Sim {
                    cubic: 0.05,
                    ..CLEAN
                },
                Effect::NonlinearDistortion,
            ),
            (
                Sim {
                    drift: 0.2,
                    ..CLEAN
                },
                Effect::TimeVariation,
            ),
        ];
        for (base, effect) in cases {
            let mut sim = case.sim(base);
            // effect sizes relative to the output: x_rms² = mean_k |G_k|² (unit-RMS input)
            let design = OddMultisineDesign::new(BAND, 3, 17).unwrap();
            let x2 = design
                .excited()
                .iter()
                .map(|k| truth(&sim, std::f64::consts::TAU * *k as f64 / M as f64).norm_sqr())
                .sum::<f64>()
                / design.excited().len() as f64;
            sim.sigma_y = 0.02 * x2.sqrt();
            sim.cubic *= 1.0 / x2;
            let (report, _) = run(&sim, case.seed);
            if report.effects.first() != Some(&effect) {
                println!("{case:?}: {effect} expected, got {:?}", report.effects);
                return TestResult::failed();
            }
        }
        TestResult::passed()
    }
    crate::common::seeded(0xbae26291)
        .tests(10)
        .quickcheck(prop as fn(Case) -> TestResult);
}
