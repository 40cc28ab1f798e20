//! Common-pole fits weighted by the full ny × ny noise covariance of each input column
//! (`FrfMatrix::with_covariances`, `CommonPoleOptions::full_covariance`): noise-free
//! recovery of random systems under random correlated weightings in f64 and f32
//! (quickcheck), and the Monte Carlo spread of the poles with strongly correlated output
//! noise against the predicted covariance and against the fit that weights by the
//! variances alone.

use crate::common;
use crate::mimo::{Case, Draw, frf_matrix, noise, omega, pole_error, two_outputs_on_150_lines};

use fdid::data::{FrfMatrix, InputNoise};
use fdid::mimo::{CommonPoleOptions, MlOutcome, fit_common_poles};
use fdid::prelude::*;
use nalgebra::{DMatrix, DVector};
use quickcheck::TestResult;

/// A random ny × ny covariance L Lᴴ: L lower triangular with a positive diagonal and
/// complex entries below it, scaled by `size`.
fn random_covariance(d: &mut Draw, ny: usize, size: f64) -> DMatrix<Complex<f64>> {
    let l = DMatrix::from_fn(ny, ny, |i, j| match i.cmp(&j) {
        std::cmp::Ordering::Less => Complex::new(0.0, 0.0),
        std::cmp::Ordering::Equal => Complex::new(0.5 + d.unit(), 0.0),
        std::cmp::Ordering::Greater => Complex::new(d.signed(), d.signed()),
    });
    (&l * l.adjoint()) * Complex::new(size, 0.0)
}

fn covariances_of<T: Real>(
    d: &mut Draw,
    ny: usize,
    nu: usize,
    lines: usize,
) -> Vec<Vec<DMatrix<Complex<T>>>> {
    (0..nu)
        .map(|_| {
            (0..lines)
                .map(|_| {
                    random_covariance(d, ny, 1e-4).map(|v| Complex::new(T::lit(v.re), T::lit(v.im)))
                })
                .collect()
        })
        .collect()
}

/// The options of a full-covariance fit.
fn full<T: Real>() -> CommonPoleOptions<T> {
    CommonPoleOptions {
        full_covariance: true,
        ..Default::default()
    }
}

fn recovers<T: Real>(case: Case, tolerance: f64) -> TestResult {
    let model = case.model();
    let w = omega(300);
    let mut d = Draw(case.seed ^ 0xc0ffee);
    let data: FrfMatrix<T> = frf_matrix::<T>(&model, &w);
    let covariances = covariances_of::<T>(&mut d, case.ny, case.nu, w.len());
    let data = match data.with_covariances(covariances) {
        Ok(m) => m,
        Err(e) => return TestResult::error(format!("{case:?}: {e}")),
    };
    let fit = match fit_common_poles(&data, model.order(), &full()) {
        Ok(f) => f,
        Err(e) => return TestResult::error(format!("{case:?}: {e}")),
    };
    if fit.correlated != (case.ny > 1) {
        return TestResult::error(format!("{case:?}: correlated {}", fit.correlated));
    }
    let err = pole_error(&model.poles, &fit.model.poles);
    let scale = data
        .entries()
        .iter()
        .flat_map(|e| e.y().iter().map(|v| v.norm().to_f64_lossless()))
        .fold(0.0, f64::max);
    let rms = fit.rms(&data).to_f64_lossless() / scale;
    if err < tolerance && rms < tolerance {
        TestResult::passed()
    } else {
        TestResult::error(format!(
            "{case:?}: pole error {err:.2e}, relative rms {rms:.2e} (tolerance {tolerance:.0e}), \
             ml {:?}",
            fit.ml
        ))
    }
}

fn recovers_f64(case: Case) -> TestResult {
    recovers::<f64>(case, 1e-7)
}

fn recovers_f32(case: Case) -> TestResult {
    recovers::<f32>(case, 2e-3)
}

#[test]
fn noise_free_recovery_under_correlated_weights_f64() {
    common::seeded(0xc0_7a71)
        .tests(30)
        .quickcheck(recovers_f64 as fn(Case) -> TestResult);
}

#[test]
fn noise_free_recovery_under_correlated_weights_f32() {
    common::seeded(0xc0_7a72)
        .tests(30)
        .quickcheck(recovers_f32 as fn(Case) -> TestResult);
}

/// Per-run results of the Monte Carlo: the pole parameters and predicted standard
/// deviations of the full-covariance fit, the diagonal fit's pole parameters, and the
/// full fit's cost.
struct Runs {
    full: Vec<Vec<f64>>,
    predicted: Vec<f64>,
    diagonal: Vec<Vec<f64>>,
    costs: Vec<f64>,
}

fn pair_theta(poles: &fdid::mimo::PoleSet<f64>) -> Vec<f64> {
    poles.pairs.iter().flat_map(|p| [p.re, p.im]).collect()
}

fn mean_sd(samples: &[Vec<f64>], t: usize) -> (f64, f64) {
    let n = samples.len() as f64;
    let mean = samples.iter().map(|s| s[t]).sum::<f64>() / n;
    let var = samples.iter().map(|s| (s[t] - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

/// Two outputs of one input sharing two resonances, their noise correlated with
/// ρ = 0.95 (one disturbance seen by both sensors), known covariance, 200 runs of 150
/// lines. The full-covariance ML: the spread of each pole parameter within 20 % of the
/// predicted standard deviation (McKelvey eq. 32 with the whitened Jacobian), the mean
/// within 3 standard errors of the truth, the mean cost within 5 % of its expectation
/// (2L·ny − P)/2; and it beats the fit weighted by the variances alone: the summed
/// variance of the pole parameters at most 0.7 of that fit's (0.54 measured).
#[test]
fn correlated_output_noise_spread_as_predicted_and_below_the_diagonal_fit() {
    let (truth, w, clean) = two_outputs_on_150_lines();
    let (var, rho) = (1e-4, 0.95);
    let c = Complex::new(var, 0.0);
    let cov = DMatrix::from_row_slice(2, 2, &[c, c * rho, c * rho, c]);
    let runs = 200;
    let mut d = Draw(0x2545_f491_4f6c_dd1d);
    let mut out = Runs {
        full: vec![],
        predicted: vec![0.0; 4],
        diagonal: vec![],
        costs: vec![],
    };
    for _ in 0..runs {
        let mut entries: Vec<Vec<Complex<f64>>> = vec![vec![]; 2];
        for g in &clean {
            let (n1, n2) = (noise(&mut d, var), noise(&mut d, var));
            entries[0].push(g[(0, 0)] + n1);
            entries[1].push(g[(1, 0)] + n1 * rho + n2 * (1.0 - rho * rho).sqrt());
        }
        let data = FrfMatrix::from_entries(w.clone(), 2, 1, entries, None)
            .unwrap()
            .with_covariances(vec![vec![cov.clone(); w.len()]])
            .unwrap();
        let full = fit_common_poles(&data, 4, &full()).unwrap();
        assert!(full.correlated && matches!(full.ml, MlOutcome::Kept { .. }));
        let p = full.pole_covariance.as_ref().unwrap();
        for (t, s) in out.predicted.iter_mut().enumerate() {
            *s += p[(t, t)].sqrt() / runs as f64;
        }
        out.full.push(pair_theta(&full.model.poles));
        out.costs.push(full.cost);
        // the default weights by the variances alone
        let diag = fit_common_poles(&data, 4, &CommonPoleOptions::default()).unwrap();
        assert!(!diag.correlated && diag.weighted);
        out.diagonal.push(pair_theta(&diag.model.poles));
    }
    let want = pair_theta(&truth.poles);
    let (mut full_var, mut diag_var) = (0.0, 0.0);
    for (t, want) in want.iter().enumerate() {
        let (mean, sd) = mean_sd(&out.full, t);
        let ratio = sd / out.predicted[t];
        assert!(
            (0.8..1.25).contains(&ratio),
            "θ{t}: Monte Carlo sd {sd:.3e}, predicted {:.3e}",
            out.predicted[t]
        );
        let bias = (mean - want).abs() / (out.predicted[t] / (runs as f64).sqrt());
        assert!(bias < 3.0, "θ{t}: bias {bias:.1} standard errors");
        full_var += sd * sd;
        diag_var += mean_sd(&out.diagonal, t).1.powi(2);
    }
    assert!(
        full_var <= 0.7 * diag_var,
        "summed variance {full_var:.3e} with the covariance vs {diag_var:.3e} without"
    );
    // P = 4 poles + 2 entries × 4 residue parameters
    let expected = (2.0 * 150.0 * 2.0 - 12.0) / 2.0;
    let mean_cost = out.costs.iter().sum::<f64>() / runs as f64;
    assert!(
        (mean_cost / expected - 1.0).abs() < 0.05,
        "mean cost {mean_cost:.1}, expected {expected:.1}"
    );
}

/// Errors in variables: two outputs of one input sharing two resonances, the FRF
/// measured as Ĝ = Ȳ/Ū with noise on the input's sensor (variance s = 10⁻³ of |U|²,
/// not driving the system) and on the outputs (10⁻⁴ each), known noise, 200 runs of 150
/// lines. With the input's noise attached (`with_input_noise`) the reweighted fit's
/// covariance C − c Gᴴ − G cᴴ + GGᴴs is right: the spread of each pole parameter within
/// 25 % of the predicted standard deviation, the mean within 3 standard errors of the
/// truth, the mean cost within 10 % of (2L·ny − P)/2. Ignoring it (the outputs' covariance
/// alone) the cost is over twice its expectation and the poles' summed variance larger.
#[test]
fn input_noise_weighting_spread_as_predicted() {
    let (truth, w, clean) = two_outputs_on_150_lines();
    let (var_y, var_u) = (1e-4, 1e-3);
    let output = DMatrix::from_diagonal_element(2, 2, Complex::new(var_y, 0.0));
    let runs = 200;
    let mut d = Draw(0x5eed_e1f5);
    let (mut eiv, mut outputs_only) = (vec![], vec![]);
    let (mut predicted, mut costs, mut ignored_costs) = (vec![0.0; 4], vec![], vec![]);
    for _ in 0..runs {
        let mut entries: Vec<Vec<Complex<f64>>> = vec![vec![]; 2];
        let mut covariances = vec![];
        let mut inputs = vec![];
        for g in &clean {
            let u = Complex::new(1.0, 0.0) + noise(&mut d, var_u);
            for (i, entry) in entries.iter_mut().enumerate() {
                entry.push((g[(i, 0)] + noise(&mut d, var_y)) / u);
            }
            // the noise's covariances scaled by |U|² of the measured input
            let u2 = u.norm_sqr();
            covariances.push(output.map(|c| c / u2));
            inputs.push(InputNoise {
                cross: DVector::zeros(2),
                relative_variance: var_u / u2,
            });
        }
        let data = FrfMatrix::from_entries(w.clone(), 2, 1, entries, None)
            .unwrap()
            .with_covariances(vec![covariances])
            .unwrap();
        let ignored = fit_common_poles(&data, 4, &full()).unwrap();
        outputs_only.push(pair_theta(&ignored.model.poles));
        ignored_costs.push(ignored.cost);
        let data = data.with_input_noise(vec![inputs]).unwrap();
        let fit = fit_common_poles(&data, 4, &full()).unwrap();
        assert!(fit.correlated && matches!(fit.ml, MlOutcome::Kept { .. }));
        let p = fit.pole_covariance.as_ref().unwrap();
        for (t, s) in predicted.iter_mut().enumerate() {
            *s += p[(t, t)].sqrt() / runs as f64;
        }
        eiv.push(pair_theta(&fit.model.poles));
        costs.push(fit.cost);
    }
    let want = pair_theta(&truth.poles);
    let (mut eiv_var, mut ignored_var) = (0.0, 0.0);
    for (t, want) in want.iter().enumerate() {
        let (mean, sd) = mean_sd(&eiv, t);
        let ratio = sd / predicted[t];
        assert!(
            (0.75..1.25).contains(&ratio),
            "θ{t}: Monte Carlo sd {sd:.3e}, predicted {:.3e}",
            predicted[t]
        );
        let bias = (mean - want).abs() / (predicted[t] / (runs as f64).sqrt());
        assert!(bias < 3.0, "θ{t}: bias {bias:.1} standard errors");
        eiv_var += sd * sd;
        ignored_var += mean_sd(&outputs_only, t).1.powi(2);
    }
    let expected = (2.0 * 150.0 * 2.0 - 12.0) / 2.0;
    let mean = |c: &[f64]| c.iter().sum::<f64>() / runs as f64;
    let (cost, ignored_cost) = (mean(&costs), mean(&ignored_costs));
    eprintln!(
        "errors in variables: mean cost {cost:.1} (ignoring the input's noise {ignored_cost:.1}, \
         expected {expected:.1}); summed pole variance {eiv_var:.3e} vs {ignored_var:.3e}"
    );
    assert!(
        (cost / expected - 1.0).abs() < 0.1,
        "mean cost {cost:.1}, expected {expected:.1}"
    );
    assert!(ignored_cost > 2.0 * expected, "ignored: {ignored_cost:.1}");
    assert!(eiv_var < ignored_var, "{eiv_var:.3e} vs {ignored_var:.3e}");
}

/// Covariances of the wrong shape, not Hermitian, or with a zero variance are refused
/// naming the column and line; a band keeps the covariances of its lines.
#[test]
fn bad_covariances_are_errors_and_bands_keep_them() {
    let c = Complex::new(1.0, 0.0);
    let w = vec![1.0, 2.0, 3.0];
    let m = FrfMatrix::from_entries(w, 2, 1, vec![vec![c; 3]; 2], None).unwrap();
    let good = DMatrix::from_row_slice(2, 2, &[c, c * 0.5, c * 0.5, c]);
    let err = |cov: Vec<Vec<DMatrix<Complex<f64>>>>| {
        m.clone().with_covariances(cov).unwrap_err().to_string()
    };
    assert!(err(vec![]).contains("0 columns"));
    assert!(err(vec![vec![good.clone(); 2]]).contains("2 matrices for input 1"));
    let wrong = DMatrix::from_element(3, 3, c);
    assert!(err(vec![vec![good.clone(), good.clone(), wrong]]).contains("input 1, line 3"));
    let skew = DMatrix::from_row_slice(2, 2, &[c, c * 0.5, c * 0.4, c]);
    assert!(err(vec![vec![skew, good.clone(), good.clone()]]).contains("not conjugate"));
    let zero = DMatrix::from_row_slice(2, 2, &[c, c * 0.0, c * 0.0, c * 0.0]);
    assert!(err(vec![vec![good.clone(), zero, good.clone()]]).contains("not positive"));
    let nan = DMatrix::from_row_slice(2, 2, &[c, c * f64::NAN, c * f64::NAN, c]);
    assert!(err(vec![vec![good.clone(), good.clone(), nan]]).contains("not finite"));
    let mut covs = vec![good.clone(); 3];
    covs[2] = good.clone() * Complex::new(2.0, 0.0);
    let m = m.with_covariances(vec![covs]).unwrap();
    let band = m
        .band_hz(1.5 / std::f64::consts::TAU, 4.0 / std::f64::consts::TAU)
        .unwrap();
    assert_eq!(band.len(), 2);
    assert_eq!(band.covariance(0, 1).unwrap()[(0, 0)].re, 2.0);
    assert_eq!(band.entry(0, 0).noise().unwrap().var_y, vec![1.0, 2.0]);
}

/// The input's noise: refused before the outputs' covariances, with the wrong number of
/// columns, lines or outputs, a negative variance or a NaN (naming column and line); a
/// band keeps it; the errors-in-variables covariance at a response is C − c gᴴ − g cᴴ +
/// g gᴴ s.
#[test]
fn input_noise_is_checked_kept_by_bands_and_formed_at_a_response() {
    let c = Complex::new(1.0, 0.0);
    let w = vec![1.0, 2.0, 3.0];
    let plain = FrfMatrix::from_entries(w, 2, 1, vec![vec![c; 3]; 2], None).unwrap();
    let term = |s: f64| InputNoise {
        cross: DVector::from_vec(vec![c * 0.1, c * 0.0]),
        relative_variance: s,
    };
    let good = vec![vec![term(0.01), term(0.02), term(0.03)]];
    let before = plain.clone().with_input_noise(good.clone()).unwrap_err();
    assert!(before.to_string().contains("with_covariances"), "{before}");
    let m = plain
        .with_covariances(vec![vec![DMatrix::identity(2, 2); 3]])
        .unwrap();
    let err = |n: Vec<Vec<InputNoise<f64>>>| m.clone().with_input_noise(n).unwrap_err().to_string();
    assert!(err(vec![]).contains("0 columns"));
    assert!(err(vec![vec![term(0.01); 2]]).contains("2 terms for input 1"));
    let short = InputNoise {
        cross: DVector::zeros(1),
        relative_variance: 0.0,
    };
    assert!(err(vec![vec![term(0.01), short, term(0.01)]]).contains("input 1, line 2"));
    assert!(err(vec![vec![term(0.01), term(0.01), term(-1.0)]]).contains("input 1, line 3"));
    assert!(err(vec![vec![term(f64::NAN), term(0.01), term(0.01)]]).contains("line 1"));
    let m = m.with_input_noise(good).unwrap();
    assert!(m.has_input_noise());
    let band = m
        .band_hz(1.5 / std::f64::consts::TAU, 4.0 / std::f64::consts::TAU)
        .unwrap();
    assert_eq!(band.input_noise(0, 0).unwrap().relative_variance, 0.02);
    // at g = (2, i): C − c gᴴ − g cᴴ + g gᴴ s with c = (0.1, 0), s = 0.03 on line 3
    let g = DMatrix::from_column_slice(2, 1, &[c * 2.0, Complex::new(0.0, 1.0)]);
    let at = m.at_response(|_| g.clone()).unwrap();
    assert!(!at.has_input_noise());
    let cov = at.covariance(0, 2).unwrap();
    assert!(
        (cov[(0, 0)].re - (1.0 - 0.4 + 4.0 * 0.03)).abs() < 1e-12,
        "{cov}"
    );
    // (1, 0): −c₁ḡ₀ − g₁c̄₀ + g₁ḡ₀ s = −0 − 0.1i + 0.06i
    assert!(
        (cov[(1, 0)] - Complex::new(0.0, -0.1 + 0.06)).norm() < 1e-12,
        "{cov}"
    );
    assert_eq!(at.entry(0, 0).noise().unwrap().var_y[2], cov[(0, 0)].re);
}
