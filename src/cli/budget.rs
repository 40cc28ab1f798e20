//! How long a command may run by default: runs whose bound is beyond about a minute are
//! refused up front, with the reason and what to change, unless `--allow-long` is given.

use super::Failure;
use fdid::estimate::{ModelSpec, RationalFit};
use fdid::prelude::*;
use std::result::Result;

/// Multiply-adds of least-squares solves per second on two cores: the slowest rate of
/// the delay searches and noise models measured on the bundled dryer record (2026).
const WORK_PER_SECOND: f64 = 1.6e8;

/// The longest bound `fdid fit` runs without `--allow-long` (s).
const MAX_SECONDS: f64 = 60.0;

/// The note of a fit stopped by the work budget.
const STOPPED_NOTE: &str = "the fit was stopped at the work budget of about a minute on two \
    cores before its iterations converged: the model may not be at the criterion's minimum \
    (--allow-long lifts the budget; --band or lower orders make the fit cheaper)";

/// `spec` fitted to `data`, with a note when the work budget stopped it. Unless
/// `allow_long`: refused when the work every fit of it makes
/// ([`ModelSpec::least_search_work`]: a delay search up to its first candidate) is beyond
/// [`MAX_SECONDS`], and run within that much work ([`ModelSpec::fit_within`]), which stops
/// a delay search that has to scan further.
pub(super) fn fit(
    spec: &ModelSpec,
    data: &FrequencyData<f64>,
    allow_long: bool,
) -> Result<(RationalFit, Option<&'static str>), Failure> {
    if allow_long {
        return Ok((spec.fit(data)?, None));
    }
    check_search(spec, data)?;
    let (fit, stopped) = spec.fit_within(data, MAX_SECONDS * WORK_PER_SECOND)?;
    Ok((fit, stopped.then_some(STOPPED_NOTE)))
}

/// Refuses `spec` on `data` when the least work of its search stages is beyond
/// [`MAX_SECONDS`].
fn check_search(spec: &ModelSpec, data: &FrequencyData<f64>) -> Result<(), Failure> {
    let work = spec.least_search_work(data)?;
    let seconds = work / WORK_PER_SECOND;
    if seconds <= MAX_SECONDS {
        return Ok(());
    }
    let mut options = vec![];
    if spec.delay {
        options
            .push("--delay (the phase-slope delay refined by ML, then the joint ML)".to_string());
    }
    if let Some(n) = spec.noise_order {
        options.push(format!(
            "--noise-order {n} (maximum likelihood on {} parameters)",
            spec.na + spec.nb + 1 + 2 * n
        ));
    }
    refuse(
        &format!(
            "{} on {} lines with --na {} --nb {}",
            options.join(" and "),
            data.len(),
            spec.na,
            spec.nb
        ),
        seconds,
    )
}

/// Refuses `fdid ltv` when the total least squares of its regressor (`rows` real
/// equations, `params` columns: QR, then the SVD of R, about 2·rows·params²) is estimated
/// beyond [`MAX_SECONDS`], unless `allow_long`.
pub(super) fn check_ltv(rows: usize, params: usize, allow_long: bool) -> Result<(), Failure> {
    let seconds = 2.0 * rows as f64 * (params * params) as f64 / WORK_PER_SECOND;
    if allow_long || seconds <= MAX_SECONDS {
        return Ok(());
    }
    refuse(
        &format!("the time-varying fit of {params} parameters on {rows} real equations"),
        seconds,
    )
}

/// The usage error for `what`, estimated at `seconds`.
fn refuse(what: &str, seconds: f64) -> Result<(), Failure> {
    Err(Failure::usage(format!(
        "{what} could take up to {seconds:.0} s on two cores, more than the minute the \
         command runs by default: select the band of interest with --band FMIN:FMAX, lower \
         the orders, or pass --allow-long to run anyway"
    )))
}

/// Work units per second of a common-pole fit on two cores: its relocations and
/// variable-projection evaluations run as matrix products, about 20 times the rate of
/// the delay searches ([`WORK_PER_SECOND`]); measured on the 8-port of
/// `bench/multiport.py` (64 entries, 5 000 lines, 40 poles: 7.3·10¹⁰ units in 22 s).
const COMMON_POLE_WORK_PER_SECOND: f64 = 3.3e9;

/// A common-pole fit (`fit`, of an FRF matrix or of a record's spectra), within the work
/// budget of [`MAX_SECONDS`] unless `allow_long`, with a note when the budget stopped its
/// iterations.
pub(super) fn fit_common_poles<R>(
    allow_long: bool,
    fit: impl FnOnce() -> fdid::Result<R>,
) -> Result<(R, Option<&'static str>), Failure> {
    if allow_long {
        return Ok((fit()?, None));
    }
    let (fit, stopped) = fdid::solver::work::within(MAX_SECONDS * COMMON_POLE_WORK_PER_SECOND, fit);
    Ok((fit?, stopped.then_some(STOPPED_NOTE)))
}
