//! `fdid._fdid`: the Python extension of fdid. numpy arrays in and out; fits run with the
//! GIL released; bad input raises `ValueError` with fdid's message.

mod diagnose;
mod fit;
mod fits;
mod ltv;
mod mimo;
mod record;
mod saved;

use fdid::estimate::{DelayRange, Method, ModelSpec, Stability};
use fdid::model::Domain;
use fit::Fit;
use numpy::PyReadonlyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use saved::Saved;

/// The allocator of the extension's own (Rust) allocations. The system allocator maps
/// every block above 128 KiB afresh and unmaps it when freed, so each call on 10 000
/// lines paid page faults for its data and the fit's per-line vectors and their
/// unmapping again (about 100 µs, more than the rest of the call's overhead); mimalloc
/// reuses the pages of one call in the next. Python's own objects and numpy's arrays
/// keep their allocators.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

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
    // one copy of the contiguous memory (the package's wrappers pass contiguous arrays)
    let v: Vec<T> = match a.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => a.as_array().iter().copied().collect(),
    };
    match len {
        Some(n) if v.len() != n => Err(value_error(format!(
            "{name} has {} values, f has {n}: one per frequency",
            v.len()
        ))),
        _ => Ok(v),
    }
}

/// The model structure and criterion of every call, passed by the package's wrappers as
/// one dict (`domain`, `ts`, `na`, `nb`, `delay`, `criterion`, `stable`, `transient`,
/// `noise_order`).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub(crate) struct Model {
    domain: String,
    ts: Option<f64>,
    na: usize,
    nb: usize,
    delay: bool,
    criterion: String,
    stable: bool,
    transient: bool,
    noise_order: Option<usize>,
}

impl Model {
    /// The model structure and criterion (a delay may lie anywhere, as in `fdid fit`),
    /// with the sample time `record_ts` of a record for a discrete-time model.
    fn spec(&self, record_ts: Option<f64>) -> PyResult<ModelSpec> {
        let ts = match (self.domain.as_str(), record_ts) {
            ("z", Some(ts)) => Some(ts),
            _ => self.ts,
        };
        Ok(ModelSpec {
            domain: domain(&self.domain, ts)?,
            na: self.na,
            nb: self.nb,
            delay: self.delay,
            delay_range: DelayRange::Unbounded,
            transient: self.transient,
            noise_order: self.noise_order,
            criterion: method(&self.criterion)?,
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

/// ω = 2πf, every f finite.
pub(crate) fn angular(f_hz: &[f64]) -> PyResult<Vec<f64>> {
    // or-ed over every value first (vector lanes), the bad one searched only if any
    if f_hz.iter().fold(false, |bad, f| bad | (f * 0.0 != 0.0))
        && let Some(k) = f_hz.iter().position(|f| !f.is_finite())
    {
        return Err(value_error(format!("f[{k}] = {} is not finite", f_hz[k])));
    }
    Ok(angular_unchecked(f_hz))
}

/// ω = 2πf, not checked: for data whose constructor checks the frequencies
/// (`FrequencyData`, `FrfMatrix`; its errors renamed by [`in_hz`]).
pub(crate) fn angular_unchecked(f_hz: &[f64]) -> Vec<f64> {
    f_hz.iter().map(|f| std::f64::consts::TAU * f).collect()
}

/// fdid's error about data, with the frequencies named as the argument `f` and in Hz
/// (the library checks and reports ω in rad/s).
pub(crate) fn in_hz(e: fdid::FdidError) -> PyErr {
    use fdid::FdidError::{NegativeFrequency, NonFinite, Unsorted};
    let hz = |w: f64| w / std::f64::consts::TAU;
    match e {
        Unsorted {
            index,
            value,
            previous,
        } => value_error(format!(
            "f must increase: f[{index}] = {} Hz follows f[{}] = {} Hz",
            hz(value),
            index - 1,
            hz(previous)
        )),
        NegativeFrequency { index, value } => {
            value_error(format!("f[{index}] = {} Hz is negative", hz(value)))
        }
        NonFinite {
            what: "omega",
            index,
            value,
        } => value_error(format!("f[{index}] is not finite (2π f = {value})")),
        e => value_error(e),
    }
}

/// [`angular_unchecked`] of a numpy array, read in place when it is contiguous.
pub(crate) fn angular_of(f: &PyReadonlyArray1<'_, f64>) -> Vec<f64> {
    match f.as_slice() {
        Ok(f_hz) => angular_unchecked(f_hz),
        Err(_) => angular_unchecked(&f.as_array().to_vec()),
    }
}

/// A model saved with `Fit.to_json` or `fdid fit --save`, from its JSON text.
#[pyfunction]
fn load_json(text: &str) -> PyResult<Fit> {
    Fit::of_saved(Saved::from_json(text).map_err(value_error)?)
}

#[pymodule]
fn _fdid(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fits::fit_frf, m)?)?;
    m.add_function(wrap_pyfunction!(load_json, m)?)?;
    m.add_function(wrap_pyfunction!(fits::fit_spectra, m)?)?;
    m.add_function(wrap_pyfunction!(fits::fit_record, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose::diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(fits::fit_many, m)?)?;
    m.add_function(wrap_pyfunction!(ltv::ltv, m)?)?;
    m.add_function(wrap_pyfunction!(mimo::fit_common_poles_py, m)?)?;
    m.add_class::<mimo::CommonPoleFit>()?;
    m.add_class::<Fit>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
