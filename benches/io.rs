//! Cost of reading data files (CSV parsing into [`fdid::data::Measurement`], from memory:
//! no disk access in the timing), 10 000 and 100 000 rows:
//! - `csv_frf_{10k,100k}`: `f,re,im` rows (a frequency response);
//! - `csv_time_{10k,100k}`: `t,u,y` rows (a time record; the uniform-time check included).
//!
//! Run: `cargo bench --bench io` (the `csv` feature, on by default).

use criterion::{Criterion, black_box, criterion_group, criterion_main};
use fdid::io::parse_csv;

/// A file of `n` rows as `fdid fit` meets it: 17 significant digits per number.
fn frf_file(n: usize) -> String {
    let mut s = String::from("f,re,im\n");
    for k in 1..=n {
        let f = k as f64 * 0.013_7;
        let g = 1.0 / (1.0 + f * f);
        s.push_str(&format!("{f:.17e},{g:.17e},{:.17e}\n", -f * g));
    }
    s
}

fn time_file(n: usize) -> String {
    let mut s = String::from("t,u,y\n");
    for k in 0..n {
        let t = k as f64 * 1e-3;
        s.push_str(&format!(
            "{t:.17e},{:.17e},{:.17e}\n",
            (k as f64 * 0.37).sin(),
            (k as f64 * 0.11).cos()
        ));
    }
    s
}

fn io(c: &mut Criterion) {
    let mut group = c.benchmark_group("io");
    group.sample_size(20);
    for (label, n) in [("10k", 10_000), ("100k", 100_000)] {
        let frf = frf_file(n);
        group.bench_function(format!("csv_frf_{label}"), |b| {
            b.iter(|| parse_csv::<f64, _>(black_box(frf.as_bytes()), "frf.csv").unwrap())
        });
        let time = time_file(n);
        group.bench_function(format!("csv_time_{label}"), |b| {
            b.iter(|| parse_csv::<f64, _>(black_box(time.as_bytes()), "time.csv").unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, io);
criterion_main!(benches);
