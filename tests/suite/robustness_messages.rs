//! Errors in the user's terms: readers with bounded lines and any line break, values
//! echoed short and printable, file line numbers and Hz, no `Debug` text or internal
//! wording, and exit codes 0 (ok), 1 (data or fit failure), 2 (usage) only.

use fdid::FdidError;
use fdid::io::{MAX_LINE_BYTES, parse_csv, parse_touchstone};
use std::io::Read;

/// The line and message of a parse error of `parse_csv::<f64>` on `bytes`.
fn csv_error(bytes: impl Read) -> (usize, String) {
    match parse_csv::<f64, _>(bytes, "test.csv") {
        Err(FdidError::Parse { line, message, .. }) => (line, message),
        other => panic!("expected a parse error, got {other:?}"),
    }
}

/// Old: a file without line breaks was read into memory without bound.
#[test]
fn a_line_longer_than_the_cap_is_refused_with_its_number() {
    let mut text = b"f,re,im\n1,2,3\n".to_vec();
    text.extend(std::iter::repeat_n(b'7', MAX_LINE_BYTES + 10));
    let (line, message) = csv_error(&text[..]);
    assert_eq!(line, 3);
    assert!(message.contains("longer than"), "{message}");
    // an endless stream without a line break ends at the cap
    let (line, message) = csv_error(std::io::repeat(b'9').take(1 << 40));
    assert_eq!(line, 1);
    assert!(message.contains("longer than"), "{message}");
    let s1p = std::io::repeat(b'1').take(1 << 40);
    match parse_touchstone(s1p, 1, "endless.s1p") {
        Err(FdidError::Parse {
            line: 1, message, ..
        }) => {
            assert!(message.contains("longer than"), "{message}")
        }
        other => panic!("expected a parse error at line 1, got {other:?}"),
    }
}

/// Old: CR-only line endings made the whole file one line ("unknown column").
#[test]
fn cr_only_line_endings_read_as_lines() {
    let lf = "f,re,im\n1,2,3\n2,4,5\n";
    let want = parse_csv::<f64, _>(lf.as_bytes(), "lf.csv").unwrap();
    for text in [lf.replace('\n', "\r"), lf.replace('\n', "\r\n")] {
        let got = parse_csv::<f64, _>(text.as_bytes(), "cr.csv").unwrap();
        assert_eq!(got, want);
    }
    // line numbers count CR-only breaks
    let (line, message) = csv_error("f,re,im\r1,2,3\r2,x,5\r".as_bytes());
    assert_eq!(line, 3);
    assert!(message.contains("`x`"), "{message}");
}

/// Old: a value of 100 kB with NUL bytes was echoed whole.
#[test]
fn echoed_values_are_cut_and_escaped() {
    let long = format!("f,re,im\n1,{}\u{0}\u{1b},3\n", "9x".repeat(50_000));
    let (line, message) = csv_error(long.as_bytes());
    assert_eq!(line, 2);
    assert!(message.chars().count() < 400, "{} chars", message.len());
    assert!(!message.chars().any(char::is_control), "{message:?}");
    let header = format!("f,re,{}\u{7}\n1,2,3\n", "q".repeat(5000));
    let (_, message) = csv_error(header.as_bytes());
    assert!(message.chars().count() < 700, "{} chars", message.len());
    assert!(!message.chars().any(char::is_control), "{message:?}");
}

/// Old: a skipped row at row 2000 was reported at the first row the skewed grid missed
/// (line 5).
#[test]
fn a_missing_row_is_named_where_it_is() {
    let mut text = String::from("# a record\nt,u,y\n");
    for i in (0..3000).filter(|i| *i != 2000) {
        text.push_str(&format!("{},{},{}\n", i as f64 * 0.01, i % 7, i % 5));
    }
    let (line, message) = csv_error(text.as_bytes());
    // row i < 2000 is on line 3 + i (a comment, the header); row 2001 follows row 1999
    // (line 2002) on line 2003
    assert_eq!(line, 2003, "{message}");
    assert!(message.contains("line 2002"), "{message}");
    assert!(message.contains("1 row seems missing"), "{message}");
}

/// Old: the condition number printed as "NaN" and the band in rad/s (the
/// Levenberg–Marquardt failure text is tested in `solver::lm`).
#[test]
fn error_texts_speak_in_words_and_hz() {
    let singular = FdidError::Singular {
        what: "the normal equations",
        condition: f64::NAN,
    }
    .to_string();
    assert!(!singular.contains("NaN"), "{singular}");
    assert!(singular.contains("not finite"), "{singular}");
    let inf = FdidError::Singular {
        what: "x",
        condition: f64::INFINITY,
    }
    .to_string();
    assert!(inf.contains("exactly singular"), "{inf}");
    let band = FdidError::EmptyBand {
        min: std::f64::consts::TAU * 10.0,
        max: std::f64::consts::TAU * 20.0,
    }
    .to_string();
    assert!(band.contains("10 .. 20 Hz ("), "{band}");
}

#[cfg(feature = "cli")]
mod command {
    use crate::cli_common::{Scratch, bundled, fdid, json, run, stderr, stdout, theta_names};

    /// `fdid fit FILE ARGS` exits with `code`; its error line (if any) is one printable
    /// line of at most 1000 characters (plus the prefix).
    fn exits(file: &std::path::Path, args: &[&str], code: i32) -> String {
        let out = run("fit", file, args);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(code), "{}: {err}", file.display());
        one_clean_line(&err);
        err
    }

    fn one_clean_line(err: &str) {
        if err.is_empty() {
            return;
        }
        let line = err.strip_suffix('\n').unwrap_or(err);
        assert!(!line.contains('\n'), "not one line: {err:?}");
        assert!(
            !line.chars().any(char::is_control),
            "control chars: {err:?}"
        );
        assert!(
            line.chars().count() <= 1100,
            "{} chars",
            line.chars().count()
        );
    }

    const S21: [&str; 6] = ["--domain", "s", "--na", "2", "--nb", "1"];

    /// Old: `--periods 0` exited 1 (bad usage is 2); `--ts` was ignored with `--domain s`
    /// on frequency data.
    #[test]
    fn usage_errors_exit_2() {
        let dryer = std::path::PathBuf::from(bundled("dryer.csv"));
        let z = ["--domain", "z", "--na", "2", "--nb", "2"];
        for extra in [["--periods", "0"], ["--realisations", "0"]] {
            let mut a = z.to_vec();
            a.extend(extra);
            exits(&dryer, &a, 2);
        }
        let s1p = std::path::PathBuf::from(bundled("rlc_bandpass.s1p"));
        let mut a = S21.to_vec();
        a.extend(["--ts", "0.1"]);
        let err = exits(&s1p, &a, 2);
        assert!(err.contains("--ts") && err.contains("--domain s"), "{err}");
    }

    /// Old: with `--noise-order` in s the names `c1` and `d1` appeared twice.
    #[test]
    fn parameter_names_are_unique() {
        let dryer = std::path::PathBuf::from(bundled("dryer.csv"));
        let args = [
            "--domain",
            "s",
            "--na",
            "2",
            "--nb",
            "2",
            "--noise-order",
            "1",
        ];
        let v = json("fit", &dryer, &args);
        let names = theta_names(&v);
        let mut unique = names.clone();
        unique.sort_unstable();
        unique.dedup();
        assert_eq!(unique.len(), names.len(), "{names:?}");
        assert!(names.ends_with(&["nc1", "nd1"]), "{names:?}");
    }

    /// Old: `eval` of a z model above Nyquist gave the aliased response silently.
    #[test]
    fn eval_above_nyquist_warns() {
        let dir = Scratch::new("nyquist");
        let model = dir.path("m.json");
        let out = fdid(&[
            "fit",
            &bundled("dryer.csv"),
            "--domain",
            "z",
            "--na",
            "2",
            "--nb",
            "2",
            "--save",
            model.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        let m = model.to_str().unwrap();
        // Ts = 0.08 s: Nyquist 6.25 Hz
        let below = fdid(&["eval", m, "--freq", "1,6"]);
        assert!(!stdout(&below).contains("Nyquist"), "{}", stdout(&below));
        let above = fdid(&["eval", m, "--freq", "1,7,20"]);
        let text = stdout(&above);
        assert!(
            text.contains("# warning: 2 of the 3 frequencies lie above the Nyquist frequency"),
            "{text}"
        );
        let json = fdid(&["eval", m, "--freq", "7", "--json"]);
        let v: serde_json::Value = serde_json::from_str(&stdout(&json)).unwrap();
        assert_eq!(v["warnings"].as_array().unwrap().len(), 1, "{v}");
    }

    /// Old: "invalid basis pole … repeated basis poles" for a constant G at na 2, nb 0.
    #[test]
    fn a_constant_response_is_no_internal_error() {
        let dir = Scratch::new("constant_g");
        let mut text = String::from("f,re,im\n");
        for k in 1..=200 {
            text.push_str(&format!("{},1,0\n", f64::from(k) * 0.1));
        }
        let file = dir.file("const.csv", &text);
        for (na, nb) in [("2", "0"), ("2", "1"), ("4", "2")] {
            let out = run("fit", &file, &["--domain", "s", "--na", na, "--nb", nb]);
            let err = stderr(&out);
            assert!(!err.contains("basis pole"), "na {na}, nb {nb}: {err}");
            assert!(out.status.code() == Some(0) || out.status.code() == Some(1));
        }
    }

    /// Old: `diagnose` on a record of 10⁶ samples ran for hours; now more than 10 000
    /// lines are refused up front, naming the remedies.
    #[test]
    fn diagnose_refuses_long_data_up_front() {
        let dir = Scratch::new("long_record");
        let mut text = String::from("t,u,y\n");
        let mut y = [0.0f64; 2];
        for k in 0..30_000u32 {
            let u = (f64::from(k) * 0.37).sin() + (f64::from(k) * 1.3).cos();
            let next = 1.2 * y[0] - 0.5 * y[1] + 0.3 * u;
            text.push_str(&format!("{},{u},{next}\n", f64::from(k) * 0.01));
            y = [next, y[0]];
        }
        let file = dir.file("long.csv", &text);
        let args = ["--domain", "z", "--na", "2", "--nb", "2"];
        let started = std::time::Instant::now();
        let out = run("diagnose", &file, &args);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(
            err.contains("lines, more than the 10000")
                && err.contains("--band")
                && err.contains("--allow-long"),
            "{err}"
        );
        one_clean_line(&err);
        // refused before any fit (reading and the DFT only)
        println!("refused in {:?}", started.elapsed());
        // a band brings it under the limit: accepted (the check is on the lines used)
        let mut banded = args.to_vec();
        banded.extend(["--band", ":5", "--max-steps", "0"]);
        let out = run("diagnose", &file, &banded);
        assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    }

    /// Old: `--noise-order 50` ran for over 590 s, `--delay` with na 20 for over 120 s,
    /// either on a 10⁶-sample record and a large `fdid ltv` for minutes, with no word. Now a fit whose search
    /// budget could take more than about a minute is refused up front (exit 2, the bound
    /// and the way out named); `--allow-long` lifts the refusal; small orders run.
    #[test]
    fn fits_beyond_a_minute_are_refused_up_front() {
        let dryer = std::path::PathBuf::from(bundled("dryer.csv"));
        let z = ["--domain", "z", "--na", "2", "--nb", "2"];
        let long = [
            (&z[..], &["--noise-order", "50"][..], "--noise-order 50"),
            (
                &["--domain", "z", "--na", "20", "--nb", "20"][..],
                &["--delay"][..],
                "--delay",
            ),
        ];
        for (orders, extra, named) in long {
            let args = [orders, extra].concat();
            // exit 2 with the estimate: refused before the fit (no timing asserted)
            let err = exits(&dryer, &args, 2);
            assert!(
                err.contains(named)
                    && err.contains("could take up to")
                    && err.contains("--allow-long"),
                "{err}"
            );
        }
        // 10⁶ samples: a noise model of the lowest orders is refused, and so is a delay
        // whose search up to its first candidate alone would take longer (order 1/0 runs:
        // its search stops at the work budget, `work_budget::a_spent_budget_ends_the_delay_search`)
        let dir = Scratch::new("million");
        let mut text = String::with_capacity(30_000_000);
        text.push_str("t,u,y\n");
        let mut y = [0.0f64; 2];
        for k in 0..1_000_000u32 {
            let u = (f64::from(k) * 0.37).sin();
            let next = 1.2 * y[0] - 0.5 * y[1] + 0.3 * u;
            text.push_str(&format!("{k},{u:.6},{next:.6}\n"));
            y = [next, y[0]];
        }
        let file = dir.file("million.csv", &text);
        let zts = ["--domain", "z", "--ts", "1"];
        let cases = [
            (&["--na", "2", "--nb", "1", "--delay"][..]),
            (&["--na", "1", "--nb", "0", "--noise-order", "3"][..]),
        ];
        for extra in cases {
            let err = exits(&file, &[&zts[..], extra].concat(), 2);
            assert!(
                err.contains("500000 lines") || err.contains("499999 lines"),
                "{err}"
            );
        }
        // and a time-varying ODE of 692 parameters on its 10⁶ real equations (it ran for
        // more than 5 minutes)
        let out = run("ltv", &file, &["--na", "10", "--nb", "10", "--np", "30"]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(
            err.contains("692 parameters") && err.contains("--allow-long"),
            "{err}"
        );
        one_clean_line(&err);
        // the refusal is lifted by --allow-long, and a small order runs without it
        let mut allowed = z.to_vec();
        allowed.extend(["--noise-order", "1", "--allow-long"]);
        exits(&dryer, &allowed, 0);
        allowed.pop();
        exits(&dryer, &allowed, 0);
    }

    /// Old: Ctrl-C killed the command by the signal, in the middle of whatever it wrote.
    /// Now it exits 130 with one line, and the file it was to write is absent (neither
    /// complete nor partial). The fit (a noise model of order 30 on the 81 920 samples of
    /// the Silverbox record) takes over half a minute; the interrupt comes after 3 s.
    #[cfg(unix)]
    #[test]
    fn ctrl_c_stops_cleanly() {
        let dir = Scratch::new("interrupt");
        let saved = dir.path("model.json");
        let child = std::process::Command::new(env!("CARGO_BIN_EXE_fdid"))
            .args([
                "fit",
                &bundled("silverbox.csv"),
                "--domain",
                "z",
                "--na",
                "2",
                "--nb",
                "2",
                "--noise-order",
                "30",
                "--allow-long",
                "--save",
                saved.to_str().unwrap(),
            ])
            .stderr(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_secs(3));
        let kill = std::process::Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status()
            .unwrap();
        assert!(kill.success());
        let out = child.wait_with_output().unwrap();
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(130), "{err}");
        assert!(err.contains("interrupted"), "{err}");
        one_clean_line(&err);
        let left: Vec<_> = std::fs::read_dir(saved.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert!(left.is_empty(), "{left:?}");
    }

    /// Bad files of every kind end in exit 1 with one clean error line: never 70 (a caught
    /// panic) or a signal.
    #[test]
    fn bad_files_exit_1_with_one_clean_line() {
        let dir = Scratch::new("bad_files");
        let long_line = format!("f,re,im\n1,2,{}\n", "3".repeat(2 << 20));
        let nul = "f,re,im\n1,\u{0}\u{0},3\n".to_string();
        let binary: String = (0u8..=255).map(char::from).collect();
        let mut missing = String::from("t,u,y\n");
        for i in (0..500).filter(|i| *i != 300) {
            missing.push_str(&format!("{},{},{}\n", f64::from(i) * 0.5, i % 3, i % 4));
        }
        let cases: [(&str, String); 8] = [
            ("empty.csv", String::new()),
            ("long.csv", long_line),
            ("nul.csv", nul),
            ("binary.csv", binary),
            ("header_only.csv", "f,re,im\n".into()),
            ("cr.csv", "f,re,im\r1,2\r".into()),
            ("missing.csv", missing),
            ("bad.s1p", "# Hz S RI R 50\n1 2\n".into()),
        ];
        for (name, text) in &cases {
            let file = dir.file(name, text);
            let err = exits(&file, &S21, 1);
            assert!(err.starts_with("error: "), "{name}: {err}");
        }
    }
}
