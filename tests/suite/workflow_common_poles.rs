//! The discrepancy workflow on every entry of an FRF matrix
//! (`fdid::workflow::diagnose_common_poles`): a common-pole model one resonance short is
//! told so by the summed residual power, the resonance is named near the missing mode,
//! two poles are added and accepted by the likelihood-ratio test, and the gap closes; a
//! model of the right order is left alone.

use super::mimo::{Case, noisy_matrix};
use fdid::data::FrfMatrix;
use fdid::mimo::{CommonPoleModel, CommonPoleOptions};
use fdid::workflow::{check_common_poles, diagnose_common_poles};

/// A case's FRF matrix on 300 log-spaced lines (0.05–20 rad/s) with complex noise of
/// variance `var` on every line and entry, the variances attached.
fn noisy(case: &Case, var: f64) -> (CommonPoleModel<f64>, FrfMatrix<f64>) {
    let model = case.model();
    let omega: Vec<f64> = (0..300)
        .map(|k| 0.05 * (400.0f64).powf(k as f64 / 299.0))
        .collect();
    let data = noisy_matrix(&model, &omega, var, case.seed ^ 0x5151);
    (model, data)
}

fn case(seed: u64) -> Case {
    Case {
        seed,
        ny: 2,
        nu: 2,
        pairs: 4,
        real: 0,
    }
}

#[test]
fn a_missing_resonance_is_named_added_and_the_gap_closes() {
    for seed in [7u64, 19, 23] {
        let (model, data) = noisy(&case(seed), 1e-6);
        let options = CommonPoleOptions::<f64>::default();
        let diagnosis = diagnose_common_poles(&data, 6, &options, 0.01, 3).unwrap();
        let first = &diagnosis.steps[0];
        let resonance = first.check.resonance.as_ref().unwrap();
        assert!(
            first.check.resonance_found(0.01),
            "seed {seed}: p = {}",
            resonance.p_value
        );
        // the named resonance lies at a true mode that the first model misses
        let found: Vec<f64> = first
            .fit
            .model
            .poles
            .pairs
            .iter()
            .map(|p| p.norm() / std::f64::consts::TAU)
            .collect();
        let missed: Vec<f64> = model
            .poles
            .pairs
            .iter()
            .map(|p| p.norm() / std::f64::consts::TAU)
            .filter(|f| !found.iter().any(|g| (g - f).abs() < 0.01 * f))
            .collect();
        assert!(
            missed
                .iter()
                .any(|f| (resonance.peak_hz - f).abs() < 0.1 * f),
            "seed {seed}: resonance at {} Hz, missed modes {missed:?}",
            resonance.peak_hz
        );
        let result = diagnosis.result();
        assert_eq!(result.order, 8, "seed {seed}: {}", diagnosis.stop);
        assert!(result.lr.as_ref().unwrap().p_value < 0.01);
        assert!(
            !result.check.resonance_found(0.01),
            "seed {seed}: {}",
            diagnosis.stop
        );
        // every true pole is in the final model, and each entry's cost is at the noise level
        for p in &model.poles.pairs {
            assert!(
                result
                    .fit
                    .model
                    .poles
                    .pairs
                    .iter()
                    .any(|q| (q - p).norm() < 0.01 * p.norm()),
                "seed {seed}: pole {p}"
            );
        }
        for e in &result.check.entries {
            let p = e.validation.cost_p.unwrap();
            assert!(
                p > 1e-4,
                "seed {seed} entry {}{}: cost p = {p}",
                e.output,
                e.input
            );
        }
    }
}

/// At the true order the shared-resonance test is a test at level α: over 40 noisy
/// matrices of the right order it fires on at most 6 (expected 2 at α = 0.05; the
/// binomial tail beyond 6 is below 0.5 %).
#[test]
fn a_model_of_the_right_order_is_left_alone() {
    let mut alarms = 0;
    for seed in 1..=40u64 {
        let (model, data) = noisy(&case(seed * 101), 1e-4);
        let fit = fdid::mimo::fit_common_poles(&data, model.order(), &CommonPoleOptions::default())
            .unwrap();
        let check = check_common_poles(&data, &fit);
        assert!(check.noise_known);
        if check.resonance_found(0.05) {
            alarms += 1;
        }
    }
    assert!(alarms <= 6, "{alarms} false alarms in 40");
}

#[test]
fn a_bad_level_is_an_error() {
    let (_, data) = noisy(&case(3), 1e-4);
    for alpha in [0.0, 1.0, f64::NAN] {
        let e =
            diagnose_common_poles(&data, 4, &CommonPoleOptions::default(), alpha, 3).unwrap_err();
        assert!(e.to_string().contains("alpha"), "{e}");
    }
}
