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
