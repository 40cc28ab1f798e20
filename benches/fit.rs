//! Criterion benches of the estimation chain and the DFT.
//!
//! * `ml_ct10_20000`: Levy → SK → ML of the order-10 CT case `b_ct10` (five resonances)
//!   on 20 000 log-spaced lines over 0.1–10 rad/s at 40 dB SNR;
//! * `ml_ct4_2000`: the same for the order-4 case `a_ct4` on 2 000 lines;
//!   `ml_ct4_2000_stable` with `Pipeline { stable: true, .. }` (stability-constrained);
//! * `stages_ct10_20000/{levy,levy_sk,ml_from_sk}`: the order-10 case stage by stage
//!   (`levy` and `levy_sk` are `Pipeline::fit`, so they include building the `Fit`:
//!   covariance and response standard deviations); `levy_estimate` (the bare Levy solve)
//!   and `fit_new` (`Fit::new` at the ML estimate) separate that overhead;
//! * `lines_ct4/{2000,20000,200000}`: the full chain for `a_ct4` against the number of
//!   lines (throughput in lines);
//! * `dft_1e6`, `dft_1e7`: `TimeData::dft` of 10⁶ and 10⁷ samples of `u` and `y` (f64);
//! * `simd/ml_ct4_2000/{scalar,avx2,avx512}`: `ml_ct4_2000` on each SIMD path this
//!   processor has ([`fdid::linalg::simd`]; every path gives the same bits).
//!
//! All data are simulated with constant seeds outside the timed closures. The accuracy of
//! the fits (relative RMS error against the noise-free truth) is printed once to stderr.
//!
//! Run: `cargo bench --bench fit` (about 2½–3 minutes on 2 cores).

#[path = "../tests/common/mod.rs"]
mod common;

use common::{Noise, a_ct4, b_ct10, noisy_frf, rel_rms};
use criterion::{
    BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use fdid::criterion::NoiseWeighting;
use fdid::estimate::estimate;
use fdid::solver::{LevenbergMarquardt, LinearLeastSquares};
use fdid::{Complex, Fit, FrequencyData, Levy, MaximumLikelihood, Pipeline, Rational, TimeData};
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Fits once with `pipeline` outside the timing and prints accuracy, stages and wall time.
fn report(
    label: &str,
    pipeline: &Pipeline,
    model: &Rational<f64>,
    data: &FrequencyData<f64>,
    g0: &[Complex<f64>],
) {
    let t = Instant::now();
    let fit = pipeline.fit(model, data).expect("fit");
    let elapsed = t.elapsed();
    let stages: Vec<String> = fit
        .stages()
        .iter()
        .map(|s| format!("{} {} it", s.kind, s.solution.iterations))
        .collect();
    eprintln!(
        "[accuracy] {label}: rel_rms vs truth {:.3e}, cost {:.1} for {} lines ({}; one fit {:.1?})",
        rel_rms(fit.response(), g0),
        fit.cost(),
        data.len(),
        stages.join(", "),
        elapsed
    );
}

fn full_pipeline(c: &mut Criterion) {
    // case 1: order 10, 20 000 lines
    let (data10, g10) = noisy_frf(&b_ct10(), 20_000, 7);
    let model10 = Rational::continuous(10, 9, data10.omega()).expect("model");
    report(
        "ml_ct10_20000",
        &Pipeline::default(),
        &model10,
        &data10,
        &g10,
    );

    // case 2: order 4, 2 000 lines
    let (data4, g4) = noisy_frf(&a_ct4(), 2_000, 11);
    let model4 = Rational::continuous(4, 3, data4.omega()).expect("model");
    report("ml_ct4_2000", &Pipeline::default(), &model4, &data4, &g4);

    let mut group = c.benchmark_group("full");
    group
        .sampling_mode(SamplingMode::Flat)
        .sample_size(20)
        .warm_up_time(Duration::from_secs(2))
        .measurement_time(Duration::from_secs(12));
    group.bench_function("ml_ct10_20000", |b| {
        b.iter(|| {
            Pipeline::default()
                .fit(black_box(&model10), black_box(&data10))
                .expect("fit")
        })
    });
    group
        .sampling_mode(SamplingMode::Auto)
        .sample_size(30)
        .measurement_time(Duration::from_secs(6));
    group.bench_function("ml_ct4_2000", |b| {
        b.iter(|| {
            Pipeline::default()
                .fit(black_box(&model4), black_box(&data4))
                .expect("fit")
        })
    });
    // the same with the stability constraint (reflection after the linear stages,
    // constrained ML): its overhead is the pole computation of every trial step
    let stable = Pipeline {
        stable: true,
        ..Pipeline::default()
    };
    group.bench_function("ml_ct4_2000_stable", |b| {
        b.iter(|| {
            stable
                .fit(black_box(&model4), black_box(&data4))
                .expect("fit")
        })
    });
    group.finish();
}

fn stages(c: &mut Criterion) {
    let (data, g0) = noisy_frf(&b_ct10(), 20_000, 7);
    let start = Rational::continuous(10, 9, data.omega()).expect("model");
    report("stages levy", &Pipeline::levy(), &start, &data, &g0);
    report("stages levy+sk", &Pipeline::sk(), &start, &data, &g0);
    // SK relocates the partial-fraction basis: ML continues in the SK fit's model
    let sk_fit = Pipeline::sk().fit(&start, &data).expect("sk fit");
    let model = sk_fit.model().clone();
    let sk_theta = sk_fit.theta().to_vec();
    let levy = Levy::default();
    let linear = LinearLeastSquares::default();
    let ml = MaximumLikelihood::default();
    let lm = LevenbergMarquardt::default();
    let t = Instant::now();
    let sol = estimate(&model, &data, &ml, &lm, Some(&sk_theta)).expect("ml");
    eprintln!(
        "[stages] ml from sk: {} iterations, cost {:.1}, {:?} ({:.1?})",
        sol.iterations,
        sol.cost,
        sol.termination,
        t.elapsed()
    );

    let mut group = c.benchmark_group("stages_ct10_20000");
    group
        .sampling_mode(SamplingMode::Flat)
        .sample_size(15)
        .warm_up_time(Duration::from_secs(2))
        .measurement_time(Duration::from_secs(6));
    group.bench_function("levy", |b| {
        b.iter(|| {
            Pipeline::levy()
                .fit(black_box(&start), black_box(&data))
                .expect("fit")
        })
    });
    group.bench_function("levy_sk", |b| {
        b.iter(|| {
            Pipeline::sk()
                .fit(black_box(&start), black_box(&data))
                .expect("fit")
        })
    });
    group.bench_function("ml_from_sk", |b| {
        b.iter(|| {
            estimate(
                black_box(&model),
                black_box(&data),
                &ml,
                &lm,
                Some(black_box(&sk_theta)),
            )
            .expect("ml")
        })
    });
    group.bench_function("levy_estimate", |b| {
        b.iter(|| {
            estimate(black_box(&start), black_box(&data), &levy, &linear, None).expect("levy")
        })
    });
    let ml_theta = sol.theta;
    group.bench_function("fit_new", |b| {
        b.iter(|| {
            Fit::new(
                model.clone(),
                black_box(&data),
                ml_theta.clone(),
                NoiseWeighting::Auto,
                vec![],
            )
            .expect("fit")
        })
    });
    group.finish();
}

fn lines(c: &mut Criterion) {
    let mut group = c.benchmark_group("lines_ct4");
    group
        .sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_secs(2));
    for n in [2_000usize, 20_000, 200_000] {
        // about 1 s per fit at 200 000 lines: room for the 10 samples
        group.measurement_time(Duration::from_secs(if n > 100_000 { 14 } else { 5 }));
        let (data, g0) = noisy_frf(&a_ct4(), n, 11);
        let model = Rational::continuous(4, 3, data.omega()).expect("model");
        report(
            &format!("lines_ct4/{n}"),
            &Pipeline::default(),
            &model,
            &data,
            &g0,
        );
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                Pipeline::default()
                    .fit(black_box(&model), black_box(&data))
                    .expect("fit")
            })
        });
    }
    group.finish();
}

/// A record of `n` samples: white Gaussian u and a first-order low-pass response y.
fn dft_record(n: usize) -> TimeData<f64> {
    let mut noise = Noise::new(3);
    let u: Vec<f64> = (0..n).map(|_| noise.gauss()).collect();
    // a first-order low-pass response to u, so y is not just a copy of the input
    let mut y = Vec::with_capacity(n);
    let mut state = 0.0;
    for &x in &u {
        state = 0.9 * state + 0.1 * x;
        y.push(state + 0.01 * noise.gauss());
    }
    TimeData::new(u, y, 1e-3).expect("time record")
}

fn dft(c: &mut Criterion) {
    const N: usize = 1_000_000;
    let record = dft_record(N);
    let mut group = c.benchmark_group("dft");
    group
        .sample_size(30)
        .warm_up_time(Duration::from_secs(2))
        .measurement_time(Duration::from_secs(6))
        .throughput(Throughput::Elements(N as u64));
    group.bench_function("dft_1e6", |b| b.iter(|| black_box(&record).dft()));
    drop(record);
    // 10⁷ samples (10⁷ = 2⁷·5⁷, a mixed-radix FFT of both channels)
    const BIG: usize = 10_000_000;
    let record = dft_record(BIG);
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(10))
        .throughput(Throughput::Elements(BIG as u64));
    group.bench_function("dft_1e7", |b| b.iter(|| black_box(&record).dft()));
    group.finish();
}

/// `ml_ct4_2000` on each SIMD path of this processor, the path forced for the group.
fn simd_paths(c: &mut Criterion) {
    use fdid::linalg::simd::{self, SimdPath};
    let (data4, _) = noisy_frf(&a_ct4(), 2_000, 11);
    let model4 = Rational::continuous(4, 3, data4.omega()).expect("model");
    let mut group = c.benchmark_group("simd/ml_ct4_2000");
    group
        .sample_size(30)
        .warm_up_time(Duration::from_secs(2))
        .measurement_time(Duration::from_secs(6));
    for path in SimdPath::supported() {
        simd::force(Some(path)).expect("a supported path");
        group.bench_function(path.name(), |b| {
            b.iter(|| {
                Pipeline::default()
                    .fit(black_box(&model4), black_box(&data4))
                    .expect("fit")
            })
        });
    }
    simd::force(None).expect("the default path");
    group.finish();
}

criterion_group!(benches, full_pipeline, stages, lines, dft, simd_paths);
criterion_main!(benches);
