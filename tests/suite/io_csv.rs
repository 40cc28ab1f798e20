//! Tests of the CSV file contract (`fdid::io::parse_csv`, `read_csv`).
#![cfg(feature = "csv")]

use fdid::io::{Measurement, parse_csv, read_csv};
use fdid::{Complex, FdidError, FrequencyData, Real, TimeData};
use quickcheck::TestResult;
use std::f64::consts::TAU;
use std::path::Path;

fn parse<T: Real>(text: &str) -> fdid::Result<Measurement<T>> {
    parse_csv::<T, _>(text.as_bytes(), "test.csv")
}

fn freq<T: Real>(text: &str) -> FrequencyData<T> {
    match parse::<T>(text).unwrap() {
        Measurement::Frequency(d) => d,
        other => panic!("expected frequency data, got {other:?}"),
    }
}

fn time<T: Real>(text: &str) -> TimeData<T> {
    match parse::<T>(text).unwrap() {
        Measurement::Time(d) => d,
        other => panic!("expected a time record, got {other:?}"),
    }
}

/// Unwraps a `Parse` error into (line, message), checking the file name.
fn parse_err<T: Real>(text: &str) -> (usize, String) {
    match parse::<T>(text) {
        Err(FdidError::Parse {
            path,
            line,
            message,
        }) => {
            assert_eq!(path, "test.csv");
            (line, message)
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()).max(1e-300)
}

// ---------------------------------------------------------------- happy paths

fn frf_happy<T: Real>(rel: f64) {
    let d = freq::<T>("f,re,im\n0.5,1.0,-2.0\n1.5,3.0,4.0\n");
    assert_eq!(d.len(), 2);
    assert!(d.ts().is_none());
    assert!(d.noise().is_none());
    assert!(close(d.omega()[0].to_f64_lossless(), TAU * 0.5, rel));
    assert!(close(d.omega()[1].to_f64_lossless(), TAU * 1.5, rel));
    assert_eq!(d.y()[0], Complex::new(T::lit(1.0), T::lit(-2.0)));
    assert_eq!(d.y()[1], Complex::new(T::lit(3.0), T::lit(4.0)));
    assert!(
        d.u()
            .iter()
            .all(|u| *u == Complex::new(T::one(), T::zero()))
    );

    let d = freq::<T>("f,re,im,var\n0,1,0,0.25\n10,0.5,-0.5,0.5\n");
    let n = d.noise().unwrap();
    assert_eq!(n.var_y, vec![T::lit(0.25), T::lit(0.5)]);
    assert_eq!(n.var_u, vec![T::zero(); 2]);
    assert_eq!(n.cov_yu, vec![Complex::new(T::zero(), T::zero()); 2]);
}

#[test]
fn frf_happy_f64() {
    frf_happy::<f64>(1e-15);
}

#[test]
fn frf_happy_f32() {
    frf_happy::<f32>(1e-6);
}

fn spectra_happy<T: Real>() {
    let d = freq::<T>(
        "f,u_re,u_im,y_re,y_im,var_u,var_y\n1,1,0.5,2,-1,0.1,0.2\n2,0.25,0,1,1,0.3,0.4\n",
    );
    assert_eq!(d.len(), 2);
    assert_eq!(d.u()[0], Complex::new(T::lit(1.0), T::lit(0.5)));
    assert_eq!(d.y()[0], Complex::new(T::lit(2.0), T::lit(-1.0)));
    assert_eq!(d.u()[1], Complex::new(T::lit(0.25), T::zero()));
    let n = d.noise().unwrap();
    assert_eq!(n.var_u, vec![T::lit(0.1), T::lit(0.3)]);
    assert_eq!(n.var_y, vec![T::lit(0.2), T::lit(0.4)]);
    assert!(
        n.cov_yu
            .iter()
            .all(|c| *c == Complex::new(T::zero(), T::zero()))
    );

    // Only var_y: var_u is zero. No variance column: no noise.
    let d = freq::<T>("f,u_re,u_im,y_re,y_im,var_y\n1,1,0,1,0,0.5\n");
    let n = d.noise().unwrap();
    assert_eq!(n.var_y, vec![T::lit(0.5)]);
    assert_eq!(n.var_u, vec![T::zero()]);
    assert!(
        freq::<T>("f,u_re,u_im,y_re,y_im\n1,1,0,1,0\n")
            .noise()
            .is_none()
    );
}

#[test]
fn spectra_happy_f64() {
    spectra_happy::<f64>();
}

#[test]
fn spectra_happy_f32() {
    spectra_happy::<f32>();
}

fn time_happy<T: Real>(rel: f64) {
    let d = time::<T>("t,u,y\n0,1,2\n0.1,3,4\n0.2,5,6\n0.3,7,8\n");
    assert_eq!(d.len(), 4);
    assert!(close(d.ts().to_f64_lossless(), 0.1, rel));
    assert_eq!(d.u(), &[T::lit(1.0), T::lit(3.0), T::lit(5.0), T::lit(7.0)]);
    assert_eq!(d.y(), &[T::lit(2.0), T::lit(4.0), T::lit(6.0), T::lit(8.0)]);
    // Non-zero start, times rounded to 4 decimals (well within 1e-3·Ts).
    let mut text = String::from("t,u,y\n");
    for i in 0..1000 {
        text.push_str(&format!("{:.4},{i},0\n", 12.5 + i as f64 / 3.0));
    }
    let d = time::<T>(&text);
    assert_eq!(d.len(), 1000);
    assert!(close(d.ts().to_f64_lossless(), 1.0 / 3.0, 1e-5));
}

#[test]
fn time_happy_f64() {
    time_happy::<f64>(1e-12);
}

#[test]
fn time_happy_f32() {
    time_happy::<f32>(1e-6);
}

#[test]
fn header_is_case_insensitive_trimmed_and_in_any_order() {
    let text = "# a comment\n\n   \n  # indented comment\n Im , F,RE \n-2, 0.5 ,1\n";
    let d = freq::<f64>(text);
    assert_eq!(d.y()[0], Complex::new(1.0, -2.0));
    assert!(close(d.omega()[0], TAU * 0.5, 1e-15));

    let d = time::<f32>("Y,T,U\n1,0,2\n3,1,4\n");
    assert_eq!(d.u(), &[2.0, 4.0]);
    assert_eq!(d.y(), &[1.0, 3.0]);
}

#[test]
fn crlf_bom_blank_lines_and_comments_between_rows() {
    let text = "\u{feff}f,re,im\r\n1,1,0\r\n\r\n# note\r\n2,2,0\r\n";
    let d = freq::<f64>(text);
    assert_eq!(d.len(), 2);
    assert_eq!(d.y()[1], Complex::new(2.0, 0.0));
}

#[test]
fn quoted_fields_are_accepted() {
    let d = freq::<f64>("\"f\",\"re\",\"im\"\n\"1\",\"2\",\"3\"\n");
    assert_eq!(d.y()[0], Complex::new(2.0, 3.0));
}

#[test]
fn measurement_helpers() {
    let m = parse::<f64>("t,u,y\n0,1,0\n1,0,0\n2,0,0\n3,0,0\n").unwrap();
    assert!(m.is_time());
    let d = m.into_frequency_data().unwrap();
    assert_eq!(d.len(), 3);
    assert_eq!(d.ts(), Some(1.0));
    let m = parse::<f64>("f,re,im\n1,2,3\n").unwrap();
    assert!(!m.is_time());
    assert_eq!(m.into_frequency_data().unwrap().len(), 1);
}

// ---------------------------------------------------------------- errors

fn empty_file_errors<T: Real>() {
    for text in ["", "\n\n", "# only a comment\n", "   \n# x\n"] {
        let (line, msg) = parse_err::<T>(text);
        assert_eq!(line, 0, "{text:?}");
        assert!(msg.contains("no header"), "{msg}");
    }
    for text in ["f,re,im\n", "f,re,im\n# nothing\n\n"] {
        assert_eq!(
            parse::<T>(text).unwrap_err(),
            FdidError::TooShort {
                what: "data rows",
                needed: 1,
                got: 0
            }
        );
    }
    for text in ["t,u,y\n", "t,u,y\n0,1,2\n"] {
        assert!(matches!(
            parse::<T>(text).unwrap_err(),
            FdidError::TooShort { needed: 2, .. }
        ));
    }
}

#[test]
fn empty_file_errors_f64() {
    empty_file_errors::<f64>();
}

#[test]
fn empty_file_errors_f32() {
    empty_file_errors::<f32>();
}

fn header_errors<T: Real>() {
    let cases: &[(&str, &str)] = &[
        ("f,re\n1,2\n", "missing column `im`"),
        ("f,im\n1,2\n", "missing column `re`"),
        ("re,im\n1,2\n", "missing column `f`"),
        ("f,u_re,u_im,y_re\n1,2,3,4\n", "missing column `y_im`"),
        ("t,u\n0,1\n1,2\n", "missing column `y`"),
        ("f\n1\n", "missing columns"),
        ("f,re,im,phase\n1,2,3,4\n", "unknown column `phase`"),
        ("f,re,im,var_y\n1,2,3,4\n", "unknown column `var_y`"),
        (
            "f,u_re,u_im,y_re,y_im,var\n1,1,1,1,1,1\n",
            "unknown column `var`",
        ),
        ("t,u,y,f\n0,1,2,3\n", "unknown column `f`"),
        ("f,re,im,re\n1,2,3,4\n", "duplicate column `re`"),
        ("f,re,im,\n1,2,3,4\n", "empty column name"),
        ("1,2,3\n4,5,6\n", "unrecognized header `1,2,3`"),
        ("a,b\n", "unrecognized header"),
    ];
    for (text, want) in cases {
        let (line, msg) = parse_err::<T>(text);
        assert_eq!(line, 1, "{text:?}");
        assert!(msg.contains(want), "{text:?}: {msg}");
    }
    // The header line number counts skipped lines.
    let (line, msg) = parse_err::<T>("# c\n\nf,re\n1,2\n");
    assert_eq!(line, 3);
    assert!(msg.contains("`im`"));
}

#[test]
fn header_errors_f64() {
    header_errors::<f64>();
}

#[test]
fn header_errors_f32() {
    header_errors::<f32>();
}

fn row_errors<T: Real>() {
    // Wrong field counts, with the line number and the row text.
    let (line, msg) = parse_err::<T>("f,re,im\n1,2,3\n2,3\n");
    assert_eq!(line, 3);
    assert!(
        msg.contains("expected 3 fields") && msg.contains("found 2"),
        "{msg}"
    );
    assert!(msg.contains("`2,3`"), "{msg}");
    let (line, msg) = parse_err::<T>("# c\nt,u,y\n0,1,2\n\n1,2,3,4\n");
    assert_eq!(line, 5);
    assert!(
        msg.contains("found 4") && msg.contains("`1,2,3,4`"),
        "{msg}"
    );

    // Non-numbers, with the line, the column and the bad text.
    for (text, line_no, bad) in [
        ("f,re,im\n1,2,3\n2,abc,4\n", 3, "`abc`"),
        ("f,re,im\n1,2,3\n2,3,\n", 3, "``"),
        ("f,re,im\n1,2,3\n2,3,1.2.3\n", 3, "`1.2.3`"),
        ("t,u,y\n0,1,2\n1,2,3e\n", 3, "`3e`"),
    ] {
        let (line, msg) = parse_err::<T>(text);
        assert_eq!(line, line_no, "{text:?}");
        assert!(msg.contains(bad) && msg.contains("not a number"), "{msg}");
    }
    let (_, msg) = parse_err::<T>("f,re,im\n1,x,3\n");
    assert!(msg.contains("column `re`"), "{msg}");

    // NaN and infinities, naming row and column.
    for (text, col, bad) in [
        ("f,re,im\n1,2,3\n2,NaN,4\n", "re", "NaN"),
        ("f,re,im\n1,2,inf\n", "im", "inf"),
        ("t,u,y\n0,1,2\n1,-inf,3\n", "u", "-inf"),
        ("f,re,im,var\n1,2,3,nan\n", "var", "nan"),
        ("f,re,im\n1e400,1,1\n", "f", "1e400"),
    ] {
        let (line, msg) = parse_err::<T>(text);
        assert!(line >= 2, "{text:?}");
        assert!(
            msg.contains(&format!("column `{col}`")) && msg.contains(bad),
            "{text:?}: {msg}"
        );
        assert!(msg.contains("not finite"), "{msg}");
    }

    // Negative variances.
    let (line, msg) = parse_err::<T>("f,re,im,var\n1,2,3,0.1\n2,2,3,-0.5\n");
    assert_eq!(line, 3);
    assert!(msg.contains("`var`") && msg.contains("-0.5"), "{msg}");
    let (line, msg) = parse_err::<T>("f,u_re,u_im,y_re,y_im,var_u\n1,1,1,1,1,-1\n");
    assert_eq!(line, 2);
    assert!(msg.contains("`var_u`"), "{msg}");

    // Invalid UTF-8 in a field.
    let bytes = b"f,re,im\n1,\xff\xfe,3\n";
    match parse_csv::<T, _>(&bytes[..], "bin.csv") {
        Err(FdidError::Parse { line, .. }) => assert_eq!(line, 2),
        other => panic!("{other:?}"),
    }
    let bytes = b"f,r\xffe,im\n1,2,3\n";
    assert!(matches!(
        parse_csv::<T, _>(&bytes[..], "bin.csv"),
        Err(FdidError::Parse { line: 1, .. })
    ));
}

#[test]
fn row_errors_f64() {
    row_errors::<f64>();
}

#[test]
fn row_errors_f32() {
    row_errors::<f32>();
}

#[test]
fn value_out_of_f32_range_is_named() {
    let (line, msg) = parse_err::<f32>("f,re,im\n1,1e39,0\n");
    assert_eq!(line, 2);
    assert!(
        msg.contains("`re`") && msg.contains("1e39") && msg.contains("f32"),
        "{msg}"
    );
    // The same file is fine in f64.
    assert!(parse::<f64>("f,re,im\n1,1e39,0\n").is_ok());
    // 2π·f overflowing.
    let (line, msg) = parse_err::<f32>("f,re,im\n1e38,1,0\n");
    assert_eq!(line, 2);
    assert!(msg.contains("`f`"), "{msg}");
}

/// Bad frequencies are named with their file line and value in Hz.
fn frequency_order_errors<T: Real>() {
    let (line, msg) = parse_err::<T>("f,re,im\n1,0,0\n-2,0,0\n");
    assert_eq!(line, 3);
    assert!(msg.contains("negative frequency -2 Hz"), "{msg}");
    let (line, msg) = parse_err::<T>("f,re,im\n-1,0,0\n");
    assert_eq!(line, 2);
    assert!(msg.contains("negative frequency -1 Hz"), "{msg}");
    let (line, msg) = parse_err::<T>("# notes\nf,re,im\n1,0,0\n3,0,0\n\n2,0,0\n");
    assert_eq!(line, 6);
    assert!(
        msg.contains("frequency 2 Hz is below the previous row's 3 Hz (line 4)"),
        "{msg}"
    );
    let (line, msg) = parse_err::<T>("f,u_re,u_im,y_re,y_im\n1,1,0,1,0\n2,1,0,1,0\n2,1,0,1,0\n");
    assert_eq!(line, 4);
    assert!(
        msg.contains("duplicate frequency 2 Hz (the previous row, line 3,"),
        "{msg}"
    );
    // Zero is allowed.
    assert_eq!(freq::<T>("f,re,im\n0,1,0\n1,1,0\n").omega()[0], T::zero());
}

#[test]
fn frequency_order_errors_f64() {
    frequency_order_errors::<f64>();
}

#[test]
fn frequency_order_errors_f32() {
    frequency_order_errors::<f32>();
}

fn time_grid_errors<T: Real>() {
    let (line, msg) = parse_err::<T>("t,u,y\n0,1,1\n1,1,1\n1,1,1\n");
    assert_eq!(line, 4);
    assert!(msg.contains("does not increase"), "{msg}");
    let (line, msg) = parse_err::<T>("t,u,y\n0,1,1\n2,1,1\n1,1,1\n");
    assert_eq!(line, 4);
    assert!(msg.contains("does not increase"), "{msg}");
    // Non-uniform: row 3 (line 4) is 0.1·Ts off the grid.
    let (line, msg) = parse_err::<T>("t,u,y\n0,1,1\n1,1,1\n2.1,1,1\n3,1,1\n");
    assert_eq!(line, 4);
    assert!(msg.contains("non-uniform") && msg.contains("2.1"), "{msg}");
    // A deviation just under the tolerance is accepted.
    assert!(parse::<T>("t,u,y\n0,1,1\n1.0009,1,1\n2,1,1\n").is_ok());
    assert!(parse::<T>("t,u,y\n0,1,1\n1.0011,1,1\n2,1,1\n").is_err());
}

#[test]
fn time_grid_errors_f64() {
    time_grid_errors::<f64>();
}

#[test]
fn time_grid_errors_f32() {
    time_grid_errors::<f32>();
}

#[test]
fn missing_file_is_an_io_error() {
    let e = read_csv::<f64>(Path::new("/nonexistent/dir/file.csv")).unwrap_err();
    match e {
        FdidError::Io(msg) => assert!(msg.contains("/nonexistent/dir/file.csv"), "{msg}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn read_csv_names_the_file_in_errors() {
    let dir = std::env::temp_dir().join(format!("fdid-io-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.csv");
    std::fs::write(&path, "f,re,im\n1,2,x\n").unwrap();
    let e = read_csv::<f64>(&path).unwrap_err();
    let _ = std::fs::remove_dir_all(&dir);
    match e {
        FdidError::Parse { path: p, line, .. } => {
            assert!(p.ends_with("bad.csv"), "{p}");
            assert_eq!(line, 2);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_file_reads_as_its_bytes_do_small_or_large() {
    // a file below and one above the size where the reading takes larger pieces (2 MiB),
    // with a comment among the rows: reading the file (whose length sizes the buffers)
    // and parsing its bytes give the same data, bit for bit
    let dir = std::env::temp_dir().join(format!("fdid-io-sizes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for rows in [1_000, 40_000] {
        let mut text = String::from("f,re,im\n");
        for k in 1..=rows {
            let f = k as f64 * 0.0137;
            let g = 1.0 / (1.0 + f * f);
            text.push_str(&format!("{f:.17e},{g:.17e},{:.17e}\n", -f * g));
            if k == rows / 3 {
                text.push_str("# a comment\n\n");
            }
        }
        let path = dir.join(format!("rows{rows}.csv"));
        std::fs::write(&path, &text).unwrap();
        let from_file = read_csv::<f64>(&path).unwrap();
        let from_bytes = parse_csv::<f64, _>(text.as_bytes(), "bytes").unwrap();
        assert_eq!(from_file, from_bytes, "{rows} rows");
        let d = from_file.into_frequency_data().unwrap();
        assert_eq!(d.len(), rows);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------- bundled data

fn bundled(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
}

#[test]
fn bundled_robot_arm_parses() {
    let Measurement::Time(d) = read_csv::<f64>(&bundled("robot_arm.csv")).unwrap() else {
        panic!("expected a time record")
    };
    assert_eq!(d.len(), 1024);
    assert_eq!(d.ts(), 1.0);
    assert_eq!(d.u()[0], 2.2183165e-01);
    assert_eq!(d.y()[0], -1.7703630e-01);
    // One period of an odd-harmonic excitation: odd lines dominate.
    let f = d.dft();
    assert_eq!(f.len(), 513);
    let odd: f64 = (1..200).step_by(2).map(|k| f.u()[k].norm_sqr()).sum();
    let even: f64 = (2..201).step_by(2).map(|k| f.u()[k].norm_sqr()).sum();
    assert!(odd > 100.0 * even, "odd {odd}, even {even}");

    let Measurement::Time(d32) = read_csv::<f32>(&bundled("robot_arm.csv")).unwrap() else {
        panic!("expected a time record")
    };
    assert_eq!(d32.len(), 1024);
    assert_eq!(d32.ts(), 1.0f32);
}

#[test]
fn bundled_eis_battery_parses() {
    let Measurement::Frequency(d) = read_csv::<f64>(&bundled("eis_battery.csv")).unwrap() else {
        panic!("expected frequency data")
    };
    assert_eq!(d.len(), 66);
    assert!(d.ts().is_none());
    assert!(close(d.omega()[0], TAU * 3.1623e-3, 1e-12));
    assert!(close(d.omega()[65], TAU * 1.0e4, 1e-12));
    let capacitive = d.y().iter().filter(|z| z.im < 0.0).count();
    assert_eq!(capacitive, 57);
    let d32 = read_csv::<f32>(&bundled("eis_battery.csv")).unwrap();
    assert_eq!(d32.into_frequency_data().unwrap().len(), 66);
}

#[test]
fn bundled_dryer_parses() {
    let Measurement::Time(d) = read_csv::<f64>(&bundled("dryer.csv")).unwrap() else {
        panic!("expected a time record")
    };
    assert_eq!(d.len(), 1000);
    assert!(close(d.ts(), 0.08, 1e-12), "Ts = {}", d.ts());
    // the numbers of DaISy's dryer.dat, unchanged: first and last rows
    assert_eq!((d.u()[0], d.y()[0]), (6.41, 4.7660989));
    assert_eq!((d.u()[999], d.y()[999]), (6.41, 4.6830789));
    // a binary input at exactly 3.41 and 6.41 V
    assert!(d.u().iter().all(|u| *u == 3.41 || *u == 6.41));
    assert_eq!(d.dft().len(), 501);
}

// ---------------------------------------------------------------- robustness

fn no_panic(bytes: &[u8]) {
    let _ = parse_csv::<f64, _>(bytes, "q");
    let _ = parse_csv::<f32, _>(bytes, "q");
}

#[test]
fn random_bytes_never_panic() {
    fn prop(bytes: Vec<u8>) -> bool {
        no_panic(&bytes);
        true
    }
    crate::common::seeded(0xe142a0e2)
        .tests(2000)
        .quickcheck(prop as fn(Vec<u8>) -> bool);
}

#[test]
fn random_text_never_panics() {
    fn prop(s: String) -> bool {
        no_panic(s.as_bytes());
        let with_header = format!("f,re,im\n{s}");
        no_panic(with_header.as_bytes());
        let time = format!("t,u,y\n{s}");
        no_panic(time.as_bytes());
        true
    }
    crate::common::seeded(0x96459074)
        .tests(2000)
        .quickcheck(prop as fn(String) -> bool);
}

const VALID: [&str; 4] = [
    "# comment\nf,re,im,var\n0,1,0,0.1\n0.5,0.8,-0.3,0.1\n1,0.5,-0.5,0.2\n2,0.1,-0.4,0.3\n",
    "f,u_re,u_im,y_re,y_im,var_u,var_y\n1,1,0,0.5,0.5,0.01,0.02\n2,1,0.1,0.4,0.3,0.01,0.02\n",
    "t,u,y\n0,1,0\n0.5,-1,0.5\n1,1,-0.5\n1.5,-1,0.5\n2,1,-0.5\n",
    "T , U , Y\r\n0,1e-3,2E4\r\n1,-0.0,+3\r\n",
];

/// Applies edit operations to a valid file: (op, position, byte).
fn mutate(base: &[u8], edits: &[(u8, usize, u8)]) -> Vec<u8> {
    let mut v = base.to_vec();
    for &(op, pos, byte) in edits {
        let alphabet = b"0123456789.,-+eE#\n\r \"nNaAiIfF\xff\x00tuyrm_";
        let b = alphabet[byte as usize % alphabet.len()];
        match op % 3 {
            0 if !v.is_empty() => {
                let i = pos % v.len();
                v[i] = b;
            }
            1 => {
                let i = pos % (v.len() + 1);
                v.insert(i, b);
            }
            _ if !v.is_empty() => {
                let i = pos % v.len();
                v.remove(i);
            }
            _ => {}
        }
    }
    v
}

#[test]
fn mutated_valid_files_never_panic() {
    fn prop(which: u8, edits: Vec<(u8, usize, u8)>) -> TestResult {
        let base = VALID[which as usize % VALID.len()].as_bytes();
        no_panic(&mutate(base, &edits));
        TestResult::passed()
    }
    for base in VALID {
        assert!(parse::<f64>(base).is_ok(), "{base}");
        assert!(parse::<f32>(base).is_ok(), "{base}");
    }
    crate::common::seeded(0xf4cc1ce)
        .tests(5000)
        .quickcheck(prop as fn(u8, Vec<(u8, usize, u8)>) -> TestResult);
}
