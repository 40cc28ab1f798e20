//! The common-denominator (matrix-fraction) estimator (`mimo::fit_common_denominator`):
//! noise-free recovery of random systems with every numerator degree nb ≤ na in z (f64
//! and f32, on the whole band and on a short arc) and in s (any relative degree), the
//! relative degree kept, the Monte Carlo spread of the poles against their predicted
//! covariance, stability under `stable`, and bad input.

use crate::common;
use crate::mimo::{Draw, noise, pole_error};

use fdid::data::FrfMatrix;
use fdid::mimo::{CommonPoleOptions, MlOutcome, PoleSet, fit_common_denominator};
use fdid::prelude::*;
use quickcheck::{Arbitrary, Gen, TestResult};

/// A random stable system in z: `pairs` resonances and `real` real poles (|p| 0.3–0.95,
/// angles spread over (0, π)), numerators of degree `nb` with random coefficients.
#[derive(Debug, Clone, Copy)]
struct Case {
    seed: u64,
    ny: usize,
    nu: usize,
    pairs: usize,
    real: usize,
    nb: usize,
}

impl Arbitrary for Case {
    fn arbitrary(g: &mut Gen) -> Self {
        let pairs = u32::arbitrary(g) as usize % 4;
        let real = usize::from(pairs == 0) + u32::arbitrary(g) as usize % 2;
        let na = 2 * pairs + real;
        Self {
            seed: u64::arbitrary(g) | 1,
            ny: 1 + u32::arbitrary(g) as usize % 3,
            nu: 1 + u32::arbitrary(g) as usize % 3,
            pairs,
            real,
            nb: u32::arbitrary(g) as usize % (na + 1),
        }
    }
}

/// The truth of a case: its poles and each entry's numerator b_0 … b_nb.
struct Truth {
    poles: PoleSet<f64>,
    numerators: Vec<Vec<f64>>,
}

impl Case {
    fn na(&self) -> usize {
        2 * self.pairs + self.real
    }

    /// The truth with the resonances' angles spread over (lo, hi) (rad/sample).
    fn truth(&self, (lo, hi): (f64, f64)) -> Truth {
        let mut d = Draw(self.seed);
        let slots = self.pairs + self.real;
        let angle = |k: usize, d: &mut Draw| {
            lo + (k as f64 + 0.2 + 0.6 * d.unit()) / slots as f64 * (hi - lo)
        };
        let mut real = Vec::new();
        let mut pairs = Vec::new();
        for k in 0..slots {
            let radius = 0.3 + 0.65 * d.unit();
            if k < self.real {
                real.push(if d.unit() < 0.5 { radius } else { -radius });
            } else {
                pairs.push(Complex::from_polar(radius, angle(k, &mut d)));
            }
        }
        let numerators = (0..self.ny * self.nu)
            .map(|_| (0..=self.nb).map(|_| d.signed()).collect())
            .collect();
        Truth {
            poles: PoleSet { real, pairs },
            numerators,
        }
    }
}

/// A(z⁻¹) = Π (1 − p z⁻¹) at ξ = z⁻¹.
fn denominator(poles: &PoleSet<f64>, xi: Complex<f64>) -> Complex<f64> {
    poles
        .all()
        .iter()
        .fold(Complex::new(1.0, 0.0), |v, p| v * (1.0 - p * xi))
}

fn omega(lines: usize) -> Vec<f64> {
    band(lines, (0.0, std::f64::consts::PI))
}

/// `lines` lines evenly inside (lo, hi) (rad/sample).
fn band(lines: usize, (lo, hi): (f64, f64)) -> Vec<f64> {
    (1..=lines)
        .map(|k| lo + (hi - lo) * k as f64 / (lines + 1) as f64)
        .collect()
}

/// The whole band, and a narrow one: 2–15 Hz of data sampled at 400 Hz (a short arc of
/// the unit circle, where the powers of z⁻¹ are nearly dependent).
const WHOLE: (f64, f64) = (0.0, 3.0);
const NARROW: (f64, f64) = (0.0314, 0.2356);

fn responses(truth: &Truth, w: &[f64]) -> Vec<Vec<Complex<f64>>> {
    truth
        .numerators
        .iter()
        .map(|b| {
            w.iter()
                .map(|w| {
                    let xi = Complex::new(0.0, -w).exp();
                    let num = b
                        .iter()
                        .rev()
                        .fold(Complex::new(0.0, 0.0), |v, c| v * xi + c);
                    num / denominator(&truth.poles, xi)
                })
                .collect()
        })
        .collect()
}

fn options<T: Real>() -> CommonPoleOptions<T> {
    CommonPoleOptions {
        domain: Domain::Discrete { ts: T::one() },
        ..Default::default()
    }
}

fn recovers<T: Real>(case: Case, tolerance: f64, arc: (f64, f64)) -> TestResult {
    let truth = case.truth(arc);
    let w = if arc == WHOLE {
        omega(200)
    } else {
        band(200, arc)
    };
    let g = responses(&truth, &w);
    let entries = g
        .iter()
        .map(|e| {
            e.iter()
                .map(|v| Complex::new(T::lit(v.re), T::lit(v.im)))
                .collect()
        })
        .collect();
    let tw = w.iter().map(|v| T::lit(*v)).collect();
    let data = FrfMatrix::from_entries(tw, case.ny, case.nu, entries, Some(T::one())).unwrap();
    let fit = match fit_common_denominator(&data, case.na(), case.nb, &options()) {
        Ok(f) => f,
        Err(e) => return TestResult::error(format!("{case:?}: {e}")),
    };
    let err = pole_error(&truth.poles, &fit.model.poles);
    let scale = g
        .iter()
        .flat_map(|e| e.iter().map(|v| v.norm()))
        .fold(0.0, f64::max);
    let rms = fit.rms(&data).to_f64_lossless() / scale;
    // the numerators' coefficients beyond nb stay zero
    let mf = fit.model.matrix_fraction();
    let size = mf
        .numerators
        .iter()
        .flatten()
        .fold(0.0, |m: f64, c| m.max(c.to_f64_lossless().abs()));
    let beyond = mf
        .numerators
        .iter()
        .flat_map(|b| b[case.nb + 1..].iter())
        .fold(0.0, |m: f64, c| m.max(c.to_f64_lossless().abs()))
        / size.max(1.0);
    if err < tolerance && rms < tolerance && beyond < tolerance {
        TestResult::passed()
    } else {
        TestResult::error(format!(
            "{case:?}: pole error {err:.2e}, relative rms {rms:.2e}, b beyond nb {beyond:.2e} \
             (tolerance {tolerance:.0e}), ml {:?}",
            fit.ml
        ))
    }
}

fn recovers_f64(case: Case) -> TestResult {
    recovers::<f64>(case, 1e-8, WHOLE)
}

fn recovers_f32(case: Case) -> TestResult {
    recovers::<f32>(case, 2e-3, WHOLE)
}

fn recovers_narrow_f64(case: Case) -> TestResult {
    recovers::<f64>(case, 1e-6, NARROW)
}

#[test]
fn noise_free_recovery_of_random_common_denominator_systems_f64() {
    common::seeded(0xde_7031)
        .tests(50)
        .quickcheck(recovers_f64 as fn(Case) -> TestResult);
}

#[test]
fn noise_free_recovery_of_random_common_denominator_systems_f32() {
    common::seeded(0xde_7032)
        .tests(50)
        .quickcheck(recovers_f32 as fn(Case) -> TestResult);
}

/// Lines and resonances on a short arc (2–15 Hz at 400 Hz sampling): the orthonormal
/// basis keeps the recovery at 10⁻⁶ for na ≤ 7 (in powers of z⁻¹ the F-16's fit on that
/// arc was singular at na = 20).
#[test]
fn noise_free_recovery_on_a_short_arc_f64() {
    common::seeded(0xde_7033)
        .tests(40)
        .quickcheck(recovers_narrow_f64 as fn(Case) -> TestResult);
}

/// A random stable continuous-time system of a case: the poles spread over 0.1–10 rad/s
/// (damping 0.05–0.3 for the pairs), each entry's numerator c Π(s − z_m) with nb random
/// real zeros of either sign in the same band; the entries on 300 lines from 0.05 to
/// 20 rad/s.
fn s_system(case: &Case) -> (PoleSet<f64>, FrfMatrix<f64>) {
    let mut d = Draw(case.seed);
    let slots = case.pairs + case.real;
    let step = 100f64.ln() / slots as f64;
    let freq =
        |k: usize, d: &mut Draw| (0.1f64.ln() + (k as f64 + 0.3 + 0.4 * d.unit()) * step).exp();
    let mut poles = PoleSet {
        real: vec![],
        pairs: vec![],
    };
    for k in 0..slots {
        let w = freq(k, &mut d);
        if k < case.real {
            poles.real.push(-w);
        } else {
            let zeta = 0.05 + 0.25 * d.unit();
            poles
                .pairs
                .push(Complex::new(-zeta * w, w * (1.0 - zeta * zeta).sqrt()));
        }
    }
    let w: Vec<f64> = (0..300)
        .map(|k| 0.05 * 400f64.powf(k as f64 / 299.0))
        .collect();
    let entries = (0..case.ny * case.nu)
        .map(|_| {
            let zeros: Vec<f64> = (0..case.nb)
                .map(|_| {
                    let size = (0.1f64.ln() + d.unit() * 100f64.ln()).exp();
                    if d.unit() < 0.5 { size } else { -size }
                })
                .collect();
            let c = d.signed() + 2.0f64.copysign(d.signed());
            w.iter()
                .map(|w| {
                    let s = Complex::new(0.0, *w);
                    let num = zeros.iter().fold(Complex::new(c, 0.0), |v, z| v * (s - z));
                    let den = poles
                        .all()
                        .iter()
                        .fold(Complex::new(1.0, 0.0), |v, p| v * (s - p));
                    num / den
                })
                .collect()
        })
        .collect();
    let data = FrfMatrix::from_entries(w, case.ny, case.nu, entries, None).unwrap();
    (poles, data)
}

/// In s, any relative degree: the poles recovered to 10⁻⁷, the entries to 10⁻⁷ of their
/// largest value, a direct term exactly when nb = na, and the leading na − nb numerator
/// coefficients of the polynomial form zero (to 10⁻⁷ of the largest).
fn recovers_in_s(case: Case) -> TestResult {
    let (poles, data) = s_system(&case);
    let options = CommonPoleOptions::default();
    let fit = match fit_common_denominator(&data, case.na(), case.nb, &options) {
        Ok(f) => f,
        Err(e) => return TestResult::error(format!("{case:?}: {e}")),
    };
    let err = pole_error(&poles, &fit.model.poles);
    let scale = data
        .entries()
        .iter()
        .flat_map(|e| e.y().iter().map(|v| v.norm()))
        .fold(0.0, f64::max);
    let rms = fit.rms(&data) / scale;
    let mf = fit.model.matrix_fraction();
    let lead = case.na() - case.nb;
    let beyond = mf
        .numerators
        .iter()
        .map(|b| {
            let size = b.iter().fold(0.0f64, |m, c| m.max(c.abs()));
            b[..lead].iter().fold(0.0f64, |m, c| m.max(c.abs())) / size
        })
        .fold(0.0, f64::max);
    let direct = fit.model.direct.is_some() == (case.nb == case.na());
    if err < 1e-7 && rms < 1e-7 && beyond < 1e-7 && direct {
        TestResult::passed()
    } else {
        TestResult::error(format!(
            "{case:?}: pole error {err:.2e}, relative rms {rms:.2e}, leading numerator \
             {beyond:.2e}, direct {:?}, ml {:?}",
            fit.model.direct.is_some(),
            fit.ml
        ))
    }
}

#[test]
fn noise_free_recovery_in_s_with_any_relative_degree() {
    common::seeded(0xde_7034)
        .tests(40)
        .quickcheck(recovers_in_s as fn(Case) -> TestResult);
}

/// Two entries over one resonance (p = 0.9 e^{±0.6i}) and a real pole at 0.5, numerators
/// of degree 1, 120 lines, known noise variances; 200 runs: each pole parameter's spread
/// within 20 % of the predicted standard deviation (eq. 32 through the roots'
/// sensitivities), its mean within 3 standard errors of the truth.
#[test]
fn poles_spread_as_predicted() {
    let truth = Truth {
        poles: PoleSet {
            real: vec![0.5],
            pairs: vec![Complex::from_polar(0.9, 0.6)],
        },
        numerators: vec![vec![0.4, 0.2], vec![-0.3, 0.5]],
    };
    let w = omega(120);
    let clean = responses(&truth, &w);
    let want = [0.5, truth.poles.pairs[0].re, truth.poles.pairs[0].im];
    spread_as_predicted(
        &clean,
        &w,
        Some(1.0),
        1e-4,
        &options(),
        want,
        0x5851_f42d_4c95_7f2d,
    );
}

/// Fits 200 noisy copies (complex noise of variance `var` on every entry, known
/// variances) of the two entries `clean` with na 3, nb 1, and checks each pole parameter
/// (the real pole, then Re and Im of the pair) against `want`: its spread within 20 % of
/// the mean predicted standard deviation, its mean within 3 standard errors.
fn spread_as_predicted(
    clean: &[Vec<Complex<f64>>],
    w: &[f64],
    ts: Option<f64>,
    var: f64,
    options: &CommonPoleOptions<f64>,
    want: [f64; 3],
    seed: u64,
) {
    let runs = 200;
    let mut d = Draw(seed);
    let mut samples: Vec<Vec<f64>> = Vec::new();
    let mut predicted = [0.0; 3];
    for _ in 0..runs {
        let entries = clean
            .iter()
            .map(|e| e.iter().map(|g| g + noise(&mut d, var)).collect())
            .collect();
        let data = FrfMatrix::from_entries(w.to_vec(), 2, 1, entries, ts)
            .unwrap()
            .with_variances(vec![vec![var; w.len()]; 2])
            .unwrap();
        let fit = fit_common_denominator(&data, 3, 1, options).unwrap();
        assert!(matches!(fit.ml, MlOutcome::Kept { .. }), "{:?}", fit.ml);
        let cov = fit.pole_covariance.as_ref().unwrap();
        for (t, s) in predicted.iter_mut().enumerate() {
            *s += cov[(t, t)].sqrt() / runs as f64;
        }
        let p = &fit.model.poles;
        samples.push(vec![p.real[0], p.pairs[0].re, p.pairs[0].im]);
    }
    for (t, want) in want.iter().enumerate() {
        let n = runs as f64;
        let mean = samples.iter().map(|s| s[t]).sum::<f64>() / n;
        let sd = (samples.iter().map(|s| (s[t] - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let ratio = sd / predicted[t];
        assert!(
            (0.8..1.25).contains(&ratio),
            "θ{t}: Monte Carlo sd {sd:.3e}, predicted {:.3e}",
            predicted[t]
        );
        let bias = (mean - want).abs() / (predicted[t] / n.sqrt());
        assert!(bias < 3.0, "θ{t}: bias {bias:.1} standard errors");
    }
}

/// In s, relative degree 2: two entries (s + 2)·c/((s + 1)(s² + 0.4s + 4)), 150 lines
/// over 0.1–10 rad/s, known variances; 200 runs: each pole parameter's spread within 20 %
/// of the predicted standard deviation, its mean within 3 standard errors.
#[test]
fn poles_spread_as_predicted_in_s() {
    let pair = Complex::new(-0.2, 4f64.sqrt() * (1.0 - 0.01f64).sqrt());
    let w: Vec<f64> = (0..150)
        .map(|k| 0.1 * 100f64.powf(k as f64 / 149.0))
        .collect();
    let clean: Vec<Vec<Complex<f64>>> = [1.0, -0.6]
        .iter()
        .map(|c| {
            w.iter()
                .map(|w| {
                    let s = Complex::new(0.0, *w);
                    (s + 2.0) * *c / ((s + 1.0) * (s - pair) * (s - pair.conj()))
                })
                .collect()
        })
        .collect();
    // relative degree 2: no direct term
    let data = FrfMatrix::from_entries(w.clone(), 2, 1, clean.clone(), None).unwrap();
    let noise_free = fit_common_denominator(&data, 3, 1, &CommonPoleOptions::default()).unwrap();
    assert!(noise_free.model.direct.is_none());
    let want = [-1.0, pair.re, pair.im];
    let options = CommonPoleOptions::default();
    spread_as_predicted(
        &clean,
        &w,
        None,
        1e-6,
        &options,
        want,
        0x1234_5678_9abc_def1,
    );
}

/// Data of an unstable system (a pole at 1.2) fitted with `stable`: every pole inside
/// the unit circle; without it the unstable pole is found.
#[test]
fn stable_fits_stay_inside_the_unit_circle() {
    let truth = Truth {
        poles: PoleSet {
            real: vec![1.2],
            pairs: vec![Complex::from_polar(0.8, 1.0)],
        },
        numerators: vec![vec![1.0, 0.3]],
    };
    let w = omega(100);
    let data = FrfMatrix::from_entries(w, 1, 1, responses(&truth, &omega(100)), Some(1.0)).unwrap();
    let free = fit_common_denominator(&data, 3, 1, &options()).unwrap();
    assert!(pole_error(&truth.poles, &free.model.poles) < 1e-8);
    let stable = CommonPoleOptions {
        stable: true,
        ..options()
    };
    let fit = fit_common_denominator(&data, 3, 1, &stable).unwrap();
    assert!(fit.model.poles.is_stable(Domain::Discrete { ts: 1.0 }));
}

#[test]
fn bad_input_gives_errors() {
    let w = omega(10);
    let c = vec![Complex::new(1.0, 0.5); 10];
    let data = FrfMatrix::from_entries(w.clone(), 1, 1, vec![c.clone()], Some(1.0)).unwrap();
    let err = |na, nb, o: &CommonPoleOptions<f64>| {
        fit_common_denominator(&data, na, nb, o)
            .unwrap_err()
            .to_string()
    };
    assert!(err(2, 3, &options()).contains("at most na = 2"));
    assert!(err(0, 0, &options()).contains("at least one pole"));
    assert!(err(12, 8, &options()).contains("10 lines"));
    let fast = CommonPoleOptions {
        domain: Domain::Discrete { ts: 2.0 },
        ..options()
    };
    assert!(err(2, 1, &fast).contains("Nyquist"));
}
