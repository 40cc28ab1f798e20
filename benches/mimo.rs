//! Criterion bench of `fdid::mimo::fit_common_poles`: a random 4-port (16 entries, 50
//! poles in 25 resonances spread over two decades, reciprocal residue matrices and a
//! direct term) on 200 log-spaced lines with complex noise of 1e-4 per entry (seeded):
//!
//! * `mimo_4port/relocation`: relaxed vector fitting alone (`ml: false`);
//! * `mimo_4port/relocation_ml`: the default, relocation then variable-projection ML.
//!
//! The same case in the Touchstone file of `bench/multiport.py` is what scikit-rf's
//! VectorFitting is compared against there (whole process for fdid).
//!
//! Run: `cargo bench --bench mimo` (about a minute).

use criterion::{Criterion, criterion_group, criterion_main};
use fdid::data::FrfMatrix;
use fdid::mimo::{CommonPoleModel, CommonPoleOptions, PoleSet, fit_common_poles};
use fdid::prelude::*;
use nalgebra::DMatrix;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::hint::black_box;

fn four_port() -> FrfMatrix<f64> {
    let mut rng = StdRng::seed_from_u64(4);
    let pairs: Vec<Complex<f64>> = (0..25)
        .map(|k| {
            let f = 1e8 * (100f64).powf(k as f64 / 24.0) * (1.0 + 0.1 * rng.gen_range(-1.0..1.0));
            let zeta: f64 = rng.gen_range(0.01..0.08);
            let w = 2.0 * std::f64::consts::PI * f;
            Complex::new(-zeta * w, w * (1.0 - zeta * zeta).sqrt())
        })
        .collect();
    let residues = pairs
        .iter()
        .map(|p| {
            let r = DMatrix::from_fn(4, 4, |_, _| {
                Complex::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0))
            });
            (&r + r.transpose()) * Complex::new(p.re.abs() * 0.04, 0.0)
        })
        .collect();
    let model = CommonPoleModel {
        domain: Domain::Continuous,
        poles: PoleSet {
            real: vec![],
            pairs,
        },
        residues,
        direct: Some(DMatrix::from_fn(4, 4, |i, j| 0.05 * (i + j) as f64)),
    };
    let omega: Vec<f64> = (0..200)
        .map(|k| 2.0 * std::f64::consts::PI * 1e7 * (2000f64).powf(k as f64 / 199.0))
        .collect();
    let g = model.response(&omega);
    let entries = (0..16)
        .map(|e| {
            g.iter()
                .map(|m| {
                    let noise = Complex::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
                    m[(e % 4, e / 4)] + noise * 1e-4
                })
                .collect()
        })
        .collect();
    FrfMatrix::from_entries(omega, 4, 4, entries, None).unwrap()
}

fn bench(c: &mut Criterion) {
    let data = four_port();
    let mut group = c.benchmark_group("mimo_4port");
    group.sample_size(10);
    let relocation = CommonPoleOptions {
        direct: true,
        ml: false,
        ..CommonPoleOptions::default()
    };
    group.bench_function("relocation", |b| {
        b.iter(|| fit_common_poles(black_box(&data), 50, &relocation).unwrap())
    });
    let full = CommonPoleOptions {
        direct: true,
        ..CommonPoleOptions::default()
    };
    group.bench_function("relocation_ml", |b| {
        b.iter(|| fit_common_poles(black_box(&data), 50, &full).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
