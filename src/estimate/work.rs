//! Upper bounds of the work of the search stages of a fit, from their evaluation budgets,
//! so that a caller can refuse a run that could last far longer than it wants to wait.
//!
//! The unit is one multiply-add of a least-squares solve: an evaluation of a problem with
//! `lines` complex lines and q parameters costs 2·lines·q² (the QR of its real-stacked
//! Jacobian, which dominates the evaluation).

use super::delay::{
    BETWEEN_STARTS, CANDIDATE_ROUNDS, MAX_SCAN, PHASE_ITERATIONS, PROFILE_LINES, PROFILE_MINIMA,
    PROFILE_ROUNDS, REFINED_MINIMA, SAMPLE_MULTIPLES, SCREEN_ITERATIONS, SEARCH_EVALUATIONS,
    SEARCH_PATIENCE,
};
use crate::solver::work::solve_cost;
use crate::solver::{FixedPoint, LevenbergMarquardt};

/// The cost of `evaluations` solves of 2·`lines` real rows and `q` columns.
fn solves(evaluations: usize, lines: usize, q: usize) -> f64 {
    evaluations as f64 * solve_cost(2 * lines, q)
}

/// The most residual evaluations of a Levenberg–Marquardt run on `q` parameters with the
/// default settings (`patience·(q + 1)`).
fn lm_evaluations(q: usize) -> usize {
    LevenbergMarquardt::default().patience * (q + 1)
}

/// The most solves of a delay-free fit without ML: Levy, then the Sanathanan–Koerner
/// iterations at their default cap.
fn linear_fit() -> usize {
    1 + FixedPoint::default().max_iterations
}

/// The Levy profile of [`super::delay_start`] for an inner model of `p` parameters on
/// `lines` lines: its screening fit (Levy and three SK solves) and about one Gram matrix
/// per delay of the scan (at most [`MAX_SCAN`]), both on at most [`PROFILE_LINES`] lines.
fn delay_profile(p: usize, lines: usize) -> f64 {
    let lines = lines.min(PROFILE_LINES);
    let delays = (3 * 4 * (p / 2 + 2) + 1).min(MAX_SCAN);
    solves(1 + SCREEN_ITERATIONS, lines, p) + solves(delays, lines, p + 1) / 2.0
}

/// One refinement round of the delay search: a delay-free fit and an ML with the search's
/// budget on q = p + 1 parameters.
fn delay_round(p: usize, lines: usize) -> f64 {
    let q = p + 1;
    let search_ml = SEARCH_EVALUATIONS.max(SEARCH_PATIENCE * (q + 1));
    solves(linear_fit(), lines, p) + solves(search_ml, lines, q)
}

/// The fits after the delay search: the inner model's full fit at the chosen delay and
/// the joint ML on p + 1 parameters.
fn after_delay_search(p: usize, lines: usize) -> f64 {
    solves(linear_fit() + lm_evaluations(p), lines, p) + solves(lm_evaluations(p + 1), lines, p + 1)
}

/// The delay search of [`super::delay_start`] and the fits after it, for an inner model of
/// `p` parameters on `lines` lines: the Levy profile and the refinements of its minima,
/// the phase iterations (delay-free fits), the scan (Levy and three SK solves per
/// candidate), the refinements (the local minima of the scan, up to nine delays a whole
/// number of samples away and seven between minima, each in rounds of a delay-free fit
/// and an ML with the search's budget), the inner model's full fit at the chosen delay and
/// the joint ML on p + 1 parameters.
pub(super) fn delay_search(p: usize, lines: usize) -> f64 {
    let refined = REFINED_MINIMA + SAMPLE_MULTIPLES + BETWEEN_STARTS;
    delay_profile(p, lines)
        + (PROFILE_MINIMA * PROFILE_ROUNDS) as f64 * delay_round(p, lines)
        + solves(PHASE_ITERATIONS * linear_fit(), lines, p)
        + solves(MAX_SCAN * (1 + SCREEN_ITERATIONS), lines, p)
        + (refined * CANDIDATE_ROUNDS) as f64 * delay_round(p, lines)
        + after_delay_search(p, lines)
}

/// The part of [`delay_search`] that every search makes: the Levy profile, the first
/// refinement of its lowest minimum and the fits after the search. A search whose first
/// refinement reaches the noise level stops there (after the profile's competing minima);
/// the phase iterations, the scan and the other refinements follow only when it does not.
pub(super) fn delay_search_least(p: usize, lines: usize) -> f64 {
    delay_profile(p, lines)
        + PROFILE_ROUNDS as f64 * delay_round(p, lines)
        + after_delay_search(p, lines)
}

/// The noise-model ML of [`super::refine_noise_model`] for a system of `p` parameters and
/// `n` noise parameters on `lines` lines: one Levenberg–Marquardt run on p + n parameters
/// at its full budget (the polish after H is stabilised, when a root was reflected, took
/// a fifth or less of the first run in the runs measured).
pub(super) fn noise_model(p: usize, n: usize, lines: usize) -> f64 {
    let q = p + n;
    solves(lm_evaluations(q), lines, q)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bounds_grow_with_the_lines_and_the_order() {
        // linear in the lines but for the profile, which uses at most 256 of them
        let (short, long) = (delay_search(5, 1000), delay_search(5, 2000));
        assert!(
            long > 1.99 * short && long < 2.0 * short,
            "{long} vs {short}"
        );
        assert_eq!(delay_profile(5, 2000), delay_profile(5, PROFILE_LINES));
        assert!(delay_profile(5, 100) < delay_profile(5, 200));
        // every solve grows with the square of its parameters: (22/6)² ≈ 13.4 at least
        assert!(delay_search(21, 500) > 13.4 * delay_search(5, 500));
        assert_eq!(noise_model(5, 4, 1000), 2.0 * noise_model(5, 4, 500));
        // order 30 (60 noise parameters) against order 2: (65/9)³ ≈ 380 times more
        let ratio = noise_model(5, 60, 500) / noise_model(5, 4, 500);
        assert!((ratio - (66.0 * 65.0 * 65.0) / (10.0 * 9.0 * 9.0)).abs() < 1e-9);
    }
}
