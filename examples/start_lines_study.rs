//! The start on fewer lines (`Pipeline::start_lines`) against the linear stages on all
//! lines, on random stable systems of the optimisation-robustness study (orders 1–10,
//! continuous-time and discrete-time alternating, 40 dB SNR) measured on long records
//! (2 500–20 000 lines over the study's band): how often the two reach the same ML cost
//! (within 10⁻⁶ relative or 10⁻³ absolute), how often either is lower, and the times.
//!
//! `cargo run --release --example start_lines_study -- [count] [first seed]`
//! (defaults 200, 1000).

#[path = "../tests/common/mod.rs"]
mod common;
#[path = "../tests/common/robustness.rs"]
mod robustness;

use fdid::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use robustness::{Kind, ct_system, dt_system, long_record};

fn main() {
    let args: Vec<u64> = std::env::args()
        .skip(1)
        .map(|s| s.parse().expect("arguments: [count] [first seed]"))
        .collect();
    let (count, first) = (
        args.first().copied().unwrap_or(200),
        args.get(1).copied().unwrap_or(1000),
    );
    let all_lines = Pipeline {
        start_lines: None,
        ..Pipeline::default()
    };
    let (mut same, mut lower, mut higher, mut failed) = (0, 0, 0, 0);
    let (mut t_fewer, mut t_all) = (0.0, 0.0);
    for seed in first..first + count {
        let kind = if (seed - first).is_multiple_of(2) {
            Kind::Ct
        } else {
            Kind::Dt
        };
        let sys = match kind {
            Kind::Ct => ct_system(seed),
            Kind::Dt => dt_system(seed),
        };
        let n = StdRng::seed_from_u64(seed).gen_range(2_500..=20_000usize);
        let data = long_record(&sys, n, seed);
        let model = match kind {
            Kind::Ct => Rational::continuous(sys.na, sys.nb, data.omega()).unwrap(),
            Kind::Dt => Rational::discrete(sys.na, sys.nb, sys.zpk.ts.unwrap()).unwrap(),
        };
        let clock = std::time::Instant::now();
        let fewer = Pipeline::default().fit(&model, &data);
        t_fewer += clock.elapsed().as_secs_f64();
        let clock = std::time::Instant::now();
        let all = all_lines.fit(&model, &data);
        t_all += clock.elapsed().as_secs_f64();
        let (Ok(a), Ok(b)) = (&fewer, &all) else {
            failed += 1;
            println!(
                "seed {seed} {kind:?} na {} nb {} lines {n}: fewer {:?}, all {:?}",
                sys.na,
                sys.nb,
                fewer.as_ref().map(|f| f.cost()).map_err(|e| e.to_string()),
                all.as_ref().map(|f| f.cost()).map_err(|e| e.to_string())
            );
            continue;
        };
        eprintln!(
            "[{}/{count}] seed {seed} {kind:?} na {} lines {n}: {:.1} / {:.1} s so far",
            seed - first + 1,
            sys.na,
            t_fewer,
            t_all
        );
        let (ca, cb) = (a.cost(), b.cost());
        let tol = (1e-6 * cb).max(1e-3);
        if (ca - cb).abs() <= tol {
            same += 1;
        } else {
            if ca < cb {
                lower += 1;
            } else {
                higher += 1;
            }
            println!(
                "seed {seed} {kind:?} na {} nb {} lines {n}: fewer {ca:.6}, all {cb:.6}",
                sys.na, sys.nb
            );
        }
    }
    println!(
        "{count} systems: same optimum {same}, lower from fewer lines {lower}, higher {higher}, \
         failed {failed}; time {t_fewer:.2} s from fewer lines, {t_all:.2} s from all"
    );
}
