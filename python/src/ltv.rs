//! `fdid.ltv`: the continuous-time time-varying ODE of Lataire and Pintelon (total least
//! squares on the DFT lines of one record), as `fdid ltv` fits it.

use crate::{value_error, vector};
use fdid::TimeData;
use fdid::ltv::{FrequencyBasis, Lines, LtvOde, TimeBasis};
use num_complex::Complex64;
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// Fits the time-varying ODE Σ aₙ(t) y⁽ⁿ⁾ = Σ bₙ(t) u⁽ⁿ⁾ with coefficients polynomial in
/// t of degree `np` (Legendre or monomial bases) to a sampled record.
///
/// See `fdid.ltv` in the package for the parameters and the result.
#[pyfunction]
#[pyo3(signature = (t, u, y, *, na, nb, np, ntr=None, band=None, basis="legendre", at=None))]
#[allow(clippy::too_many_arguments)]
pub fn ltv<'py>(
    py: Python<'py>,
    t: PyReadonlyArray1<'_, f64>,
    u: PyReadonlyArray1<'_, f64>,
    y: PyReadonlyArray1<'_, f64>,
    na: usize,
    nb: usize,
    np: usize,
    ntr: Option<usize>,
    band: Option<(f64, f64)>,
    basis: &str,
    at: Option<PyReadonlyArray1<'_, f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let t = vector(&t, "t", None)?;
    let u = vector(&u, "u", Some(t.len()))?;
    let y = vector(&y, "y", Some(t.len()))?;
    let ts = crate::record::sample_time(&t)?;
    let (n, t0) = (t.len(), t[0]);
    if na == 0 {
        return Err(value_error(
            "na = 0: the ODE needs at least one output derivative",
        ));
    }
    let nyquist = 0.5 / ts;
    let (lo, hi) = band.unwrap_or((0.0, nyquist));
    if hi > nyquist * (1.0 + 1e-12) {
        return Err(value_error(format!(
            "band up to {hi} Hz: above the Nyquist frequency {nyquist} Hz of the record"
        )));
    }
    let lines = Lines::band(lo, hi.min(nyquist))
        .resolve(n, ts)
        .map_err(value_error)?;
    let omega_top = lines
        .last()
        .map_or(0.0, |k| std::f64::consts::TAU * *k as f64 / (n as f64 * ts));
    let omega_max = if omega_top > 0.0 {
        omega_top
    } else {
        std::f64::consts::TAU / (n as f64 * ts)
    };
    let mut model = LtvOde::new(na, nb, np);
    if let Some(k) = ntr {
        model = model.with_transient(Some(k));
    }
    let model = match basis {
        "legendre" => model
            .with_time_basis(TimeBasis::Legendre)
            .with_frequency_basis(FrequencyBasis::legendre(omega_max).map_err(value_error)?),
        "monomial" => model
            .with_time_basis(TimeBasis::Monomial)
            .with_frequency_basis(FrequencyBasis::Monomial),
        other => {
            return Err(value_error(format!(
                "basis {other:?} is not \"legendre\" or \"monomial\""
            )));
        }
    };
    let times: Vec<f64> = match at {
        Some(a) => vector(&a, "at", None)?.iter().map(|v| v - t0).collect(),
        None => (0..5)
            .map(|i| (n - 1) as f64 * ts * i as f64 / 4.0)
            .collect(),
    };
    if let Some(k) = times.iter().position(|v| !v.is_finite()) {
        return Err(value_error(format!("at[{k}] is not finite")));
    }
    let (fit, poles) = py.allow_threads(|| -> PyResult<_> {
        let record = TimeData::new(u, y, ts).map_err(value_error)?;
        let fit = model
            .fit(&record, &Lines::Indices(lines))
            .map_err(value_error)?;
        let poles = fit.pole_sweep(&times).map_err(value_error)?;
        Ok((fit, poles))
    })?;
    let d = PyDict::new(py);
    d.set_item("theta", fit.theta.clone().into_pyarray(py))?;
    d.set_item(
        "singular_values",
        fit.singular_values.clone().into_pyarray(py),
    )?;
    d.set_item("lines", fit.lines.len())?;
    d.set_item("transient", fit.transient().to_vec().into_pyarray(py))?;
    d.set_item(
        "times",
        times
            .iter()
            .map(|v| v + t0)
            .collect::<Vec<f64>>()
            .into_pyarray(py),
    )?;
    let sweep = PyList::empty(py);
    for p in poles {
        sweep.append(p.into_iter().collect::<Vec<Complex64>>().into_pyarray(py))?;
    }
    d.set_item("poles", sweep)?;
    Ok(d)
}
