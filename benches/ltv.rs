//! Cost of the time-varying TLS estimator and of the local polynomial method:
//! - `ltv_tls/N`: regression matrix by FFT (eqs. 15/18) and TLS (eq. 19) for
//!   `LtvOde::new(4, 2, 2)` with Legendre bases and the default transient polynomial, a
//!   record of N samples at 2048 Hz and the band [0, 200] Hz (the paper's section V set-up);
//! - `lpm_4096`: the local polynomial method (R = 2) on the DFT of a 4096-sample record.
//!
//! Run: `cargo bench --bench ltv`.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use fdid::data::{Lpm, lpm};
use fdid::ltv::{FrequencyBasis, Lines, LtvOde, TimeBasis};
use fdid::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::hint::black_box;

fn record(n: usize, ts: f64, seed: u64) -> TimeData<f64> {
    let mut rng = StdRng::seed_from_u64(seed);
    let u: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
    // a smooth output: a first-order low-pass of u
    let mut y = vec![0.0; n];
    for t in 1..n {
        y[t] = 0.9 * y[t - 1] + 0.1 * u[t - 1];
    }
    TimeData::new(u, y, ts).unwrap()
}

fn ltv(c: &mut Criterion) {
    let mut group = c.benchmark_group("ltv_tls");
    group.sample_size(10);
    let fs = 2048.0;
    let w_max = std::f64::consts::TAU * 200.0;
    let model = LtvOde::<f64>::new(4, 2, 2)
        .with_time_basis(TimeBasis::Legendre)
        .with_frequency_basis(FrequencyBasis::legendre(w_max).unwrap());
    let lines = Lines::Band {
        f_lo: 0.0,
        f_hi: 200.0,
    };
    for n in [1usize << 13, 1 << 16] {
        let data = record(n, 1.0 / fs, 1);
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| black_box(&model).fit(&data, &lines).unwrap())
        });
    }
    group.finish();
    let dft = record(4096, 1.0, 2).dft();
    c.bench_function("lpm_4096", |b| {
        b.iter(|| lpm(black_box(&dft), Lpm::default()).unwrap())
    });
}

criterion_group!(benches, ltv);
criterion_main!(benches);
