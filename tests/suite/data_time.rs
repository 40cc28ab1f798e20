//! Tests of `TimeData` and its DFT (McKelvey eq. 1) against a naive DFT.

use fdid::data::dft_lines;
use fdid::{Complex, FdidError, Real, TimeData};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Naive DFT in f64: X_k = (1/√N) Σ x_t e^{-i 2π k t / N}, k = 0..=N/2.
fn naive_dft(x: &[f64]) -> Vec<Complex<f64>> {
    let n = x.len();
    (0..=n / 2)
        .map(|k| {
            let s = x
                .iter()
                .enumerate()
                .fold(Complex::new(0.0, 0.0), |acc, (t, v)| {
                    let ang = -2.0 * std::f64::consts::PI * ((k * t) % n) as f64 / n as f64;
                    acc + Complex::new(ang.cos(), ang.sin()) * *v
                });
            s / (n as f64).sqrt()
        })
        .collect()
}

fn random_signal(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect()
}

fn max_err<T: Real>(got: &[Complex<T>], want: &[Complex<f64>]) -> f64 {
    assert_eq!(got.len(), want.len());
    got.iter()
        .zip(want)
        .map(|(g, w)| {
            let g = Complex::new(g.re.to_f64_lossless(), g.im.to_f64_lossless());
            (g - w).norm()
        })
        .fold(0.0, f64::max)
}

fn check_against_naive<T: Real>(tol: f64) {
    for (i, &n) in [1usize, 2, 7, 64, 1000, 1001].iter().enumerate() {
        let u = random_signal(n, 10 + i as u64);
        let y = random_signal(n, 100 + i as u64);
        let ut: Vec<T> = u.iter().map(|v| T::lit(*v)).collect();
        let yt: Vec<T> = y.iter().map(|v| T::lit(*v)).collect();
        // Reference computed from the samples as rounded to T.
        let u64s: Vec<f64> = ut.iter().map(|v| v.to_f64_lossless()).collect();
        let y64s: Vec<f64> = yt.iter().map(|v| v.to_f64_lossless()).collect();
        let (nu, ny) = (naive_dft(&u64s), naive_dft(&y64s));

        let lines = dft_lines(&ut);
        assert_eq!(lines.len(), n / 2 + 1, "N = {n}");
        let e = max_err(&lines, &nu);
        assert!(e < tol, "dft_lines N = {n}: error {e}");

        if n >= 2 {
            let ts = 0.25;
            let rec = TimeData::new(ut, yt, T::lit(ts)).unwrap();
            let d = rec.dft();
            assert_eq!(d.len(), n / 2 + 1);
            assert_eq!(d.ts(), Some(T::lit(ts)));
            assert!(d.noise().is_none());
            let eu = max_err(d.u(), &nu);
            let ey = max_err(d.y(), &ny);
            assert!(eu < tol && ey < tol, "N = {n}: errors {eu}, {ey}");
            for (k, w) in d.omega().iter().enumerate() {
                let want = 2.0 * std::f64::consts::PI * k as f64 / (n as f64 * ts);
                let got = w.to_f64_lossless();
                assert!(
                    (got - want).abs() <= 1e-6 * want.max(1.0),
                    "N = {n}, k = {k}: omega {got} vs {want}"
                );
            }
        }
    }
}

#[test]
fn dft_matches_naive_f64() {
    check_against_naive::<f64>(1e-11);
}

#[test]
fn dft_matches_naive_f32() {
    check_against_naive::<f32>(1e-4);
}

#[test]
fn dft_of_empty_slice_is_empty() {
    assert!(dft_lines::<f64>(&[]).is_empty());
}

fn sinusoid_lands_on_its_line<T: Real>(tol: f64) {
    for &(n, k0) in &[(64usize, 5usize), (1000, 37), (999, 100)] {
        let amp = 2.0;
        let phase = 0.3;
        let x: Vec<T> = (0..n)
            .map(|t| {
                T::lit(
                    amp * (2.0 * std::f64::consts::PI * (k0 * t) as f64 / n as f64 + phase).cos(),
                )
            })
            .collect();
        let rec = TimeData::new(x.clone(), x, T::one()).unwrap();
        let d = rec.dft();
        // A cos(2π k0 t/N + φ) gives X_{k0} = (A √N / 2) e^{iφ}, zero elsewhere.
        let want = Complex::from_polar(amp * (n as f64).sqrt() / 2.0, phase);
        for (k, (u, y)) in d.u().iter().zip(d.y()).enumerate() {
            let u = Complex::new(u.re.to_f64_lossless(), u.im.to_f64_lossless());
            let y = Complex::new(y.re.to_f64_lossless(), y.im.to_f64_lossless());
            let expect = if k == k0 {
                want
            } else {
                Complex::new(0.0, 0.0)
            };
            assert!((u - expect).norm() < tol, "N = {n}, k = {k}: {u}");
            assert!((y - expect).norm() < tol, "N = {n}, k = {k}: {y}");
        }
        let w = d.omega()[k0].to_f64_lossless();
        let want_w = 2.0 * std::f64::consts::PI * k0 as f64 / n as f64;
        assert!((w - want_w).abs() < 1e-6);
    }
}

#[test]
fn sinusoid_lands_on_its_line_f64() {
    sinusoid_lands_on_its_line::<f64>(1e-9);
}

#[test]
fn sinusoid_lands_on_its_line_f32() {
    sinusoid_lands_on_its_line::<f32>(2e-3);
}

#[test]
fn parseval_holds() {
    // Σ|x_t|² = |X_0|² + 2 Σ_{0<k<N/2} |X_k|² + |X_{N/2}|² (N even).
    let n = 256;
    let x = random_signal(n, 7);
    let energy: f64 = x.iter().map(|v| v * v).sum();
    let xk = dft_lines(&x);
    let mut s = xk[0].norm_sqr() + xk[n / 2].norm_sqr();
    s += 2.0 * xk[1..n / 2].iter().map(|c| c.norm_sqr()).sum::<f64>();
    assert!((s - energy).abs() < 1e-9 * energy);
}

#[test]
fn getters() {
    let rec = TimeData::new(vec![1.0f64, 2.0, 3.0], vec![4.0, 5.0, 6.0], 0.5).unwrap();
    assert_eq!(rec.u(), &[1.0, 2.0, 3.0]);
    assert_eq!(rec.y(), &[4.0, 5.0, 6.0]);
    assert_eq!(rec.ts(), 0.5);
    assert_eq!(rec.len(), 3);
    assert!(!rec.is_empty());
}

#[test]
fn rejects_length_mismatch() {
    let e = TimeData::new(vec![1.0f64, 2.0, 3.0], vec![1.0, 2.0], 1.0).unwrap_err();
    assert_eq!(
        e,
        FdidError::LengthMismatch {
            what: "y",
            expected: 3,
            got: 2
        }
    );
}

#[test]
fn rejects_too_short() {
    for n in [0usize, 1] {
        let e = TimeData::new(vec![1.0f32; n], vec![1.0; n], 1.0).unwrap_err();
        assert_eq!(
            e,
            FdidError::TooShort {
                what: "time samples",
                needed: 2,
                got: n
            }
        );
    }
}

#[test]
fn rejects_non_finite_samples() {
    let e = TimeData::new(vec![1.0f64, f64::NAN, 3.0], vec![0.0; 3], 1.0).unwrap_err();
    match e {
        FdidError::NonFinite { what, index, value } => {
            assert_eq!((what, index), ("u", 1));
            assert_eq!(value, "NaN");
        }
        other => panic!("unexpected {other:?}"),
    }
    let e = TimeData::new(vec![0.0f32; 3], vec![1.0, 2.0, f32::INFINITY], 1.0).unwrap_err();
    match e {
        FdidError::NonFinite { what, index, value } => {
            assert_eq!((what, index), ("y", 2));
            assert_eq!(value, "inf");
        }
        other => panic!("unexpected {other:?}"),
    }
}

#[test]
fn rejects_bad_sample_time() {
    for ts in [0.0f64, -1.0, f64::NAN, f64::INFINITY, 5e-324] {
        let e = TimeData::new(vec![0.0; 4], vec![0.0; 4], ts).unwrap_err();
        match e {
            FdidError::InvalidArgument { name, value, .. } => {
                assert_eq!(name, "ts");
                assert_eq!(value, format!("{ts}"));
            }
            other => panic!("unexpected {other:?}"),
        }
    }
    let e = TimeData::new(vec![0.0f32; 4], vec![0.0; 4], -0.1).unwrap_err();
    assert!(matches!(e, FdidError::InvalidArgument { name: "ts", .. }));
}

#[test]
fn rejects_samples_whose_dft_would_overflow() {
    let big = f32::MAX / 2.0;
    let e = TimeData::new(vec![big; 4], vec![0.0f32; 4], 1.0).unwrap_err();
    assert!(
        matches!(e, FdidError::InvalidArgument { name: "u", .. }),
        "{e}"
    );
    // Large but representable values are accepted and give a finite DFT.
    let ok = TimeData::new(vec![1e30f32; 1024], vec![-1e30; 1024], 1.0).unwrap();
    let d = ok.dft();
    assert!(d.u().iter().all(|c| c.re.is_finite() && c.im.is_finite()));
}
