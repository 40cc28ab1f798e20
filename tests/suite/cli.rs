//! Integration tests of the `fdid` command: the built binary on CSV files in a temporary
//! directory.
#![cfg(feature = "cli")]

use crate::cli_common as cli;

use cli::{Scratch, fdid, json, run, stderr, stdout, theta_names};
use serde_json::Value;
use std::f64::consts::TAU;
use std::path::{Path, PathBuf};

/// `[[re, im], …]` as pairs sorted by imaginary part.
fn pairs(v: &Value) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = v
        .as_array()
        .expect("array")
        .iter()
        .map(|p| (p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
        .collect();
    out.sort_by(|a, b| a.1.partial_cmp(&b.1).unwrap());
    out
}

fn close(a: (f64, f64), b: (f64, f64), tol: f64) -> bool {
    ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt() < tol
}

/// G(s) = 2/(s² + 0.4 s + 1) at s = iω.
fn g_ct(w: f64) -> (f64, f64) {
    // 2 / ((1 − ω²) + 0.4 i ω)
    let (re, im) = (1.0 - w * w, 0.4 * w);
    let d = re * re + im * im;
    (2.0 * re / d, -2.0 * im / d)
}

/// The noise-free FRF file: 200 lines, ω = 0.02 k rad/s.
fn ct_frf_csv() -> (String, Vec<(f64, f64, f64)>) {
    let mut text = String::from("f,re,im\n");
    let mut rows = Vec::new();
    for k in 1..=200 {
        let w = 0.02 * k as f64;
        let f = w / TAU;
        let (re, im) = g_ct(w);
        text.push_str(&format!("{f:e},{re:e},{im:e}\n"));
        rows.push((f, re, im));
    }
    (text, rows)
}

const CT_POLES: [(f64, f64); 2] = [(-0.2, -0.9797958971132712), (-0.2, 0.9797958971132712)];

#[test]
fn ct_frf_json_poles_and_frf() {
    let dir = Scratch::new("ct");
    let (text, rows) = ct_frf_csv();
    let path = dir.file("frf.csv", &text);
    let v = json("fit", &path, &["--domain", "s", "--na", "2", "--nb", "0"]);
    assert_eq!(v["domain"], "s");
    let poles = pairs(&v["poles"]);
    assert_eq!(poles.len(), 2);
    for (p, e) in poles.iter().zip(CT_POLES) {
        assert!(close(*p, e, 1e-6), "pole {p:?}, expected {e:?}");
    }
    assert_eq!(v["zeros"].as_array().unwrap().len(), 0);
    assert!(v["cost"].as_f64().unwrap() < 1e-12);
    assert!(v["noise_variance"].as_f64().unwrap() < 1e-12);
    assert!((v["gain"].as_f64().unwrap() - 2.0).abs() < 1e-6);
    let frf = v["frf"].as_array().unwrap();
    assert_eq!(frf.len(), 200);
    for (row, (f, re, im)) in frf.iter().zip(&rows) {
        let r: Vec<f64> = row
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(r.len(), 3);
        assert!((r[0] - f).abs() <= 1e-12 * f, "frequency {} vs {f}", r[0]);
        let scale = (re * re + im * im).sqrt();
        assert!(
            ((r[1] - re).powi(2) + (r[2] - im).powi(2)).sqrt() < 1e-8 * scale,
            "frf at {f} Hz: {r:?} vs ({re}, {im})"
        );
    }
}

#[test]
fn ct_frf_every_criterion_finds_the_poles() {
    let dir = Scratch::new("crit");
    let path = dir.file("frf.csv", &ct_frf_csv().0);
    // nb ≤ na: partial-fraction form (nb = 0 with a relative-degree constraint);
    // nb > na (improper): polynomial form
    for (nb, form) in [
        ("0", "partial_fractions"),
        ("1", "partial_fractions"),
        ("3", "orthonormal_polynomials"),
    ] {
        for c in ["ml", "levy", "sk", "tls"] {
            let v = json(
                "fit",
                &path,
                &["--domain", "s", "--na", "2", "--nb", nb, "--criterion", c],
            );
            assert_eq!(v["criterion"], c);
            assert_eq!(v["form"], form);
            let nbv: usize = nb.parse().unwrap();
            assert_eq!(v["theta"].as_array().unwrap().len(), 3 + nbv);
            let poles = pairs(&v["poles"]);
            for (p, e) in poles.iter().zip(CT_POLES) {
                assert!(
                    close(*p, e, 1e-6),
                    "{c}, nb = {nb}: pole {p:?}, expected {e:?}"
                );
            }
        }
    }
}

#[test]
fn band_selects_lines() {
    let dir = Scratch::new("band");
    let (text, rows) = ct_frf_csv();
    let path = dir.file("frf.csv", &text);
    let (lo, hi) = (0.1, 0.4);
    let inside = rows.iter().filter(|r| r.0 >= lo && r.0 <= hi).count();
    let v = json(
        "fit",
        &path,
        &[
            "--domain", "s", "--na", "2", "--nb", "0", "--band", "0.1:0.4",
        ],
    );
    let frf = v["frf"].as_array().unwrap();
    assert_eq!(frf.len(), inside);
    assert!(frf.iter().all(|r| {
        let f = r[0].as_f64().unwrap();
        (lo..=hi).contains(&f)
    }));
    for (p, e) in pairs(&v["poles"]).iter().zip(CT_POLES) {
        assert!(close(*p, e, 1e-6));
    }
}

#[test]
fn text_output_reports_poles() {
    let dir = Scratch::new("text");
    let path = dir.file("frf.csv", &ct_frf_csv().0);
    let o = run("fit", &path, &["--domain", "s", "--na", "2", "--nb", "0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    for needle in [
        "poles",
        "zeros",
        "gain",
        "cost",
        "lambda",
        "-0.2000000",
        "0.9797959",
        "damping",
        "levy",
        "sk",
        "ml",
        "std",
    ] {
        assert!(out.contains(needle), "`{needle}` missing from:\n{out}");
    }
}

/// A deterministic pseudo-random sequence in [−0.5, 0.5).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

/// DT system A = 1 + a1 z⁻¹ + a2 z⁻², B = b0 + b1 z⁻¹ with poles 0.9 e^{±0.5i}.
const R: f64 = 0.9;
const ANGLE: f64 = 0.5;
const TS: f64 = 0.01;

fn dt_poles() -> [(f64, f64); 2] {
    [
        (R * ANGLE.cos(), -R * ANGLE.sin()),
        (R * ANGLE.cos(), R * ANGLE.sin()),
    ]
}

/// A time record of `periods` periods of `m` samples of the DT system driven by a
/// periodic pseudo-random input, after a transient that is discarded; `noise` is the
/// amplitude of uniform output noise.
fn dt_record(m: usize, periods: usize, noise: f64) -> String {
    let (a1, a2) = (-2.0 * R * ANGLE.cos(), R * R);
    let (b0, b1) = (1.0, 0.5);
    let mut rng = Lcg(12345);
    let period: Vec<f64> = (0..m).map(|_| rng.next()).collect();
    let warm = 20;
    let total = (warm + periods) * m;
    let (mut y1, mut y2, mut u1) = (0.0, 0.0, 0.0);
    let mut text = String::from("t,u,y\n");
    for t in 0..total {
        let u = period[t % m];
        let y = -a1 * y1 - a2 * y2 + b0 * u + b1 * u1;
        (y2, y1, u1) = (y1, y, u);
        if t >= warm * m {
            let k = t - warm * m;
            let yn = y + noise * rng.next();
            text.push_str(&format!("{:e},{u:e},{yn:e}\n", k as f64 * TS));
        }
    }
    text
}

#[test]
fn dt_time_record_periods_noise_free() {
    let dir = Scratch::new("dt");
    let path = dir.file("record.csv", &dt_record(256, 4, 0.0));
    let v = json(
        "fit",
        &path,
        &["--domain", "z", "--na", "2", "--nb", "1", "--periods", "4"],
    );
    assert_eq!(v["domain"], "z");
    assert!((v["ts"].as_f64().unwrap() - TS).abs() < 1e-12);
    let poles = pairs(&v["poles"]);
    assert_eq!(poles.len(), 2);
    for (p, e) in poles.iter().zip(dt_poles()) {
        assert!(close(*p, e, 1e-6), "pole {p:?}, expected {e:?}");
    }
    let zeros = pairs(&v["zeros"]);
    assert_eq!(zeros.len(), 1);
    assert!(close(zeros[0], (-0.5, 0.0), 1e-6), "zero {:?}", zeros[0]);
    // 256-sample periods: lines 1..=128 (DC dropped)
    let frf = v["frf"].as_array().unwrap();
    assert_eq!(frf.len(), 128);
    let f1 = frf[0][0].as_f64().unwrap();
    assert!((f1 - 1.0 / (256.0 * TS)).abs() < 1e-9);
}

#[test]
fn dt_time_record_periods_with_noise() {
    let dir = Scratch::new("dtn");
    let path = dir.file("record.csv", &dt_record(256, 4, 1e-3));
    let v = json(
        "fit",
        &path,
        &["--domain", "z", "--na", "2", "--nb", "1", "--periods", "4"],
    );
    assert_eq!(v["noise_known"], true, "weighting: {}", v["weighting"]);
    for (p, e) in pairs(&v["poles"]).iter().zip(dt_poles()) {
        assert!(close(*p, e, 1e-3), "pole {p:?}, expected {e:?}");
    }
    // with the noise variances known, λ̂ = V/N should be of order one
    let lambda = v["noise_variance"].as_f64().unwrap();
    assert!(lambda > 0.2 && lambda < 5.0, "lambda = {lambda}");
    assert!(
        v["theta_std"]
            .as_array()
            .unwrap()
            .iter()
            .all(|s| s.as_f64().unwrap() > 0.0)
    );
    // text output mentions the poles too
    let o = run(
        "fit",
        &path,
        &["--domain", "z", "--na", "2", "--nb", "1", "--periods", "4"],
    );
    assert!(o.status.success());
    assert!(stdout(&o).contains("poles (z-plane)"));
}

#[test]
fn dt_whole_record_dft_and_spectra_file() {
    let dir = Scratch::new("dft");
    // one period: the DFT of the whole record is the same as averaging one period
    let path = dir.file("record.csv", &dt_record(512, 1, 0.0));
    let v = json("fit", &path, &["--domain", "z", "--na", "2", "--nb", "1"]);
    for (p, e) in pairs(&v["poles"]).iter().zip(dt_poles()) {
        assert!(close(*p, e, 1e-6), "pole {p:?}, expected {e:?}");
    }
    // the same system as input/output spectra (U = 1 + 0.5 i, Y = G U), with --ts
    let mut text = String::from("f,u_re,u_im,y_re,y_im\n");
    for k in 1..=100 {
        let f = k as f64 * 0.45 / (100.0 * TS);
        let wt = TAU * f * TS;
        let zi = (wt.cos(), -wt.sin()); // z^-1
        let mul = |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
        let zi2 = mul(zi, zi);
        let (a1, a2) = (-2.0 * R * ANGLE.cos(), R * R);
        let a = (1.0 + a1 * zi.0 + a2 * zi2.0, a1 * zi.1 + a2 * zi2.1);
        let b = (1.0 + 0.5 * zi.0, 0.5 * zi.1);
        let d = a.0 * a.0 + a.1 * a.1;
        let g = mul(b, (a.0 / d, -a.1 / d));
        let y = mul(g, (1.0, 0.5));
        text.push_str(&format!("{f:e},1,0.5,{:e},{:e}\n", y.0, y.1));
    }
    let path = dir.file("spectra.csv", &text);
    let v = json(
        "fit",
        &path,
        &["--domain", "z", "--ts", "0.01", "--na", "2", "--nb", "1"],
    );
    for (p, e) in pairs(&v["poles"]).iter().zip(dt_poles()) {
        assert!(close(*p, e, 1e-6), "pole {p:?}, expected {e:?}");
    }
}

/// Runs `fdid` expecting failure with one `error:` line on stderr containing `needle`.
fn expect_error(args: &[&str], needle: &str) {
    let o = fdid(args);
    let err = stderr(&o);
    assert!(
        !o.status.success(),
        "{args:?} should fail; stdout: {}",
        stdout(&o)
    );
    assert!(o.stdout.is_empty(), "{args:?}: nothing on stdout expected");
    assert_eq!(err.lines().count(), 1, "{args:?}: one line expected: {err}");
    assert!(err.starts_with("error:"), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert!(
        err.to_lowercase().contains(&needle.to_lowercase()),
        "{args:?}: `{needle}` not in {err}"
    );
}

#[test]
fn bad_inputs_give_one_error_line() {
    let dir = Scratch::new("bad");
    let s = |p: &PathBuf| p.to_str().unwrap().to_string();
    let good = s(&dir.file("good.csv", "f,re,im\n1,1,0\n2,0.5,-0.5\n3,0.2,-0.4\n"));
    let missing = s(&dir.path("does-not-exist.csv"));
    let no_col = s(&dir.file("nocol.csv", "f,re\n1,1\n2,0.5\n"));
    let nan = s(&dir.file("nan.csv", "f,re,im\n1,1,0\n2,NaN,0\n"));
    let unsorted = s(&dir.file("unsorted.csv", "f,re,im\n2,1,0\n1,0.5,0\n"));
    let dup = s(&dir.file("dup.csv", "f,re,im\n1,1,0\n1,0.5,0\n"));
    let empty = s(&dir.file("empty.csv", ""));
    let ct = ["--domain", "s", "--na", "1", "--nb", "0"];
    let with = |file: &str, extra: &[&'static str]| -> Vec<String> {
        let mut v = vec!["fit".to_string(), file.to_string()];
        v.extend(extra.iter().map(|x| x.to_string()));
        v
    };
    let cases: Vec<(Vec<String>, &str)> = vec![
        (with(&missing, &ct), "does-not-exist.csv"),
        (with(&no_col, &ct), "im"),
        (with(&nan, &ct), "not finite"),
        (with(&unsorted, &ct), "increase"),
        (with(&dup, &ct), "duplicate"),
        (with(&empty, &ct), "empty"),
        (
            with(&good, &["--domain", "s", "--na", "4", "--nb", "3"]),
            "too few frequencies",
        ),
        (
            with(
                &good,
                &["--domain", "s", "--na", "1", "--nb", "0", "--bogus"],
            ),
            "--bogus",
        ),
        (
            with(
                &good,
                &["--domain", "s", "--na", "1", "--nb", "0", "--band", "1-2"],
            ),
            "--band",
        ),
        (
            with(
                &good,
                &["--domain", "s", "--na", "1", "--nb", "0", "--band", "a:2"],
            ),
            "--band",
        ),
        (
            with(
                &good,
                &["--domain", "s", "--na", "1", "--nb", "0", "--band", "3:1"],
            ),
            "--band",
        ),
        (
            with(
                &good,
                &["--domain", "s", "--na", "1", "--nb", "0", "--band", "10:20"],
            ),
            "no frequency lines",
        ),
        (
            with(&good, &["--domain", "z", "--na", "1", "--nb", "0"]),
            "--ts",
        ),
        (
            with(
                &good,
                &["--domain", "z", "--ts", "1", "--na", "1", "--nb", "0"],
            ),
            "nyquist",
        ),
        (
            with(
                &good,
                &["--domain", "z", "--ts", "-1", "--na", "1", "--nb", "0"],
            ),
            "--ts",
        ),
        (
            with(&good, &["--domain", "s", "--na", "1000000", "--nb", "0"]),
            "--na",
        ),
        (
            with(&good, &["--domain", "s", "--na", "1", "--nb", "100000"]),
            "--nb",
        ),
        (
            with(
                &good,
                &[
                    "--domain",
                    "s",
                    "--na",
                    "99999999999999999999999",
                    "--nb",
                    "0",
                ],
            ),
            "--na",
        ),
        (
            with(
                &good,
                &["--domain", "s", "--na", "1", "--nb", "0", "--periods", "2"],
            ),
            "--periods",
        ),
        (
            with(&good, &["--domain", "q", "--na", "1", "--nb", "0"]),
            "--domain",
        ),
        (
            with(
                &good,
                &[
                    "--domain",
                    "s",
                    "--na",
                    "1",
                    "--nb",
                    "0",
                    "--criterion",
                    "x",
                ],
            ),
            "--criterion",
        ),
        (with(&good, &["--na", "1", "--nb", "0"]), "--domain"),
        (vec!["frobnicate".into()], "frobnicate"),
    ];
    for (args, needle) in cases {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        expect_error(&a, needle);
    }
}

#[test]
fn time_record_errors() {
    let dir = Scratch::new("tbad");
    let rec = dir.file("record.csv", &dt_record(100, 3, 0.0));
    let p = rec.to_str().unwrap();
    // 300 samples are not a multiple of 7 periods
    expect_error(
        &[
            "fit",
            p,
            "--domain",
            "z",
            "--na",
            "2",
            "--nb",
            "1",
            "--periods",
            "7",
        ],
        "periods",
    );
    expect_error(
        &[
            "fit",
            p,
            "--domain",
            "z",
            "--na",
            "2",
            "--nb",
            "1",
            "--periods",
            "0",
        ],
        "periods",
    );
    // --ts contradicting the t column
    expect_error(
        &[
            "fit", p, "--domain", "z", "--ts", "1", "--na", "2", "--nb", "1",
        ],
        "--ts",
    );
    // a zero input carries no information
    let mut zero = String::from("t,u,y\n");
    for k in 0..16 {
        zero.push_str(&format!("{k},0,{}\n", k % 3));
    }
    let z = dir.file("zero.csv", &zero);
    expect_error(
        &[
            "fit",
            z.to_str().unwrap(),
            "--domain",
            "z",
            "--na",
            "1",
            "--nb",
            "0",
        ],
        "input",
    );
}

#[test]
fn help_is_complete() {
    let o = fdid(&["--help"]);
    assert!(o.status.success());
    let top = stdout(&o);
    assert!(top.contains("fit") && top.contains("Examples:"), "{top}");
    let o = fdid(&["fit", "--help"]);
    assert!(o.status.success());
    let h = stdout(&o);
    for needle in [
        "--domain",
        "--na",
        "--nb",
        "--ts",
        "--criterion",
        "--band",
        "--periods",
        "--json",
        "--delay",
        "--transient",
        "--noise-order",
        "eiv",
        "\"delay\"",
        "\"covariance\"",
        "\"cost_expected\"",
        "\"whiteness_p\"",
        "\"noise_model\"",
        "f,re,im",
        "t,u,y",
        "u_re",
        "DC line",
        "Examples:",
        "\"frf\"",
    ] {
        assert!(h.contains(needle), "`{needle}` missing from fit --help");
    }
}

/// The bundled data sets run with the README's commands.
#[test]
fn bundled_data_sets_fit() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let v = json(
        "fit",
        &root.join("data/robot_arm.csv"),
        &["--domain", "z", "--na", "4", "--nb", "4", "--periods", "1"],
    );
    assert_eq!(v["poles"].as_array().unwrap().len(), 4);
    assert_eq!(v["stable"], true);
    assert!(v["relative_residual"].as_f64().unwrap() < 0.1);
    for (order, worst) in [("4", 0.05), ("6", 0.02)] {
        let v = json(
            "fit",
            &root.join("data/eis_battery.csv"),
            &[
                "--domain", "s", "--na", order, "--nb", order, "--band", ":1000",
            ],
        );
        assert_eq!(v["frf"].as_array().unwrap().len(), 56);
        assert_eq!(v["stable"], true, "order {order}");
        // an RC-ladder-like impedance: real poles
        assert!(
            pairs(&v["poles"])
                .iter()
                .all(|p| p.0 < 0.0 && p.1.abs() <= 1e-9 * p.0.abs())
        );
        let r = v["relative_residual"].as_f64().unwrap();
        assert!(r < worst, "order {order}: relative residual {r}");
    }
}

// ---------------------------------------------------------------------------------------
// --delay, --transient, --noise-order, --criterion eiv

/// Complex numbers as pairs, for the simulations below.
#[derive(Clone, Copy, Debug)]
struct C(f64, f64);

impl C {
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn div(self, o: C) -> C {
        let d = o.0 * o.0 + o.1 * o.1;
        C(
            (self.0 * o.0 + self.1 * o.1) / d,
            (self.1 * o.0 - self.0 * o.1) / d,
        )
    }
    fn polar(r: f64, phi: f64) -> C {
        C(r * phi.cos(), r * phi.sin())
    }
}

/// The DT system of `dt_record` at the angle ωTs: (b0 + b1 z⁻¹)/(1 + a1 z⁻¹ + a2 z⁻²).
fn g_dt(wt: f64) -> C {
    let (a1, a2) = (-2.0 * R * ANGLE.cos(), R * R);
    let zi = C::polar(1.0, -wt);
    let zi2 = zi.mul(zi);
    let a = C(1.0 + a1 * zi.0 + a2 * zi2.0, a1 * zi.1 + a2 * zi2.1);
    let b = C(1.0 + 0.5 * zi.0, 0.5 * zi.1);
    b.div(a)
}

/// `periods` periods of `m` samples of the steady-state response of the DT system followed
/// by a delay of `delay` samples (fractional allowed) to a random-phase multisine on the
/// lines 1 … m/2 − 1, synthesised exactly line by line; uniform noise of amplitude
/// `noise_u` on the recorded input and `noise_y` on the output.
fn periodic_record(m: usize, periods: usize, delay: f64, noise_u: f64, noise_y: f64) -> String {
    let mut rng = Lcg(777);
    let lines: Vec<(usize, f64, C)> = (1..m / 2)
        .map(|k| {
            let phase = TAU * (rng.next() + 0.5);
            let wt = TAU * k as f64 / m as f64;
            let g = g_dt(wt).mul(C::polar(1.0, -wt * delay));
            (k, phase, g)
        })
        .collect();
    let (u0, y0): (Vec<f64>, Vec<f64>) = (0..m)
        .map(|t| {
            lines.iter().fold((0.0, 0.0), |(u, y), (k, phase, g)| {
                let arg = TAU * (k * t) as f64 / m as f64 + phase;
                let e = C::polar(1.0, arg);
                (u + e.0, y + e.mul(*g).0)
            })
        })
        .map(|(u, y)| (u * 0.1, y * 0.1))
        .unzip();
    let mut text = String::from("t,u,y\n");
    for t in 0..m * periods {
        let u = u0[t % m] + noise_u * rng.next();
        let y = y0[t % m] + noise_y * rng.next();
        text.push_str(&format!("{:e},{u:e},{y:e}\n", t as f64 * TS));
    }
    text
}

/// `n` samples of the DT system started from a non-zero state, driven by a random input
/// (not periodic); output noise v = H e with H = (1 + c1 z⁻¹)/(1 + d1 z⁻¹) and e uniform
/// of amplitude `noise` (after a warm-up of the noise filter).
fn transient_record(n: usize, noise: f64, c1: f64, d1: f64) -> String {
    let (a1, a2) = (-2.0 * R * ANGLE.cos(), R * R);
    let mut rng = Lcg(4242);
    let (mut y1, mut y2, mut u1) = (0.8, -0.5, 0.3);
    let (mut e1, mut v1) = (0.0, 0.0);
    for _ in 0..200 {
        let e = noise * rng.next();
        (e1, v1) = (e, e + c1 * e1 - d1 * v1);
    }
    let mut text = String::from("t,u,y\n");
    for t in 0..n {
        let u = rng.next();
        let y = -a1 * y1 - a2 * y2 + u + 0.5 * u1;
        (y2, y1, u1) = (y1, y, u);
        let e = noise * rng.next();
        let v = e + c1 * e1 - d1 * v1;
        (e1, v1) = (e, v);
        text.push_str(&format!("{:e},{u:e},{:e}\n", t as f64 * TS, y + v));
    }
    text
}

fn num(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("`{key}` is not a number: {}", v[key]))
}

/// The parameter named `name` and its standard deviation.
fn param(v: &Value, name: &str) -> (f64, f64) {
    let names = v["theta_names"].as_array().expect("theta_names");
    let i = names
        .iter()
        .position(|n| n == name)
        .unwrap_or_else(|| panic!("no parameter {name} in {names:?}"));
    (
        v["theta"][i].as_f64().unwrap(),
        v["theta_std"][i].as_f64().unwrap(),
    )
}

#[test]
fn delay_of_two_and_a_half_samples_is_recovered() {
    let dir = Scratch::new("delay");
    let path = dir.file("record.csv", &periodic_record(128, 1, 2.5, 0.0, 0.0));
    let args = ["--domain", "z", "--na", "2", "--nb", "1", "--delay"];
    let v = json("fit", &path, &args);
    let tau = num(&v, "delay");
    assert!((tau - 2.5 * TS).abs() < 1e-9, "delay {tau} s");
    assert!((num(&v, "delay_samples") - 2.5).abs() < 1e-7);
    assert!(num(&v, "delay_std") >= 0.0);
    assert_eq!(v["theta_names"].as_array().unwrap().last().unwrap(), "tau");
    assert_eq!(v["theta"].as_array().unwrap().len(), 5);
    for (p, e) in pairs(&v["poles"]).iter().zip(dt_poles()) {
        assert!(close(*p, e, 1e-7), "pole {p:?}, expected {e:?}");
    }
    assert!(close(pairs(&v["zeros"])[0], (-0.5, 0.0), 1e-7));
    assert!(num(&v, "cost") < 1e-20, "cost {}", v["cost"]);
    // without the delay the model cannot follow the phase
    let plain = json("fit", &path, &["--domain", "z", "--na", "2", "--nb", "1"]);
    assert!(plain["delay"].is_null() && plain["delay_samples"].is_null());
    assert!(num(&plain, "cost") > 1e6 * num(&v, "cost").max(1e-24));
    // the text names the delay in seconds and in samples
    let o = run("fit", &path, &args);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let line = out
        .lines()
        .find(|l| l.starts_with("delay"))
        .expect("a delay line");
    assert!(
        line.contains("0.02500000") && line.contains("2.500000") && line.contains("samples"),
        "{line}"
    );
    assert!(out.contains("validation"), "{out}");
}

#[test]
fn transient_term_fits_a_short_non_periodic_record() {
    let dir = Scratch::new("transient");
    let path = dir.file("record.csv", &transient_record(64, 0.0, 0.0, 0.0));
    let base = ["--domain", "z", "--na", "2", "--nb", "1"];
    let plain = json("fit", &path, &base);
    let with = json("fit", &path, &[&base[..], &["--transient"]].concat());
    assert_eq!(with["transient"], 2);
    assert_eq!(plain["transient"], 0);
    let names = theta_names(&with);
    assert_eq!(names, ["a1", "a2", "b0", "b1", "t1", "t2"]);
    let (c0, c1) = (num(&plain, "cost"), num(&with, "cost"));
    assert!(
        c0 > 1e-4,
        "without the transient term the leakage stays: {c0}"
    );
    assert!(c1 < 1e-20, "with it the fit is exact: {c1}");
    for (p, e) in pairs(&with["poles"]).iter().zip(dt_poles()) {
        assert!(close(*p, e, 1e-9), "pole {p:?}, expected {e:?}");
    }
    assert!(num(&with, "relative_residual") < 1e-10);
    // the equation error stays linear: the linear criteria estimate the transient too
    for c in ["levy", "sk", "tls"] {
        let v = json(
            "fit",
            &path,
            &[&base[..], &["--transient", "--criterion", c]].concat(),
        );
        for (p, e) in pairs(&v["poles"]).iter().zip(dt_poles()) {
            assert!(close(*p, e, 1e-9), "{c}: pole {p:?}, expected {e:?}");
        }
    }
    // continuous time: the sampled transient of eqs. 9–10, one coefficient per pole
    let s = json(
        "fit",
        &path,
        &["--domain", "s", "--na", "2", "--nb", "1", "--transient"],
    );
    assert_eq!(s["transient"], 2);
    assert_eq!(s["theta"].as_array().unwrap().len(), 6);
    let o = run("fit", &path, &[&base[..], &["--transient"]].concat());
    assert!(stdout(&o).contains("Y - G U - T"), "{}", stdout(&o));
}

#[test]
fn noise_model_of_coloured_noise() {
    let dir = Scratch::new("noise");
    let (c1, d1) = (0.5, -0.8);
    let path = dir.file("record.csv", &transient_record(2048, 0.05, c1, d1));
    let args = [
        "--domain",
        "z",
        "--na",
        "2",
        "--nb",
        "1",
        "--transient",
        "--noise-order",
        "1",
    ];
    let v = json("fit", &path, &args);
    assert_eq!(v["noise_order"], 1);
    let h = &v["noise_model"];
    let c: Vec<f64> = h["c"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let d: Vec<f64> = h["d"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!((c.len(), d.len()), (2, 2));
    assert_eq!((c[0], d[0]), (1.0, 1.0));
    let (ce, cs) = param(&v, "nc1");
    let (de, ds) = param(&v, "nd1");
    assert_eq!((ce, de), (c[1], d[1]));
    assert!(
        (ce - c1).abs() < 4.0 * cs && cs < 0.05,
        "c1 = {ce} +/- {cs}"
    );
    assert!(
        (de - d1).abs() < 4.0 * ds && ds < 0.05,
        "d1 = {de} +/- {ds}"
    );
    assert!(close(pairs(&h["zeros"])[0], (-ce, 0.0), 1e-9));
    assert!(close(pairs(&h["poles"])[0], (-de, 0.0), 1e-9));
    for (p, e) in pairs(&v["poles"]).iter().zip(dt_poles()) {
        assert!(close(*p, e, 1e-2), "pole {p:?}, expected {e:?}");
    }
    // λ̂ is the variance of the white e per DFT line: 0.05²/12
    let lambda = num(&v, "noise_variance");
    let var_e = 0.05f64.powi(2) / 12.0;
    assert!(
        (lambda / var_e - 1.0).abs() < 0.15,
        "lambda {lambda} vs {var_e}"
    );
    // DC and Nyquist dropped, every other line kept
    assert_eq!(v["lines"], 1023);
    let names = v["theta_names"].as_array().unwrap();
    assert_eq!(names[names.len() - 2..], ["nc1", "nd1"]);
    let o = run("fit", &path, &args);
    let out = stdout(&o);
    assert!(
        out.contains("noise model  H = C/D") && out.contains("poles of H"),
        "{out}"
    );
}

#[test]
fn noise_model_with_delay() {
    let dir = Scratch::new("noisedelay");
    let path = dir.file("record.csv", &periodic_record(256, 1, 2.5, 0.0, 0.02));
    let v = json(
        "fit",
        &path,
        &[
            "--domain",
            "z",
            "--na",
            "2",
            "--nb",
            "1",
            "--delay",
            "--noise-order",
            "1",
        ],
    );
    let names = theta_names(&v);
    assert_eq!(names, ["a1", "a2", "b0", "b1", "tau", "nc1", "nd1"]);
    let (tau, std) = param(&v, "tau");
    assert!(
        (tau / TS - 2.5).abs() < 0.05 && std > 0.0,
        "tau {tau} +/- {std}"
    );
    assert!(v["noise_model"]["c"].is_array());
    for (p, e) in pairs(&v["poles"]).iter().zip(dt_poles()) {
        assert!(close(*p, e, 1e-2), "pole {p:?}, expected {e:?}");
    }
}

#[test]
fn errors_in_variables_on_a_periodic_record() {
    let dir = Scratch::new("eiv");
    let path = dir.file("record.csv", &periodic_record(256, 4, 0.0, 0.02, 0.02));
    let base = ["--domain", "z", "--na", "2", "--nb", "1", "--periods", "4"];
    let v = json("fit", &path, &[&base[..], &["--criterion", "eiv"]].concat());
    assert_eq!(v["criterion"], "eiv");
    assert_eq!(v["noise_known"], true);
    let stages = v["stages"].as_array().unwrap();
    assert_eq!(stages.last().unwrap()["name"], "eiv");
    assert!(
        v["weighting"]
            .as_str()
            .unwrap()
            .contains("errors-in-variables")
    );
    for (p, e) in pairs(&v["poles"]).iter().zip(dt_poles()) {
        assert!(close(*p, e, 5e-3), "pole {p:?}, expected {e:?}");
    }
    // the cost is compared with its expected value under the sample variances (P = 4)
    let expected = num(&v, "cost_expected");
    let cost = num(&v, "cost");
    assert!(
        expected > 100.0 && (cost / expected - 1.0).abs() < 0.5,
        "{cost} vs {expected}"
    );
    let p = num(&v, "cost_p");
    assert!((0.0..=1.0).contains(&p));
    // with the transient term (zero for this periodic record)
    let v = json(
        "fit",
        &path,
        &[&base[..], &["--criterion", "eiv", "--transient"]].concat(),
    );
    assert_eq!(v["transient"], 2);
    assert_eq!(
        v["stages"].as_array().unwrap().last().unwrap()["name"],
        "eiv"
    );
    for (p, e) in pairs(&v["poles"]).iter().zip(dt_poles()) {
        assert!(close(*p, e, 5e-3), "pole {p:?}, expected {e:?}");
    }
    // with a delay too: the delayed model under errors-in-variables
    let path = dir.file("delayed.csv", &periodic_record(256, 4, 2.5, 0.02, 0.02));
    let v = json(
        "fit",
        &path,
        &[&base[..], &["--criterion", "eiv", "--delay"]].concat(),
    );
    let (tau, std) = param(&v, "tau");
    assert!(
        (tau / TS - 2.5).abs() < 0.05 && std > 0.0,
        "tau {tau} +/- {std}"
    );
    assert_eq!(
        v["stages"].as_array().unwrap().last().unwrap()["name"],
        "eiv"
    );
    assert_eq!(v["noise_known"], true);
}

#[test]
fn json_validation_and_covariance_keys() {
    let dir = Scratch::new("keys");
    let path = dir.file("record.csv", &dt_record(256, 4, 1e-3));
    let v = json(
        "fit",
        &path,
        &["--domain", "z", "--na", "2", "--nb", "1", "--periods", "4"],
    );
    for key in [
        "delay",
        "delay_std",
        "delay_samples",
        "noise_model",
        "noise_order",
    ] {
        assert!(v[key].is_null(), "{key} = {}", v[key]);
    }
    assert_eq!(v["transient"], 0);
    assert!(num(&v, "noise_variance") > 0.0);
    assert!(num(&v, "cost_expected") > 0.0);
    for key in ["cost_p", "whiteness_p"] {
        let p = num(&v, key);
        assert!((0.0..=1.0).contains(&p), "{key} = {p}");
    }
    let std: Vec<f64> = v["theta_std"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let cov = v["covariance"].as_array().expect("covariance rows");
    assert_eq!(cov.len(), 4);
    for (i, row) in cov.iter().enumerate() {
        let row = row.as_array().unwrap();
        assert_eq!(row.len(), 4);
        let cii = row[i].as_f64().unwrap();
        assert!((cii.sqrt() / std[i] - 1.0).abs() < 1e-9);
        for (j, x) in row.iter().enumerate() {
            let other = cov[j][i].as_f64().unwrap();
            assert!((x.as_f64().unwrap() - other).abs() <= 1e-12 * cii.abs().max(other.abs()));
        }
    }
    // flat weighting: the noise level comes from the residuals, no cost test
    let flat = json("fit", &path, &["--domain", "z", "--na", "2", "--nb", "1"]);
    assert!(flat["cost_expected"].is_null() && flat["cost_p"].is_null());
    assert!(flat["whiteness_p"].is_number());
    // the text reports the validation on every fit
    let o = run(
        "fit",
        &path,
        &["--domain", "z", "--na", "2", "--nb", "1", "--periods", "4"],
    );
    let out = stdout(&o);
    let line = out
        .lines()
        .find(|l| l.starts_with("validation"))
        .expect("a validation line");
    assert!(
        line.contains("expected") && line.contains("whiteness p"),
        "{line}"
    );
}

/// Runs `fdid fit` expecting exit status 2 and one `error:` line naming every needle.
fn expect_usage(args: &[&str], needles: &[&str]) {
    let o = fdid(args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(o.stdout.is_empty(), "{args:?}: nothing on stdout expected");
    assert_eq!(err.lines().count(), 1, "{args:?}: one line expected: {err}");
    assert!(err.starts_with("error:"), "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: `{n}` not in {err}");
    }
}

#[test]
fn unsupported_combinations_are_usage_errors() {
    let dir = Scratch::new("combos");
    let rec = dir.file("record.csv", &dt_record(64, 4, 1e-3));
    let frf = dir.file("frf.csv", &ct_frf_csv().0);
    let (r, f) = (rec.to_str().unwrap(), frf.to_str().unwrap());
    let z = ["--domain", "z", "--na", "2", "--nb", "1"];
    let s = ["--domain", "s", "--na", "2", "--nb", "0"];
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            [
                &["fit", r][..],
                &z,
                &["--noise-order", "1", "--criterion", "levy"],
            ]
            .concat(),
            vec!["--noise-order", "--criterion levy"],
        ),
        (
            [
                &["fit", r][..],
                &z,
                &["--noise-order", "1", "--criterion", "sk"],
            ]
            .concat(),
            vec!["--noise-order", "--criterion sk"],
        ),
        (
            [
                &["fit", r][..],
                &z,
                &["--noise-order", "1", "--criterion", "tls"],
            ]
            .concat(),
            vec!["--noise-order", "--criterion tls"],
        ),
        (
            [
                &["fit", r][..],
                &z,
                &["--noise-order", "1", "--criterion", "eiv", "--periods", "4"],
            ]
            .concat(),
            vec!["--noise-order", "--criterion eiv"],
        ),
        (
            [
                &["fit", r][..],
                &z,
                &["--noise-order", "1", "--periods", "4"],
            ]
            .concat(),
            vec!["--noise-order", "--periods 4"],
        ),
        (
            [&["fit", r][..], &z, &["--noise-order", "0"]].concat(),
            vec!["--noise-order 0"],
        ),
        (
            [&["fit", r][..], &z, &["--noise-order", "101"]].concat(),
            vec!["--noise-order 101"],
        ),
        (
            [&["fit", r][..], &z, &["--delay", "--criterion", "levy"]].concat(),
            vec!["--delay", "--criterion levy"],
        ),
        (
            [&["fit", r][..], &z, &["--delay", "--criterion", "tls"]].concat(),
            vec!["--delay", "--criterion tls"],
        ),
        (
            [&["fit", f][..], &s, &["--transient"]].concat(),
            vec!["--transient needs a time record"],
        ),
        (
            [&["fit", f][..], &s, &["--noise-order", "1"]].concat(),
            vec!["--noise-order 1 needs a time record"],
        ),
        (
            [
                &["fit", r][..],
                &["--domain", "s", "--na", "1", "--nb", "2", "--transient"],
            ]
            .concat(),
            vec!["--transient", "--domain s", "--nb <= --na"],
        ),
        (
            [&["fit", r][..], &z, &["--criterion", "eiv"]].concat(),
            vec!["--criterion eiv", "--periods P >= 2", "var_u"],
        ),
        (
            [&["fit", f][..], &s, &["--criterion", "eiv"]].concat(),
            vec!["--criterion eiv", "var_u,var_y"],
        ),
    ];
    for (args, needles) in cases {
        expect_usage(&args, &needles);
    }
}

#[test]
fn errors_in_variables_on_a_spectra_file() {
    let dir = Scratch::new("eivspectra");
    // noise-free spectra of G(s) = 2/(s² + 0.4 s + 1) with stated noise variances
    let mut rng = Lcg(99);
    let mut text = String::from("f,u_re,u_im,y_re,y_im,var_u,var_y\n");
    for k in 1..=100 {
        let w = 0.02 * k as f64;
        let g = g_ct(w);
        let u = C::polar(1.0, TAU * rng.next());
        let y = C(g.0, g.1).mul(u);
        text.push_str(&format!(
            "{:e},{:e},{:e},{:e},{:e},1e-4,2e-4\n",
            w / TAU,
            u.0,
            u.1,
            y.0,
            y.1
        ));
    }
    let path = dir.file("spectra.csv", &text);
    let args = [
        "--domain",
        "s",
        "--na",
        "2",
        "--nb",
        "0",
        "--criterion",
        "eiv",
    ];
    let v = json("fit", &path, &args);
    assert_eq!(v["noise_known"], true);
    for (p, e) in pairs(&v["poles"]).iter().zip(CT_POLES) {
        assert!(close(*p, e, 1e-9), "pole {p:?}, expected {e:?}");
    }
    assert!(num(&v, "cost") < 1e-12);
    // known variances: the expected cost is N − p/2
    assert_eq!(num(&v, "cost_expected"), 100.0 - 1.5);
    // a frequency response with output variances only has no input noise to model
    let mut frf = String::from("f,re,im,var\n");
    for k in 1..=100 {
        let w = 0.02 * k as f64;
        let g = g_ct(w);
        frf.push_str(&format!("{:e},{:e},{:e},1e-4\n", w / TAU, g.0, g.1));
    }
    let path = dir.file("frf.csv", &frf);
    let mut a = vec!["fit", path.to_str().unwrap()];
    a.extend_from_slice(&args);
    expect_error(&a, "var_u");
    assert_eq!(fdid(&a).status.code(), Some(1));
}

/// `fit --plot FILE` writes an SVG Bode plot (with the `plot` feature) and still prints the
/// report; an unwritable path is a runtime error naming it.
#[test]
fn fit_plot_writes_an_svg() {
    let dir = Scratch::new("plot");
    let svg = dir.path("bode.svg");
    let o = fdid(&[
        "fit",
        "data/robot_arm.csv",
        "--domain",
        "z",
        "--na",
        "4",
        "--nb",
        "4",
        "--periods",
        "1",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    if cfg!(feature = "plot") {
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stdout(&o).contains("poles"));
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.starts_with("<svg"));
        assert!(text.contains("model +/- 2 sigma_G"));
        assert!(text.contains("residual |Y/U - G|"));
        let bad = dir.path("missing-dir").join("bode.svg");
        let o = fdid(&[
            "fit",
            "data/robot_arm.csv",
            "--domain",
            "z",
            "--na",
            "2",
            "--nb",
            "2",
            "--periods",
            "1",
            "--plot",
            bad.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(1));
        assert!(stderr(&o).contains("missing-dir"), "{}", stderr(&o));
    } else {
        assert_eq!(o.status.code(), Some(2));
        assert!(stderr(&o).contains("plot"));
    }
}
