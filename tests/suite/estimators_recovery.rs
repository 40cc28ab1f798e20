//! Noise-free recovery by the estimators, as quickcheck properties over random stable
//! systems (see `common::random_ct_system` / `common::random_dt_system` for the
//! generators), and total least squares on a few fixed systems.
//!
//! Each property draws 100 cases `(seed, na, nb)` with `na` uniform in `1..=MAX` and `nb`
//! uniform in `0..=na`; the system and its grid are built deterministically from `seed`.
//! The quickcheck generator itself is seeded (set `FDID_QC_SEED` to explore other draws),
//! so CI runs are reproducible. Every property is one generic function instantiated for
//! `f64` and `f32`.
//!
//! Thresholds: the ML pipeline must reproduce the FRF with relative RMS error < 1e-9
//! (f64) / < 1e-3 (f32); SK must stop with `Termination::Converged` and reproduce the
//! FRF to < 1e-7 (f64) / < 1e-2 (f32), over orders 1–8 in both precisions.
//!
//! Continuous-time models come from `Rational::continuous`, which picks the partial-fraction
//! form for every nb ≤ na (with a relative-degree constraint when nb < na − 1); `Ct` cases
//! mix nb uniform in 0..=na, `CtPf` cases have nb ∈ {na − 1, na}. The `*_regression` tests
//! pin cases that failed in earlier versions (grid-orthonormal polynomial form for
//! nb < na − 1, SK truncating too many singular values, SK returning a worse iterate than
//! its start); their comments keep the figures measured then. The polynomial form
//! (`Rational::polynomial`, still used for improper models) keeps those limits: measured
//! over 200 seeds per order, f32 held only to order 2 and f64 failed marginally at
//! orders 7–8 (the `survey` below measures any form).

use crate::common;

use common::{RandomSystem, random_ct_system, random_dt_system, rel_rms, two_resonances};
use fdid::prelude::*;
use fdid::solver::Termination;
use quickcheck::{Arbitrary, Gen, TestResult};

/// One random case: a system seed and model orders.
#[derive(Debug, Clone, Copy)]
struct Case {
    seed: u64,
    na: usize,
    nb: usize,
}

impl Case {
    fn draw(g: &mut Gen, max_order: usize) -> Self {
        let seed = u64::arbitrary(g);
        let na = 1 + (u32::arbitrary(g) as usize) % max_order;
        let nb = (u32::arbitrary(g) as usize) % (na + 1);
        Self { seed, na, nb }
    }
}

/// A continuous-time case with `na ≤ MAX`.
#[derive(Debug, Clone, Copy)]
struct Ct<const MAX: usize>(Case);

/// A continuous-time case with `na ≤ MAX` and `nb ∈ {na − 1, na}`, for which
/// `Rational::continuous` picks the partial-fraction form.
#[derive(Debug, Clone, Copy)]
struct CtPf<const MAX: usize>(Case);

/// A discrete-time case with `na ≤ MAX`.
#[derive(Debug, Clone, Copy)]
struct Dt<const MAX: usize>(Case);

impl<const MAX: usize> Arbitrary for Ct<MAX> {
    fn arbitrary(g: &mut Gen) -> Self {
        Ct(Case::draw(g, MAX))
    }
}

impl<const MAX: usize> Arbitrary for CtPf<MAX> {
    fn arbitrary(g: &mut Gen) -> Self {
        let mut c = Case::draw(g, MAX);
        c.nb = c.na - (u32::arbitrary(g) as usize % 2);
        CtPf(c)
    }
}

impl<const MAX: usize> Arbitrary for Dt<MAX> {
    fn arbitrary(g: &mut Gen) -> Self {
        Dt(Case::draw(g, MAX))
    }
}

/// Something that yields a system.
trait SystemCase: Arbitrary + std::fmt::Debug {
    fn system(&self) -> RandomSystem;
}

impl<const MAX: usize> SystemCase for Ct<MAX> {
    fn system(&self) -> RandomSystem {
        random_ct_system(self.0.seed, self.0.na, self.0.nb)
    }
}

impl<const MAX: usize> SystemCase for CtPf<MAX> {
    fn system(&self) -> RandomSystem {
        random_ct_system(self.0.seed, self.0.na, self.0.nb)
    }
}

impl<const MAX: usize> SystemCase for Dt<MAX> {
    fn system(&self) -> RandomSystem {
        random_dt_system(self.0.seed, self.0.na, self.0.nb)
    }
}

/// Noise-free FRF data of `sys` in `T`, and the matching model.
fn data_and_model<T: Real>(sys: &RandomSystem) -> fdid::Result<(FrequencyData<T>, Rational<T>)> {
    let omega: Vec<T> = sys.omega.iter().map(|w| T::lit(*w)).collect();
    let ts = sys.zpk.ts.map(T::lit);
    let data = FrequencyData::from_frf(omega, sys.zpk.frf_t::<T>(&sys.omega), ts)?;
    let model = match ts {
        None => Rational::continuous(sys.na, sys.nb, data.omega())?,
        Some(ts) => Rational::discrete(sys.na, sys.nb, ts)?,
    };
    Ok((data, model))
}

/// Relative RMS FRF error of the default (Levy → SK → ML) pipeline.
fn ml_error<T: Real>(sys: &RandomSystem) -> fdid::Result<f64> {
    let (data, model) = data_and_model::<T>(sys)?;
    let fit = Pipeline::default().fit(&model, &data)?;
    Ok(rel_rms(fit.response(), &sys.frf()))
}

/// Relative RMS FRF error and termination of the SK pipeline (Levy → SK).
fn sk_outcome<T: Real>(sys: &RandomSystem) -> fdid::Result<(f64, Termination)> {
    let (data, model) = data_and_model::<T>(sys)?;
    let fit = Pipeline::sk().fit(&model, &data)?;
    let sk = fit
        .stages()
        .iter()
        .find(|s| s.kind == StageKind::Sk)
        .expect("the SK pipeline has an SK stage");
    Ok((rel_rms(fit.response(), &sys.frf()), sk.solution.termination))
}

fn ml_tol<T: Real>() -> f64 {
    if T::default_epsilon().to_f64_lossless() > 1e-10 {
        1e-3
    } else {
        1e-9
    }
}

fn sk_tol<T: Real>() -> f64 {
    if T::default_epsilon().to_f64_lossless() > 1e-10 {
        1e-2
    } else {
        1e-7
    }
}

/// Property: the default pipeline recovers the FRF of the case's system.
fn ml_recovers<T: Real, C: SystemCase>(case: C) -> TestResult {
    let sys = case.system();
    match ml_error::<T>(&sys) {
        Ok(e) if e < ml_tol::<T>() => TestResult::passed(),
        Ok(e) => TestResult::error(format!(
            "{case:?} ({} lines): FRF rel. RMS error {e:.3e} ≥ {:.0e}",
            sys.omega.len(),
            ml_tol::<T>()
        )),
        Err(err) => TestResult::error(format!("{case:?}: error {err}")),
    }
}

/// Property: SK converges and its FRF error is small.
fn sk_converges<T: Real, C: SystemCase>(case: C) -> TestResult {
    let sys = case.system();
    match sk_outcome::<T>(&sys) {
        Ok((e, Termination::Converged)) if e < sk_tol::<T>() => TestResult::passed(),
        Ok((e, term)) => TestResult::error(format!(
            "{case:?} ({} lines): SK {term:?}, FRF rel. RMS error {e:.3e} (tolerance {:.0e})",
            sys.omega.len(),
            sk_tol::<T>()
        )),
        Err(err) => TestResult::error(format!("{case:?}: error {err}")),
    }
}

/// Runs `prop` on 100 cases from a seeded generator (`FDID_QC_SEED` overrides the seed).
fn check<A: Arbitrary + std::fmt::Debug>(seed: u64, prop: fn(A) -> TestResult) {
    crate::common::seeded(seed).tests(100).quickcheck(prop);
}

// ---------------------------------------------------------------------------------------
// Maximum likelihood (the default pipeline)
//
// Survey figures (200 seeds per order and kind, `survey`); failures = FRF error ≥ 1e-9
// (f64) or ≥ 1e-3 (f32). `Rational::continuous` uses partial fractions when nb ≥ na − 1
// ("CT pf") and the grid-orthonormal polynomial basis otherwise ("CT poly"):
//   CT pf   f64: all orders, worst 1.5e-15.
//   CT pf   f32: orders 1–7 worst 2.2e-5; order 8: 1/200 (1.6e-3, seed 124008).
//   CT poly f64: orders 2–6 worst 1.5e-11; order 7: 1/200 (2.4e-6); order 8: 2/200 (1.2e-9).
//   CT poly f32: order 2 worst 1.0e-5; order 3: 13/200 (worst 6.0e-2); 4: 1/200; 5: 65/200;
//                6: 54/200; 7: 123/200; 8: 175/200 (worst 0.33).
//   DT f64: all orders, worst 1.2e-12.   DT f32: order 7: 1/200 (4.9e-3), else ≤ 1.2e-4.
// The large polynomial-form failures share one cause (`sk_does_not_degrade_levy_regression`):
// SK returns an estimate much worse than the Levy estimate it started from, with a spurious
// real pole far in the right half plane, and ML started there stays in that local minimum.
// With `Pipeline { sk: Some(FixedPoint { rcond_eps: 1.0, .. }), .. }` the CT poly f64
// order-7 worst drops to 1.4e-9 and the CT poly f32 failures to 0/200 at orders 3–4,
// 6/200 at 5, 25 at 6, 95 at 7, 156 at 8.
// ---------------------------------------------------------------------------------------

/// CT (both forms), f64, orders 1–6: FRF error < 1e-9.
#[test]
fn ml_recovers_ct_f64_orders_1_to_6() {
    check(1, ml_recovers::<f64, Ct<6>>);
}

/// CT (both forms), f64, the required orders 1–8: this draw passes, but the survey finds
/// failures in the polynomial form at orders 7–8, pinned by `ml_ct_f64_order_7_regression`
/// (3.5e-6) and `ml_ct_f64_order_8_regression` (1.25e-9).
#[test]
fn ml_recovers_ct_f64_orders_1_to_8() {
    check(2, ml_recovers::<f64, Ct<8>>);
}

/// CT partial-fraction form (nb ∈ {na − 1, na}), f64, orders 1–8: FRF error < 1e-9.
#[test]
fn ml_recovers_ct_partial_fractions_f64_orders_1_to_8() {
    check(21, ml_recovers::<f64, CtPf<8>>);
}

/// CT f64 order 7 (polynomial form), seed 40007: Levy 1.2e-8, SK 8.2e-6, ML 3.5e-6 with a
/// spurious pole at +2.9e5 (true: −10.03). With `FixedPoint { rcond_eps: 1.0, .. }` in
/// the pipeline the error is 1.2e-9.
#[test]
fn ml_ct_f64_order_7_regression() {
    let e = ml_error::<f64>(&random_ct_system(40_007, 7, 3)).unwrap();
    assert!(e < 1e-9, "FRF error {e:.3e}");
}

/// CT f64 order 8 (polynomial form), seed 68008: ML error 1.25e-9 (Levy 1.3e-8, SK
/// 4.4e-9): the f64 round-off floor of the polynomial form at this order, not a wrong
/// estimate (the poles agree to ~1e-9).
#[test]
fn ml_ct_f64_order_8_regression() {
    let e = ml_error::<f64>(&random_ct_system(68_008, 8, 2)).unwrap();
    assert!(e < 1e-9, "FRF error {e:.3e}");
}

/// DT, f64, orders 1–8: FRF error < 1e-9.
#[test]
fn ml_recovers_dt_f64_orders_1_to_8() {
    check(3, ml_recovers::<f64, Dt<8>>);
}

/// CT (both forms), f32, orders 1–2: FRF error < 1e-3 (the measured limit of f32 with
/// the polynomial form, see above).
#[test]
fn ml_recovers_ct_f32_orders_1_to_2() {
    check(4, ml_recovers::<f32, Ct<2>>);
}

/// CT (both forms), f32, the required orders 1–8: fails from order 3 in the polynomial
/// form (e.g. seed 62003: Levy 2.4e-5, SK 9.7e-2, ML 4.7e-2 with a pole at +2.9e5 instead
/// of −10.1).
#[test]
fn ml_recovers_ct_f32_orders_1_to_8() {
    check(5, ml_recovers::<f32, Ct<8>>);
}

/// CT f32 order 3 (polynomial form), seed 62003 (see above): FRF error 4.7e-2.
#[test]
fn ml_ct_f32_order_3_regression() {
    let e = ml_error::<f32>(&random_ct_system(62_003, 3, 1)).unwrap();
    assert!(e < 1e-3, "FRF error {e:.3e}");
}

/// CT partial-fraction form, f32, orders 1–8: FRF error < 1e-3 (this draw passes; the
/// survey's one failure is `ml_ct_pf_f32_order_8_regression`).
#[test]
fn ml_recovers_ct_partial_fractions_f32_orders_1_to_8() {
    check(22, ml_recovers::<f32, CtPf<8>>);
}

/// The one CT partial-fraction f32 failure of the survey: order 8, seed 124008, FRF
/// error 1.6e-3.
#[test]
fn ml_ct_pf_f32_order_8_regression() {
    let e = ml_error::<f32>(&random_ct_system(124_008, 8, 8)).unwrap();
    assert!(e < 1e-3, "FRF error {e:.3e}");
}

/// DT, f32, the required orders 1–8 (this draw passes; see `ml_dt_f32_order_7_regression`).
#[test]
fn ml_recovers_dt_f32_orders_1_to_8() {
    check(7, ml_recovers::<f32, Dt<8>>);
}

/// The one DT f32 failure of the survey (order 7, seed 185007): FRF error 4.9e-3 ≥ 1e-3.
/// With `FixedPoint { rcond_eps: 1.0, .. }` the survey's worst DT f32 order-7 error is
/// 6.3e-4.
#[test]
fn ml_dt_f32_order_7_regression() {
    let e = ml_error::<f32>(&random_dt_system(185_007, 7, 2)).unwrap();
    assert!(e < 1e-3, "FRF error {e:.3e}");
}

/// SK must not make a noise-free Levy estimate worse: started from Levy, its output-error
/// cost should not exceed Levy's (the true system is SK's fixed point). CT f64 order 7
/// (polynomial form), seed 40007: Levy cost 2.3e-14 (FRF error 1.2e-8); SK returns cost
/// 1.1e-8 (FRF error 8.2e-6) and reports `Converged`. Cause: the truncated SVD in the
/// re-weighted solves (`FixedPoint::rcond_eps = 1e3` drops singular values below
/// 2.2e-13·σ_max of the column-equilibrated weighted regressor, 1.2e-4·σ_max in f32);
/// with `rcond_eps = 1` the SK iterates stay at the Levy accuracy or improve. The solver
/// also returns its last iterate on `Converged`, never comparing with its start.
#[test]
fn sk_does_not_degrade_levy_regression() {
    let sys = random_ct_system(40_007, 7, 3);
    let (data, model) = data_and_model::<f64>(&sys).unwrap();
    let fit = Pipeline::sk().fit(&model, &data).unwrap();
    // Levy's θ is in the starting model's basis, SK's in the fit's (relocated) one
    let cost = |m: &Rational<f64>, theta: &[f64]| {
        Fit::new(
            m.clone(),
            &data,
            theta.to_vec(),
            NoiseWeighting::Auto,
            vec![],
        )
        .unwrap()
        .cost()
    };
    let levy = cost(&model, &fit.stages()[0].solution.theta);
    let sk = cost(fit.model(), &fit.stages()[1].solution.theta);
    assert!(sk <= levy * 1.01, "Levy cost {levy:.3e}, SK cost {sk:.3e}");
}

// ---------------------------------------------------------------------------------------
// Sanathanan–Koerner (for partial fractions: SK by pole relocation, i.e. vector fitting)
//
// Survey figures (SK not `Converged` / SK FRF error ≥ 1e-7 (f64), ≥ 1e-2 (f32)):
//   CT pf   f64: always converge, worst 5.9e-15.
//   CT pf   f32: order 8: 1 / 0; otherwise always converge (worst 6.5e-3 at order 6).
//   CT poly f64: orders 2–6 always converge (worst 1.8e-10); 7: 1 / 1 (5.0e-6); 8: 15 / 0.
//   CT poly f32: order 2 always converges (worst 4.6e-5); 3: 3 / 16 (worst 0.98);
//                4: 35 / 10; 5: 60 / 96; 6: 49 / 118; 7: 87 / 177; 8: 40 / 180.
//   DT f64: always converge (worst 9.9e-12).
//   DT f32: 3: 1 / 0; 4: 2 / 1; 5: 8 / 2; 6: 9 / 5; 7: 13 / 7; 8: 15 / 7 (worst 8.3e-2).
// A typical f32 non-convergence is a 2-cycle: DT order 7, seed 7678021018090068927,
// alternates between FRF errors 1e-6 and 1.4e-3 (the truncated SVD again: with
// `rcond_eps ≤ 100` the iterates stay at ~1e-6 and converge).
// ---------------------------------------------------------------------------------------

/// CT (both forms), f64, orders 1–6: SK converges, FRF error < 1e-7.
#[test]
fn sk_converges_ct_f64_orders_1_to_6() {
    check(11, sk_converges::<f64, Ct<6>>);
}

/// CT (both forms), f64, the required orders 1–8: fails in the polynomial form at orders
/// 7–8.
#[test]
fn sk_converges_ct_f64_orders_1_to_8() {
    check(12, sk_converges::<f64, Ct<8>>);
}

/// CT partial-fraction form, f64, orders 1–8: SK converges, FRF error < 1e-7.
#[test]
fn sk_converges_ct_partial_fractions_f64_orders_1_to_8() {
    check(23, sk_converges::<f64, CtPf<8>>);
}

/// DT, f64, orders 1–8: SK converges, FRF error < 1e-7.
#[test]
fn sk_converges_dt_f64_orders_1_to_8() {
    check(13, sk_converges::<f64, Dt<8>>);
}

/// CT (both forms), f32, orders 1–2: SK converges, FRF error < 1e-2.
#[test]
fn sk_converges_ct_f32_orders_1_to_2() {
    check(14, sk_converges::<f32, Ct<2>>);
}

/// CT (both forms), f32, the required orders 1–8: fails from order 3 (polynomial form).
#[test]
fn sk_converges_ct_f32_orders_1_to_8() {
    check(15, sk_converges::<f32, Ct<8>>);
}

/// CT partial-fraction form, f32, orders 1–8: SK converges, FRF error < 1e-2 (survey:
/// 1/200 not converged at order 8).
#[test]
fn sk_converges_ct_partial_fractions_f32_orders_1_to_8() {
    check(24, sk_converges::<f32, CtPf<8>>);
}

/// DT, f32, orders 1–2: SK converges, FRF error < 1e-2.
#[test]
fn sk_converges_dt_f32_orders_1_to_2() {
    check(16, sk_converges::<f32, Dt<2>>);
}

/// DT, f32, the required orders 1–8: fails from order 3.
#[test]
fn sk_converges_dt_f32_orders_1_to_8() {
    check(17, sk_converges::<f32, Dt<8>>);
}

/// The SK 2-cycle in f32 (DT order 7): SK should converge on noise-free data.
#[test]
fn sk_dt_f32_two_cycle_regression() {
    let (e, term) = sk_outcome::<f32>(&random_dt_system(7_678_021_018_090_068_927, 7, 6)).unwrap();
    assert_eq!(term, Termination::Converged, "FRF error {e:.3e}");
    assert!(e < 1e-2, "FRF error {e:.3e}");
}

// ---------------------------------------------------------------------------------------
// Total least squares
// ---------------------------------------------------------------------------------------

fn tls_error<T: Real>(sys: &RandomSystem) -> f64 {
    let (data, model) = data_and_model::<T>(sys).unwrap();
    let sol = estimate(
        &model,
        &data,
        &TotalLeastSquares::default(),
        &SvdNullVector,
        None,
    )
    .unwrap();
    rel_rms(&model.response(&sol.theta, data.omega()), &sys.frf())
}

/// TLS recovers noise-free systems to 1e-9 (f64): the two-resonance CT system, and random
/// CT and DT systems of orders 2–6.
#[test]
fn tls_recovers_noise_free() {
    let mut systems = vec![RandomSystem {
        zpk: two_resonances(),
        na: 4,
        nb: 1,
        omega: common::logspace(-0.5, 1.7, 200),
    }];
    for (seed, na, nb) in [(101, 2, 0), (102, 3, 3), (103, 4, 2), (104, 6, 5)] {
        systems.push(random_ct_system(seed, na, nb));
        systems.push(random_dt_system(seed, na, nb));
    }
    for sys in &systems {
        let e = tls_error::<f64>(sys);
        assert!(
            e < 1e-9,
            "TLS error {e:.3e} for na {} nb {} ({})",
            sys.na,
            sys.nb,
            if sys.zpk.ts.is_some() { "DT" } else { "CT" }
        );
    }
}

// ---------------------------------------------------------------------------------------
// Survey (measures the figures quoted above)
// ---------------------------------------------------------------------------------------

/// Prints, per case kind, precision and order, the worst errors and failure counts over
/// 200 seeds (seed = 1000·s + na). Kinds: CT with nb ≥ na − 1 (`Rational::continuous`
/// picks partial fractions, nb = na − (s mod 2)), CT with nb < na − 1 (polynomial form,
/// nb = s mod (na − 1)), DT (nb = (7s + 3) mod (na + 1)).
#[test]
#[ignore = "measurement, not a check: run with --ignored --nocapture"]
fn survey() {
    fn one<T: Real>(sys: &RandomSystem) -> Option<(f64, f64, bool)> {
        let ml = ml_error::<T>(sys).ok()?;
        let (sk, term) = sk_outcome::<T>(sys).ok()?;
        Some((ml, sk, term == Termination::Converged))
    }
    for kind in ["CT pf", "CT poly", "DT"] {
        for single in [false, true] {
            for na in 1..=8usize {
                if kind == "CT poly" && na < 2 {
                    continue;
                }
                let (mut worst_ml, mut worst_sk) = (0f64, 0f64);
                let (mut ml_fail, mut sk_fail, mut not_conv, mut errors) = (0, 0, 0, 0);
                let (ml_t, sk_t) = if single { (1e-3, 1e-2) } else { (1e-9, 1e-7) };
                let mut first_fail = None;
                for s in 0..200u64 {
                    let seed = s * 1000 + na as u64;
                    let sys = match kind {
                        "CT pf" => random_ct_system(seed, na, na - (s as usize % 2)),
                        "CT poly" => random_ct_system(seed, na, s as usize % (na - 1)),
                        _ => random_dt_system(seed, na, (s as usize * 7 + 3) % (na + 1)),
                    };
                    let out = if single {
                        one::<f32>(&sys)
                    } else {
                        one::<f64>(&sys)
                    };
                    let Some((ml, sk, conv)) = out else {
                        errors += 1;
                        continue;
                    };
                    if ml >= ml_t && first_fail.is_none() {
                        first_fail = Some((seed, sys.nb, ml));
                    }
                    worst_ml = worst_ml.max(ml);
                    worst_sk = worst_sk.max(sk);
                    ml_fail += usize::from(ml >= ml_t);
                    sk_fail += usize::from(sk >= sk_t);
                    not_conv += usize::from(!conv);
                }
                println!(
                    "{kind} {} na={na}: ML worst {worst_ml:.2e}, ≥tol {ml_fail}/200 (first {first_fail:?}); \
                     SK worst {worst_sk:.2e}, ≥tol {sk_fail}/200, not converged {not_conv}/200; errors {errors}",
                    if single { "f32" } else { "f64" },
                );
            }
        }
    }
}
