//! Common-pole fits of records with several inputs acting together
//! (`fdid::mimo::fit_common_poles_spectra`): noise-free recovery of random discrete-time
//! MIMO systems simulated from random initial states (so the record carries a transient)
//! in f64 and f32 (quickcheck), the transient's part, the CD player arm (2 × 2, DaISy)
//! and bad input.

use super::mimo::{Case, Draw, pole_error};
use crate::common;
use fdid::data::MimoSpectra;
use fdid::io::{Column, MultiChannelSelection, read_multichannel};
use fdid::mimo::{CommonPoleModel, CommonPoleOptions, fit_common_poles_spectra};
use fdid::prelude::*;
use nalgebra::DMatrix;
use quickcheck::TestResult;

/// The sample time of the simulated records: the cases' 0.1–10 rad/s become 0.025–2.5
/// rad/sample.
pub(crate) const TS: f64 = 0.25;

/// The discrete-time image of a case (poles e^{pTs}, residues scaled by Ts) with a direct
/// term when `direct`.
pub(crate) fn z_model(case: &Case, direct: bool) -> CommonPoleModel<f64> {
    let ct = case.model();
    let map = |p: &Complex<f64>| (p * TS).exp();
    let mut d = Draw(case.seed ^ 0x9e37_79b9);
    CommonPoleModel {
        domain: Domain::Discrete { ts: TS },
        poles: fdid::mimo::PoleSet {
            real: ct.poles.real.iter().map(|p| (p * TS).exp()).collect(),
            pairs: ct.poles.pairs.iter().map(map).collect(),
        },
        residues: ct
            .residues
            .iter()
            .map(|r| r * Complex::new(TS, 0.0))
            .collect(),
        direct: direct.then(|| DMatrix::from_fn(case.ny, case.nu, |_, _| d.signed())),
    }
}

/// Simulates `model` (z) on the inputs `u` (nu rows of N samples) from random initial
/// states: every pole and input has the state w(t+1) = p w(t) + u_j(t), and output i
/// gathers R_ij w(t) (2 Re R_ij w(t) for a pair) and D_ij u_j(t).
pub(crate) fn simulate(
    model: &CommonPoleModel<f64>,
    u: &[Vec<f64>],
    d: &mut Draw,
) -> Vec<Vec<f64>> {
    let n = u[0].len();
    let ny = model.ny();
    let nr = model.poles.real.len();
    let slots = model.poles.slots();
    let mut y = vec![vec![0.0; n]; ny];
    for (s, p) in slots.iter().enumerate() {
        let pair = s >= nr;
        for (j, uj) in u.iter().enumerate() {
            let mut w = if pair {
                Complex::new(d.signed(), d.signed())
            } else {
                Complex::new(d.signed(), 0.0)
            };
            for t in 0..n {
                for (i, yi) in y.iter_mut().enumerate() {
                    let v = model.residues[s][(i, j)] * w;
                    yi[t] += if pair { 2.0 * v.re } else { v.re };
                }
                w = p * w + uj[t];
            }
        }
    }
    if let Some(dm) = &model.direct {
        for (i, yi) in y.iter_mut().enumerate() {
            for (j, uj) in u.iter().enumerate() {
                for t in 0..n {
                    yi[t] += dm[(i, j)] * uj[t];
                }
            }
        }
    }
    y
}

/// A record of `case` (N = 1024 samples of white inputs, random initial states) and its
/// spectra in `T` without the DC line.
fn record<T: Real>(case: &Case, direct: bool) -> (CommonPoleModel<f64>, MimoSpectra<T>) {
    let model = z_model(case, direct);
    let mut d = Draw(case.seed.wrapping_mul(0x2545_f491_4f6c_dd1d) | 1);
    let u: Vec<Vec<f64>> = (0..case.nu)
        .map(|_| (0..1024).map(|_| d.signed()).collect())
        .collect();
    let y = simulate(&model, &u, &mut d);
    let cast = |x: Vec<Vec<f64>>| -> Vec<Vec<T>> {
        x.into_iter()
            .map(|c| c.into_iter().map(T::lit).collect())
            .collect()
    };
    let spectra = MimoSpectra::from_time(cast(u), cast(y), T::lit(TS)).unwrap();
    let keep: Vec<bool> = spectra.omega().iter().map(|w| *w > T::zero()).collect();
    (model, spectra.select_lines(&keep).unwrap())
}

fn options<T: Real>(direct: bool) -> CommonPoleOptions<T> {
    CommonPoleOptions {
        domain: Domain::Discrete { ts: T::lit(TS) },
        direct,
        ..CommonPoleOptions::default()
    }
}

fn recovers<T: Real>(case: Case, tolerance: f64) -> TestResult {
    let direct = case.seed.is_multiple_of(2);
    let (model, data) = record::<T>(&case, direct);
    let fit = match fit_common_poles_spectra(&data, model.order(), &options(direct)) {
        Ok(f) => f,
        Err(e) => return TestResult::error(format!("{case:?}: {e}")),
    };
    let err = pole_error(&model.poles, &fit.model.poles);
    let energy: f64 = (0..data.ny())
        .flat_map(|i| data.y(i).iter().map(|v| v.norm_sqr().to_f64_lossless()))
        .sum();
    let misfit = (fit.cost.to_f64_lossless() / energy).sqrt();
    if err < tolerance && misfit < tolerance {
        TestResult::passed()
    } else {
        TestResult::error(format!(
            "{case:?} direct {direct}: pole error {err:.2e}, relative misfit {misfit:.2e} \
             (tolerance {tolerance:.0e}), {} relocations, ml {:?}",
            fit.relocations, fit.ml
        ))
    }
}

fn recovers_f64(case: Case) -> TestResult {
    recovers::<f64>(case, 1e-7)
}

fn recovers_f32(case: Case) -> TestResult {
    recovers::<f32>(case, 5e-3)
}

#[test]
fn noise_free_recovery_from_records_with_several_inputs_f64() {
    common::seeded(0x5eed_1618)
        .tests(30)
        .quickcheck(recovers_f64 as fn(Case) -> TestResult);
}

#[test]
fn noise_free_recovery_from_records_with_several_inputs_f32() {
    common::seeded(0x5eed_1414)
        .tests(30)
        .quickcheck(recovers_f32 as fn(Case) -> TestResult);
}

/// The residue matrices and direct term are recovered, and the transient matters: the
/// same record fitted without it leaves a misfit many orders above the noise-free one.
#[test]
fn residues_direct_term_and_transient_of_a_three_by_two_record() {
    let case = Case {
        seed: 42,
        ny: 3,
        nu: 2,
        pairs: 3,
        real: 1,
    };
    let (model, data) = record::<f64>(&case, true);
    let fit = fit_common_poles_spectra(&data, model.order(), &options(true)).unwrap();
    assert!(pole_error(&model.poles, &fit.model.poles) < 1e-9);
    for (s, p) in model.poles.slots().iter().enumerate() {
        let fitted = fit
            .model
            .poles
            .slots()
            .iter()
            .position(|q| (q - p).norm() < 1e-8)
            .expect("every pole found");
        let diff = (&fit.model.residues[fitted] - &model.residues[s]).norm();
        assert!(
            diff < 1e-8 * model.residues[s].norm(),
            "residue {s}: {diff:e}"
        );
    }
    let d = fit.model.direct.as_ref().unwrap() - model.direct.as_ref().unwrap();
    assert!(d.norm() < 1e-8, "direct term off by {:e}", d.norm());
    let without = CommonPoleOptions {
        transient: false,
        ..options(true)
    };
    let blind = fit_common_poles_spectra(&data, model.order(), &without).unwrap();
    assert!(
        blind.cost > 1e6 * fit.cost,
        "without the transient {:e}, with it {:e}",
        blind.cost,
        fit.cost
    );
}

/// The spectra of the CD player arm record (DaISy): inputs u1, u2, outputs y1, y2, Ts = 1,
/// without the DC line.
fn cd_player() -> MimoSpectra<f64> {
    let selection = MultiChannelSelection {
        inputs: vec![Column::parse("u1"), Column::parse("u2")],
        outputs: vec![Column::parse("y1"), Column::parse("y2")],
        ts: None,
        periods: None,
        skip_periods: 0,
    };
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/cd_player_arm.csv");
    let s = read_multichannel::<f64>(&path, &selection).unwrap();
    let keep: Vec<bool> = s.omega().iter().map(|w| *w > 0.0).collect();
    s.select_lines(&keep).unwrap()
}

/// The share of each output explained, 1 − ‖Y − Ŷ‖/‖Y‖.
fn explained(data: &MimoSpectra<f64>, costs: &[f64]) -> Vec<f64> {
    costs
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let energy: f64 = data.y(i).iter().map(|v| v.norm_sqr()).sum();
            1.0 - (c / energy).sqrt()
        })
        .collect()
}

/// The CD player arm is a 2 × 2 system of low order (its README: order 2–3): a common-pole
/// model of order 3 with a direct term and the transient is stable without being forced
/// to, explains most of each output, and each output needs both inputs — the fit with
/// both explains more of it than the fit with either input alone.
#[test]
fn cd_player_arm_two_by_two() {
    let data = cd_player();
    let opts = CommonPoleOptions {
        domain: Domain::Discrete { ts: 1.0 },
        direct: true,
        ..CommonPoleOptions::default()
    };
    let fit = fit_common_poles_spectra(&data, 3, &opts).unwrap();
    assert!(
        fit.model.poles.is_stable(opts.domain),
        "poles {:?}",
        fit.model.poles.all()
    );
    assert_eq!((fit.model.ny(), fit.model.nu()), (2, 2));
    let both = explained(&data, &fit.costs);
    assert!(both.iter().all(|e| *e > 0.7), "explained {both:?}");
    for j in 0..2 {
        let alone = MimoSpectra::new(
            data.omega().to_vec(),
            vec![data.u(j).to_vec()],
            vec![data.y(0).to_vec(), data.y(1).to_vec()],
            data.ts(),
        )
        .unwrap();
        let one = fit_common_poles_spectra(&alone, 3, &opts).unwrap();
        let single = explained(&alone, &one.costs);
        for i in 0..2 {
            assert!(
                both[i] > single[i] + 0.02,
                "output {} with both inputs {:.3}, with input {} alone {:.3}",
                i + 1,
                both[i],
                j + 1,
                single[i]
            );
        }
    }
}

#[test]
fn bad_records_give_errors() {
    let case = Case {
        seed: 7,
        ny: 2,
        nu: 2,
        pairs: 1,
        real: 0,
    };
    let (_, data) = record::<f64>(&case, false);
    let e = fit_common_poles_spectra(&data, 0, &options(false)).unwrap_err();
    assert!(e.to_string().contains("order"), "{e}");
    // 2·L = 8 real equations cannot carry 2·(n + 0) + n + n + 1 = 9 unknowns for n = 2
    let few = data
        .select_lines(&(0..data.len()).map(|k| k < 4).collect::<Vec<_>>())
        .unwrap();
    let e = fit_common_poles_spectra(&few, 2, &options(false)).unwrap_err();
    assert!(matches!(e, FdidError::TooFewFrequencies { .. }), "{e}");
    // lines beyond Nyquist for the stated sample time
    let wrong = CommonPoleOptions {
        domain: Domain::Discrete { ts: 1.0 },
        ..options::<f64>(false)
    };
    let e = fit_common_poles_spectra(&data, 2, &wrong).unwrap_err();
    assert!(e.to_string().contains("Nyquist"), "{e}");
    // channels of different lengths, non-finite samples
    let e = MimoSpectra::from_time(vec![vec![0.0; 8]], vec![vec![0.0; 7]], 1.0).unwrap_err();
    assert!(matches!(e, FdidError::LengthMismatch { .. }), "{e}");
    let mut bad = vec![1.0; 8];
    bad[3] = f64::INFINITY;
    assert!(MimoSpectra::from_time(vec![bad], vec![vec![0.0; 8]], 1.0).is_err());
}
