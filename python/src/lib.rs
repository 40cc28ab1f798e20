//! `fdid._fdid`: the Python extension of fdid. numpy arrays in and out; fits run with the
//! GIL released; bad input raises `ValueError` with fdid's message.

mod ltv;
mod mimo;
mod record;
mod saved;

use fdid::estimate::{DelayRange, Method, ModelSpec, RationalFit, Stability};
use fdid::model::Domain;
use fdid::validation::Validation;
use fdid::workflow::{Context, Report as WorkflowReport, Workflow};
use fdid::{FrequencyData, NoiseVariances, TimeData};
use num_complex::Complex64;
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLike1, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use saved::Saved;

/// A `ValueError` carrying fdid's message.
pub(crate) fn value_error(e: impl std::fmt::Display) -> PyErr {
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
pub(crate) fn domain(name: &str, ts: Option<f64>) -> PyResult<Domain<f64>> {
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
pub(crate) fn vector<T: numpy::Element + Copy>(
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

/// The model options of every call, in Python's terms.
struct Options<'a> {
    domain: &'a str,
    ts: Option<f64>,
    na: usize,
    nb: usize,
    delay: bool,
    criterion: &'a str,
    stable: bool,
    transient: bool,
    noise_order: Option<usize>,
}

impl Options<'_> {
    /// The model structure and criterion (a delay may lie anywhere, as in `fdid fit`).
    fn spec(&self) -> PyResult<ModelSpec> {
        Ok(ModelSpec {
            domain: domain(self.domain, self.ts)?,
            na: self.na,
            nb: self.nb,
            delay: self.delay,
            delay_range: DelayRange::Unbounded,
            transient: self.transient,
            noise_order: self.noise_order,
            criterion: method(self.criterion)?,
            stability: if self.stable {
                Stability::Enforced
            } else {
                Stability::Free
            },
        })
    }
}

/// The sample time of a discrete-time spec.
fn sample_time(spec: &ModelSpec) -> Option<f64> {
    match spec.domain {
        Domain::Discrete { ts } => Some(ts),
        Domain::Continuous => None,
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
    let spec = Options {
        domain,
        ts,
        na,
        nb,
        delay,
        criterion,
        stable,
        transient: false,
        noise_order: None,
    }
    .spec()?;
    let ts = sample_time(&spec);
    // the fit runs without the GIL: other Python threads go on meanwhile
    py.allow_threads(|| fit_spec(&spec, frf_data(&f_hz, g, var, ts)?, band))
}

/// Fits a rational model to input and output spectra (errors in the output).
///
/// See `fdid.fit_spectra` in the package for the parameters.
#[pyfunction]
#[pyo3(signature = (f, u, y, *, domain, na, nb, ts=None, var=None, delay=false, criterion="ml", band=None, stable=false, transient=false, noise_order=None))]
#[allow(clippy::too_many_arguments)]
fn fit_spectra(
    py: Python<'_>,
    f: PyReadonlyArray1<'_, f64>,
    u: PyReadonlyArray1<'_, Complex64>,
    y: PyReadonlyArray1<'_, Complex64>,
    domain: &str,
    na: usize,
    nb: usize,
    ts: Option<f64>,
    var: Option<PyReadonlyArray1<'_, f64>>,
    delay: bool,
    criterion: &str,
    band: Option<(f64, f64)>,
    stable: bool,
    transient: bool,
    noise_order: Option<usize>,
) -> PyResult<Fit> {
    let f_hz = vector(&f, "f", None)?;
    let u = vector(&u, "u", Some(f_hz.len()))?;
    let y = vector(&y, "y", Some(f_hz.len()))?;
    let var = var
        .map(|v| vector(&v, "var", Some(f_hz.len())))
        .transpose()?;
    let spec = Options {
        domain,
        ts,
        na,
        nb,
        delay,
        criterion,
        stable,
        transient,
        noise_order,
    }
    .spec()?;
    let ts = sample_time(&spec);
    py.allow_threads(|| {
        let data = record::spectra(angular(&f_hz)?, u, y, ts)?;
        fit_spec(&spec, with_variances(data, var)?, band)
    })
}

/// Fits a rational model to a sampled input/output record.
///
/// See `fdid.fit_record` in the package for the parameters.
#[pyfunction]
#[pyo3(signature = (t, u, y, *, domain, na, nb, periods=None, delay=false, criterion="ml", band=None, stable=false, transient=false, noise_order=None))]
#[allow(clippy::too_many_arguments)]
fn fit_record(
    py: Python<'_>,
    t: PyReadonlyArray1<'_, f64>,
    u: PyReadonlyArray1<'_, f64>,
    y: PyReadonlyArray1<'_, f64>,
    domain: &str,
    na: usize,
    nb: usize,
    periods: Option<usize>,
    delay: bool,
    criterion: &str,
    band: Option<(f64, f64)>,
    stable: bool,
    transient: bool,
    noise_order: Option<usize>,
) -> PyResult<Fit> {
    let t = vector(&t, "t", None)?;
    let u = vector(&u, "u", Some(t.len()))?;
    let y = vector(&y, "y", Some(t.len()))?;
    let ts = record::sample_time(&t)?;
    let spec = Options {
        domain,
        ts: (domain == "z").then_some(ts),
        na,
        nb,
        delay,
        criterion,
        stable,
        transient,
        noise_order,
    }
    .spec()?;
    py.allow_threads(|| {
        let record = TimeData::new(u, y, ts).map_err(value_error)?;
        let data = record::record_lines(&record, periods, noise_order.is_some(), false)?;
        fit_spec(&spec, data, band)
    })
}

/// The discrepancy workflow on a frequency response or a time record (see `fdid.diagnose`
/// in the package): the steps taken, the effects named, the verdict and the final fit.
#[pyfunction]
#[pyo3(signature = (*, domain, na, nb, f=None, frf=None, var=None, t=None, u=None, y=None, periods=None, ts=None, alpha=0.01, max_steps=4))]
#[allow(clippy::too_many_arguments)]
fn diagnose<'py>(
    py: Python<'py>,
    domain: &str,
    na: usize,
    nb: usize,
    f: Option<PyReadonlyArray1<'_, f64>>,
    frf: Option<PyReadonlyArray1<'_, Complex64>>,
    var: Option<PyReadonlyArray1<'_, f64>>,
    t: Option<PyReadonlyArray1<'_, f64>>,
    u: Option<PyReadonlyArray1<'_, f64>>,
    y: Option<PyReadonlyArray1<'_, f64>>,
    periods: Option<usize>,
    ts: Option<f64>,
    alpha: f64,
    max_steps: usize,
) -> PyResult<Bound<'py, PyDict>> {
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(value_error(format!("alpha = {alpha}: a level in (0, 1)")));
    }
    enum Input {
        Frf(Vec<f64>, Vec<Complex64>, Option<Vec<f64>>),
        Record(TimeData<f64>),
    }
    let input = match (f, frf, t, u, y) {
        (Some(f), Some(frf), None, None, None) => {
            let f_hz = vector(&f, "f", None)?;
            let g = vector(&frf, "frf", Some(f_hz.len()))?;
            let var = var
                .map(|v| vector(&v, "var", Some(f_hz.len())))
                .transpose()?;
            Input::Frf(f_hz, g, var)
        }
        (None, None, Some(t), Some(u), Some(y)) => {
            let t = vector(&t, "t", None)?;
            let u = vector(&u, "u", Some(t.len()))?;
            let y = vector(&y, "y", Some(t.len()))?;
            let ts = record::sample_time(&t)?;
            Input::Record(TimeData::new(u, y, ts).map_err(value_error)?)
        }
        _ => {
            return Err(value_error(
                "diagnose takes f and frf (a frequency response) or t, u and y (a time                  record)",
            ));
        }
    };
    let record_ts = match &input {
        Input::Record(r) => Some(r.ts()),
        Input::Frf(..) => None,
    };
    let spec = Options {
        domain,
        ts: if domain == "z" { record_ts.or(ts) } else { ts },
        na,
        nb,
        delay: false,
        criterion: "ml",
        stable: false,
        transient: false,
        noise_order: None,
    }
    .spec()?;
    let report = py.allow_threads(|| -> PyResult<_> {
        let (data, ctx) = match input {
            Input::Frf(f_hz, g, var) => (
                frf_data(&f_hz, g, var, sample_time(&spec))?,
                Context::frequency_data(alpha),
            ),
            Input::Record(record) => {
                let data = record::record_lines(&record, periods, false, true)?;
                let ctx = match periods {
                    Some(p) if p >= 2 => {
                        let plain = Context::periodic(alpha);
                        plain.clone().with_record(record, p).unwrap_or(plain)
                    }
                    Some(_) => Context::periodic(alpha),
                    None => Context::non_periodic(alpha).with_time_record(record),
                };
                (data, ctx)
            }
        };
        let workflow = Workflow {
            max_steps,
            ..Workflow::default()
        };
        let report = workflow.run(&data, spec, ctx).map_err(value_error)?;
        let fit = match &report.final_fit.fit {
            Some(fit) => Some(Fit::of(fit, report.final_fit.spec.domain)?),
            None => None,
        };
        Ok((report, fit))
    })?;
    report_dict(py, &report.0, report.1)
}

/// The workflow's report as a dict.
fn report_dict<'py>(
    py: Python<'py>,
    report: &WorkflowReport,
    fit: Option<Fit>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let steps = pyo3::types::PyList::empty(py);
    for s in &report.steps {
        let step = PyDict::new(py);
        step.set_item("effect", s.effect.as_str())?;
        step.set_item("p_value", s.p_value)?;
        step.set_item("lr_p", s.lr_p)?;
        step.set_item("cost_before", s.cost_before)?;
        step.set_item("cost_after", s.cost_after)?;
        steps.append(step)?;
    }
    d.set_item("steps", steps)?;
    let names = |e: &[fdid::workflow::Effect]| -> Vec<&'static str> {
        e.iter().map(|e| e.as_str()).collect()
    };
    d.set_item("effects", names(&report.effects))?;
    d.set_item("unmodelled", names(&report.unmodelled))?;
    d.set_item("consistent", report.consistent_with_noise)?;
    let spec = &report.final_fit.spec;
    let final_spec = PyDict::new(py);
    final_spec.set_item("na", spec.na)?;
    final_spec.set_item("nb", spec.nb)?;
    final_spec.set_item("delay", spec.delay)?;
    final_spec.set_item("transient", spec.transient)?;
    final_spec.set_item("noise_order", spec.noise_order)?;
    d.set_item("final_spec", final_spec)?;
    d.set_item("cost_initial", report.initial_fit.cost)?;
    d.set_item("cost_final", report.final_fit.cost)?;
    d.set_item("fit", fit.map(|f| Py::new(py, f)).transpose()?)?;
    Ok(d)
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
#[pyo3(signature = (datasets, *, domain, na, nb, ts=None, delay=false, criterion="ml", band=None, stable=false, errors="raise"))]
#[allow(clippy::too_many_arguments)]
fn fit_many(
    py: Python<'_>,
    datasets: Vec<Dataset<'_>>,
    domain: &str,
    na: usize,
    nb: usize,
    ts: Option<f64>,
    delay: bool,
    criterion: &str,
    band: Option<(f64, f64)>,
    stable: bool,
    errors: &str,
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
    let spec = Options {
        domain,
        ts,
        na,
        nb,
        delay,
        criterion,
        stable,
        transient: false,
        noise_order: None,
    }
    .spec()?;
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
fn frf_data(
    f_hz: &[f64],
    g: Vec<Complex64>,
    var: Option<Vec<f64>>,
    ts: Option<f64>,
) -> PyResult<FrequencyData<f64>> {
    let omega = angular(f_hz)?;
    finite_complex("frf", &g)?;
    let data = FrequencyData::from_frf(omega, g, ts).map_err(value_error)?;
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

/// Every value of `name` finite.
pub(crate) fn finite_complex(name: &str, v: &[Complex64]) -> PyResult<()> {
    match v
        .iter()
        .position(|v| !(v.re.is_finite() && v.im.is_finite()))
    {
        Some(k) => Err(value_error(format!("{name}[{k}] = {} is not finite", v[k]))),
        None => Ok(()),
    }
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

    /// Pointwise confidence bounds at `level` on |G| and on its phase (rad) at the
    /// frequencies `f` (Hz), from the first-order standard deviations and the normal
    /// quantile: a dict {"magnitude": (lower, upper), "phase": (lower, upper)} of arrays,
    /// or None without a covariance.
    #[pyo3(signature = (f, level=0.95))]
    fn bounds<'py>(
        &self,
        py: Python<'py>,
        f: PyArrayLike1<'_, f64, AllowTypeChange>,
        level: f64,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        if !(level > 0.0 && level < 1.0) {
            return Err(value_error(format!(
                "level = {level}: a probability in (0, 1)"
            )));
        }
        let omega = angular(&vector(&f, "f", None)?)?;
        let Some(b) = self.saved.bounds(&omega, level) else {
            return Ok(None);
        };
        let column =
            |pick: fn(&fdid::fit::Bounds<f64>) -> f64| -> Vec<f64> { b.iter().map(pick).collect() };
        let d = PyDict::new(py);
        d.set_item(
            "magnitude",
            (
                column(|b| b.magnitude.0).into_pyarray(py),
                column(|b| b.magnitude.1).into_pyarray(py),
            ),
        )?;
        d.set_item(
            "phase",
            (
                column(|b| b.phase.0).into_pyarray(py),
                column(|b| b.phase.1).into_pyarray(py),
            ),
        )?;
        Ok(Some(d))
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
pub(crate) fn angular(f_hz: &[f64]) -> PyResult<Vec<f64>> {
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
    m.add_function(wrap_pyfunction!(fit_spectra, m)?)?;
    m.add_function(wrap_pyfunction!(fit_record, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(fit_many, m)?)?;
    m.add_function(wrap_pyfunction!(ltv::ltv, m)?)?;
    m.add_function(wrap_pyfunction!(mimo::fit_common_poles_py, m)?)?;
    m.add_class::<mimo::CommonPoleFit>()?;
    m.add_class::<Fit>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
