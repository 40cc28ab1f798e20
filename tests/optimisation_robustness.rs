//! Optimisation robustness: from its automatic start (Levy → SK), does the ML fit reach
//! the global optimum of the cost (the best of ML from the true parameters, of the chain
//! from perturbed true poles and of `fit_multistart`) on random stable systems of order
//! ≤ 10 at 40 dB SNR, continuous time (partial fractions) and discrete time? See
//! `common/robustness.rs` for the systems and the criterion, and
//! `cargo run --release --example optimisation_robustness` for the full study with the
//! failures' seeds and costs.
//!
//! Measured on the 500 systems of seeds 1000–1499 (README, Tests): `Pipeline::fit`
//! reaches the optimum on 86.4 % (continuous time 79.6 %, discrete time 93.2 %), below the
//! 99 % target; `fit_multistart` on 97.2 % of the continuous-time systems. These tests
//! guard those levels.

mod common;
#[path = "common/robustness.rs"]
mod robustness;

use robustness::Outcome;

/// (automatic-start rate over all cases, multistart rate over the continuous-time cases)
fn rates(outcomes: &[Outcome]) -> (f64, f64) {
    let auto = outcomes.iter().filter(|o| o.reached()).count() as f64 / outcomes.len() as f64;
    let multi: Vec<bool> = outcomes.iter().filter_map(Outcome::multi_reached).collect();
    let m = multi.iter().filter(|m| **m).count() as f64 / multi.len() as f64;
    (auto, m)
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
    // multiple starts: at most one of the 20 continuous-time systems misses the optimum
    assert!(
        multi >= 0.95,
        "fit_multistart rate {multi}: {:?}",
        failed(|o| o.multi_reached() != Some(false))
    );
    // the automatic start: the measured level (below the 99 % target), as a guard
    assert!(
        auto >= 0.75,
        "Pipeline::fit rate {auto}: {:?}",
        failed(Outcome::reached)
    );
}

#[test]
#[ignore = "500-system study (about 100 s in release); the 99 % target is not met by the single automatic start (86 %)"]
fn five_hundred_systems() {
    let outcomes = robustness::study(1000, 500, 2, |_| {});
    let (auto, multi) = rates(&outcomes);
    eprintln!("Pipeline::fit {auto}, fit_multistart (continuous time) {multi}");
    assert!(multi >= 0.96, "fit_multistart rate {multi}");
    assert!(auto >= 0.85, "Pipeline::fit rate {auto}");
}
