//! Cost of a fit against the number of lines, with fits of 2 000, 20 000 and 200 000 lines
//! interleaved in one process (as a user fitting records of several lengths would run
//! them, and unlike a benchmark that runs each size alone): the order-4 case `a_ct4` at
//! 40 dB SNR, `REPS` rounds (default 30) of 20 fits on 2 000 lines, 4 on 20 000 and one
//! on 200 000; prints the median and the fastest time of each and the 200 000 ÷ 20 000
//! ratio. `cargo run --release --example lines_ratio` (about 10 s).

#[path = "../tests/common/mod.rs"]
mod common;
use common::{a_ct4, noisy_frf};
use fdid::{FrequencyData, Pipeline, Rational};
use std::time::Instant;

/// Lines of the three record lengths, and fits of each per round.
const ROUNDS: [(usize, usize); 3] = [(2_000, 20), (20_000, 4), (200_000, 1)];

fn main() {
    let reps: usize = std::env::var("REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(30);
    let sets: Vec<FrequencyData<f64>> = ROUNDS
        .iter()
        .map(|&(n, _)| noisy_frf(&a_ct4(), n, 11).0)
        .collect();
    let mut times: Vec<Vec<f64>> = vec![vec![]; ROUNDS.len()];
    for _ in 0..reps {
        for ((d, &(_, fits)), t) in sets.iter().zip(&ROUNDS).zip(&mut times) {
            let model = Rational::continuous(4, 3, d.omega()).expect("model");
            for _ in 0..fits {
                let clock = Instant::now();
                let fit = Pipeline::default().fit(&model, d).expect("fit");
                t.push(clock.elapsed().as_secs_f64() * 1e3);
                std::hint::black_box(fit);
            }
        }
    }
    // (median, fastest) of each length
    let stats: Vec<(f64, f64)> = times
        .iter_mut()
        .map(|v| {
            v.sort_by(f64::total_cmp);
            (v[v.len() / 2], v[0])
        })
        .collect();
    for (&(n, _), (median, fastest)) in ROUNDS.iter().zip(&stats) {
        println!("{n:>7} lines: median {median:.3} ms, fastest {fastest:.3} ms");
    }
    println!(
        "200 000 ÷ 20 000 lines: {:.2}× (medians), {:.2}× (fastest)",
        stats[2].0 / stats[1].0,
        stats[2].1 / stats[1].1
    );
}
