//! The delayed model G_M(θ_M, ω)·e^{−iωτ} (McKelvey section 4): analytic Jacobian against
//! finite differences, the forwarded transient and poles/zeros, noise-free recovery of θ and
//! τ (fixed continuous- and discrete-time cases, and quickcheck properties over random
//! stable systems and delays for f64 and f32), Monte Carlo of τ̂ against the predicted
//! standard deviation, bounds and bad input.
//!
//! Delays of random cases are drawn as d·π/ω_max with d ∈ [0, 8): d is the delay in
//! samples for a discrete-time grid reaching Nyquist, and the same phase span at the top of
//! the band for a continuous-time grid.
//!
//! The quickcheck generator is seeded (`FDID_QC_SEED` overrides it) so runs are
//! reproducible. Long variants are `#[ignore]`d: run them with
//! `cargo test --release --all-features --test suite model_delay:: -- --ignored`.

use crate::common;

use common::{
    Noise, RandomSystem, a_ct4, central_difference, dt_theta, logspace, random_ct_system,
    random_dt_system,
};
use fdid::criterion::MlProblem;
use fdid::estimate::{DelayStart, delay_start};
use fdid::model::{Output, remove_delay};
use fdid::prelude::*;
use fdid::problem::NonlinearProblem;
use nalgebra::DMatrix;
use quickcheck::{Arbitrary, Gen, TestResult};

// ---------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------

/// G_k e^{−iω_kτ}.
fn delayed(g: &[Complex<f64>], omega: &[f64], tau: f64) -> Vec<Complex<f64>> {
    g.iter()
        .zip(omega)
        .map(|(g, w)| g * Complex::new(0.0, -w * tau).exp())
        .collect()
}

/// Noise-free FRF data of `g` delayed by τ, in `T`.
fn frf_data<T: Real>(
    g: &[Complex<f64>],
    omega: &[f64],
    tau: f64,
    ts: Option<f64>,
) -> FrequencyData<T> {
    let y = delayed(g, omega, tau)
        .into_iter()
        .map(|v| Complex::new(T::lit(v.re), T::lit(v.im)))
        .collect();
    FrequencyData::from_frf(
        omega.iter().map(|w| T::lit(*w)).collect(),
        y,
        ts.map(T::lit),
    )
    .expect("valid data")
}

fn rel_rms<T: Real>(a: &[Complex<T>], b: &[Complex<f64>]) -> f64 {
    common::rel_rms(a, b)
}

/// max over parameters of max_k |J_kj − D_kj| / max_k |J_kj| for the complex Jacobian of
/// `model`'s response (real and imaginary parts stacked).
fn jacobian_error<M: ModelStructure<f64>>(model: &M, theta: &[f64], omega: &[f64]) -> f64 {
    let (n, p) = (omega.len(), model.n_params());
    let mut g = vec![Complex::new(0.0, 0.0); n];
    let mut jac = DMatrix::zeros(n, p);
    model.jacobian_into(theta, omega, &mut g, &mut jac);
    let g_direct = model.response(theta, omega);
    assert!(
        common::rel_rms(&g, &g_direct) < 1e-15,
        "jacobian_into writes G"
    );
    let stacked = |t: &[f64]| -> Vec<f64> {
        model
            .response(t, omega)
            .iter()
            .flat_map(|v| [v.re, v.im])
            .collect()
    };
    (0..p)
        .map(|j| {
            let d = central_difference(stacked, theta, j);
            let a: Vec<f64> = (0..n)
                .flat_map(|k| [jac[(k, j)].re, jac[(k, j)].im])
                .collect();
            let scale = a.iter().map(|v| v.abs()).fold(0.0, f64::max);
            let err = a
                .iter()
                .zip(&d)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
            err / scale
        })
        .fold(0.0, f64::max)
}

// ---------------------------------------------------------------------------------------
// Jacobian and model structure
// ---------------------------------------------------------------------------------------

/// ∂G/∂θ of the delayed model against finite differences (max relative error per column
/// ≤ 1e-6), for the polynomial and partial-fraction CT forms and a DT model, with delays
/// of a fraction of and several periods of the top frequency.
#[test]
fn jacobian_matches_finite_differences() {
    let omega = logspace(-1.0, 1.0, 60);
    let poly = Rational::polynomial(2, 1, &omega).unwrap();
    let pf = Rational::continuous(4, 2, &omega).unwrap();
    let ts = 0.1;
    let omega_dt: Vec<f64> = (1..=50).map(|k| k as f64 * 0.6).collect();
    let dt = Rational::discrete(3, 2, ts).unwrap();
    fn check<M: ModelStructure<f64>>(label: &str, inner: M, theta: &[f64], omega: &[f64]) {
        let m = Delayed::new(inner);
        for tau in [0.0, 0.037, 0.37, 2.6] {
            let theta = Delayed::<M>::theta(theta, tau);
            let e = jacobian_error(&m, &theta, omega);
            assert!(e < 1e-6, "{label}, τ = {tau}: Jacobian error {e:.2e}");
        }
    }
    check("poly", poly, &[0.4, 0.7, 1.0, 0.5], &omega);
    check("pf", pf, &[0.3, -0.2, 0.5, 0.1, 0.8, -0.4, 0.6], &omega);
    check("dt", dt, &[-0.5, 0.3, -0.1, 1.0, 0.4, 0.2], &omega_dt);
}

/// The ML residual Jacobian of a delayed model (what LM uses) against differences of the
/// residuals, with noise weights and spectra data (U ≠ 1).
#[test]
fn ml_residual_jacobian_matches_finite_differences() {
    let ts = 0.01;
    let omega: Vec<f64> = (1..=80).map(|k| k as f64 * 3.9).collect();
    let model = Delayed::new(Rational::discrete(2, 2, ts).unwrap());
    let mut noise = Noise::new(5);
    let u: Vec<Complex<f64>> = omega.iter().map(|_| noise.complex(1.0)).collect();
    let y: Vec<Complex<f64>> = omega.iter().map(|_| noise.complex(1.0)).collect();
    let var: Vec<f64> = omega.iter().map(|w| 0.01 * (1.0 + w / 100.0)).collect();
    let data = FrequencyData::new(omega, y, u, Some(ts))
        .unwrap()
        .with_noise(NoiseVariances::output_only(var))
        .unwrap();
    let problem = MlProblem::new(&model, &data, Default::default()).unwrap();
    let theta = vec![-0.6, 0.3, 1.0, 0.5, -0.2, 0.0263];
    let m = problem.n_residuals();
    let mut r = vec![0.0; m];
    let mut jac = DMatrix::zeros(m, theta.len());
    assert!(problem.jacobian_into(&theta, &mut r, &mut jac));
    for j in 0..theta.len() {
        let d = central_difference(
            |t| {
                let mut r = vec![0.0; m];
                problem.residuals_into(t, &mut r);
                r
            },
            &theta,
            j,
        );
        let scale = jac.column(j).amax();
        let err = (0..m)
            .map(|k| (jac[(k, j)] - d[k]).abs())
            .fold(0.0, f64::max);
        assert!(err <= 1e-6 * scale, "column {j}: {err:.2e} vs {scale:.2e}");
    }
}

/// A first-order model with a transient term T = c/(1 + iω) (θ = [k, c]), to check that
/// the delayed model forwards T undelayed with a zero τ column.
#[derive(Debug, Clone)]
struct WithTransient;

impl ModelStructure<f64> for WithTransient {
    fn n_params(&self) -> usize {
        2
    }
    fn response_into(&self, theta: &[f64], omega: &[f64], out: &mut [Complex<f64>]) {
        for (w, o) in omega.iter().zip(out.iter_mut()) {
            *o = theta[0] / Complex::new(1.0, *w);
        }
    }
    fn jacobian_into(
        &self,
        theta: &[f64],
        omega: &[f64],
        g: &mut [Complex<f64>],
        jac: &mut DMatrix<Complex<f64>>,
    ) {
        for (k, w) in omega.iter().enumerate() {
            let d = Complex::new(1.0, 0.0) / Complex::new(1.0, *w);
            g[k] = d * theta[0];
            jac[(k, 0)] = d;
            jac[(k, 1)] = Complex::new(0.0, 0.0);
        }
    }
    fn transient_into(
        &self,
        theta: &[f64],
        omega: &[f64],
        t: &mut [Complex<f64>],
        jac: Option<&mut DMatrix<Complex<f64>>>,
    ) -> bool {
        let mut jac = jac;
        for (k, w) in omega.iter().enumerate() {
            let d = Complex::new(1.0, 0.0) / Complex::new(1.0, *w);
            t[k] = d * theta[1];
            if let Some(j) = jac.as_deref_mut() {
                j[(k, 0)] = Complex::new(0.0, 0.0);
                j[(k, 1)] = d;
            }
        }
        true
    }
}

/// Ŷ = G e^{−iωτ} U + T with T not delayed; ∂Ŷ/∂τ = −iω G U, ∂Ŷ/∂c = ∂T/∂c.
#[test]
fn transient_is_forwarded_undelayed() {
    let omega = vec![0.5, 1.0, 2.0, 4.0];
    let u: Vec<Complex<f64>> = omega.iter().map(|w| Complex::new(1.0, *w * 0.1)).collect();
    let data = FrequencyData::new(omega.clone(), u.clone(), u.clone(), None).unwrap();
    let model = Delayed::new(WithTransient);
    let (k, c, tau) = (2.0, 0.7, 0.3);
    let mut out = Output::new(data.len(), 3);
    assert!(out.evaluate(&model, &[k, c, tau], &data, true));
    for (i, w) in omega.iter().enumerate() {
        let d = Complex::new(1.0, 0.0) / Complex::new(1.0, *w);
        let g = d * k * Complex::new(0.0, -w * tau).exp();
        let yhat = g * u[i] + d * c;
        assert!((out.yhat[i] - yhat).norm() < 1e-14);
        assert!((out.dyhat[(i, 2)] - Complex::new(0.0, -w) * g * u[i]).norm() < 1e-14);
        assert!((out.dyhat[(i, 1)] - d).norm() < 1e-14);
    }
    // a model without transient stays without one
    let plain = Delayed::new(Rational::polynomial(1, 0, &omega).unwrap());
    let mut t = vec![Complex::new(0.0, 0.0); 4];
    let mut jac = DMatrix::zeros(4, 3);
    assert!(!plain.transient_into(&[1.0, 1.0, 0.1], &omega, &mut t, Some(&mut jac)));
}

/// Accessors and the delegation of poles, zeros and gain.
#[test]
fn accessors_and_poles_zeros_delegate() {
    let ts = 0.1;
    let inner = Rational::discrete(2, 1, ts).unwrap();
    let model = Delayed::new(inner.clone());
    let theta_m = vec![-0.9, 0.2, 0.5, 0.3];
    let theta = Delayed::<()>::theta(&theta_m, 0.26);
    assert_eq!(ModelStructure::<f64>::n_params(&model), 5);
    assert_eq!(model.delay(&theta), Some(0.26));
    assert_eq!(model.delay(&theta_m), None);
    assert_eq!(model.inner_theta(&theta), &theta_m[..]);
    assert_eq!(model.inner(), &inner);
    assert_eq!(model.poles(&theta).unwrap(), inner.poles(&theta_m).unwrap());
    assert_eq!(model.zeros(&theta).unwrap(), inner.zeros(&theta_m).unwrap());
    assert_eq!(model.gain(&theta), inner.gain(&theta_m));
    // |G| is unchanged by the delay, the phase turns by −ωτ
    let omega = [1.0, 5.0, 10.0];
    let g = model.response(&theta, &omega);
    let g0 = inner.response(&theta_m, &omega);
    for ((a, b), w) in g.iter().zip(&g0).zip(&omega) {
        assert!((a - b * Complex::new(0.0, -w * 0.26).exp()).norm() < 1e-15);
    }
    // the data checks of the inner model are forwarded (Nyquist of Ts = 0.1 is 31.4 rad/s)
    let data =
        FrequencyData::from_frf(vec![1.0, 40.0], vec![Complex::new(1.0, 0.0); 2], None).unwrap();
    assert!(matches!(
        model.check_data(&data),
        Err(FdidError::InvalidArgument { name: "omega", .. })
    ));
    // and the delay parameter counts: 2 lines = 4 equations < 5 parameters
    let data =
        FrequencyData::from_frf(vec![1.0, 2.0], vec![Complex::new(1.0, 0.0); 2], None).unwrap();
    assert!(matches!(
        model.check_data(&data),
        Err(FdidError::TooFewFrequencies { parameters: 5, .. })
    ));
}

/// Removing a delay turns Y (and cov_yu) by e^{iωτ} and keeps U and the variances.
#[test]
fn remove_delay_turns_output_and_covariance() {
    let omega = vec![1.0, 2.0];
    let y = vec![Complex::new(1.0, 0.5), Complex::new(-0.3, 2.0)];
    let u = vec![Complex::new(0.5, 0.0), Complex::new(0.0, 1.0)];
    let noise = NoiseVariances {
        var_y: vec![0.1, 0.2],
        var_u: vec![0.01, 0.02],
        cov_yu: vec![Complex::new(0.01, 0.0), Complex::new(0.0, 0.02)],
    };
    let data = FrequencyData::new(omega.clone(), y.clone(), u.clone(), None)
        .unwrap()
        .with_noise(noise.clone())
        .unwrap();
    let out = remove_delay(&data, 0.4).unwrap();
    for k in 0..2 {
        let turn = Complex::new(0.0, omega[k] * 0.4).exp();
        assert!((out.y()[k] - y[k] * turn).norm() < 1e-15);
        assert_eq!(out.u()[k], u[k]);
        let n = out.noise().unwrap();
        assert_eq!(n.var_y[k], noise.var_y[k]);
        assert_eq!(n.var_u[k], noise.var_u[k]);
        assert!((n.cov_yu[k] - noise.cov_yu[k] * turn).norm() < 1e-15);
    }
    assert!(matches!(
        remove_delay(&data, f64::NAN),
        Err(FdidError::NonFinite { what: "delay", .. })
    ));
}

// ---------------------------------------------------------------------------------------
// Noise-free recovery, fixed cases
// ---------------------------------------------------------------------------------------

/// a_ct4 (two modes, ζ = 0.02 and 0.05) with τ = 0.37 s on 400 lines over 0.1–10 rad/s:
/// τ and the FRF recovered to 1e-9, poles to 1e-9.
#[test]
fn recovers_ct_a_ct4_with_delay() {
    let omega = logspace(-1.0, 1.0, 400);
    let sys = a_ct4();
    let tau = 0.37;
    let data = frf_data::<f64>(&sys.frf(&omega), &omega, tau, None);
    let model = Rational::continuous(4, 2, data.omega()).unwrap();
    let fit = fit_delayed(&Pipeline::default(), &model, &data).unwrap();
    let tau_hat = fit.model().delay(fit.theta()).unwrap();
    assert!((tau_hat - tau).abs() < 1e-9, "τ̂ = {tau_hat}");
    let e = rel_rms(fit.response(), &delayed(&sys.frf(&omega), &omega, tau));
    assert!(e < 1e-9, "FRF error {e:.2e}");
    let mut poles = fit.poles().unwrap();
    let mut truth = sys.poles();
    for p in [&mut poles, &mut truth] {
        p.sort_by(|a, b| a.im.total_cmp(&b.im));
    }
    for (p, q) in poles.iter().zip(&truth) {
        assert!((p - q).norm() < 1e-9 * q.norm(), "pole {p} vs {q}");
    }
    let names: Vec<String> = fit.stages().iter().map(|s| s.kind.name()).collect();
    // the search's best round: its delay-free fit (Levy, then SK unless that round was
    // Levy alone), then the joint ML continued from it
    assert_eq!(names.first().map(String::as_str), Some("delay"));
    assert_eq!(names.last().map(String::as_str), Some("ml-delayed"));
    let inner = &names[1..names.len() - 1];
    assert!(
        inner == ["levy", "sk"] || inner == ["levy"],
        "stages {names:?}"
    );
    assert!(fit.stages()[0].solution.theta[0].is_finite());
}

/// A discrete-time system (Ts = 0.1 s) with a fractional delay of 2.6 samples: θ_M
/// (the coefficients of B/A) and τ recovered to 1e-9.
#[test]
fn recovers_dt_fractional_delay() {
    let sys = random_dt_system(1, 3, 2);
    let ts = sys.zpk.ts.unwrap();
    let tau = 2.6 * ts;
    let data = frf_data::<f64>(&sys.frf(), &sys.omega, tau, Some(ts));
    let model = Rational::discrete(3, 2, ts).unwrap();
    let fit = fit_delayed(&Pipeline::default(), &model, &data).unwrap();
    let tau_hat = fit.model().delay(fit.theta()).unwrap();
    assert!((tau_hat - tau).abs() < 1e-9 * ts, "τ̂/Ts = {}", tau_hat / ts);
    let truth = dt_theta(&sys);
    for (a, b) in fit.model().inner_theta(fit.theta()).iter().zip(&truth) {
        assert!((a - b).abs() < 1e-9, "θ {a} vs {b}");
    }
}

/// Spectra data (U ≠ 1) with noise variances attached and a delay of 6.3 samples.
#[test]
fn recovers_dt_spectra_with_noise_variances_attached() {
    let sys = random_dt_system(7, 2, 2);
    let ts = sys.zpk.ts.unwrap();
    let tau = 6.3 * ts;
    let mut noise = Noise::new(9);
    let u: Vec<Complex<f64>> = sys.omega.iter().map(|_| noise.complex(1.0)).collect();
    let g = delayed(&sys.frf(), &sys.omega, tau);
    let y = g.iter().zip(&u).map(|(g, u)| g * u).collect();
    let var: Vec<f64> = sys.omega.iter().map(|w| 1e-4 * (1.0 + w * ts)).collect();
    let data = FrequencyData::new(sys.omega.clone(), y, u, Some(ts))
        .unwrap()
        .with_noise(NoiseVariances::output_only(var))
        .unwrap();
    let model = Rational::discrete(2, 2, ts).unwrap();
    let fit = fit_delayed(&Pipeline::default(), &model, &data).unwrap();
    let tau_hat = fit.model().delay(fit.theta()).unwrap();
    assert!((tau_hat - tau).abs() < 1e-9 * ts, "τ̂/Ts = {}", tau_hat / ts);
    assert!(fit.noise_known());
}

/// Without delay the delayed fit finds τ = 0.
#[test]
fn recovers_zero_delay() {
    let sys = random_ct_system(3, 3, 2);
    let data = frf_data::<f64>(&sys.frf(), &sys.omega, 0.0, None);
    let model = Rational::continuous(3, 2, data.omega()).unwrap();
    let fit = fit_delayed(&Pipeline::default(), &model, &data).unwrap();
    let w_max = sys.omega[sys.omega.len() - 1];
    let tau_hat = fit.model().delay(fit.theta()).unwrap();
    assert!(tau_hat.abs() < 1e-9 / w_max, "τ̂ = {tau_hat}");
}

// ---------------------------------------------------------------------------------------
// Noise-free recovery, quickcheck over random systems and delays
// ---------------------------------------------------------------------------------------

/// A random system (CT or DT by `DT`), orders na ≤ MAX, and a delay d ∈ [0, 8) in units
/// of π/ω_max.
#[derive(Debug, Clone, Copy)]
struct Case<const DT: bool, const MAX: usize> {
    seed: u64,
    na: usize,
    nb: usize,
    d: f64,
}

impl<const DT: bool, const MAX: usize> Arbitrary for Case<DT, MAX> {
    fn arbitrary(g: &mut Gen) -> Self {
        let seed = u64::arbitrary(g);
        let na = 1 + (u32::arbitrary(g) as usize) % MAX;
        let nb = if DT {
            (u32::arbitrary(g) as usize) % (na + 1)
        } else {
            // the partial-fraction form (nb ≥ na − 1), the one that reaches 1e-9 at all
            // orders (see estimators_recovery.rs)
            na - (u32::arbitrary(g) as usize) % 2
        };
        let d = (u32::arbitrary(g) % 8000) as f64 / 1000.0;
        Self { seed, na, nb, d }
    }
}

impl<const DT: bool, const MAX: usize> Case<DT, MAX> {
    fn system(&self) -> RandomSystem {
        if DT {
            random_dt_system(self.seed, self.na, self.nb)
        } else {
            random_ct_system(self.seed, self.na, self.nb)
        }
    }
}

/// The recovery errors of a case: (|τ̂ − τ|·ω_max/π, FRF relative RMS error).
fn recovery<T: Real, const DT: bool, const MAX: usize>(
    case: &Case<DT, MAX>,
) -> fdid::Result<(f64, f64)> {
    let sys = case.system();
    let w_max = sys.omega[sys.omega.len() - 1];
    let unit = std::f64::consts::PI / w_max;
    let tau = case.d * unit;
    let ts = sys.zpk.ts;
    let data = frf_data::<T>(&sys.frf(), &sys.omega, tau, ts);
    let model = match ts {
        Some(ts) => Rational::discrete(sys.na, sys.nb, T::lit(ts))?,
        None => Rational::continuous(sys.na, sys.nb, data.omega())?,
    };
    let fit = fit_delayed(&Pipeline::default(), &model, &data)?;
    let tau_hat = fit.model().delay(fit.theta()).unwrap().to_f64_lossless();
    Ok((
        (tau_hat - tau).abs() / unit,
        rel_rms(fit.response(), &delayed(&sys.frf(), &sys.omega, tau)),
    ))
}

fn tolerance<T: Real>() -> f64 {
    if T::default_epsilon().to_f64_lossless() > 1e-10 {
        1e-3
    } else {
        1e-9
    }
}

/// Property: τ (in units of π/ω_max) and the FRF recovered to the tolerance of `T`.
fn recovers<T: Real, const DT: bool, const MAX: usize>(case: Case<DT, MAX>) -> TestResult {
    let tol = tolerance::<T>();
    match recovery::<T, DT, MAX>(&case) {
        Ok((et, eg)) if et < tol && eg < tol => TestResult::passed(),
        Ok((et, eg)) => TestResult::error(format!(
            "{case:?}: τ error {et:.2e} (units of π/ω_max), FRF error {eg:.2e}"
        )),
        Err(e) => TestResult::error(format!("{case:?}: {e}")),
    }
}

/// The generator's seed: `seed`, or `FDID_QC_SEED` when set.
fn qc_seed(seed: u64) -> u64 {
    std::env::var("FDID_QC_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(seed)
}

/// Draws `cases` cases from quickcheck's generator (seeded, see [`qc_seed`]) and checks
/// that at most `allowed` of them fail [`recovers`], printing the failures. The search for
/// the delay is global and heuristic: the survey (`survey`) finds about 0.1 % of random
/// cases in f32 (none in f64 over 2 000) where it ends a fraction of π/ω_max or one sample
/// off, so the fast checks allow one failure (`quickcheck_all_recover` is the strict
/// property).
fn check_rate<T: Real, const DT: bool, const MAX: usize>(seed: u64, cases: usize, allowed: usize) {
    let mut g = Gen::from_size_and_seed(100, qc_seed(seed));
    let failures: Vec<String> = (0..cases)
        .filter_map(|_| {
            let case = Case::<DT, MAX>::arbitrary(&mut g);
            recovers::<T, DT, MAX>(case)
                .is_failure()
                .then(|| format!("{case:?}"))
        })
        .collect();
    for f in &failures {
        eprintln!("failed: {f}");
    }
    assert!(
        failures.len() <= allowed,
        "{} of {cases} cases failed: {failures:?}",
        failures.len()
    );
}

/// CT (partial fractions), f64, orders 1–4: at most 1 of 20 cases fails.
#[test]
fn random_systems_recover_ct_f64() {
    check_rate::<f64, false, 4>(11, 20, 1);
}

/// DT, f64, orders 1–4: at most 1 of 20 cases fails.
#[test]
fn random_systems_recover_dt_f64() {
    check_rate::<f64, true, 4>(12, 20, 1);
}

/// CT (partial fractions), f32, orders 1–3: at most 1 of 20 cases fails.
#[test]
fn random_systems_recover_ct_f32() {
    check_rate::<f32, false, 3>(13, 20, 1);
}

/// DT, f32, orders 1–3: at most 1 of 20 cases fails.
#[test]
fn random_systems_recover_dt_f32() {
    check_rate::<f32, true, 3>(14, 20, 1);
}

/// The strict property (every case recovered) as quickcheck tests over 100 cases for CT
/// and DT, f64. Run with
/// `cargo test --release --all-features --test suite model_delay::quickcheck_all -- --ignored`.
#[test]
#[ignore]
fn quickcheck_all_recover() {
    crate::common::seeded(qc_seed(11))
        .tests(100)
        .max_tests(100)
        .quickcheck(recovers::<f64, false, 4> as fn(Case<false, 4>) -> TestResult);
    crate::common::seeded(qc_seed(12))
        .tests(100)
        .max_tests(100)
        .quickcheck(recovers::<f64, true, 4> as fn(Case<true, 4>) -> TestResult);
}

/// A former failure of the search (CT, order 3, d = 3.862): τ̂ ended 0.386 π/ω_max off,
/// FRF error 6.1e-3.
#[test]
fn ct_f64_known_failure() {
    let case: Case<false, 4> = Case {
        seed: 9_727_820_056_472_191_907,
        na: 3,
        nb: 3,
        d: 3.862,
    };
    let r = recovers::<f64, false, 4>(case);
    assert!(!r.is_failure(), "{r:?}");
}

/// A former failure of the search (DT, order 3, 5.926 samples): τ̂ one sample off, FRF
/// error 2.0e-2.
#[test]
fn dt_f64_known_failure() {
    let case: Case<true, 4> = Case {
        seed: 12_356_274_173_791_829_712,
        na: 3,
        nb: 1,
        d: 5.926,
    };
    let r = recovers::<f64, true, 4>(case);
    assert!(!r.is_failure(), "{r:?}");
}

/// Survey: failure counts over 500 random noise-free cases per kind (CT and DT, f64 and
/// f32, orders 1–6, delays of 0–8 units of π/ω_max; prints the failures), at most one
/// failure per kind (the right minimum on ≥ 499 of 500). Run with
/// `cargo test --release --all-features --test suite model_delay::survey -- --ignored --nocapture`
/// (about a minute; `FDID_QC_SEED` changes the cases).
#[test]
#[ignore]
fn survey() {
    fn run<T: Real, const DT: bool>(label: &str) -> usize {
        let mut g = Gen::from_size_and_seed(100, qc_seed(99));
        let (mut fails, mut worst_t, mut worst_g) = (0, 0.0f64, 0.0f64);
        let t = std::time::Instant::now();
        for _ in 0..500 {
            let case = Case::<DT, 6>::arbitrary(&mut g);
            match recovery::<T, DT, 6>(&case) {
                Ok((et, eg)) => {
                    if et >= tolerance::<T>() || eg >= tolerance::<T>() {
                        fails += 1;
                        eprintln!("  {label} {case:?}: τ {et:.2e}, FRF {eg:.2e}");
                    } else {
                        worst_t = worst_t.max(et);
                        worst_g = worst_g.max(eg);
                    }
                }
                Err(e) => {
                    fails += 1;
                    eprintln!("  {label} {case:?}: {e}");
                }
            }
        }
        eprintln!(
            "{label}: {fails}/500 failures; passing worst τ {worst_t:.1e}, FRF {worst_g:.1e}; {:.1?}",
            t.elapsed()
        );
        fails
    }
    let fails = [
        run::<f64, false>("CT f64"),
        run::<f64, true>("DT f64"),
        run::<f32, false>("CT f32"),
        run::<f32, true>("DT f32"),
    ];
    assert!(fails.iter().all(|f| *f <= 1), "failures per kind {fails:?}");
}

// ---------------------------------------------------------------------------------------
// Monte Carlo: τ̂ unbiased, its spread as predicted
// ---------------------------------------------------------------------------------------

/// Standard normal quantile for a two-sided 99.9 % interval.
const Z999: f64 = 3.2905;

/// `runs` fits of a_ct4 delayed by τ = 0.37 s on 200 lines over 0.1–10 rad/s with output
/// noise of variance 1e-3·(RMS |G|)² attached to the data; returns (τ̂, predicted std of
/// τ̂) per run.
fn monte_carlo(runs: usize, seed: u64) -> Vec<(f64, f64)> {
    let omega = logspace(-1.0, 1.0, 200);
    let g0 = delayed(&a_ct4().frf(&omega), &omega, 0.37);
    let rms = (g0.iter().map(|g| g.norm_sqr()).sum::<f64>() / g0.len() as f64).sqrt();
    let var = 1e-3 * rms * rms;
    let model = Rational::continuous(4, 2, &omega).unwrap();
    let mut noise = Noise::new(seed);
    (0..runs)
        .map(|_| {
            let y = g0.iter().map(|g| g + noise.complex(var)).collect();
            let data = FrequencyData::from_frf(omega.clone(), y, None)
                .unwrap()
                .with_noise(NoiseVariances::output_only(vec![var; omega.len()]))
                .unwrap();
            let fit = fit_delayed(&Pipeline::default(), &model, &data).unwrap();
            let p = fit.theta().len() - 1;
            (fit.theta()[p], fit.theta_std().unwrap()[p])
        })
        .collect()
}

/// One Monte Carlo run: (τ̂, predicted std of τ̂).
type Run = (f64, f64);

/// (bias/standard error, sample std / mean predicted std).
fn mc_figures(runs: &[(f64, f64)], tau: f64) -> (f64, f64) {
    let n = runs.len() as f64;
    let mean = runs.iter().map(|r| r.0).sum::<f64>() / n;
    let var = runs.iter().map(|r| (r.0 - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let predicted = runs.iter().map(|r| r.1).sum::<f64>() / n;
    ((mean - tau) / (var / n).sqrt(), var.sqrt() / predicted)
}

/// 50 runs: the bias of τ̂ within 3.3 standard errors (99.9 %), and its sample std within
/// 25 % of the predicted `theta_std` (the 99.9 % interval of a 50-run sample std is about
/// ±26 %).
#[test]
fn monte_carlo_delay_fast() {
    let runs = monte_carlo(50, 21);
    let (bias, ratio) = mc_figures(&runs, 0.37);
    eprintln!("τ̂: bias {bias:.2} standard errors, sample/predicted std {ratio:.3}");
    assert!(bias.abs() < Z999, "bias {bias:.2} standard errors");
    assert!((ratio - 1.0).abs() < 0.25, "std ratio {ratio:.3}");
}

/// 500 runs. The search ends in a wrong local minimum — τ̂ more than 5 median predicted
/// standard deviations off — in a few of them (seed 22: 4 runs; one with τ̂ = 0.627 s, three
/// with degenerate inner models whose own predicted std is 0.2–0.6 s); with them the
/// sample std is 4.3 times the predicted one. The assertions: at most 1 % such runs, and
/// over the other runs a bias within 3.3 standard errors and a std ratio within 10 %. Run
/// with
/// `cargo test --release --all-features --test suite model_delay::monte_carlo_delay_long -- --ignored --nocapture`.
#[test]
#[ignore]
fn monte_carlo_delay_long() {
    let runs = monte_carlo(500, 22);
    let mut sds: Vec<f64> = runs.iter().map(|r| r.1).collect();
    sds.sort_by(f64::total_cmp);
    let typical = sds[sds.len() / 2];
    let (inliers, outliers): (Vec<Run>, Vec<Run>) = runs
        .iter()
        .partition(|(t, _)| (t - 0.37).abs() <= 5.0 * typical);
    eprintln!("median predicted std {typical:.3e}; outliers (τ̂, predicted std): {outliers:?}");
    let (bias, ratio) = mc_figures(&runs, 0.37);
    eprintln!("all runs: bias {bias:.2} standard errors, sample/predicted std {ratio:.3}");
    let (bias, ratio) = mc_figures(&inliers, 0.37);
    eprintln!("without outliers: bias {bias:.2} standard errors, sample/predicted std {ratio:.3}");
    assert!(outliers.len() <= 5, "{} outliers", outliers.len());
    assert!(bias.abs() < Z999, "bias {bias:.2} standard errors");
    assert!((ratio - 1.0).abs() < 0.10, "std ratio {ratio:.3}");
}

// ---------------------------------------------------------------------------------------
// Bounds and bad input
// ---------------------------------------------------------------------------------------

#[test]
fn bad_bounds_are_typed_errors() {
    let m = || Delayed::new(Rational::<f64>::discrete(1, 0, 0.1).unwrap());
    match m().with_bounds(-0.1, 1.0) {
        Err(FdidError::InvalidArgument { name, value, .. }) => {
            assert_eq!(name, "delay lower bound");
            assert_eq!(value, "-0.1");
        }
        other => panic!("{other:?}"),
    }
    match m().with_bounds(0.0, -2.0) {
        Err(FdidError::InvalidArgument { name, value, .. }) => {
            assert_eq!(name, "delay upper bound");
            assert_eq!(value, "-2");
        }
        other => panic!("{other:?}"),
    }
    for (lo, hi) in [(1.0, 1.0), (2.0, 1.0)] {
        assert!(matches!(
            m().with_bounds(lo, hi),
            Err(FdidError::InvalidArgument {
                name: "delay bounds",
                ..
            })
        ));
    }
    for (lo, hi) in [(f64::NAN, 1.0), (0.0, f64::NAN), (0.0, f64::INFINITY)] {
        assert!(matches!(
            m().with_bounds(lo, hi),
            Err(FdidError::InvalidArgument { .. })
        ));
    }
    assert_eq!(
        m().with_bounds(0.0, 0.5).unwrap().bounds(),
        Some((0.0, 0.5))
    );
    assert!(m().check_delay(f64::NAN).is_err());
}

/// Bounds that contain the delay confine the search and give the same estimate; bounds
/// that exclude it make the fit fail with an error naming τ̂.
#[test]
fn bounds_confine_the_search_and_reject_outside_estimates() {
    let sys = random_dt_system(2, 2, 1);
    let ts = sys.zpk.ts.unwrap();
    let tau = 5.3 * ts;
    let data = frf_data::<f64>(&sys.frf(), &sys.omega, tau, Some(ts));
    let inner = Rational::discrete(2, 1, ts).unwrap();
    let inside = Delayed::new(inner.clone())
        .with_bounds(4.0 * ts, 7.0 * ts)
        .unwrap();
    let start: DelayStart<f64> = delay_start(&Pipeline::default(), &inside, &data).unwrap();
    assert!(start.tau >= 4.0 * ts && start.tau <= 7.0 * ts);
    let fit = inside.fit(&Pipeline::default(), &data).unwrap();
    assert!((fit.model().delay(fit.theta()).unwrap() - tau).abs() < 1e-9 * ts);
    assert_eq!(fit.model().bounds(), Some((4.0 * ts, 7.0 * ts)));
    // the true delay lies above the bounds: the start is clamped, ML leaves them
    let outside = Delayed::new(inner).with_bounds(0.0, 2.0 * ts).unwrap();
    match outside.fit(&Pipeline::default(), &data) {
        Err(FdidError::InvalidArgument { name: "delay", .. }) => {}
        other => panic!("expected an out-of-bounds error, got {other:?}"),
    }
}

/// A delay at the lower bound: G = 0.5 z⁻¹/((1 − 0.8 z⁻¹)(1 − 0.5 z⁻¹)) fitted as a
/// second-order model with a first-order numerator and a delay in [0, 2N]. Both τ ≈ 0 (the
/// numerator's z⁻¹ term) and τ ≈ 1 (its constant term) fit to the noise; with noise the ML
/// at τ ≈ 0 often wants a slightly negative delay. The search ranks such a candidate
/// below every one within the bounds, so the fit ends within them instead of failing.
#[test]
fn a_candidate_leaving_the_bounds_gives_way_to_one_within_them() {
    let n = 128;
    let model = Delayed::new(Rational::<f64>::discrete(2, 1, 1.0).unwrap())
        .with_bounds(0.0, 2.0 * n as f64)
        .unwrap();
    for seed in 0..10 {
        let data = common::second_order_lines(0.5, 1e-4, seed);
        assert_eq!(data.len(), n);
        let fit = model
            .fit(&Pipeline::default(), &data)
            .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let tau = fit.model().delay(fit.theta()).unwrap();
        assert!(
            (0.0..0.05).contains(&tau) || (tau - 1.0).abs() < 0.05,
            "seed {seed}: τ̂ {tau}"
        );
        // at the noise level: the 99.95 % quantile of the cost
        let bound = n as f64 + 3.3 * (n as f64).sqrt();
        assert!(fit.cost() < bound, "seed {seed}: cost {}", fit.cost());
    }
}

#[test]
fn no_positive_frequency_and_zero_input_are_typed_errors() {
    let model = Delayed::new(Rational::<f64>::polynomial(0, 0, &[0.0, 1.0]).unwrap());
    let data =
        FrequencyData::from_frf(vec![0.0, 0.0], vec![Complex::new(1.0, 0.0); 2], None).unwrap();
    assert!(matches!(
        delay_start(&Pipeline::default(), &model, &data),
        Err(FdidError::InvalidArgument { name: "omega", .. })
    ));
    let data = FrequencyData::new(
        vec![1.0, 2.0, 3.0],
        vec![Complex::new(1.0, 0.0); 3],
        vec![
            Complex::new(1.0, 0.0),
            Complex::new(0.0, 0.0),
            Complex::new(1.0, 0.0),
        ],
        None,
    )
    .unwrap();
    assert!(matches!(
        fit_delayed(&Pipeline::default(), model.inner(), &data),
        Err(FdidError::ZeroInput { index: 1, .. })
    ));
}

#[cfg(feature = "serde")]
#[test]
fn serde_round_trip() {
    let model = Delayed::new(Rational::<f64>::discrete(2, 1, 0.1).unwrap())
        .with_bounds(0.0, 1.0)
        .unwrap();
    let text = serde_json::to_string(&model).unwrap();
    let back: Delayed<Rational<f64>> = serde_json::from_str(&text).unwrap();
    assert_eq!(back, model);
}

/// A delay outside the bounds is refused with the fact, not with advice: a negative one
/// (the output leads the input), one below or above the bounds with the bound.
#[test]
fn a_delay_outside_the_bounds_is_named_as_a_fact() {
    let model = Delayed::new(Rational::discrete(2, 2, 1.0).unwrap())
        .with_bounds(0.0, 1680.0)
        .unwrap();
    let err = model.check_delay(-3.0f64).unwrap_err().to_string();
    assert!(err.contains("-3 s") && err.contains("negative"), "{err}");
    assert!(!err.contains("widen"), "{err}");
    let err = model.check_delay(2000.0f64).unwrap_err().to_string();
    assert!(err.contains("2000 s") && err.contains("1680"), "{err}");
    let model = Delayed::new(Rational::discrete(2, 2, 1.0).unwrap())
        .with_bounds(1.0, 5.0)
        .unwrap();
    let err = model.check_delay(0.5f64).unwrap_err().to_string();
    assert!(err.contains("smallest delay allowed, 1 s"), "{err}");
    assert!(model.check_delay(2.0f64).is_ok());
}
