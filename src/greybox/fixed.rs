//! [`Fixed`]: a model with some parameters held at given values.

use super::{Parameter, PhysicalParameters, Slot, fill_nan};
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::model::ModelStructure;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// A model with some parameters held at known values: θ holds only the free ones.
///
/// ```text
/// G_Fixed(θ_free, ω) = G_M(θ_full, ω),   θ_full,i = θ_free,j(i) (free) or c_i (fixed),
/// ∂G_Fixed/∂θ_free,j = ∂G_M/∂θ_full,i(j)
/// ```
///
/// Use it where the physics leaves a direction unidentifiable (a DC motor's five
/// parameters give three transfer-function combinations: fix the measured winding
/// resistance and inductance) or where a value is known from another experiment. The criteria see only
/// the free parameters; [`crate::estimate::greybox::physical_values`] reports the fixed ones with zero std.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::greybox::{AutoDiff, Fixed, physical::DcMotor};
/// let motor = AutoDiff::new(DcMotor::new());
/// // hold R = 2 Ω and L = 5 mH; θ = [ln K, ln J, ln b]
/// let model = Fixed::physical(motor, &[("R", 2.0), ("L", 5e-3)]).unwrap();
/// assert_eq!(ModelStructure::<f64>::n_params(&model), 3);
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Fixed<M> {
    inner: M,
    /// Per inner parameter: the fixed θ value, or `None` when free.
    fixed: Vec<Option<f64>>,
}

impl<M> Fixed<M> {
    /// `inner` with θ entries `fixed = [(index, θ value), …]` held (θ values: on the log
    /// scale for log parameters).
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] (name `"fixed"`) for an index ≥ p or given twice;
    /// [`FdidError::NonFinite`] for a non-finite value.
    pub fn new<T: Real>(inner: M, fixed: &[(usize, T)]) -> Result<Self>
    where
        M: ModelStructure<T>,
    {
        let p = inner.n_params();
        let mut slots = vec![None; p];
        for (i, (j, v)) in fixed.iter().enumerate() {
            if *j >= p || slots[*j].is_some() {
                return Err(FdidError::InvalidArgument {
                    name: "fixed",
                    value: format!("index {j}"),
                    reason: if *j >= p {
                        format!("the model has {p} parameters")
                    } else {
                        "the parameter is fixed twice".into()
                    },
                });
            }
            if !Float::is_finite(*v) {
                return Err(FdidError::NonFinite {
                    what: "fixed",
                    index: i,
                    value: format!("{v}"),
                });
            }
            slots[*j] = Some(v.to_f64_lossless());
        }
        Ok(Self {
            inner,
            fixed: slots,
        })
    }

    /// `inner` with the named parameters held at physical values (e.g. `[("R", 2.0)]` in
    /// the parameter's unit), converted to θ by their [`Scale`](super::Scale).
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] for an unknown or repeated name, a name of a
    /// parameter that is not free in `inner`, or a value the scale rejects (non-finite,
    /// non-positive on the log scale).
    pub fn physical(inner: M, values: &[(&str, f64)]) -> Result<Self>
    where
        M: PhysicalParameters,
    {
        let params = inner.physical_parameters();
        let p = params
            .iter()
            .filter(|(_, s)| matches!(s, Slot::Free(_)))
            .count();
        let mut slots = vec![None; p];
        for (name, v) in values {
            let Some((param, Slot::Free(j))) = params.iter().find(|(q, _)| q.name == *name) else {
                return Err(FdidError::InvalidArgument {
                    name: "fixed",
                    value: (*name).to_string(),
                    reason: format!(
                        "not a free parameter of the model (free: {})",
                        params
                            .iter()
                            .filter(|(_, s)| matches!(s, Slot::Free(_)))
                            .map(|(q, _)| q.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                });
            };
            if slots[*j].is_some() {
                return Err(FdidError::InvalidArgument {
                    name: "fixed",
                    value: (*name).to_string(),
                    reason: "the parameter is fixed twice".into(),
                });
            }
            slots[*j] = Some(param.theta::<f64>(*v)?);
        }
        Ok(Self {
            inner,
            fixed: slots,
        })
    }

    /// The model with all parameters.
    pub fn inner(&self) -> &M {
        &self.inner
    }

    /// The full θ of the inner model from the free θ (`None` when `free` has the wrong
    /// length).
    pub fn full_theta<T: Real>(&self, free: &[T]) -> Option<Vec<T>> {
        let mut it = free.iter();
        let full: Vec<T> = self
            .fixed
            .iter()
            .map(|f| match f {
                Some(v) => Some(T::lit(*v)),
                None => it.next().copied(),
            })
            .collect::<Option<_>>()?;
        it.next().is_none().then_some(full)
    }

    /// The free entries of a full θ.
    pub fn free_theta<T: Real>(&self, full: &[T]) -> Vec<T> {
        full.iter()
            .zip(&self.fixed)
            .filter(|(_, f)| f.is_none())
            .map(|(v, _)| *v)
            .collect()
    }

    fn free_count(&self) -> usize {
        self.fixed.iter().filter(|f| f.is_none()).count()
    }
}

impl<T: Real, M: ModelStructure<T>> ModelStructure<T> for Fixed<M> {
    fn n_params(&self) -> usize {
        self.free_count()
    }

    fn response_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        match self.full_theta(theta) {
            Some(full) => self.inner.response_into(&full, omega, out),
            None => fill_nan(out, None),
        }
    }

    /// The inner Jacobian's free columns.
    fn jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) {
        let Some(full) = self.full_theta(theta) else {
            return fill_nan(g, Some(jac));
        };
        let mut all = DMatrix::zeros(omega.len(), full.len());
        self.inner.jacobian_into(&full, omega, g, &mut all);
        self.copy_free_columns(&all, jac);
    }

    fn transient_into(
        &self,
        theta: &[T],
        omega: &[T],
        t: &mut [Complex<T>],
        jac: Option<&mut DMatrix<Complex<T>>>,
    ) -> bool {
        let Some(full) = self.full_theta(theta) else {
            return false;
        };
        match jac {
            None => self.inner.transient_into(&full, omega, t, None),
            Some(jac) => {
                let mut all = DMatrix::zeros(omega.len(), full.len());
                let has = self.inner.transient_into(&full, omega, t, Some(&mut all));
                if has {
                    self.copy_free_columns(&all, jac);
                }
                has
            }
        }
    }

    fn check_data(&self, data: &FrequencyData<T>) -> Result<()> {
        self.inner.check_data(data)?;
        crate::model::check_line_count(self.free_count(), data.len())
    }
}

impl<M> Fixed<M> {
    fn copy_free_columns<T: Real>(&self, all: &DMatrix<Complex<T>>, jac: &mut DMatrix<Complex<T>>) {
        let free = self
            .fixed
            .iter()
            .enumerate()
            .filter(|(_, f)| f.is_none())
            .map(|(i, _)| i);
        for (j, i) in free.enumerate() {
            jac.column_mut(j).copy_from(&all.column(i));
        }
    }
}

impl<M: PhysicalParameters> PhysicalParameters for Fixed<M> {
    /// The inner model's parameters with the fixed ones marked [`Slot::Fixed`] and the free
    /// ones renumbered.
    fn physical_parameters(&self) -> Vec<(Parameter, Slot)> {
        // free index of each inner θ entry
        let mut map = vec![None; self.fixed.len()];
        let mut next = 0;
        for (i, f) in self.fixed.iter().enumerate() {
            if f.is_none() {
                map[i] = Some(next);
                next += 1;
            }
        }
        self.inner
            .physical_parameters()
            .into_iter()
            .map(|(p, s)| match s {
                Slot::Free(i) => match (self.fixed.get(i).copied().flatten(), map.get(i)) {
                    (Some(v), _) => (p, Slot::Fixed(v)),
                    (None, Some(Some(j))) => (p, Slot::Free(*j)),
                    _ => (p, Slot::Free(i)),
                },
                fixed => (p, fixed),
            })
            .collect()
    }

    fn check_theta(&self, theta: &[f64]) -> Result<()> {
        match self.full_theta(theta) {
            Some(full) => self.inner.check_theta(&full),
            None => Ok(()),
        }
    }
}
