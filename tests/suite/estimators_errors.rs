//! Bad inputs to the estimator API return the right `FdidError` variant and never panic.

use fdid::prelude::*;
use quickcheck::{Arbitrary, Gen, TestResult};
use std::sync::atomic::{AtomicUsize, Ordering};

fn c(re: f64, im: f64) -> Complex<f64> {
    Complex::new(re, im)
}

/// Noise-free FRF data of G(s) = 1/(s² + 0.4 s + 1) on `omega`.
fn ct_data(omega: &[f64]) -> FrequencyData<f64> {
    let frf = omega
        .iter()
        .map(|w| {
            let s = c(0.0, *w);
            c(1.0, 0.0) / (s * s + s * 0.4 + 1.0)
        })
        .collect();
    FrequencyData::from_frf(omega.to_vec(), frf, None).unwrap()
}

/// Noise-free FRF data of G(z) = 0.5 z⁻¹ / (1 − 0.5 z⁻¹) on `omega`, sample time `ts`.
fn dt_data(omega: &[f64], ts: f64, data_ts: Option<f64>) -> FrequencyData<f64> {
    let frf = omega
        .iter()
        .map(|w| {
            let zi = c(0.0, -w * ts).exp();
            zi * 0.5 / (c(1.0, 0.0) - zi * 0.5)
        })
        .collect();
    FrequencyData::from_frf(omega.to_vec(), frf, data_ts).unwrap()
}

fn grid(n: usize, lo: f64, hi: f64) -> Vec<f64> {
    (0..n)
        .map(|k| lo + (hi - lo) * k as f64 / (n - 1).max(1) as f64)
        .collect()
}

/// Every estimator (Levy, SK, TLS, ML from a start of the right length, the pipeline)
/// returns an error satisfying `expected` on `data` with `model`.
fn all_estimators_fail(
    model: &Rational<f64>,
    data: &FrequencyData<f64>,
    expected: impl Fn(&FdidError) -> bool,
    what: &str,
) {
    let start = vec![0.1; model.n_params()];
    let results: Vec<(&str, fdid::Result<Vec<f64>>)> = vec![
        (
            "levy",
            estimate(
                model,
                data,
                &Levy::default(),
                &LinearLeastSquares::default(),
                None,
            )
            .map(|s| s.theta),
        ),
        (
            "sk",
            estimate(
                model,
                data,
                &SanathananKoerner::default(),
                &FixedPoint::default(),
                None,
            )
            .map(|s| s.theta),
        ),
        (
            "tls",
            estimate(
                model,
                data,
                &TotalLeastSquares::default(),
                &SvdNullVector,
                None,
            )
            .map(|s| s.theta),
        ),
        (
            "ml",
            estimate(
                model,
                data,
                &MaximumLikelihood::default(),
                &LevenbergMarquardt::default(),
                Some(&start),
            )
            .map(|s| s.theta),
        ),
        (
            "pipeline",
            Pipeline::default()
                .fit(model, data)
                .map(|f| f.theta().to_vec()),
        ),
        (
            "fit",
            Fit::new(
                model.clone(),
                data,
                start.clone(),
                NoiseWeighting::Auto,
                vec![],
            )
            .map(|f| f.theta().to_vec()),
        ),
    ];
    for (name, r) in results {
        match r {
            Err(e) if expected(&e) => {}
            other => panic!("{what}: {name} returned {other:?}"),
        }
    }
}

#[test]
fn too_few_frequencies() {
    // CT: 3 lines = 6 real equations for 9 parameters
    let data = ct_data(&[0.5, 1.0, 2.0]);
    let model = Rational::continuous(4, 4, data.omega()).unwrap();
    all_estimators_fail(
        &model,
        &data,
        |e| {
            *e == FdidError::TooFewFrequencies {
                lines: 3,
                equations: 6,
                parameters: 9,
            }
        },
        "CT 4/4 on 3 lines",
    );
    // DT: 3 lines for 7 parameters
    let data = dt_data(&[0.5, 1.0, 2.0], 0.1, Some(0.1));
    let model = Rational::discrete(3, 3, 0.1).unwrap();
    all_estimators_fail(
        &model,
        &data,
        |e| {
            *e == FdidError::TooFewFrequencies {
                lines: 3,
                equations: 6,
                parameters: 7,
            }
        },
        "DT 3/3 on 3 lines",
    );
    // the polynomial CT basis itself cannot be built: one line (points ±1) spans degree ≤ 1
    assert!(matches!(
        Rational::polynomial(2, 0, &[1.0]),
        Err(FdidError::TooFewFrequencies { .. })
    ));
    // the partial-fraction form builds (its basis does not depend on the grid) and the fit
    // reports the shortage
    let one_line = FrequencyData::from_frf(vec![1.0], vec![Complex::new(1.0, 0.5)], None).unwrap();
    let pf = Rational::continuous(2, 0, one_line.omega()).unwrap();
    assert!(matches!(
        Pipeline::default().fit(&pf, &one_line),
        Err(FdidError::TooFewFrequencies {
            lines: 1,
            equations: 2,
            parameters: 3
        })
    ));
}

/// With exactly as many real equations as parameters (2N = p) the data are accepted, the
/// noise-free model is interpolated, and no covariance is reported (no degrees of
/// freedom).
#[test]
fn as_many_equations_as_parameters_is_accepted() {
    let data = ct_data(&[0.5, 1.0]);
    let model = Rational::continuous(2, 1, data.omega()).unwrap(); // p = 4 = 2N
    let fit = Pipeline::default().fit(&model, &data).unwrap();
    assert!(fit.cost() < 1e-20, "cost {:e}", fit.cost());
    assert!(fit.covariance().is_none());
}

#[test]
fn zero_input_line() {
    let omega = grid(20, 0.1, 3.0);
    let d = ct_data(&omega);
    let mut u = d.u().to_vec();
    u[5] = c(0.0, 0.0);
    let data = FrequencyData::new(omega.clone(), d.y().to_vec(), u, None).unwrap();
    let model = Rational::continuous(2, 0, data.omega()).unwrap();
    all_estimators_fail(
        &model,
        &data,
        |e| {
            *e == FdidError::ZeroInput {
                index: 5,
                omega: omega[5],
            }
        },
        "U[5] = 0",
    );
}

#[test]
fn dt_model_with_data_above_nyquist() {
    let ts = 0.1; // Nyquist π/Ts = 31.4 rad/s
    let omega = grid(30, 1.0, 40.0);
    let is_omega_error =
        |e: &FdidError| matches!(e, FdidError::InvalidArgument { name: "omega", .. });
    for data_ts in [None, Some(ts)] {
        let data = dt_data(&omega, ts, data_ts);
        let model = Rational::discrete(1, 1, ts).unwrap();
        all_estimators_fail(&model, &data, is_omega_error, "above Nyquist");
    }
    // exactly at Nyquist is fine
    let data = dt_data(&grid(30, 1.0, std::f64::consts::PI / ts), ts, Some(ts));
    let model = Rational::discrete(1, 1, ts).unwrap();
    let fit = Pipeline::default().fit(&model, &data).unwrap();
    assert!(fit.cost() < 1e-20);
}

#[test]
fn dt_model_with_different_sample_time() {
    let data = dt_data(&grid(30, 0.5, 10.0), 0.1, Some(0.1));
    let model = Rational::discrete(1, 1, 0.2).unwrap();
    all_estimators_fail(
        &model,
        &data,
        |e| matches!(e, FdidError::InvalidArgument { name: "ts", .. }),
        "ts 0.1 data, 0.2 model",
    );
}

#[test]
fn discrete_model_rejects_bad_sample_time() {
    for ts in [0.0, -0.0, -1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        match Rational::discrete(2, 1, ts) {
            Err(FdidError::InvalidArgument { name: "ts", .. }) => {}
            other => panic!("ts = {ts}: {other:?}"),
        }
    }
    for ts in [0.0f32, -1.0, f32::NAN, f32::INFINITY] {
        match Rational::discrete(2, 1, ts) {
            Err(FdidError::InvalidArgument { name: "ts", .. }) => {}
            other => panic!("f32 ts = {ts}: {other:?}"),
        }
    }
}

#[test]
fn continuous_model_needs_a_positive_frequency() {
    for omega in [vec![0.0], vec![0.0, 0.0, 0.0], vec![]] {
        match Rational::continuous(1, 0, &omega) {
            Err(FdidError::InvalidArgument { name: "omega", .. }) => {}
            other => panic!("omega = {omega:?}: {other:?}"),
        }
    }
    match Rational::continuous(1, 0, &[1.0, f64::NAN]) {
        Err(FdidError::NonFinite {
            what: "omega",
            index: 1,
            ..
        }) => {}
        other => panic!("NaN omega: {other:?}"),
    }
}

#[test]
fn zero_noise_variance_with_auto_weighting() {
    let omega = grid(20, 0.1, 3.0);
    let mut var = vec![1e-4; omega.len()];
    var[3] = 0.0;
    let data = ct_data(&omega)
        .with_noise(NoiseVariances::output_only(var))
        .unwrap();
    let model = Rational::continuous(2, 0, data.omega()).unwrap();
    all_estimators_fail(
        &model,
        &data,
        |e| matches!(e, FdidError::InvalidArgument { name: "var_y", .. }),
        "var_y[3] = 0",
    );
    // flat weighting ignores the variances
    let fit = Pipeline {
        weighting: NoiseWeighting::Flat,
        ..Pipeline::default()
    }
    .fit(&model, &data)
    .unwrap();
    assert!(fit.cost() < 1e-20);
    assert!(!fit.noise_known());
}

#[test]
fn levenberg_marquardt_needs_a_valid_start() {
    let data = ct_data(&grid(20, 0.1, 3.0));
    let model = Rational::continuous(2, 0, data.omega()).unwrap();
    let ml = MaximumLikelihood::default();
    let lm = LevenbergMarquardt::default();
    match estimate(&model, &data, &ml, &lm, None) {
        Err(FdidError::InvalidArgument { name: "start", .. }) => {}
        other => panic!("no start: {other:?}"),
    }
    match estimate(&model, &data, &ml, &lm, Some(&[0.1, 0.2])) {
        Err(FdidError::LengthMismatch {
            what: "start",
            expected: 3,
            got: 2,
        }) => {}
        other => panic!("short start: {other:?}"),
    }
    match estimate(&model, &data, &ml, &lm, Some(&[0.1, f64::NAN, 0.2])) {
        Err(FdidError::NonFinite {
            what: "start",
            index: 1,
            ..
        }) => {}
        other => panic!("NaN start: {other:?}"),
    }
}

#[test]
fn levenberg_marquardt_rejects_bad_tolerances() {
    let data = ct_data(&grid(20, 0.1, 3.0));
    let model = Rational::continuous(2, 0, data.omega()).unwrap();
    let ml = MaximumLikelihood::default();
    let start = [0.1, 0.2, 0.3];
    for (lm, name) in [
        (
            LevenbergMarquardt {
                tolerance: Some(0.0),
                ..LevenbergMarquardt::default()
            },
            "tolerance",
        ),
        (
            LevenbergMarquardt {
                cost_tolerance: Some(-1.0),
                ..LevenbergMarquardt::default()
            },
            "cost_tolerance",
        ),
        (
            LevenbergMarquardt {
                cost_tolerance: Some(f64::NAN),
                ..LevenbergMarquardt::default()
            },
            "cost_tolerance",
        ),
    ] {
        match estimate(&model, &data, &ml, &lm, Some(&start)) {
            Err(FdidError::InvalidArgument { name: n, .. }) if n == name => {}
            other => panic!("{name}: {other:?}"),
        }
    }
}

#[test]
fn non_finite_data_are_rejected() {
    let omega = grid(10, 0.1, 3.0);
    let good = ct_data(&omega);
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let mut y = good.y().to_vec();
        y[4] = c(1.0, bad);
        match FrequencyData::new(omega.clone(), y, good.u().to_vec(), None) {
            Err(FdidError::NonFinite {
                what: "y",
                index: 4,
                ..
            }) => {}
            other => panic!("y = {bad}: {other:?}"),
        }
        let mut u = good.u().to_vec();
        u[7] = c(bad, 0.0);
        match FrequencyData::new(omega.clone(), good.y().to_vec(), u, None) {
            Err(FdidError::NonFinite {
                what: "u",
                index: 7,
                ..
            }) => {}
            other => panic!("u = {bad}: {other:?}"),
        }
        let mut w = omega.clone();
        w[2] = bad;
        match FrequencyData::new(w, good.y().to_vec(), good.u().to_vec(), None) {
            Err(FdidError::NonFinite {
                what: "omega",
                index: 2,
                ..
            }) => {}
            other => panic!("omega = {bad}: {other:?}"),
        }
        let frf = vec![c(bad, 1.0); omega.len()];
        assert!(matches!(
            FrequencyData::from_frf(omega.clone(), frf, None),
            Err(FdidError::NonFinite {
                what: "y",
                index: 0,
                ..
            })
        ));
    }
}

#[test]
fn unsorted_frequencies_are_rejected() {
    let omega = vec![0.1, 0.2, 0.4, 0.3, 0.5];
    let frf = vec![c(1.0, 0.0); 5];
    assert_eq!(
        FrequencyData::from_frf(omega, frf, None),
        Err(FdidError::Unsorted {
            index: 3,
            value: 0.3,
            previous: 0.4,
        })
    );
}

// ---------------------------------------------------------------------------------------
// Garbage in, no panic out
// ---------------------------------------------------------------------------------------

/// A number from a pool of awkward values: zeros, ±1, tiny, huge, subnormal, NaN, ±inf,
/// or a random magnitude 10^U(−40, 40) of either sign.
fn awkward(g: &mut Gen) -> f64 {
    let pool = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        1e-300,
        1e300,
        f64::MAX,
        f64::MIN_POSITIVE,
        5e-324,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    if u8::arbitrary(g) % 3 == 0 {
        *g.choose(&pool).unwrap()
    } else {
        let m = (u32::arbitrary(g) as f64 / u32::MAX as f64) * 80.0 - 40.0;
        let s = if bool::arbitrary(g) { 1.0 } else { -1.0 };
        s * 10f64.powf(m)
    }
}

/// A moderate number: 10^U(−3, 3) of either sign, or zero.
fn moderate(g: &mut Gen) -> f64 {
    if u8::arbitrary(g) % 10 == 0 {
        return 0.0;
    }
    let m = (u32::arbitrary(g) as f64 / u32::MAX as f64) * 6.0 - 3.0;
    let s = if bool::arbitrary(g) { 1.0 } else { -1.0 };
    s * 10f64.powf(m)
}

/// Random FRF data, mostly passing validation (so the estimators are reached), with
/// awkward values, random orders and a random domain.
#[derive(Debug, Clone)]
struct Garbage {
    omega: Vec<f64>,
    y: Vec<(f64, f64)>,
    u: Vec<(f64, f64)>,
    var: Option<Vec<f64>>,
    ts: Option<f64>,
    na: usize,
    nb: usize,
}

impl Arbitrary for Garbage {
    fn arbitrary(g: &mut Gen) -> Self {
        let n = usize::arbitrary(g) % 61;
        let wild = u8::arbitrary(g) % 4 == 0;
        let value = |g: &mut Gen| if wild { awkward(g) } else { moderate(g) };
        let mut omega: Vec<f64> = (0..n).map(|_| value(g)).collect();
        if u8::arbitrary(g) % 5 != 0 {
            // usually valid: non-negative, sorted (NaN sorts last)
            for w in omega.iter_mut() {
                *w = w.abs();
            }
            omega.sort_by(f64::total_cmp);
            if bool::arbitrary(g) && n > 2 {
                omega[1] = omega[0]; // a repeated line
            }
        }
        let y = (0..n).map(|_| (value(g), value(g))).collect();
        let u = if bool::arbitrary(g) {
            vec![(1.0, 0.0); n]
        } else {
            (0..n).map(|_| (value(g), value(g))).collect()
        };
        let var = if bool::arbitrary(g) {
            Some(
                (0..n)
                    .map(|_| {
                        if wild {
                            awkward(g).abs()
                        } else {
                            // a zero variance (an error with Auto weighting) now and then
                            let v = moderate(g).abs();
                            if v == 0.0 && u8::arbitrary(g) % 10 != 0 {
                                1.0
                            } else {
                                v
                            }
                        }
                    })
                    .collect(),
            )
        } else {
            None
        };
        let ts = if bool::arbitrary(g) {
            Some(if wild {
                awkward(g)
            } else {
                // Nyquist at 2, 1 or 2/3 times the top line (the last is an error)
                let top = omega.iter().copied().fold(0.0, f64::max);
                let factor = *g.choose(&[0.5, 1.0, 1.5]).unwrap();
                if top > 0.0 {
                    std::f64::consts::PI / top * factor
                } else {
                    1.0
                }
            })
        } else {
            None
        };
        Self {
            omega,
            y,
            u,
            var,
            ts,
            na: usize::arbitrary(g) % 11,
            nb: usize::arbitrary(g) % 11,
        }
    }
}

/// Cases whose data and model were valid (so the estimators ran), and cases where the
/// default pipeline returned a fit.
static REACHED: AtomicUsize = AtomicUsize::new(0);
static FITTED: AtomicUsize = AtomicUsize::new(0);

/// Builds data and model from the garbage and fits; any `Result` is fine, a panic is not.
fn fit_garbage<T: Real>(x: &Garbage) -> Option<bool> {
    let t = |v: f64| T::lit(v);
    let omega: Vec<T> = x.omega.iter().map(|v| t(*v)).collect();
    let y =
        x.y.iter()
            .map(|(a, b)| Complex::new(t(*a), t(*b)))
            .collect();
    let u =
        x.u.iter()
            .map(|(a, b)| Complex::new(t(*a), t(*b)))
            .collect();
    let mut data = FrequencyData::new(omega, y, u, x.ts.map(t)).ok()?;
    if let Some(var) = &x.var {
        data = data
            .with_noise(NoiseVariances::output_only(
                var.iter().map(|v| t(*v)).collect(),
            ))
            .ok()?;
    }
    let model = match x.ts {
        Some(ts) => Rational::discrete(x.na, x.nb, t(ts)).ok()?,
        None => Rational::continuous(x.na, x.nb, data.omega()).ok()?,
    };
    REACHED.fetch_add(1, Ordering::Relaxed);
    let mut ok = true;
    for (i, pipeline) in [Pipeline::default(), Pipeline::sk(), Pipeline::levy()]
        .iter()
        .enumerate()
    {
        if let Ok(fit) = pipeline.fit(&model, &data) {
            if i == 0 {
                FITTED.fetch_add(1, Ordering::Relaxed);
            }
            ok &= fit.theta().len() == model.n_params()
                && fit.theta().iter().all(|v| num_traits::Float::is_finite(*v));
            let _ = (fit.poles(), fit.zeros(), fit.gain(), fit.theta_std());
        }
    }
    let _ = estimate(
        &model,
        &data,
        &TotalLeastSquares::default(),
        &SvdNullVector,
        None,
    );
    Some(ok)
}

fn garbage_never_panics(x: Garbage) -> TestResult {
    let a = fit_garbage::<f64>(&x);
    let b = fit_garbage::<f32>(&x);
    if a == Some(false) || b == Some(false) {
        return TestResult::error(format!(
            "{x:?}: a fit returned θ of the wrong length or not finite"
        ));
    }
    TestResult::passed()
}

/// Random garbage (finite or not) FRF data and random orders into the estimators (the
/// three pipelines, and TLS): `Ok` with a finite θ of the right length, or `Err`, never a
/// panic (quickcheck reports a panic as a failure). This draw passes; scanning 250 other
/// generator seeds found TLS panics, pinned by `tls_huge_data_regression`.
#[test]
fn garbage_data_never_panics() {
    let seed = 2024;
    crate::common::seeded(seed)
        .tests(1000)
        .quickcheck(garbage_never_panics as fn(Garbage) -> TestResult);
    // 1000 cases × (f64, f32): make sure the generator reaches the estimators often
    let (reached, fitted) = (
        REACHED.load(Ordering::Relaxed),
        FITTED.load(Ordering::Relaxed),
    );
    println!("estimators reached in {reached} of 2000 runs, default pipeline Ok in {fitted}");
    assert!(
        reached >= 500 && fitted >= 200,
        "reached {reached}, fitted {fitted}"
    );
}

/// TLS (`SvdNullVector`) on finite data large enough for the QR factorisation to overflow:
/// must return an error, not panic. It panics inside nalgebra ("Singular value was NaN",
/// `SVD::try_new` on a triangular factor holding NaN): from |Y| = 1e154 in f64 and 1e19 in
/// f32 on a two-line DT model of order 0 (found by the garbage property with other seeds,
/// e.g. a single line Y = −1.3e31 in f32). Fix:
/// in `solver::linear::svd_of_r`, return `FdidError::Numerical` when the factor `r` is
/// not finite (checked: no panic over 250 generator seeds of the garbage property).
#[test]
fn tls_huge_data_regression() {
    let data =
        FrequencyData::from_frf(vec![1.0, 2.0], vec![c(1e160, 0.0), c(1.0, 0.0)], None).unwrap();
    let model = Rational::discrete(0, 0, 1.0).unwrap();
    let r = std::panic::catch_unwind(|| {
        estimate(
            &model,
            &data,
            &TotalLeastSquares::default(),
            &SvdNullVector,
            None,
        )
        .is_ok()
    });
    assert!(r.is_ok(), "TLS panicked on |Y| = 1e160 (f64)");
    let data32 =
        FrequencyData::<f32>::from_frf(vec![1.0], vec![Complex::new(-1.3e31, 0.0)], None).unwrap();
    let model32 = Rational::continuous(0, 0, data32.omega()).unwrap();
    let r = std::panic::catch_unwind(|| {
        estimate(
            &model32,
            &data32,
            &TotalLeastSquares::default(),
            &SvdNullVector,
            None,
        )
        .is_ok()
    });
    assert!(r.is_ok(), "TLS panicked on |Y| = 1.3e31 (f32)");
}

/// Levy on data with |Y| = f64::MAX returns `Ok` with θ = [inf] instead of an error; the
/// pipeline then fails with `NonFinite { what: "start" }`, naming a start the user never
/// gave.
#[test]
fn levy_overflow_regression() {
    let data =
        FrequencyData::from_frf(vec![1.0, 2.0], vec![c(f64::MAX, 0.0), c(1.0, 0.0)], None).unwrap();
    let model = Rational::discrete(0, 0, 1.0).unwrap();
    let levy = estimate(
        &model,
        &data,
        &Levy::default(),
        &LinearLeastSquares::default(),
        None,
    );
    if let Ok(sol) = levy {
        assert!(
            sol.theta.iter().all(|v| v.is_finite()),
            "Levy returned Ok with θ = {:?}",
            sol.theta
        );
    }
}
