//! The `Fit` class: a fitted single-entry model with its statistics.

use crate::saved::Saved;
use crate::{angular, value_error, vector};
use fdid::estimate::RationalFit;
use fdid::model::Domain;
use fdid::validation::Validation;
use num_complex::Complex64;
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLike1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A fitted model: poles, zeros, gain, delay, parameters with their covariance, cost and
/// validation; its response and uncertainty at any frequency.
#[pyclass(module = "fdid", frozen)]
pub struct Fit {
    saved: Saved,
    poles: Vec<Complex64>,
    zeros: Vec<Complex64>,
    gain: f64,
    validation: Option<Validation>,
    pub(crate) fit_seconds: Option<f64>,
}

impl Fit {
    pub(crate) fn of(fit: &RationalFit, domain: Domain<f64>) -> PyResult<Self> {
        let saved = Saved::of_fit(fit, domain);
        let mut out = Self::of_saved(saved)?;
        out.validation = Some(fit.validation().clone());
        Ok(out)
    }

    pub(crate) fn of_saved(saved: Saved) -> PyResult<Self> {
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
