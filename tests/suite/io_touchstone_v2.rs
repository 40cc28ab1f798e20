//! Touchstone 2.0 files: equal to their version 1 equivalents, each keyword, and bad
//! inputs as typed errors naming the line and the value.
#![cfg(feature = "csv")]

#[cfg(feature = "cli")]
use crate::cli_common as cli;

use fdid::Complex;
use fdid::error::FdidError;
use fdid::io::{
    NetworkParameter, NumberFormat, Touchstone, TouchstoneVersion, parse_touchstone,
    parse_touchstone_v2, read_touchstone,
};
use std::path::Path;

fn bundled(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
}

fn parse(text: &str, ports: usize) -> Result<Touchstone, FdidError> {
    parse_touchstone(text.as_bytes(), ports, "t.s2p")
}

/// The line and message of a parse error: read as `t.s2p` with `Some(ports)` ports, or as
/// a `.ts` file with `None`.
fn error_of(text: &str, ports: Option<usize>) -> (usize, String) {
    let read = match ports {
        Some(ports) => parse(text, ports),
        None => parse_touchstone_v2(text.as_bytes(), "t.ts"),
    };
    match read {
        Err(FdidError::Parse { line, message, .. }) => (line, message),
        Err(e) => panic!("{text:?}: not a parse error: {e}"),
        Ok(t) => panic!("{text:?}: read as {t:?}"),
    }
}

/// The rows of a version 1 file (comments and the option line dropped), as fields.
fn v1_rows(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .map(|l| l.split('!').next().unwrap().trim())
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| l.split_whitespace().map(String::from).collect())
        .collect()
}

/// The bundled version 1 2-port rewritten as version 2.0 with `order` and `matrix`
/// (`Full`, `Lower`, `Upper`).
fn rlc_v2(order: &str, matrix: &str) -> String {
    let v1 = std::fs::read_to_string(bundled("rlc_bandpass.s2p")).unwrap();
    let rows = v1_rows(&v1);
    let mut out = format!(
        "! the series RLC of rlc_bandpass.s2p\n[Version] 2.0\n# MHz S DB R 50\n\
         [Number of Ports] 2\n[Two-Port Data Order] {order}\n[Number of Frequencies] {}\n\
         [Matrix Format] {matrix}\n[Network Data]\n",
        rows.len()
    );
    for r in rows {
        // version 1: f S11 S21 S12 S22, two fields each
        let (f, s11, s21, s12, s22) = (&r[0], &r[1..3], &r[3..5], &r[5..7], &r[7..9]);
        let pairs: Vec<&[String]> = match (matrix, order) {
            ("Full", "21_12") => vec![s11, s21, s12, s22],
            ("Full", _) => vec![s11, s12, s21, s22],
            ("Lower", _) => vec![s11, s21, s22],
            _ => vec![s11, s12, s22],
        };
        out.push_str(f);
        for p in pairs {
            out.push_str(&format!(" {} {}", p[0], p[1]));
        }
        out.push('\n');
    }
    out.push_str("[End]\n");
    out
}

#[test]
fn version_2_two_port_equals_version_1() {
    let v1 = read_touchstone(&bundled("rlc_bandpass.s2p")).unwrap();
    assert_eq!(v1.version, TouchstoneVersion::V1);
    assert_eq!(v1.references, vec![50.0, 50.0]);
    for (order, matrix) in [
        ("21_12", "Full"),
        ("12_21", "Full"),
        ("12_21", "Lower"),
        ("21_12", "Upper"),
    ] {
        let text = rlc_v2(order, matrix);
        let v2 = parse(&text, 2).unwrap_or_else(|e| panic!("{order} {matrix}: {e}"));
        assert_eq!(v2.version, TouchstoneVersion::V2);
        assert_eq!(v2.freq_hz, v1.freq_hz, "{order} {matrix}");
        assert_eq!(v2.values, v1.values, "{order} {matrix}");
        assert_eq!(
            (v2.ports, v2.parameter, v2.format, v2.reference),
            (2, NetworkParameter::S, NumberFormat::DecibelAngle, 50.0)
        );
        assert_eq!(v2.references, vec![50.0, 50.0]);
        // the bundled .ts file is the 12_21 full form
        if (order, matrix) == ("12_21", "Full") {
            let ts = read_touchstone(&bundled("rlc_bandpass.ts")).unwrap();
            assert_eq!(ts.values, v1.values);
            assert_eq!(ts.freq_hz, v1.freq_hz);
        }
    }
}

#[test]
fn version_2_one_port_equals_version_1() {
    let v1 = read_touchstone(&bundled("rlc_bandpass.s1p")).unwrap();
    let text = std::fs::read_to_string(bundled("rlc_bandpass.s1p")).unwrap();
    let rows = v1_rows(&text);
    let mut v2 = format!(
        "[VERSION] 2.0 ! keywords are case-insensitive\n# Hz S RI R 50\n\
         [number of ports] 1\n[Number of Frequencies] {}\n[Network Data]\n",
        rows.len()
    );
    for r in rows {
        v2.push_str(&r.join(" "));
        v2.push('\n');
    }
    v2.push_str("[End]\n! a comment after the end\n\n");
    let t = parse(&v2, 1).unwrap();
    assert_eq!(t.freq_hz, v1.freq_hz);
    assert_eq!(t.values, v1.values);
    // a .ts file needs no extension to name its ports
    let ts = parse_touchstone_v2(v2.as_bytes(), "t.ts").unwrap();
    assert_eq!((ts.ports, ts.values.len()), (1, v1.values.len()));
}

#[test]
fn two_port_data_order_places_the_entries() {
    // an asymmetric matrix: X11 = 11, X12 = 12, X21 = 21, X22 = 22
    let head = "[Version] 2.0\n# Hz Z RI\n[Number of Ports] 2\n[Number of Frequencies] 1\n";
    let natural = format!(
        "{head}[Two-Port Data Order] 12_21\n[Network Data]\n1 11 0 12 0 21 0 22 0\n[End]\n"
    );
    let legacy = format!(
        "{head}[Two-Port Data Order] 21_12\n[Network Data]\n1 11 0 21 0 12 0 22 0\n[End]\n"
    );
    for text in [natural, legacy] {
        let t = parse(&text, 2).unwrap();
        let re: Vec<f64> = t.values[0].iter().map(|c| c.re).collect();
        // row-major X11 X12 X21 X22; version 2 Z values are not normalised
        assert_eq!(re, vec![11.0, 12.0, 21.0, 22.0], "{text}");
        let z21 = t.frequency_data::<f64>((2, 1)).unwrap();
        assert_eq!(z21.y()[0], Complex::new(21.0, 0.0));
    }
}

#[test]
fn version_2_values_are_not_normalised() {
    // the same impedance in both versions: v1 writes z = Z/R
    let v1 = parse("# Hz Z RI R 50\n1 2 -1 0.5 0 0.5 0 4 2\n", 2).unwrap();
    let v2 = parse(
        "[Version] 2.0\n# Hz Z RI R 50\n[Number of Ports] 2\n[Two-Port Data Order] 21_12\n\
         [Number of Frequencies] 1\n[Network Data]\n1 100 -50 25 0 25 0 200 100\n[End]\n",
        2,
    )
    .unwrap();
    assert_eq!(v1.values, v2.values);
    // Y in version 1 is y/R
    let y1 = parse("# Hz Y RI R 25\n1 2 -1\n", 1).unwrap();
    let y2 = parse(
        "[Version] 2.0\n# Hz Y RI R 25\n[Number of Ports] 1\n[Number of Frequencies] 1\n\
         [Network Data]\n1 0.08 -0.04\n[End]\n",
        1,
    )
    .unwrap();
    assert!((y1.values[0][0] - y2.values[0][0]).norm() < 1e-15);
}

#[test]
fn reference_per_port_over_several_lines() {
    let text = "[Version] 2.0\n# GHz S MA R 50\n[Number of Ports] 2\n\
                [Two-Port Data Order] 12_21\n[Reference] 50 ! port 1\n75 ! port 2\n\
                [Number of Frequencies] 2\n[Network Data]\n1 0.5 0 0.1 90\n 0.1 90 0.5 0\n\
                2 0.4 0 0.2 90 0.2 90 0.4 0\n[End]\n";
    let t = parse(text, 2).unwrap();
    assert_eq!(t.references, vec![50.0, 75.0]);
    assert_eq!(t.reference, 50.0);
    assert_eq!(t.freq_hz, vec![1e9, 2e9]);
    // a row continued on the next line
    assert!((t.values[0][1] - Complex::new(0.0, 0.1)).norm() < 1e-15);
    // on the keyword line
    let one = parse(
        "[Version] 2.0\n#\n[Number of Ports] 1\n[Reference] 20\n[Number of Frequencies] 1\n\
         [Network Data]\n1 1 0\n[End]\n",
        1,
    )
    .unwrap();
    assert_eq!(one.references, vec![20.0]);
    assert_eq!(one.reference, 50.0);
}

#[test]
fn information_and_noise_blocks_are_skipped() {
    let text = "[Version] 2.0\n# GHz S RI\n[Number of Ports] 2\n[Two-Port Data Order] 21_12\n\
                [Number of Frequencies] 2\n[Number of Noise Frequencies] 2\n\
                [Begin Information]\n[Whatever] 1 2 3\nfree text\n# not an option line\n[End Information]\n\
                [Network Data]\n1 1 0 2 0 3 0 4 0\n2 1 0 2 0 3 0 4 0\n\
                [Noise Data]\n1 0.5 0.1 10 0.3\n2 0.6 0.1 20 0.3\n[End]\n";
    let t = parse(text, 2).unwrap();
    assert_eq!(t.freq_hz, vec![1e9, 2e9]);
    assert_eq!(t.values[1][1], Complex::new(3.0, 0.0));
}

/// A bad file: its text, how it is read (`Some(ports)`: as `t.s2p` with that many ports,
/// `None`: as a `.ts` file), the line its error names and the needles of its message.
struct Bad {
    text: String,
    ports: Option<usize>,
    line: usize,
    needles: &'static [&'static str],
}

const HEAD1: &str = "[Version] 2.0\n# Hz S RI\n[Number of Ports] 1\n";
const HEAD2: &str = "[Version] 2.0\n# Hz S RI\n[Number of Ports] 2\n[Two-Port Data Order] 12_21\n";

/// `text` read with `ports` ports.
fn raw(text: &str, ports: usize, line: usize, needles: &'static [&'static str]) -> Bad {
    Bad {
        text: text.to_string(),
        ports: Some(ports),
        line,
        needles,
    }
}

/// A 1-port file: [`HEAD1`] and then `body`.
fn one(body: &str, line: usize, needles: &'static [&'static str]) -> Bad {
    raw(&format!("{HEAD1}{body}"), 1, line, needles)
}

/// A 2-port file: [`HEAD2`] and then `body`.
fn two(body: &str, line: usize, needles: &'static [&'static str]) -> Bad {
    raw(&format!("{HEAD2}{body}"), 2, line, needles)
}

/// `text` read as a `.ts` file.
fn ts(text: &str, line: usize, needles: &'static [&'static str]) -> Bad {
    Bad {
        text: text.to_string(),
        ports: None,
        line,
        needles,
    }
}

/// Each bad file: the error names the line, and the message holds every needle.
#[test]
fn bad_version_2_files_name_the_line_and_value() {
    let cases = [
        // fewer rows than declared
        one(
            "[Number of Frequencies] 3\n[Network Data]\n1 0 0\n2 0 0\n[End]\n",
            8,
            &["2 frequencies", "says 3", "line 4"],
        ),
        // more rows than declared
        one(
            "[Number of Frequencies] 1\n[Network Data]\n1 0 0\n2 0 0\n[End]\n",
            7,
            &["more than the 1 frequencies", "`2`"],
        ),
        // no [Network Data]
        one("[Number of Frequencies] 1\n", 4, &["no `[Network Data]`"]),
        one(
            "[Number of Frequencies] 1\n[End]\n",
            5,
            &["[End]", "before `[Network Data]`"],
        ),
        one(
            "[Number of Frequencies] 1\n1 0 0\n",
            5,
            &["`1 0 0` before `[Network Data]`"],
        ),
        // bad numbers
        one(
            "[Number of Frequencies] 1\n[Network Data]\n1 0 zero\n[End]\n",
            6,
            &["`zero` is not a number"],
        ),
        one(
            "[Number of Frequencies] 1\n[Network Data]\n1 0 inf\n[End]\n",
            6,
            &["`inf` is not finite"],
        ),
        one(
            "[Number of Frequencies] 2\n[Network Data]\n2 0 0\n1 0 0\n[End]\n",
            7,
            &["not above the previous one"],
        ),
        // a row cut short
        two(
            "[Number of Frequencies] 1\n[Network Data]\n1 0 0 0 0 0\n[End]\n",
            7,
            &["ends after 6 of its 9 numbers"],
        ),
        // no [End]
        one(
            "[Number of Frequencies] 1\n[Network Data]\n1 0 0\n",
            6,
            &["without `[End]`"],
        ),
        one(
            "[Number of Frequencies] 1\n[Network Data]\n1 0 0\n[End]\n1 0 0\n",
            8,
            &["after `[End]`"],
        ),
        // counts
        one(
            "[Number of Frequencies] 0\n",
            4,
            &["positive whole number", "`0`"],
        ),
        one("[Number of Frequencies] many\n", 4, &["`many`"]),
        one(
            "[Network Data]\n1 0 0\n[End]\n",
            4,
            &["without `[Number of Frequencies]`"],
        ),
        // ports
        raw(
            "[Version] 2.0\n# Hz S RI\n[Number of Ports] 65\n",
            2,
            3,
            &["[Number of Ports] 65", "more than 64 ports"],
        ),
        raw(
            "[Version] 2.0\n# Hz S RI\n[Number of Ports] 1\n",
            2,
            3,
            &["[Number of Ports] 1", ".s2p names 2 ports"],
        ),
        raw(
            "[Version] 2.0\n# Hz S RI\n[Number of Frequencies] 1\n",
            1,
            3,
            &["[Number of Ports]` must follow the option line"],
        ),
        raw(
            "[Version] 2.0\n# Hz H RI\n[Number of Ports] 1\n",
            1,
            3,
            &["H parameters are defined for 2 ports only"],
        ),
        // two-port data order
        raw(
            "[Version] 2.0\n# Hz S RI\n[Number of Ports] 2\n[Number of Frequencies] 1\n\
             [Network Data]\n",
            2,
            5,
            &["without `[Two-Port Data Order]`"],
        ),
        raw(
            "[Version] 2.0\n# Hz S RI\n[Number of Ports] 2\n[Two-Port Data Order] 12-21\n",
            2,
            4,
            &["12_21 or 21_12", "`12-21`"],
        ),
        one("[Two-Port Data Order] 12_21\n", 4, &["2-port files only"]),
        // reference
        two(
            "[Reference] 50\n[Number of Frequencies] 1\n",
            6,
            &["`[Reference]` (line 5) gives 1 of the 2"],
        ),
        two("[Reference] 50 -75\n", 5, &["-75", "port 2", "positive"]),
        two("[Reference] 50 75 100\n", 5, &["`100` is one value more"]),
        two("[Reference] 50 ohm\n", 5, &["`ohm` is not a number"]),
        // matrix format
        one(
            "[Matrix Format] Diagonal\n",
            4,
            &["Full, Lower or Upper", "`Diagonal`"],
        ),
        // unsupported and unknown keywords
        two(
            "[Mixed-Mode Order] D1,2\n",
            5,
            &["[Mixed-Mode Order]", "not supported"],
        ),
        one(
            "[Frobnicate] 1\n",
            4,
            &["unknown Touchstone 2.0 keyword `[Frobnicate]`"],
        ),
        one(
            "[Number of Frequencies] 1\n[Number of Frequencies] 1\n",
            5,
            &["repeats the keyword of line 4"],
        ),
        // version and option line
        raw(
            "[Version] 2.1\n# Hz S RI\n",
            1,
            1,
            &["`[Version] 2.1`", "2.0"],
        ),
        raw(
            "! c\n[Version] 2.0\n[Number of Ports] 1\n",
            1,
            3,
            &["option line", "must follow `[Version] 2.0`"],
        ),
        one("# GHz S MA\n", 4, &["a second option line"]),
        raw("[Version] 2.0\n# Hz S XY\n", 1, 2, &["unknown field `XY`"]),
        // noise data
        two(
            "[Number of Frequencies] 1\n[Network Data]\n1 0 0 0 0 0 0 0 0\n\
             [Noise Data]\n1 0.5 0.1 10 0.3\n[End]\n",
            8,
            &["without `[Number of Noise Frequencies]`"],
        ),
        two(
            "[Number of Frequencies] 1\n[Number of Noise Frequencies] 1\n\
             [Network Data]\n1 0 0 0 0 0 0 0 0\n[End]\n",
            9,
            &["without the `[Noise Data]`", "(line 6)"],
        ),
        one("[Number of Noise Frequencies] 1\n", 4, &["2 ports only"]),
        one(
            "[Number of Frequencies] 1\n[Network Data] 1 0 0\n[End]\n",
            5,
            &["takes no argument", "`1 0 0`"],
        ),
        // information block
        one("[End Information]\n", 4, &["without `[Begin Information]`"]),
        // a version 1 file in a .ts file
        ts("# Hz S RI\n1 0 0\n", 1, &["[Version] 2.0"]),
    ];
    let mut failures = Vec::new();
    for Bad {
        text,
        ports,
        line,
        needles,
    } in cases
    {
        let (got, message) = error_of(&text, ports);
        if got != line {
            failures.push(format!("{text:?}: line {got}, expected {line}: {message}"));
        }
        for n in needles {
            if !message.contains(n) {
                failures.push(format!("{text:?}: `{n}` missing from: {message}"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Every prefix of a valid version 2 file, and the file with each byte replaced, reads or
/// gives a typed error: no panic.
#[test]
fn damaged_version_2_files_never_panic() {
    let text = rlc_v2("12_21", "Lower");
    let text = &text[..text.len().min(900)];
    for end in 0..text.len() {
        if text.is_char_boundary(end) {
            let _ = parse(&text[..end], 2);
        }
    }
    let bytes = text.as_bytes();
    for (k, b) in [b'[', b']', b'!', b'#', b'\n', b'x', b'-', b' ']
        .iter()
        .enumerate()
    {
        for i in (k..bytes.len()).step_by(7) {
            let mut damaged = bytes.to_vec();
            damaged[i] = *b;
            let _ = parse_touchstone(&damaged[..], 2, "t.s2p");
            let _ = parse_touchstone_v2(&damaged[..], "t.ts");
        }
    }
}

/// `fdid fit` on the version 2.0 file: the poles of the version 1 file.
#[cfg(feature = "cli")]
#[test]
fn cli_fits_the_version_2_file_as_the_version_1_file() {
    use cli::{json_of, run, stderr, stdout};
    let orders = ["--domain", "s", "--na", "2", "--nb", "1"];
    let fit = |file: &str| {
        json_of(&run(
            "fit",
            &bundled(file),
            &[&orders[..], &["--port", "21", "--json"]].concat(),
        ))
    };
    let (v1, v2) = (fit("rlc_bandpass.s2p"), fit("rlc_bandpass.ts"));
    assert_eq!(v1["poles"], v2["poles"]);
    assert_eq!(v1["frf"], v2["frf"]);
    // the text names the version
    let ts = bundled("rlc_bandpass.ts");
    let text = stdout(&run("fit", &ts, &[&orders[..], &["--port", "21"]].concat()));
    assert!(text.contains("Touchstone (version 2.0) S21"), "{text}");
    // --port outside the ports of a .ts file is a usage error
    let o = run("fit", &ts, &[&orders[..], &["--port", "31"]].concat());
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--port 31"));
}
