//! The optimisation-robustness study shared by `tests/suite/optimisation_robustness.rs` and
//! `examples/optimisation_robustness.rs`: does `Pipeline::fit`, from its automatic start
//! (Levy → SK), reach the global optimum of the ML cost?
//!
//! For each random stable system (see [`ct_case`] and [`dt_case`]) at 40 dB SNR, the cost
//! reached by the pipeline is compared with the best of reference runs: ML started at the
//! true parameters, the pipeline started from perturbed true poles, and the multistart
//! fits (`fit_multistart`, `fit_multistart_discrete`). The pipeline
//! "reached the global optimum" when its cost is within 10⁻⁶ relative or 10⁻³ absolute of
//! the best cost found by any run (its own included). The chain alone
//! (`Pipeline { restarts: false, .. }`, without the further starts on evidence of a local
//! minimum) is measured against the same references, and both are timed.

#![allow(dead_code)]

use crate::common::{
    Noise, RandomSystem, dt_theta, log_uniform, poly_from_roots, random_dt_system,
    with_random_zeros,
};
use fdid::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Time domain of a study case.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Continuous time, partial-fraction form (`Rational::continuous`).
    Ct,
    /// Discrete time (`Rational::discrete`).
    Dt,
}

/// One case: the system, its noisy data (with their noise variances) and the noise-free
/// response.
pub struct Case {
    /// The seed the case was built from.
    pub seed: u64,
    /// Domain.
    pub kind: Kind,
    /// The system and grid.
    pub sys: RandomSystem,
    /// Noisy FRF data, σ² = 10⁻⁴ on every line (RMS |G| = 1: 40 dB SNR).
    pub data: FrequencyData<f64>,
    /// Noise-free FRF on the grid.
    pub g0: Vec<Complex<f64>>,
}

/// The noise variance per line: 40 dB below the RMS |G| = 1 of the cases.
pub const NOISE_VAR: f64 = 1e-4;

/// A random stable continuous-time system from `seed`:
/// - na uniform in 1..=10, nb = na − U{0, 1, 2} (≥ 0);
/// - grid: 2–3 decades from 10^U(−1, 1) rad/s, 200–500 log-spaced lines;
/// - poles: modes spread over the band without a 20 % margin at each end (m equal
///   log-segments, each mode log-uniform in the middle 60 % of its segment); each mode is
///   a real pole (probability 0.3, or when one pole is left), or a complex pair, lightly
///   damped (ζ log-uniform in [0.02, 0.1]) or heavily damped (ζ uniform in [0.1, 0.9]) with
///   equal probability;
/// - zeros: real (either sign) or complex pairs (ζ in [0.05, 0.7], either half-plane),
///   |z| log-uniform over the grid, at least 0.25 |p| from every pole p;
/// - gain: RMS |G| = 1 over the grid.
pub fn ct_system(seed: u64) -> RandomSystem {
    let mut rng = StdRng::seed_from_u64(seed ^ 0x5eed_c7c7);
    let na: usize = rng.gen_range(1..=10);
    let nb = na.saturating_sub(rng.gen_range(0..=2usize));
    // mode kinds: true = real pole
    let mut kinds = vec![];
    let mut left = na;
    while left > 0 {
        let real = left == 1 || rng.gen_bool(0.3);
        kinds.push(real);
        left -= if real { 1 } else { 2 };
    }
    let m = kinds.len();
    let decades: f64 = rng.gen_range(2.0..=3.0);
    let w_lo = log_uniform(&mut rng, 0.1, 10.0);
    let w_hi = w_lo * 10f64.powf(decades);
    let n: usize = rng.gen_range(200..=500);
    let omega: Vec<f64> = (0..n)
        .map(|k| w_lo * (w_hi / w_lo).powf(k as f64 / (n - 1) as f64))
        .collect();
    let (lo, hi) = ((w_lo * 1.2).log10(), (w_hi / 1.2).log10());
    let seg = (hi - lo) / m as f64;
    let mut poles = vec![];
    for (i, real) in kinds.iter().enumerate() {
        let w = 10f64.powf(lo + seg * (i as f64 + rng.gen_range(0.2..=0.8)));
        if *real {
            poles.push(Complex::new(-w, 0.0));
        } else {
            let zeta = if rng.gen_bool(0.5) {
                log_uniform(&mut rng, 0.02, 0.1)
            } else {
                rng.gen_range(0.1..=0.9)
            };
            let (re, im) = (-zeta * w, w * (1.0 - zeta * zeta).sqrt());
            poles.push(Complex::new(re, im));
            poles.push(Complex::new(re, -im));
        }
    }
    with_random_zeros(&mut rng, poles, na, nb, (w_lo, w_hi), omega)
}

/// A random stable discrete-time system from `seed`: na uniform in 1..=10, nb uniform in
/// 0..=na, then [`random_dt_system`] (poles of radius 0.3–0.95, 50–400 random lines).
pub fn dt_system(seed: u64) -> RandomSystem {
    let mut rng = StdRng::seed_from_u64(seed ^ 0x5eed_d7d7);
    let na: usize = rng.gen_range(1..=10);
    let nb: usize = rng.gen_range(0..=na);
    random_dt_system(seed, na, nb)
}

fn case(seed: u64, kind: Kind, sys: RandomSystem) -> Case {
    let g0 = sys.frf();
    let mut noise = Noise::new(seed ^ 0x0000_9e37);
    let y: Vec<Complex<f64>> = g0.iter().map(|g| g + noise.complex(NOISE_VAR)).collect();
    let data = FrequencyData::from_frf(sys.omega.clone(), y, sys.zpk.ts)
        .unwrap()
        .with_noise(NoiseVariances::output_only(vec![NOISE_VAR; g0.len()]))
        .unwrap();
    Case {
        seed,
        kind,
        sys,
        data,
        g0,
    }
}

/// The continuous-time case of `seed`.
pub fn ct_case(seed: u64) -> Case {
    case(seed, Kind::Ct, ct_system(seed))
}

/// The discrete-time case of `seed`.
pub fn dt_case(seed: u64) -> Case {
    case(seed, Kind::Dt, dt_system(seed))
}

/// What the study found for one case.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// Seed of the case.
    pub seed: u64,
    /// Domain.
    pub kind: Kind,
    /// Model orders.
    pub na: usize,
    /// Numerator degree.
    pub nb: usize,
    /// Number of lines.
    pub lines: usize,
    /// Cost reached by `Pipeline::fit` from its automatic start, or its error.
    pub auto: std::result::Result<f64, String>,
    /// Whether the automatic fit is stable.
    pub auto_stable: bool,
    /// Wall-clock time of `Pipeline::fit` (s).
    pub auto_time: f64,
    /// Cost reached by the chain alone (`Pipeline { restarts: false, .. }`), or its error.
    pub plain: std::result::Result<f64, String>,
    /// Wall-clock time of the chain alone (s).
    pub plain_time: f64,
    /// Cost reached by `fit_multistart` (continuous time) or `fit_multistart_discrete`,
    /// or its error.
    pub multi: Option<std::result::Result<f64, String>>,
    /// Cost of ML started at the true parameters (`None` if it failed).
    pub truth: Option<f64>,
    /// Best cost of all runs, the automatic one included.
    pub best: f64,
}

impl Outcome {
    /// The automatic fit reached the best cost found, within 10⁻⁶ relative or 10⁻³
    /// absolute.
    pub fn reached(&self) -> bool {
        self.hit(&self.auto)
    }

    /// The chain alone (without the further starts) reached the best cost found.
    pub fn plain_reached(&self) -> bool {
        self.hit(&self.plain)
    }

    /// The multistart fit reached the best cost found.
    pub fn multi_reached(&self) -> Option<bool> {
        self.multi.as_ref().map(|m| self.hit(m))
    }

    fn hit(&self, cost: &std::result::Result<f64, String>) -> bool {
        match cost {
            Ok(c) => *c <= self.best + (1e-6 * self.best).max(1e-3),
            Err(_) => false,
        }
    }
}

/// Stable basis poles (upper half-plane and real) from a conjugate-closed set.
fn basis_poles(poles: &[Complex<f64>]) -> Vec<Complex<f64>> {
    poles
        .iter()
        .filter(|p| p.im >= 0.0)
        .map(|p| Complex::new(-p.re.abs().max(1e-12), p.im))
        .collect()
}

/// ML from `start` for `model`: the cost, `None` when it fails.
fn ml_from(model: &Rational<f64>, data: &FrequencyData<f64>, start: &[f64]) -> Option<f64> {
    estimate(
        model,
        data,
        &MaximumLikelihood::default(),
        &LevenbergMarquardt::default(),
        Some(start),
    )
    .ok()
    .map(|s| s.cost)
}

/// Runs the study on one case: the automatic pipeline, ML from the truth, `perturbed`
/// runs from true poles perturbed by 5 % relative (uniform in a complex square), and the
/// multistart fit (`fit_multistart` or `fit_multistart_discrete`, also measured).
pub fn run(case: &Case, perturbed: usize) -> Outcome {
    let sys = &case.sys;
    let (na, nb) = (sys.na, sys.nb);
    let model = match case.kind {
        Kind::Ct => Rational::continuous(na, nb, case.data.omega()).unwrap(),
        Kind::Dt => Rational::discrete(na, nb, sys.zpk.ts.unwrap()).unwrap(),
    };
    let clock = std::time::Instant::now();
    let (auto, auto_stable) = match Pipeline::default().fit(&model, &case.data) {
        Ok(f) => (
            Ok(f.cost()),
            f.model().is_stable(f.theta()).unwrap_or(false),
        ),
        Err(e) => (Err(e.to_string()), false),
    };
    let auto_time = clock.elapsed().as_secs_f64();
    let clock = std::time::Instant::now();
    let plain = Pipeline {
        restarts: false,
        ..Pipeline::default()
    }
    .fit(&model, &case.data)
    .map(|f| f.cost())
    .map_err(|e| e.to_string());
    let plain_time = clock.elapsed().as_secs_f64();
    let multi = match case.kind {
        Kind::Ct => fit_multistart(&Pipeline::default(), na, nb, &case.data),
        Kind::Dt => fit_multistart_discrete(
            &Pipeline::default(),
            na,
            nb,
            sys.zpk.ts.unwrap(),
            &case.data,
        ),
    }
    .map(|f| f.cost())
    .map_err(|e| e.to_string());
    let multi = Some(multi);
    let mut rng = StdRng::seed_from_u64(case.seed ^ 0x9e37_79b9);
    let mut refs: Vec<f64> = vec![];
    let truth = match case.kind {
        Kind::Ct => {
            // with basis poles at the true poles, Levy on noise-free data gives the true θ
            let m = Rational::partial_fractions(basis_poles(&sys.zpk.poles), nb).unwrap();
            let clean = FrequencyData::from_frf(sys.omega.clone(), case.g0.clone(), None).unwrap();
            let t0 = estimate(
                &m,
                &clean,
                &Levy::default(),
                &LinearLeastSquares::default(),
                None,
            );
            let truth = t0.ok().and_then(|t0| ml_from(&m, &case.data, &t0.theta));
            for _ in 0..perturbed {
                let p: Vec<Complex<f64>> = basis_poles(&sys.zpk.poles)
                    .into_iter()
                    .map(|p| {
                        let g = Complex::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
                        let q = p + g * (0.05 * p.norm());
                        if p.im == 0.0 {
                            Complex::new(-q.re.abs(), 0.0)
                        } else {
                            Complex::new(-q.re.abs(), q.im.abs())
                        }
                    })
                    .collect();
                if let Ok(m) = Rational::partial_fractions(p, nb)
                    && let Ok(f) = Pipeline::default().fit(&m, &case.data)
                {
                    refs.push(f.cost());
                }
            }
            truth
        }
        Kind::Dt => {
            let theta = dt_theta(sys);
            let truth = ml_from(&model, &case.data, &theta);
            for _ in 0..perturbed {
                let p: Vec<Complex<f64>> = {
                    let mut out = vec![];
                    for p in sys.zpk.poles.iter().filter(|p| p.im >= 0.0) {
                        let g = Complex::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
                        let mut q = p + g * (0.05 * p.norm());
                        if q.norm() > 0.99 {
                            q *= 0.99 / q.norm();
                        }
                        if p.im == 0.0 {
                            out.push(Complex::new(q.re, 0.0));
                        } else {
                            out.push(q);
                            out.push(q.conj());
                        }
                    }
                    out
                };
                let mut a = poly_from_roots(&p);
                a.reverse();
                let mut start = a[1..].to_vec();
                start.extend_from_slice(&theta[na..]);
                if let Some(c) = ml_from(&model, &case.data, &start) {
                    refs.push(c);
                }
            }
            truth
        }
    };
    refs.extend(truth);
    if let Ok(c) = auto {
        refs.push(c);
    }
    if let Ok(c) = plain {
        refs.push(c);
    }
    if let Some(Ok(c)) = multi {
        refs.push(c);
    }
    let best = refs.iter().copied().fold(f64::INFINITY, f64::min);
    Outcome {
        seed: case.seed,
        kind: case.kind,
        na,
        nb,
        lines: sys.omega.len(),
        auto,
        auto_stable,
        auto_time,
        plain,
        plain_time,
        multi,
        truth,
        best,
    }
}

/// The study over `count` seeds from `first` for each domain (CT and DT alternate: seed
/// s gives the CT case for even s − first and the DT case for odd), with a progress
/// callback. Returns the outcomes.
pub fn study(
    first: u64,
    count: u64,
    perturbed: usize,
    mut progress: impl FnMut(&Outcome),
) -> Vec<Outcome> {
    (first..first + count)
        .map(|seed| {
            let case = if (seed - first).is_multiple_of(2) {
                ct_case(seed)
            } else {
                dt_case(seed)
            };
            let o = run(&case, perturbed);
            progress(&o);
            o
        })
        .collect()
}

/// `sys` on `n` lines spread over its own band (log-spaced in continuous time, evenly in
/// discrete time), with noise of variance `NOISE_VAR` per line.
pub fn long_record(sys: &RandomSystem, n: usize, seed: u64) -> FrequencyData<f64> {
    let (lo, hi) = (sys.omega[0], *sys.omega.last().unwrap());
    let omega: Vec<f64> = (0..n)
        .map(|k| {
            let x = k as f64 / (n - 1) as f64;
            match sys.zpk.ts {
                None => lo * (hi / lo).powf(x),
                Some(_) => lo + (hi - lo) * x,
            }
        })
        .collect();
    let long = RandomSystem {
        zpk: sys.zpk.clone(),
        na: sys.na,
        nb: sys.nb,
        omega,
    };
    let g0 = long.frf();
    let mut noise = Noise::new(seed ^ 0x51a7);
    let y: Vec<Complex<f64>> = g0.iter().map(|g| g + noise.complex(NOISE_VAR)).collect();
    FrequencyData::from_frf(long.omega, y, sys.zpk.ts)
        .unwrap()
        .with_noise(NoiseVariances::output_only(vec![NOISE_VAR; n]))
        .unwrap()
}
