//! ML started from given poles ([`Pipeline::fit_from_roots`],
//! [`ModelSpec::fit_from_poles`]): noise-free recovery from poles 1 % off the truth, as
//! quickcheck properties over random stable systems in f64 and f32, and the warm start
//! against a fit from scratch on a lightly damped system.

use crate::common;
use common::{RandomSystem, random_ct_system, random_dt_system, rel_rms};
use fdid::estimate::{ModelSpec, RationalFit, Stability};
use fdid::prelude::*;
use quickcheck::{Arbitrary, Gen, TestResult};

/// A random system (continuous or discrete time) and its orders.
#[derive(Debug, Clone, Copy)]
struct Case {
    seed: u64,
    na: usize,
    nb: usize,
    discrete: bool,
}

impl Arbitrary for Case {
    fn arbitrary(g: &mut Gen) -> Self {
        let na = 1 + (u32::arbitrary(g) as usize) % 8;
        Self {
            seed: u64::arbitrary(g),
            na,
            nb: (u32::arbitrary(g) as usize) % (na + 1),
            discrete: bool::arbitrary(g),
        }
    }
}

impl Case {
    fn system(&self) -> RandomSystem {
        if self.discrete {
            random_dt_system(self.seed, self.na, self.nb)
        } else {
            random_ct_system(self.seed, self.na, self.nb)
        }
    }
}

/// The poles of `sys` moved by 1 % (each pair by the same factor, so the set stays
/// closed under conjugation): in s scaled by 1.01 or 0.99, in z towards or away from the
/// origin.
fn perturbed(sys: &RandomSystem) -> Vec<Complex<f64>> {
    sys.zpk
        .poles
        .iter()
        .enumerate()
        .map(|(i, p)| {
            // pairs are stored next to each other: one factor per pair
            let factor = if (i / 2) % 2 == 0 { 1.01 } else { 0.99 };
            if p.im == 0.0 {
                p * (2.0 - factor)
            } else {
                p * factor
            }
        })
        .collect()
}

fn tolerance<T: Real>() -> f64 {
    if T::default_epsilon().to_f64_lossless() > 1e-10 {
        1e-3
    } else {
        1e-9
    }
}

/// Property: from poles 1 % off, the pipeline's ML recovers the FRF.
fn recovers<T: Real>(case: Case) -> TestResult {
    let sys = case.system();
    let omega: Vec<T> = sys.omega.iter().map(|w| T::lit(*w)).collect();
    let ts = sys.zpk.ts.map(T::lit);
    let run = || -> fdid::Result<f64> {
        let data = FrequencyData::from_frf(omega.clone(), sys.zpk.frf_t::<T>(&sys.omega), ts)?;
        let model = match ts {
            None => Rational::continuous(sys.na, sys.nb, data.omega())?,
            Some(ts) => Rational::discrete(sys.na, sys.nb, ts)?,
        };
        let start: Vec<Complex<T>> = perturbed(&sys)
            .iter()
            .map(|p| Complex::new(T::lit(p.re), T::lit(p.im)))
            .collect();
        let fit = Pipeline::default().fit_from_roots(&model, &data, &start)?;
        Ok(rel_rms(fit.response(), &sys.frf()))
    };
    match run() {
        Ok(e) if e < tolerance::<T>() => TestResult::passed(),
        Ok(e) => TestResult::error(format!(
            "{case:?}: FRF rel. RMS error {e:.3e} ≥ {:.0e}",
            tolerance::<T>()
        )),
        Err(err) => TestResult::error(format!("{case:?}: error {err}")),
    }
}

#[test]
fn ml_from_nearby_poles_recovers_random_systems_f64() {
    common::seeded(0x9e11)
        .tests(60)
        .quickcheck(recovers::<f64> as fn(Case) -> TestResult);
}

/// f32, orders ≤ 5 in the partial-fraction and discrete forms (the polynomial basis in
/// f32 is limited to low orders, see `estimators_recovery`).
#[test]
fn ml_from_nearby_poles_recovers_random_systems_f32() {
    fn prop(case: Case) -> TestResult {
        let case = Case {
            na: 1 + case.na % 5,
            ..case
        };
        let case = Case {
            nb: if case.discrete {
                case.nb % (case.na + 1)
            } else {
                case.na - case.nb % 2
            },
            ..case
        };
        recovers::<f32>(case)
    }
    common::seeded(0x9e32)
        .tests(60)
        .quickcheck(prop as fn(Case) -> TestResult);
}

/// `ModelSpec::fit_from_poles` (partial-fraction basis at the starting poles in s, the
/// spec's own basis in z) recovers the system from poles 1 % off, with stability enforced
/// too, and refuses specs it does not cover.
#[test]
fn spec_fit_from_poles_recovers_and_refuses_delays() {
    for seed in 0..20u64 {
        for discrete in [false, true] {
            let (na, nb) = (2 + (seed as usize) % 6, 1 + (seed as usize) % 2);
            let sys = if discrete {
                random_dt_system(seed, na, nb.min(na))
            } else {
                random_ct_system(seed, na, nb.min(na))
            };
            let data = FrequencyData::from_frf(sys.omega.clone(), sys.frf(), sys.zpk.ts).unwrap();
            let spec = match sys.zpk.ts {
                None => ModelSpec::continuous(sys.na, sys.nb),
                Some(ts) => ModelSpec::discrete(sys.na, sys.nb, ts),
            };
            for stability in [Stability::Free, Stability::Enforced] {
                let spec = ModelSpec {
                    stability,
                    ..spec.clone()
                };
                let fit = spec.fit_from_poles(&data, &perturbed(&sys)).unwrap();
                let RationalFit::Plain(fit) = fit else {
                    panic!("a plain fit")
                };
                let e = rel_rms(fit.response(), &sys.frf());
                assert!(
                    e < 1e-9,
                    "seed {seed} discrete {discrete} {stability:?}: {e:.3e}"
                );
            }
            let delayed = ModelSpec {
                delay: true,
                ..spec
            };
            assert!(delayed.fit_from_poles(&data, &perturbed(&sys)).is_err());
        }
    }
}

/// Four lightly damped modes (ζ = 0.002 … 0.01) between 1 and 10 rad/s with noise:
/// the model of order 6 with three of the modes, augmented from its poles by a pair at
/// the missing mode, reaches the cost of the true structure (within the noise), as a fit
/// of order 8 from scratch does or does worse.
#[test]
fn a_warm_start_finds_the_added_mode() {
    let modes = [(1.3, 0.004), (2.9, 0.002), (4.4, 0.01), (8.1, 0.003)];
    let pole = |(w, z): (f64, f64)| Complex::new(-z * w, w * (1.0 - z * z).sqrt());
    let omega: Vec<f64> = (0..600).map(|k| 0.8 + 0.016 * k as f64).collect();
    let g = |w: f64| {
        let s = Complex::new(0.0, w);
        modes
            .iter()
            .enumerate()
            .fold(Complex::new(0.0, 0.0), |acc, (i, m)| {
                let p = pole(*m);
                let r = Complex::new(0.0, 1.0 + i as f64) * p.norm();
                acc + r / (s - p) + r.conj() / (s - p.conj())
            })
    };
    let mut noise = common::Noise::new(7);
    let var = 1e-4;
    let y: Vec<Complex<f64>> = omega.iter().map(|w| g(*w) + noise.complex(var)).collect();
    let data = FrequencyData::from_frf(omega, y, None).unwrap();
    // the model without the mode at 4.4 rad/s
    let three: Vec<Complex<f64>> = [modes[0], modes[1], modes[3]]
        .iter()
        .flat_map(|m| [pole(*m), pole(*m).conj()])
        .collect();
    let small = ModelSpec::continuous(6, 6)
        .fit_from_poles(&data, &three)
        .unwrap();
    let mut start = small.poles().unwrap();
    start.extend([pole((4.5, 0.02)), pole((4.5, 0.02)).conj()]);
    let spec = ModelSpec::continuous(8, 8);
    let warm = spec.fit_from_poles(&data, &start).unwrap();
    let scratch = spec.fit(&data).unwrap();
    // unweighted: V ≈ N·σ² for a model at the noise
    let floor = data.len() as f64 * var;
    assert!(
        warm.cost() < 1.2 * floor,
        "warm {} vs N σ² {floor}",
        warm.cost()
    );
    assert!(
        warm.cost() <= scratch.cost() * (1.0 + 1e-6),
        "warm {} scratch {}",
        warm.cost(),
        scratch.cost()
    );
    assert!(
        warm.poles()
            .unwrap()
            .iter()
            .any(|p| (p - pole(modes[2])).norm() < 0.01),
        "{:?}",
        warm.poles()
    );
}
