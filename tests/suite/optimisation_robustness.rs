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
//! on 98.8 % (continuous time 99.2 %, discrete time 98.4 %), below the 99 % target; the
//! chain alone (`restarts: false`) on 81.6 %; the multistart fits (`fit_multistart`,
//! `fit_multistart_discrete`) on 99.2 %. These tests guard those levels.

use crate::robustness;
use fdid::prelude::*;

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

/// A system on which the search used to end above the cost of ML started at the true
/// parameters — a pole (pair) of its best fit in the wrong place — and which the
/// relocation starts (`fit_multistart`: every pole moved in turn over the band) now take
/// to that cost or below: seed 7188 (continuous time, order 8: 479.74 against 478.18 from
/// the truth). The discrete-time system 1083 (order 10 on 128 lines) also reached its
/// truth-start cost with them, but only through a pole that a single line determines
/// in a fit without an unresolved pole, which the search does not keep (it keeps such a
/// fit only when it stays flagged).
#[test]
fn relocation_reaches_the_truth_start_cost() {
    for case in [robustness::ct_case(7188)] {
        let o = robustness::run(&case, 0);
        let truth = o.truth.expect("ML from the true parameters");
        let at_most = truth + f64::max(1e-6 * truth, 1e-3);
        // the case needs the relocation: without it the search stays above that cost
        let (na, nb) = (case.sys.na, case.sys.nb);
        let without = fdid::estimate::without_relocation(|| match case.sys.zpk.ts {
            None => fit_multistart(&Pipeline::default(), na, nb, &case.data),
            Some(ts) => fit_multistart_discrete(&Pipeline::default(), na, nb, ts, &case.data),
        })
        .expect("the search without relocation");
        assert!(
            without.cost() > at_most,
            "seed {}: the search reaches {} without the relocation (truth start {truth}): \
             the case no longer tests it",
            o.seed,
            without.cost()
        );
        for (what, cost) in [
            ("fit_multistart", o.multi.clone().unwrap()),
            ("Pipeline::fit", o.auto.clone()),
        ] {
            let cost = cost.unwrap_or_else(|e| panic!("seed {}: {what} failed: {e}", o.seed));
            assert!(
                cost <= at_most,
                "seed {}: {what} ends at {cost}, above ML from the truth {truth}",
                o.seed
            );
        }
    }
}

/// A relocated fit that gains a pole a single line determines is kept when it stays
/// flagged: on seed 1170 (continuous time, order 10) `Pipeline::fit` reaches the study's
/// best cost (320.54, from a perturbed true start; 326.84 from the true parameters) only
/// through such a fit — without that exception it and the multistart fit end at 321.11 —
/// and the fit it returns names an unresolved pole, so the user is warned that the data
/// do not determine it.
#[test]
fn a_single_line_pole_is_kept_in_a_flagged_fit() {
    let case = robustness::ct_case(1170);
    let o = robustness::run(&case, 2);
    assert!(
        o.reached(),
        "Pipeline::fit ends at {:?}, above the best cost {}",
        o.auto,
        o.best
    );
    let model = Rational::continuous(case.sys.na, case.sys.nb, case.data.omega()).unwrap();
    let fit = Pipeline::default()
        .fit(&model, &case.data)
        .expect("Pipeline::fit");
    assert!(
        !fit.unresolved_poles().unwrap().is_empty(),
        "the fit is not flagged"
    );
}

#[test]
#[ignore = "500-system study (about 4 min in release): 99.2 % from the automatic start with its further starts (the 99 % aimed at), 81.6 % for the chain alone, 99.2 % with multiple starts"]
fn five_hundred_systems() {
    let outcomes = robustness::study(1000, 500, 2, |_| {});
    let (auto, multi, plain) = rates(&outcomes);
    eprintln!("Pipeline::fit {auto}, multistart {multi}, the chain alone {plain}");
    assert!(multi >= 0.985, "multistart rate {multi}");
    assert!(auto >= 0.99, "Pipeline::fit rate {auto}");
}

/// A pole the data barely determine is evidence of a local minimum: on seed 7224
/// (continuous time, order 9/7, outside the 500-system study) the chain's fit shows no
/// other evidence, but the standard deviation of its real pole near −11.6 exceeds half
/// its distance from the imaginary axis. The search that this starts reaches the
/// multistart fit's cost (366.62, a stable fit whose weak real poles sit elsewhere),
/// against 367.44 for the chain's fit.
#[test]
fn a_weak_pole_is_evidence_of_a_local_minimum() {
    let case = robustness::ct_case(7224);
    let (na, nb) = (case.sys.na, case.sys.nb);
    let model = Rational::continuous(na, nb, case.data.omega()).unwrap();
    let chain = Pipeline {
        restarts: false,
        ..Pipeline::default()
    }
    .fit(&model, &case.data)
    .expect("the chain");
    let fit = Pipeline::default()
        .fit(&model, &case.data)
        .expect("Pipeline::fit");
    let multi = fit_multistart(&Pipeline::default(), na, nb, &case.data).expect("multistart");
    assert!(
        fit.cost() <= multi.cost() + 1e-3,
        "Pipeline::fit ends at {}, the multistart fit at {}",
        fit.cost(),
        multi.cost()
    );
    assert!(
        fit.cost() < chain.cost() - 0.5,
        "no search: Pipeline::fit {} against the chain's {}",
        fit.cost(),
        chain.cost()
    );
    assert!(fit.model().is_stable(fit.theta()).unwrap());
}
