//! `fdid._fdid`: the Python extension of fdid. numpy arrays in and out; fits run with the
//! GIL released; bad input raises `ValueError` with fdid's message.

mod saved;

use fdid::estimate::{DelayRange, Method, ModelSpec, RationalFit, Stability};
use fdid::model::Domain;
use fdid::validation::Validation;
use fdid::{FrequencyData, NoiseVariances};
use num_complex::Complex64;
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLike1, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use saved::Saved;

/// A `ValueError` carrying fdid's message.
fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The criterion named in Python's terms.
fn method(name: &str) -> PyResult<Method> {
    match name {
        "ml" => Ok(Method::Ml),
        "levy" => Ok(Method::Levy),
        "sk" => Ok(Method::Sk),
        "tls" => Ok(Method::Tls),
        other => Err(value_error(format!(
            "criterion {other:?} is not one of \"ml\", \"levy\", \"sk\", \"tls\""
        ))),
    }
}

/// The model domain: `"s"` (continuous time) or `"z"` with the sample time `ts` (s).
fn domain(name: &str, ts: Option<f64>) -> PyResult<Domain<f64>> {
    match (name, ts) {
        ("s", None) => Ok(Domain::Continuous),
        ("s", Some(ts)) => Err(value_error(format!(
            "ts = {ts} is for domain \"z\"; a continuous-time (\"s\") model has no sample time"
        ))),
        ("z", Some(ts)) if ts.is_finite() && ts > 0.0 => Ok(Domain::Discrete { ts }),
        ("z", Some(ts)) => Err(value_error(format!(
            "ts = {ts}: the sample time must be positive and finite"
        ))),
        ("z", None) => Err(value_error(
            "domain \"z\" needs the sample time: ts=... (s)",
        )),
        (other, _) => Err(value_error(format!(
            "domain {other:?} is not \"s\" (continuous time) or \"z\" (discrete time)"
        ))),
    }
}

/// A 1-D float or complex array as a vector (any strides), with its length checked
/// against `len`.
fn vector<T: numpy::Element + Copy>(
    a: &PyReadonlyArray1<'_, T>,
    name: &str,
    len: Option<usize>,
) -> PyResult<Vec<T>> {
    let v: Vec<T> = a.as_array().iter().copied().collect();
    match len {
        Some(n) if v.len() != n => Err(value_error(format!(
            "{name} has {} values, f has {n}: one per frequency",
            v.len()
        ))),
        _ => Ok(v),
    }
}

/// Fits a rational model to a frequency response.
///
/// See `fdid.fit` in the package for the parameters.
#[pyfunction]
#[pyo3(signature = (f, frf, *, domain, na, nb, ts=None, var=None, delay=false, criterion="ml", band=None, stable=false))]
#[allow(clippy::too_many_arguments)]
fn fit_frf(
    py: Python<'_>,
    f: PyReadonlyArray1<'_, f64>,
    frf: PyReadonlyArray1<'_, Complex64>,
    domain: &str,
    na: usize,
    nb: usize,
    ts: Option<f64>,
    var: Option<PyReadonlyArray1<'_, f64>>,
    delay: bool,
    criterion: &str,
    band: Option<(f64, f64)>,
    stable: bool,
) -> PyResult<Fit> {
    let f_hz = vector(&f, "f", None)?;
    let g = vector(&frf, "frf", Some(f_hz.len()))?;
    let var = var
        .map(|v| vector(&v, "var", Some(f_hz.len())))
        .transpose()?;
    let spec = ModelSpec {
        domain: self::domain(domain, ts)?,
        na,
        nb,
        delay,
        delay_range: DelayRange::Unbounded,
        transient: false,
        noise_order: None,
        criterion: method(criterion)?,
        stability: if stable {
            Stability::Enforced
        } else {
            Stability::Free
        },
    };
    // the fit runs without the GIL: other Python threads go on meanwhile
    py.allow_threads(|| fit_spec(&spec, f_hz, g, var, band))
}

/// The data of `fit_frf` checked and fitted with `spec`.
fn fit_spec(
    spec: &ModelSpec,
    f_hz: Vec<f64>,
    g: Vec<Complex64>,
    var: Option<Vec<f64>>,
    band: Option<(f64, f64)>,
) -> PyResult<Fit> {
    let omega = angular(&f_hz)?;
    if let Some(k) = g
        .iter()
        .position(|v| !(v.re.is_finite() && v.im.is_finite()))
    {
        return Err(value_error(format!("frf[{k}] = {} is not finite", g[k])));
    }
    if let Some(k) = var
        .iter()
        .flatten()
        .position(|v| !(v.is_finite() && *v > 0.0))
    {
        let v = var.as_ref().map_or(0.0, |v| v[k]);
        return Err(value_error(format!(
            "var[{k}] = {v}: a noise variance must be positive and finite"
        )));
    }
    let ts = match spec.domain {
        Domain::Discrete { ts } => Some(ts),
        Domain::Continuous => None,
    };
    let mut data = FrequencyData::from_frf(omega, g, ts).map_err(value_error)?;
    if let Some(var) = var {
        data = data
            .with_noise(NoiseVariances::output_only(var))
            .map_err(value_error)?;
    }
    if let Some((lo, hi)) = band {
        data = data.band_hz(lo, hi).map_err(value_error)?;
    }
    let started = std::time::Instant::now();
    let fit = spec.fit(&data).map_err(value_error)?;
    let seconds = started.elapsed().as_secs_f64();
    let mut out = Fit::of(&fit, spec.domain)?;
    out.fit_seconds = Some(seconds);
    Ok(out)
}

/// A fitted model: poles, zeros, gain, delay, parameters with their covariance, cost and
/// validation; its response and uncertainty at any frequency.
#[pyclass(module = "fdid", frozen)]
pub struct Fit {
    saved: Saved,
    poles: Vec<Complex64>,
    zeros: Vec<Complex64>,
    gain: f64,
    validation: Option<Validation>,
    fit_seconds: Option<f64>,
}

impl Fit {
    fn of(fit: &RationalFit, domain: Domain<f64>) -> PyResult<Self> {
        let saved = Saved::of_fit(fit, domain);
        let mut out = Self::of_saved(saved)?;
        out.validation = Some(match fit {
            RationalFit::Plain(f) => f.validation().clone(),
            RationalFit::Delayed(f) => f.validation().clone(),
            RationalFit::NoiseModel(f) => f.validation().clone(),
            RationalFit::DelayedNoiseModel(f) => f.validation().clone(),
        });
        Ok(out)
    }

    fn of_saved(saved: Saved) -> PyResult<Self> {
        let (poles, zeros, gain) = saved.factored().map_err(value_error)?;
        Ok(Self {
            saved,
            poles,
            zeros,
            gain,
            validation: None,
            fit_seconds: None,
        })
    }
}

#[pymethods]
impl Fit {
    /// Poles (rad/s for "s", the z-plane for "z").
    #[getter]
    fn poles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<Complex64>> {
        self.poles.clone().into_pyarray(py)
    }

    /// Zeros, as the poles.
    #[getter]
    fn zeros<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<Complex64>> {
        self.zeros.clone().into_pyarray(py)
    }

    /// Gain of the factored form G = gain · Π(x − zeros)/Π(x − poles).
    #[getter]
    fn gain(&self) -> f64 {
        self.gain
    }

    /// The estimated delay τ (s), or None.
    #[getter]
    fn delay(&self) -> Option<f64> {
        self.saved.delay()
    }

    /// "s" or "z".
    #[getter]
    fn domain(&self) -> &'static str {
        match self.saved.domain {
            Domain::Continuous => "s",
            Domain::Discrete { .. } => "z",
        }
    }

    /// The sample time (s) of a "z" model, or None.
    #[getter]
    fn ts(&self) -> Option<f64> {
        match self.saved.domain {
            Domain::Continuous => None,
            Domain::Discrete { ts } => Some(ts),
        }
    }

    /// The parameter estimate θ̂ (in the model's basis).
    #[getter]
    fn theta<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.saved.theta().to_vec().into_pyarray(py)
    }

    /// The covariance of θ̂ (p × p), or None when it could not be computed.
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.saved.covariance().map(|c| {
            let rows: Vec<Vec<f64>> = c.row_iter().map(|r| r.iter().copied().collect()).collect();
            PyArray2::from_vec2(py, &rows).expect("rows of equal length")
        })
    }

    /// The cost V at θ̂.
    #[getter]
    fn cost(&self) -> f64 {
        self.saved.cost()
    }

    /// The noise variance λ: from the data's variances, or estimated as V/N.
    #[getter]
    fn noise_variance(&self) -> f64 {
        self.saved.noise_variance()
    }

    /// Number of frequency lines fitted.
    #[getter]
    fn lines(&self) -> usize {
        self.saved.lines()
    }

    /// True when every pole is stable.
    #[getter]
    fn stable(&self) -> bool {
        self.poles.iter().all(|p| match self.saved.domain {
            Domain::Continuous => p.re < 0.0,
            Domain::Discrete { .. } => p.norm() < 1.0,
        })
    }

    /// The validation of the fit (dict: cost, cost_expected, cost_p, whiteness_lags,
    /// whiteness_q, whiteness_p, max_residual), or None for a loaded model.
    #[getter]
    fn validation<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(v) = &self.validation else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        d.set_item("cost", v.cost)?;
        d.set_item("cost_expected", v.cost_expected)?;
        d.set_item("cost_p", v.cost_p)?;
        d.set_item("whiteness_lags", v.whiteness_lags)?;
        d.set_item("whiteness_q", v.whiteness_q)?;
        d.set_item("whiteness_p", v.whiteness_p)?;
        d.set_item("max_residual", v.max_residual)?;
        Ok(Some(d))
    }

    /// Wall-clock seconds of the estimation itself (the Rust fit, without the checks and
    /// conversions of the call), or None for a loaded model.
    #[getter]
    fn fit_seconds(&self) -> Option<f64> {
        self.fit_seconds
    }

    /// G at the frequencies `f` (Hz).
    fn frf<'py>(
        &self,
        py: Python<'py>,
        f: PyArrayLike1<'_, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray1<Complex64>>> {
        let omega = angular(&vector(&f, "f", None)?)?;
        Ok(self.saved.response(&omega).into_pyarray(py))
    }

    /// σ_G at the frequencies `f` (Hz), the first-order standard deviation of the
    /// complex response from the covariance of θ̂; None without a covariance.
    fn frf_std<'py>(
        &self,
        py: Python<'py>,
        f: PyArrayLike1<'_, f64, AllowTypeChange>,
    ) -> PyResult<Option<Bound<'py, PyArray1<f64>>>> {
        let omega = angular(&vector(&f, "f", None)?)?;
        Ok(self.saved.response_std(&omega).map(|s| s.into_pyarray(py)))
    }

    /// The model as JSON, in the saved-model format of `fdid fit --save` (`fdid eval`
    /// reads it; `fdid.load` reads it back).
    fn to_json(&self) -> PyResult<String> {
        self.saved.to_json().map_err(value_error)
    }

    fn __repr__(&self) -> String {
        format!(
            "Fit(domain={:?}, poles={}, zeros={}, delay={:?}, cost={:.6e})",
            self.domain(),
            self.poles.len(),
            self.zeros.len(),
            self.delay(),
            self.cost()
        )
    }
}

/// ω = 2πf, every f finite.
fn angular(f_hz: &[f64]) -> PyResult<Vec<f64>> {
    if let Some(k) = f_hz.iter().position(|f| !f.is_finite()) {
        return Err(value_error(format!("f[{k}] = {} is not finite", f_hz[k])));
    }
    Ok(f_hz.iter().map(|f| std::f64::consts::TAU * f).collect())
}

/// A model saved with `Fit.to_json` or `fdid fit --save`, from its JSON text.
#[pyfunction]
fn load_json(text: &str) -> PyResult<Fit> {
    Fit::of_saved(Saved::from_json(text).map_err(value_error)?)
}

#[pymodule]
fn _fdid(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fit_frf, m)?)?;
    m.add_function(wrap_pyfunction!(load_json, m)?)?;
    m.add_class::<Fit>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
