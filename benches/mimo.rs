//! Criterion bench of `fdid::mimo::fit_common_poles` on random n-ports (resonances spread
//! over two decades, reciprocal residue matrices and a direct term, complex noise of 1e-4
//! per entry, seeded), the shapes of `bench/multiport.py`:
//!
//! * `mimo_4port/relocation`: 16 entries, 50 poles, 200 log-spaced lines, relaxed vector
//!   fitting alone (`ml: false`);
//! * `mimo_4port/relocation_ml`: the same with the default variable-projection ML;
//! * `mimo_8port/relocation_ml`: 64 entries, 40 poles, 5 000 evenly spaced lines;
//! * `mimo_4port/enforce_passivity`: the 4-port's fitted model with its residues and
//!   direct term scaled to a largest singular value of 1.2, made passive on the
//!   command's grid (4 000 points) by `enforce_passivity`.
//!
//! Thread count: rayon's pool (the `rayon` feature, on with `--all-features`) forms the
//! entries' blocks of a relocation in parallel. The Touchstone cases of
//! `bench/multiport.py` are what scikit-rf's VectorFitting is compared against there
//! (whole process for fdid).
//!
//! Run: `cargo bench --all-features --bench mimo` (about two minutes).

use criterion::{Criterion, criterion_group, criterion_main};
use fdid::data::FrfMatrix;
use fdid::mimo::{
    CommonPoleModel, CommonPoleOptions, PoleSet, enforce_passivity, fit_common_poles, passivity,
};
use fdid::prelude::*;
use nalgebra::DMatrix;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::hint::black_box;

/// A random `ports`-port with `pairs` resonances on `lines` lines from 10 MHz (log-spaced
/// to 20 GHz, or evenly spaced to 12 GHz).
fn n_port(ports: usize, pairs: usize, lines: usize, log_spaced: bool) -> FrfMatrix<f64> {
    let mut rng = StdRng::seed_from_u64(ports as u64);
    let last = (pairs - 1) as f64;
    let pairs: Vec<Complex<f64>> = (0..pairs)
        .map(|k| {
            let f = 1e8 * (100f64).powf(k as f64 / last) * (1.0 + 0.1 * rng.gen_range(-1.0..1.0));
            let zeta: f64 = rng.gen_range(0.01..0.08);
            let w = 2.0 * std::f64::consts::PI * f;
            Complex::new(-zeta * w, w * (1.0 - zeta * zeta).sqrt())
        })
        .collect();
    let residues = pairs
        .iter()
        .map(|p| {
            let r = DMatrix::from_fn(ports, ports, |_, _| {
                Complex::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0))
            });
            (&r + r.transpose()) * Complex::new(p.re.abs() * 0.16 / ports as f64, 0.0)
        })
        .collect();
    let model = CommonPoleModel {
        domain: Domain::Continuous,
        poles: PoleSet {
            real: vec![],
            pairs,
        },
        residues,
        direct: Some(DMatrix::from_fn(ports, ports, |i, j| 0.05 * (i + j) as f64)),
    };
    let span = (lines - 1) as f64;
    let omega: Vec<f64> = (0..lines)
        .map(|k| {
            let f = if log_spaced {
                1e7 * (2000f64).powf(k as f64 / span)
            } else {
                1e7 + (1.2e10 - 1e7) * k as f64 / span
            };
            2.0 * std::f64::consts::PI * f
        })
        .collect();
    let g = model.response(&omega);
    let entries = (0..ports * ports)
        .map(|e| {
            g.iter()
                .map(|m| {
                    let noise = Complex::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
                    m[(e % ports, e / ports)] + noise * 1e-4
                })
                .collect()
        })
        .collect();
    FrfMatrix::from_entries(omega, ports, ports, entries, None).unwrap()
}

fn bench(c: &mut Criterion) {
    let data = n_port(4, 25, 200, true);
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
    let mut model = fit_common_poles(&data, 50, &full).unwrap().model;
    let f_max = data.omega().iter().copied().fold(0.0, f64::max) / std::f64::consts::TAU;
    let factor = 1.2 / passivity(&model, f_max, 4000).max_singular_value;
    for r in model.residues.iter_mut() {
        *r *= Complex::new(factor, 0.0);
    }
    if let Some(d) = model.direct.as_mut() {
        *d *= factor;
    }
    let once = enforce_passivity(&model, data.omega(), f_max, 4000).unwrap();
    assert!(once.after.passive(), "{:?}", once.after);
    eprintln!(
        "enforce_passivity: {} of {} grid points violate; relative change {:.4} ({}), \
         scaling would change {:.4}",
        once.before.violations,
        once.before.points,
        once.relative_change,
        if once.scaled { "scaled" } else { "perturbed" },
        1.0 - 1.0 / 1.2
    );
    group.bench_function("enforce_passivity", |b| {
        b.iter(|| enforce_passivity(black_box(&model), data.omega(), f_max, 4000).unwrap())
    });
    group.finish();
    let data = n_port(8, 20, 5000, false);
    let mut group = c.benchmark_group("mimo_8port");
    group.sample_size(10);
    group.bench_function("relocation_ml", |b| {
        b.iter(|| fit_common_poles(black_box(&data), 40, &full).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
