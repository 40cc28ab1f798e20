//! The stabilisation diagram (`fdid::mimo::stabilisation_diagram`): on noisy FRF matrices
//! of random MIMO systems every true mode is found as a physical mode, and the marks
//! follow their definitions.

use super::mimo::{Case, noisy_matrix};
use fdid::data::FrfMatrix;
use fdid::mimo::{CommonPoleOptions, PoleMark, StabilityTolerances, stabilisation_diagram};
use fdid::prelude::*;

/// A case's FRF matrix on 400 log-spaced lines (0.05–20 rad/s) with complex noise of
/// relative level `snr_db` below the largest entry, and its variances.
fn noisy(case: &Case, snr_db: f64) -> (fdid::mimo::CommonPoleModel<f64>, FrfMatrix<f64>) {
    let model = case.model();
    let omega: Vec<f64> = (0..400)
        .map(|k| 0.05 * (400.0f64).powf(k as f64 / 399.0))
        .collect();
    let peak = model
        .response(&omega)
        .iter()
        .flat_map(|m| m.iter().map(|v| v.norm()))
        .fold(0.0, f64::max);
    let var = (peak * 10f64.powf(-snr_db / 20.0)).powi(2);
    let data = noisy_matrix(&model, &omega, var, case.seed ^ 0xabcd);
    (model, data)
}

#[test]
fn every_true_mode_is_a_physical_mode_of_the_diagram() {
    for seed in [3u64, 11, 29] {
        let case = Case {
            seed,
            ny: 3,
            nu: 2,
            pairs: 4,
            real: 0,
        };
        let (model, data) = noisy(&case, 60.0);
        let orders: Vec<usize> = (2..=20).step_by(2).collect();
        let options = CommonPoleOptions {
            stable: true,
            ml: false,
            ..CommonPoleOptions::default()
        };
        let diagram =
            stabilisation_diagram(&data, &orders, &options, &StabilityTolerances::default())
                .unwrap();
        assert_eq!(diagram.orders, orders);
        assert!(diagram.failed.is_empty(), "{:?}", diagram.failed);
        let truth: Vec<(f64, f64)> = model
            .poles
            .pairs
            .iter()
            .map(|p| (p.norm() / std::f64::consts::TAU, -p.re / p.norm()))
            .collect();
        for (f, zeta) in &truth {
            let found = diagram
                .modes
                .iter()
                .find(|m| (m.f_n_hz - f).abs() < 0.005 * f);
            let Some(m) = found else {
                panic!(
                    "seed {seed}: mode {f:.4} Hz (zeta {zeta:.3}) not among {:?}",
                    diagram.modes.iter().map(|m| m.f_n_hz).collect::<Vec<_>>()
                );
            };
            assert!(
                (m.damping - zeta).abs() < 0.05 * zeta,
                "seed {seed}: damping {} for {zeta}",
                m.damping
            );
            assert!(m.orders.len() >= 3 && m.orders[0] >= 2);
        }
        // the first order's poles are all new; a stable mark needs a pole of the previous
        // order within 1 % in frequency and 5 % in damping
        for p in &diagram.poles {
            if p.order == orders[0] {
                assert_eq!(p.mark, PoleMark::New);
            }
            if p.mark == PoleMark::Stable {
                let prev = p.order - 2;
                assert!(diagram.poles.iter().any(|q| q.order == prev
                    && (q.mode.f_n_hz - p.mode.f_n_hz).abs() <= 0.01 * p.mode.f_n_hz
                    && (q.mode.damping - p.mode.damping).abs() <= 0.05 * p.mode.damping));
            }
        }
    }
}

#[test]
fn an_empty_order_list_is_an_error() {
    let case = Case {
        seed: 5,
        ny: 1,
        nu: 1,
        pairs: 1,
        real: 0,
    };
    let (_, data) = noisy(&case, 60.0);
    let e = stabilisation_diagram(
        &data,
        &[],
        &CommonPoleOptions::default(),
        &StabilityTolerances::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("at least one order"), "{e}");
    // every order failing (more poles than the lines carry) returns the first error
    let few = data.band_hz(0.0, 0.01).unwrap();
    let e = stabilisation_diagram(
        &few,
        &[40],
        &CommonPoleOptions::default(),
        &StabilityTolerances::default(),
    )
    .unwrap_err();
    assert!(matches!(e, FdidError::TooFewFrequencies { .. }), "{e}");
}
