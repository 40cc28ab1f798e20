//! Optimisation robustness: from its automatic start (Levy → SK), does the ML fit reach
//! the global optimum of the cost (the best of ML from the true parameters, of the chain
//! from perturbed true poles and of the multistart fits) on random stable systems of
//! order ≤ 10 at 40 dB SNR, continuous time (partial fractions) and discrete time? See
//! `common/robustness.rs` for the systems and the criterion, and
//! `cargo run --release --example optimisation_robustness` for the full study with the
//! failures' seeds and costs.
//!
//! Measured on the 500 systems of seeds 1000–1499 (docs/testing.md): `Pipeline::fit`, which
//! runs further starts when its fit shows evidence of a local minimum, reaches the optimum
//! on 97.8 % (continuous time 98.8 %, discrete time 96.8 %), below the 99 % target; the
//! chain alone (`restarts: false`) on 84.0 %; the multistart fits (`fit_multistart`,
//! `fit_multistart_discrete`) on 98.8 %. These tests guard those levels.

use crate::robustness;

use robustness::Outcome;

/// (automatic-start rate, multistart rate, rate of the chain alone)
fn rates(outcomes: &[Outcome]) -> (f64, f64, f64) {
    let n = outcomes.len() as f64;
    let share = |f: &dyn Fn(&Outcome) -> bool| outcomes.iter().filter(|o| f(o)).count() as f64 / n;
    (
        share(&Outcome::reached),
        share(&|o| o.multi_reached() == Some(true)),
        share(&Outcome::plain_reached),
    )
}

#[test]
fn forty_systems() {
    let outcomes = robustness::study(0, 40, 2, |_| {});
    let (auto, multi, plain) = rates(&outcomes);
    let failed = |f: fn(&Outcome) -> bool| {
        outcomes
            .iter()
            .filter(|o| !f(o))
            .map(|o| (o.seed, o.auto.clone(), o.multi.clone(), o.best))
            .collect::<Vec<_>>()
    };
    // the further starts only ever replace the chain's fit by one of lower cost
    for o in &outcomes {
        if let (Ok(a), Ok(p)) = (&o.auto, &o.plain) {
            assert!(
                a <= p,
                "seed {}: Pipeline::fit {a} above the chain alone {p}",
                o.seed
            );
        }
    }
    // multiple starts: at most one of the 40 systems misses the optimum
    assert!(
        multi >= 39.0 / 40.0,
        "multistart rate {multi}: {:?}",
        failed(|o| o.multi_reached() == Some(true))
    );
    // the automatic start with its further starts on evidence: 37 of 40 measured (the
    // three misses are discrete-time fits of order 7–10 without evidence or where no start
    // finds the optimum), the chain alone 35 of 40
    assert!(
        auto >= 37.0 / 40.0,
        "Pipeline::fit rate {auto}: {:?}",
        failed(Outcome::reached)
    );
    assert!(
        auto > plain,
        "the further starts gain nothing: {auto} vs the chain alone {plain}"
    );
}

#[test]
#[ignore = "500-system study (about 4 min in release); the 99 % target is not met: 97.8 % from the automatic start with its further starts, 84.0 % for the chain alone, 98.8 % with multiple starts"]
fn five_hundred_systems() {
    let outcomes = robustness::study(1000, 500, 2, |_| {});
    let (auto, multi, plain) = rates(&outcomes);
    eprintln!("Pipeline::fit {auto}, multistart {multi}, the chain alone {plain}");
    assert!(multi >= 0.985, "multistart rate {multi}");
    assert!(auto >= 0.975, "Pipeline::fit rate {auto}");
}
