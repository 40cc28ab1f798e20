//! Rational models: conversions between parameters, poles, zeros and gain; reflection of
//! unstable poles; monomial coefficients.

mod common;

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
