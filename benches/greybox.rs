//! Criterion benches of the automatic (dual-number) Jacobian against the hand-written one.
//!
//! * `jacobian/{analytic,auto}/p`: `jacobian_into` of a discrete-time rational model
//!   B(z⁻¹)/A(z⁻¹) with na = nb = n (p = 2n + 1 parameters) on 1 000 lines, by
//!   `Rational::discrete` (analytic ∂G/∂θ) and by `AutoDiff` over the same formula written
//!   in the generic `GreyBox` form (one pass of `Dual<f64, N>` per line, N = p or the next
//!   of 10, 12, 16, 20, 24, 32);
//! * `response/{analytic,auto}/p`: `response_into` of the same models (no derivatives);
//! * `physical/*`: `jacobian_into` of the shipped physical models on 1 000 lines;
//! * `fit_two_mass_1000`: `fit_ml_from` of the two-mass drive (motor speed) on 1 000 noisy lines
//!   from a start 20 % off.
//!
//! Before the criterion groups, the ratio auto/analytic of the Jacobian time per p is
//! printed to stderr (median of 15 timed repetitions).
//!
//! Run: `cargo bench --bench greybox` (about a minute on 2 cores). The dual code is
//! sensitive to how the release build splits the crate into codegen units (a generic
//! `response` instance placed apart from its caller is not inlined): measured on 1 000
//! lines, auto/analytic was 2.2–3.2 for p = 3…9 with the default 16 units and 0.97–1.6
//! with `CARGO_PROFILE_BENCH_CODEGEN_UNITS=1`; p = 17 (a 20-component dual) 9.7 and 4.3.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use fdid::estimate::greybox::fit_ml_from;
use fdid::greybox::physical::{DriveOutput, MassSpringDamper, TwoMassDrive};
use fdid::greybox::{AutoDiff, DualScalar, GreyBox, PhysicalParameters};
use fdid::{Complex, FrequencyData, ModelStructure, NoiseVariances, Rational};
use nalgebra::DMatrix;
use std::hint::black_box;
use std::time::{Duration, Instant};

/// B(z⁻¹)/A(z⁻¹) in the generic form, θ = [a₁ … a_na, b₀ … b_nb] as `Rational::discrete`.
#[derive(Debug, Clone, Copy)]
struct RationalZ {
    na: usize,
    nb: usize,
    ts: f64,
}

impl GreyBox for RationalZ {
    fn n_params(&self) -> usize {
        self.na + self.nb + 1
    }
    #[inline]
    fn response<S: DualScalar>(&self, theta: &[S], zinv: Complex<S>) -> Complex<S> {
        let one = Complex::new(S::one(), S::zero());
        let (mut a, mut b, mut pw) = (one, Complex::new(S::zero(), S::zero()), one);
        for j in 0..=self.na.max(self.nb) {
            if j >= 1 && j <= self.na {
                a += pw * theta[j - 1];
            }
            if j <= self.nb {
                b += pw * theta[self.na + j];
            }
            pw *= zinv;
        }
        b / a
    }
    fn sample_time(&self) -> Option<f64> {
        Some(self.ts)
    }
}

const LINES: usize = 1000;
const TS: f64 = 1.0;

fn grid() -> Vec<f64> {
    (1..=LINES)
        .map(|k| std::f64::consts::PI * k as f64 / (LINES + 1) as f64)
        .collect()
}

/// A stable θ: A = (1 − 0.5 z⁻¹)ⁿ-like small coefficients, B arbitrary.
fn theta(n: usize) -> Vec<f64> {
    (0..2 * n + 1)
        .map(|j| 0.3 / (1.0 + j as f64) * if j % 2 == 0 { 1.0 } else { -1.0 })
        .collect()
}

fn time_jacobian(model: &dyn ModelStructure<f64>, theta: &[f64], omega: &[f64]) -> f64 {
    let mut g = vec![Complex::new(0.0, 0.0); omega.len()];
    let mut jac = DMatrix::zeros(omega.len(), theta.len());
    let mut times: Vec<f64> = (0..15)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..20 {
                model.jacobian_into(black_box(theta), omega, &mut g, &mut jac);
            }
            t.elapsed().as_secs_f64() / 20.0
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn print_ratios() {
    let omega = grid();
    for n in [1, 2, 4, 8] {
        let th = theta(n);
        let analytic = Rational::discrete(n, n, TS).unwrap();
        let auto = AutoDiff::new(RationalZ {
            na: n,
            nb: n,
            ts: TS,
        });
        let ta = time_jacobian(&analytic, &th, &omega);
        let tb = time_jacobian(&auto, &th, &omega);
        eprintln!(
            "jacobian_into, {LINES} lines, p = {:2}: analytic {:7.1} µs, automatic {:7.1} µs, ratio {:.2}",
            th.len(),
            ta * 1e6,
            tb * 1e6,
            tb / ta
        );
    }
}

fn bench_rational(c: &mut Criterion) {
    print_ratios();
    let omega = grid();
    let mut group = c.benchmark_group("jacobian");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500));
    for n in [2, 4, 8] {
        let th = theta(n);
        let p = th.len();
        let analytic = Rational::discrete(n, n, TS).unwrap();
        let auto = AutoDiff::new(RationalZ {
            na: n,
            nb: n,
            ts: TS,
        });
        let mut g = vec![Complex::new(0.0, 0.0); LINES];
        let mut jac = DMatrix::zeros(LINES, p);
        group.bench_with_input(BenchmarkId::new("analytic", p), &p, |b, _| {
            b.iter(|| analytic.jacobian_into(black_box(&th), &omega, &mut g, &mut jac))
        });
        group.bench_with_input(BenchmarkId::new("auto", p), &p, |b, _| {
            b.iter(|| auto.jacobian_into(black_box(&th), &omega, &mut g, &mut jac))
        });
    }
    group.finish();
    let mut group = c.benchmark_group("response");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500));
    for n in [2, 8] {
        let th = theta(n);
        let p = th.len();
        let analytic = Rational::discrete(n, n, TS).unwrap();
        let auto = AutoDiff::new(RationalZ {
            na: n,
            nb: n,
            ts: TS,
        });
        let mut g = vec![Complex::new(0.0, 0.0); LINES];
        group.bench_with_input(BenchmarkId::new("analytic", p), &p, |b, _| {
            b.iter(|| analytic.response_into(black_box(&th), &omega, &mut g))
        });
        group.bench_with_input(BenchmarkId::new("auto", p), &p, |b, _| {
            b.iter(|| auto.response_into(black_box(&th), &omega, &mut g))
        });
    }
    group.finish();
}

fn bench_physical(c: &mut Criterion) {
    let omega: Vec<f64> = (0..LINES)
        .map(|k| 10f64.powf(0.5 + 2.0 * k as f64 / (LINES - 1) as f64))
        .collect();
    let mut group = c.benchmark_group("physical");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500));
    let msd = AutoDiff::new(MassSpringDamper::new());
    let t_msd: Vec<f64> = msd.theta_from_physical(&[2.0, 0.3, 50.0]).unwrap();
    let drive = AutoDiff::new(TwoMassDrive::new(DriveOutput::MotorSpeed).with_friction());
    let t_drive: Vec<f64> = drive
        .theta_from_physical(&[0.02, 0.05, 100.0, 0.05, 0.01, 0.02])
        .unwrap();
    let mut g = vec![Complex::new(0.0, 0.0); LINES];
    let mut jac3 = DMatrix::zeros(LINES, 3);
    let mut jac6 = DMatrix::zeros(LINES, 6);
    group.bench_function("mass_spring_damper", |b| {
        b.iter(|| msd.jacobian_into(black_box(&t_msd), &omega, &mut g, &mut jac3))
    });
    group.bench_function("two_mass_friction", |b| {
        b.iter(|| drive.jacobian_into(black_box(&t_drive), &omega, &mut g, &mut jac6))
    });
    group.finish();

    // a complete grey-box fit
    let drive = AutoDiff::new(TwoMassDrive::new(DriveOutput::MotorSpeed));
    let truth: Vec<f64> = drive
        .theta_from_physical(&[0.02, 0.05, 100.0, 0.05])
        .unwrap();
    let g0 = drive.response(&truth, &omega);
    let mut state = 7u64;
    let mut gauss = || {
        // a small LCG + Box–Muller, enough for a bench
        let mut u = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (u1, u2) = (u(), u());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    let var = 1e-4;
    let y: Vec<Complex<f64>> = g0
        .iter()
        .map(|g| g + Complex::new(gauss(), gauss()) * (var / 2.0f64).sqrt())
        .collect();
    let data = FrequencyData::from_frf(omega.clone(), y, None)
        .unwrap()
        .with_noise(NoiseVariances::output_only(vec![var; LINES]))
        .unwrap();
    let start: Vec<f64> = drive
        .theta_from_physical(&[0.024, 0.04, 120.0, 0.06])
        .unwrap();
    let mut group = c.benchmark_group("fit");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    group.bench_function("fit_two_mass_1000", |b| {
        b.iter(|| fit_ml_from(&drive, &data, black_box(&start)).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_rational, bench_physical);
criterion_main!(benches);
