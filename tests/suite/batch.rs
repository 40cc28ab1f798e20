//! `fdid::estimate::batch`: many independent fits, in parallel with the `rayon` feature, give the
//! results of the sequential loop bit for bit, in order, and a failing item does not stop
//! the batch.

use crate::common::on_threads;
use fdid::estimate::batch::{fit_each, fit_each_sequential, fit_many, fit_many_sequential};
use fdid::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// A noisy FRF (1 % of its RMS) of a random stable DT order-2 system with `lines` lines on
/// (0, π) rad/sample, Ts = 1.
fn dt_frf(rng: &mut StdRng, lines: usize) -> FrequencyData<f64> {
    let r: f64 = rng.gen_range(0.6..0.95);
    let th: f64 = rng.gen_range(0.3..2.5);
    let (a1, a2) = (-2.0 * r * th.cos(), r * r);
    let b1: f64 = rng.gen_range(0.5..2.0);
    let omega: Vec<f64> = (1..=lines)
        .map(|k| std::f64::consts::PI * k as f64 / (lines + 1) as f64)
        .collect();
    let g0: Vec<Complex<f64>> = omega
        .iter()
        .map(|w| {
            let q = Complex::new(0.0, -w).exp();
            q * b1 / (1.0 + q * a1 + q * q * a2)
        })
        .collect();
    let rms = (g0.iter().map(|g| g.norm_sqr()).sum::<f64>() / lines as f64).sqrt();
    let g = g0
        .iter()
        .map(|g| {
            let e = Complex::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
            g + e * 0.01 * rms
        })
        .collect();
    FrequencyData::from_frf(omega, g, Some(1.0)).unwrap()
}

/// Bitwise equality of two batches: same successes (θ, cost, response) and same errors.
fn assert_identical<M: ModelStructure<f64> + std::fmt::Debug>(
    a: &[Result<Fit<f64, M>>],
    b: &[Result<Fit<f64, M>>],
) {
    assert_eq!(a.len(), b.len());
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        match (x, y) {
            (Ok(x), Ok(y)) => {
                let bits = |v: &[f64]| v.iter().map(|t| t.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(x.theta()), bits(y.theta()), "item {k}: theta");
                assert_eq!(x.cost().to_bits(), y.cost().to_bits(), "item {k}: cost");
                assert_eq!(x.response(), y.response(), "item {k}: response");
            }
            (Err(x), Err(y)) => assert_eq!(x.to_string(), y.to_string(), "item {k}: error"),
            _ => panic!("item {k}: one batch fitted it and the other did not: {x:?} / {y:?}"),
        }
    }
}

#[test]
fn parallel_batch_equals_sequential_bit_for_bit() {
    let mut rng = StdRng::seed_from_u64(11);
    let data: Vec<_> = (0..40)
        .map(|_| {
            let lines = rng.gen_range(60..160);
            dt_frf(&mut rng, lines)
        })
        .collect();
    let model = Rational::discrete(2, 1, 1.0).unwrap();
    let pipeline = Pipeline::default();
    let seq = fit_many_sequential(&pipeline, &model, &data);
    assert!(seq.iter().all(|r| r.is_ok()), "every item is fittable");
    for threads in [1, 2, 3] {
        let par = on_threads(threads, || fit_many(&pipeline, &model, &data));
        assert_identical(&par, &seq);
    }
    // and each item is the fit of that data set alone
    for (d, r) in data.iter().zip(&seq).step_by(7) {
        assert_identical(std::slice::from_ref(r), &[pipeline.fit(&model, d)]);
    }
}

#[test]
fn a_failing_item_does_not_abort_the_batch() {
    let mut rng = StdRng::seed_from_u64(12);
    let mut data: Vec<_> = (0..12).map(|_| dt_frf(&mut rng, 80)).collect();
    // one line: 2 real equations for the 4 parameters of the order-(2, 1) model
    let bad = [3usize, 8];
    for &k in &bad {
        data[k] = dt_frf(&mut rng, 1);
    }
    let model = Rational::discrete(2, 1, 1.0).unwrap();
    let pipeline = Pipeline::default();
    let par = on_threads(2, || fit_many(&pipeline, &model, &data));
    assert_eq!(par.len(), data.len());
    for (k, r) in par.iter().enumerate() {
        if bad.contains(&k) {
            let e = r
                .as_ref()
                .expect_err("a one-line data set cannot be fitted");
            assert!(
                matches!(e, FdidError::TooFewFrequencies { .. }),
                "item {k}: {e}"
            );
        } else {
            let fit = r.as_ref().unwrap_or_else(|e| panic!("item {k}: {e}"));
            assert_eq!(fit.omega().len(), 80);
        }
    }
    assert_identical(&par, &fit_many_sequential(&pipeline, &model, &data));
}

#[test]
fn fit_each_gives_each_item_its_own_model() {
    // CT order 2 on grids of different lengths, each model built for its grid
    let items: Vec<_> = (0..10)
        .map(|k| {
            let lines = 50 + 17 * k;
            let wn = 1.0 + 0.2 * k as f64;
            let omega: Vec<f64> = (0..lines)
                .map(|i| 0.1 * 100f64.powf(i as f64 / (lines - 1) as f64))
                .collect();
            let g = omega
                .iter()
                .map(|w| {
                    let s = Complex::new(0.0, *w);
                    Complex::new(wn * wn, 0.0) / (s * s + s * 0.1 * wn + wn * wn)
                })
                .collect();
            let model = Rational::continuous(2, 0, &omega).unwrap();
            (model, FrequencyData::from_frf(omega, g, None).unwrap())
        })
        .collect();
    let pipeline = Pipeline::default();
    let seq = fit_each_sequential(&pipeline, &items);
    let par = on_threads(2, || fit_each(&pipeline, &items));
    assert_identical(&par, &seq);
    for (k, r) in par.iter().enumerate() {
        let wn = 1.0 + 0.2 * k as f64;
        let fit = r.as_ref().unwrap();
        assert_eq!(fit.omega().len(), 50 + 17 * k);
        for p in fit.poles().unwrap() {
            // noise-free: the poles of s² + 0.1 wn s + wn², |p| = wn
            assert!((p.norm() - wn).abs() < 1e-8 * wn, "item {k}: pole {p}");
        }
    }
}
