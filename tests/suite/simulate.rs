//! The time-varying ODE simulator: exact LTI responses (steady state + free response),
//! time-varying cases with closed-form or quadrature solutions, multisine derivatives
//! and spectra, coloured noise at a target SNR, and typed errors on bad input.
//!
//! Run with `cargo test --release --test suite simulate::`.

use fdid::FdidError;
use fdid::simulate::{
    Coefficient, ColouredNoise, DormandPrince, DtFilter, Excitation, LineSelection, Multisine,
    SplitMix64, TimeVaryingOde, snr_db,
};
use fdid::{Complex, TimeData};
use nalgebra::{DMatrix, DVector};
use quickcheck::{Arbitrary, Gen};
use std::f64::consts::TAU;

type C64 = Complex<f64>;

// ---------------------------------------------------------------- reference solutions

/// Ascending coefficients of `lead · Π (s − p)` (real for conjugate-closed `p`).
fn poly_from_roots(roots: &[C64], lead: f64) -> Vec<f64> {
    let mut c = vec![C64::new(lead, 0.0)];
    for r in roots {
        let mut next = vec![C64::new(0.0, 0.0); c.len() + 1];
        for (i, ci) in c.iter().enumerate() {
            next[i + 1] += ci;
            next[i] -= ci * r;
        }
        c = next;
    }
    c.iter().map(|v| v.re).collect()
}

fn poly_eval(c: &[f64], s: C64) -> C64 {
    c.iter()
        .rev()
        .fold(C64::new(0.0, 0.0), |acc, ci| acc * s + ci)
}

/// The exact response of the LTI ODE `Σ αₙ y⁽ⁿ⁾ = Σ βₙ u⁽ⁿ⁾` (poles `lambda`, distinct,
/// roots of `Σ αₙ sⁿ`) to the multisine `u` from the state `x0` at t = 0:
/// `y = y_ss + Σ_j c_j e^{λ_j t}` with `y_ss(t) = Σ_i Re(G(jω_i) A_i e^{jφ_i} e^{jω_i t})`
/// and `c` from `Σ_j c_j λ_jⁱ = x0_i − y_ss⁽ⁱ⁾(0)` (a Vandermonde system).
fn lti_exact(
    alpha: &[f64],
    beta: &[f64],
    lambda: &[C64],
    u: &Multisine<f64>,
    x0: &[f64],
    ts: f64,
    n: usize,
) -> Vec<f64> {
    let na = lambda.len();
    let w: Vec<f64> = u.frequencies_hz().iter().map(|f| TAU * f).collect();
    let g: Vec<C64> = w
        .iter()
        .zip(u.phasors())
        .map(|(wi, p)| {
            let s = C64::new(0.0, *wi);
            poly_eval(beta, s) / poly_eval(alpha, s) * p
        })
        .collect();
    // y_ss^{(i)}(0) = Σ Re(G P (jω)^i)
    let rho = lambda.iter().map(|l| l.norm()).fold(1.0, f64::max);
    let mut v = DMatrix::<C64>::zeros(na, na);
    let mut d = DVector::<C64>::zeros(na);
    for i in 0..na {
        let ss: f64 = w
            .iter()
            .zip(&g)
            .map(|(wi, gi)| (gi * C64::new(0.0, *wi).powu(i as u32)).re)
            .sum();
        // rows scaled by ρ^{-i} for conditioning
        let sc = rho.powi(-(i as i32));
        d[i] = C64::new((x0[i] - ss) * sc, 0.0);
        for j in 0..na {
            v[(i, j)] = lambda[j].powu(i as u32) * sc;
        }
    }
    let c = v.lu().solve(&d).expect("distinct poles");
    (0..n)
        .map(|k| {
            let t = k as f64 * ts;
            let yss: f64 = w
                .iter()
                .zip(&g)
                .map(|(wi, gi)| (gi * C64::new(0.0, wi * t).exp()).re)
                .sum();
            let yh: f64 = c
                .iter()
                .zip(lambda)
                .map(|(cj, l)| (cj * (l * t).exp()).re)
                .sum();
            yss + yh
        })
        .collect()
}

/// `max |a − b| / max |b|`.
fn rel_max(a: &[f64], b: &[f64]) -> f64 {
    let e = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    e / b.iter().map(|y| y.abs()).fold(0.0, f64::max)
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on Pₘ).
fn gauss_legendre(m: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; m];
    let mut w = vec![0.0; m];
    for i in 0..m {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (m as f64 + 0.5)).cos();
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=m {
                let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let dp = m as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                let dp = {
                    let (mut p0, mut p1) = (1.0, z);
                    for k in 2..=m {
                        let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                        p0 = p1;
                        p1 = p2;
                    }
                    m as f64 * (z * p1 - p0) / (z * z - 1.0)
                };
                x[i] = z;
                w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
                break;
            }
        }
    }
    (x, w)
}

// ---------------------------------------------------------------- generators

/// A random stable LTI ODE of order 1 … 4 with distinct poles (conjugate pairs with
/// natural frequencies 2π·[2, 30] rad/s, damping 0.05 … 0.7, or real poles), a random
/// numerator of order ≤ N_α, a random initial state and a multisine seed.
#[derive(Debug, Clone)]
struct LtiCase {
    poles: Vec<C64>,
    beta: Vec<f64>,
    x0: Vec<f64>,
    seed: u64,
}

impl Arbitrary for LtiCase {
    fn arbitrary(g: &mut Gen) -> Self {
        let mut rng = SplitMix64::new(u64::arbitrary(g));
        let na = 1 + (rng.next_u64() % 4) as usize;
        let mut poles = Vec::new();
        while poles.len() < na {
            let wn = TAU * (2.0 + 28.0 * rng.uniform());
            if na - poles.len() >= 2 && rng.uniform() < 0.7 {
                let z = 0.05 + 0.65 * rng.uniform();
                let p = C64::new(-z * wn, wn * (1.0 - z * z).sqrt());
                poles.push(p);
                poles.push(p.conj());
            } else {
                poles.push(C64::new(-wn, 0.0));
            }
        }
        let nb = (rng.next_u64() % (na as u64 + 1)) as usize;
        // numerator scaled like the denominator: β_n ~ ω^{N_α − n}
        let w = TAU * 10.0;
        let beta = (0..=nb)
            .map(|n| (rng.uniform() - 0.5) * w.powi(na as i32 - n as i32))
            .collect();
        let x0 = (0..na)
            .map(|i| (rng.uniform() - 0.5) * w.powi(i as i32))
            .collect();
        Self {
            poles,
            beta,
            x0,
            seed: rng.next_u64(),
        }
    }
}

/// Simulates an LTI case and returns (simulated, exact, steps).
fn run_lti(case: &LtiCase, opts: &DormandPrince) -> (Vec<f64>, Vec<f64>, usize) {
    let fs = 256.0;
    let n = 256;
    let alpha = poly_from_roots(&case.poles, 1.0);
    let ode = TimeVaryingOde::new(
        alpha.iter().map(|a| Coefficient::constant(*a)).collect(),
        case.beta
            .iter()
            .map(|b| Coefficient::constant(*b))
            .collect(),
    )
    .unwrap();
    let u = Multisine::new(1.0, [1.0, 40.0], fs, LineSelection::All, case.seed).unwrap();
    let sol = ode.simulate(&u, 1.0 / fs, n, &case.x0, opts).unwrap();
    let exact = lti_exact(&alpha, &case.beta, &case.poles, &u, &case.x0, 1.0 / fs, n);
    (sol.y, exact, sol.steps)
}

// ---------------------------------------------------------------- ODE tests

/// A 4th-order biproper LTI system (input derivatives up to u'''') against its exact
/// steady-state + free response.
#[test]
fn lti_fourth_order_matches_exact_response() {
    let poles = vec![
        C64::new(-8.0, 60.0),
        C64::new(-8.0, -60.0),
        C64::new(-20.0, 150.0),
        C64::new(-20.0, -150.0),
    ];
    let case = LtiCase {
        beta: poly_from_roots(
            &[
                C64::new(-30.0, 90.0),
                C64::new(-30.0, -90.0),
                C64::new(-5.0, 0.0),
                C64::new(-200.0, 0.0),
            ],
            0.5,
        ),
        poles,
        x0: vec![0.3, -20.0, 1000.0, 5e4],
        seed: 11,
    };
    let (sim, exact, steps) = run_lti(&case, &DormandPrince::new());
    let err = rel_max(&sim, &exact);
    println!("4th-order LTI: relative max error {err:.2e}, {steps} steps");
    assert!(err < 1e-10, "relative error {err:e}");
    // a looser tolerance gives a visibly larger error: the tolerance is what limits it
    let (loose, _, loose_steps) = run_lti(&case, &DormandPrince::new().with_rtol(1e-6));
    let err_loose = rel_max(&loose, &exact);
    println!("  rtol 1e-6: {err_loose:.2e}, {loose_steps} steps");
    assert!(err_loose > 10.0 * err && err_loose < 1e-4);
}

/// Random stable LTI systems of orders 1 … 4 with random numerators and initial states.
#[test]
fn quickcheck_lti_matches_exact_response() {
    fn prop(case: LtiCase) -> bool {
        let (sim, exact, _) = run_lti(&case, &DormandPrince::new());
        let err = rel_max(&sim, &exact);
        if err >= 1e-10 || err.is_nan() {
            println!("{case:?}: relative error {err:e}");
        }
        err < 1e-10
    }
    crate::common::seeded(0xb36a30f9)
        .tests(25)
        .quickcheck(prop as fn(LtiCase) -> bool);
}

/// ẏ + (a₀ + a₁ t) y = 0: y = y₀ exp(−a₀ t − a₁ t²/2), exactly.
#[test]
fn first_order_time_varying_free_response_is_exact() {
    let (a0, a1, y0) = (2.0, 3.0, 1.5);
    let ode =
        TimeVaryingOde::from_polynomials(vec![vec![a0, a1], vec![1.0]], vec![vec![1.0]]).unwrap();
    let zero = Multisine::from_lines(1.0, vec![3], vec![0.0], vec![0.0]).unwrap();
    let (ts, n) = (0.01, 200);
    let y = ode
        .simulate(&zero, ts, n, &[y0], &DormandPrince::new())
        .unwrap()
        .y;
    let exact: Vec<f64> = (0..n)
        .map(|k| {
            let t = k as f64 * ts;
            y0 * (-a0 * t - 0.5 * a1 * t * t).exp()
        })
        .collect();
    // the tolerance is relative to each state's peak, so the error is measured against the
    // peak too; pointwise, where y has decayed to 5e-5 of its start, it is larger
    let err = rel_max(&y, &exact);
    let pointwise = y
        .iter()
        .zip(&exact)
        .map(|(a, b)| ((a - b) / b).abs())
        .fold(0.0, f64::max);
    println!("free response: relative max error {err:.2e}, pointwise {pointwise:.2e}");
    assert!(err < 1e-11, "{err:e}");
    assert!(pointwise < 1e-8, "{pointwise:e}");
}

/// ẏ + a(t) y = b(t) u with a(t) = a₀ + a₁ t, b(t) = 1 + t/2 and u a multisine, against
/// the integrating-factor formula
/// `y(t_{k+1}) = e^{−(A(t_{k+1})−A(t_k))} y(t_k) + ∫_{t_k}^{t_{k+1}} e^{−(A(t_{k+1})−A(s))} b(s) u(s) ds`,
/// `A' = a`, by composite 20-point Gauss–Legendre quadrature.
#[test]
fn first_order_time_varying_forced_matches_quadrature() {
    let (a0, a1) = (5.0, -2.0); // a(t) = 5 − 2t stays positive on [0, 2]
    let ode = TimeVaryingOde::new(
        vec![
            Coefficient::polynomial(vec![a0, a1]),
            Coefficient::constant(1.0),
        ],
        vec![Coefficient::polynomial(vec![1.0, 0.5])],
    )
    .unwrap();
    let fs = 128.0;
    let (ts, n) = (1.0 / fs, 256);
    let u = Multisine::new(1.0, [0.0, 20.0], fs, LineSelection::Odd, 3).unwrap();
    let y0 = 0.7;
    let y = ode
        .simulate(&u, ts, n, &[y0], &DormandPrince::new())
        .unwrap()
        .y;
    let big_a = |t: f64| a0 * t + 0.5 * a1 * t * t;
    let (gx, gw) = gauss_legendre(20);
    let panels = 4;
    let mut du = [0.0];
    let mut exact = vec![y0];
    for k in 0..n - 1 {
        let (t0, t1) = (k as f64 * ts, (k + 1) as f64 * ts);
        let mut integral = 0.0;
        for p in 0..panels {
            let (lo, hi) = (
                t0 + (t1 - t0) * p as f64 / panels as f64,
                t0 + (t1 - t0) * (p + 1) as f64 / panels as f64,
            );
            for (x, w) in gx.iter().zip(&gw) {
                let s = 0.5 * (lo + hi) + 0.5 * (hi - lo) * x;
                u.derivatives_into(s, &mut du);
                integral +=
                    0.5 * (hi - lo) * w * (big_a(s) - big_a(t1)).exp() * (1.0 + 0.5 * s) * du[0];
            }
        }
        let prev = exact[k];
        exact.push((big_a(t0) - big_a(t1)).exp() * prev + integral);
    }
    let err = rel_max(&y, &exact);
    println!("forced first-order LTV: relative max error {err:.2e}");
    assert!(err < 1e-9, "{err:e}");
}

/// With βₙ(t) = αₙ(t) (time-varying, of order N_β = N_α, closures and polynomials mixed)
/// and x(0) = [u(0), u'(0), …], the unique solution is y = u: this checks the realisation
/// with time-varying coefficients on the input derivatives exactly.
#[test]
fn time_varying_input_derivatives_reproduce_the_input() {
    let alpha = vec![
        Coefficient::function(|t| 400.0 * (1.0 + 0.5 * (3.0 * t).sin())),
        Coefficient::polynomial(vec![20.0, -4.0, 2.0]),
        Coefficient::function(|t| 1.0 + 0.2 * t * t),
    ];
    let ode = TimeVaryingOde::new(alpha.clone(), alpha).unwrap();
    assert_eq!((ode.order(), ode.input_order()), (2, 2));
    let fs = 200.0;
    let u = Multisine::new(2.0, [0.5, 30.0], fs, LineSelection::All, 5).unwrap();
    let mut d = [0.0; 2];
    u.derivatives_into(0.0, &mut d);
    let n = 400;
    let y = ode
        .simulate(&u, 1.0 / fs, n, &d, &DormandPrince::new())
        .unwrap()
        .y;
    let want = u.sample(1.0 / fs, n);
    let err = rel_max(&y, &want);
    println!("y = u with time-varying α = β: relative max error {err:.2e}");
    assert!(err < 1e-10, "{err:e}");
}

/// A static equation (N_α = 0): y = (β₀(t) u + β₁(t) u') / α₀(t) at the samples.
#[test]
fn static_equation_is_evaluated_directly() {
    let ode =
        TimeVaryingOde::from_polynomials(vec![vec![2.0, 1.0]], vec![vec![1.0], vec![0.0, 0.1]])
            .unwrap();
    let u = Multisine::new(1.0, [1.0, 10.0], 64.0, LineSelection::All, 9).unwrap();
    let sol = ode
        .simulate(&u, 1.0 / 64.0, 64, &[], &DormandPrince::new())
        .unwrap();
    for (k, y) in sol.y.iter().enumerate() {
        let t = k as f64 / 64.0;
        let want = (u.value(t) + 0.1 * t * u.derivative(t, 1)) / (2.0 + t);
        assert!((y - want).abs() <= 1e-14 * want.abs().max(1.0));
    }
}

/// The record in f32 equals the f64 one rounded; its u is the sampled multisine.
#[test]
fn simulate_record_in_f32_and_f64() {
    let ode = TimeVaryingOde::from_polynomials(
        vec![vec![900.0, 100.0], vec![12.0], vec![1.0]],
        vec![vec![900.0]],
    )
    .unwrap();
    let u64 = Multisine::new(1.0, [1.0, 20.0], 128.0, LineSelection::Odd, 2).unwrap();
    let u32 = Multisine::new(1.0f32, [1.0, 20.0], 128.0, LineSelection::Odd, 2).unwrap();
    let opts = DormandPrince::new();
    let r64: TimeData<f64> = ode
        .simulate_record(&u64, 1.0 / 128.0, 128, &[0.0, 0.0], &opts)
        .unwrap();
    let r32: TimeData<f32> = ode
        .simulate_record(&u32, 1.0f32 / 128.0, 128, &[0.0, 0.0], &opts)
        .unwrap();
    assert_eq!(r64.u(), u64.sample(1.0 / 128.0, 128).as_slice());
    let scale = r64.y().iter().map(|v| v.abs()).fold(0.0, f64::max);
    for (a, b) in r32.y().iter().zip(r64.y()) {
        assert!((*a as f64 - b).abs() < 1e-5 * scale, "{a} vs {b}");
    }
}

// ---------------------------------------------------------------- multisine tests

#[derive(Debug, Clone)]
struct MsCase {
    seed: u64,
    t: f64,
    odd: bool,
    fmax: f64,
}

impl Arbitrary for MsCase {
    fn arbitrary(g: &mut Gen) -> Self {
        let mut rng = SplitMix64::new(u64::arbitrary(g));
        Self {
            seed: rng.next_u64(),
            t: 10.0 * rng.uniform(),
            odd: rng.uniform() < 0.5,
            fmax: 5.0 + 95.0 * rng.uniform(),
        }
    }
}

/// dⁿu/dtⁿ against a central difference of dⁿ⁻¹u/dtⁿ⁻¹ (error O((ω h)²) + rounding).
#[test]
fn quickcheck_multisine_derivatives_match_finite_differences() {
    fn prop(c: MsCase) -> bool {
        let sel = if c.odd {
            LineSelection::Odd
        } else {
            LineSelection::All
        };
        let u = Multisine::new(0.5, [0.0, c.fmax], 1000.0, sel, c.seed).unwrap();
        let w = TAU * c.fmax;
        let h = 1e-4 / w;
        let mut ok = true;
        for n in 1..=4 {
            let mut p = vec![0.0; n + 1];
            let mut m = vec![0.0; n + 1];
            let mut d = vec![0.0; n + 1];
            u.derivatives_into(c.t + h, &mut p);
            u.derivatives_into(c.t - h, &mut m);
            u.derivatives_into(c.t, &mut d);
            let fd = (p[n - 1] - m[n - 1]) / (2.0 * h);
            // scale of the n-th derivative: RMS · ω_maxⁿ
            let scale = w.powi(n as i32);
            let err = (fd - d[n]).abs() / scale;
            ok &= err < 1e-7;
            ok &= (u.derivative(c.t, n) - d[n]).abs() <= 1e-15 * scale;
            if err >= 1e-7 {
                println!("{c:?} n = {n}: {err:e}");
            }
        }
        ok
    }
    crate::common::seeded(0xc46d006f)
        .tests(100)
        .quickcheck(prop as fn(MsCase) -> bool);
}

/// Sampled on one period below Nyquist, the multisine's power equals the analytic RMS²
/// and its DFT is zero off the excited lines (no leakage), in f64 and f32.
#[test]
fn quickcheck_multisine_spectrum_and_rms() {
    fn prop(c: MsCase) -> bool {
        let sel = if c.odd {
            LineSelection::Odd
        } else {
            LineSelection::All
        };
        let (period, fs) = (1.0, 256.0);
        let n = 256;
        let u = Multisine::new(period, [1.0, c.fmax], fs, sel, c.seed)
            .unwrap()
            .with_rms(2.5)
            .unwrap();
        let x = u.sample(1.0 / fs, n);
        let ms = x.iter().map(|v| v * v).sum::<f64>() / n as f64;
        let mut ok = (ms - 6.25).abs() < 1e-12 && (u.rms() - 2.5).abs() < 1e-14;
        let data = TimeData::new(x.clone(), x, 1.0 / fs).unwrap().dft();
        let lines = u.lines();
        for (k, yk) in data.y().iter().enumerate() {
            let excited = lines.contains(&k);
            // |U_k| = √N A/2 on an excited line (1/√N DFT, McKelvey eq. 1)
            if excited {
                let i = lines.iter().position(|l| *l == k).unwrap();
                ok &= (yk.norm() - (n as f64).sqrt() * u.amplitudes()[i] / 2.0).abs() < 1e-10;
            } else {
                ok &= yk.norm() < 1e-11;
            }
            if sel == LineSelection::Odd && k % 2 == 0 {
                ok &= !excited;
            }
        }
        // f32: same signal to f32 rounding
        let u32 = Multisine::new(period as f32, [1.0, c.fmax as f32], fs as f32, sel, c.seed)
            .unwrap()
            .with_rms(2.5)
            .unwrap();
        let x32 = u32.sample(1.0 / fs as f32, n);
        let ms32 = x32.iter().map(|v| (*v as f64).powi(2)).sum::<f64>() / n as f64;
        ok &= (ms32 - 6.25).abs() < 1e-4;
        ok
    }
    crate::common::seeded(0x5d6451d5)
        .tests(50)
        .quickcheck(prop as fn(MsCase) -> bool);
}

/// The evaluation (rotations by recurrence, re-anchored every 32 lines) against the
/// direct sum `Σ A ωⁿ cos(ω t + φ + nπ/2)` with one `cos` per line, on 1601 lines with
/// odd and gapped line sets, at times up to 100 periods.
#[test]
fn quickcheck_multisine_matches_direct_sum() {
    fn prop(c: MsCase) -> bool {
        let sel = if c.odd {
            LineSelection::Odd
        } else {
            LineSelection::All
        };
        let u = Multisine::new(8.0, [0.0, 200.0], 2048.0, sel, c.seed).unwrap();
        // a gapped set too: every third line of u
        let keep: Vec<usize> = (0..u.lines().len()).filter(|i| i % 3 != 1).collect();
        let gapped = Multisine::from_lines(
            8.0,
            keep.iter().map(|&i| u.lines()[i]).collect(),
            keep.iter().map(|&i| u.amplitudes()[i]).collect(),
            keep.iter().map(|&i| u.phases()[i]).collect(),
        )
        .unwrap();
        // a dyadic t = q / 1024, so that the reference phase 2π frac(k t / 8) is computed
        // exactly in integers: ω t itself would carry ~1e-10 rad of rounding at t ~ 800 s
        let q = (80.0 * c.t * 1024.0).round() as u64;
        let t = q as f64 / 1024.0;
        let mut ok = true;
        for ms in [&u, &gapped] {
            let mut d = [0.0; 5];
            ms.derivatives_into(t, &mut d);
            for (n, dn) in d.iter().enumerate() {
                let mut direct = 0.0;
                let mut abs = 0.0;
                for ((k, a), p) in ms.lines().iter().zip(ms.amplitudes()).zip(ms.phases()) {
                    let w = TAU * *k as f64 / 8.0;
                    let frac = ((*k as u64 * q) % 8192) as f64 / 8192.0;
                    let term = a
                        * w.powi(n as i32)
                        * (TAU * frac + p + n as f64 * std::f64::consts::FRAC_PI_2).cos();
                    direct += term;
                    abs += term.abs();
                }
                let err = (dn - direct).abs() / abs;
                if err > 1e-14 {
                    println!("{c:?} n = {n}: {err:e}");
                    ok = false;
                }
            }
        }
        ok
    }
    crate::common::seeded(0x2a636143)
        .tests(30)
        .quickcheck(prop as fn(MsCase) -> bool);
}

#[test]
fn multisine_line_selection_and_band_edges() {
    // band edges are inclusive; DC gets phase 0
    let u = Multisine::new(2.0, [0.0, 10.0], 100.0, LineSelection::All, 1).unwrap();
    assert_eq!(u.lines(), (0..=20).collect::<Vec<_>>().as_slice());
    assert_eq!(u.phases()[0], 0.0);
    assert_eq!(u.frequencies_hz()[20], 10.0);
    let odd = Multisine::new(2.0, [0.0, 10.0], 100.0, LineSelection::Odd, 1).unwrap();
    assert_eq!(
        odd.lines(),
        (0..10).map(|i| 2 * i + 1).collect::<Vec<_>>().as_slice()
    );
    // the seed fixes the phases
    let again = Multisine::new(2.0, [0.0, 10.0], 100.0, LineSelection::Odd, 1).unwrap();
    let other = Multisine::new(2.0, [0.0, 10.0], 100.0, LineSelection::Odd, 2).unwrap();
    assert_eq!(odd, again);
    assert_ne!(odd.phases(), other.phases());
    // the DC line counts fully in the RMS: a constant 3
    let dc = Multisine::from_lines(1.0, vec![0], vec![3.0], vec![0.0]).unwrap();
    assert_eq!(dc.rms(), 3.0);
    assert_eq!(dc.value(0.7), 3.0);
}

// ---------------------------------------------------------------- noise tests

#[derive(Debug, Clone)]
struct NoiseCase {
    seed: u64,
    snr: f64,
    pole: f64,
}

impl Arbitrary for NoiseCase {
    fn arbitrary(g: &mut Gen) -> Self {
        let mut rng = SplitMix64::new(u64::arbitrary(g));
        Self {
            seed: rng.next_u64(),
            snr: -20.0 + 80.0 * rng.uniform(),
            pole: 0.95 * (2.0 * rng.uniform() - 1.0),
        }
    }
}

/// The scaled noise gives the requested SNR (to rounding), in f64 and f32.
#[test]
fn quickcheck_noise_has_requested_snr() {
    fn prop(c: NoiseCase) -> bool {
        let s = Multisine::new(1.0, [1.0, 50.0], 256.0, LineSelection::All, c.seed)
            .unwrap()
            .sample(1.0 / 256.0, 1000);
        let noise = ColouredNoise::new(
            DtFilter::new(vec![1.0, 0.5], vec![1.0, -c.pole]).unwrap(),
            c.seed,
        );
        let (noisy, v) = noise.add_at_snr(&s, c.snr).unwrap();
        let got = snr_db(&s, &v).unwrap();
        let diff: Vec<f64> = noisy.iter().zip(&s).map(|(a, b)| a - b).collect();
        let got2 = snr_db(&s, &diff).unwrap();
        let s32: Vec<f32> = s.iter().map(|v| *v as f32).collect();
        let v32 = noise.at_snr(&s32, c.snr).unwrap();
        let got32 = snr_db(&s32, &v32).unwrap();
        (got - c.snr).abs() < 1e-9 && (got2 - c.snr).abs() < 1e-6 && (got32 - c.snr).abs() < 1e-4
    }
    crate::common::seeded(0xb407f4e0)
        .tests(100)
        .quickcheck(prop as fn(NoiseCase) -> bool);
}

/// The noise is coloured by the filter: white input N(0, 1), averaged periodogram in
/// bands against |H(e^{jθ})|², and the impulse response of 1 / (1 − 0.5 z⁻¹).
#[test]
fn coloured_noise_has_the_filter_spectrum() {
    let e = ColouredNoise::white(4).generate(200_000);
    let mean = e.iter().sum::<f64>() / e.len() as f64;
    let var = e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / e.len() as f64;
    assert!(
        mean.abs() < 0.01 && (var - 1.0).abs() < 0.01,
        "{mean} {var}"
    );
    let h = DtFilter::new(vec![1.0], vec![1.0, -0.5]).unwrap();
    let mut imp = vec![0.0; 10];
    imp[0] = 1.0;
    for (k, v) in h.filter(&imp).iter().enumerate() {
        assert!((v - 0.5f64.powi(k as i32)).abs() < 1e-15);
    }
    // second-order resonant filter (23 dB above its floor): Welch averaged periodogram
    // with a Hann window (a rectangular window leaks ~10 % of the peak into the floor)
    let f = DtFilter::new(vec![1.0, 0.3], vec![1.0, -1.2, 0.72]).unwrap();
    let seg = 256;
    let segs = 400;
    let v = ColouredNoise::new(f.clone(), 8).generate(seg * segs);
    let hann: Vec<f64> = (0..seg)
        .map(|t| 0.5 - 0.5 * (TAU * t as f64 / seg as f64).cos())
        .collect();
    let w2 = hann.iter().map(|w| w * w).sum::<f64>() / seg as f64;
    let mut psd = vec![0.0; seg / 2];
    for s in 0..segs {
        let xw: Vec<f64> = v[s * seg..(s + 1) * seg]
            .iter()
            .zip(&hann)
            .map(|(x, w)| x * w)
            .collect();
        let x = TimeData::new(xw, vec![0.0; seg], 1.0).unwrap().dft();
        for (k, p) in psd.iter_mut().enumerate() {
            *p += x.u()[k].norm_sqr() / (w2 * segs as f64);
        }
    }
    // bands of 16 lines, skipping DC (each band averages ~6400 periodogram values: ~2 %
    // standard deviation)
    for b in 0..seg / 32 {
        let ks = (b * 16).max(1)..(b + 1) * 16;
        let est: f64 = ks.clone().map(|k| psd[k]).sum::<f64>() / ks.len() as f64;
        let want: f64 = ks
            .clone()
            .map(|k| f.response(TAU * k as f64 / seg as f64).norm_sqr())
            .sum::<f64>()
            / ks.len() as f64;
        assert!((est / want - 1.0).abs() < 0.06, "band {b}: {est} vs {want}");
    }
}

// ---------------------------------------------------------------- typed errors

/// The name carried by an `InvalidArgument` error.
fn name<X: std::fmt::Debug>(r: fdid::Result<X>) -> &'static str {
    match r {
        Err(FdidError::InvalidArgument { name, .. }) => name,
        other => panic!("expected InvalidArgument, got {other:?}"),
    }
}

fn zero_input() -> Multisine<f64> {
    Multisine::from_lines(1.0, vec![1], vec![0.0], vec![0.0]).unwrap()
}

#[test]
fn bad_input_gives_typed_errors() {
    use FdidError::*;
    // multisine
    assert_eq!(
        name(Multisine::new(
            1.0,
            [1.0, 200.0],
            400.0,
            LineSelection::All,
            0
        )),
        "band_hz"
    );
    assert_eq!(
        name(Multisine::new(
            1.0,
            [1.0, 100.0],
            200.0,
            LineSelection::All,
            0
        )),
        "band_hz"
    );
    assert!(matches!(
        Multisine::new(1.0, [0.2, 0.8], 100.0, LineSelection::All, 0),
        Err(EmptyBand { .. })
    ));
    assert!(matches!(
        Multisine::new(1.0, [2.0, 2.0], 100.0, LineSelection::Odd, 0),
        Err(EmptyBand { .. })
    ));
    assert_eq!(
        name(Multisine::new(
            1.0,
            [5.0, 1.0],
            100.0,
            LineSelection::All,
            0
        )),
        "band_hz"
    );
    assert_eq!(
        name(Multisine::new(
            1.0,
            [f64::NAN, 1.0],
            100.0,
            LineSelection::All,
            0
        )),
        "band_hz"
    );
    assert_eq!(
        name(Multisine::new(
            0.0,
            [1.0, 2.0],
            100.0,
            LineSelection::All,
            0
        )),
        "period"
    );
    assert_eq!(
        name(Multisine::new(1.0, [1.0, 2.0], -1.0, LineSelection::All, 0)),
        "fs"
    );
    assert!(matches!(
        Multisine::<f64>::from_lines(1.0, vec![], vec![], vec![]),
        Err(TooShort { .. })
    ));
    assert!(matches!(
        Multisine::from_lines(1.0, vec![1, 2], vec![1.0], vec![0.0, 0.0]),
        Err(LengthMismatch {
            what: "amplitudes",
            ..
        })
    ));
    assert!(matches!(
        Multisine::from_lines(1.0, vec![2, 1], vec![1.0; 2], vec![0.0; 2]),
        Err(Unsorted { index: 1, .. })
    ));
    assert!(matches!(
        Multisine::from_lines(1.0, vec![2, 2], vec![1.0; 2], vec![0.0; 2]),
        Err(DuplicateFrequency { index: 1, .. })
    ));
    assert!(matches!(
        Multisine::from_lines(1.0, vec![1, 2], vec![1.0, f64::NAN], vec![0.0; 2]),
        Err(NonFinite {
            what: "amplitudes",
            index: 1,
            ..
        })
    ));
    let zero = Multisine::from_lines(1.0, vec![1], vec![0.0], vec![0.0]).unwrap();
    assert_eq!(name(zero.clone().with_rms(1.0)), "rms");
    assert_eq!(name(zero.clone().with_rms(-1.0)), "rms");
    assert!(zero.with_rms(0.0).is_ok());
    let u = Multisine::from_lines(1.0, vec![1, 30], vec![1.0; 2], vec![0.0; 2]).unwrap();
    assert_eq!(name(u.check_sampling(60.0)), "band_hz");
    assert!(u.check_sampling(61.0).is_ok());

    // ODE construction
    assert!(matches!(
        TimeVaryingOde::from_polynomials(vec![], vec![vec![1.0]]),
        Err(TooShort { what: "alpha", .. })
    ));
    assert!(matches!(
        TimeVaryingOde::from_polynomials(vec![vec![1.0]], vec![]),
        Err(TooShort { what: "beta", .. })
    ));
    assert!(matches!(
        TimeVaryingOde::from_polynomials(
            vec![vec![1.0], vec![1.0, f64::INFINITY]],
            vec![vec![1.0]]
        ),
        Err(NonFinite {
            what: "alpha",
            index: 1,
            ..
        })
    ));
    // simulation
    let ode =
        TimeVaryingOde::from_polynomials(vec![vec![1.0], vec![1.0]], vec![vec![1.0]]).unwrap();
    let opts = DormandPrince::new();
    assert!(matches!(
        ode.simulate(&u, 0.01, 10, &[0.0, 0.0], &opts),
        Err(LengthMismatch {
            what: "x0",
            expected: 1,
            got: 2
        })
    ));
    assert!(matches!(
        ode.simulate(&u, 0.01, 10, &[f64::NAN], &opts),
        Err(NonFinite { what: "x0", .. })
    ));
    assert!(matches!(
        ode.simulate(&u, 0.01, 0, &[0.0], &opts),
        Err(TooShort { .. })
    ));
    assert_eq!(name(ode.simulate(&u, 0.0, 10, &[0.0], &opts)), "ts");
    assert_eq!(
        name(ode.simulate(&u, 0.01, 10, &[0.0], &opts.with_rtol(0.0))),
        "rtol"
    );
    assert_eq!(
        name(ode.simulate(&u, 0.01, 10, &[0.0], &opts.with_atol(-1.0))),
        "atol"
    );
    assert_eq!(
        name(ode.simulate(&u, 0.01, 10, &[0.0], &opts.with_max_step(f64::NAN))),
        "max_step"
    );
    assert_eq!(
        name(ode.simulate(&u, 0.01, 10, &[0.0], &opts.with_max_steps(0))),
        "max_steps"
    );
    assert!(matches!(
        ode.simulate(&u, 0.01, 100, &[0.0], &opts.with_max_steps(50)),
        Err(NotConverged { .. })
    ));
    // the leading coefficient t − 0.5 vanishes inside the record: a polynomial is
    // checked before integrating, a function where it is evaluated
    let singular =
        TimeVaryingOde::from_polynomials(vec![vec![1.0], vec![-0.5, 1.0]], vec![vec![1.0]])
            .unwrap();
    assert!(singular.simulate(&u, 0.01, 40, &[0.0], &opts).is_ok());
    assert_eq!(name(singular.simulate(&u, 0.1, 10, &[0.0], &opts)), "alpha");
    let singular_fn = TimeVaryingOde::new(
        vec![
            Coefficient::constant(1.0),
            Coefficient::function(|t| t - 0.5),
        ],
        vec![Coefficient::constant(1.0)],
    )
    .unwrap();
    assert_eq!(
        name(singular_fn.simulate(&zero_input(), 0.1, 10, &[0.0], &opts)),
        "alpha"
    );
    assert_eq!(
        name(
            TimeVaryingOde::from_polynomials(vec![vec![0.0]], vec![vec![1.0]])
                .unwrap()
                .simulate(&u, 0.1, 10, &[], &opts)
        ),
        "alpha"
    );
    // a coefficient function returning NaN
    let nan = TimeVaryingOde::new(
        vec![
            Coefficient::function(|t| if t > 0.05 { f64::NAN } else { 1.0 }),
            Coefficient::constant(1.0),
        ],
        vec![Coefficient::constant(1.0)],
    )
    .unwrap();
    assert!(matches!(
        nan.simulate(&u, 0.01, 10, &[0.0], &opts),
        Err(Numerical { .. })
    ));
    // the record helper needs two samples
    assert!(matches!(
        ode.simulate_record(&u, 0.01, 1, &[0.0], &opts),
        Err(TooShort { .. })
    ));

    // noise
    assert!(matches!(
        DtFilter::new(vec![], vec![1.0]),
        Err(TooShort { what: "b", .. })
    ));
    assert!(matches!(
        DtFilter::new(vec![1.0], vec![1.0, f64::NAN]),
        Err(NonFinite {
            what: "a",
            index: 1,
            ..
        })
    ));
    assert_eq!(name(DtFilter::new(vec![1.0], vec![0.0, 1.0])), "a");
    assert_eq!(name(DtFilter::new(vec![1.0], vec![1.0, -1.0])), "a");
    assert_eq!(name(DtFilter::new(vec![1.0], vec![1.0, 0.0, 1.21])), "a");
    let w = ColouredNoise::white(0);
    assert_eq!(name(w.at_snr(&[1.0, 2.0], f64::INFINITY)), "snr_db");
    assert_eq!(name(w.at_snr(&[0.0f64, 0.0], 10.0)), "signal");
    assert!(matches!(w.at_snr::<f64>(&[], 10.0), Err(TooShort { .. })));
    assert!(matches!(
        w.at_snr(&[1.0, f64::NAN], 10.0),
        Err(NonFinite {
            what: "signal",
            index: 1,
            ..
        })
    ));
    assert!(matches!(
        snr_db(&[1.0, 2.0], &[1.0]),
        Err(LengthMismatch { what: "noise", .. })
    ));
    assert_eq!(name(snr_db(&[1.0, 2.0], &[0.0, 0.0])), "noise");
}

/// Cost at the scale of Lataire & Pintelon's section V: f_s = 2048 Hz, [0, 200] Hz excited
/// (random phases, all lines), a 4th-order system with N_β = 4 whose coefficients drift
/// linearly, 2¹⁴ samples (a 8 s period: 1601 lines). Checks the result against a run at a
/// 100× tighter tolerance and prints the work. Slow (~20 s for the first run, ~1 min for
/// the reference at rtol 1e-14, on one core):
/// `cargo test --release --test suite -- --ignored --nocapture simulate::paper_scale`.
#[test]
#[ignore]
fn paper_scale_simulation() {
    let fs = 2048.0;
    let n = 1 << 14;
    let period = n as f64 / fs;
    let wn0 = poly_from_roots(
        &[
            C64::new(-40.0, 400.0),
            C64::new(-40.0, -400.0),
            C64::new(-60.0, 900.0),
            C64::new(-60.0, -900.0),
        ],
        1.0,
    );
    let wn1 = poly_from_roots(
        &[
            C64::new(-50.0, 600.0),
            C64::new(-50.0, -600.0),
            C64::new(-40.0, 1100.0),
            C64::new(-40.0, -1100.0),
        ],
        1.0,
    );
    // α_n(t) linear between the two pole sets over the record
    let alpha: Vec<Vec<f64>> = wn0
        .iter()
        .zip(&wn1)
        .map(|(a, b)| vec![*a, (b - a) / period])
        .collect();
    let beta = vec![
        vec![wn0[0]],
        vec![wn0[0] / 100.0],
        vec![1000.0],
        vec![1.0],
        vec![0.01],
    ];
    let ode = TimeVaryingOde::from_polynomials(alpha, beta).unwrap();
    let u = Multisine::new(period, [0.0, 200.0], fs, LineSelection::All, 1).unwrap();
    let start = std::time::Instant::now();
    let sol = ode
        .simulate(&u, 1.0 / fs, n, &[0.0; 4], &DormandPrince::new())
        .unwrap();
    let elapsed = start.elapsed();
    println!(
        "{} lines, {n} samples: {} steps ({} rejected) in {:.2?}",
        u.lines().len(),
        sol.steps,
        sol.rejected,
        elapsed
    );
    let tight = ode
        .simulate(
            &u,
            1.0 / fs,
            n,
            &[0.0; 4],
            &DormandPrince::new().with_rtol(1e-14),
        )
        .unwrap();
    let err = rel_max(&sol.y, &tight.y);
    println!("difference to rtol 1e-14: {err:.2e}");
    assert!(err < 1e-10);
}
