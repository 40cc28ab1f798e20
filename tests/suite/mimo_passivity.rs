//! Passivity enforcement of scattering models (`fdid::mimo::enforce_passivity`): random
//! 2 × 2 and 3 × 3 common-pole models scaled to a largest singular value of 1.2 are made
//! passive on the check's grid, with a smaller change than the uniform scaling that would
//! also make them passive, the poles kept; a passive model is left as it is.

use crate::mimo::Case;
use fdid::mimo::{CommonPoleModel, enforce_passivity, passivity};
use fdid::prelude::*;

/// The check's grid density (as the command's).
const POINTS: usize = 2000;

fn lines() -> Vec<f64> {
    (0..300)
        .map(|k| 0.05 * (400.0f64).powf(k as f64 / 299.0))
        .collect()
}

/// `model` scaled so that its largest singular value on the check's grid is `peak`.
fn scaled(model: &CommonPoleModel<f64>, f_max_hz: f64, peak: f64) -> CommonPoleModel<f64> {
    let s = passivity(model, f_max_hz, POINTS).max_singular_value;
    let mut out = model.clone();
    for r in out.residues.iter_mut() {
        *r *= Complex::new(peak / s, 0.0);
    }
    if let Some(d) = out.direct.as_mut() {
        *d *= peak / s;
    }
    out
}

#[test]
fn violations_are_removed_with_less_change_than_scaling() {
    let omega = lines();
    let f_max = omega[omega.len() - 1] / std::f64::consts::TAU;
    let mut worst_ratio: f64 = 0.0;
    for seed in 0..12u64 {
        let n = 2 + (seed as usize) % 2;
        let case = Case {
            seed: 2 * seed + 11,
            ny: n,
            nu: n,
            pairs: 1 + (seed as usize) % 4,
            real: (seed as usize) % 2,
        };
        let model = scaled(&case.model(), f_max, 1.2);
        let before = passivity(&model, f_max, POINTS);
        assert!(!before.passive(), "seed {seed}: the scaled model violates");
        let e = enforce_passivity(&model, &omega, f_max, POINTS).unwrap();
        assert!(e.after.passive(), "seed {seed}: {:?}", e.after);
        assert!(e.after.max_singular_value <= 1.0 + 1e-6);
        assert_eq!(e.model.poles, model.poles);
        assert!(
            !e.scaled,
            "seed {seed}: the perturbation did better than scaling"
        );
        // a uniform scaling by 1/1.2 also makes it passive: its change is 1 − 1/1.2
        let uniform = 1.0 - 1.0 / 1.2;
        assert!(
            e.relative_change < uniform,
            "seed {seed}: change {} vs scaling {uniform}",
            e.relative_change
        );
        worst_ratio = worst_ratio.max(e.relative_change / uniform);
        // between the grid's points the model stays close to passive
        let fine = passivity(&e.model, f_max, 8 * POINTS);
        assert!(fine.max_singular_value < 1.01, "seed {seed}: {fine:?}");
    }
    eprintln!("largest change relative to uniform scaling: {worst_ratio:.3}");
}

#[test]
fn a_passive_model_is_left_unchanged() {
    let omega = lines();
    let f_max = omega[omega.len() - 1] / std::f64::consts::TAU;
    let case = Case {
        seed: 5,
        ny: 2,
        nu: 2,
        pairs: 2,
        real: 1,
    };
    let model = scaled(&case.model(), f_max, 0.9);
    let e = enforce_passivity(&model, &omega, f_max, POINTS).unwrap();
    assert_eq!(e.iterations, 0);
    assert_eq!(e.model, model);
    assert_eq!(e.relative_change, 0.0);
    assert!(enforce_passivity(&model, &[], f_max, POINTS).is_err());
}
