//! One case per bad-input kind per public entry point: the specific `FdidError` variant,
//! and a message that names the offending value (the NaN's index, the duplicate
//! frequency, the sample time given, the order, …).

use fdid::data::PeriodicAverage;
use fdid::io::parse_csv;
use fdid::ltv::{Lines, LtvOde};
use fdid::model::{Domain, NoiseModel};
use fdid::prelude::*;
use fdid::workflow::{Context, ModelSpec, Workflow, fit_spec};
use std::fmt::Debug;

fn c(re: f64, im: f64) -> Complex<f64> {
    Complex::new(re, im)
}

/// `r` is an error matching `variant` whose message contains every one of `names`.
fn check<T: Debug>(
    case: &str,
    r: fdid::Result<T>,
    variant: fn(&FdidError) -> bool,
    names: &[&str],
) {
    let e = match r {
        Ok(v) => panic!("{case}: expected an error, got Ok({v:?})"),
        Err(e) => e,
    };
    assert!(variant(&e), "{case}: wrong variant {e:?}");
    let msg = e.to_string();
    for n in names {
        assert!(
            msg.contains(n),
            "{case}: message `{msg}` does not name `{n}`"
        );
    }
}

macro_rules! is {
    ($p:pat) => {
        |e: &FdidError| matches!(e, $p)
    };
}

/// 20 noise-free lines of G(z) = 0.5 z⁻¹/(1 − 0.5 z⁻¹), Ts = 1.
fn dt_data() -> FrequencyData<f64> {
    let omega: Vec<f64> = (1..=20).map(|k| 0.15 * f64::from(k)).collect();
    let frf = omega
        .iter()
        .map(|w| {
            let zi = c(0.0, -w).exp();
            zi * 0.5 / (c(1.0, 0.0) - zi * 0.5)
        })
        .collect();
    FrequencyData::from_frf(omega, frf, Some(1.0)).unwrap()
}

fn ones(n: usize) -> Vec<Complex<f64>> {
    vec![c(1.0, 0.0); n]
}

// ---------------------------------------------------------------------------------------
// FrequencyData

#[test]
fn frequency_data_rejects_each_bad_input() {
    let w = vec![0.5, 1.0, 1.5, 2.0];
    check(
        "NaN frequency",
        FrequencyData::from_frf(vec![0.5, 1.0, f64::NAN, 2.0], ones(4), None),
        is!(FdidError::NonFinite {
            what: "omega",
            index: 2,
            ..
        }),
        &["omega[2]", "NaN"],
    );
    check(
        "infinite frequency",
        FrequencyData::from_frf(vec![0.5, f64::INFINITY], ones(2), None),
        is!(FdidError::NonFinite {
            what: "omega",
            index: 1,
            ..
        }),
        &["omega[1]", "inf"],
    );
    let mut y = ones(4);
    y[3] = c(1.0, f64::NEG_INFINITY);
    check(
        "infinite output",
        FrequencyData::new(w.clone(), y, ones(4), None),
        is!(FdidError::NonFinite {
            what: "y",
            index: 3,
            ..
        }),
        &["y[3]", "inf"],
    );
    let mut u = ones(4);
    u[1] = c(f64::NAN, 0.0);
    check(
        "NaN input",
        FrequencyData::new(w.clone(), ones(4), u, None),
        is!(FdidError::NonFinite {
            what: "u",
            index: 1,
            ..
        }),
        &["u[1]", "NaN"],
    );
    check(
        "no line",
        FrequencyData::<f64>::from_frf(vec![], vec![], None),
        is!(FdidError::TooShort {
            needed: 1,
            got: 0,
            ..
        }),
        &["0 given"],
    );
    check(
        "length mismatch",
        FrequencyData::from_frf(w.clone(), ones(3), None),
        is!(FdidError::LengthMismatch {
            expected: 4,
            got: 3,
            ..
        }),
        &["3 entries", "expected 4"],
    );
    check(
        "unsorted",
        FrequencyData::from_frf(vec![0.5, 1.5, 1.25], ones(3), None),
        is!(FdidError::Unsorted { index: 2, .. }),
        &["1.25", "1.5"],
    );
    check(
        "negative frequency",
        FrequencyData::from_frf(vec![-0.75, 1.0], ones(2), None),
        is!(FdidError::NegativeFrequency { index: 0, .. }),
        &["-0.75"],
    );
    for ts in [0.0, -0.25, f64::NAN, f64::INFINITY] {
        check(
            "bad Ts",
            FrequencyData::from_frf(w.clone(), ones(4), Some(ts)),
            is!(FdidError::InvalidArgument { name: "ts", .. }),
            &[&format!("ts = {ts}")],
        );
        check(
            "bad Ts (with_ts)",
            dt_data().with_ts(Some(ts)),
            is!(FdidError::InvalidArgument { name: "ts", .. }),
            &[&format!("ts = {ts}")],
        );
    }
    let d = FrequencyData::from_frf(w.clone(), ones(4), None).unwrap();
    check(
        "NaN variance",
        d.clone()
            .with_noise(NoiseVariances::output_only(vec![1.0, 1.0, f64::NAN, 1.0])),
        is!(FdidError::NonFinite {
            what: "var_y",
            index: 2,
            ..
        }),
        &["var_y[2]", "NaN"],
    );
    check(
        "negative variance",
        d.clone()
            .with_noise(NoiseVariances::output_only(vec![1.0, -0.125, 1.0, 1.0])),
        is!(FdidError::InvalidArgument { name: "var_y", .. }),
        &["-0.125 at entry 1"],
    );
    check(
        "variance length",
        d.clone().with_noise(NoiseVariances::output_only(vec![1.0])),
        is!(FdidError::LengthMismatch {
            what: "var_y",
            expected: 4,
            got: 1
        }),
        &["var_y has 1"],
    );
    check(
        "zero input (ETFE)",
        FrequencyData::new(
            w.clone(),
            ones(4),
            vec![c(1.0, 0.0), c(0.0, 0.0), c(1.0, 0.0), c(1.0, 0.0)],
            None,
        )
        .unwrap()
        .etfe(),
        is!(FdidError::ZeroInput { index: 1, .. }),
        &["entry 1", "at 0.1591549 Hz"],
    );
    check(
        "empty selection",
        d.select_lines(&[false; 4]),
        is!(FdidError::TooShort { got: 0, .. }),
        &["selected frequency lines"],
    );
}

#[test]
fn bands_reject_bad_and_empty_edges() {
    let d = dt_data();
    check(
        "NaN band edge",
        d.band(f64::NAN, 1.0),
        is!(FdidError::InvalidArgument { name: "band", .. }),
        &["[NaN, 1]"],
    );
    check(
        "reversed band",
        d.band(2.0, 1.0),
        is!(FdidError::InvalidArgument { name: "band", .. }),
        &["[2, 1]"],
    );
    // above every line (here: above the Nyquist frequency π rad/s of Ts = 1)
    check(
        "band above the data",
        d.band(4.0, 5.0),
        is!(FdidError::EmptyBand { .. }),
        &["4 .. 5 rad/s", "0.6366198 .. 0.7957747 Hz"],
    );
    check(
        "band in Hz above the data",
        d.band_hz(10.0, 20.0),
        is!(FdidError::EmptyBand { .. }),
        &["selects no frequency lines"],
    );
}

// ---------------------------------------------------------------------------------------
// TimeData, DFT and periodic averaging

#[test]
fn time_data_rejects_each_bad_input() {
    let u = vec![1.0, -1.0, 0.5, 0.25];
    check(
        "NaN sample",
        TimeData::new(vec![1.0, f64::NAN, 0.0, 0.0], u.clone(), 1.0),
        is!(FdidError::NonFinite {
            what: "u",
            index: 1,
            ..
        }),
        &["u[1]", "NaN"],
    );
    check(
        "infinite output sample",
        TimeData::new(u.clone(), vec![0.0, 0.0, 0.0, f64::INFINITY], 1.0),
        is!(FdidError::NonFinite {
            what: "y",
            index: 3,
            ..
        }),
        &["y[3]", "inf"],
    );
    check(
        "empty record",
        TimeData::<f64>::new(vec![], vec![], 1.0),
        is!(FdidError::TooShort {
            needed: 2,
            got: 0,
            ..
        }),
        &["0 given"],
    );
    check(
        "single sample",
        TimeData::new(vec![1.0], vec![1.0], 1.0),
        is!(FdidError::TooShort {
            needed: 2,
            got: 1,
            ..
        }),
        &["1 given"],
    );
    check(
        "length mismatch",
        TimeData::new(u.clone(), vec![1.0; 3], 1.0),
        is!(FdidError::LengthMismatch {
            expected: 4,
            got: 3,
            ..
        }),
        &["3 entries"],
    );
    for ts in [0.0, -2.5, f64::NAN, f64::INFINITY, 1e-310] {
        check(
            "bad Ts",
            TimeData::new(u.clone(), u.clone(), ts),
            is!(FdidError::InvalidArgument { name: "ts", .. }),
            &[&format!("ts = {ts}")],
        );
    }
    check(
        "samples overflowing the DFT",
        TimeData::new(vec![1e308, 1e308, 0.0, 0.0], u.clone(), 1.0),
        is!(FdidError::InvalidArgument { name: "u", .. }),
        &["sum of |u| = inf"],
    );
    let t = TimeData::new(vec![1.0; 12], vec![0.5; 12], 0.1).unwrap();
    check(
        "zero periods",
        t.average_periods(0),
        is!(FdidError::InvalidArgument {
            name: "periods",
            ..
        }),
        &["periods = 0"],
    );
    check(
        "periods not dividing N",
        t.average_periods(5),
        is!(FdidError::InvalidArgument {
            name: "periods",
            ..
        }),
        &["periods = 5", "N = 12"],
    );
    check(
        "huge number of periods",
        PeriodicAverage::new(&t, usize::MAX),
        is!(FdidError::InvalidArgument {
            name: "periods",
            ..
        }),
        &[&format!("periods = {}", usize::MAX)],
    );
    check(
        "one sample per period",
        t.average_periods(12),
        is!(FdidError::TooShort {
            needed: 2,
            got: 1,
            ..
        }),
        &["samples per period"],
    );
}

// ---------------------------------------------------------------------------------------
// Models

#[test]
fn model_constructors_reject_each_bad_input() {
    check(
        "NaN grid",
        Rational::continuous(2, 1, &[0.5, f64::NAN]),
        is!(FdidError::NonFinite {
            what: "omega",
            index: 1,
            ..
        }),
        &["omega[1]"],
    );
    check(
        "no positive frequency",
        Rational::continuous(2, 1, &[0.0, 0.0, 0.0]),
        is!(FdidError::InvalidArgument { name: "omega", .. }),
        &["max 0"],
    );
    check(
        "order too high for the grid (partial fractions)",
        Rational::continuous(8, 7, &[0.5, 1.0, 1.5]),
        is!(FdidError::TooFewFrequencies {
            lines: 3,
            equations: 6,
            parameters: 16
        }),
        &["3 lines", "16 parameters"],
    );
    check(
        "order too high for the grid (polynomial)",
        Rational::<f64>::polynomial(1, 9, &[0.5, 1.0, 1.5]),
        is!(FdidError::TooFewFrequencies {
            lines: 3,
            parameters: 10,
            ..
        }),
        &["10 parameters"],
    );
    check(
        "huge continuous order",
        Rational::continuous(usize::MAX, 0, &[0.5, 1.0]),
        is!(FdidError::InvalidArgument { name: "na", .. }),
        &[&usize::MAX.to_string()],
    );
    check(
        "huge discrete order",
        Rational::<f64>::discrete(1, usize::MAX / 2, 1.0),
        is!(FdidError::InvalidArgument { name: "nb", .. }),
        &[&(usize::MAX / 2).to_string()],
    );
    for ts in [0.0, -1.0, f64::NAN, f64::NEG_INFINITY] {
        check(
            "discrete model, bad Ts",
            Rational::discrete(1, 0, ts),
            is!(FdidError::InvalidArgument { name: "ts", .. }),
            &[&format!("ts = {ts}")],
        );
        check(
            "sampled transient, bad Ts",
            Rational::continuous(2, 1, &[0.5, 1.0, 2.0]).and_then(|m| m.with_sampled_transient(ts)),
            is!(FdidError::InvalidArgument { name: "ts", .. }),
            &[&format!("ts = {ts}")],
        );
        check(
            "noise model, bad Ts",
            NoiseModel::new(1, 1, ts),
            is!(FdidError::InvalidArgument { name: "ts", .. }),
            &[&format!("{ts}")],
        );
        check(
            "ZOH modal model, bad Ts",
            Modal::new(1, 1, false, Domain::Discrete { ts }),
            is!(FdidError::InvalidArgument { name: "ts", .. }),
            &[&format!("{ts}")],
        );
    }
    check(
        "huge modal order",
        Modal::<f64>::continuous(1, usize::MAX / 2, false),
        is!(FdidError::InvalidArgument {
            name: "n_real + 2 n_pairs",
            ..
        }),
        &[&format!("1 + 2·{}", usize::MAX / 2)],
    );
    check(
        "modal model without a pole",
        Modal::<f64>::continuous(0, 0, true),
        is!(FdidError::InvalidArgument {
            name: "n_real + n_pairs",
            ..
        }),
        &["= 0"],
    );
    check(
        "delay bounds NaN",
        Delayed::new(Rational::<f64>::discrete(1, 0, 1.0).unwrap()).with_bounds(f64::NAN, 1.0),
        is!(FdidError::InvalidArgument { .. }),
        &["NaN"],
    );
}

// ---------------------------------------------------------------------------------------
// Fits

#[test]
fn fits_reject_orders_too_high_for_the_data() {
    let d = dt_data().band(0.0, 0.5).unwrap(); // 3 lines = 6 real equations
    assert_eq!(d.len(), 3);
    let model = Rational::discrete(4, 4, 1.0).unwrap();
    let too_few = is!(FdidError::TooFewFrequencies {
        lines: 3,
        equations: 6,
        parameters: 9
    });
    let names = &["3 lines", "6 real equations", "9 parameters"];
    check(
        "Pipeline::fit",
        Pipeline::default().fit(&model, &d),
        too_few,
        names,
    );
    check(
        "fit_delayed",
        fit_delayed(&Pipeline::default(), &model, &d),
        too_few,
        names,
    );
    let noisy = d
        .clone()
        .without_noise()
        .with_noise(NoiseVariances {
            var_y: vec![0.01; 3],
            var_u: vec![0.01; 3],
            cov_yu: vec![c(0.0, 0.0); 3],
        })
        .unwrap();
    check(
        "fit_eiv",
        fit_eiv(&Pipeline::default(), &model, &noisy),
        too_few,
        names,
    );
    check(
        "fit_noise_model",
        fit_noise_model(
            &Pipeline::default(),
            &Rational::discrete(1, 0, 1.0).unwrap(),
            &d,
            3,
            3,
        ),
        is!(FdidError::TooFewFrequencies {
            lines: 3,
            parameters: 7,
            ..
        }),
        &["7 parameters"],
    );
    check(
        "fit_modal",
        fit_modal(&Pipeline::default(), &d, 2, 2, ModalOptions::continuous()),
        is!(FdidError::TooFewFrequencies { lines: 3, .. }),
        &["3 lines"],
    );
    check(
        "fit_spec",
        fit_spec(&ModelSpec::discrete(4, 4, 1.0), &d),
        too_few,
        names,
    );
}

#[test]
fn fits_reject_zero_input_on_the_lines_used() {
    let d = dt_data();
    let mut u = d.u().to_vec();
    u[4] = c(0.0, 0.0);
    let zero = FrequencyData::new(d.omega().to_vec(), d.y().to_vec(), u, Some(1.0))
        .unwrap()
        .with_noise(NoiseVariances {
            var_y: vec![0.01; 20],
            var_u: vec![0.01; 20],
            cov_yu: vec![c(0.0, 0.0); 20],
        })
        .unwrap();
    let model = Rational::discrete(1, 0, 1.0).unwrap();
    check(
        "fit_eiv",
        fit_eiv(&Pipeline::default(), &model, &zero),
        is!(FdidError::ZeroInput { index: 4, .. }),
        &["entry 4", "at 0.1193662 Hz"],
    );
    check(
        "lpm",
        lpm(&zero.without_noise(), Lpm::new()),
        is!(FdidError::ZeroInput { .. }),
        &["the input spectrum is zero"],
    );
}

#[test]
fn noise_model_needs_a_sample_time() {
    let d = dt_data().with_ts(None).unwrap();
    check(
        "fit_noise_model without Ts",
        fit_noise_model(
            &Pipeline::default(),
            &Rational::discrete(1, 0, 1.0).unwrap(),
            &d,
            1,
            1,
        ),
        is!(FdidError::InvalidArgument { name: "ts", .. }),
        &["ts = none"],
    );
    check(
        "fit_eiv without noise variances",
        fit_eiv(
            &Pipeline::default(),
            &Rational::discrete(1, 0, 1.0).unwrap(),
            &d,
        ),
        is!(FdidError::InvalidArgument { name: "noise", .. }),
        &["noise"],
    );
}

#[test]
fn lpm_rejects_bad_settings_and_grids() {
    let d = dt_data();
    check(
        "window too small",
        lpm(&d, Lpm::new().with_degree(3).with_half_width(2)),
        is!(FdidError::InvalidArgument {
            name: "half_width",
            ..
        }),
        &["half_width = 2", "R = 3"],
    );
    check(
        "zero half-width",
        lpm(&d, Lpm::new().with_half_width(0)),
        is!(FdidError::InvalidArgument {
            name: "half_width",
            ..
        }),
        &["half_width = 0"],
    );
    check(
        "huge degree",
        lpm(&d, Lpm::new().with_degree(usize::MAX)),
        is!(FdidError::InvalidArgument { name: "degree", .. }),
        &[&usize::MAX.to_string()],
    );
    check(
        "too few lines",
        lpm(&d.band(0.0, 1.0).unwrap(), Lpm::new()),
        is!(FdidError::TooShort {
            got: 6,
            needed: 11,
            ..
        }),
        &["6 given", "11 needed"],
    );
    // a duplicated frequency is not a uniform DFT grid
    let mut w = d.omega().to_vec();
    w[7] = w[6];
    let dup = FrequencyData::from_frf(w, d.y().to_vec(), Some(1.0)).unwrap();
    check(
        "duplicate frequency",
        lpm(&dup, Lpm::new()),
        is!(FdidError::InvalidArgument { name: "omega", .. }),
        &["step 0 rad/s from line 6 to line 7"],
    );
}

// ---------------------------------------------------------------------------------------
// The time-varying ODE

#[test]
fn ltv_rejects_bands_outside_nyquist_and_bad_lines() {
    let n = 64;
    let u: Vec<f64> = (0..n).map(|t| (0.3 * f64::from(t)).sin()).collect();
    let y: Vec<f64> = (0..n).map(|t| (0.3 * f64::from(t) + 0.2).sin()).collect();
    let t = TimeData::new(u, y, 0.5).unwrap(); // Nyquist 1 Hz
    let model = LtvOde::new(1, 0, 0);
    check(
        "band above Nyquist",
        model.fit(&t, &Lines::band(0.1, 1.5)),
        is!(FdidError::InvalidArgument { name: "band", .. }),
        &["[0.1, 1.5] Hz", "Nyquist frequency 1 Hz"],
    );
    check(
        "negative band edge",
        model.fit(&t, &Lines::band(-0.5, 0.5)),
        is!(FdidError::InvalidArgument { name: "band", .. }),
        &["[-0.5, 0.5] Hz"],
    );
    check(
        "NaN band edge",
        model.fit(&t, &Lines::band(0.0, f64::NAN)),
        is!(FdidError::InvalidArgument { name: "band", .. }),
        &["NaN"],
    );
    check(
        "band between two lines",
        model.fit(&t, &Lines::band(0.0101, 0.0102)),
        is!(FdidError::EmptyBand { .. }),
        &["selects no frequency lines"],
    );
    check(
        "line index above N/2",
        model.fit(&t, &Lines::Indices(vec![1, 2, 40])),
        is!(FdidError::InvalidArgument {
            name: "line index",
            ..
        }),
        &["40 at entry 2", "N/2 = 32"],
    );
    check(
        "duplicate line index",
        model.fit(&t, &Lines::Indices(vec![1, 2, 2])),
        is!(FdidError::InvalidArgument {
            name: "line index",
            ..
        }),
        &["2 at entry 2"],
    );
    check(
        "no line index",
        model.fit(&t, &Lines::Indices(vec![])),
        is!(FdidError::TooShort { got: 0, .. }),
        &["line indices"],
    );
}

// ---------------------------------------------------------------------------------------
// The workflow and the CSV readers

#[test]
fn workflow_rejects_bad_levels_and_sample_times() {
    let d = dt_data();
    for alpha in [0.0, 1.0, -0.5, f64::NAN] {
        check(
            "alpha",
            Workflow::default().run(
                &d,
                ModelSpec::discrete(1, 0, 1.0),
                Context::frequency_data(alpha),
            ),
            is!(FdidError::InvalidArgument { name: "alpha", .. }),
            &[&format!("alpha = {alpha}")],
        );
    }
    let spec = ModelSpec {
        domain: Domain::Discrete { ts: -0.5 },
        ..ModelSpec::discrete(1, 0, 1.0)
    };
    check(
        "spec Ts",
        Workflow::default().run(&d, spec, Context::frequency_data(0.05)),
        is!(FdidError::InvalidArgument { name: "ts", .. }),
        &["ts = -0.5"],
    );
}

fn csv(text: &str) -> fdid::Result<fdid::io::Measurement<f64>> {
    parse_csv(text.as_bytes(), "test.csv")
}

#[test]
fn csv_reader_rejects_each_bad_input() {
    let parse = is!(FdidError::Parse { .. });
    check(
        "empty file",
        csv(""),
        parse,
        &["test.csv", "line 0", "empty file"],
    );
    check(
        "no data rows",
        csv("f,re,im\n"),
        is!(FdidError::TooShort { got: 0, .. }),
        &["0 given"],
    );
    check(
        "NaN field",
        csv("f,re,im\n1,2,3\n2,nan,3\n"),
        parse,
        &["line 3", "`re`", "nan"],
    );
    check(
        "infinite field",
        csv("f,re,im\n1,inf,3\n"),
        parse,
        &["line 2", "inf"],
    );
    check(
        "not a number",
        csv("f,re,im\n1,abc,3\n"),
        parse,
        &["line 2", "`abc`"],
    );
    check(
        "out of range for f32",
        parse_csv::<f32, _>("f,re,im\n1,1e39,3\n".as_bytes(), "test.csv"),
        parse,
        &["line 2", "1e39"],
    );
    check(
        "duplicate frequency",
        csv("f,re,im\n1,2,3\n1.5,2,3\n1.5,2,3\n"),
        parse,
        &["line 4", "duplicate frequency 1.5 Hz"],
    );
    check(
        "unsorted frequencies",
        csv("f,re,im\n1,2,3\n3,2,3\n2,2,3\n"),
        parse,
        &["line 4", "2 Hz is below the previous row's 3 Hz"],
    );
    check(
        "negative frequency",
        csv("f,re,im\n-1,2,3\n"),
        parse,
        &["line 2", "-1 Hz"],
    );
    check(
        "negative variance",
        csv("f,re,im,var\n1,2,3,-0.5\n"),
        parse,
        &["line 2", "-0.5"],
    );
    check(
        "single time sample",
        csv("t,u,y\n0,1,2\n"),
        is!(FdidError::TooShort { got: 1, .. }),
        &["1 given"],
    );
    check(
        "non-increasing time",
        csv("t,u,y\n0,1,2\n1,1,2\n1,1,2\n"),
        parse,
        &["line 4", "time 1 does not increase"],
    );
    check(
        "non-uniform time",
        csv("t,u,y\n0,1,2\n1,1,2\n3,1,2\n"),
        parse,
        &["non-uniform sampling"],
    );
    check(
        "wrong field count",
        csv("f,re,im\n1,2\n"),
        parse,
        &["line 2", "expected 3 fields"],
    );
    check(
        "invalid UTF-8",
        parse_csv::<f64, _>(&b"f,re,im\n1,\xff,3\n"[..], "test.csv"),
        parse,
        &["line 2", "UTF-8"],
    );
    check(
        "missing file",
        fdid::io::read_csv::<f64>(std::path::Path::new("/nonexistent/fdid.csv")),
        is!(FdidError::Io(_)),
        &["/nonexistent/fdid.csv"],
    );
}

#[test]
fn fits_of_data_whose_squares_overflow_give_the_poles_of_the_unscaled_data() {
    // finite values whose squares overflow: the fits normalise the data by a power of two
    // (they returned a numerical error before normalisation)
    let base = dt_data();
    let huge: Vec<Complex<f64>> = base.y().iter().map(|g| g * 1e308).collect();
    let data = FrequencyData::from_frf(base.omega().to_vec(), huge, Some(1.0)).unwrap();
    let model = Rational::discrete(1, 1, 1.0).unwrap();
    for (name, pipeline) in [
        ("levy", Pipeline::levy()),
        ("sk", Pipeline::sk()),
        ("ml", Pipeline::default()),
    ] {
        let plain = pipeline.fit(&model, &base).unwrap().poles().unwrap();
        let fit = pipeline.fit(&model, &data).unwrap();
        let poles = fit.poles().unwrap();
        assert!(
            (poles[0] - plain[0]).norm() < 1e-9 * plain[0].norm(),
            "{name}: {poles:?} vs {plain:?}"
        );
        assert!(fit.gain().is_finite(), "{name}: gain {}", fit.gain());
    }
}
