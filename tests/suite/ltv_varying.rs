//! The Lataire–Pintelon TLS estimator (`fdid::ltv`) on slowly time-varying systems,
//! simulated here by a fixed-step RK4 integration of the ODE (32 sub-steps per sample)
//! driven by a multisine evaluated in continuous time, from rest (so the output carries a
//! transient).
//!
//! The systems: a random stable LTI system (`common::random_ct_system`, orders 1–3) whose
//! non-leading ODE coefficients vary linearly over the record,
//! αₙ(t) = aₙ(1 + εₙ(2t/T − 1)), βₙ(t) = bₙ(1 + δₙ(2t/T − 1)), |εₙ|, |δₙ| ≤ 0.25, with
//! α_{N_α} = 1 (N_p = 1); cases whose frozen poles leave the left half-plane are
//! discarded. The reference is the frozen FRF of eq. 4 from the true coefficients.

use crate::common;

use common::{Noise, poly_from_roots, random_ct_system};
use fdid::ltv::{FrequencyBasis, Lines, LtvOde, TimeBasis};
use fdid::prelude::*;
use quickcheck::{Arbitrary, Gen, TestResult};
use std::f64::consts::TAU;

/// A time-varying ODE with linear-in-time coefficients, monic in the highest derivative.
#[derive(Debug, Clone)]
struct Ltv {
    /// aₙ, n = 0 … N_α (a_{N_α} = 1).
    a: Vec<f64>,
    /// bₙ, n = 0 … N_β.
    b: Vec<f64>,
    /// εₙ (n < N_α).
    eps: Vec<f64>,
    /// δₙ.
    delta: Vec<f64>,
    /// Record length T (s).
    record: f64,
}

impl Ltv {
    fn alpha(&self, t: f64) -> Vec<f64> {
        let x = 2.0 * t / self.record - 1.0;
        let na = self.a.len() - 1;
        (0..=na)
            .map(|n| {
                if n == na {
                    1.0
                } else {
                    self.a[n] * (1.0 + self.eps[n] * x)
                }
            })
            .collect()
    }

    fn beta(&self, t: f64) -> Vec<f64> {
        let x = 2.0 * t / self.record - 1.0;
        self.b
            .iter()
            .zip(&self.delta)
            .map(|(b, d)| b * (1.0 + d * x))
            .collect()
    }

    fn frf(&self, t: f64, omega: &[f64]) -> Vec<Complex<f64>> {
        let (a, b) = (self.alpha(t), self.beta(t));
        let poly = |c: &[f64], s: Complex<f64>| {
            c.iter()
                .rev()
                .fold(Complex::new(0.0, 0.0), |acc, v| acc * s + *v)
        };
        omega
            .iter()
            .map(|w| {
                let s = Complex::new(0.0, *w);
                poly(&b, s) / poly(&a, s)
            })
            .collect()
    }

    /// True if every frozen pole on [0, T] is in the open left half-plane.
    fn stable(&self) -> bool {
        (0..=20).all(|i| {
            let a = self.alpha(self.record * i as f64 / 20.0);
            let d = a.len() - 1;
            if d == 0 {
                return true;
            }
            let mut m = nalgebra::DMatrix::<f64>::zeros(d, d);
            for k in 1..d {
                m[(k, k - 1)] = 1.0;
            }
            for k in 0..d {
                m[(k, d - 1)] = -a[k];
            }
            m.complex_eigenvalues().iter().all(|e| e.re < 0.0)
        })
    }
}

/// A multisine u(t) = Σ A cos(ω_k t + φ_k) on lines 1 … K of a record of length T, with
/// its derivatives.
struct Multisine {
    omega: Vec<f64>,
    phase: Vec<f64>,
    amp: f64,
}

impl Multisine {
    fn new(k_max: usize, record: f64, seed: u64) -> Self {
        let mut noise = Noise::new(seed);
        Self {
            omega: (1..=k_max).map(|k| TAU * k as f64 / record).collect(),
            phase: (0..k_max).map(|_| TAU * noise.gauss()).collect(),
            amp: 1.0 / (k_max as f64).sqrt(),
        }
    }

    /// u⁽ⁿ⁾(t) for n = 0 … out.len() − 1.
    fn derivatives(&self, t: f64, out: &mut [f64]) {
        out.iter_mut().for_each(|v| *v = 0.0);
        for (w, ph) in self.omega.iter().zip(&self.phase) {
            let arg = w * t + ph;
            let (s, c) = arg.sin_cos();
            let mut wn = self.amp;
            for (n, o) in out.iter_mut().enumerate() {
                // dⁿ/dtⁿ cos(arg) = wⁿ cos(arg + nπ/2)
                *o += wn
                    * match n % 4 {
                        0 => c,
                        1 => -s,
                        2 => -c,
                        _ => s,
                    };
                wn *= w;
            }
        }
    }
}

/// RK4 on x = (y, y', …, y^(N_α−1)) from rest, `sub` steps per sample; returns (u, y)
/// sampled at t_d T_s, d = 0 … N − 1.
fn simulate(sys: &Ltv, input: &Multisine, n: usize, ts: f64, sub: usize) -> (Vec<f64>, Vec<f64>) {
    let na = sys.a.len() - 1;
    let nb = sys.b.len() - 1;
    let mut du = vec![0.0; nb + 1];
    let rhs = |t: f64, x: &[f64], du: &mut [f64]| -> Vec<f64> {
        input.derivatives(t, du);
        let (a, b) = (sys.alpha(t), sys.beta(t));
        let forcing: f64 = b.iter().zip(du.iter()).map(|(b, u)| b * u).sum();
        let mut dx = vec![0.0; na];
        dx[..(na - 1)].copy_from_slice(&x[1..na]);
        let top = forcing - (0..na).map(|k| a[k] * x[k]).sum::<f64>();
        dx[na - 1] = top / a[na];
        dx
    };
    let h = ts / sub as f64;
    let mut x = vec![0.0; na];
    let (mut u, mut y) = (vec![0.0; n], vec![0.0; n]);
    let mut tmp = vec![0.0; na];
    let mut u0 = vec![0.0; nb + 1];
    for d in 0..n {
        let t0 = d as f64 * ts;
        input.derivatives(t0, &mut u0);
        u[d] = u0[0];
        y[d] = x[0];
        for s in 0..sub {
            let t = t0 + s as f64 * h;
            let k1 = rhs(t, &x, &mut du);
            for i in 0..na {
                tmp[i] = x[i] + 0.5 * h * k1[i];
            }
            let k2 = rhs(t + 0.5 * h, &tmp, &mut du);
            for i in 0..na {
                tmp[i] = x[i] + 0.5 * h * k2[i];
            }
            let k3 = rhs(t + 0.5 * h, &tmp, &mut du);
            for i in 0..na {
                tmp[i] = x[i] + h * k3[i];
            }
            let k4 = rhs(t + h, &tmp, &mut du);
            for i in 0..na {
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
    }
    (u, y)
}

/// One simulated experiment.
struct Experiment {
    sys: Ltv,
    data: TimeData<f64>,
    k_max: usize,
    omega: Vec<f64>,
}

/// A random slowly time-varying system of orders (na, nb) and its simulated record:
/// N = 1024 samples, lines 1 … 100 excited, the band edge at 1.1 × the top of the random
/// system's grid (so f_s/2 is 5.12 × the band edge). `None` if a frozen pole goes
/// unstable.
fn experiment(seed: u64, na: usize, nb: usize, variation: f64) -> Option<Experiment> {
    let rs = random_ct_system(seed, na, nb);
    let (n, k_max) = (1024usize, 100usize);
    let w_top = 1.1 * rs.omega.last().unwrap();
    let record = TAU * k_max as f64 / w_top;
    let ts = record / n as f64;
    let a = poly_from_roots(&rs.zpk.poles);
    let b: Vec<f64> = poly_from_roots(&rs.zpk.zeros)
        .iter()
        .map(|v| v * rs.zpk.gain)
        .collect();
    let mut noise = Noise::new(seed ^ 0xabc);
    let mut draw = |m: usize| -> Vec<f64> {
        (0..m)
            .map(|_| variation * (2.0 * (noise.gauss().abs().min(3.0) / 3.0) - 1.0))
            .collect()
    };
    let sys = Ltv {
        eps: draw(na),
        delta: draw(nb + 1),
        a,
        b,
        record,
    };
    if !sys.stable() {
        return None;
    }
    let input = Multisine::new(k_max, record, seed ^ 0x77);
    let (u, y) = simulate(&sys, &input, n, ts, 32);
    let data = TimeData::new(u, y, ts).unwrap();
    let omega = (1..=k_max).map(|k| TAU * k as f64 / record).collect();
    Some(Experiment {
        sys,
        data,
        k_max,
        omega,
    })
}

impl Experiment {
    fn band(&self) -> Lines<f64> {
        let df = 1.0 / self.sys.record;
        Lines::band(df, self.k_max as f64 * df)
    }

    /// RMS over 11 instants t* ∈ [0, T] of the relative RMS frozen-FRF error on the band.
    fn frf_error(&self, fit: &LtvFit<f64>) -> f64 {
        let mut acc = 0.0;
        for i in 0..=10 {
            let t = self.sys.record * (i as f64 / 10.0) * (1.0 - 1.0 / 1024.0);
            let g = fit.instantaneous(t).frf(&self.omega);
            let truth = self.sys.frf(t, &self.omega);
            acc += common::rel_rms(&g, &truth).powi(2);
        }
        (acc / 11.0).sqrt()
    }

    fn fit(&self, ntr: Option<usize>, tb: TimeBasis) -> fdid::Result<LtvFit<f64>> {
        let na = self.sys.a.len() - 1;
        let nb = self.sys.b.len() - 1;
        LtvOde::new(na, nb, 1)
            .with_time_basis(tb)
            .with_frequency_basis(FrequencyBasis::legendre(*self.omega.last().unwrap())?)
            .with_transient(ntr)
            .fit(&self.data, &self.band())
    }
}

/// The FRF errors for N_tr = none, 1, 3, 5, 7.
fn errors_by_order(exp: &Experiment) -> Vec<f64> {
    [None, Some(1), Some(3), Some(5), Some(7)]
        .iter()
        .map(|o| exp.frf_error(&exp.fit(*o, TimeBasis::Legendre).unwrap()))
        .collect()
}

#[derive(Debug, Clone, Copy)]
struct Case {
    seed: u64,
    na: usize,
    nb: usize,
}

impl Arbitrary for Case {
    fn arbitrary(g: &mut Gen) -> Self {
        let seed = u64::arbitrary(g);
        let na = 1 + (u32::arbitrary(g) as usize) % 3;
        let nb = (u32::arbitrary(g) as usize) % (na + 1);
        Self { seed, na, nb }
    }
}

fn check<A: Arbitrary + std::fmt::Debug>(seed: u64, tests: u64, prop: fn(A) -> TestResult) {
    crate::common::seeded(seed).tests(tests).quickcheck(prop);
}

/// Property: over random slowly time-varying systems (orders 1–3), the frozen-FRF error
/// falls as the transient + alias polynomial grows: N_tr = 3 is at least 2× below no
/// polynomial, 5 at least 10× below 3, 7 below 5, and N_tr = 7 reaches < 1e-6.
///
/// Survey (40 cases, `survey` below): no polynomial 1.2e-3 … 1.9, N_tr = 1 4e-5 … 0.8
/// (not always better than none: the alias of the non-band-limited response dominates),
/// N_tr = 3 7e-9 … 7e-2, N_tr = 5 5e-11 … 8e-5, N_tr = 7 4e-12 … 1.7e-7; every step
/// none → 3 gains ≥ 18× there (7× in a third-order case found by this property),
/// 3 → 5 ≥ 100×, 5 → 7 ≥ 9×.
#[test]
fn frf_error_falls_with_transient_order() {
    fn prop(c: Case) -> TestResult {
        let Some(exp) = experiment(c.seed, c.na, c.nb, 0.25) else {
            return TestResult::discard();
        };
        let e = errors_by_order(&exp);
        let ok = e[2] < 0.5 * e[0] && e[3] < 0.1 * e[2] && e[4] < e[3] && e[4] < 1e-6;
        if ok {
            TestResult::passed()
        } else {
            TestResult::error(format!("{c:?}: errors for N_tr = none, 1, 3, 5, 7: {e:?}"))
        }
    }
    check(12, 12, prop as fn(Case) -> TestResult);
}

#[test]
#[ignore = "survey: cargo test --release --test suite ltv_varying::survey -- --ignored --nocapture"]
fn survey() {
    let mut g = Gen::from_size_and_seed(100, 1);
    for _ in 0..40 {
        let c = Case::arbitrary(&mut g);
        let Some(exp) = experiment(c.seed, c.na, c.nb, 0.25) else {
            println!("{c:?}: unstable, skipped");
            continue;
        };
        let e = errors_by_order(&exp);
        let e: Vec<String> = e.iter().map(|v| format!("{v:.1e}")).collect();
        println!("na {} nb {}: {e:?}", c.na, c.nb);
    }
}

/// The instantaneous poles of the estimate follow the true frozen poles over the record
/// (a pole sweep), and the monomial form of eqs. 1–2 reproduces the true coefficient
/// polynomials αₙ(t), βₙ(t) up to the common scale.
#[test]
fn pole_sweep_and_monomial_coefficients_follow_the_system() {
    let exp = experiment(3, 2, 1, 0.25).expect("stable");
    let fit = exp.fit(Some(7), TimeBasis::Legendre).unwrap();
    let times: Vec<f64> = (0..=10).map(|i| exp.sys.record * i as f64 / 10.0).collect();
    let sweep = fit.pole_sweep(&times).unwrap();
    for (t, poles) in times.iter().zip(&sweep) {
        let a = exp.sys.alpha(*t);
        // roots of the true frozen denominator s² + a₁ s + a₀
        let disc = Complex::new(a[1] * a[1] - 4.0 * a[0], 0.0).sqrt();
        let mut want = [(-disc - a[1]) / 2.0, (disc - a[1]) / 2.0];
        let key = |p: &Complex<f64>| (p.im, p.re);
        want.sort_by(|x, y| key(x).partial_cmp(&key(y)).unwrap());
        let mut got = poles.clone();
        got.sort_by(|x, y| key(x).partial_cmp(&key(y)).unwrap());
        assert_eq!(got.len(), 2);
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).norm() < 1e-8 * w.norm(), "t {t}: {g} vs {w}");
        }
    }
    let mono = fit.monomial();
    let scale = mono.alpha[2][0]; // α₂(t) = 1 for the true system
    let sys = &exp.sys;
    let x0 = |c: f64, e: f64| c * (1.0 - e); // coefficient of t⁰
    let x1 = |c: f64, e: f64| c * e * 2.0 / sys.record; // coefficient of t¹
    let close = |got: f64, want: f64| (got / scale - want).abs() < 1e-8 * (1.0 + want.abs());
    for n in 0..2 {
        assert!(close(mono.alpha[n][0], x0(sys.a[n], sys.eps[n])), "α_{n},0");
        assert!(close(mono.alpha[n][1], x1(sys.a[n], sys.eps[n])), "α_{n},1");
    }
    assert!(close(mono.alpha[2][1], 0.0), "α_2,1");
    for n in 0..2 {
        assert!(
            close(mono.beta[n][0], x0(sys.b[n], sys.delta[n])),
            "β_{n},0"
        );
        assert!(
            close(mono.beta[n][1], x1(sys.b[n], sys.delta[n])),
            "β_{n},1"
        );
    }
}

/// Noisy case (paper section V-B): white noise on input and output at 28 dB SNR, N_tr = 3.
/// Legendre bases in t and s (eq. 20) give a frozen-FRF error far below monomials, as the
/// paper reports, even though the regressor columns are normalised in both cases.
/// Measured (4 noise seeds): monomial 0.24 … 1.7, Legendre 0.017 … 0.033.
#[test]
fn legendre_bases_beat_monomials_with_noise() {
    let exp = experiment(3, 2, 1, 0.25).expect("stable");
    let rms = |x: &[f64]| (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
    let snr = 10f64.powf(-28.0 / 20.0);
    let (su, sy) = (rms(exp.data.u()) * snr, rms(exp.data.y()) * snr);
    let w = *exp.omega.last().unwrap();
    for seed in 0..4 {
        let mut noise = Noise::new(900 + seed);
        let u: Vec<f64> = exp
            .data
            .u()
            .iter()
            .map(|v| v + su * noise.gauss())
            .collect();
        let y: Vec<f64> = exp
            .data
            .y()
            .iter()
            .map(|v| v + sy * noise.gauss())
            .collect();
        let data = TimeData::new(u, y, exp.data.ts()).unwrap();
        let err = |tb: TimeBasis, fb: FrequencyBasis<f64>| {
            let fit = LtvOde::new(2, 1, 1)
                .with_time_basis(tb)
                .with_frequency_basis(fb)
                .with_transient(Some(3))
                .fit(&data, &exp.band())
                .unwrap();
            exp.frf_error(&fit)
        };
        let mono = err(TimeBasis::Monomial, FrequencyBasis::Monomial);
        let leg = err(
            TimeBasis::Legendre,
            FrequencyBasis::Legendre { omega_max: w },
        );
        println!("seed {seed}: monomial {mono:.3e}, Legendre {leg:.3e}");
        assert!(
            leg < 0.2 * mono,
            "seed {seed}: Legendre {leg:.3e}, monomial {mono:.3e}"
        );
        assert!(leg < 0.05, "seed {seed}: Legendre {leg:.3e}");
    }
}

/// f32 on an easy case: the second-order system with N_tr = 3 (error 6e-7 in f64).
#[test]
fn time_varying_f32() {
    let exp = experiment(3, 2, 1, 0.25).expect("stable");
    let c = |x: &[f64]| x.iter().map(|v| *v as f32).collect::<Vec<f32>>();
    let data = TimeData::new(c(exp.data.u()), c(exp.data.y()), exp.data.ts() as f32).unwrap();
    let df = 1.0 / exp.sys.record as f32;
    let w = *exp.omega.last().unwrap() as f32;
    let fit = LtvOde::new(2, 1, 1)
        .with_frequency_basis(FrequencyBasis::legendre(w).unwrap())
        .with_transient(Some(3))
        .fit(&data, &Lines::band(df, exp.k_max as f32 * df))
        .unwrap();
    let omega: Vec<f32> = exp.omega.iter().map(|w| *w as f32).collect();
    let mut worst: f64 = 0.0;
    for i in 0..=10 {
        let t = exp.sys.record * i as f64 / 10.0;
        let g = fit.instantaneous(t as f32).frf(&omega);
        worst = worst.max(common::rel_rms(&g, &exp.sys.frf(t, &exp.omega)));
    }
    println!("f32 worst frozen-FRF error {worst:.3e}");
    // measured 9.5e-6
    assert!(worst < 1e-4, "f32: {worst:.3e}");
}

/// Timing of the benchmark size: regression matrix + TLS for N = 2¹⁶ samples at
/// f_s = 2048 Hz, N_α = N_β = 4, N_p = 3, band [0, 200] Hz (6401 lines, 44 parameters).
#[test]
#[ignore = "timing: cargo test --release --test suite ltv_varying::timing -- --ignored --nocapture"]
fn timing_large_record() {
    let n = 1 << 16;
    let ts = 1.0 / 2048.0;
    let mut noise = Noise::new(1);
    let u: Vec<f64> = (0..n).map(|_| noise.gauss()).collect();
    let y: Vec<f64> = (0..n).map(|_| noise.gauss()).collect();
    let data = TimeData::new(u, y, ts).unwrap();
    let model =
        LtvOde::new(4, 4, 3).with_frequency_basis(FrequencyBasis::legendre(TAU * 200.0).unwrap());
    let start = std::time::Instant::now();
    let reg = fdid::ltv::regression(&model, &data, &Lines::band(0.0, 200.0)).unwrap();
    let t_reg = start.elapsed();
    let fit = model.fit(&data, &Lines::band(0.0, 200.0)).unwrap();
    let t_all = start.elapsed() - t_reg;
    println!(
        "N = {n}: {} lines × {} columns; regression {t_reg:?}, regression + TLS {t_all:?}",
        reg.lines.len(),
        fit.theta.len()
    );
}
