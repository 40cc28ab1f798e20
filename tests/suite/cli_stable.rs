//! `fdid fit --stable` and the report of an unstable fit: the bundled robot arm
//! (`--domain z --periods 1`, reference order 4 with resonances near 0.058 and 0.127
//! cycles/sample, data/README.md) fitted stable at orders 4, 6 and 8; the noise-free FRF
//! of an unstable system, whose free fit is unstable (a warning line, `"stable":false`)
//! and whose `--stable` fit is stable.
#![cfg(feature = "cli")]

use crate::cli_common as cli;

use cli::{Scratch, bundled, fdid, json_of, run, stdout_ok};
use serde_json::Value;

fn robot_arm(na: usize, extra: &[&str]) -> std::process::Output {
    let n = na.to_string();
    let path = bundled("robot_arm.csv");
    let mut args = vec![
        "fit",
        path.as_str(),
        "--domain",
        "z",
        "--periods",
        "1",
        "--na",
        &n,
        "--nb",
        &n,
    ];
    args.extend_from_slice(extra);
    fdid(&args)
}

/// The poles `[[re, im], …]` of a JSON report.
fn poles(v: &Value) -> Vec<(f64, f64)> {
    v["poles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| (p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
        .collect()
}

#[test]
fn robot_arm_stable_fits_at_orders_4_to_8() {
    for na in [4, 6, 8] {
        let v = json_of(&robot_arm(na, &["--stable", "--json"]));
        assert_eq!(v["stable"], Value::Bool(true), "na {na}");
        let p = poles(&v);
        assert!(
            p.iter().all(|(re, im)| re.hypot(*im) < 1.0),
            "na {na}: {p:?}"
        );
        // the two resonances of the reference, in cycles/sample
        let f: Vec<f64> = p
            .iter()
            .filter(|(_, im)| *im > 0.0)
            .map(|(re, im)| im.atan2(*re) / std::f64::consts::TAU)
            .collect();
        for r in [0.058, 0.127] {
            assert!(
                f.iter().any(|x| (x - r).abs() < 0.005),
                "na {na}: no resonance near {r}: {f:?}"
            );
        }
    }
}

/// G(s) = 1/((s − 0.5)(s² + 0.2 s + 4)), noise free, 200 lines from 0.1 to 10 rad/s.
fn unstable_csv(dir: &Scratch) -> std::path::PathBuf {
    let mut text = String::from("f,re,im\n");
    for k in 0..200 {
        let w = 10f64.powf(-1.0 + 2.0 * k as f64 / 199.0);
        // (iω − 0.5)(4 − ω² + 0.2 iω)
        let (a, b) = (-0.5, w);
        let (c, d) = (4.0 - w * w, 0.2 * w);
        let (re, im) = (a * c - b * d, a * d + b * c);
        let n = re * re + im * im;
        text.push_str(&format!(
            "{},{},{}\n",
            w / std::f64::consts::TAU,
            re / n,
            -im / n
        ));
    }
    dir.file("unstable.csv", &text)
}

#[test]
fn unstable_fit_prints_a_warning_and_stable_false() {
    let dir = Scratch::new("cli_stable");
    let path = unstable_csv(&dir);
    let args = ["--domain", "s", "--na", "3", "--nb", "2"];
    let text = stdout_ok(&run("fit", &path, &args));
    assert!(text.contains("stable       no"), "{text}");
    assert!(
        text.lines()
            .any(|l| l.starts_with("warning") && l.contains("the model is unstable")),
        "{text}"
    );
    let mut json_args = args.to_vec();
    json_args.push("--json");
    let v = json_of(&run("fit", &path, &json_args));
    assert_eq!(v["stable"], Value::Bool(false));
    assert!(poles(&v).iter().any(|(re, _)| *re > 0.0));
    // --stable: stable, no warning
    let mut stable_args = args.to_vec();
    stable_args.push("--stable");
    let text = stdout_ok(&run("fit", &path, &stable_args));
    assert!(text.contains("stable       yes"), "{text}");
    assert!(!text.contains("the model is unstable"), "{text}");
    stable_args.push("--json");
    let v = json_of(&run("fit", &path, &stable_args));
    assert_eq!(v["stable"], Value::Bool(true));
    assert!(poles(&v).iter().all(|(re, _)| *re < 0.0));
}

#[test]
fn stable_flag_with_every_criterion() {
    let dir = Scratch::new("cli_stable_criteria");
    let path = unstable_csv(&dir);
    for criterion in ["levy", "sk", "ml", "tls"] {
        let args = [
            "--domain",
            "s",
            "--na",
            "3",
            "--nb",
            "2",
            "--stable",
            "--json",
            "--criterion",
            criterion,
        ];
        let v = json_of(&run("fit", &path, &args));
        assert_eq!(v["stable"], Value::Bool(true), "{criterion}");
    }
}

/// G(s) = 1/((s² − 0.02 s + 4)(s + 1)): a resonance at 2 rad/s with negative damping
/// (ζ = −0.005), noise free, 200 lines from 0.1 to 10 rad/s.
fn barely_unstable_csv(dir: &Scratch) -> std::path::PathBuf {
    let mut text = String::from("f,re,im\n");
    for k in 0..200 {
        let w = 10f64.powf(-1.0 + 2.0 * k as f64 / 199.0);
        let s = ::fdid::Complex::new(0.0, w);
        let g = ::fdid::Complex::new(1.0, 0.0) / ((s * s - s * 0.02 + 4.0) * (s + 1.0));
        text.push_str(&format!(
            "{},{},{}\n",
            w / std::f64::consts::TAU,
            g.re,
            g.im
        ));
    }
    dir.file("barely_unstable.csv", &text)
}

/// With `--stable` the constrained ML stops the pair that the data place across the
/// boundary on it: the model is stable in name only, and the report says so (a warning
/// line, JSON `marginal_poles`); without `--stable` the pair is unstable, warned as such,
/// and not listed as marginal.
#[test]
fn a_pole_stopped_on_the_boundary_is_warned_about() {
    let dir = Scratch::new("cli_stable_marginal");
    let path = barely_unstable_csv(&dir);
    let args = ["--domain", "s", "--na", "3", "--nb", "0"];
    let mut stable_args = args.to_vec();
    stable_args.push("--stable");
    let text = stdout_ok(&run("fit", &path, &stable_args));
    assert!(text.contains("stable       yes"), "{text}");
    assert!(
        text.lines()
            .any(|l| l.starts_with("warning") && l.contains("on the stability boundary")),
        "{text}"
    );
    stable_args.push("--json");
    let v = json_of(&run("fit", &path, &stable_args));
    let marginal = v["marginal_poles"].as_array().expect("marginal_poles");
    assert_eq!(marginal.len(), 1, "{marginal:?}");
    let im = marginal[0][1].as_f64().unwrap();
    assert!((im - 2.0).abs() < 0.01, "{marginal:?}");
    let mut free_args = args.to_vec();
    free_args.push("--json");
    let v = json_of(&run("fit", &path, &free_args));
    assert_eq!(v["stable"], Value::Bool(false));
    assert_eq!(v["marginal_poles"], serde_json::json!([]));
    // the saved model carries the boundary pole, and `fdid eval` warns about it
    let model = dir.path("marginal.json");
    let mut save_args = args.to_vec();
    save_args.extend(["--stable", "--save", model.to_str().unwrap()]);
    stdout_ok(&run("fit", &path, &save_args));
    let csv = stdout_ok(&run("eval", &model, &["--freq", "0.1,0.3"]));
    assert!(
        csv.lines()
            .any(|l| l.starts_with("# warning: pole") && l.contains("stability boundary")),
        "{csv}"
    );
    let v = json_of(&run("eval", &model, &["--freq", "0.1,0.3", "--json"]));
    assert_eq!(v["marginal_poles"].as_array().map(Vec::len), Some(1), "{v}");
}
