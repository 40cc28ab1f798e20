//! The start on fewer lines (`Pipeline::start_lines`): on long records Levy and SK run on
//! every m-th line and only start ML, which runs on all lines, so the fit reaches the
//! optimum the linear stages on all lines reach; the stages record the lines they used;
//! without ML, or with too few lines for the model, every stage uses all lines.

use crate::common::{self, Noise, logspace, modal};
use fdid::prelude::*;
use fdid::solver::Termination;

/// `sys`'s FRF on `n` log-spaced lines over 0.1–10 rad/s with output noise of variance
/// `var` (known).
fn record(sys: &common::Modal, n: usize, var: f64, seed: u64) -> FrequencyData<f64> {
    let omega = logspace(-1.0, 1.0, n);
    let mut noise = Noise::new(seed);
    let y: Vec<Complex<f64>> = sys
        .frf(&omega)
        .iter()
        .map(|g| g + noise.complex(var))
        .collect();
    FrequencyData::from_frf(omega, y, None)
        .unwrap()
        .with_noise(NoiseVariances::output_only(vec![var; n]))
        .unwrap()
}

fn all_lines() -> Pipeline {
    Pipeline {
        start_lines: None,
        ..Pipeline::default()
    }
}

/// Both fits reach one optimum (cost within 10⁻⁹ relative, responses within 10⁻⁶ of the
/// largest), the default's linear stages on ⌈N/m⌉ lines and its ML on all; with
/// `relocated` (a partial-fraction basis) one relocation on all lines between them. The
/// stage sequence is the contract here (`Pipeline`'s documented chain on fewer lines): on
/// these well-determined records none of the chain's tests for a local minimum fires, so
/// no second chain or further start runs.
fn same_optimum(model: &Rational<f64>, data: &FrequencyData<f64>, lines: usize, relocated: bool) {
    let fewer = Pipeline::default().fit(model, data).unwrap();
    let all = all_lines().fit(model, data).unwrap();
    assert!(
        (fewer.cost() - all.cost()).abs() <= 1e-9 * all.cost(),
        "{} vs {}",
        fewer.cost(),
        all.cost()
    );
    let peak = all.response().iter().fold(0.0f64, |m, g| m.max(g.norm()));
    for (a, b) in fewer.response().iter().zip(all.response()) {
        assert!((a - b).norm() <= 1e-6 * peak, "{a} vs {b}");
    }
    let stages = fewer.stages();
    let names: Vec<String> = stages.iter().map(|s| s.kind.name()).collect();
    let expected: &[&str] = if relocated {
        &["levy", "sk", "sk", "ml"]
    } else {
        &["levy", "sk", "ml"]
    };
    assert_eq!(names, expected);
    assert_eq!(stages[0].lines, Some(lines));
    assert_eq!(stages[1].lines, Some(lines));
    if relocated {
        // one direct solve on all lines, its cost the output-error one there
        let last = &stages[2];
        assert_eq!(last.lines, None);
        assert_eq!(last.solution.iterations, 1);
        assert_eq!(last.solution.termination, Termination::Direct);
        let at_start = Fit::new(
            fewer.model().clone(),
            data,
            last.solution.theta.clone(),
            NoiseWeighting::Auto,
            vec![],
        )
        .unwrap();
        assert!((at_start.cost() - last.solution.cost).abs() <= 1e-9 * last.solution.cost);
        assert!(last.solution.cost >= fewer.cost());
    }
    assert_eq!(stages.last().unwrap().lines, None);
    assert!(all.stages().iter().all(|s| s.lines.is_none()));
}

#[test]
fn five_resonances_on_20_000_lines_reach_the_optimum_of_all_lines() {
    let data = record(&common::b_ct10(), 20_000, 1e-4, 5);
    let model = Rational::continuous(10, 9, data.omega()).unwrap();
    // 21 coefficients: at most 64·21 = 1 344 lines, every 15th line
    same_optimum(&model, &data, 1_334, true);
}

/// A resonance of ζ = 3·10⁻⁴ (about half a kept line across its half-power band)
/// between two heavily damped modes.
#[test]
fn a_narrow_resonance_between_broad_modes_reaches_the_optimum_of_all_lines() {
    let sys = modal(&[0.3, 1.0, 3.0], &[0.3, 3e-4, 0.2], &[1.0, 0.05, 1.0]);
    let data = record(&sys, 20_000, 1e-6, 3);
    let model = Rational::continuous(6, 5, data.omega()).unwrap();
    // 13 coefficients: at most 832 lines, every 25th line
    same_optimum(&model, &data, 800, true);
}

#[test]
fn a_discrete_time_record_of_8_192_lines_reaches_the_optimum_of_all_lines() {
    // 0.1 z⁻¹ (1 + 0.5 z⁻¹) / ((1 − 1.6 z⁻¹ + 0.9 z⁻²)(1 − 0.5 z⁻¹))
    let n = 8_192;
    let omega: Vec<f64> = (1..=n)
        .map(|k| k as f64 * std::f64::consts::PI / (n + 1) as f64)
        .collect();
    let mut noise = Noise::new(8);
    let var = 1e-6;
    let y: Vec<Complex<f64>> = omega
        .iter()
        .map(|w| {
            let z = Complex::new(0.0, -w).exp();
            let a = (Complex::new(1.0, 0.0) - z * 1.6 + z * z * 0.9) * (1.0 - z * 0.5);
            z * 0.1 * (1.0 + z * 0.5) / a + noise.complex(var)
        })
        .collect();
    let data = FrequencyData::from_frf(omega, y, Some(1.0))
        .unwrap()
        .with_noise(NoiseVariances::output_only(vec![var; n]))
        .unwrap();
    let model = Rational::discrete(3, 2, 1.0).unwrap();
    // 7 coefficients: at most 512 lines (the floor), every 16th line; powers of z⁻¹ are
    // not relocated
    same_optimum(&model, &data, 512, false);
}

/// Without ML every stage is the estimator on all lines; a `start_lines` below twice the
/// model's coefficients leaves all lines too; `start_lines` bounds the lines, and so does
/// the per-coefficient rule.
#[test]
fn without_ml_or_with_too_few_lines_every_stage_uses_all_lines() {
    let data = record(&common::a_ct4(), 6_000, 1e-4, 2);
    let model = Rational::continuous(4, 3, data.omega()).unwrap();
    let sk = Pipeline::sk().fit(&model, &data).unwrap();
    assert!(sk.stages().iter().all(|s| s.lines.is_none()));
    for start_lines in [Some(10), None] {
        let fit = Pipeline {
            start_lines,
            ..Pipeline::default()
        }
        .fit(&model, &data)
        .unwrap();
        assert!(
            fit.stages().iter().all(|s| s.lines.is_none()),
            "{start_lines:?}"
        );
    }
    let fit = Pipeline {
        start_lines: Some(100),
        ..Pipeline::default()
    }
    .fit(&model, &data)
    .unwrap();
    assert_eq!(fit.stages()[0].lines, Some(100));
    // 9 coefficients: at most 64·9 = 576 of the 6 000 lines, every 11th line
    let fit = Pipeline::default().fit(&model, &data).unwrap();
    assert_eq!(fit.stages()[0].lines, Some(546));
    assert_eq!(fit.stages().last().unwrap().lines, None);
}

/// A long record whose fit shows evidence of a local minimum (SK at its cap). The outcome:
/// the fit is no worse than ML started at the true system on all lines, and its last stage
/// used all lines. The contract of the further starts themselves, called directly from a
/// fit short of the optimum (from the pipeline's own fit, whether their ML or the chain's
/// wins is a tie between two fits of one optimum, decided by rounding): they run on fewer
/// lines, and ML on all lines from their best, so that the search costs a fraction of a
/// search on all lines. (Random system 1034 of the optimisation study, order 10/9 on
/// 11 907 lines; about 12 s here for the fit, the SK fit and the search.)
#[test]
fn further_starts_of_a_long_record_run_on_fewer_lines() {
    use crate::robustness::{ct_system, long_record};
    let sys = ct_system(1034);
    let data = long_record(&sys, 11_907, 1034);
    let model = Rational::continuous(sys.na, sys.nb, data.omega()).unwrap();
    let fit = Pipeline::default().fit(&model, &data).unwrap();
    // ML from the truth: basis at the true poles, θ from Levy on the noise-free response
    let basis: Vec<Complex<f64>> = sys
        .zpk
        .poles
        .iter()
        .filter(|p| p.im >= 0.0)
        .copied()
        .collect();
    let truth_model = Rational::partial_fractions(basis, sys.nb).unwrap();
    let clean =
        FrequencyData::from_frf(data.omega().to_vec(), sys_frf(&sys, data.omega()), None).unwrap();
    let t0 = fdid::estimate::estimate(
        &truth_model,
        &clean,
        &Levy::default(),
        &LinearLeastSquares::default(),
        None,
    )
    .unwrap();
    let truth = fdid::estimate::estimate(
        &truth_model,
        &data,
        &MaximumLikelihood::default(),
        &LevenbergMarquardt::default(),
        Some(&t0.theta),
    )
    .unwrap();
    assert!(
        fit.cost() <= truth.cost * (1.0 + 1e-9),
        "{} vs {}",
        fit.cost(),
        truth.cost
    );
    assert_eq!(fit.stages().last().unwrap().lines, None);

    // the further starts from a fit short of the optimum (SK without ML)
    let pipeline = Pipeline::default();
    let sk = Pipeline {
        ml: None,
        ..Pipeline::default()
    }
    .fit(&model, &data)
    .unwrap();
    assert!(sk.cost() > truth.cost * (1.0 + 1e-6));
    let further = model
        .further_starts(&pipeline, &data, &sk, true)
        .expect("the further starts improve on SK");
    assert!(
        further.cost() <= truth.cost * (1.0 + 1e-9),
        "{} vs {}",
        further.cost(),
        truth.cost
    );
    let stages = further.stages();
    let last = stages.last().unwrap();
    assert_eq!(last.kind, StageKind::MlPolish, "{stages:?}");
    assert_eq!(last.lines, None);
    assert!(
        stages[..stages.len() - 1]
            .iter()
            .all(|s| s.lines.is_some_and(|l| l < data.len())),
        "{stages:?}"
    );
}

/// The noise-free response of `sys` at `omega`.
fn sys_frf(sys: &common::RandomSystem, omega: &[f64]) -> Vec<Complex<f64>> {
    common::RandomSystem {
        zpk: sys.zpk.clone(),
        na: sys.na,
        nb: sys.nb,
        omega: omega.to_vec(),
    }
    .frf()
}
