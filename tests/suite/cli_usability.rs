//! The `fdid` command on Touchstone files, saving and evaluating a fitted model, and the
//! examples in every help text.
#![cfg(feature = "cli")]

use crate::cli_common as cli;

use cli::{Scratch, bundled, fdid, json_of, run, stderr, stdout};
use serde_json::Value;

/// The series RLC of data/rlc_bandpass.s2p: S21 = 2 Z0 s C / (L C s² + (R + 2 Z0) C s + 1)
/// with R = 5, L = 1e-6, C = 1e-9, Z0 = 50.
fn s21_poles() -> [f64; 2] {
    let (b, c): (f64, f64) = (105.0 / 1e-6, 1.0 / 1e-15);
    let d = (b * b - 4.0 * c).sqrt();
    [(-b - d) / 2.0, (-b + d) / 2.0]
}

#[test]
fn touchstone_two_port_fit_finds_the_rlc_poles() {
    let v = json_of(&fdid(&[
        "fit",
        &bundled("rlc_bandpass.s2p"),
        "--domain",
        "s",
        "--na",
        "2",
        "--nb",
        "1",
        "--port",
        "21",
        "--json",
    ]));
    let mut poles: Vec<f64> = v["poles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p[0].as_f64().unwrap())
        .collect();
    poles.sort_by(f64::total_cmp);
    for (got, want) in poles.iter().zip(s21_poles()) {
        assert!((got - want).abs() < 1e-4 * want.abs(), "{got} vs {want}");
    }
    // S21: at resonance |S21| = 2 Z0/(2 Z0 + R)
    let r = v["relative_residual"].as_f64().unwrap();
    assert!(r < 1e-5, "relative residual {r}");
}

#[test]
fn touchstone_port_selects_the_entry_and_s1p_reads() {
    let s2p = bundled("rlc_bandpass.s2p");
    let fit = |file: &str, port: Option<&str>| {
        let mut a = vec![
            "fit", file, "--domain", "s", "--na", "2", "--nb", "2", "--json",
        ];
        if let Some(p) = port {
            a.extend(["--port", p]);
        }
        json_of(&fdid(&a))
    };
    let s11 = fit(&s2p, Some("11"));
    let s22 = fit(&s2p, Some("22"));
    let s1p = fit(&bundled("rlc_bandpass.s1p"), None);
    // S11 = Z/(Z + 2 Z0) -> 1 far from resonance; S22 = S11 for the symmetric network; the
    // .s1p holds the same S11 in another unit and format
    let g0 = |v: &Value| v["frf"][0][1].as_f64().unwrap();
    assert!((g0(&s11) - g0(&s22)).abs() < 1e-6);
    assert!(
        (g0(&s11) - g0(&s1p)).abs() < 1e-5,
        "{} vs {}",
        g0(&s11),
        g0(&s1p)
    );
    let s21 = fit(&s2p, Some("21"));
    assert!((g0(&s21) - g0(&s11)).abs() > 0.1);

    let bad = fdid(&[
        "fit", &s2p, "--domain", "s", "--na", "2", "--nb", "1", "--port", "13",
    ]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("--port 13"), "{}", stderr(&bad));
}

#[test]
fn diagnose_reads_touchstone_and_adds_the_missing_pole() {
    let v = json_of(&fdid(&[
        "diagnose",
        &bundled("rlc_bandpass.s2p"),
        "--domain",
        "s",
        "--na",
        "1",
        "--nb",
        "1",
        "--port",
        "21",
        "--json",
    ]));
    assert_eq!(v["effects"][0], "missing_pole", "{v}");
    assert_eq!(v["final"]["na"], 2);
    let csv = fdid(&[
        "fit",
        &bundled("eis_battery.csv"),
        "--domain",
        "s",
        "--na",
        "1",
        "--nb",
        "1",
        "--port",
        "11",
    ]);
    assert_eq!(csv.status.code(), Some(2));
    assert!(stderr(&csv).contains("Touchstone"), "{}", stderr(&csv));
}

#[test]
fn malformed_touchstone_is_one_error_line_with_its_line_number() {
    let dir = Scratch::new("bad-ts");
    let p = dir.file("bad.s1p", "! x\n# MHz S MA R 50\n1 0.5 10\n2 0.5 oops\n");
    let o = run("fit", &p, &["--domain", "s", "--na", "1", "--nb", "1"]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.starts_with("error:") && e.contains("line 4") && e.contains("oops"),
        "{e}"
    );
    let p = dir.file("v2.s2p", "[Version] 2.0\n# GHz S RI\n");
    let o = run("fit", &p, &["--domain", "s", "--na", "1", "--nb", "1"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        e.starts_with("error:") && e.contains("line 2") && e.contains("[Number of Ports]"),
        "{e}"
    );
}

#[test]
fn saved_model_evaluates_to_the_fitted_response() {
    let dir = Scratch::new("save");
    let model = dir.path("eis.json");
    let m = model.to_str().unwrap();
    let fit = json_of(&fdid(&[
        "fit",
        &bundled("eis_battery.csv"),
        "--domain",
        "s",
        "--na",
        "4",
        "--nb",
        "4",
        "--band",
        ":1000",
        "--json",
        "--save",
        m,
    ]));
    let saved: Value = serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    assert_eq!(saved["format"], "fdid-model");
    assert_eq!(saved["kind"], "rational");
    assert_eq!(saved["fitted"]["theta"], fit["theta"]);
    // evaluate at the fitted frequencies: the same response as the fit's `frf`
    let frf = fit["frf"].as_array().unwrap();
    let freqs: Vec<String> = frf.iter().map(|r| r[0].to_string()).collect();
    let ev = json_of(&fdid(&["eval", m, "--freq", &freqs.join(","), "--json"]));
    let got = ev["frf"].as_array().unwrap();
    assert_eq!(got.len(), frf.len());
    for (a, b) in got.iter().zip(frf) {
        for c in 1..3 {
            let (x, y) = (a[c].as_f64().unwrap(), b[c].as_f64().unwrap());
            assert!((x - y).abs() <= 1e-12 * y.abs().max(1e-3), "{x} vs {y}");
        }
    }
    for (a, b) in ev["frf_std"]
        .as_array()
        .unwrap()
        .iter()
        .zip(fit["frf_std"].as_array().unwrap())
    {
        let (x, y) = (a.as_f64().unwrap(), b.as_f64().unwrap());
        assert!((x - y).abs() <= 1e-6 * y, "{x} vs {y}");
    }
    // CSV output with a log grid
    let csv = fdid(&["eval", m, "--freq", "0.01:100:5"]);
    assert!(csv.status.success(), "{}", stderr(&csv));
    let text = stdout(&csv);
    let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(rows[0], "f,re,im,std");
    assert_eq!(rows.len(), 6);
    // a file that is not a saved model
    let o = fdid(&["eval", &bundled("eis_battery.csv"), "--freq", "1"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).starts_with("error:"));
}

#[test]
fn every_help_shows_an_example() {
    for sub in [None, Some("fit"), Some("diagnose"), Some("eval")] {
        let mut args: Vec<&str> = sub.into_iter().collect();
        args.push("--help");
        let o = fdid(&args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        let text = stdout(&o);
        let examples = text
            .split("Examples:")
            .nth(1)
            .unwrap_or_else(|| panic!("{args:?}: no examples"));
        let lines: Vec<&str> = examples
            .lines()
            .map(str::trim)
            .filter(|l| l.starts_with("fdid "))
            .collect();
        assert!(!lines.is_empty(), "{args:?}: no example line");
        if let Some(s) = sub {
            assert!(
                lines.iter().any(|l| l.starts_with(&format!("fdid {s} "))),
                "{s}: no example of the subcommand itself"
            );
        }
        // every example on bundled data names a file that exists
        for l in lines {
            for word in l.split_whitespace().filter(|w| w.starts_with("data/")) {
                let p = format!("{}/{word}", env!("CARGO_MANIFEST_DIR"));
                assert!(
                    std::path::Path::new(&p).exists(),
                    "{args:?}: {word} missing"
                );
            }
        }
    }
}

/// `fdid eval` of an edited saved model exits 1 with the field named (an edited reflector
/// used to panic, exit 70), and an N beyond 10⁷ in `--freq FMIN:FMAX:N` is a usage error
/// (exit 2) before anything is allocated.
#[test]
fn eval_refuses_edited_models_and_huge_grids() {
    let dir = Scratch::new("save-edited");
    let model = dir.path("eis.json");
    let m = model.to_str().unwrap();
    let o = fdid(&[
        "fit",
        &bundled("eis_battery.csv"),
        "--domain",
        "s",
        "--na",
        "4",
        "--nb",
        "2",
        "--band",
        ":1000",
        "--save",
        m,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let saved: Value = serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    let variance = saved["fitted"]["covariance"][0][0].as_f64().unwrap();
    for (path, new, named) in [
        (
            "/fitted/model/numerator_reflectors/reflectors/0/start",
            serde_json::json!(7),
            "numerator_reflectors",
        ),
        (
            "/fitted/model/numerator_reflectors/n",
            serde_json::json!(7),
            "numerator_reflectors",
        ),
        (
            "/fitted/covariance/0/0",
            serde_json::json!(-variance),
            "covariance",
        ),
    ] {
        let mut v = saved.clone();
        *v.pointer_mut(path).unwrap() = new;
        let edited = dir.path("edited.json");
        std::fs::write(&edited, v.to_string()).unwrap();
        let o = fdid(&["eval", edited.to_str().unwrap(), "--freq", "1,10"]);
        assert_eq!(o.status.code(), Some(1), "{path}: {}", stderr(&o));
        assert!(stderr(&o).contains(named), "{path}: {}", stderr(&o));
    }
    for n in ["18446744073709551615", "1000000000000", "10000001"] {
        let o = fdid(&["eval", m, "--freq", &format!("1:100:{n}")]);
        assert_eq!(o.status.code(), Some(2), "{n}: {}", stderr(&o));
        assert!(stderr(&o).contains("at most 10000000"), "{}", stderr(&o));
    }
}
