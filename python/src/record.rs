//! The frequency lines of input/output spectra and of time records, as `fdid fit` forms
//! them: the DFT of the record (averaged over its periods when it has several), the lines
//! the input excites (all lines strictly between DC and Nyquist for a noise model), and
//! the sample variances of a periodic record as weights.

use crate::value_error;
use fdid::data::{EXCITATION_FRACTION, ExcitationRule, Lpm, UNEXCITED_NEIGHBOURS};
use fdid::{FrequencyData, TimeData};
use num_complex::Complex64;
use pyo3::PyResult;

/// The sample time of the uniform time grid `t` (s), by the check of a `t,u,y` file.
pub fn sample_time(t: &[f64]) -> PyResult<f64> {
    fdid::io::uniform_sample_time(t).map_err(value_error)
}

/// The fitted lines of the record (`u`, `y`) sampled every `ts` s: averaged over
/// `periods` periods or the DFT of the whole record, then the excited lines above DC
/// (`every_line`: all lines strictly between DC and Nyquist, for a noise model), weighted
/// by their sample variances when every line has a positive one.
///
/// With `reference` (the discrepancy workflow, whose tests need a noise level), a record
/// without sample variances is weighted as `fdid diagnose` weights it: by the output
/// error on the nearest unexcited lines of a multisine, else by the output noise
/// variances of the local polynomial method.
pub fn record_lines(
    record: &TimeData<f64>,
    periods: Option<usize>,
    every_line: bool,
    reference: bool,
) -> PyResult<FrequencyData<f64>> {
    let data = match periods {
        Some(p) => record.average_periods(p).map_err(value_error)?,
        None => record.dft(),
    };
    let excitation = data.excitation(EXCITATION_FRACTION);
    if excitation.count() == 0 {
        return Err(value_error(
            "the input excites no line above DC: the record carries no information about \
             the system",
        ));
    }
    let nyquist = std::f64::consts::PI / record.ts();
    let keep: Vec<bool> = data
        .omega()
        .iter()
        .zip(excitation.lines())
        .map(|(w, excited)| {
            *w > 0.0
                && if every_line {
                    *w < nyquist * (1.0 - 1e-12)
                } else {
                    *excited
                }
        })
        .collect();
    let selected = flat_unless_weighted(data.select_lines(&keep).map_err(value_error)?);
    if !reference || selected.noise().is_some() || periods.is_some_and(|p| p >= 2) {
        return Ok(selected);
    }
    let unexcited = match excitation.rule() {
        ExcitationRule::Level => None,
        _ => data.unexcited_noise(&excitation, UNEXCITED_NEIGHBOURS).ok(),
    };
    if let Some(noisy) = unexcited
        && noisy.omega() == selected.omega()
        && noisy.variance_dof().is_some()
    {
        return Ok(noisy);
    }
    Ok(Lpm::new()
        .estimate(&selected)
        .and_then(|estimate| estimate.spectra_data())
        .ok()
        .filter(|d| d.noise().is_some_and(|n| n.var_y.iter().all(|v| *v > 0.0)))
        .unwrap_or(selected))
}

/// The data without noise variances unless every line has a positive one (the rule of
/// `fdid fit`: a record of one period, or periods that repeat exactly, has none).
pub fn flat_unless_weighted(data: FrequencyData<f64>) -> FrequencyData<f64> {
    let weighted = data
        .noise()
        .is_some_and(|n| n.var_y.iter().all(|v| v.is_finite() && *v > 0.0));
    if weighted { data } else { data.without_noise() }
}

/// The spectra (`u`, `y`) at `omega` (rad/s), checked by the library (its errors name
/// `f`, `u`, `y`).
pub fn spectra(
    omega: Vec<f64>,
    u: Vec<Complex64>,
    y: Vec<Complex64>,
    ts: Option<f64>,
) -> PyResult<FrequencyData<f64>> {
    FrequencyData::new(omega, y, u, ts).map_err(crate::in_hz)
}
