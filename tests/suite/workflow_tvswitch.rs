//! The switch to the piecewise time-invariant model when the workflow names time
//! variation ([`piecewise_model`], [`Workflow::time_varying`]): a periodic record with a
//! drifting a₁ and a non-periodic record whose a₁ jumps halfway; the step's costs and F
//! test, the segment parameters against the truth, the final verdict on the noise, clean
//! records unchanged, noise-free recovery, a Monte Carlo of the segment estimates and of
//! the F test's size, typed errors.
//!
//! The ignored tests run with
//! `cargo test --release --all-features --test suite workflow_tvswitch:: -- --ignored --nocapture`.

use crate::drifting::{self, M, System, TRUTH, WARM, periodic, transient_spec};
use fdid::prelude::*;
use fdid::workflow::detectors::{TimeVariationTests, piecewise_model};
use fdid::workflow::{Acceptance, Context, Detector, Effect, ModelSpec, Workflow, fit_spec};
use quickcheck::{Arbitrary, Gen, TestResult};

const ALPHA: f64 = 0.05;
/// The truth's θ in the layout of `ModelSpec::discrete(2, 2, ·)`: a₁, a₂, b₀, b₁, b₂.
fn truth_theta(sys: &System, jump: f64) -> [f64; 5] {
    [sys.a[1] + jump, sys.a[2], sys.b[0], sys.b[1], sys.b[2]]
}

/// [`drifting::non_periodic`] with the known noise variance σ² per line when σ > 0 (eq. 1:
/// the 1/√N DFT keeps σ²).
fn non_periodic(
    sys: &System,
    n: usize,
    jump: f64,
    sigma: f64,
    seed: u64,
) -> (TimeData<f64>, FrequencyData<f64>) {
    let (record, data) = drifting::non_periodic(sys, n, jump, sigma, seed);
    let data = if sigma > 0.0 {
        let var = vec![sigma * sigma; data.len()];
        data.with_noise(NoiseVariances::output_only(var)).unwrap()
    } else {
        data
    };
    (record, data)
}

fn periodic_context(record: TimeData<f64>, periods: usize) -> Context {
    Context::periodic(ALPHA)
        .with_record(record, periods)
        .unwrap()
}

/// Checks the switch on one report: `time_variation` first, a piecewise step whose cost
/// drops with lr_p < 10⁻³, a₁ of the first segment below the last's (the truth
/// increases), the verdict and `unmodelled` from the segment models. Whether the final
/// description is consistent with the noise.
fn check_switch(report: &fdid::workflow::Report, label: &str) -> bool {
    assert_eq!(report.effects, vec![Effect::TimeVariation], "{label}");
    let step = &report.steps[0];
    assert!(step.piecewise, "{label}");
    assert_eq!(step.acceptance(), Acceptance::Piecewise);
    let tv = report.time_varying.as_ref().unwrap();
    let a1: Vec<f64> = tv.theta.iter().map(|t| t[0]).collect();
    println!(
        "{label}: cost {:.1} → {:.1} (+{} params) lr_p {:.1e}, cost_p {:?}, whiteness {:?}, a1 {a1:.4?}",
        step.cost_before, step.cost_after, tv.extra_params, step.lr_p, tv.cost_p, tv.whiteness_p
    );
    assert_eq!(
        (step.cost_before, step.cost_after, step.lr_p),
        (tv.cost_before, tv.cost_after, tv.lr_p)
    );
    assert!(step.cost_after < step.cost_before, "{label}");
    assert!(step.lr_p < 1e-3, "{label}: lr_p {}", step.lr_p);
    assert_eq!(tv.extra_params, 5);
    assert!(a1[0] < a1[a1.len() - 1], "{label}: a₁ increases: {a1:?}");
    assert_eq!(tv.fits.len(), 2);
    assert_eq!(
        report.consistent_with_noise,
        tv.consistent_with_noise(ALPHA)
    );
    assert_eq!(
        report.unmodelled.contains(&Effect::TimeVariation),
        !report.consistent_with_noise
    );
    report.consistent_with_noise
}

// ---------------------------------------------------------------- the switch

/// a₁ drifting by 0.05 over a periodic record (P = 8, two segments of four periods):
/// `time_variation` named first and the switch made on every seed, the final description
/// consistent with the noise on at least 8 of 10 seeds.
#[test]
fn drifting_a1_periodic_switches_to_segments() {
    let seeds = 10;
    let mut consistent = 0;
    for seed in 0..seeds {
        let (record, data) = periodic(&TRUTH, 8, 0.05, 0.05, 300 + seed);
        let ctx = periodic_context(record, 8);
        let report = Workflow::time_varying()
            .run(&data, ModelSpec::discrete(2, 2, 1.0), ctx)
            .unwrap();
        let tv = report.time_varying.as_ref().unwrap();
        assert_eq!(tv.segments, vec![(0.0, 2048.0), (2048.0, 4096.0)]);
        // the truth's a₁ at the segments' middles: −1.2 + 0.05(t/T − 1/2), T with warm-up
        let total = ((WARM + 8) * M) as f64;
        let mid = |t: f64| TRUTH.a[1] + 0.05 * ((WARM * M) as f64 + t) / total - 0.025;
        println!(
            "  truth a1 at the middles {:.4} {:.4}",
            mid(1024.0),
            mid(3072.0)
        );
        if check_switch(&report, &format!("periodic seed {seed}")) {
            consistent += 1;
        }
    }
    println!("periodic drift: consistent {consistent}/{seeds}");
    assert!(consistent >= 8, "consistent {consistent}/{seeds}");
}

/// a₁ changed by 0.05 halfway through a non-periodic record (N = 4096, known noise
/// level): the same switch; the segment models are consistent with the noise on at
/// least 8 of 10 seeds.
#[test]
fn jump_halfway_non_periodic_switches_to_segments() {
    let seeds = 10;
    let mut consistent = 0;
    for seed in 0..seeds {
        let (record, data) = non_periodic(&TRUTH, 4096, 0.05, 0.05, 500 + seed);
        let ctx = Context::non_periodic(ALPHA).with_time_record(record);
        let report = Workflow::time_varying()
            .run(&data, transient_spec(), ctx)
            .unwrap();
        if check_switch(&report, &format!("non-periodic seed {seed}")) {
            consistent += 1;
        }
        let tv = report.time_varying.as_ref().unwrap();
        assert!(tv.cost_p.is_some());
    }
    println!("non-periodic jump: consistent {consistent}/{seeds}");
    assert!(consistent >= 8, "consistent {consistent}/{seeds}");
}

/// The naming-only workflow does not switch: `time_variation` stays unmodelled.
#[test]
fn naming_workflow_does_not_switch() {
    let (record, data) = periodic(&TRUTH, 8, 0.05, 0.05, 300);
    let ctx = periodic_context(record, 8);
    let report = Workflow::naming_time_variation()
        .run(&data, ModelSpec::discrete(2, 2, 1.0), ctx)
        .unwrap();
    assert_eq!(report.effects, vec![Effect::TimeVariation]);
    assert_eq!(report.steps[0].acceptance(), Acceptance::NotAbsorbed);
    assert!(report.time_varying.is_none());
    assert_eq!(report.unmodelled, vec![Effect::TimeVariation]);
    assert_eq!(TimeVariationTests::default().piecewise_segments(), None);
    assert_eq!(
        TimeVariationTests::switching(3).piecewise_segments(),
        Some(3)
    );
}

/// A continuous-time spec: the drift test and the switch do not apply (`Ok(None)`); the
/// workflow reports no piecewise model.
#[test]
fn continuous_time_spec_is_not_switched() {
    let (record, data) = periodic(&TRUTH, 8, 0.05, 0.05, 301);
    let ctx = periodic_context(record, 8);
    let fit = fit_spec(&ModelSpec::continuous(2, 2), &data).unwrap();
    assert!(piecewise_model(&fit, &ctx, 2).unwrap().is_none());
    let report = Workflow::time_varying()
        .run(&data, ModelSpec::continuous(2, 2), ctx)
        .unwrap();
    assert!(report.time_varying.is_none());
    assert!(report.steps.iter().all(|s| !s.piecewise));
}

// ---------------------------------------------------------------- clean records

/// Clean records (no drift, no jump), 10 seeds each: the switching workflow names
/// `time_variation` on at most 2 of them (the detector's false-alarm rate is α/2 at
/// most), and builds a piecewise model only when it does.
#[test]
fn clean_records_unchanged() {
    let seeds = 10;
    let mut named = 0;
    for seed in 0..seeds {
        let (record, data) = periodic(&TRUTH, 8, 0.0, 0.05, 700 + seed);
        let report = Workflow::time_varying()
            .run(
                &data,
                ModelSpec::discrete(2, 2, 1.0),
                periodic_context(record, 8),
            )
            .unwrap();
        let (record, data2) = non_periodic(&TRUTH, 4096, 0.0, 0.05, 700 + seed);
        let report2 = Workflow::time_varying()
            .run(
                &data2,
                transient_spec(),
                Context::non_periodic(ALPHA).with_time_record(record),
            )
            .unwrap();
        for r in [&report, &report2] {
            let tv_named = r.effects.contains(&Effect::TimeVariation);
            named += usize::from(tv_named);
            if !tv_named {
                assert!(r.time_varying.is_none());
                assert_eq!(
                    r.consistent_with_noise,
                    r.final_fit.consistent_with_noise(ALPHA)
                );
            }
        }
    }
    println!("clean: time_variation named on {named}/{}", 2 * seeds);
    assert!(named <= 2, "named {named}/{}", 2 * seeds);
}

// ---------------------------------------------------------------- recovery

/// A stable second-order system with real or complex poles of radius 0.3 … 0.85 and a
/// jump of a₁ by up to ±0.05 (cases whose second system is unstable are discarded).
#[derive(Debug, Clone, Copy)]
struct Case {
    sys: System,
    jump: f64,
    seed: u64,
}

impl Arbitrary for Case {
    fn arbitrary(g: &mut Gen) -> Self {
        let unit = |g: &mut Gen| f64::from(u16::arbitrary(g)) / f64::from(u16::MAX);
        let radius = 0.3 + 0.55 * unit(g);
        let angle = std::f64::consts::PI * unit(g);
        let a = [1.0, -2.0 * radius * angle.cos(), radius * radius];
        let b = [0.2 + unit(g), unit(g) - 0.5, 0.3 * unit(g)];
        Self {
            sys: System { a, b },
            jump: 0.1 * (unit(g) - 0.5),
            seed: u64::arbitrary(g) % 1000,
        }
    }
}

fn max_error(theta: &[Vec<f64>], truth: [[f64; 5]; 2]) -> f64 {
    theta
        .iter()
        .zip(truth)
        .flat_map(|(t, r)| {
            t.iter()
                .zip(r)
                .map(|(a, b)| (a - b).abs())
                .collect::<Vec<_>>()
        })
        .fold(0.0, f64::max)
}

/// Noise-free non-periodic records with a jump of a₁ halfway: each segment model is the
/// segment's system to 1e-9 (the second segment's initial state is its transient term,
/// eq. 5).
#[test]
fn noise_free_segments_recover_the_truth() {
    let (record, data) = non_periodic(&TRUTH, 2048, 0.05, 0.0, 1);
    let fit = fit_spec(&transient_spec(), &data).unwrap();
    let ctx = Context::non_periodic(ALPHA).with_time_record(record);
    let tv = piecewise_model(&fit, &ctx, 2).unwrap().unwrap();
    let err = max_error(
        &tv.theta,
        [truth_theta(&TRUTH, 0.0), truth_theta(&TRUTH, 0.05)],
    );
    println!("noise-free θ error {err:.1e}, lr_p {:.1e}", tv.lr_p);
    assert!(err < 1e-9, "θ error {err:e}");
    assert!(tv.cost_after < 1e-12 * tv.cost_before);
}

/// The same over random stable systems and jumps (quickcheck, 30 cases).
#[test]
fn noise_free_recovery_random_systems() {
    fn prop(case: Case) -> TestResult {
        // both systems stable: poles of z² + a₁z + a₂ inside the unit circle
        let a1 = case.sys.a[1] + case.jump;
        let a2 = case.sys.a[2];
        if !(a2.abs() < 1.0 && a1.abs() < 1.0 + a2) {
            return TestResult::discard();
        }
        let (record, data) = non_periodic(&case.sys, 1024, case.jump, 0.0, case.seed);
        let Ok(fit) = fit_spec(&transient_spec(), &data) else {
            return TestResult::discard();
        };
        let ctx = Context::non_periodic(ALPHA).with_time_record(record);
        let tv = piecewise_model(&fit, &ctx, 2).unwrap().unwrap();
        let err = max_error(
            &tv.theta,
            [
                truth_theta(&case.sys, 0.0),
                truth_theta(&case.sys, case.jump),
            ],
        );
        if err.is_nan() || err >= 1e-8 || !(0.0..=1.0).contains(&tv.lr_p) {
            println!("{case:?}: θ error {err:e}, lr_p {}", tv.lr_p);
            return TestResult::failed();
        }
        TestResult::passed()
    }
    crate::common::seeded(0xf9b60e65)
        .tests(30)
        .quickcheck(prop as fn(Case) -> TestResult);
}

// ---------------------------------------------------------------- Monte Carlo

/// `runs` non-periodic records (N = 2048, a₁ jumping by 0.05 halfway, σ = 0.05, known
/// noise level): per segment the bias of â₁ over its sample std, and the sample std over
/// the mean predicted std √C₁₁ of the segment fit's covariance; and the F test's
/// rejection rate at α on the same records without a jump.
fn monte_carlo(runs: u64) -> ([f64; 2], [f64; 2], f64) {
    let mut est = [Vec::new(), Vec::new()];
    let mut pred = [0.0; 2];
    let mut rejected = 0;
    for seed in 0..runs {
        let (record, data) = non_periodic(&TRUTH, 2048, 0.05, 0.05, 10_000 + seed);
        let fit = fit_spec(&transient_spec(), &data).unwrap();
        let ctx = Context::non_periodic(ALPHA).with_time_record(record);
        let tv = piecewise_model(&fit, &ctx, 2).unwrap().unwrap();
        for s in 0..2 {
            est[s].push(tv.theta[s][0]);
            pred[s] += tv.fits[s].covariance.as_ref().unwrap()[(0, 0)].sqrt() / runs as f64;
        }
        let (record, data) = non_periodic(&TRUTH, 2048, 0.0, 0.05, 20_000 + seed);
        let fit = fit_spec(&transient_spec(), &data).unwrap();
        let ctx = Context::non_periodic(ALPHA).with_time_record(record);
        if piecewise_model(&fit, &ctx, 2).unwrap().unwrap().lr_p < ALPHA {
            rejected += 1;
        }
    }
    let truth = [TRUTH.a[1], TRUTH.a[1] + 0.05];
    let mut bias = [0.0; 2];
    let mut ratio = [0.0; 2];
    for s in 0..2 {
        let n = est[s].len() as f64;
        let mean = est[s].iter().sum::<f64>() / n;
        let std = (est[s].iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        bias[s] = (mean - truth[s]) / std;
        ratio[s] = std / pred[s];
    }
    let rate = rejected as f64 / runs as f64;
    println!(
        "{runs} runs: bias/std {bias:.3?}, sample std/predicted {ratio:.3?}, F test size {rate:.3}"
    );
    (bias, ratio, rate)
}

/// 100 runs: |bias| below 0.35 sample std (0.1 expected spread), std ratio within
/// 0.8 … 1.2, F test size at most 0.1.
#[test]
fn monte_carlo_fast() {
    let (bias, ratio, rate) = monte_carlo(100);
    for s in 0..2 {
        assert!(bias[s].abs() < 0.35, "bias {bias:?}");
        assert!((0.8..1.2).contains(&ratio[s]), "ratio {ratio:?}");
    }
    assert!(rate <= 0.1, "size {rate}");
}

/// 2000 runs: |bias| below 0.08 std, std ratio within 0.95 … 1.05, size within 0.035 …
/// 0.065.
#[test]
#[ignore = "long Monte Carlo: cargo test --release --all-features --test suite workflow_tvswitch:: -- --ignored"]
fn monte_carlo_long() {
    let (bias, ratio, rate) = monte_carlo(2000);
    for s in 0..2 {
        assert!(bias[s].abs() < 0.08, "bias {bias:?}");
        assert!((0.95..1.05).contains(&ratio[s]), "ratio {ratio:?}");
    }
    assert!((0.035..0.065).contains(&rate), "size {rate}");
}

// ---------------------------------------------------------------- bad input

/// Fewer than 2 segments, too few periods per segment, a segment count not dividing the
/// record: typed errors naming the value; no record: `Ok(None)`.
#[test]
fn bad_input_is_a_typed_error() {
    let (record, data) = periodic(&TRUTH, 8, 0.0, 0.05, 3);
    let fit = fit_spec(&ModelSpec::discrete(2, 2, 1.0), &data).unwrap();
    let ctx = periodic_context(record, 8);
    match piecewise_model(&fit, &ctx, 1) {
        Err(FdidError::InvalidArgument { name, value, .. }) => {
            assert_eq!((name, value.as_str()), ("segments", "1"));
        }
        other => panic!("{other:?}"),
    }
    match piecewise_model(&fit, &ctx, 5) {
        Err(FdidError::TooShort { what, needed, got }) => {
            assert_eq!((what, needed, got), ("periods per segment", 2, 1));
        }
        other => panic!("{other:?}"),
    }
    assert!(
        piecewise_model(&fit, &Context::periodic(ALPHA), 2)
            .unwrap()
            .is_none()
    );
    let (record, data) = non_periodic(&TRUTH, 1000, 0.0, 0.05, 3);
    let fit = fit_spec(&transient_spec(), &data).unwrap();
    let ctx = Context::non_periodic(ALPHA).with_time_record(record);
    match piecewise_model(&fit, &ctx, 3) {
        Err(FdidError::InvalidArgument { name, value, .. }) => {
            assert_eq!((name, value.as_str()), ("segments", "3"));
        }
        other => panic!("{other:?}"),
    }
}
