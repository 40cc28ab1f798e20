//! Rational models: conversions between parameters, poles, zeros and gain; reflection of
//! unstable poles; monomial coefficients.

use crate::common;

use common::{Zpk, logspace};
use fdid::prelude::*;

fn close(a: Complex<f64>, b: Complex<f64>, tol: f64) -> bool {
    (a - b).norm() <= tol * b.norm().max(1.0)
}

fn sorted(mut v: Vec<Complex<f64>>) -> Vec<Complex<f64>> {
    v.sort_by(|a, b| (a.im, a.re).partial_cmp(&(b.im, b.re)).unwrap());
    v
}

/// Fits noise-free data of `sys` with `model` and returns the fit.
fn fit_exact(sys: &Zpk, model: Rational<f64>, omega: &[f64]) -> Fit<f64, Rational<f64>> {
    let data = FrequencyData::from_frf(omega.to_vec(), sys.frf(omega), sys.ts).unwrap();
    Pipeline::default().fit(&model, &data).unwrap()
}

#[test]
fn poles_zeros_gain_round_trip_in_s() {
    let sys = Zpk {
        zeros: vec![Complex::new(-3.0, 0.0)],
        poles: vec![
            Complex::new(-0.2, 1.5),
            Complex::new(-0.2, -1.5),
            Complex::new(-1.0, 0.0),
        ],
        gain: 2.5,
        ts: None,
    };
    let omega = logspace(-1.0, 1.5, 300);
    for model in [
        Rational::polynomial(3, 1, &omega).unwrap(),
        Rational::partial_fractions_on(3, 2, &omega).unwrap(),
    ] {
        let fit = fit_exact(&sys, model, &omega);
        let poles = sorted(fit.poles().unwrap());
        for (p, w) in poles.iter().zip(sorted(sys.poles.clone())) {
            assert!(close(*p, w, 1e-9), "{p} vs {w}");
        }
        // the strictly proper partial-fraction form has one more zero, at |s| → ∞ in exact
        // arithmetic; the finite one must be there
        let zeros = fit.zeros().unwrap();
        assert!(
            zeros.iter().any(|z| close(*z, sys.zeros[0], 1e-8)),
            "{zeros:?}"
        );
        if zeros.len() == 1 {
            assert!((fit.gain() - 2.5).abs() < 1e-8, "gain {}", fit.gain());
        }
    }
}

#[test]
fn poles_zeros_gain_round_trip_in_z() {
    let sys = Zpk {
        zeros: vec![Complex::new(0.5, 0.0)],
        poles: vec![
            Complex::new(0.6, 0.5),
            Complex::new(0.6, -0.5),
            Complex::new(-0.3, 0.0),
        ],
        gain: 0.7,
        ts: Some(0.01),
    };
    let omega: Vec<f64> = (1..200)
        .map(|k| k as f64 * std::f64::consts::PI / 0.01 / 200.0)
        .collect();
    // G(z) = 0.7 (z − 0.5)/((z − p1)(z − p2)(z − p3)) = z⁻² 0.7(1 − 0.5 z⁻¹)/A(z⁻¹):
    // B(z⁻¹) = b₀ + … + b₃z⁻³ with b₀ = b₁ = 0
    let model = Rational::discrete(3, 3, 0.01).unwrap();
    let fit = fit_exact(&sys, model, &omega);
    for (p, w) in sorted(fit.poles().unwrap())
        .iter()
        .zip(sorted(sys.poles.clone()))
    {
        assert!(close(*p, w, 1e-9), "{p} vs {w}");
    }
    let zeros = fit.zeros().unwrap();
    assert_eq!(zeros.len(), 1, "{zeros:?}");
    assert!(close(zeros[0], sys.zeros[0], 1e-8));
    let (_, b) = fit.model().coefficients(fit.theta());
    assert!(b[0].abs() < 1e-10 && b[1].abs() < 1e-10, "{b:?}");
    assert!((fit.gain() - 0.7).abs() < 1e-9, "gain {}", fit.gain());
}

#[test]
fn reflecting_unstable_poles_keeps_the_magnitude() {
    let omega = logspace(-1.0, 1.0, 200);
    // an unstable CT system (poles 0.3 ± 2i and −1)
    let ct = Zpk {
        zeros: vec![Complex::new(-2.0, 0.0)],
        poles: vec![
            Complex::new(0.3, 2.0),
            Complex::new(0.3, -2.0),
            Complex::new(-1.0, 0.0),
        ],
        gain: 1.0,
        ts: None,
    };
    let w_dt: Vec<f64> = (1..150).map(|k| k as f64 * 0.02).collect();
    let dt = Zpk {
        zeros: vec![Complex::new(0.2, 0.0)],
        poles: vec![Complex::new(1.25, 0.0), Complex::new(0.5, 0.0)],
        gain: 1.0,
        ts: Some(1.0),
    };
    let cases = [
        (
            ct.clone(),
            Rational::polynomial(3, 1, &omega).unwrap(),
            omega.clone(),
        ),
        (
            ct,
            Rational::partial_fractions_on(3, 2, &omega).unwrap(),
            omega,
        ),
        (dt, Rational::discrete(2, 2, 1.0).unwrap(), w_dt),
    ];
    for (sys, model, w) in cases {
        let fit = fit_exact(&sys, model, &w);
        let model = fit.model();
        assert!(!model.is_stable(fit.theta()).unwrap());
        let theta = model.reflect_unstable(fit.theta()).unwrap();
        assert!(model.is_stable(&theta).unwrap());
        let before = model.response(fit.theta(), &w);
        let after = model.response(&theta, &w);
        for (a, b) in before.iter().zip(&after) {
            assert!((a.norm() - b.norm()).abs() < 1e-8 * a.norm().max(1e-12));
        }
        // the stable poles are untouched, the unstable ones mirrored
        let mut poles = model.poles(&theta).unwrap();
        poles.sort_by(|a, b| a.re.total_cmp(&b.re));
        for p in &sys.poles {
            let mirrored = match sys.ts {
                None if p.re > 0.0 => Complex::new(-p.re, p.im),
                Some(_) if p.norm() > 1.0 => p.conj().inv(),
                _ => *p,
            };
            assert!(
                poles.iter().any(|q| close(*q, mirrored, 1e-8)),
                "{mirrored} not in {poles:?}"
            );
        }
    }
}

#[test]
fn monomial_coefficients_reproduce_the_response() {
    let omega = logspace(-1.0, 1.0, 100);
    for model in [
        Rational::polynomial(4, 2, &omega).unwrap(),
        Rational::partial_fractions_on(4, 3, &omega).unwrap(),
    ] {
        let theta: Vec<f64> = (0..model.n_params())
            .map(|k| 0.3 + 0.1 * k as f64)
            .collect();
        let (a, b) = model.monomial_coefficients(&theta);
        let horner = |p: &[f64], s: Complex<f64>| {
            p.iter()
                .rev()
                .fold(Complex::new(0.0, 0.0), |acc, c| acc * s + *c)
        };
        let g = model.response(&theta, &omega);
        for (w, g) in omega.iter().zip(&g) {
            let s = Complex::new(0.0, *w);
            let via = horner(&b, s) / horner(&a, s);
            assert!(close(via, *g, 1e-8), "{via} vs {g}");
        }
    }
}

/// The regressor built block by block (as the Levy and SK solves of large problems do)
/// equals the whole regressor, row for row, for every form of the model.
#[test]
fn regressor_rows_by_blocks_equal_the_whole_regressor() {
    use fdid::EquationError;
    use nalgebra::DMatrix;
    let omega = logspace(-1.0, 1.0, 101);
    let mut noise = common::Noise::new(5);
    let y: Vec<Complex<f64>> = omega.iter().map(|_| noise.complex(1.0)).collect();
    let u: Vec<Complex<f64>> = omega.iter().map(|_| noise.complex(1.0)).collect();
    let ct = FrequencyData::new(omega.clone(), u.clone(), y.clone(), None).unwrap();
    let dt = FrequencyData::new(omega.iter().map(|w| w * 0.3).collect(), u, y, Some(1.0)).unwrap();
    let models = [
        (Rational::continuous(4, 3, ct.omega()).unwrap(), &ct),
        (Rational::continuous(4, 1, ct.omega()).unwrap(), &ct), // constrained numerator
        (Rational::polynomial(3, 2, ct.omega()).unwrap(), &ct),
        (Rational::discrete(3, 3, 1.0).unwrap(), &dt),
        (
            Rational::discrete(2, 1, 1.0)
                .unwrap()
                .with_transient()
                .unwrap(),
            &dt,
        ),
    ];
    for (model, data) in models {
        let q = model.n_coefficients();
        let mut whole = DMatrix::zeros(data.len(), q);
        model.regressor_into(data, &mut whole);
        for k0 in (0..data.len()).step_by(7) {
            let len = 7.min(data.len() - k0);
            let mut rows = DMatrix::zeros(len, q);
            model.regressor_lines_into(data, k0, &mut rows);
            assert_eq!(rows, whole.rows(k0, len), "{model:?} lines {k0}..");
        }
    }
}

/// On a problem large enough for the blocked normal equations (N·q > 8 192), the Levy
/// stage of the standard chain has the estimate and the cost of the QR solve.
#[test]
fn blocked_levy_stage_equals_the_qr_one() {
    blocked_levy_stage_on(6_000);
}

/// The same with a last block of one line (the order-(10, 9) model's Levy and ML passes
/// take 204 lines per block): its 2 × p rows once made the Gram product write past its
/// result.
#[test]
fn blocked_passes_with_a_last_block_of_one_line() {
    blocked_levy_stage_on(204 * 29 + 1);
}

fn blocked_levy_stage_on(lines: usize) {
    let omega = logspace(-1.0, 1.0, lines);
    let sys = common::b_ct10();
    let mut noise = common::Noise::new(9);
    let y: Vec<Complex<f64>> = sys
        .frf(&omega)
        .iter()
        .map(|g| g + noise.complex(1e-6))
        .collect();
    let data = FrequencyData::from_frf(omega, y, None).unwrap();
    let model = Rational::continuous(10, 9, data.omega()).unwrap();
    // the linear stages on all lines (by default a record this long starts ML from fewer)
    let all_lines = Pipeline {
        start_lines: None,
        ..Pipeline::default()
    };
    let chain = all_lines.fit(&model, &data).unwrap();
    let qr = Pipeline::levy().fit(&model, &data).unwrap();
    assert_eq!(chain.stages()[0].lines, None);
    let (a, b) = (&chain.stages()[0].solution, &qr.stages()[0].solution);
    assert_eq!(chain.stages()[0].kind, StageKind::Levy);
    assert!(
        (a.cost - b.cost).abs() <= 1e-6 * b.cost,
        "{} vs {}",
        a.cost,
        b.cost
    );
    let scale = b.theta.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (x, y) in a.theta.iter().zip(&b.theta) {
        assert!((x - y).abs() <= 1e-6 * scale, "{x} vs {y}");
    }
}

/// G and A from one evaluation equal the response and the denominator evaluated apart.
#[test]
fn response_and_denominator_in_one_pass() {
    use fdid::EquationError;
    let omega = logspace(-1.0, 0.4, 50);
    let zero = Complex::new(0.0, 0.0);
    for (model, theta) in [
        (
            Rational::discrete(3, 2, 1.0).unwrap(),
            vec![-0.5, 0.2, 0.1, 1.0, 0.3, -0.2],
        ),
        (
            Rational::continuous(2, 1, &omega).unwrap(),
            vec![0.4, 0.3, 1.0, -0.5],
        ),
    ] {
        let (mut g, mut a) = (vec![zero; omega.len()], vec![zero; omega.len()]);
        model.response_and_denominator_into(&theta, &omega, &mut g, &mut a);
        let (mut g0, mut a0) = (vec![zero; omega.len()], vec![zero; omega.len()]);
        model.response_into(&theta, &omega, &mut g0);
        model.denominator_into(&theta, &omega, &mut a0);
        assert_eq!(g, g0, "{model:?}");
        assert_eq!(a, a0, "{model:?}");
    }
}
