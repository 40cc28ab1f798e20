//! Optimisation robustness: from its automatic start (Levy → SK), does the ML fit reach
//! the global optimum of the cost (the best of ML from the true parameters, of the chain
//! from perturbed true poles and of the multistart fits) on random stable systems of
//! order ≤ 10 at 40 dB SNR, continuous time (partial fractions) and discrete time? See
//! `common/robustness.rs` for the systems and the criterion, and
//! `cargo run --release --example optimisation_robustness` for the full study with the
//! failures' seeds and costs.
//!
//! Measured on the 500 systems of seeds 1000–1499 (README, Tests): `Pipeline::fit`
//! reaches the optimum on 84.8 % (continuous time 79.6 %, discrete time 90.0 %), below the
//! 99 % target; the multistart fits (`fit_multistart`, `fit_multistart_discrete`) on
//! 97.2 % (96.8 % and 97.6 %). These tests guard those levels.

mod common;
#[path = "common/robustness.rs"]
mod robustness;

use robustness::Outcome;

/// (automatic-start rate, multistart rate)
fn rates(outcomes: &[Outcome]) -> (f64, f64) {
    let n = outcomes.len() as f64;
    let auto = outcomes.iter().filter(|o| o.reached()).count() as f64 / n;
    let multi = outcomes
        .iter()
        .filter(|o| o.multi_reached() == Some(true))
        .count() as f64
        / n;
    (auto, multi)
}

#[test]
fn forty_systems() {
    let outcomes = robustness::study(0, 40, 2, |_| {});
    let (auto, multi) = rates(&outcomes);
    let failed = |f: fn(&Outcome) -> bool| {
        outcomes
            .iter()
            .filter(|o| !f(o))
            .map(|o| (o.seed, o.auto.clone(), o.multi.clone(), o.best))
            .collect::<Vec<_>>()
    };
    // multiple starts: at most one of the 40 systems misses the optimum
    assert!(
        multi >= 39.0 / 40.0,
        "multistart rate {multi}: {:?}",
        failed(|o| o.multi_reached() == Some(true))
    );
    // the automatic start: the measured level (35 of 40, below the 99 % target), as a guard
    assert!(
        auto >= 0.85,
        "Pipeline::fit rate {auto}: {:?}",
        failed(Outcome::reached)
    );
}

#[test]
#[ignore = "500-system study (about 130 s in release); the 99 % target is not met: 84.8 % from the automatic start, 97.2 % with multiple starts"]
fn five_hundred_systems() {
    let outcomes = robustness::study(1000, 500, 2, |_| {});
    let (auto, multi) = rates(&outcomes);
    eprintln!("Pipeline::fit {auto}, multistart {multi}");
    assert!(multi >= 0.97, "multistart rate {multi}");
    assert!(auto >= 0.84, "Pipeline::fit rate {auto}");
}
