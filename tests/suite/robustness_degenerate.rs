//! Degenerate data get typed errors in the user's terms, not a fit of arbitrary poles:
//! an identically zero output, a constant input (it excites only DC), fewer excited lines
//! than parameters, and Touchstone rows whose column count does not match the port count
//! of the extension.
#![cfg(feature = "cli")]

use crate::cli_common::{Scratch, run, stderr};
use fdid::estimate::ModelSpec;
use fdid::io::parse_touchstone;
use fdid::prelude::*;

/// A time record `t,u,y` of `n` samples with `u(k)`, `y(k)`.
fn record(u: impl Fn(usize) -> f64, y: impl Fn(usize) -> f64, n: usize) -> String {
    let mut text = String::from("t,u,y\n");
    for k in 0..n {
        text.push_str(&format!("{},{},{}\n", k as f64 * 0.1, u(k), y(k)));
    }
    text
}

/// A deterministic pseudo-random sequence in (−1, 1).
fn noise(k: usize) -> f64 {
    let x = (k as f64 * 12.9898).sin() * 43_758.545;
    2.0 * (x - x.floor()) - 1.0
}

/// `fdid fit` with `args` on `file` fails with exit 1 and a message containing `words`.
fn fails_with(file: &std::path::Path, args: &[&str], words: &[&str]) {
    let out = run("fit", file, args);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{}: {err}", file.display());
    for w in words {
        assert!(err.contains(w), "{}: `{w}` not in: {err}", file.display());
    }
}

const Z22: [&str; 8] = ["--domain", "z", "--na", "2", "--nb", "2", "--ts", "0.1"];

/// Old: "fitted" with no poles, exit 0.
#[test]
fn an_identically_zero_output_is_refused() {
    let dir = Scratch::new("degenerate_zero");
    let time = dir.file("zero_y.csv", &record(noise, |_| 0.0, 1000));
    fails_with(&time, &Z22, &["output is zero", "no response to fit"]);
    let mut frf = String::from("f,re,im\n");
    for k in 1..=500 {
        frf.push_str(&format!("{},0,0\n", k as f64 * 0.1));
    }
    let frf = dir.file("zero_frf.csv", &frf);
    fails_with(
        &frf,
        &["--domain", "s", "--na", "2", "--nb", "1"],
        &["output is zero on all 500 lines"],
    );
    let out = run(
        "diagnose",
        &frf,
        &["--domain", "s", "--na", "2", "--nb", "1"],
    );
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(stderr(&out).contains("output is zero"), "{}", stderr(&out));
    // the library says the same
    let data = FrequencyData::from_frf(vec![1.0, 2.0, 3.0], vec![Complex::new(0.0, 0.0); 3], None)
        .unwrap();
    let err = ModelSpec::continuous(1, 0).fit(&data).unwrap_err();
    assert!(matches!(err, FdidError::ZeroOutput { lines: 3 }), "{err:?}");
    let model = Rational::continuous(1, 0, data.omega()).unwrap();
    let err = Pipeline::default().fit(&model, &data).unwrap_err();
    assert!(matches!(err, FdidError::ZeroOutput { .. }), "{err:?}");
}

/// Old: gain −2.7e15 (or 6e14), exit 0, and `diagnose` "consistent".
#[test]
fn a_constant_input_is_refused_as_exciting_only_dc() {
    let dir = Scratch::new("degenerate_constant");
    let file = dir.file("constant_u.csv", &record(|_| 1.0, noise, 1000));
    fails_with(&file, &Z22, &["input is constant", "only DC"]);
    let out = run("diagnose", &file, &Z22);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(stderr(&out).contains("only DC"), "{}", stderr(&out));
    // an input with a large offset but a real variation is still excited everywhere
    let offset = dir.file("offset_u.csv", &record(|k| 1e3 + noise(k), noise, 1000));
    let out = run("fit", &offset, &Z22);
    assert!(out.status.success(), "{}", stderr(&out));
}

/// Three excited lines cannot determine five parameters: the count of lines against the
/// count of parameters.
#[test]
fn fewer_excited_lines_than_parameters_is_refused() {
    let dir = Scratch::new("degenerate_few_lines");
    // one sine at line 50 of a 1000-sample record: one excited line
    let file = dir.file(
        "one_sine.csv",
        &record(
            |k| (std::f64::consts::TAU * 50.0 * k as f64 / 1000.0).sin(),
            noise,
            1000,
        ),
    );
    fails_with(
        &file,
        &Z22,
        &["1 lines give 2 real equations for 5 parameters"],
    );
}

/// A 1-port file under a 2-port extension, and a 2-port file under a 1-port one: the
/// row's column count against the port count, with the line (old: 166 lines of a wrong
/// S21, exit 0; "negative frequency" or "not above the previous one").
#[test]
fn touchstone_rows_must_match_the_port_count() {
    let mut one_port = String::from("# GHz S RI R 50\n");
    for k in 1..=498 {
        let f = k as f64 * 0.01;
        one_port.push_str(&format!("{f} {} {}\n", 0.5 / (1.0 + f), -0.1 * f));
    }
    let err = parse_touchstone(one_port.as_bytes(), 2, "a.s2p")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("line 2") && err.contains("3 numbers") && err.contains("holds 9"),
        "{err}"
    );
    let mut two_port = String::from("# GHz S RI R 50\n");
    for k in 1..=10 {
        two_port.push_str(&format!("{} 0.1 0 0.9 0 0.9 0 0.1 0\n", k as f64 * 0.1));
    }
    let err = parse_touchstone(two_port.as_bytes(), 1, "a.s1p")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("line 2") && err.contains("9 numbers") && err.contains(".s2p"),
        "{err}"
    );
    // a 2-port row continued over two lines is still read
    let wrapped = "# GHz S RI R 50\n1 0.1 0 0.9 0\n 0.9 0 0.1 0\n2 0.1 0 0.9 0 0.9 0 0.1 0\n";
    assert_eq!(
        parse_touchstone(wrapped.as_bytes(), 2, "w.s2p")
            .unwrap()
            .freq_hz
            .len(),
        2
    );
    // and the command reports it
    let dir = Scratch::new("degenerate_touchstone");
    let file = dir.file("one_port.s2p", &one_port);
    fails_with(
        &file,
        &["--domain", "s", "--na", "2", "--nb", "1"],
        &["1-port file named .s2p"],
    );
}
