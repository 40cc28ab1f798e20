//! The fits of one model structure: to a frequency response, to spectra, to a sampled
//! record, and to many frequency responses on the thread pool.

use crate::fit::Fit;
use crate::{
    Model, angular_of, angular_unchecked, in_hz, record, sample_time, value_error, vector,
};
use fdid::estimate::ModelSpec;
use fdid::{FdidError, FrequencyData, NoiseVariances, TimeData};
use num_complex::Complex64;
use numpy::PyReadonlyArray1;
use pyo3::prelude::*;

/// Fits a rational model to a frequency response.
///
/// See `fdid.fit` in the package for the parameters.
#[pyfunction]
#[pyo3(signature = (f, frf, var, band, model))]
pub fn fit_frf(
    py: Python<'_>,
    f: PyReadonlyArray1<'_, f64>,
    frf: PyReadonlyArray1<'_, Complex64>,
    var: Option<PyReadonlyArray1<'_, f64>>,
    band: Option<(f64, f64)>,
    model: Model,
) -> PyResult<Fit> {
    let omega = angular_of(&f);
    let g = vector(&frf, "frf", Some(omega.len()))?;
    let var = var
        .map(|v| vector(&v, "var", Some(omega.len())))
        .transpose()?;
    let spec = model.spec(None)?;
    let ts = sample_time(&spec);
    // the fit runs without the GIL: other Python threads go on meanwhile
    py.allow_threads(|| fit_spec(&spec, frf_of(omega, g, var, ts)?, band))
}

/// Fits a rational model to input and output spectra (errors in the output).
///
/// See `fdid.fit_spectra` in the package for the parameters.
#[pyfunction]
#[pyo3(signature = (f, u, y, var, band, model))]
pub fn fit_spectra(
    py: Python<'_>,
    f: PyReadonlyArray1<'_, f64>,
    u: PyReadonlyArray1<'_, Complex64>,
    y: PyReadonlyArray1<'_, Complex64>,
    var: Option<PyReadonlyArray1<'_, f64>>,
    band: Option<(f64, f64)>,
    model: Model,
) -> PyResult<Fit> {
    let omega = angular_of(&f);
    let u = vector(&u, "u", Some(omega.len()))?;
    let y = vector(&y, "y", Some(omega.len()))?;
    let var = var
        .map(|v| vector(&v, "var", Some(omega.len())))
        .transpose()?;
    let spec = model.spec(None)?;
    let ts = sample_time(&spec);
    py.allow_threads(|| {
        let data = record::spectra(omega, u, y, ts)?;
        fit_spec(&spec, with_variances(data, var)?, band)
    })
}

/// Fits a rational model to a sampled input/output record.
///
/// See `fdid.fit_record` in the package for the parameters.
#[pyfunction]
#[pyo3(signature = (t, u, y, periods, band, model))]
pub fn fit_record(
    py: Python<'_>,
    t: PyReadonlyArray1<'_, f64>,
    u: PyReadonlyArray1<'_, f64>,
    y: PyReadonlyArray1<'_, f64>,
    periods: Option<usize>,
    band: Option<(f64, f64)>,
    model: Model,
) -> PyResult<Fit> {
    let t = vector(&t, "t", None)?;
    let u = vector(&u, "u", Some(t.len()))?;
    let y = vector(&y, "y", Some(t.len()))?;
    let ts = record::sample_time(&t)?;
    let spec = model.spec(Some(ts))?;
    let every_line = spec.noise_order.is_some();
    py.allow_threads(|| {
        let record = TimeData::new(u, y, ts).map_err(value_error)?;
        let data = record::record_lines(&record, periods, every_line, false)?;
        fit_spec(&spec, data, band)
    })
}

/// One frequency response of `fit_many`: f (Hz), the FRF and optional noise variances.
type Dataset<'py> = (
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, Complex64>,
    Option<PyReadonlyArray1<'py, f64>>,
);

/// Fits the same model structure to many frequency responses on the thread pool (rayon;
/// `RAYON_NUM_THREADS` sets its size), the GIL released: one `Fit` per data set, or, with
/// `errors="none"`, `None` for a data set whose fit fails (else the first failure raises
/// a `ValueError` naming its index).
#[pyfunction]
#[pyo3(signature = (datasets, band, errors, model))]
pub fn fit_many(
    py: Python<'_>,
    datasets: Vec<Dataset<'_>>,
    band: Option<(f64, f64)>,
    errors: &str,
    model: Model,
) -> PyResult<Vec<Option<Fit>>> {
    let keep_going = match errors {
        "raise" => false,
        "none" => true,
        other => {
            return Err(value_error(format!(
                "errors={other:?} is not \"raise\" or \"none\""
            )));
        }
    };
    let spec = model.spec(None)?;
    let mut inputs = Vec::with_capacity(datasets.len());
    for (k, (f, g, var)) in datasets.iter().enumerate() {
        let at = |e: PyErr| value_error(format!("data set {k}: {}", e.value(py)));
        let f_hz = vector(f, "f", None).map_err(at)?;
        let g = vector(g, "frf", Some(f_hz.len())).map_err(at)?;
        let var = var
            .as_ref()
            .map(|v| vector(v, "var", Some(f_hz.len())))
            .transpose()
            .map_err(at)?;
        inputs.push((f_hz, g, var));
    }
    let ts = sample_time(&spec);
    let fits: Vec<Result<Fit, String>> = py.allow_threads(|| {
        use rayon::prelude::*;
        inputs
            .into_par_iter()
            .map(|(f_hz, g, var)| {
                frf_data(&f_hz, g, var, ts)
                    .and_then(|data| fit_spec(&spec, data, band))
                    .map_err(|e| Python::with_gil(|py| e.value(py).to_string()))
            })
            .collect()
    });
    fits.into_iter()
        .enumerate()
        .map(|(k, fit)| match fit {
            Ok(fit) => Ok(Some(fit)),
            Err(_) if keep_going => Ok(None),
            Err(m) => Err(value_error(format!("data set {k}: {m}"))),
        })
        .collect()
}

/// The frequency lines of an FRF (f in Hz) with optional noise variances, checked.
pub(crate) fn frf_data(
    f_hz: &[f64],
    g: Vec<Complex64>,
    var: Option<Vec<f64>>,
    ts: Option<f64>,
) -> PyResult<FrequencyData<f64>> {
    frf_of(angular_unchecked(f_hz), g, var, ts)
}

/// [`frf_data`] from the angular frequencies. The frequencies and the frequency response
/// are checked by the library (one pass each), its errors named after the arguments.
fn frf_of(
    omega: Vec<f64>,
    g: Vec<Complex64>,
    var: Option<Vec<f64>>,
    ts: Option<f64>,
) -> PyResult<FrequencyData<f64>> {
    let data = FrequencyData::from_frf(omega, g, ts).map_err(|e| match e {
        FdidError::NonFinite {
            what: "y",
            index,
            value,
        } => value_error(format!("frf[{index}] = {value} is not finite")),
        e => in_hz(e),
    })?;
    with_variances(data, var)
}

/// The data with the noise variance `var` of each line (positive and finite), if given.
fn with_variances(data: FrequencyData<f64>, var: Option<Vec<f64>>) -> PyResult<FrequencyData<f64>> {
    let Some(var) = var else {
        return Ok(data);
    };
    if let Some(k) = var.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
        return Err(value_error(format!(
            "var[{k}] = {}: a noise variance must be positive and finite",
            var[k]
        )));
    }
    data.with_noise(NoiseVariances::output_only(var))
        .map_err(value_error)
}

/// `data` restricted to `band` (Hz), fitted with `spec`.
fn fit_spec(spec: &ModelSpec, data: FrequencyData<f64>, band: Option<(f64, f64)>) -> PyResult<Fit> {
    let data = match band {
        Some((lo, hi)) => data.band_hz(lo, hi).map_err(value_error)?,
        None => data,
    };
    let started = std::time::Instant::now();
    let fit = spec.fit(&data).map_err(value_error)?;
    let seconds = started.elapsed().as_secs_f64();
    let mut out = Fit::of(&fit, spec.domain)?;
    out.fit_seconds = Some(seconds);
    Ok(out)
}
