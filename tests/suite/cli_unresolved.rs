//! Poles the data do not resolve (`Fit::unresolved_poles`) in the reports of `fdid fit`,
//! `fdid diagnose` and `fdid eval`: a lightly damped resonance fitted between two lines is
//! named with a warning; the fits of the bundled data sets carry none.
#![cfg(feature = "cli")]

use crate::cli_common as cli;

use cli::{Scratch, bundled, fdid, json_of, stdout_ok};
use serde_json::Value;
use std::f64::consts::TAU;
use std::path::Path;

/// ζ = 10⁻⁴ at 1 rad/s and ζ = 0.05 at 20 rad/s, unit static gain each.
fn g(w: f64) -> (f64, f64) {
    let mut out = (0.0, 0.0);
    for (wn, zeta) in [(1.0, 1e-4), (20.0, 0.05)] {
        // wn² / (wn² − w² + 2iζ wn w)
        let (re, im) = (wn * wn - w * w, 2.0 * zeta * wn * w);
        let d = re * re + im * im;
        out.0 += wn * wn * re / d;
        out.1 -= wn * wn * im / d;
    }
    out
}

/// The noise-free FRF on 600 log-spaced lines from 0.1 to 100 rad/s, without the lines
/// within 2·10⁻³ rad/s of the 1 rad/s resonance (whose half-power band is ±10⁻⁴ rad/s:
/// the nearest lines are 1 % away) unless `line_at_resonance`, which adds ω = 1.
fn resonance_csv(line_at_resonance: bool) -> String {
    let mut omega: Vec<f64> = (0..600)
        .map(|k| 10f64.powf(-1.0 + 3.0 * k as f64 / 599.0))
        .filter(|w| (w - 1.0).abs() > 2e-3)
        .collect();
    if line_at_resonance {
        omega.push(1.0);
        omega.sort_by(f64::total_cmp);
    }
    let mut text = String::from("f,re,im\n");
    for w in omega {
        let (re, im) = g(w);
        text.push_str(&format!("{:e},{re:e},{im:e}\n", w / TAU));
    }
    text
}

const ORDERS: [&str; 6] = ["--domain", "s", "--na", "4", "--nb", "3"];

fn fit_args<'a>(file: &'a Path, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["fit", file.to_str().unwrap()];
    a.extend_from_slice(&ORDERS);
    a.extend_from_slice(extra);
    a
}

/// The one unresolved pole of a JSON report: the 1 rad/s resonance, with its band and
/// the lines either side of it.
fn check_unresolved_json(v: &Value) {
    let list = v["unresolved_poles"].as_array().expect("unresolved_poles");
    assert_eq!(list.len(), 1, "{list:?}");
    let u = &list[0];
    let (re, im) = (
        u["pole"][0].as_f64().unwrap(),
        u["pole"][1].as_f64().unwrap(),
    );
    assert!(
        (re + 1e-4).abs() < 1e-7 && (im - 1.0).abs() < 1e-6,
        "pole {re} {im}"
    );
    let (lo, hi) = (
        u["band_hz"][0].as_f64().unwrap(),
        u["band_hz"][1].as_f64().unwrap(),
    );
    assert!((lo - (1.0 - 1e-4) / TAU).abs() < 1e-8, "{lo}");
    assert!((hi - (1.0 + 1e-4) / TAU).abs() < 1e-8, "{hi}");
    let (below, above) = (
        u["nearest_lines_hz"][0].as_f64().unwrap(),
        u["nearest_lines_hz"][1].as_f64().unwrap(),
    );
    assert!(below < lo && above > hi, "{below} {above}");
    assert!(below * TAU < 1.0 - 2e-3 && above * TAU > 1.0 + 2e-3);
    assert!((u["s"][0].as_f64().unwrap() + 1e-4).abs() < 1e-7);
}

/// The warning line of the text report naming the pole.
fn warning_lines(text: &str) -> Vec<&str> {
    text.lines()
        .filter(|l| l.starts_with("warning") && l.contains("unresolved pole"))
        .collect()
}

#[test]
fn a_resonance_between_two_lines_is_named_in_text_and_json() {
    let dir = Scratch::new("gap");
    let file = dir.file("gap.csv", &resonance_csv(false));
    let text = stdout_ok(&fdid(&fit_args(&file, &[])));
    let warnings = warning_lines(&text);
    assert_eq!(warnings.len(), 1, "{text}");
    let w = warnings[0];
    for needle in [
        "unresolved pole -1.000000e-4 +/- 1.0000000i (rad/s)",
        "no line in its half-power band 0.1591390 .. 0.1591709 Hz",
        "|sigma| = 1.000000e-4 rad/s",
        "nearest lines 0.1579",
        "do not determine its damping",
    ] {
        assert!(w.contains(needle), "`{needle}` missing from: {w}");
    }
    check_unresolved_json(&json_of(&fdid(&fit_args(&file, &["--json"]))));
}

#[test]
fn a_line_inside_the_band_resolves_the_resonance() {
    let dir = Scratch::new("line");
    let file = dir.file("line.csv", &resonance_csv(true));
    let text = stdout_ok(&fdid(&fit_args(&file, &[])));
    assert!(!text.contains("unresolved"), "{text}");
    let v = json_of(&fdid(&fit_args(&file, &["--json"])));
    assert_eq!(v["unresolved_poles"], Value::Array(vec![]));
    // the same poles as without the line: the warning comes from the grid alone
    assert!(
        v["poles"]
            .as_array()
            .unwrap()
            .iter()
            .any(|p| (p[0].as_f64().unwrap() + 1e-4).abs() < 1e-7)
    );
}

#[test]
fn a_delayed_fit_names_the_resonance_too() {
    let dir = Scratch::new("delay");
    let file = dir.file("gap.csv", &resonance_csv(false));
    let text = stdout_ok(&fdid(&fit_args(&file, &["--delay"])));
    assert!(text.contains("\ndelay "), "{text}");
    assert_eq!(warning_lines(&text).len(), 1, "{text}");
    check_unresolved_json(&json_of(&fdid(&fit_args(&file, &["--delay", "--json"]))));
}

#[test]
fn saved_model_keeps_the_unresolved_poles_and_eval_warns() {
    let dir = Scratch::new("save");
    let file = dir.file("gap.csv", &resonance_csv(false));
    let model = dir.path("model.json");
    let model = model.to_str().unwrap();
    stdout_ok(&fdid(&fit_args(&file, &["--save", model])));
    let saved: Value = serde_json::from_str(&std::fs::read_to_string(model).unwrap()).unwrap();
    let list = saved["unresolved_poles"].as_array().expect("saved key");
    assert_eq!(list.len(), 1, "{list:?}");
    assert!((list[0][1].as_f64().unwrap() - 1.0).abs() < 1e-6);
    // eval: a comment line in CSV, the key in JSON
    let csv = stdout_ok(&fdid(&["eval", model, "--freq", "0.1,0.2"]));
    assert_eq!(
        csv.lines()
            .filter(|l| l.starts_with("# warning: unresolved pole"))
            .count(),
        1,
        "{csv}"
    );
    let ev = json_of(&fdid(&["eval", model, "--freq", "0.1,0.2", "--json"]));
    assert_eq!(ev["unresolved_poles"].as_array().unwrap().len(), 1);
    // a file saved before the key existed still evaluates, with no warning
    let mut old = saved.clone();
    old.as_object_mut().unwrap().remove("unresolved_poles");
    let old_path = dir.file("old.json", &old.to_string());
    let csv_old = stdout_ok(&fdid(&[
        "eval",
        old_path.to_str().unwrap(),
        "--freq",
        "0.1,0.2",
    ]));
    assert!(!csv_old.contains("warning"), "{csv_old}");
    let strip = |t: &str| -> Vec<String> {
        t.lines()
            .filter(|l| !l.starts_with('#'))
            .map(String::from)
            .collect()
    };
    assert_eq!(strip(&csv_old), strip(&csv));
    // a malformed key is an error naming the file, not a panic
    let mut bad = saved;
    bad["unresolved_poles"] = Value::String("x".into());
    let bad_path = dir.file("bad.json", &bad.to_string());
    let o = fdid(&["eval", bad_path.to_str().unwrap(), "--freq", "0.1"]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.starts_with("error:") && err.contains("bad.json"),
        "{err}"
    );
}

#[test]
fn diagnose_names_the_resonance_of_its_final_model() {
    let dir = Scratch::new("diagnose");
    let file = dir.file("gap.csv", &resonance_csv(false));
    let mut args = vec!["diagnose", file.to_str().unwrap()];
    args.extend_from_slice(&ORDERS);
    let text = stdout_ok(&fdid(&args));
    assert!(!warning_lines(&text).is_empty(), "{text}");
    assert!(
        text.contains("the data do not resolve (listed above)"),
        "{text}"
    );
    args.push("--json");
    let v = json_of(&fdid(&args));
    check_unresolved_json(&v["initial"]);
    assert!(
        !v["final"]["unresolved_poles"]
            .as_array()
            .unwrap()
            .is_empty()
    );
}

#[test]
fn bundled_data_sets_have_no_unresolved_poles() {
    let cases: [(&str, &[&str]); 2] = [
        (
            "eis_battery.csv",
            &["--domain", "s", "--na", "6", "--nb", "6", "--band", ":1000"],
        ),
        (
            "dryer.csv",
            &["--domain", "z", "--ts", "0.08", "--na", "2", "--nb", "2"],
        ),
    ];
    for (name, flags) in cases {
        let file = bundled(name);
        let mut args = vec!["fit", file.as_str()];
        args.extend_from_slice(flags);
        let text = stdout_ok(&fdid(&args));
        assert!(!text.contains("unresolved"), "{name}: {text}");
        args.push("--json");
        let v = json_of(&fdid(&args));
        assert_eq!(v["unresolved_poles"], Value::Array(vec![]), "{name}");
    }
    let dryer = bundled("dryer.csv");
    let args = [
        "diagnose", &dryer, "--domain", "z", "--ts", "0.08", "--na", "2", "--nb", "2",
    ];
    let text = stdout_ok(&fdid(&args));
    assert!(!text.contains("unresolved"), "{text}");
}

/// The robot arm's input excites the odd lines only (spacing 2/1024 Hz). Its first
/// resonance (ζ ≈ 0.003 at 0.058 Hz) has a half-power band of about 4·10⁻⁴ Hz and the
/// second (ζ ≈ 0.005 at 0.127 Hz) of about 1.2·10⁻³ Hz, both narrower than that spacing:
/// each falls between two excited lines and is named.
#[test]
fn robot_arm_resonances_fall_between_two_excited_lines() {
    let file = bundled("robot_arm.csv");
    let args = [
        "fit",
        &file,
        "--domain",
        "z",
        "--na",
        "4",
        "--nb",
        "4",
        "--periods",
        "1",
    ];
    let text = stdout_ok(&fdid(&args));
    let warnings = warning_lines(&text);
    assert_eq!(warnings.len(), 2, "{text}");
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("nearest lines 0.05761719 and 0.05957031 Hz")),
        "{warnings:?}"
    );
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("nearest lines 0.1259766 and 0.1279297 Hz")),
        "{warnings:?}"
    );
    let mut args = args.to_vec();
    args.push("--json");
    let v = json_of(&fdid(&args));
    let list = v["unresolved_poles"].as_array().unwrap();
    assert_eq!(list.len(), 2);
    let first = list
        .iter()
        .map(|p| {
            (
                p["band_hz"][0].as_f64().unwrap(),
                p["band_hz"][1].as_f64().unwrap(),
            )
        })
        .find(|(lo, _)| *lo < 0.1)
        .expect("the first resonance");
    let (lo, hi) = first;
    assert!(
        hi - lo < 2.0 / 1024.0 && lo > 0.0576 && hi < 0.0596,
        "{lo} {hi}"
    );
}
