//! Tests of periodic averaging (`TimeData::average_periods`, `PeriodicAverage`).

use fdid::data::{PeriodicAverage, dft_lines};
use fdid::{Complex, FdidError, Real, TimeData};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Standard normal samples by Box–Muller from a seeded generator.
fn gaussian(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let u1: f64 = 1.0 - rng.r#gen::<f64>(); // (0, 1]
            let u2: f64 = rng.r#gen::<f64>();
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        })
        .collect()
}

/// One period of a random-phase multisine plus a simple FIR response to it (periodic).
fn periodic_record(m: usize, periods: usize) -> (Vec<f64>, Vec<f64>) {
    let mut rng = StdRng::seed_from_u64(42);
    let phases: Vec<f64> = (0..m / 2)
        .map(|_| rng.gen_range(0.0..2.0 * std::f64::consts::PI))
        .collect();
    let u_period: Vec<f64> = (0..m)
        .map(|t| {
            (1..m / 2)
                .map(|k| (2.0 * std::f64::consts::PI * (k * t) as f64 / m as f64 + phases[k]).cos())
                .sum::<f64>()
        })
        .collect();
    // y(t) = 0.5 u(t) + 0.3 u(t-1) - 0.2 u(t-2), circular (steady state).
    let y_period: Vec<f64> = (0..m)
        .map(|t| {
            0.5 * u_period[t] + 0.3 * u_period[(t + m - 1) % m] - 0.2 * u_period[(t + m - 2) % m]
        })
        .collect();
    let u = u_period.iter().copied().cycle().take(m * periods).collect();
    let y = y_period.iter().copied().cycle().take(m * periods).collect();
    (u, y)
}

fn to_t<T: Real>(x: &[f64]) -> Vec<T> {
    x.iter().map(|v| T::lit(*v)).collect()
}

fn c64<T: Real>(c: &Complex<T>) -> Complex<f64> {
    Complex::new(c.re.to_f64_lossless(), c.im.to_f64_lossless())
}

fn noise_free_gives_zero_variance<T: Real>(tol: f64) {
    let (m, p) = (128usize, 4usize);
    let (u, y) = periodic_record(m, p);
    let rec = TimeData::new(to_t::<T>(&u), to_t::<T>(&y), T::lit(0.01)).unwrap();
    let avg = rec.average_periods(p).unwrap();
    let one_u = dft_lines(&to_t::<T>(&u[..m]));
    let one_y = dft_lines(&to_t::<T>(&y[..m]));
    assert_eq!(avg.len(), m / 2 + 1);
    assert_eq!(avg.ts(), Some(T::lit(0.01)));
    let scale = (m as f64).sqrt();
    for k in 0..avg.len() {
        assert!(
            (c64(&avg.u()[k]) - c64(&one_u[k])).norm() < tol * scale,
            "U line {k}"
        );
        assert!(
            (c64(&avg.y()[k]) - c64(&one_y[k])).norm() < tol * scale,
            "Y line {k}"
        );
        let want_w = 2.0 * std::f64::consts::PI * k as f64 / (m as f64 * 0.01);
        assert!((avg.omega()[k].to_f64_lossless() - want_w).abs() < 1e-4 * want_w.max(1.0));
    }
    let noise = avg.noise().expect("P >= 2 gives noise");
    let tiny = (tol * scale).powi(2);
    assert!(noise.var_y.iter().all(|v| v.to_f64_lossless() <= tiny));
    assert!(noise.var_u.iter().all(|v| v.to_f64_lossless() <= tiny));
    assert!(noise.cov_yu.iter().all(|c| c64(c).norm() <= tiny));
}

#[test]
fn noise_free_gives_zero_variance_f64() {
    noise_free_gives_zero_variance::<f64>(1e-12);
}

#[test]
fn noise_free_gives_zero_variance_f32() {
    noise_free_gives_zero_variance::<f32>(1e-5);
}

fn white_noise_variance<T: Real>() {
    let (m, p) = (512usize, 10usize);
    let sigma = 0.3;
    let (u, mut y) = periodic_record(m, p);
    for (yt, e) in y.iter_mut().zip(gaussian(m * p, 7)) {
        *yt += sigma * e;
    }
    let rec = TimeData::new(to_t::<T>(&u), to_t::<T>(&y), T::one()).unwrap();
    let avg = PeriodicAverage::new(&rec, p).unwrap();
    assert_eq!(avg.periods(), p);
    assert_eq!(avg.period_len(), m);
    let noise = avg.data().noise().unwrap();
    let lines = noise.len() as f64;
    let mean_var_y: f64 = noise.var_y.iter().map(|v| v.to_f64_lossless()).sum::<f64>() / lines;
    let want = sigma * sigma / p as f64;
    assert!(
        (mean_var_y - want).abs() < 0.1 * want,
        "mean var_y {mean_var_y} vs sigma^2/P = {want}"
    );
    // No input noise: var_u and cov_yu vanish (up to rounding).
    let max_var_u = noise
        .var_u
        .iter()
        .map(|v| v.to_f64_lossless())
        .fold(0.0, f64::max);
    assert!(max_var_u < 1e-6 * want, "var_u {max_var_u}");
    // The sample variance (not divided by P) is P times the variance of the mean.
    let sample = avg.sample_variances().unwrap();
    for (s, v) in sample.var_y.iter().zip(&noise.var_y) {
        let (s, v) = (s.to_f64_lossless(), v.to_f64_lossless());
        assert!((s - p as f64 * v).abs() <= 1e-5 * s.max(1e-30));
    }
    let mean_sample: f64 = sample
        .var_y
        .iter()
        .map(|v| v.to_f64_lossless())
        .sum::<f64>()
        / lines;
    assert!((mean_sample - sigma * sigma).abs() < 0.1 * sigma * sigma);
    // into_frequency_data is the same as average_periods.
    let direct = rec.average_periods(p).unwrap();
    assert_eq!(avg.into_frequency_data(), direct);
}

#[test]
fn white_noise_variance_f64() {
    white_noise_variance::<f64>();
}

#[test]
fn white_noise_variance_f32() {
    white_noise_variance::<f32>();
}

#[test]
fn common_noise_gives_covariance() {
    // The same noise on input and output: cov_yu ≈ var_y ≈ var_u ≈ σ²/P.
    let (m, p) = (256usize, 8usize);
    let sigma = 0.5;
    let (mut u, mut y) = periodic_record(m, p);
    for ((ut, yt), e) in u.iter_mut().zip(y.iter_mut()).zip(gaussian(m * p, 99)) {
        *ut += sigma * e;
        *yt += sigma * e;
    }
    let rec = TimeData::new(u, y, 1.0).unwrap();
    let avg = rec.average_periods(p).unwrap();
    let n = avg.noise().unwrap();
    for k in 0..n.len() {
        assert!((n.cov_yu[k].re - n.var_y[k]).abs() < 1e-9);
        assert!(n.cov_yu[k].im.abs() < 1e-9);
        assert!((n.var_u[k] - n.var_y[k]).abs() < 1e-9);
    }
    let mean: f64 = n.cov_yu.iter().map(|c| c.re).sum::<f64>() / n.len() as f64;
    let want = sigma * sigma / p as f64;
    assert!((mean - want).abs() < 0.1 * want, "{mean} vs {want}");
}

#[test]
fn one_period_equals_dft_without_noise() {
    let (u, y) = periodic_record(64, 1);
    let rec = TimeData::new(u, y, 0.1).unwrap();
    let avg = PeriodicAverage::new(&rec, 1).unwrap();
    assert!(avg.sample_variances().is_none());
    let d = avg.into_frequency_data();
    assert!(d.noise().is_none());
    assert_eq!(d, rec.dft());
}

#[test]
fn rejects_zero_periods() {
    let rec = TimeData::new(vec![0.0f64; 8], vec![0.0; 8], 1.0).unwrap();
    let e = rec.average_periods(0).unwrap_err();
    assert!(
        matches!(
            e,
            FdidError::InvalidArgument {
                name: "periods",
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn rejects_length_not_multiple_of_periods() {
    let rec = TimeData::new(vec![0.0f32; 10], vec![0.0; 10], 1.0).unwrap();
    let e = rec.average_periods(3).unwrap_err();
    match &e {
        FdidError::InvalidArgument {
            name,
            value,
            reason,
        } => {
            assert_eq!(*name, "periods");
            assert_eq!(value, "3");
            assert!(reason.contains("N = 10"), "{reason}");
        }
        other => panic!("unexpected {other:?}"),
    }
    assert!(e.to_string().contains("periods = 3"));
}

#[test]
fn rejects_periods_shorter_than_two_samples() {
    let rec = TimeData::new(vec![0.0f64; 6], vec![0.0; 6], 1.0).unwrap();
    let e = rec.average_periods(6).unwrap_err();
    assert_eq!(
        e,
        FdidError::TooShort {
            what: "samples per period",
            needed: 2,
            got: 1
        }
    );
    // M = 2 is the smallest allowed period.
    let d = rec.average_periods(3).unwrap();
    assert_eq!(d.len(), 2);
}
