//! `fdid.fit_common_poles`: one set of poles shared by every entry of an FRF matrix (the
//! partial-fraction form with a residue matrix per pole), fitted by relaxed vector fitting
//! with the fast block solution and refined by maximum likelihood, as `fdid fit` fits
//! every entry of a multi-port file.

use crate::{angular, angular_of, domain, value_error, vector};
use fdid::data::FrfMatrix;
use fdid::mimo::{CommonPoleFit as Fitted, CommonPoleOptions, MlOutcome, fit_common_poles};
use nalgebra::DMatrix;
use num_complex::Complex64;
use numpy::{
    AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayLike1, PyArrayMethods,
    PyReadonlyArray1, PyReadonlyArray3,
};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// Fits poles shared by every entry of `frf` (lines × outputs × inputs).
///
/// See `fdid.fit_common_poles` in the package for the parameters.
#[pyfunction]
#[pyo3(signature = (f, frf, *, domain, order, ts=None, var=None, direct=true, stable=false, ml=true, band=None))]
#[allow(clippy::too_many_arguments)]
pub fn fit_common_poles_py(
    py: Python<'_>,
    f: PyReadonlyArray1<'_, f64>,
    frf: PyReadonlyArray3<'_, Complex64>,
    domain: &str,
    order: usize,
    ts: Option<f64>,
    var: Option<PyReadonlyArray3<'_, f64>>,
    direct: bool,
    stable: bool,
    ml: bool,
    band: Option<(f64, f64)>,
) -> PyResult<CommonPoleFit> {
    let omega = angular_of(&f);
    let shape = frf.as_array().shape().to_vec();
    let (n, ny, nu) = (shape[0], shape[1], shape[2]);
    if n != omega.len() {
        return Err(value_error(format!(
            "frf has {n} lines (its first axis), f has {}: one per frequency",
            omega.len()
        )));
    }
    let frf = frf.as_array();
    // entries column by column (output i, input j), as FrfMatrix holds them
    let entries: Vec<Vec<Complex64>> = (0..nu)
        .flat_map(|j| (0..ny).map(move |i| (i, j)))
        .map(|(i, j)| (0..n).map(|k| frf[[k, i, j]]).collect())
        .collect();
    for (e, g) in entries.iter().enumerate() {
        if let Some(k) = g
            .iter()
            .position(|v| !(v.re.is_finite() && v.im.is_finite()))
        {
            return Err(value_error(format!(
                "frf[{k}, {}, {}] = {} is not finite",
                e % ny,
                e / ny,
                g[k]
            )));
        }
    }
    let variances = match var {
        Some(v) => {
            if v.as_array().shape() != [n, ny, nu] {
                return Err(value_error(format!(
                    "var has shape {:?}, frf has ({n}, {ny}, {nu}): one variance per value",
                    v.as_array().shape()
                )));
            }
            let v = v.as_array();
            Some(
                (0..nu)
                    .flat_map(|j| (0..ny).map(move |i| (i, j)))
                    .map(|(i, j)| (0..n).map(|k| v[[k, i, j]]).collect::<Vec<f64>>())
                    .collect::<Vec<_>>(),
            )
        }
        None => None,
    };
    let options = CommonPoleOptions {
        domain: domain_of(domain, ts)?,
        direct,
        stable,
        ml,
        ..CommonPoleOptions::default()
    };
    let ts = match options.domain {
        fdid::model::Domain::Discrete { ts } => Some(ts),
        fdid::model::Domain::Continuous => None,
    };
    py.allow_threads(|| {
        let mut data = FrfMatrix::from_entries(omega, ny, nu, entries, ts).map_err(crate::in_hz)?;
        if let Some(v) = variances {
            data = data.with_variances(v).map_err(value_error)?;
        }
        if let Some((lo, hi)) = band {
            data = data.band_hz(lo, hi).map_err(value_error)?;
        }
        let fit = fit_common_poles(&data, order, &options).map_err(value_error)?;
        let rms = fit.rms(&data);
        Ok(CommonPoleFit { fit, rms })
    })
}

fn domain_of(name: &str, ts: Option<f64>) -> PyResult<fdid::model::Domain<f64>> {
    domain(name, ts)
}

/// A common-pole model of an FRF matrix: its poles, residue matrices, direct term, modes
/// and state-space realisation; its response at any frequency.
#[pyclass(module = "fdid", frozen)]
pub struct CommonPoleFit {
    fit: Fitted<f64>,
    rms: f64,
}

fn matrix<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    let rows: Vec<Vec<f64>> = m.row_iter().map(|r| r.iter().copied().collect()).collect();
    if rows.is_empty() || rows[0].is_empty() {
        return PyArray2::zeros(py, [m.nrows(), m.ncols()], false);
    }
    PyArray2::from_vec2(py, &rows).expect("rows of equal length")
}

/// A list of ny × nu complex matrices as an array (count × ny × nu).
fn stack<'py>(
    py: Python<'py>,
    ms: &[DMatrix<Complex64>],
    ny: usize,
    nu: usize,
) -> Bound<'py, PyArray3<Complex64>> {
    let flat: Vec<Complex64> = ms
        .iter()
        .flat_map(|m| (0..ny).flat_map(move |i| (0..nu).map(move |j| m[(i, j)])))
        .collect();
    flat.into_pyarray(py)
        .reshape([ms.len(), ny, nu])
        .expect("count × ny × nu values")
}

#[pymethods]
impl CommonPoleFit {
    /// Every pole (rad/s for "s", the z-plane for "z"): the real ones, then each pair.
    #[getter]
    fn poles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<Complex64>> {
        self.fit.model.poles.all().into_pyarray(py)
    }

    /// One residue matrix per pole slot (the real poles, then one member Im p > 0 of each
    /// pair, whose conjugate has the conjugate residue): slots × ny × nu.
    #[getter]
    fn residues<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<Complex64>> {
        let m = &self.fit.model;
        stack(py, &m.residues, m.ny(), m.nu())
    }

    /// The slot poles the residues belong to.
    #[getter]
    fn pole_slots<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<Complex64>> {
        self.fit.model.poles.slots().into_pyarray(py)
    }

    /// The direct term D (ny × nu), or None.
    #[getter]
    fn direct<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.fit.model.direct.as_ref().map(|d| matrix(py, d))
    }

    /// The modes: a list of dicts with the pole (s), natural frequency (Hz), damping, the
    /// output shape and input participation of the residue's rank-one approximation, and
    /// its error σ₂/σ₁.
    #[getter]
    fn modes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let out = PyList::empty(py);
        for m in self.fit.model.modes().map_err(value_error)? {
            let d = PyDict::new(py);
            d.set_item("pole", m.pole)?;
            d.set_item("f_n_hz", m.f_n_hz)?;
            d.set_item("damping", m.damping)?;
            d.set_item("shape", m.shape.into_pyarray(py))?;
            d.set_item("participation", m.participation.into_pyarray(py))?;
            d.set_item("rank_one_error", m.rank_one_error)?;
            out.append(d)?;
        }
        Ok(out)
    }

    /// A real state-space realisation: a dict with the matrices a, b, c, d.
    #[getter]
    fn state_space<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let ss = self.fit.model.state_space();
        let d = PyDict::new(py);
        d.set_item("a", matrix(py, &ss.a))?;
        d.set_item("b", matrix(py, &ss.b))?;
        d.set_item("c", matrix(py, &ss.c))?;
        d.set_item("d", matrix(py, &ss.d))?;
        Ok(d)
    }

    /// RMS error of the model against the data over every entry and line.
    #[getter]
    fn rms(&self) -> f64 {
        self.rms
    }

    /// The cost of the fit (weighted when the data carry variances).
    #[getter]
    fn cost(&self) -> f64 {
        self.fit.cost
    }

    /// Relocation iterations run.
    #[getter]
    fn relocations(&self) -> usize {
        self.fit.relocations
    }

    /// What the maximum-likelihood refinement did: "kept", "kept_unconverged" (its
    /// budget stopped it), "failed" (it raised the cost or failed: the relocated model is
    /// kept), "unstable" (it left the stable region under `stable`) or "skipped".
    #[getter]
    fn ml(&self) -> &'static str {
        match self.fit.ml {
            MlOutcome::Kept { converged: true } => "kept",
            MlOutcome::Kept { converged: false } => "kept_unconverged",
            MlOutcome::Failed => "failed",
            MlOutcome::Unstable => "unstable",
            MlOutcome::Skipped => "skipped",
        }
    }

    /// True when every pole is stable.
    #[getter]
    fn stable(&self) -> bool {
        let model = &self.fit.model;
        model.poles.is_stable(model.domain)
    }

    /// G at the frequencies `f` (Hz): lines × ny × nu.
    fn frf<'py>(
        &self,
        py: Python<'py>,
        f: PyArrayLike1<'_, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray3<Complex64>>> {
        let omega = angular(&vector(&f, "f", None)?)?;
        let m = &self.fit.model;
        Ok(stack(py, &m.response(&omega), m.ny(), m.nu()))
    }

    fn __repr__(&self) -> String {
        let m = &self.fit.model;
        format!(
            "CommonPoleFit(order={}, outputs={}, inputs={}, rms={:.6e})",
            m.order(),
            m.ny(),
            m.nu(),
            self.rms
        )
    }
}
