//! Time segments in the discrepancy workflow: the parameter-drift test of time variation
//! ([`parameter_drift`], the [`TimeDrift`] detector) and the per-segment disagreement of
//! the whole-record model ([`segment_disagreement`]), on simulated periodic records with a
//! drifting a₁ and non-periodic records whose system changes halfway: detection, the
//! false-alarm rate on clean records, the segment estimates and their predicted spread,
//! typed errors.
//!
//! The ignored tests run with
//! `cargo test --release --all-features --test suite workflow_segments:: -- --ignored --nocapture`.

use crate::drifting::{System, TRUTH, filter, non_periodic, periodic, transient_spec};
use fdid::prelude::*;
use fdid::simulate::SplitMix64;
use fdid::workflow::detectors::{TimeDrift, TimeVariation, TimeVariationTests, parameter_drift};
use fdid::workflow::{
    Acceptance, Context, Detector, Effect, ModelSpec, SpecFit, Workflow, fit_spec,
    segment_disagreement,
};
use quickcheck::{Arbitrary, Gen, TestResult};

const ALPHA: f64 = 0.05;
/// The truth's θ in the layout of `ModelSpec::discrete(2, 2, ·)`: a₁, a₂, b₀, b₁, b₂.
fn truth_theta(sys: &System) -> [f64; 5] {
    [sys.a[1], sys.a[2], sys.b[0], sys.b[1], sys.b[2]]
}

// ---------------------------------------------------------------- SpecFit θ and covariance

/// θ̂ and its covariance on `SpecFit`: noise-free data give the truth to 1e-9; the
/// covariance is the fit's (λ/2)(JᵀJ)⁻¹ (symmetric, positive diagonal).
#[test]
fn spec_fit_carries_theta_and_covariance() {
    let (_, data) = periodic(&TRUTH, 4, 0.0, 1e-12, 1);
    let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
    let err = fit
        .theta
        .iter()
        .zip(truth_theta(&TRUTH))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    println!("noise-free θ error {err:.2e}");
    assert!(err < 1e-9, "θ error {err}");
    let (_, data) = periodic(&TRUTH, 4, 0.0, 0.05, 1);
    let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
    let c = fit.covariance.as_ref().unwrap();
    assert_eq!(c.shape(), (5, 5));
    assert!((c - c.transpose()).amax() <= 1e-12 * c.amax());
    assert!((0..5).all(|i| c[(i, i)] > 0.0));
}

// ---------------------------------------------------------------- periodic: drifting a₁

fn periodic_context(record: TimeData<f64>, periods: usize) -> Context {
    Context::periodic(ALPHA)
        .with_record(record, periods)
        .unwrap()
}

/// a₁ drifting by 0.05 over the record, P = 8 (two groups of four periods): the drift
/// test fires (p < 10⁻³) on at least 9 of 10 seeds and the workflow names
/// `time_variation` first, not absorbed.
#[test]
fn drifting_a1_periodic_is_detected() {
    let seeds = 10;
    let (mut fired, mut first) = (0, 0);
    for seed in 0..seeds {
        let (record, data) = periodic(&TRUTH, 8, 0.05, 0.05, 300 + seed);
        let ctx = periodic_context(record, 8);
        let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
        let drift = parameter_drift(&fit, &ctx, 2).unwrap().unwrap();
        // the segments see a₁ on either side of the drift's middle
        let a1: Vec<f64> = drift.theta.iter().map(|t| t[0]).collect();
        println!(
            "seed {seed}: T {:.1} (dof {}) p {:.2e}, a1 per segment {a1:?}",
            drift.statistic, drift.dof, drift.p_value
        );
        assert!(a1[0] < a1[1], "a₁ drifts upwards: {a1:?}");
        if drift.p_value < 1e-3 {
            fired += 1;
        }
        // the workflow's combined detector: both tests, Bonferroni over the two
        let both = TimeVariationTests::default()
            .detect(&data, &fit, &ctx)
            .unwrap();
        let tests = both.detail.time_variation_tests().unwrap();
        let (skirt_p, drift_p) = (tests.skirt_p.unwrap(), tests.drift_p.unwrap());
        assert_eq!(drift_p, drift.p_value);
        assert_eq!(both.p_value, (2.0 * skirt_p.min(drift_p)).min(1.0));
        assert!(tests.skirt.is_some());
        assert!(tests.drift.is_some());
        // the workflow that only names the effect (the default switches to the piecewise
        // model, tests/workflow_tvswitch.rs)
        let report = Workflow::naming_time_variation()
            .run(&data, ModelSpec::discrete(2, 2, 1.0), ctx)
            .unwrap();
        if report.effects.first() == Some(&Effect::TimeVariation) {
            first += 1;
            assert_eq!(report.steps[0].acceptance(), Acceptance::NotAbsorbed);
        }
        assert_eq!(report.unmodelled, vec![Effect::TimeVariation]);
    }
    println!("drift test p < 1e-3 on {fired}/{seeds}, time_variation first {first}/{seeds}");
    assert!(fired >= 9, "fired {fired}/{seeds}");
    assert_eq!(first, seeds);
}

/// Without the skirt test (a workflow whose only measurement detector is the drift test)
/// the drift alone names `time_variation` on the drifting record.
#[test]
fn drift_alone_names_time_variation() {
    let (record, data) = periodic(&TRUTH, 8, 0.05, 0.05, 77);
    let ctx = periodic_context(record, 8);
    let workflow = Workflow {
        detectors: vec![Box::new(TimeDrift::default())],
        max_steps: 4,
    };
    let report = workflow
        .run(&data, ModelSpec::discrete(2, 2, 1.0), ctx)
        .unwrap();
    println!("{:?}", report.steps.first().map(|s| &s.detail));
    assert_eq!(report.effects, vec![Effect::TimeVariation]);
    let detail = report.steps[0].detail.time_drift();
    assert!(detail.unwrap().drift_statistic > 0.0);
    assert_eq!(detail.map(|d| d.segments), Some(2));
}

/// A weak drift (a₁ by 0.005 over the record, P = 8, 40 seeds): the drift test fires at α
/// on at least 36/40 and more often than the skirt test of [`TimeVariation`].
#[test]
fn weak_drift_power_against_the_skirt_test() {
    let seeds = 40;
    let (mut drift, mut skirt) = (0, 0);
    for seed in 0..seeds {
        let (record, data) = periodic(&TRUTH, 8, 0.005, 0.05, 300 + seed);
        let ctx = periodic_context(record, 8);
        let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
        if TimeDrift::default()
            .detect(&data, &fit, &ctx)
            .unwrap()
            .p_value
            < ALPHA
        {
            drift += 1;
        }
        if TimeVariation.detect(&data, &fit, &ctx).unwrap().p_value < ALPHA {
            skirt += 1;
        }
    }
    println!("a1 drift 0.005: drift test {drift}/{seeds}, skirt test {skirt}/{seeds}");
    assert!(drift >= 36, "drift test {drift}/{seeds}");
    assert!(drift > skirt);
}

// ---------------------------------------------------------------- non-periodic: a jump

/// A non-periodic record (N = 4096, white input) whose a₁ changes by 0.05 halfway: the
/// drift test fires, the workflow names `time_variation`, and both segments disagree with
/// the whole-record model; the same record without the jump shows no disagreement.
#[test]
fn system_change_halfway_is_detected_and_localised() {
    let seeds = 5;
    for seed in 0..seeds {
        let (record, data) = non_periodic(&TRUTH, 4096, 0.05, 0.05, 500 + seed);
        let ctx = Context::non_periodic(ALPHA).with_time_record(record.clone());
        let fit = fit_spec(&transient_spec(), &data).unwrap();
        let drift = parameter_drift(&fit, &ctx, 2).unwrap().unwrap();
        let segs = segment_disagreement(&fit, &record, 2, ALPHA).unwrap();
        println!(
            "seed {seed}: drift T {:.1} p {:.2e}; segments {:?}",
            drift.statistic,
            drift.p_value,
            segs.iter()
                .map(|s| (s.t_start, s.cost, s.expected, s.p_value))
                .collect::<Vec<_>>()
        );
        assert!(
            drift.p_value < 1e-3,
            "seed {seed}: drift p {}",
            drift.p_value
        );
        assert_eq!(segs.len(), 2);
        assert_eq!((segs[0].t_start, segs[1].t_end), (0.0, 4096.0));
        for s in &segs {
            assert!(s.p_value < ALPHA, "seed {seed}: segment {s:?}");
            assert!(s.cost > s.expected);
        }
        let report = Workflow::default()
            .run(&data, transient_spec(), ctx)
            .unwrap();
        assert_eq!(report.effects.first(), Some(&Effect::TimeVariation));

        let (record, data) = non_periodic(&TRUTH, 4096, 0.0, 0.05, 500 + seed);
        let fit = fit_spec(&transient_spec(), &data).unwrap();
        let segs = segment_disagreement(&fit, &record, 4, ALPHA).unwrap();
        println!(
            "   no jump: segments {:?}",
            segs.iter()
                .map(|s| (s.cost, s.expected, s.p_value))
                .collect::<Vec<_>>()
        );
        assert!(segs.iter().all(|s| s.p_value >= ALPHA));
    }
}

/// A change in the last quarter only: among four segments the last one disagrees most.
#[test]
fn segment_results_point_at_the_changed_quarter() {
    let n = 8192;
    let mut rng = SplitMix64::new(9);
    let u: Vec<f64> = (0..n).map(|_| rng.gaussian()).collect();
    let x = filter(&TRUTH, &u, |t| if t >= 3 * n / 4 { 0.08 } else { 0.0 });
    let y: Vec<f64> = x.iter().map(|v| v + 0.05 * rng.gaussian()).collect();
    let record = TimeData::new(u, y, 1.0).unwrap();
    let all = record.dft();
    let keep: Vec<bool> = (0..all.len()).map(|k| k > 0 && 2 * k < n).collect();
    let data = all.select_lines(&keep).unwrap();
    let fit = fit_spec(&transient_spec(), &data).unwrap();
    let segs = segment_disagreement(&fit, &record, 4, ALPHA).unwrap();
    for s in &segs {
        println!(
            "[{:6.0}, {:6.0}) cost {:9.1} expected {:6.1} p {:.2e}",
            s.t_start, s.t_end, s.cost, s.expected, s.p_value
        );
    }
    let worst = segs
        .iter()
        .enumerate()
        .max_by(|a, b| (a.1.cost / a.1.expected).total_cmp(&(b.1.cost / b.1.expected)))
        .unwrap()
        .0;
    assert_eq!(worst, 3);
    assert!(segs[3].p_value < 1e-3);
}

// ---------------------------------------------------------------- false alarms

/// The drift test's rejection rate at α on clean periodic (P = 8) and non-periodic
/// (N = 2048) records of the correct model, the combined test's (skirts and drift) on the
/// periodic ones, and the segment test's (S = 2) on the non-periodic ones.
fn false_alarms(seeds: u64) -> (f64, f64, f64, f64) {
    let (mut periodic_fired, mut record_fired, mut segment_fired) = (0, 0, 0);
    let mut combined_fired = 0;
    for seed in 0..seeds {
        let (record, data) = periodic(&TRUTH, 8, 0.0, 0.05, 10_000 + seed);
        let ctx = periodic_context(record, 8);
        let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
        let f = TimeDrift::default().detect(&data, &fit, &ctx).unwrap();
        assert!((0.0..=1.0).contains(&f.p_value));
        if f.p_value < ALPHA {
            periodic_fired += 1;
        }
        if TimeVariationTests::default()
            .detect(&data, &fit, &ctx)
            .unwrap()
            .p_value
            < ALPHA
        {
            combined_fired += 1;
        }
        let (record, data) = non_periodic(&TRUTH, 2048, 0.0, 0.05, 20_000 + seed);
        let ctx = Context::non_periodic(ALPHA).with_time_record(record.clone());
        let fit = fit_spec(&transient_spec(), &data).unwrap();
        let f = TimeDrift::default().detect(&data, &fit, &ctx).unwrap();
        if f.p_value < ALPHA {
            record_fired += 1;
        }
        let segs = segment_disagreement(&fit, &record, 2, ALPHA).unwrap();
        if segs.iter().any(|s| s.p_value < ALPHA) {
            segment_fired += 1;
        }
    }
    let rate = |n: u64| n as f64 / seeds as f64;
    let rates = (
        rate(periodic_fired),
        rate(record_fired),
        rate(segment_fired),
        rate(combined_fired),
    );
    println!(
        "{seeds} seeds: drift false-alarm rate periodic {} non-periodic {}; segment test {}; \
         skirts and drift combined {}",
        rates.0, rates.1, rates.2, rates.3
    );
    rates
}

/// 200 seeds: each rate at most α + 3 binomial standard errors (0.096).
#[test]
fn clean_records_false_alarm_rate() {
    let seeds = 200;
    let limit = ALPHA + 3.0 * (ALPHA * (1.0 - ALPHA) / seeds as f64).sqrt();
    let (p, r, s, c) = false_alarms(seeds);
    assert!(c <= limit, "combined test {c}");
    assert!(p <= limit, "periodic drift test {p}");
    assert!(r <= limit, "non-periodic drift test {r}");
    assert!(s <= limit, "segment test {s}");
}

// ---------------------------------------------------------------- Monte Carlo of C_s

/// The segment estimates of the drift test on clean records, periodic (P = 8, the first
/// of two groups of four periods) or non-periodic (N = 2048, the first half with its
/// transient): per parameter, the bias of θ̂_s is below 3 standard errors of the Monte
/// Carlo mean and the sample standard deviation matches the predicted √(C_s)_ii within 3
/// sampling errors of a standard deviation (3/√(2(R − 1))).
fn segment_monte_carlo(runs: usize, periodic_record: bool) {
    let truth = truth_theta(&TRUTH);
    let mut est = vec![vec![]; 5];
    let mut pred = [0.0; 5];
    for r in 0..runs {
        let seed = 40_000 + r as u64;
        let drift = if periodic_record {
            let (record, data) = periodic(&TRUTH, 8, 0.0, 0.05, seed);
            let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
            parameter_drift(&fit, &periodic_context(record, 8), 2)
        } else {
            let (record, data) = non_periodic(&TRUTH, 2048, 0.0, 0.05, seed);
            let fit = fit_spec(&transient_spec(), &data).unwrap();
            parameter_drift(
                &fit,
                &Context::non_periodic(ALPHA).with_time_record(record),
                2,
            )
        };
        let drift = drift.unwrap().unwrap();
        for i in 0..5 {
            est[i].push(drift.theta[0][i]);
            pred[i] += drift.covariance[0][(i, i)] / runs as f64;
        }
    }
    let rn = runs as f64;
    let tol = 3.0 / (2.0 * (rn - 1.0)).sqrt();
    for i in 0..5 {
        let mean = est[i].iter().sum::<f64>() / rn;
        let var = est[i].iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (rn - 1.0);
        let bias = (mean - truth[i]) / (var / rn).sqrt();
        let ratio = (var / pred[i]).sqrt();
        println!(
            "{} θ{i}: bias {bias:+.2} SE, sample/predicted std {ratio:.3} (tolerance {tol:.3})",
            if periodic_record {
                "periodic"
            } else {
                "non-periodic"
            }
        );
        assert!(bias.abs() < 3.0, "θ{i}: bias {bias} SE");
        assert!((ratio - 1.0).abs() < tol, "θ{i}: std ratio {ratio}");
    }
}

#[test]
fn segment_monte_carlo_periodic_fast() {
    segment_monte_carlo(100, true);
}

#[test]
fn segment_monte_carlo_non_periodic_fast() {
    segment_monte_carlo(100, false);
}

#[test]
#[ignore = "1000 runs; see the file header"]
fn segment_monte_carlo_long() {
    segment_monte_carlo(1000, true);
    segment_monte_carlo(1000, false);
}

// ---------------------------------------------------------------- random systems

/// A stable second-order system with real or complex poles of radius 0.3 … 0.9.
#[derive(Debug, Clone, Copy)]
struct Case {
    sys: System,
    seed: u64,
}

impl Arbitrary for Case {
    fn arbitrary(g: &mut Gen) -> Self {
        let unit = |g: &mut Gen| f64::from(u16::arbitrary(g)) / f64::from(u16::MAX);
        let radius = 0.3 + 0.6 * unit(g);
        let angle = std::f64::consts::PI * unit(g);
        // poles r e^{±iφ}: A = 1 − 2r cos φ z⁻¹ + r² z⁻²
        let a = [1.0, -2.0 * radius * angle.cos(), radius * radius];
        let b = [0.2 + unit(g), unit(g) - 0.5, 0.3 * unit(g)];
        Self {
            sys: System { a, b },
            seed: u64::arbitrary(g) % 1000,
        }
    }
}

/// On random systems with (nearly) no noise every segment's θ̂ is the truth to 1e-6, the
/// p-value lies in [0, 1]; on random noisy clean records T is finite and non-negative.
#[test]
fn segment_estimates_recover_random_systems() {
    fn prop(case: Case) -> TestResult {
        let (record, data) = periodic(&case.sys, 4, 0.0, 1e-10, case.seed);
        let ctx = periodic_context(record, 4);
        let Ok(fit) = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data) else {
            return TestResult::discard();
        };
        // `Ok(None)`: a segment fit without a covariance (documented); the case says
        // nothing about the recovery
        let Some(drift) = parameter_drift(&fit, &ctx, 2).unwrap() else {
            println!(
                "{case:?}: no drift statistic (a segment covariance is not positive definite)"
            );
            return TestResult::discard();
        };
        let truth = truth_theta(&case.sys);
        let err = drift
            .theta
            .iter()
            .flat_map(|t| t.iter().zip(&truth).map(|(a, b)| (a - b).abs()))
            .fold(0.0, f64::max);
        if err > 1e-6 || !(0.0..=1.0).contains(&drift.p_value) {
            println!("{case:?}: θ error {err:e}, p {}", drift.p_value);
            return TestResult::failed();
        }
        let (record, data) = periodic(&case.sys, 4, 0.0, 0.05, case.seed);
        let ctx = periodic_context(record, 4);
        // a segment fit of a noisy lightly damped system may fail: a typed error, not a
        // panic, and no statistic to check
        let drift = match fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data)
            .and_then(|fit| parameter_drift(&fit, &ctx, 2))
        {
            Ok(Some(drift)) => drift,
            Ok(None) => return TestResult::failed(),
            Err(e) => {
                println!("{case:?}: noisy segment fit failed: {e}");
                return TestResult::discard();
            }
        };
        TestResult::from_bool(drift.statistic.is_finite() && drift.statistic >= 0.0)
    }
    crate::common::seeded(0x11c71fb6)
        .tests(30)
        .quickcheck(prop as fn(Case) -> TestResult);
}

// ---------------------------------------------------------------- bad input

fn clean_fit(periods: usize) -> (TimeData<f64>, FrequencyData<f64>, SpecFit) {
    let (record, data) = periodic(&TRUTH, periods, 0.0, 0.05, 3);
    let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
    (record, data, fit)
}

/// Too few periods or samples per segment, fewer than 2 segments, a segment count that
/// does not divide the record, α outside (0, 1): typed errors naming the value. Without a
/// record, for a continuous-time spec or P < 4 the drift test does not apply.
#[test]
fn bad_input_is_a_typed_error() {
    let (record, data, fit) = clean_fit(4);
    let ctx = periodic_context(record.clone(), 4);
    assert!(matches!(
        parameter_drift(&fit, &ctx, 3),
        Err(FdidError::TooShort {
            what: "periods per segment",
            needed: 2,
            got: 1
        })
    ));
    assert!(matches!(
        parameter_drift(&fit, &ctx, 1),
        Err(FdidError::InvalidArgument {
            name: "segments",
            ..
        })
    ));
    assert!(matches!(
        segment_disagreement(&fit, &record, 1, ALPHA),
        Err(FdidError::InvalidArgument {
            name: "segments",
            ..
        })
    ));
    assert!(matches!(
        segment_disagreement(&fit, &record, 2, 1.5),
        Err(FdidError::InvalidArgument { name: "alpha", .. })
    ));
    // 4 · 512 samples do not split into 3 equal segments
    assert!(matches!(
        segment_disagreement(&fit, &record, 3, ALPHA),
        Err(FdidError::InvalidArgument {
            name: "segments",
            ..
        })
    ));
    // a short non-periodic record: 64 samples in 8 segments leave 3 lines each
    let (short, sdata) = non_periodic(&TRUTH, 64, 0.0, 0.05, 1);
    let sfit = fit_spec(&transient_spec(), &sdata).unwrap();
    let sctx = Context::non_periodic(ALPHA).with_time_record(short.clone());
    for err in [
        parameter_drift(&sfit, &sctx, 8).unwrap_err(),
        segment_disagreement(&sfit, &short, 8, ALPHA).unwrap_err(),
    ] {
        println!("{err}");
        assert!(matches!(
            err,
            FdidError::TooShort {
                what: "fitted lines per segment",
                needed: 8,
                got: 3
            }
        ));
    }
    // not applicable: no record, continuous time, fewer than 4 periods
    assert!(
        parameter_drift(&fit, &Context::periodic(ALPHA), 2)
            .unwrap()
            .is_none()
    );
    assert!(
        TimeDrift::default()
            .detect(&data, &fit, &Context::periodic(ALPHA))
            .is_none()
    );
    let ct = fit_spec(&ModelSpec::continuous(2, 2), &data).unwrap();
    assert!(parameter_drift(&ct, &ctx, 2).unwrap().is_none());
    let (record3, _) = periodic(&TRUTH, 3, 0.0, 0.05, 3);
    assert!(
        parameter_drift(&fit, &periodic_context(record3, 3), 2)
            .unwrap()
            .is_none()
    );
}

// ---------------------------------------------------------------- delayed specs

/// A non-periodic record (N = 2048, white input, σ = 0.05) of [`TRUTH`] behind an input
/// delay of `first` samples, `second` samples from N/2 on; its DFT at lines 1 … N/2 − 1.
fn delayed_record(first: usize, second: usize, seed: u64) -> (TimeData<f64>, FrequencyData<f64>) {
    let n = 2048;
    let mut rng = SplitMix64::new(seed);
    let u: Vec<f64> = (0..n).map(|_| rng.gaussian()).collect();
    let shifted: Vec<f64> = (0..n)
        .map(|t| {
            let d = if t < n / 2 { first } else { second };
            if t >= d { u[t - d] } else { 0.0 }
        })
        .collect();
    let x = filter(&TRUTH, &shifted, |_| 0.0);
    let y: Vec<f64> = x.iter().map(|v| v + 0.05 * rng.gaussian()).collect();
    let record = TimeData::new(u, y, 1.0).unwrap();
    let all = record.dft();
    let keep: Vec<bool> = (0..all.len()).map(|k| k > 0 && 2 * k < n).collect();
    (record.clone(), all.select_lines(&keep).unwrap())
}

/// Delayed specs: the segment fits start from the whole fit's τ̂ instead of searching
/// (`fit_segment`). On a constant delay of 3 samples (200 seeds) at most 4 of the 400
/// segment fits end more than 0.1 sample from it (measured 3; a search per segment ended
/// there on 60, most near 7.6 samples), and the drift test fires below α = 0.05 on at
/// most 30 (measured 24; 11 % over 400 seeds, 6.3 % for the same records fitted with the
/// delay in the numerator, `discrete(2, 5)`, and 32–34 % with a search per segment); a delay
/// that steps from 3 to 4 samples halfway is found (p < 10⁻³ on every one of 10 seeds),
/// the segments' delays within 0.1 sample of 3 and 4.
#[test]
fn drift_test_with_a_delay_keeps_its_level_and_sees_a_delay_step() {
    let spec = ModelSpec {
        delay: true,
        ..transient_spec()
    };
    let tau_of = |theta: &[f64]| theta[theta.len() - 1];
    let (mut alarms, mut off) = (0, 0);
    let seeds = 200;
    for seed in 0..seeds {
        let (record, data) = delayed_record(3, 3, 900 + seed);
        let ctx = Context::non_periodic(ALPHA).with_time_record(record);
        let fit = fit_spec(&spec, &data).unwrap();
        let drift = parameter_drift(&fit, &ctx, 2).unwrap().unwrap();
        off += drift
            .theta
            .iter()
            .filter(|t| (tau_of(t) - 3.0).abs() >= 0.1)
            .count();
        alarms += usize::from(drift.p_value < ALPHA);
    }
    println!("constant delay: {alarms}/{seeds} below alpha = {ALPHA}, {off} segment delays off");
    assert!(off <= 4, "{off} segment delays off by 0.1 sample or more");
    assert!(alarms <= 30, "{alarms}/{seeds} false alarms");
    for seed in 0..10 {
        let (record, data) = delayed_record(3, 4, 950 + seed);
        let ctx = Context::non_periodic(ALPHA).with_time_record(record);
        let fit = fit_spec(&spec, &data).unwrap();
        let drift = parameter_drift(&fit, &ctx, 2).unwrap().unwrap();
        println!(
            "delay step, seed {seed}: p {:.2e}, tau {:?}",
            drift.p_value,
            drift.theta.iter().map(|t| tau_of(t)).collect::<Vec<_>>()
        );
        assert!(drift.p_value < 1e-3, "seed {seed}: p {}", drift.p_value);
        assert!((tau_of(&drift.theta[0]) - 3.0).abs() < 0.1);
        assert!((tau_of(&drift.theta[1]) - 4.0).abs() < 0.1);
    }
}
