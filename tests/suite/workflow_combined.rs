//! The discrepancy workflow on combined hidden effects (a delay and a resonance together)
//! and on continuous-time models (a missing pole or zero in s, the calibration of the
//! order tests in s).
use crate::common;

use common::{Noise, logspace, on_threads};
use fdid::prelude::*;
use fdid::workflow::detectors::{Added, OrderIncrease};
use fdid::workflow::{
    Context, Detector, Effect, ModelSpec, Workflow, disagreement_bands, fit_spec,
};

const ALPHA: f64 = 0.05;

/// B(z⁻¹)/A(z⁻¹) of the second-order discrete-time truth.
const B2: [f64; 3] = [0.2, 0.3, 0.1];
const A2: [f64; 3] = [1.0, -1.2, 0.72];

fn poly(c: &[f64], x: Complex<f64>) -> Complex<f64> {
    c.iter()
        .rev()
        .fold(Complex::new(0.0, 0.0), |s, v| s * x + *v)
}

/// Y = G U + noise (variance `var`, given) on `omega`, random-phase unit input.
fn lines(
    omega: &[f64],
    g: impl Fn(f64) -> Complex<f64>,
    var: f64,
    ts: Option<f64>,
    seed: u64,
) -> FrequencyData<f64> {
    let mut noise = Noise::new(seed);
    let u: Vec<Complex<f64>> = omega
        .iter()
        .map(|_| Complex::from_polar(1.0, 6.0 * noise.gauss()))
        .collect();
    let y: Vec<Complex<f64>> = omega
        .iter()
        .zip(&u)
        .map(|(w, u)| g(*w) * u + noise.complex(var))
        .collect();
    FrequencyData::new(omega.to_vec(), y, u, ts)
        .unwrap()
        .with_noise(NoiseVariances::output_only(vec![var; omega.len()]))
        .unwrap()
}

/// Fraction of lines where the truth lies within 2.45 σ_G of the final response
/// (|Ĝ − G|²/σ_G² ~ Exp(1) to first order: 99.75 % expected).
fn coverage(report: &fdid::workflow::Report, g: impl Fn(f64) -> Complex<f64>) -> f64 {
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

/// A delay of 2.5 samples and an extra lightly damped mode at 2 rad/sample: both are
/// named (in either order), the final model is consistent with the noise and covers the
/// truth.
/// The delay (samples) of [`delayed_with_resonance`].
const TAU: f64 = 2.5;

/// The second-order truth with an extra lightly damped mode at 2 rad/sample, delayed by
/// [`TAU`] samples.
fn delayed_with_resonance(w: f64) -> Complex<f64> {
    let (r, th) = (0.98f64, 2.0f64);
    let ar = [1.0, -2.0 * r * th.cos(), r * r];
    let br = [0.0, 0.01, 0.0];
    let zi = Complex::new(0.0, -w).exp();
    (poly(&B2, zi) / poly(&A2, zi) + poly(&br, zi) / poly(&ar, zi))
        * Complex::new(0.0, -w * TAU).exp()
}

/// [`delayed_with_resonance`] on 160 lines below Nyquist (Ts = 1), noise variance 10⁻³.
fn delayed_with_resonance_data(seed: u64) -> FrequencyData<f64> {
    let n = 160;
    let omega: Vec<f64> = (1..=n)
        .map(|k| k as f64 * std::f64::consts::PI / (n + 1) as f64)
        .collect();
    lines(&omega, delayed_with_resonance, 1e-3, Some(1.0), seed)
}

#[test]
fn hidden_delay_and_resonance_are_both_found() {
    let (truth, tau) = (delayed_with_resonance, TAU);
    let seeds = 8;
    let (mut both, mut consistent, mut mean_cov) = (0, 0, 0.0);
    for seed in 0..seeds {
        let data = delayed_with_resonance_data(5000 + seed);
        let report = Workflow::default()
            .run(
                &data,
                ModelSpec::discrete(2, 2, 1.0),
                Context::periodic(ALPHA),
            )
            .unwrap();
        let cov = coverage(&report, truth);
        println!(
            "seed {seed}: effects {:?} consistent {} delay {:?} coverage {cov}",
            report.effects, report.consistent_with_noise, report.final_fit.delay
        );
        if report.effects.contains(&Effect::TimeDelay)
            && report.effects.contains(&Effect::MissingResonance)
        {
            both += 1;
            let (t, s) = report.final_fit.delay.unwrap();
            let s = s.unwrap();
            assert!((t - tau).abs() < 4.0 * s, "seed {seed}: τ̂ {t} ± {s}");
        }
        // pointwise coverage is correlated across lines (one parameter error moves many
        // lines): its mean over realisations is what the first-order σ_G predicts
        mean_cov += cov / seeds as f64;
        if report.consistent_with_noise {
            consistent += 1;
        }
    }
    println!("both found {both}/{seeds}, consistent {consistent}/{seeds}, coverage {mean_cov}");
    assert_eq!(both, seeds);
    assert!(mean_cov >= 0.95, "mean coverage {mean_cov}");
    assert!(consistent >= seeds - 1);
}

/// G(s) = ω₀²/(s² + 2ζω₀s + ω₀²), ω₀ = 10 rad/s, ζ = 0.3.
fn g_ct(w: f64) -> Complex<f64> {
    let s = Complex::new(0.0, w);
    Complex::new(100.0, 0.0) / (s * s + s * 6.0 + 100.0)
}

fn ct_omega() -> Vec<f64> {
    logspace(-1.0, 2.5, 120)
}

/// Continuous-time truths with one more real pole (at −40 rad/s) or one more zero
/// (at −15 rad/s), started from the model without it: `missing_pole` or `missing_zero`
/// is named first and the final model covers the truth.
#[test]
fn hidden_pole_and_zero_in_s_are_named_first() {
    type Truth = fn(f64) -> Complex<f64>;
    let cases: [(Effect, ModelSpec, Truth); 2] = [
        (Effect::MissingPole, ModelSpec::continuous(2, 0), |w| {
            g_ct(w) * 40.0 / (Complex::new(40.0, w))
        }),
        (Effect::MissingZero, ModelSpec::continuous(2, 0), |w| {
            g_ct(w) * Complex::new(1.0, w / 15.0)
        }),
    ];
    let omega = ct_omega();
    let seeds = 8;
    for (effect, start, truth) in cases {
        let (mut first, mut consistent, mut mean_cov) = (0, 0, 0.0);
        for seed in 0..seeds {
            let data = lines(&omega, truth, 1e-6, None, 6000 + seed);
            let report = Workflow::default()
                .run(&data, start.clone(), Context::frequency_data(ALPHA))
                .unwrap();
            let cov = coverage(&report, truth);
            println!(
                "{effect} seed {seed}: effects {:?} consistent {} coverage {cov}",
                report.effects, report.consistent_with_noise
            );
            if report.effects.first() == Some(&effect) {
                first += 1;
            }
            if report.consistent_with_noise {
                consistent += 1;
            }
            mean_cov += cov / seeds as f64;
        }
        println!(
            "{effect}: first {first}/{seeds}, consistent {consistent}/{seeds}, coverage {mean_cov}"
        );
        assert_eq!(first, seeds, "{effect}");
        assert!(consistent >= seeds - 1, "{effect}");
        assert!(mean_cov >= 0.97, "{effect}: mean coverage {mean_cov}");
    }
}

/// The order tests in s on fits of the correct model: the rejection rate at α = 0.05 over
/// 200 seeds is at most α plus three binomial standard errors.
#[test]
fn order_tests_in_s_are_calibrated() {
    let seeds = 200;
    let limit = ALPHA + 3.0 * (ALPHA * (1.0 - ALPHA) / seeds as f64).sqrt();
    let omega = ct_omega();
    let ctx = Context::frequency_data(ALPHA);
    for added in [Added::Pole, Added::Zero] {
        let detector = OrderIncrease(added);
        let mut fired = 0;
        for seed in 0..seeds {
            let data = lines(&omega, g_ct, 1e-6, None, 7000 + seed);
            let fit = fit_spec(&ModelSpec::continuous(2, 0), &data).unwrap();
            let finding = detector.detect(&data, &fit, &ctx).unwrap();
            assert!((0.0..=1.0).contains(&finding.p_value));
            if finding.p_value < ALPHA {
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

/// `disagreement_bands`: on fits of the correct model a band is reported in at most α of
/// 200 seeds (plus three binomial standard errors); a missing resonance gives a band that
/// contains its frequency.
#[test]
fn disagreement_bands_are_calibrated_and_locate_a_resonance() {
    let n = 160;
    let omega: Vec<f64> = (1..=n)
        .map(|k| k as f64 * std::f64::consts::PI / (n + 1) as f64)
        .collect();
    let g2 = |w: f64| {
        let zi = Complex::new(0.0, -w).exp();
        poly(&B2, zi) / poly(&A2, zi)
    };
    let seeds = 200;
    let mut alarms = 0;
    for seed in 0..seeds {
        let data = lines(&omega, g2, 1e-3, Some(1.0), 8000 + seed);
        let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
        if !disagreement_bands(&fit, ALPHA).unwrap().is_empty() {
            alarms += 1;
        }
    }
    let rate = alarms as f64 / seeds as f64;
    println!("bands on correct models: {rate} of {seeds} seeds");
    assert!(rate <= ALPHA + 3.0 * (ALPHA * (1.0 - ALPHA) / seeds as f64).sqrt());

    let (r, th) = (0.98f64, 2.0f64);
    let ar = [1.0, -2.0 * r * th.cos(), r * r];
    let br = [0.0, 0.01, 0.0];
    for seed in 0..10 {
        let truth = |w: f64| {
            let zi = Complex::new(0.0, -w).exp();
            g2(w) + poly(&br, zi) / poly(&ar, zi)
        };
        let data = lines(&omega, truth, 1e-3, Some(1.0), 9000 + seed);
        let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
        let bands = disagreement_bands(&fit, ALPHA).unwrap();
        println!("seed {seed}: {bands:?}");
        assert!(
            bands.iter().any(|b| b.omega_lo <= th + 0.03
                && th - 0.03 <= b.omega_hi
                && b.power > b.expected),
            "seed {seed}: {bands:?}"
        );
    }
    assert!(
        disagreement_bands(
            &fdid::workflow::fit_spec(
                &ModelSpec::discrete(2, 2, 1.0),
                &lines(&omega, g2, 1e-3, Some(1.0), 1)
            )
            .unwrap(),
            1.5
        )
        .is_err()
    );
}

/// The refits of a step run in parallel (`Hypothesis::augment_each`), each under the
/// step's work budget, relocation setting and memo: the report is the same on one thread
/// and on three, with a work budget that is not reached and with one that is (then each
/// refit of a step starts from the budget left at the step).
#[test]
fn the_report_does_not_depend_on_the_thread_count() {
    let data = delayed_with_resonance_data(5003);
    let report = |threads: usize, budget: f64| {
        on_threads(threads, || {
            fdid::solver::work::within(budget, || {
                Workflow::default()
                    .run(
                        &data,
                        ModelSpec::discrete(2, 2, 1.0),
                        Context::periodic(ALPHA),
                    )
                    .map(|r| format!("{r:?}"))
            })
        })
    };
    for budget in [1e12, 2e6, 3e7, 1e8] {
        let (one, stopped) = report(1, budget);
        let (three, stopped3) = report(3, budget);
        println!("budget {budget:e}: stopped {stopped}");
        assert_eq!(stopped, stopped3, "budget {budget:e}");
        assert_eq!(budget < 1e12, stopped, "budget {budget:e}: reached or not");
        match (one, three) {
            (Ok(one), Ok(three)) => assert!(one == three, "budget {budget:e}: reports differ"),
            (one, three) => assert_eq!(one.err(), three.err(), "budget {budget:e}"),
        }
    }
}
