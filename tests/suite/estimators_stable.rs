//! `Stability::Enforced` (`ModelSpec::stability`, `Pipeline::stable`): fits stable by
//! construction — pole reflection after the linear stages and the stability-constrained ML
//! of `solver::Feasible` — on random systems, orders and noise (quickcheck, f64 and f32),
//! noise-free recovery of stable systems unchanged, and the F-16 ground vibration test FRF
//! (order 20 in s, modes near 5.2 and 7.3 Hz, the data README's reference facts).

use crate::common::{self, Noise, random_ct_system, random_dt_system};
use fdid::estimate::{Method, ModelSpec, Pipeline, RationalFit, Stability};
use fdid::prelude::*;
use quickcheck::TestResult;

fn enforced(spec: ModelSpec) -> ModelSpec {
    ModelSpec {
        stability: Stability::Enforced,
        ..spec
    }
}

/// Every pole of a fit strictly stable, checked from its poles (not through `is_stable`).
fn poles_stable(fit: &RationalFit, discrete: bool) -> bool {
    fit.poles().is_ok_and(|p| {
        p.iter()
            .all(|p| if discrete { p.norm() < 1.0 } else { p.re < 0.0 })
    })
}

/// A random stable system (s or z by `seed`'s parity) of order `n_true`, fitted at orders
/// (na, na) with complex noise of relative level `noise`: the enforced fit is stable.
fn enforced_fit_is_stable(seed: u64, n_true: u8, na: u8, noise: u8) -> TestResult {
    let n_true = 1 + n_true as usize % 4;
    let na = 1 + na as usize % 8;
    let level = [0.0, 1e-3, 0.03, 0.3][noise as usize % 4];
    let discrete = seed.is_multiple_of(2);
    let sys = if discrete {
        random_dt_system(seed, n_true, n_true)
    } else {
        random_ct_system(seed, n_true, n_true)
    };
    let mut rng = Noise::new(seed ^ 0x5eed);
    let y: Vec<Complex<f64>> = sys
        .frf()
        .into_iter()
        .map(|g| g + rng.complex(level * level))
        .collect();
    if 2 * y.len() < 2 * na + 2 {
        return TestResult::discard();
    }
    let spec = if discrete {
        ModelSpec::discrete(na, na, sys.zpk.ts.unwrap_or(1.0))
    } else {
        ModelSpec::continuous(na, na)
    };
    let ts = if discrete { sys.zpk.ts } else { None };
    let Ok(data) = FrequencyData::from_frf(sys.omega.clone(), y, ts) else {
        return TestResult::discard();
    };
    match enforced(spec).fit(&data) {
        Ok(fit) => TestResult::from_bool(fit.is_stable() && poles_stable(&fit, discrete)),
        // a typed error is allowed (e.g. a singular start); an unstable model is not
        Err(_) => TestResult::passed(),
    }
}

#[test]
fn enforced_fits_are_always_stable() {
    crate::common::seeded(0x88f3204)
        .tests(25)
        .max_tests(100)
        .quickcheck(enforced_fit_is_stable as fn(u64, u8, u8, u8) -> TestResult);
}

/// The same property through the generic `Pipeline { stable: true }` in f32.
fn enforced_pipeline_is_stable_f32(seed: u64, na: u8) -> TestResult {
    let na = 1 + na as usize % 6;
    let sys = random_dt_system(seed, 2, 2);
    let mut rng = Noise::new(seed);
    let y: Vec<Complex<f32>> = sys
        .frf()
        .into_iter()
        .map(|g| {
            let g = g + rng.complex(1e-3);
            Complex::new(g.re as f32, g.im as f32)
        })
        .collect();
    let omega: Vec<f32> = sys.omega.iter().map(|w| *w as f32).collect();
    let ts = sys.zpk.ts.unwrap_or(1.0) as f32;
    let (Ok(data), Ok(model)) = (
        FrequencyData::from_frf(omega, y, Some(ts)),
        Rational::<f32>::discrete(na, na, ts),
    ) else {
        return TestResult::discard();
    };
    let pipeline = Pipeline {
        stable: true,
        ..Pipeline::default()
    };
    match pipeline.fit(&model, &data) {
        Ok(fit) => TestResult::from_bool(fit.model().is_stable(fit.theta()).unwrap_or(false)),
        Err(_) => TestResult::passed(),
    }
}

#[test]
fn enforced_pipeline_fits_are_stable_in_f32() {
    crate::common::seeded(0x7f880292)
        .tests(20)
        .max_tests(60)
        .quickcheck(enforced_pipeline_is_stable_f32 as fn(u64, u8) -> TestResult);
}

/// Noise-free data of stable systems: the enforced fit is the free one (the constraint is
/// inactive at a stable optimum), to the recovery tolerance.
#[test]
fn noise_free_recovery_is_unchanged() {
    for seed in 0..6u64 {
        let discrete = seed.is_multiple_of(2);
        let sys = if discrete {
            random_dt_system(seed, 4, 3)
        } else {
            random_ct_system(seed, 4, 3)
        };
        let ts = if discrete { sys.zpk.ts } else { None };
        let data = FrequencyData::from_frf(sys.omega.clone(), sys.frf(), ts).unwrap();
        let spec = if discrete {
            ModelSpec::discrete(4, 3, ts.unwrap())
        } else {
            ModelSpec::continuous(4, 3)
        };
        let free = spec.fit(&data).unwrap();
        let stable = enforced(spec).fit(&data).unwrap();
        assert!(stable.is_stable(), "seed {seed}");
        let g = sys.frf();
        let fit_g = stable
            .rational()
            .response(stable.rational_theta(), &sys.omega);
        let err = common::rel_rms(&fit_g, &g);
        assert!(err < 1e-6, "seed {seed}: relative error {err}");
        let free_g = free.rational().response(free.rational_theta(), &sys.omega);
        assert!(common::rel_rms(&free_g, &g) < 1e-6, "seed {seed}");
    }
}

/// An unstable system's FRF: the free fit recovers the unstable pole; the enforced linear
/// estimators (Levy, SK, TLS) return the reflected system, whose |G| is the data's (an
/// all-pass factor away), and the enforced ML, started from the reflected SK estimate,
/// descends from it while staying stable.
#[test]
fn reflection_keeps_the_magnitude_of_an_unstable_system() {
    // G(s) = 1/((s − 0.5)(s² + 0.2 s + 4))
    let omega = common::logspace(-1.0, 1.0, 200);
    let y: Vec<Complex<f64>> = omega
        .iter()
        .map(|w| {
            let s = Complex::new(0.0, *w);
            (s - 0.5).inv() * (s * s + s * 0.2 + 4.0).inv()
        })
        .collect();
    let data = FrequencyData::from_frf(omega.clone(), y.clone(), None).unwrap();
    let free = ModelSpec::continuous(3, 2).fit(&data).unwrap();
    assert!(!free.is_stable());
    let spec = |criterion| ModelSpec {
        criterion,
        ..enforced(ModelSpec::continuous(3, 2))
    };
    for criterion in [Method::Levy, Method::Sk, Method::Tls] {
        let fit = spec(criterion).fit(&data).unwrap();
        assert!(fit.is_stable(), "{criterion:?}");
        let g = fit.rational().response(fit.rational_theta(), &omega);
        for (a, b) in g.iter().zip(&y) {
            assert!(
                (a.norm() / b.norm() - 1.0).abs() < 0.05,
                "{criterion:?}: |G| {} vs {}",
                a.norm(),
                b.norm()
            );
        }
    }
    let sk = spec(Method::Sk).fit(&data).unwrap();
    let ml = spec(Method::Ml).fit(&data).unwrap();
    assert!(ml.is_stable() && poles_stable(&ml, false));
    assert!(
        ml.cost() <= sk.cost(),
        "ML {} vs SK {}",
        ml.cost(),
        sk.cost()
    );
}

/// A stable truth with noise, over-fitted: the enforced fit is stable and its cost within
/// 20 % of the free fit's (the constraint costs little when the truth is stable).
#[test]
fn enforced_cost_is_close_to_the_free_one_for_a_stable_truth() {
    let mut worst: f64 = 1.0;
    for seed in 0..8u64 {
        let sys = random_dt_system(seed, 2, 2);
        let mut rng = Noise::new(seed + 100);
        let y: Vec<Complex<f64>> = sys
            .frf()
            .into_iter()
            .map(|g| g + rng.complex(0.01))
            .collect();
        let ts = sys.zpk.ts.unwrap();
        let data = FrequencyData::from_frf(sys.omega.clone(), y, Some(ts)).unwrap();
        let free = ModelSpec::discrete(6, 6, ts).fit(&data).unwrap();
        let stable = enforced(ModelSpec::discrete(6, 6, ts)).fit(&data).unwrap();
        assert!(stable.is_stable(), "seed {seed}");
        worst = worst.max(stable.cost() / free.cost());
    }
    assert!(worst < 1.2, "enforced/free cost ratio up to {worst}");
}

/// The F-16 FRF (Force → Acceleration1, periods 2–9 averaged, lines 41..307 of 8192 at
/// 400 Hz) from the raw file of the shared data, when it is there.
fn f16_frf() -> Option<FrequencyData<f64>> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/f16-gvt/F16Data_FullMSine_Level1.csv");
    let Ok(text) = std::fs::read_to_string(&path) else {
        eprintln!("skipped: {} not found", path.display());
        return None;
    };
    let rows: Vec<(f64, f64)> = text
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[0].parse().unwrap(), f[2].parse().unwrap())
        })
        .collect();
    let (n, periods, fs) = (8192usize, 9usize, 400.0);
    assert_eq!(rows.len(), n * periods);
    let lines: Vec<usize> = (41..=307).collect();
    let mut u = vec![Complex::new(0.0, 0.0); lines.len()];
    let mut y = u.clone();
    let mut yk = vec![vec![]; lines.len()];
    for p in 1..periods {
        let seg = &rows[p * n..(p + 1) * n];
        for (i, k) in lines.iter().enumerate() {
            let (mut su, mut sy) = (Complex::new(0.0, 0.0), Complex::new(0.0, 0.0));
            let step = Complex::from_polar(1.0, -std::f64::consts::TAU * *k as f64 / n as f64);
            let mut tw = Complex::new(1.0, 0.0);
            for (a, b) in seg {
                su += tw * *a;
                sy += tw * *b;
                tw *= step;
            }
            u[i] += su;
            y[i] += sy;
            yk[i].push((su, sy));
        }
    }
    let m = (periods - 1) as f64;
    let mut g = vec![];
    let mut var = vec![];
    for i in 0..lines.len() {
        let (um, ym) = (u[i] / m, y[i] / m);
        let gi = ym / um;
        let spread: f64 = yk[i].iter().map(|(a, b)| (b - gi * a).norm_sqr()).sum();
        var.push(spread / (m - 1.0) / m / um.norm_sqr());
        g.push(gi);
    }
    let omega: Vec<f64> = lines
        .iter()
        .map(|k| std::f64::consts::TAU * *k as f64 * fs / n as f64)
        .collect();
    let data = FrequencyData::from_frf(omega, g, None).unwrap();
    Some(
        data.with_noise(fdid::data::NoiseVariances::output_only(var))
            .unwrap(),
    )
}

/// Order 20 in s on the F-16 FRF: stable, with modes within 0.1 Hz of the wing bending
/// (5.2 Hz) and wing torsion (7.3 Hz) modes of the benchmark document.
#[test]
fn f16_order_20_is_stable_with_the_wing_modes() {
    let Some(data) = f16_frf() else { return };
    let fit = enforced(ModelSpec::continuous(20, 20)).fit(&data).unwrap();
    assert!(fit.is_stable());
    let hz: Vec<f64> = fit
        .poles()
        .unwrap()
        .iter()
        .filter(|p| p.im > 0.0)
        .map(|p| p.norm() / std::f64::consts::TAU)
        .collect();
    for mode in [5.2, 7.3] {
        assert!(
            hz.iter().any(|f| (f - mode).abs() < 0.1),
            "no mode near {mode} Hz: {hz:?}"
        );
    }
}
