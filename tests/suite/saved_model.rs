//! Saving and reloading a fitted model: a fit written to JSON and read back evaluates to
//! the same response, bit for bit.
#![cfg(feature = "serde")]

use fdid::fitted::FittedModel;
use fdid::model::Delayed;
use fdid::prelude::*;

/// Noisy FRF lines of G(s) = (s + 2)/(s² + 0.4 s + 4) on 60 log-spaced frequencies.
fn data() -> FrequencyData<f64> {
    let omega: Vec<f64> = (0..60)
        .map(|k| 10f64.powf(-1.0 + 2.0 * k as f64 / 59.0))
        .collect();
    let g = omega
        .iter()
        .enumerate()
        .map(|(k, w)| {
            let s = Complex::new(0.0, *w);
            let noise = Complex::new((k as f64 * 1.7).sin(), (k as f64 * 2.3).cos()) * 1e-3;
            (s + 2.0) / (s * s + s * 0.4 + 4.0) + noise
        })
        .collect();
    FrequencyData::from_frf(omega, g, None).unwrap()
}

fn bits(v: &[Complex<f64>]) -> Vec<(u64, u64)> {
    v.iter().map(|c| (c.re.to_bits(), c.im.to_bits())).collect()
}

#[test]
fn fitted_rational_round_trips_to_the_last_bit() {
    let data = data();
    let model = Rational::continuous(2, 1, data.omega()).unwrap();
    let fit = Pipeline::default().fit(&model, &data).unwrap();
    let saved = FittedModel::of_fit(&fit);
    let text = serde_json::to_string(&saved).unwrap();
    let back: FittedModel<f64, Rational<f64>> = serde_json::from_str(&text).unwrap();
    assert_eq!(back, saved);
    // on the data grid and off it
    let off: Vec<f64> = (0..37).map(|k| 0.05 * 1.17f64.powi(k)).collect();
    for omega in [data.omega(), off.as_slice()] {
        let original = fit.model().response(fit.theta(), omega);
        assert_eq!(bits(&back.response(omega)), bits(&original));
    }
    // the fit's stored response comes from its Jacobian evaluation: equal to rounding
    for (a, b) in back.response(data.omega()).iter().zip(fit.response()) {
        assert!((a - b).norm() <= 1e-14 * b.norm(), "{a} vs {b}");
    }
    // the uncertainty is that of the fit
    let std = back.response_std(data.omega()).unwrap();
    for (a, b) in std.iter().zip(fit.response_std().unwrap()) {
        assert!((a - b).abs() <= 1e-9 * b.abs(), "{a} vs {b}");
    }
    // and so are its bounds on |G| and the phase, on the data lines
    let bounds = back.bounds(data.omega(), 0.95).unwrap();
    for (a, b) in bounds.iter().zip(fit.bounds(0.95).unwrap()) {
        for (x, y) in [
            (a.magnitude.0, b.magnitude.0),
            (a.magnitude.1, b.magnitude.1),
            (a.phase.0, b.phase.0),
            (a.phase.1, b.phase.1),
        ] {
            assert!((x - y).abs() <= 1e-9 * y.abs().max(1e-12), "{x} vs {y}");
        }
        assert!(a.magnitude.0 < a.magnitude.1 && a.phase.0 < a.phase.1);
    }
    // wider at a higher level; none outside (0, 1) or without a covariance
    let wide = back.bounds(&off, 0.99).unwrap();
    let narrow = back.bounds(&off, 0.5).unwrap();
    assert!(
        wide.iter()
            .zip(&narrow)
            .all(|(w, n)| w.magnitude.1 > n.magnitude.1 && w.phase.0 < n.phase.0)
    );
    assert!(back.bounds(&off, 1.0).is_none() && back.bounds(&off, 0.0).is_none());
    let mut blind = back.clone();
    blind.covariance = None;
    assert!(blind.bounds(&off, 0.95).is_none());
}

#[test]
fn whole_fit_and_data_round_trip() {
    let data = data();
    let text = serde_json::to_string(&data).unwrap();
    let back: FrequencyData<f64> = serde_json::from_str(&text).unwrap();
    assert_eq!(back, data);

    let model = Delayed::new(Rational::continuous(2, 1, data.omega()).unwrap());
    let fit = fdid::estimate::fit_delayed(&Pipeline::default(), model.inner(), &data).unwrap();
    let text = serde_json::to_string(&fit).unwrap();
    let back: Fit<f64, Delayed<Rational<f64>>> = serde_json::from_str(&text).unwrap();
    assert_eq!(back.theta(), fit.theta());
    assert_eq!(bits(back.response()), bits(fit.response()));
    assert_eq!(
        bits(&back.response_at(data.omega())),
        bits(&fit.response_at(data.omega()))
    );
    assert_eq!(back.cost().to_bits(), fit.cost().to_bits());
    // the response's standard deviations are recomputed after the round trip
    assert!(fit.response_std().is_some());
    assert_eq!(back.response_std(), fit.response_std());
    assert_eq!(back.phase_std(), fit.phase_std());
}

/// `value` with the JSON pointer `path` replaced by `new`.
fn edited(value: &serde_json::Value, path: &str, new: serde_json::Value) -> String {
    let mut v = value.clone();
    *v.pointer_mut(path).unwrap_or_else(|| panic!("{path}")) = new;
    v.to_string()
}

/// A model read from an edited file is rebuilt from its orders, basis and transient and
/// checked: every inconsistent field is an error naming it (an edited reflector used to
/// index out of bounds when evaluated); the unedited file still reads back exactly.
#[test]
fn edited_model_structures_are_refused_on_reading() {
    use serde_json::json;
    let data = data();
    // nb + 1 < na: the partial-fraction numerator is held by its Householder reflectors
    let model = Rational::continuous(4, 1, data.omega()).unwrap();
    let fit = Pipeline::default().fit(&model, &data).unwrap();
    let saved = serde_json::to_value(FittedModel::of_fit(&fit)).unwrap();
    let read = |text: &str| serde_json::from_str::<FittedModel<f64, Rational<f64>>>(text);
    assert_eq!(read(&saved.to_string()).unwrap(), FittedModel::of_fit(&fit));
    let m = "/model";
    for (path, new, named) in [
        (
            format!("{m}/numerator_reflectors/reflectors/0/start"),
            json!(7),
            "numerator_reflectors",
        ),
        (
            format!("{m}/numerator_reflectors/n"),
            json!(1),
            "numerator_reflectors",
        ),
        (
            format!("{m}/numerator_reflectors/reflectors/0/tau"),
            json!(0.5),
            "numerator_reflectors",
        ),
        (
            format!("{m}/numerator_map/0/0"),
            json!(3.0),
            "numerator_map",
        ),
        (format!("{m}/basis/PartialFractions/poles"), json!([]), "nb"),
        (
            format!("{m}/basis/PartialFractions/poles/0"),
            json!([0.0, 1.0]),
            "basis pole",
        ),
        (format!("{m}/na"), json!(6), "na"),
        (format!("{m}/transient"), json!(-1.0), "ts"),
    ] {
        let err = read(&edited(&saved, &path, new)).unwrap_err().to_string();
        assert!(err.contains(named), "{path}: {err}");
    }
    // discrete time: the sample time, and a transient of another sample time
    let model = Rational::discrete(2, 1, 0.1)
        .unwrap()
        .with_transient()
        .unwrap();
    let text = serde_json::to_value(&model).unwrap();
    let back: Rational<f64> = serde_json::from_str(&text.to_string()).unwrap();
    assert_eq!(back, model);
    for (path, new, named) in [
        ("/basis/DelayPowers/ts", json!(0.0), "ts"),
        ("/transient", json!(0.2), "transient"),
    ] {
        let err = serde_json::from_str::<Rational<f64>>(&edited(&text, path, new)).unwrap_err();
        assert!(err.to_string().contains(named), "{path}: {err}");
    }
    // polynomial continuous time: too few recurrence coefficients, a negative one
    let model = Rational::polynomial(3, 1, data.omega()).unwrap();
    let text = serde_json::to_value(&model).unwrap();
    for (path, new) in [
        ("/basis/Orthonormal/gamma", json!([1.0])),
        ("/basis/Orthonormal/gamma/0", json!(-1.0)),
        ("/basis/Orthonormal/scale", json!(0.0)),
    ] {
        let err = serde_json::from_str::<Rational<f64>>(&edited(&text, path, new)).unwrap_err();
        assert!(err.to_string().contains("basis"), "{path}: {err}");
    }
    // delay bounds the wrong way round
    let delayed = Delayed::new(Rational::discrete(1, 0, 1.0).unwrap())
        .with_bounds(0.0, 2.0)
        .unwrap();
    let text = serde_json::to_value(&delayed).unwrap();
    let err = serde_json::from_str::<Delayed<Rational<f64>>>(&edited(
        &text,
        "/bounds",
        json!([2.0, 0.0]),
    ))
    .unwrap_err();
    assert!(err.to_string().contains("delay bounds"), "{err}");
}

/// [`FittedModel::check`] refuses a θ of the wrong length or not finite, a covariance that
/// is not p × p, not symmetric or not positive semidefinite, and a negative noise variance.
#[test]
fn fitted_summary_check_names_the_bad_field() {
    let data = data();
    let model = Rational::continuous(2, 1, data.omega()).unwrap();
    let fit = Pipeline::default().fit(&model, &data).unwrap();
    let good = FittedModel::of_fit(&fit);
    good.check().unwrap();
    let p = good.theta.len();
    let cases: Vec<(FittedModel<f64, Rational<f64>>, &str)> = vec![
        (
            FittedModel {
                theta: good.theta[..p - 1].to_vec(),
                ..good.clone()
            },
            "theta",
        ),
        (
            FittedModel {
                theta: {
                    let mut t = good.theta.clone();
                    t[0] = f64::NAN;
                    t
                },
                ..good.clone()
            },
            "theta",
        ),
        (
            FittedModel {
                noise_variance: -1.0,
                ..good.clone()
            },
            "noise_variance",
        ),
        (
            FittedModel {
                covariance: Some(nalgebra::DMatrix::identity(p + 1, p + 1)),
                ..good.clone()
            },
            "covariance",
        ),
        (
            FittedModel {
                covariance: Some({
                    let mut c = nalgebra::DMatrix::identity(p, p);
                    c[(0, 1)] = 0.5;
                    c
                }),
                ..good.clone()
            },
            "symmetric",
        ),
        (
            FittedModel {
                covariance: Some({
                    let mut c = nalgebra::DMatrix::identity(p, p);
                    c[(0, 1)] = 2.0;
                    c[(1, 0)] = 2.0;
                    c
                }),
                ..good.clone()
            },
            "semidefinite",
        ),
    ];
    for (bad, named) in cases {
        let err = bad.check().unwrap_err().to_string();
        assert!(err.contains(named), "{named}: {err}");
    }
}
