use super::*;

fn parse(text: &str, ports: usize) -> Result<Touchstone> {
    parse_touchstone(text.as_bytes(), ports, "t")
}

fn line_of(e: FdidError) -> usize {
    match e {
        FdidError::Parse { line, .. } => line,
        e => panic!("not a parse error: {e}"),
    }
}

#[test]
fn formats_convert_to_the_same_complex_value() {
    // 0.5 e^{i 30°}: RI, MA and DB rows of the same value
    let x = Complex::from_polar(0.5, 30f64.to_radians());
    let db = 20.0 * 0.5f64.log10();
    let ri = format!("# Hz S RI\n1 {} {}\n", x.re, x.im);
    let ma = "# hz s ma\n1 0.5 30\n".to_string();
    let dbs = format!("# Hz S DB R 50\n1 {db} 30\n");
    for text in [ri, ma, dbs] {
        let t = parse(&text, 1).unwrap();
        assert_eq!(t.freq_hz, vec![1.0]);
        assert!(
            (t.values[0][0] - x).norm() < 1e-15,
            "{text}: {}",
            t.values[0][0]
        );
    }
}

#[test]
fn two_port_column_order_and_units() {
    let text = "! comment\n# MHz S RI R 75\n 1.5 11 0 21 0 12 0 22 0 ! S11 S21 S12 S22\n\
                2.0 1 1 2 2\n 3 3 4 4\n";
    let t = parse(text, 2).unwrap();
    assert_eq!(t.freq_hz, vec![1.5e6, 2.0e6]);
    assert_eq!(t.reference, 75.0);
    let m = &t.values[0];
    // row-major X11 X12 X21 X22
    assert_eq!(
        m.iter().map(|c| c.re).collect::<Vec<_>>(),
        vec![11.0, 12.0, 21.0, 22.0]
    );
    // a row continued over two lines
    assert_eq!(t.values[1][2], Complex::new(2.0, 2.0));
    let s21 = t.frequency_data::<f64>((2, 1)).unwrap();
    assert_eq!(s21.y()[0], Complex::new(21.0, 0.0));
    assert!((s21.omega()[1] - std::f64::consts::TAU * 2e6).abs() < 1e-6);
    assert!(t.frequency_data::<f64>((3, 1)).is_err());
}

#[test]
fn defaults_are_ghz_s_ma_50_ohm() {
    let t = parse("#\n1 1 90\n", 1).unwrap();
    assert_eq!(t.freq_hz, vec![1e9]);
    assert_eq!(
        (t.parameter, t.format, t.reference),
        (NetworkParameter::S, NumberFormat::MagnitudeAngle, 50.0)
    );
    assert!((t.values[0][0] - Complex::new(0.0, 1.0)).norm() < 1e-15);
}

#[test]
fn impedance_is_denormalised() {
    let t = parse("# Hz Z RI R 50\n1 2 -1\n", 1).unwrap();
    assert_eq!(t.values[0][0], Complex::new(100.0, -50.0));
    let t = parse("# Hz Y RI R 50\n1 2 -1\n", 1).unwrap();
    assert_eq!(t.values[0][0], Complex::new(0.04, -0.02));
}

#[test]
fn noise_parameters_of_a_two_port_are_skipped() {
    let text = "# GHz S MA\n1 1 0 2 0 3 0 4 0\n2 1 0 2 0 3 0 4 0\n1 0.5 0.1 10 0.3\n";
    let t = parse(text, 2).unwrap();
    assert_eq!(t.freq_hz.len(), 2);
}

#[test]
fn malformed_files_name_the_line() {
    let cases: [(&str, usize, usize); 9] = [
        ("# Hz S RI\n1 0 0\n2 x 0\n", 1, 3),
        ("# Hz S RI\n2 0 0\n1 0 0\n", 1, 3),
        ("# Hz S RI\n-1 0 0\n", 1, 2),
        ("! c\n# Hz Q RI\n1 0 0\n", 1, 2),
        ("# Hz S RI R\n1 0 0\n", 1, 1),
        ("# Hz S RI R -5\n1 0 0\n", 1, 1),
        ("# Hz Hz S\n1 0 0\n", 1, 1),
        ("[Version] 2.0\n# Hz S RI\n", 2, 2),
        ("# Hz S RI\n1 0 0 0 0 0 0 0 0\n2 1 1 1\n", 2, 3),
    ];
    // an option line after the data
    assert_eq!(line_of(parse("1 0 0\n# Hz S RI\n", 1).unwrap_err()), 2);
    // a second option line is ignored
    let t = parse("# Hz S RI\n1 0 0\n# GHz S MA\n2 0 0\n", 1).unwrap();
    assert_eq!(t.freq_hz, vec![1.0, 2.0]);
    for (text, ports, line) in cases {
        let e = parse(text, ports).unwrap_err();
        let msg = e.to_string();
        assert_eq!(line_of(e), line, "{text:?}: {msg}");
    }
    assert_eq!(
        line_of(parse("! only a comment\n# Hz S RI\n", 1).unwrap_err()),
        0
    );
    assert!(
        parse("# Hz S RI\n1 nan 0\n", 1)
            .unwrap_err()
            .to_string()
            .contains("not finite")
    );
    assert!(parse("# Hz S RI\n1 0 0\n", 3).is_err());
    let v2 = parse("[Version] 2.0\n", 2).unwrap_err().to_string();
    assert!(v2.contains("option line") && v2.contains("line 1"), "{v2}");
    // a keyword in a version 1 file
    let v1 = parse("# Hz S RI\n[Number of Ports] 1\n1 0 0\n", 1).unwrap_err();
    assert!(v1.to_string().contains("[Number of Ports]"), "{v1}");
    assert_eq!(line_of(v1), 2);
}
