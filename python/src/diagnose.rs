//! `fdid.diagnose`: the discrepancy workflow of `fdid diagnose` on a frequency response
//! or a sampled record.

use crate::fit::Fit;
use crate::fits::frf_data;
use crate::{Model, record, sample_time, value_error, vector};
use fdid::TimeData;
use fdid::workflow::{Context, Report as WorkflowReport, Workflow};
use num_complex::Complex64;
use numpy::PyReadonlyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The discrepancy workflow on a frequency response or a time record (see `fdid.diagnose`
/// in the package): the steps taken, the effects named, the verdict and the final fit.
#[pyfunction]
#[pyo3(signature = (f, frf, var, t, u, y, periods, alpha, max_steps, model))]
#[allow(clippy::too_many_arguments)]
pub fn diagnose<'py>(
    py: Python<'py>,
    f: Option<PyReadonlyArray1<'_, f64>>,
    frf: Option<PyReadonlyArray1<'_, Complex64>>,
    var: Option<PyReadonlyArray1<'_, f64>>,
    t: Option<PyReadonlyArray1<'_, f64>>,
    u: Option<PyReadonlyArray1<'_, f64>>,
    y: Option<PyReadonlyArray1<'_, f64>>,
    periods: Option<usize>,
    alpha: f64,
    max_steps: usize,
    model: Model,
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
                "diagnose takes f and frf (a frequency response) or t, u and y (a time record)",
            ));
        }
    };
    let record_ts = match &input {
        Input::Record(r) => Some(r.ts()),
        Input::Frf(..) => None,
    };
    let spec = model.spec(record_ts)?;
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
