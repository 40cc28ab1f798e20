//! Analytic Jacobians against central finite differences (f64):
//! - `Rational::jacobian_into` (∂G/∂θ, complex) in s — both continuous-time forms, the
//!   polynomial one (`Rational::polynomial`) and the partial-fraction one
//!   (`Rational::partial_fractions`, which `Rational::continuous` picks for nb ≥ na − 1) —
//!   and in z;
//! - the ML residual Jacobian `MlProblem::jacobian_into` (∂r/∂θ of the real-stacked,
//!   weighted residuals r_k = (Y_k − G_θ U_k)/σ_k) against differences of
//!   `residuals_into`.
//!
//! Criterion: for every parameter j, max_k |J_kj − D_kj| ≤ 1e-6 · max_k |J_kj|, with D the
//! central difference Richardson-extrapolated over two steps,
//! R(h) = (4 D(h/2) − D(h)) / 3, D(h) = (f(θ + h e_j) − f(θ − h e_j)) / 2h.
//! The step is chosen per parameter without looking at the analytic Jacobian, as numerical
//! differentiation libraries do: among h = 10⁻¹ … 10⁻⁷ · max(1, |θ_j|) the one whose
//! estimate changes least towards the next smaller step, max_k |R(h) − R(h/10)|. (A fixed
//! step fails either way: round-off ε·|G|/h swamps a column much smaller than G, e.g. a
//! basis pole far above the band, and truncation swamps columns of lightly damped poles.)

use crate::common;

use common::{central_difference, dt_theta, random_dt_system};
use fdid::criterion::MlProblem;
use fdid::prelude::*;
use fdid::problem::NonlinearProblem;
use nalgebra::DMatrix;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

const REL_TOL: f64 = 1e-6;
const CASES: u64 = 200;

/// A random CT grid: 1–3 decades from 10^U(−2, 2) rad/s, 5–120 lines, log-spaced or
/// log-uniform random (sorted).
fn random_ct_grid(rng: &mut StdRng) -> Vec<f64> {
    let lo: f64 = rng.gen_range(-2.0..2.0);
    let hi = lo + rng.gen_range(1.0..3.0);
    let n = rng.gen_range(5..=120usize);
    let mut w: Vec<f64> = if rng.gen_bool(0.5) {
        common::logspace(lo, hi, n)
    } else {
        (0..n).map(|_| 10f64.powf(rng.gen_range(lo..hi))).collect()
    };
    w.sort_by(|a, b| a.partial_cmp(b).unwrap());
    w.dedup();
    w
}

/// The two continuous-time forms.
#[derive(Debug, Clone, Copy)]
enum CtForm {
    Polynomial,
    PartialFractions,
}

/// A random CT model on a random grid, with a random θ ∈ [−2, 2]ᵖ whose denominator stays
/// away from zero on the grid (min |A| ≥ 1e-2 · max |A|; redrawn otherwise):
/// - polynomial: na 1..=8, nb 0..=na+1 (improper allowed);
/// - partial fractions: random stable basis poles (⌊na/2⌋ pairs with ζ ∈ [0.01, 0.7] and
///   natural frequencies log-uniform over the grid, one real pole for odd na), na 1..=8,
///   nb ∈ {na − 1, na}.
fn random_ct_case(seed: u64, form: CtForm) -> (Rational<f64>, Vec<f64>, Vec<f64>) {
    let mut rng = StdRng::seed_from_u64(seed);
    loop {
        let omega = random_ct_grid(&mut rng);
        let na = rng.gen_range(1..=8usize);
        let model = match form {
            CtForm::Polynomial => {
                let nb = rng.gen_range(0..=na + 1);
                // the basis needs 2·lines > degree
                let Ok(model) = Rational::polynomial(na, nb, &omega) else {
                    continue;
                };
                model
            }
            CtForm::PartialFractions => {
                let nb = na - rng.gen_range(0..=1usize);
                let (lo, hi) = (omega[0].log10(), omega[omega.len() - 1].log10());
                let mut poles: Vec<Complex<f64>> = (0..na / 2)
                    .map(|_| {
                        let w = 10f64.powf(rng.gen_range(lo..=hi));
                        let zeta: f64 = rng.gen_range(0.01..0.7);
                        Complex::new(-zeta * w, w * (1.0 - zeta * zeta).sqrt())
                    })
                    .collect();
                if na % 2 == 1 {
                    poles.push(Complex::new(-(10f64.powf(rng.gen_range(lo..=hi))), 0.0));
                }
                Rational::partial_fractions(poles, nb).unwrap()
            }
        };
        let theta: Vec<f64> = (0..model.n_params())
            .map(|_| rng.gen_range(-2.0..2.0))
            .collect();
        let mut a = vec![Complex::new(0.0, 0.0); omega.len()];
        model.denominator_into(&theta, &omega, &mut a);
        let max = a.iter().map(|v| v.norm()).fold(0.0, f64::max);
        let min = a.iter().map(|v| v.norm()).fold(f64::INFINITY, f64::min);
        if min >= 1e-2 * max {
            return (model, theta, omega);
        }
    }
}

/// A random DT model (na 1..=8, nb 0..=na) at the θ of a random stable system (poles of
/// radius 0.3–0.95, random zeros and gain; `common::random_dt_system`), on its random grid
/// in (0, π/Ts).
fn random_dt_case(seed: u64) -> (Rational<f64>, Vec<f64>, Vec<f64>) {
    let mut rng = StdRng::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15);
    let na = rng.gen_range(1..=8usize);
    let nb = rng.gen_range(0..=na);
    let sys = random_dt_system(seed, na, nb);
    let ts = sys.zpk.ts.unwrap();
    let model = Rational::discrete(na, nb, ts).unwrap();
    let gain = 10f64.powf(rng.gen_range(-1.0..1.0));
    let mut theta = dt_theta(&sys);
    for b in theta[na..].iter_mut() {
        *b *= gain;
    }
    (model, theta, sys.omega)
}

/// Checks `analytic` (rows × p) against `numeric` column by column; returns the worst
/// column-relative error.
fn compare_columns<F: Fn(usize, usize) -> f64>(
    rows: usize,
    p: usize,
    analytic: F,
    numeric: &[Vec<f64>],
    what: &str,
) -> f64 {
    let mut worst = 0f64;
    for (j, num_col) in numeric.iter().enumerate().take(p) {
        let scale = (0..rows).map(|k| analytic(k, j).abs()).fold(0.0, f64::max);
        let err = (0..rows)
            .map(|k| (analytic(k, j) - num_col[k]).abs())
            .fold(0.0, f64::max);
        assert!(
            err <= REL_TOL * scale,
            "{what}: column {j}: max |analytic − FD| = {err:.3e}, max |analytic| = {scale:.3e} \
             (relative {:.3e})",
            err / scale
        );
        worst = worst.max(err / scale);
    }
    worst
}

/// ∂G/∂θ of `model` at `theta` on `omega` against central differences of `response`;
/// also G from `jacobian_into` against `response`.
fn check_model_jacobian(model: &Rational<f64>, theta: &[f64], omega: &[f64], what: &str) -> f64 {
    let (n, p) = (omega.len(), model.n_params());
    let mut g = vec![Complex::new(0.0, 0.0); n];
    let mut jac = DMatrix::from_element(n, p, Complex::new(f64::NAN, f64::NAN));
    model.jacobian_into(theta, omega, &mut g, &mut jac);
    let g_ref = model.response(theta, omega);
    for (a, b) in g.iter().zip(&g_ref) {
        assert!(
            (a - b).norm() <= 1e-14 * b.norm().max(1e-300),
            "{what}: G from jacobian_into {a} differs from response {b}"
        );
    }
    // FD columns, real and imaginary parts stacked as rows 2k, 2k+1
    let stacked = |t: &[f64]| -> Vec<f64> {
        model
            .response(t, omega)
            .iter()
            .flat_map(|g| [g.re, g.im])
            .collect()
    };
    let numeric: Vec<Vec<f64>> = (0..p)
        .map(|j| central_difference(stacked, theta, j))
        .collect();
    compare_columns(
        2 * n,
        p,
        |r, j| {
            let v = jac[(r / 2, j)];
            if r % 2 == 0 { v.re } else { v.im }
        },
        &numeric,
        what,
    )
}

#[test]
fn rational_ct_jacobian_matches_finite_differences() {
    for form in [CtForm::Polynomial, CtForm::PartialFractions] {
        let mut worst = 0f64;
        for seed in 0..CASES {
            let (model, theta, omega) = random_ct_case(seed, form);
            worst = worst.max(check_model_jacobian(
                &model,
                &theta,
                &omega,
                &format!(
                    "CT {form:?} seed {seed} (na {}, nb {}, {} lines)",
                    model.na(),
                    model.nb(),
                    omega.len()
                ),
            ));
        }
        println!("CT {form:?}: worst column-relative error {worst:.2e}");
    }
}

#[test]
fn rational_dt_jacobian_matches_finite_differences() {
    let mut worst = 0f64;
    for seed in 0..CASES {
        let (model, theta, omega) = random_dt_case(seed);
        worst = worst.max(check_model_jacobian(
            &model,
            &theta,
            &omega,
            &format!(
                "DT seed {seed} (na {}, nb {}, {} lines)",
                model.na(),
                model.nb(),
                omega.len()
            ),
        ));
    }
    println!("DT: worst column-relative error {worst:.2e}");
}

/// The θ built by `common::dt_theta` from poles and zeros reproduces the factored-form
/// response of the system: checks the DT parameter convention the other tests rely on
/// (A(z⁻¹) = 1 + a₁z⁻¹ + …, B(z⁻¹) = b₀ + b₁z⁻¹ + …, G evaluated at z = e^{iωTs}).
#[test]
fn dt_theta_convention_matches_factored_form() {
    for seed in 0..50 {
        let na = 1 + (seed as usize % 8);
        let nb = (seed as usize * 5) % (na + 1);
        let sys = random_dt_system(seed, na, nb);
        let model = Rational::discrete(na, nb, sys.zpk.ts.unwrap()).unwrap();
        let g = model.response(&dt_theta(&sys), &sys.omega);
        let e = common::rel_rms(&g, &sys.frf());
        assert!(e < 1e-12, "seed {seed} na {na} nb {nb}: rel. error {e:.3e}");
    }
}

/// Random spectra data on `omega`: Y, U complex with |U| ∈ [0.1, 10], optionally with
/// random output noise variances (weights 1/σ_k).
fn random_data(
    rng: &mut StdRng,
    omega: &[f64],
    ts: Option<f64>,
    noisy: bool,
) -> FrequencyData<f64> {
    let mut c = |lo: f64, hi: f64| {
        Complex::from_polar(
            10f64.powf(rng.gen_range(lo..hi)),
            rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI),
        )
    };
    let y: Vec<Complex<f64>> = omega.iter().map(|_| c(-2.0, 1.0)).collect();
    let u: Vec<Complex<f64>> = omega.iter().map(|_| c(-1.0, 1.0)).collect();
    let data = FrequencyData::new(omega.to_vec(), y, u, ts).unwrap();
    if noisy {
        let var: Vec<f64> = omega
            .iter()
            .map(|_| 10f64.powf(rng.gen_range(-4.0..0.0)))
            .collect();
        data.with_noise(NoiseVariances::output_only(var)).unwrap()
    } else {
        data
    }
}

/// ∂r/∂θ of the ML problem against central differences of `residuals_into`, and the
/// residuals written by `jacobian_into` against `residuals_into`.
fn check_ml_jacobian(
    model: &Rational<f64>,
    theta: &[f64],
    data: &FrequencyData<f64>,
    weighting: NoiseWeighting,
    what: &str,
) -> f64 {
    let problem = match MlProblem::new(model, data, weighting) {
        Ok(problem) => problem,
        // fewer real equations than parameters: the problem is rightly refused
        Err(FdidError::TooFewFrequencies { .. }) if 2 * data.len() < model.n_params() => {
            return 0.0;
        }
        Err(e) => panic!("{what}: {e}"),
    };
    let (m, p) = (problem.n_residuals(), problem.n_params());
    assert_eq!(m, 2 * data.len());
    assert_eq!(p, model.n_params());
    let mut r = vec![f64::NAN; m];
    let mut jac = DMatrix::from_element(m, p, f64::NAN);
    assert!(
        problem.jacobian_into(theta, &mut r, &mut jac),
        "{what}: not finite"
    );
    let mut r_ref = vec![f64::NAN; m];
    assert!(problem.residuals_into(theta, &mut r_ref));
    let rmax = r_ref.iter().map(|v| v.abs()).fold(0.0, f64::max);
    for (a, b) in r.iter().zip(&r_ref) {
        assert!((a - b).abs() <= 1e-14 * rmax, "{what}: residual {a} vs {b}");
    }
    // weighting: the residual of line k is (Y_k − G U_k) w_k
    let g = model.response(theta, data.omega());
    for k in 0..data.len() {
        let w = match (weighting, data.noise()) {
            (NoiseWeighting::Auto, Some(n)) => 1.0 / n.var_y[k].sqrt(),
            _ => 1.0,
        };
        let e = (data.y()[k] - g[k] * data.u()[k]) * w;
        assert!(
            (e.re - r[2 * k]).abs() <= 1e-12 * rmax && (e.im - r[2 * k + 1]).abs() <= 1e-12 * rmax,
            "{what}: residual of line {k} is not (Y − G U)/σ"
        );
    }
    let residuals = |t: &[f64]| -> Vec<f64> {
        let mut out = vec![0.0; m];
        assert!(
            problem.residuals_into(t, &mut out),
            "{what}: residuals not finite"
        );
        out
    };
    let numeric: Vec<Vec<f64>> = (0..p)
        .map(|j| central_difference(residuals, theta, j))
        .collect();
    compare_columns(m, p, |k, j| jac[(k, j)], &numeric, what)
}

#[test]
fn ml_residual_jacobian_matches_finite_differences() {
    let mut worst = 0f64;
    for seed in 0..CASES {
        let mut rng = StdRng::seed_from_u64(seed + 1_000_000);
        for kind in ["polynomial", "partial fractions", "DT"] {
            let (model, theta, omega) = match kind {
                "polynomial" => random_ct_case(seed, CtForm::Polynomial),
                "partial fractions" => random_ct_case(seed, CtForm::PartialFractions),
                _ => random_dt_case(seed),
            };
            let ts = match model.domain() {
                Domain::Discrete { ts } => Some(ts),
                Domain::Continuous => None,
            };
            for (noisy, weighting) in [
                (false, NoiseWeighting::Auto),
                (true, NoiseWeighting::Auto),
                (true, NoiseWeighting::Flat),
            ] {
                let data = random_data(&mut rng, &omega, ts, noisy);
                worst = worst.max(check_ml_jacobian(
                    &model,
                    &theta,
                    &data,
                    weighting,
                    &format!(
                        "ML {kind} seed {seed} (na {}, nb {}), noise {noisy}, {weighting:?}",
                        model.na(),
                        model.nb()
                    ),
                ));
            }
        }
    }
    println!("ML: worst column-relative error {worst:.2e}");
}
