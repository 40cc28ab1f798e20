//! The work budget of the iterative solvers (`fdid::solver::work`, `ModelSpec::fit_within`):
//! a fit on many lines with more parameters than the system needs (its Levenberg–Marquardt
//! crawls and its restarts multiply) ends at the budget with its best point; a budget the
//! fit does not reach changes nothing.

use fdid::estimate::{ModelSpec, RationalFit};
use fdid::fit::StageKind;
use fdid::prelude::*;
use fdid::solver::Termination;

/// G(z) = 0.3 z⁻¹/(1 − 1.2 z⁻¹ + 0.5 z⁻²) on `lines` lines in (0, π), with a small
/// deterministic ripple as noise.
fn second_order(lines: usize) -> FrequencyData<f64> {
    let omega: Vec<f64> = (1..=lines)
        .map(|k| k as f64 * std::f64::consts::PI / (lines + 1) as f64)
        .collect();
    let y = omega
        .iter()
        .enumerate()
        .map(|(k, w)| {
            let zi = Complex::new(0.0, -w).exp();
            let g = zi * 0.3 / (Complex::new(1.0, 0.0) - zi * 1.2 + zi * zi * 0.5);
            g + Complex::new((k as f64 * 0.7).sin(), (k as f64 * 1.3).cos()) * 1e-3
        })
        .collect();
    FrequencyData::from_frf(omega, y, Some(1.0)).unwrap()
}

#[test]
fn a_spent_budget_ends_the_fit_at_its_best_point() {
    let data = second_order(20_000);
    let spec = ModelSpec::discrete(10, 9, 1.0);
    // about 30 evaluations of 40 000 rows × 20 parameters
    let (fit, stopped) = spec.fit_within(&data, 5e8).unwrap();
    assert!(stopped);
    let RationalFit::Plain(plain) = &fit else {
        panic!("a plain spec gives a plain fit")
    };
    // the best point evaluated is kept: never worse than ML's start, the last linear
    // stage's estimate (its ML cost on all lines: the linear stages of a record this long
    // run on fewer, and their own costs are on those)
    let start = plain
        .stages()
        .iter()
        .rfind(|s| matches!(s.kind, StageKind::Levy | StageKind::Sk))
        .unwrap();
    assert!(start.lines.is_some_and(|l| l < data.len()));
    let linear = Fit::new(
        plain.model().clone(),
        &data,
        start.solution.theta.clone(),
        fdid::criterion::NoiseWeighting::Auto,
        vec![],
    )
    .unwrap()
    .cost();
    assert!(linear.is_finite());
    assert!(
        fit.cost() <= linear * (1.0 + 1e-12),
        "{} > {linear}",
        fit.cost()
    );
    // a budget far too small for one evaluation: the solvers stop at their starts
    let (tiny, stopped) = spec.fit_within(&data, 1.0).unwrap();
    assert!(stopped && tiny.cost().is_finite());
    let RationalFit::Plain(tiny) = &tiny else {
        panic!("a plain spec gives a plain fit")
    };
    assert!(
        tiny.stages()
            .iter()
            .any(|s| s.solution.termination == Termination::MaxIterations),
        "{:?}",
        tiny.stages()
    );
}

#[test]
fn a_budget_the_fit_does_not_reach_changes_nothing() {
    let data = second_order(400);
    for (na, nb) in [(2, 1), (4, 3)] {
        let spec = ModelSpec::discrete(na, nb, 1.0);
        let plain = spec.fit(&data).unwrap();
        let (within, stopped) = spec.fit_within(&data, 1e15).unwrap();
        assert!(!stopped);
        assert_eq!(plain.theta(), within.theta());
        assert_eq!(plain.cost(), within.cost());
    }
}

#[test]
fn a_budget_must_be_positive() {
    let data = second_order(50);
    for work in [0.0, -1.0, f64::NAN] {
        let err = ModelSpec::discrete(2, 1, 1.0)
            .fit_within(&data, work)
            .unwrap_err();
        assert!(err.to_string().contains("work"), "{err}");
    }
}

/// The delay search makes many delay-free fits whose linear stages the budget does not
/// stop; once the budget is spent it ends at its best refined delay. An order-1 model of
/// the delayed second-order system never reaches the noise level, so without a budget the
/// search scans and refines every candidate.
#[test]
fn a_spent_budget_ends_the_delay_search() {
    let data = second_order(4000);
    let delayed: Vec<Complex<f64>> = data
        .omega()
        .iter()
        .zip(data.y())
        .map(|(w, y)| y * Complex::new(0.0, -2.3 * w).exp())
        .collect();
    let data = FrequencyData::from_frf(data.omega().to_vec(), delayed, Some(1.0)).unwrap();
    let spec = ModelSpec {
        delay: true,
        ..ModelSpec::discrete(1, 0, 1.0)
    };
    let search_fits = |fit: &RationalFit| {
        let RationalFit::Delayed(fit) = fit else {
            panic!("a delayed spec gives a delayed fit")
        };
        fit.stages()
            .iter()
            .find(|s| s.kind == StageKind::Delay)
            .map(|s| s.solution.iterations)
            .unwrap()
    };
    let full = spec.fit(&data).unwrap();
    let least = spec.least_search_work(&data).unwrap();
    assert!(least < spec.search_work(&data).unwrap());
    // the bound counts every solver at its full evaluation budget: a hundredth of it is
    // spent before the scan
    let (within, stopped) = spec.fit_within(&data, least / 100.0).unwrap();
    assert!(stopped);
    assert!(within.cost().is_finite());
    let (n_full, n_within) = (search_fits(&full), search_fits(&within));
    assert!(
        4 * n_within < n_full,
        "{n_within} fits within the budget, {n_full} without"
    );
}
