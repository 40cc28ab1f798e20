//! One answer whatever the processor: the peers' four cases (and a delay search, an f32
//! fit and a time record) fitted on every SIMD path this processor has
//! ([`fdid::linalg::simd`]) give the same bits: θ, cost, the stages (kind, lines,
//! iterations), the standard deviations and the validation. The paths are switched in
//! this process with `simd::force`; `.ci/run` also runs the suite's real-data tests and
//! the program on each path with `FDID_SIMD` and compares the outputs.

use crate::common::{Noise, a_ct4, b_ct10, lfilter, noisy_frf};
use fdid::linalg::simd::{self, SimdPath};
use fdid::prelude::*;
use rand::{Rng, SeedableRng, rngs::StdRng};
use std::sync::Mutex;

/// Serialises the tests that force a path (any path gives the same results, so other tests
/// running meanwhile are not disturbed; this keeps each comparison on the path it names).
static PATHS: Mutex<()> = Mutex::new(());

/// Everything a fit reports, as bits and names.
fn fingerprint<T: Real, M: ModelStructure<T>>(fit: &Fit<T, M>) -> Vec<String> {
    let bits = |v: T| format!("{:016x}", v.to_f64().unwrap().to_bits());
    let mut out: Vec<String> = fit.theta().iter().map(|v| bits(*v)).collect();
    out.push(bits(fit.cost()));
    for s in fit.stages() {
        out.push(format!(
            "{} {:?} {} {:?}",
            s.kind, s.lines, s.solution.iterations, s.solution.termination
        ));
    }
    if let Some(std) = fit.theta_std() {
        out.extend(std.iter().map(|v| bits(*v)));
    }
    out.push(format!("{:?}", fit.validation()));
    out
}

/// `fit` on every supported path, each against the first (the scalar path).
fn same_on_every_path(case: &str, fit: impl Fn() -> Vec<String>) {
    let _one_at_a_time = PATHS.lock().unwrap_or_else(|e| e.into_inner());
    let paths = SimdPath::supported();
    let mut first: Option<(SimdPath, Vec<String>)> = None;
    for path in paths {
        simd::force(Some(path)).unwrap();
        let got = fit();
        simd::force(None).unwrap();
        assert!(!got.is_empty(), "{case}: nothing to compare");
        match &first {
            None => first = Some((path, got)),
            Some((p0, want)) => assert_eq!(&got, want, "{case}: {path} differs from {p0}"),
        }
    }
}

/// The peers' `c_dt6_delay` system: three modes in z, each of unit-normalised DC gain
/// times its gain, one sample of numerator lag; 3.5 samples of delay on 4 096 lines over
/// [0, π) at 40 dB SNR.
fn c_dt6_delay(seed: u64) -> FrequencyData<f64> {
    let modes = [(0.97, 0.25, 1.0), (0.93, 0.9, 0.5), (0.85, 2.1, 0.3)];
    let n = 4096;
    let omega: Vec<f64> = (0..n)
        .map(|k| std::f64::consts::PI * k as f64 / n as f64)
        .collect();
    let g0: Vec<Complex<f64>> = omega
        .iter()
        .map(|&w| {
            let zi = Complex::from_polar(1.0, -w);
            let g: Complex<f64> = modes
                .iter()
                .map(|&(r, th, gain)| {
                    let a = |z: Complex<f64>| 1.0 - 2.0 * r * f64::cos(th) * z + r * r * z * z;
                    gain * a(Complex::new(1.0, 0.0)) * zi / a(zi)
                })
                .sum();
            g * Complex::from_polar(1.0, -3.5 * w)
        })
        .collect();
    let rms = (g0.iter().map(|g| g.norm_sqr()).sum::<f64>() / n as f64).sqrt();
    let var = (0.01 * rms).powi(2);
    let mut noise = Noise::new(seed);
    let y = g0.iter().map(|g| g + noise.complex(var)).collect();
    FrequencyData::from_frf(omega, y, Some(1.0))
        .unwrap()
        .with_noise(NoiseVariances::output_only(vec![var; n]))
        .unwrap()
}

/// The peers' `d_dt4_time` record: two modes in z, a random-phase multisine on lines
/// 1…511 of 1 024 samples, 8 periods in steady state, coloured output noise
/// (1 + 0.5q⁻¹)/(1 − 0.8q⁻¹) at 20 dB; averaged over the periods, on the excited band.
fn d_dt4_time(seed: u64) -> FrequencyData<f64> {
    let (n, periods) = (1024usize, 8usize);
    let mut rng = StdRng::seed_from_u64(seed);
    let phases: Vec<f64> = (1..n / 2)
        .map(|_| rng.gen_range(0.0..std::f64::consts::TAU))
        .collect();
    let mut u1: Vec<f64> = (0..n)
        .map(|t| {
            phases
                .iter()
                .enumerate()
                .map(|(i, ph)| {
                    let k = (i + 1) as f64;
                    f64::cos(std::f64::consts::TAU * k * t as f64 / n as f64 + ph)
                })
                .sum()
        })
        .collect();
    let rms = (u1.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
    u1.iter_mut().for_each(|v| *v /= rms);
    let u: Vec<f64> = u1.iter().copied().cycle().take(n * (periods + 1)).collect();
    // two modes: G = Σ gᵢ Aᵢ(1) z⁻¹ / Aᵢ(z⁻¹)
    let mut y0 = vec![0.0; u.len()];
    for (r, th, gain) in [(0.95f64, 0.3f64, 1.0), (0.9, 1.2, 0.4)] {
        let a = [1.0, -2.0 * r * th.cos(), r * r];
        let b = [0.0, gain * a.iter().sum::<f64>()];
        for (y, v) in y0.iter_mut().zip(lfilter(&b, &a, &u)) {
            *y += v;
        }
    }
    let mut noise = Noise::new(seed + 1);
    let e: Vec<f64> = (0..u.len()).map(|_| noise.gauss()).collect();
    let v = lfilter(&[1.0, 0.5], &[1.0, -0.8], &e);
    let (u, y0, v) = (&u[n..], &y0[n..], &v[n..]);
    let power = |x: &[f64]| x.iter().map(|s| s * s).sum::<f64>() / x.len() as f64;
    let scale = 0.1 * (power(y0) / power(v)).sqrt();
    let y: Vec<f64> = y0.iter().zip(v).map(|(a, b)| a + scale * b).collect();
    let avg = TimeData::new(u.to_vec(), y, 1.0)
        .unwrap()
        .average_periods(periods)
        .unwrap();
    let tau = std::f64::consts::TAU;
    avg.band(
        tau * 0.5 / n as f64,
        tau * (n as f64 / 2.0 - 0.5) / n as f64,
    )
    .unwrap()
}

#[test]
fn the_peer_cases_give_the_same_bits_on_every_path() {
    let (a, _) = noisy_frf(&a_ct4(), 2000, 1);
    let model = Rational::continuous(4, 2, a.omega()).unwrap();
    same_on_every_path("a_ct4", || {
        fingerprint(&Pipeline::default().fit(&model, &a).unwrap())
    });

    let (b, _) = noisy_frf(&b_ct10(), 20_000, 2);
    let model = Rational::continuous(10, 8, b.omega()).unwrap();
    same_on_every_path("b_ct10", || {
        fingerprint(&Pipeline::default().fit(&model, &b).unwrap())
    });

    // the delay known, as the peers get it
    let c = c_dt6_delay(3);
    let known: Vec<Complex<f64>> = c
        .omega()
        .iter()
        .zip(c.y())
        .map(|(w, g)| g * Complex::from_polar(1.0, 3.5 * w))
        .collect();
    let c_known = FrequencyData::from_frf(c.omega().to_vec(), known, Some(1.0))
        .unwrap()
        .with_noise(c.noise().unwrap().clone())
        .unwrap();
    let model = Rational::discrete(6, 5, 1.0).unwrap();
    same_on_every_path("c_dt6_delay", || {
        fingerprint(&Pipeline::default().fit(&model, &c_known).unwrap())
    });

    let d = d_dt4_time(4);
    let model = Rational::discrete(4, 3, 1.0).unwrap();
    same_on_every_path("d_dt4_time", || {
        fingerprint(&Pipeline::default().fit(&model, &d).unwrap())
    });
}

/// The delay searched (`fdid fit --delay`'s fit) on `c_dt6_delay`, and an f32 fit.
#[test]
fn a_delay_search_and_an_f32_fit_give_the_same_bits_on_every_path() {
    let c = c_dt6_delay(5);
    let model = Rational::discrete(6, 5, 1.0).unwrap();
    same_on_every_path("c_dt6_delay, delay searched", || {
        let fit = fit_delayed(&Pipeline::default(), &model, &c).unwrap();
        let mut out = fingerprint(&fit);
        out.push(format!(
            "{:?}",
            fit.model().delay(fit.theta()).map(f64::to_bits)
        ));
        out
    });

    let (a, _) = noisy_frf(&a_ct4(), 2000, 6);
    let omega: Vec<f32> = a.omega().iter().map(|w| *w as f32).collect();
    let g: Vec<Complex<f32>> = a
        .y()
        .iter()
        .map(|g| Complex::new(g.re as f32, g.im as f32))
        .collect();
    let a32 = FrequencyData::from_frf(omega, g, None).unwrap();
    let model = Rational::<f32>::continuous(4, 2, a32.omega()).unwrap();
    same_on_every_path("a_ct4 in f32", || {
        fingerprint(&Pipeline::default().fit(&model, &a32).unwrap())
    });
}

/// The switch itself: a forced path is the active one, and an unsupported one is refused
/// with its name.
#[test]
fn a_forced_path_is_active_and_an_unsupported_one_is_refused() {
    let _one_at_a_time = PATHS.lock().unwrap_or_else(|e| e.into_inner());
    for path in SimdPath::ALL {
        match simd::force(Some(path)) {
            Ok(()) => assert_eq!(simd::active(), path),
            Err(e) => {
                assert!(!path.is_supported());
                assert!(e.to_string().contains(path.name()), "{e}");
            }
        }
    }
    simd::force(None).unwrap();
    assert!(simd::active().is_supported());
}
