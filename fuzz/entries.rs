//! The entry points the fuzz targets drive, shared with the property test
//! `robustness_fuzz` of the test suite (which includes this file): each takes arbitrary
//! bytes and must return, with a value or a typed error, without panicking.

use fdid::io::{
    ChannelSelection, Column, Measurement, parse_channels, parse_csv, parse_touchstone,
    parse_touchstone_v2,
};
use fdid::model::WithNoiseModel;
use fdid::{Delayed, FittedModel, Rational};

/// The CSV and Touchstone readers on arbitrary bytes: any input gives a measurement (or
/// network data) or a typed error, whose invariants hold.
pub fn csv(data: &[u8]) {
    if let Ok(m) = parse_csv::<f64, _>(data, "fuzz") {
        // a time record goes through its DFT; a matrix of several entries is refused
        match m.into_frequency_data() {
            Ok(f) => assert!(!f.is_empty()),
            Err(e) => assert!(e.to_string().contains("frequency response matrix")),
        }
    }
    if let Ok(Measurement::Time(t)) = parse_csv::<f32, _>(data, "fuzz") {
        let _ = t.dft();
    }
    // Touchstone version 1 or 2.0 as .s1p/.s2p, and version 2.0 as .ts; with a version 2
    // header in front, so that the keyword parser sees the bytes too
    let mut v2 = b"[Version] 2.0\n# Hz S RI\n".to_vec();
    v2.extend_from_slice(data);
    for bytes in [data, &v2[..]] {
        for ports in 1..=2 {
            if let Ok(t) = parse_touchstone(bytes, ports, "fuzz") {
                assert_eq!(t.ports, ports);
                assert_eq!(t.values.len(), t.freq_hz.len());
                let _ = t.frequency_data::<f64>((ports, 1));
            }
        }
        if let Ok(t) = parse_touchstone_v2(bytes, "fuzz") {
            assert!(t.values.iter().all(|m| m.len() == t.ports * t.ports));
        }
    }
    let selection = ChannelSelection {
        input: Column::Index(1),
        output: Column::Index(2),
        ts: Some(0.5),
    };
    let _ = parse_channels::<f64, _>(data, "fuzz.dat", &selection);
}

/// The saved-model loader: the `fitted` object of every model kind `fdid eval` reads,
/// checked and evaluated at a few frequencies.
pub fn saved_model(bytes: &[u8]) {
    respond(bytes, &[0.0, 1.0, 1e3]);
}

/// `fdid eval`: the first 16 bytes give two frequencies (rad/s) and a point count, the
/// rest is the saved model.
pub fn eval(bytes: &[u8]) {
    if bytes.len() < 16 {
        return;
    }
    let (head, model) = bytes.split_at(16);
    let word = |k: usize| f64::from_le_bytes(head[8 * k..8 * k + 8].try_into().unwrap_or([0; 8]));
    let (lo, hi) = (word(0), word(1));
    let n = 1 + usize::from(head[0] % 16);
    let omega: Vec<f64> = (0..n)
        .map(|k| lo + (hi - lo) * k as f64 / n as f64)
        .collect();
    respond(model, &omega);
}

/// Loads `json` as each model kind; a model that passes its check is evaluated.
fn respond(json: &[u8], omega: &[f64]) {
    macro_rules! kind {
        ($m:ty) => {
            if let Ok(m) = serde_json::from_slice::<FittedModel<f64, $m>>(json)
                && m.check().is_ok()
            {
                let _ = m.response(omega);
                let _ = m.response_std(omega);
            }
        };
    }
    kind!(Rational<f64>);
    kind!(Delayed<Rational<f64>>);
    kind!(WithNoiseModel<Rational<f64>>);
    kind!(WithNoiseModel<Delayed<Rational<f64>>>);
}
