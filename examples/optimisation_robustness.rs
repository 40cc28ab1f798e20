//! Optimisation robustness of `Pipeline::fit`: on random stable systems of order ≤ 10 at
//! 40 dB SNR (continuous-time partial-fraction and discrete-time models alternating),
//! compares the ML cost reached from the automatic start (Levy → SK) with the best of
//! ML from the true parameters, the chain from perturbed true poles and the multistart
//! fits (`fit_multistart`, `fit_multistart_discrete`, also measured), and prints the
//! rate of fits that reach that optimum (within 10⁻⁶ relative or 10⁻³ absolute) with the
//! failures' seeds and costs, the rate of the chain alone (`Pipeline { restarts: false,
//! .. }`) against the same references, and the times of both.
//!
//! `cargo run --release --example optimisation_robustness -- [count] [first seed] [perturbed starts]`
//! (defaults 500, 1000, 2; progress on stderr).

#[path = "../tests/common/mod.rs"]
mod common;
#[path = "../tests/common/robustness.rs"]
mod robustness;

use robustness::Kind;

/// Percentage of the outcomes of `kind` for which `f` holds.
fn rate(outcomes: &[robustness::Outcome], kind: Kind, f: fn(&robustness::Outcome) -> bool) -> f64 {
    let of: Vec<_> = outcomes.iter().filter(|o| o.kind == kind).collect();
    100.0 * of.iter().filter(|o| f(o)).count() as f64 / of.len().max(1) as f64
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: u64| -> u64 {
        args.get(i)
            .map(|s| {
                s.parse()
                    .expect("arguments: [count] [first seed] [perturbed starts]")
            })
            .unwrap_or(default)
    };
    let (count, first, perturbed) = (arg(0, 500), arg(1, 1000), arg(2, 2) as usize);
    let start = std::time::Instant::now();
    let mut done = 0;
    let outcomes = robustness::study(first, count, perturbed, |o| {
        done += 1;
        if !o.reached() {
            eprintln!("[{done}/{count}] seed {} failed", o.seed);
        } else if done % 25 == 0 {
            eprintln!("[{done}/{count}] {:.1} s", start.elapsed().as_secs_f64());
        }
    });
    let mut failed = 0;
    println!("Pipeline::fit failures:");
    println!(
        "seed  kind  na nb lines   auto cost        truth-start cost  best cost        stable"
    );
    for o in &outcomes {
        if o.reached() {
            continue;
        }
        failed += 1;
        let auto = match &o.auto {
            Ok(c) => format!("{c:<16.6}"),
            Err(e) => format!("error: {e}"),
        };
        let truth = o.truth.map_or("-".to_string(), |c| format!("{c:.6}"));
        println!(
            "{:<5} {:<5} {:<2} {:<2} {:<7} {auto} {truth:<17} {:<16.6} {}",
            o.seed,
            match o.kind {
                Kind::Ct => "ct",
                Kind::Dt => "dt",
            },
            o.na,
            o.nb,
            o.lines,
            o.best,
            o.auto_stable
        );
    }
    for kind in [Kind::Ct, Kind::Dt] {
        let multi: Vec<&robustness::Outcome> = outcomes.iter().filter(|o| o.kind == kind).collect();
        let ok = multi
            .iter()
            .filter(|o| o.multi_reached() == Some(true))
            .count();
        println!(
            "multistart {kind:?}: {ok} of {} reached the optimum ({:.1} %); failed seeds: {:?}",
            multi.len(),
            100.0 * ok as f64 / multi.len().max(1) as f64,
            multi
                .iter()
                .filter(|o| o.multi_reached() != Some(true))
                .map(|o| (o.seed, o.multi.clone(), o.best))
                .collect::<Vec<_>>()
        );
    }
    for kind in [Kind::Ct, Kind::Dt] {
        let of: Vec<_> = outcomes.iter().filter(|o| o.kind == kind).collect();
        let ok = of.iter().filter(|o| o.reached()).count();
        println!(
            "{:?}: {ok} of {} reached the optimum ({:.1} %)",
            kind,
            of.len(),
            100.0 * ok as f64 / of.len().max(1) as f64
        );
    }
    let ok = outcomes.iter().filter(|o| o.plain_reached()).count();
    println!(
        "the chain alone (restarts: false): {ok} of {} reached the optimum ({:.2} %); CT {:.1} %, DT {:.1} %",
        outcomes.len(),
        100.0 * ok as f64 / outcomes.len().max(1) as f64,
        rate(&outcomes, Kind::Ct, robustness::Outcome::plain_reached),
        rate(&outcomes, Kind::Dt, robustness::Outcome::plain_reached),
    );
    let median = |mut t: Vec<f64>| {
        t.sort_by(f64::total_cmp);
        t.get(t.len() / 2).copied().unwrap_or(0.0)
    };
    let auto_t: Vec<f64> = outcomes.iter().map(|o| o.auto_time).collect();
    let plain_t: Vec<f64> = outcomes.iter().map(|o| o.plain_time).collect();
    println!(
        "time of Pipeline::fit: total {:.2} s, median {:.2} ms; the chain alone: total {:.2} s, median {:.2} ms",
        auto_t.iter().sum::<f64>(),
        1e3 * median(auto_t.clone()),
        plain_t.iter().sum::<f64>(),
        1e3 * median(plain_t.clone()),
    );
    println!(
        "by denominator order: cases, the chain alone reached, Pipeline::fit reached, its total time"
    );
    for kind in [Kind::Ct, Kind::Dt] {
        for na in 1..=10 {
            let of: Vec<_> = outcomes
                .iter()
                .filter(|o| o.kind == kind && o.na == na)
                .collect();
            println!(
                "  {kind:?} na {na:>2}: {:>3} cases, chain {:>3}, fit {:>3}, {:.2} s",
                of.len(),
                of.iter().filter(|o| o.plain_reached()).count(),
                of.iter().filter(|o| o.reached()).count(),
                of.iter().map(|o| o.auto_time).sum::<f64>()
            );
        }
    }
    let n = outcomes.len();
    println!(
        "all: {} of {n} reached the optimum ({:.2} %), {failed} failed; {:.1} s",
        n - failed,
        100.0 * (n - failed) as f64 / n.max(1) as f64,
        start.elapsed().as_secs_f64()
    );
}
