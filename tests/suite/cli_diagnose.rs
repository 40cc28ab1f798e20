//! Integration tests of `fdid diagnose`: the built binary on simulated time records, on
//! frequency files and on the bundled dryer data.
#![cfg(feature = "cli")]
use crate::cli_common as cli;
use crate::common;

use cli::{Scratch, fdid, json, run, stderr, stdout};
use common::{Noise, lfilter};
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// B(z⁻¹)/A(z⁻¹) of the simulated second-order system (poles 0.6 ± 0.6i).
const B2: [f64; 3] = [0.2, 0.3, 0.1];
const A2: [f64; 3] = [1.0, -1.2, 0.72];

/// The flags of a second-order model of B2/A2.
const ORDERS: [&str; 6] = ["--domain", "z", "--na", "2", "--nb", "2"];

/// `t,u,y` CSV of a record with sample time 1.
fn csv(u: &[f64], y: &[f64]) -> String {
    let mut s = String::from("t,u,y\n");
    for (k, (u, y)) in u.iter().zip(y).enumerate() {
        s.push_str(&format!("{k},{u:e},{y:e}\n"));
    }
    s
}

/// `periods` periods of `n` samples of the steady-state response of B2/A2 to a periodic
/// Gaussian input, the input delayed by `delay` samples, plus white output noise of
/// standard deviation `sigma`.
fn periodic_record(seed: u64, n: usize, periods: usize, delay: usize, sigma: f64) -> String {
    let mut noise = Noise::new(seed);
    let one: Vec<f64> = (0..n).map(|_| noise.gauss()).collect();
    // two warm-up periods bring the response to its steady state (|pole| = 0.85)
    let x: Vec<f64> = (0..(periods + 2) * n).map(|k| one[k % n]).collect();
    let delayed: Vec<f64> = (0..x.len())
        .map(|k| x[(k + x.len() - delay) % x.len()])
        .collect();
    let y0 = lfilter(&B2, &A2, &delayed);
    let u = &x[2 * n..];
    let y: Vec<f64> = y0[2 * n..]
        .iter()
        .map(|v| v + sigma * noise.gauss())
        .collect();
    csv(u, &y)
}

/// One non-periodic record of `n` samples (the system running before the record starts,
/// so that its transient is present), white output noise of standard deviation `sigma`.
fn non_periodic_record(seed: u64, n: usize, sigma: f64) -> String {
    let mut noise = Noise::new(seed);
    let x: Vec<f64> = (0..n + 200).map(|_| noise.gauss()).collect();
    let y0 = lfilter(&B2, &A2, &x);
    let u = &x[200..];
    let y: Vec<f64> = y0[200..]
        .iter()
        .map(|v| v + sigma * noise.gauss())
        .collect();
    csv(u, &y)
}

fn effects(v: &Value) -> Vec<String> {
    v["effects"]
        .as_array()
        .expect("effects array")
        .iter()
        .map(|e| e.as_str().unwrap().to_string())
        .collect()
}

fn keys(v: &Value) -> BTreeSet<String> {
    v.as_object().expect("object").keys().cloned().collect()
}

#[test]
fn clean_periodic_data_name_no_effect() {
    let dir = Scratch::new("clean");
    for seed in 1..=3 {
        let path = dir.file(
            &format!("clean{seed}.csv"),
            &periodic_record(seed, 256, 4, 0, 0.02),
        );
        let v = json(
            "diagnose",
            &path,
            &["--domain", "z", "--na", "2", "--nb", "2", "--periods", "4"],
        );
        assert_eq!(effects(&v), Vec::<String>::new(), "seed {seed}: {v}");
        assert_eq!(v["steps"], serde_json::json!([]));
        assert_eq!(v["consistent_with_noise"], Value::Bool(true), "seed {seed}");
        assert_eq!(v["noise_reference"], "periods");
        // no step: the final model is the initial one
        assert_eq!(v["initial"]["cost"], v["final"]["cost"]);
        assert_eq!(v["final"]["na"], 2);
    }
}

#[test]
fn json_contract_keys() {
    let dir = Scratch::new("contract");
    let path = dir.file("d.csv", &periodic_record(7, 256, 4, 3, 0.02));
    let v = json(
        "diagnose",
        &path,
        &["--domain", "z", "--na", "2", "--nb", "2", "--periods", "4"],
    );
    let want: BTreeSet<String> = [
        "steps",
        "effects",
        "consistent_with_noise",
        "unmodelled",
        "bands",
        "noise_reference",
        "initial",
        "final",
        "refits_rejected",
        "eliminated",
        "named",
        "time_varying_ode",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    assert_eq!(keys(&v), want);
    let step_keys: BTreeSet<String> = [
        "effect",
        "p_value",
        "cost_before",
        "cost_after",
        "lr_p",
        "detail",
        "revised",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let steps = v["steps"].as_array().unwrap();
    assert!(!steps.is_empty());
    for s in steps {
        assert_eq!(keys(s), step_keys);
        assert!(s["detail"].is_object());
        assert!(s["cost_after"].as_f64().unwrap() < s["cost_before"].as_f64().unwrap());
    }
    assert_eq!(
        effects(&v),
        steps
            .iter()
            .map(|s| s["effect"].as_str().unwrap().to_string())
            .collect::<Vec<_>>()
    );
}

#[test]
fn hidden_delay_is_named_first() {
    let dir = Scratch::new("delay");
    for seed in 1..=3 {
        let path = dir.file(
            &format!("delay{seed}.csv"),
            &periodic_record(10 + seed, 256, 4, 3, 0.02),
        );
        let v = json(
            "diagnose",
            &path,
            &["--domain", "z", "--na", "2", "--nb", "2", "--periods", "4"],
        );
        let e = effects(&v);
        assert_eq!(e.first().map(String::as_str), Some("time_delay"), "{e:?}");
        let tau = v["final"]["delay"]
            .as_f64()
            .expect("a delay in the final model");
        assert!((tau - 3.0).abs() < 0.05, "seed {seed}: tau = {tau}");
        assert_eq!(v["consistent_with_noise"], Value::Bool(true), "seed {seed}");
    }
}

/// `final` has exactly the keys of `fdid fit --json` on the final spec, and the same fit.
#[test]
fn final_matches_fit_json() {
    let dir = Scratch::new("same-keys");
    let path = dir.file("d.csv", &periodic_record(21, 256, 4, 3, 0.02));
    let base = ["--domain", "z", "--na", "2", "--nb", "2", "--periods", "4"];
    let v = json("diagnose", &path, &base);
    assert_eq!(effects(&v), vec!["time_delay".to_string()]);
    let mut with_delay = base.to_vec();
    with_delay.push("--delay");
    let fit = json("fit", &path, &with_delay);
    assert_eq!(keys(&v["final"]), keys(&fit));
    let (a, b) = (
        v["final"]["cost"].as_f64().unwrap(),
        fit["cost"].as_f64().unwrap(),
    );
    assert!((a - b).abs() <= 1e-9 * b, "diagnose {a} vs fit {b}");
    assert_eq!(v["final"]["theta_names"], fit["theta_names"]);
    // the starting model too
    let start = json("fit", &path, &base);
    assert_eq!(keys(&v["initial"]), keys(&start));
    assert_eq!(v["initial"]["cost"], start["cost"]);
}

#[test]
fn report_directory_holds_the_files() {
    let dir = Scratch::new("report");
    let path = dir.file("d.csv", &periodic_record(31, 128, 4, 2, 0.02));
    let out = dir.path("out/nested");
    let report = ["--periods", "4", "--report", out.to_str().unwrap()];
    let o = run("diagnose", &path, &[&ORDERS[..], &report].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    for needle in [
        "noise ref.   periods",
        "start        z",
        "steps",
        "time_delay",
        "final model",
        "verdict",
        "report.json",
    ] {
        assert!(text.contains(needle), "`{needle}` missing from:\n{text}");
    }
    let txt = std::fs::read_to_string(out.join("report.txt")).unwrap();
    assert!(txt.starts_with("fdid diagnose"));
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(json["effects"][0], "time_delay");
    #[cfg(feature = "plot")]
    for name in ["bode.svg", "residuals.svg"] {
        let svg = std::fs::read_to_string(out.join(name)).unwrap();
        assert!(
            svg.starts_with("<svg"),
            "{name}: {}",
            &svg[..40.min(svg.len())]
        );
        assert!(svg.trim_end().ends_with("</svg>"));
        // the initial and final model (lines) and the data (points) are drawn
        assert!(svg.contains("<polyline") && svg.contains("<circle") || name != "bode.svg");
    }
    #[cfg(not(feature = "plot"))]
    assert!(text.contains("`plot` feature"));
}

#[test]
fn bad_usage_exits_2_naming_the_flag() {
    let dir = Scratch::new("usage");
    let path = dir.file("d.csv", &periodic_record(41, 64, 2, 0, 0.02));
    let p = path.to_str().unwrap();
    let base = ["diagnose", p, "--domain", "z", "--na", "2", "--nb", "2"];
    for (extra, needle) in [
        (vec!["--alpha", "0"], "--alpha"),
        (vec!["--alpha", "1.5"], "--alpha"),
        (vec!["--alpha", "abc"], "--alpha"),
        (vec!["--max-steps", "-1"], "--max-steps"),
        (vec!["--bogus"], "--bogus"),
        (vec!["--na", "101"], "--na"),
        (vec!["--ts", "2"], "--ts"),
    ] {
        let mut args = base.to_vec();
        if extra[0] == "--na" {
            args[5] = extra[1];
        } else {
            args.extend(&extra);
        }
        let o = fdid(&args);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.starts_with("error:") && e.contains(needle),
            "{extra:?}: {e}"
        );
        assert_eq!(e.trim().lines().count(), 1, "{e}");
    }
    // a missing flag
    let o = fdid(&["diagnose", p, "--domain", "z", "--na", "2"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--nb"), "{}", stderr(&o));
    // --transient on frequency data
    let frf = dir.file("g.csv", "f,re,im\n0.1,1,0\n0.2,0.9,-0.1\n0.3,0.8,-0.2\n");
    let o = run(
        "diagnose",
        &frf,
        &["--domain", "s", "--na", "1", "--nb", "0", "--transient"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--transient"), "{}", stderr(&o));
}

#[test]
fn bad_data_and_report_paths_exit_1_naming_the_path() {
    let dir = Scratch::new("paths");
    let path = dir.file("d.csv", &periodic_record(51, 64, 2, 0, 0.02));
    // a report directory under a regular file cannot be created
    let blocker = dir.file("blocker", "x");
    let target = blocker.join("report");
    let report = ["--report", target.to_str().unwrap()];
    let o = run("diagnose", &path, &[&ORDERS[..], &report].concat());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(target.to_str().unwrap()),
        "{}",
        stderr(&o)
    );
    let missing = dir.path("missing.csv");
    let o = run("diagnose", &missing, &ORDERS);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("missing.csv"), "{}", stderr(&o));
}

/// Frequency files: with a `var` column the reference is `given`; without, `estimated`.
#[test]
fn frequency_files_name_their_noise_reference() {
    let dir = Scratch::new("frf");
    let mut noise = Noise::new(61);
    let (mut with, mut without) = (String::from("f,re,im,var\n"), String::from("f,re,im\n"));
    let var = 1e-4;
    for k in 1..=100 {
        let w = k as f64 * std::f64::consts::PI / 101.0;
        let zi = fdid::Complex::new(0.0, -w).exp();
        let poly = |c: &[f64]| {
            c.iter()
                .rev()
                .fold(fdid::Complex::new(0.0, 0.0), |s, v| s * zi + *v)
        };
        let g = poly(&B2) / poly(&A2) + noise.complex(var);
        let f = w / std::f64::consts::TAU;
        with.push_str(&format!("{f:e},{:e},{:e},{var:e}\n", g.re, g.im));
        without.push_str(&format!("{f:e},{:e},{:e}\n", g.re, g.im));
    }
    let args = ["--domain", "z", "--ts", "1", "--na", "2", "--nb", "2"];
    let v = json("diagnose", &dir.file("with.csv", &with), &args);
    assert_eq!(v["noise_reference"], "given");
    assert_eq!(effects(&v), Vec::<String>::new());
    assert_eq!(v["final"]["noise_known"], Value::Bool(true));
    let v = json("diagnose", &dir.file("without.csv", &without), &args);
    assert_eq!(v["noise_reference"], "estimated");
    assert_eq!(v["final"]["noise_known"], Value::Bool(false));
    let o = run("diagnose", &dir.path("without.csv"), &args);
    assert!(stdout(&o).contains("reduced power"), "{}", stdout(&o));
}

/// Runs diagnose with the correct model (order 2 with the transient) on one non-periodic
/// record per seed, the noise reference from the local polynomial method; returns the
/// number of runs that named an effect or ended inconsistent with the noise, and the mean
/// of V / E V of the final fits.
fn lpm_false_alarms(seeds: std::ops::Range<u64>) -> (usize, usize, f64) {
    let dir = Scratch::new("lpm");
    let (mut named, mut inconsistent) = (0, 0);
    let mut ratio = Vec::new();
    for seed in seeds {
        let path = dir.file("r.csv", &non_periodic_record(seed, 512, 0.05));
        let v = json(
            "diagnose",
            &path,
            &["--domain", "z", "--na", "2", "--nb", "2", "--transient"],
        );
        assert_eq!(v["noise_reference"], "lpm");
        ratio.push(
            v["final"]["cost"].as_f64().unwrap() / v["final"]["cost_expected"].as_f64().unwrap(),
        );
        if !effects(&v).is_empty() {
            named += 1;
            println!("seed {seed}: {:?}", effects(&v));
        }
        if v["consistent_with_noise"] != Value::Bool(true) {
            inconsistent += 1;
            println!(
                "seed {seed}: inconsistent, cost_p {} whiteness_p {}",
                v["final"]["cost_p"], v["final"]["whiteness_p"]
            );
        }
    }
    let mean = ratio.iter().sum::<f64>() / ratio.len() as f64;
    (named, inconsistent, mean)
}

/// The correct model on non-periodic records with LPM noise variances: the workflow names
/// an effect, or ends inconsistent with the noise, about as often as its level says
/// (measured: 0 of 100 named an effect, 1 of 100 inconsistent). About 2 s.
#[test]
fn lpm_reference_false_alarm_rate() {
    let runs = 100;
    let (named, inconsistent, ratio) = lpm_false_alarms(100..100 + runs);
    println!(
        "LPM reference, correct model: {named}/{runs} named an effect, \
         {inconsistent}/{runs} inconsistent, mean V/E V = {ratio:.3}"
    );
    // each run makes about 6 detector tests at alpha = 0.01 and one consistency test
    assert!(named <= 10, "{named}/{runs}");
    assert!(inconsistent <= 5, "{inconsistent}/{runs}");
}

/// The bundled dryer record (DaISy; known input delay of 3 samples, Ts = 0.08 s).
#[test]
fn dryer_data_show_the_delay_and_the_transient() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/dryer.csv");
    let v = json("diagnose", &path, &ORDERS);
    assert_eq!(v["noise_reference"], "lpm");
    let e = effects(&v);
    assert!(e.iter().any(|x| x == "time_delay"), "{e:?}");
    assert!(e.iter().any(|x| x == "transient"), "{e:?}");
    let tau = v["final"]["delay"].as_f64().unwrap();
    assert!((tau - 3.0 * 0.08).abs() < 0.08, "tau = {tau} s");
    assert!((v["final"]["delay_samples"].as_f64().unwrap() - 3.0).abs() < 1.0);
    assert_eq!(v["consistent_with_noise"], Value::Bool(true));
    assert_eq!(v["final"]["stable"], Value::Bool(true));
}

/// The record `alpha_outside_the_unit_interval_is_a_usage_error` runs on.
static ALPHA_FILE: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();

/// Success for α inside (0, 1), a one-line usage error (exit 2) naming --alpha outside.
fn alpha_behaves(alpha: f64) -> bool {
    let path = ALPHA_FILE.get().expect("file written first");
    // `--alpha=-inf`: a separate `-inf` would parse as flags
    let a = format!("--alpha={alpha}");
    let o = run(
        "diagnose",
        path,
        &["--domain", "z", "--na", "1", "--nb", "1", &a],
    );
    if alpha > 0.0 && alpha < 1.0 {
        o.status.success()
    } else {
        o.status.code() == Some(2)
            && stderr(&o).contains("--alpha")
            && stderr(&o).trim().lines().count() == 1
    }
}

/// Any --alpha (quickcheck's floats include NaN, infinities and huge values): success
/// inside (0, 1), a usage error naming --alpha outside; never a panic.
#[test]
fn alpha_outside_the_unit_interval_is_a_usage_error() {
    let dir = Scratch::new("alpha");
    let path = dir.file("d.csv", &periodic_record(71, 32, 2, 0, 0.02));
    ALPHA_FILE.set(path).unwrap();
    for a in [f64::NAN, f64::INFINITY, -0.0, 0.0, 1.0, 1e-300, 0.999, -0.5] {
        assert!(alpha_behaves(a), "alpha = {a}");
    }
    crate::common::seeded(0xc3927821)
        .tests(30)
        .quickcheck(alpha_behaves as fn(f64) -> bool);
}
