//! The bundled Touchstone samples against the circuit they were computed from.
#![cfg(feature = "csv")]

use fdid::Complex;
use fdid::io::{NetworkParameter, NumberFormat, read_touchstone};
use std::path::Path;

/// S11 and S21 of a series R–L–C (5 Ω, 1 µH, 1 nF) between two 50 Ω ports at f Hz.
fn rlc(f: f64) -> (Complex<f64>, Complex<f64>) {
    let w = std::f64::consts::TAU * f;
    let z = Complex::new(5.0, w * 1e-6) + Complex::new(0.0, -1.0 / (w * 1e-9));
    (z / (z + 100.0), Complex::new(100.0, 0.0) / (z + 100.0))
}

fn bundled(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
}

#[test]
fn bundled_s2p_matches_the_circuit() {
    let t = read_touchstone(&bundled("rlc_bandpass.s2p")).unwrap();
    assert_eq!(
        (t.ports, t.parameter, t.format),
        (2, NetworkParameter::S, NumberFormat::DecibelAngle)
    );
    assert_eq!(t.freq_hz.len(), 37);
    assert_eq!(t.freq_hz[0], 1e6);
    assert_eq!(t.freq_hz[36], 1e7);
    for (f, m) in t.freq_hz.iter().zip(&t.values) {
        let (s11, s21) = rlc(*f);
        // row-major S11 S12 S21 S22; 6 significant digits in the file
        for (got, want) in m.iter().zip([s11, s21, s21, s11]) {
            assert!((got - want).norm() < 2e-5, "{f} Hz: {got} vs {want}");
        }
    }
}

#[test]
fn bundled_s1p_is_the_same_s11() {
    let one = read_touchstone(&bundled("rlc_bandpass.s1p")).unwrap();
    let two = read_touchstone(&bundled("rlc_bandpass.s2p")).unwrap();
    assert_eq!(one.format, NumberFormat::RealImaginary);
    assert_eq!(one.freq_hz, two.freq_hz);
    let a = one.frequency_data::<f64>((1, 1)).unwrap();
    let b = two.frequency_data::<f64>((1, 1)).unwrap();
    for (x, y) in a.y().iter().zip(b.y()) {
        assert!((x - y).norm() < 2e-5, "{x} vs {y}");
    }
    assert!(read_touchstone(&bundled("eis_battery.csv")).is_err());
}

/// The vendor's Touchstone file of a measured 4-port (`../shared/data/minicircuits-zx10q`,
/// README: Latin-1 degree signs in its `!` comments; S21 on 1 591 lines, 10 MHz–4 GHz,
/// |S21| = −3.45 dB at 1.8 GHz): the comments are read as Latin-1, the data as written.
#[test]
fn a_vendor_file_with_latin1_comments_is_read() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/minicircuits-zx10q/ZX10Q-2-19-S+_Plus25degC.s4p");
    if !path.exists() {
        eprintln!("skipped: {} is not there", path.display());
        return;
    }
    let t = read_touchstone(&path).unwrap();
    assert_eq!(t.ports, 4);
    assert_eq!(t.freq_hz.len(), 1591);
    assert!((t.freq_hz[0] - 10e6).abs() < 1.0 && (t.freq_hz[1590] - 4e9).abs() < 1.0);
    let k = t
        .freq_hz
        .iter()
        .position(|f| (f - 1.8e9).abs() < 1.0)
        .unwrap();
    let s21 = t.values[k][4]; // row 2, column 1
    let db = 20.0 * s21.norm().log10();
    assert!((db + 3.45).abs() < 0.01, "|S21| = {db} dB at 1.8 GHz");
}
