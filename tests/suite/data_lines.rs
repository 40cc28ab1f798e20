//! Excited lines, periods against realisations, and the best linear approximation over
//! realisations: the library functions (`FrequencyData::excited_lines`,
//! `TimeData::period_mismatch`, `RealisationBla`) and the command's `--lines`, `--periods`,
//! `--skip-periods` and `--realisations` on simulated multisine records.
#![cfg(feature = "cli")]

use crate::cli_common as cli;

use cli::{Scratch, json, run, stderr};
use fdid::TimeData;
use fdid::data::{EXCITATION_FRACTION, PERIODICITY_TOLERANCE, RealisationBla};
use fdid::simulate::{Multisine, OddMultisineDesign, SplitMix64};
use std::f64::consts::TAU;

/// Samples per period of the simulated records.
const M: usize = 256;

/// The output of `x(t) = 0.5 x(t − 1) + u(t)`, `y = x + cubic x³ + noise · e(t)`, from rest.
fn simulate(u: &[f64], cubic: f64, noise: f64, rng: &mut SplitMix64) -> Vec<f64> {
    let mut x = 0.0;
    u.iter()
        .map(|ut| {
            x = 0.5 * x + ut;
            x + cubic * x * x * x + noise * rng.gaussian()
        })
        .collect()
}

/// A time-record CSV of `u`, `y` at Ts = 1.
fn csv(u: &[f64], y: &[f64]) -> String {
    let mut text = String::from("t,u,y\n");
    for (i, (a, b)) in u.iter().zip(y).enumerate() {
        text.push_str(&format!("{i},{a:.17e},{b:.17e}\n"));
    }
    text
}

/// `R` realisations of a random-phase multisine on `lines` (amplitude 1, new phases per
/// realisation), each of `periods` periods after one warm-up period, one after the other.
fn realisations(
    lines: &[usize],
    r: usize,
    periods: usize,
    cubic: f64,
    noise: f64,
    seed: u64,
) -> (Vec<f64>, Vec<f64>) {
    let mut rng = SplitMix64::new(seed);
    let (mut u_all, mut y_all) = (Vec::new(), Vec::new());
    for _ in 0..r {
        let phases: Vec<f64> = lines.iter().map(|_| TAU * rng.uniform()).collect();
        let ms = Multisine::from_lines(M as f64, lines.to_vec(), vec![0.1; lines.len()], phases)
            .unwrap();
        let u = ms.sample(1.0, (periods + 1) * M);
        let y = simulate(&u, cubic, noise, &mut rng);
        u_all.extend(u);
        y_all.extend(y);
    }
    (u_all, y_all)
}

/// Natural frequency of a z-plane pole (as f = arg z / 2π) is not needed: the first-order
/// model's pole must be near z = 0.5.
fn pole_near_half(v: &serde_json::Value) -> bool {
    let p = &v["poles"][0];
    let (re, im) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
    (re - 0.5).abs() < 0.02 && im.abs() < 1e-9
}

/// An odd random-phase multisine with one odd line in every group of 4 left out (and every
/// even line): the lines it does not excite keep |U| at the rounding level, not zero; only
/// the excited lines are fitted, their count is in the JSON, and `--lines all` keeps the
/// others.
#[test]
fn only_excited_lines_of_a_multisine_with_detection_lines_are_fitted() {
    let design = OddMultisineDesign::new([1, 100], 4, 3).unwrap();
    let excited = design.excited().to_vec();
    let ms = design.multisine(M as f64, 5).unwrap();
    // one warm-up period, then 4 periods
    let u = ms.sample(1.0, 5 * M);
    let mut rng = SplitMix64::new(9);
    let y = simulate(&u, 0.0, 1e-3, &mut rng);
    // the library rule: the averaged spectrum's excited lines are the design's
    let rec = TimeData::new(u[M..].to_vec(), y[M..].to_vec(), 1.0).unwrap();
    let avg = rec.average_periods(4).unwrap();
    let mask = avg.excited_lines(EXCITATION_FRACTION);
    let found: Vec<usize> = (0..mask.len()).filter(|&k| mask[k]).collect();
    assert_eq!(found, excited);
    // the unexcited lines are at round-off, not exactly zero: an exact-zero rule keeps them
    let max = avg.u().iter().map(|z| z.norm()).fold(0.0, f64::max);
    let unexcited: Vec<f64> = (1..mask.len())
        .filter(|&k| !mask[k])
        .map(|k| avg.u()[k].norm())
        .collect();
    assert!(unexcited.iter().all(|a| *a < 1e-12 * max));
    assert!(unexcited.iter().filter(|a| **a > 0.0).count() > unexcited.len() / 2);

    let dir = Scratch::new("excited");
    let path = dir.file("ms.csv", &csv(&u, &y));
    let args = [
        "--domain",
        "z",
        "--na",
        "1",
        "--nb",
        "0",
        "--periods",
        "5",
        "--skip-periods",
        "1",
    ];
    let v = json("fit", &path, &args);
    assert_eq!(v["lines"], excited.len());
    assert_eq!(v["lines_excited"], excited.len());
    let f: Vec<f64> = v["frf"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r[0].as_f64().unwrap())
        .collect();
    for (fk, k) in f.iter().zip(&excited) {
        assert!(
            (fk * M as f64 - *k as f64).abs() < 1e-6,
            "{fk} Hz is not line {k}"
        );
    }
    assert!(pole_near_half(&v), "{}", v["poles"]);
    // the text says how many lines are excited
    let o = run("fit", &path, &args);
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(
        text.contains(&format!("{} excited", excited.len())),
        "{text}"
    );
    // --lines all: every line above DC, the count of excited ones unchanged
    let mut all = args.to_vec();
    all.extend(["--lines", "all"]);
    let v = json("fit", &path, &all);
    assert_eq!(v["lines"], M / 2);
    assert_eq!(v["lines_excited"], excited.len());
}

/// `--periods P` on blocks that do not repeat fails and points to `--realisations`; the
/// period mismatch of the library separates the two cases by orders of magnitude.
#[test]
fn periods_on_blocks_of_different_realisations_fail_with_a_hint() {
    let lines: Vec<usize> = (1..=60).collect();
    let (u, y) = realisations(&lines, 4, 1, 0.0, 1e-3, 11);
    // 4 realisations of 2 periods (warm-up + 1): as "8 periods" it does not repeat
    let rec = TimeData::new(u.clone(), y.clone(), 1.0).unwrap();
    assert!(rec.period_mismatch(8).unwrap() > 10.0 * PERIODICITY_TOLERANCE);
    let one = TimeData::new(u[..2 * M].to_vec(), y[..2 * M].to_vec(), 1.0).unwrap();
    assert!(one.period_mismatch(2).unwrap() < 1e-20);
    let dir = Scratch::new("periods");
    let path = dir.file("r.csv", &csv(&u, &y));
    let o = run(
        "fit",
        &path,
        &["--domain", "z", "--na", "1", "--nb", "0", "--periods", "8"],
    );
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("--realisations 8") && e.contains("does not repeat"),
        "{e}"
    );
    assert_eq!(e.trim().lines().count(), 1, "{e}");
    // read as 4 realisations of 2 periods, the first dropped: it fits
    let v = json(
        "fit",
        &path,
        &[
            "--domain",
            "z",
            "--na",
            "1",
            "--nb",
            "0",
            "--realisations",
            "4",
            "--periods",
            "2",
            "--skip-periods",
            "1",
        ],
    );
    assert!(pole_near_half(&v), "{}", v["poles"]);
    assert_eq!(v["lines"], 60);
    // usage errors: --skip-periods without periods, or dropping every period
    for extra in [
        &["--skip-periods", "1"][..],
        &["--periods", "8", "--skip-periods", "8"][..],
        &["--realisations", "4", "--lines", "all"][..],
    ] {
        let mut a = vec!["--domain", "z", "--na", "1", "--nb", "0"];
        a.extend_from_slice(extra);
        let o = run("fit", &path, &a);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", stderr(&o));
    }
}

/// With R realisations of P ≥ 2 periods both variances are estimated; a static cubic
/// nonlinearity makes the total variance exceed the noise variance (the spread test
/// rejects), a linear system does not; `fdid diagnose` names `nonlinear_distortion` only in
/// the first case.
#[test]
fn total_variance_exceeds_noise_only_with_a_nonlinearity() {
    let lines: Vec<usize> = (1..=60).collect();
    let dir = Scratch::new("nl");
    for (cubic, nonlinear) in [(0.0, false), (2.0, true)] {
        let (u, y) = realisations(&lines, 6, 4, cubic, 1e-3, 21);
        let rec = TimeData::new(u.clone(), y.clone(), 1.0).unwrap();
        let blocks: Vec<TimeData<f64>> = rec
            .split_blocks(6)
            .unwrap()
            .iter()
            .map(|b| b.skip_samples(M).unwrap())
            .collect();
        let bla = RealisationBla::new(&blocks, 4, EXCITATION_FRACTION).unwrap();
        assert_eq!(bla.lines(), &lines[..]);
        let noise = bla.noise_variance().unwrap();
        let total = bla.total_variance().unwrap();
        assert!(noise.iter().chain(total).all(|v| *v > 0.0));
        let test = bla.spread_test().unwrap();
        if nonlinear {
            assert!(test.p_value < 1e-6, "cubic: p = {}", test.p_value);
            assert!(test.total_to_noise_db > 10.0, "{}", test.total_to_noise_db);
        } else {
            assert!(test.p_value > 1e-3, "linear: p = {}", test.p_value);
            assert!(
                test.total_to_noise_db.abs() < 1.5,
                "{}",
                test.total_to_noise_db
            );
        }
        let path = dir.file(&format!("r{cubic}.csv"), &csv(&u, &y));
        let args = [
            "--domain",
            "z",
            "--na",
            "1",
            "--nb",
            "0",
            "--realisations",
            "6",
            "--periods",
            "5",
            "--skip-periods",
            "1",
        ];
        let v = json("diagnose", &path, &args);
        assert_eq!(v["noise_reference"], "realisations");
        let named = ["effects", "unmodelled"].iter().any(|k| {
            v[*k]
                .as_array()
                .unwrap()
                .iter()
                .any(|e| e == "nonlinear_distortion")
        });
        assert_eq!(named, nonlinear, "cubic {cubic}: {v}");
    }
}
