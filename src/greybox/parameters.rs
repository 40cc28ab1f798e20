//! What a grey-box model says about its parameters: names, units, scales (θ = value or
//! θ = ln value), which are fixed, and the checks of a θ.

use crate::error::{FdidError, Result};
use crate::model::Delayed;
use crate::scalar::Real;
use num_traits::Float;

/// How a parameter θᵢ maps to its physical value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Scale {
    /// value = θ.
    Linear,
    /// value = e^θ (a positive quantity); std(value) = value·std(θ) (delta method).
    Log,
}

/// Name, unit and scale of a parameter.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Parameter {
    /// Name (e.g. `"m"`).
    pub name: String,
    /// Unit of the physical value (e.g. `"kg"`).
    pub unit: String,
    /// How θ maps to the value.
    pub scale: Scale,
}

impl Parameter {
    /// A positive quantity estimated as θ = ln(value).
    pub fn log(name: &str, unit: &str) -> Self {
        Self {
            name: name.into(),
            unit: unit.into(),
            scale: Scale::Log,
        }
    }

    /// A quantity estimated as θ = value.
    pub fn linear(name: &str, unit: &str) -> Self {
        Self {
            name: name.into(),
            unit: unit.into(),
            scale: Scale::Linear,
        }
    }

    /// The physical value of θᵢ: e^θ or θ.
    pub fn value<T: Real>(&self, theta: T) -> T {
        match self.scale {
            Scale::Linear => theta,
            Scale::Log => Float::exp(theta),
        }
    }

    /// θᵢ of a physical value: ln(value) or value.
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] naming the parameter when the value is not finite,
    /// or not positive on the log scale.
    pub fn theta<T: Real>(&self, value: f64) -> Result<T> {
        let bad = |reason: &str| FdidError::InvalidArgument {
            name: "physical value",
            value: format!("{} = {value} {}", self.name, self.unit),
            reason: reason.into(),
        };
        if !value.is_finite() {
            return Err(bad("not finite"));
        }
        match self.scale {
            Scale::Linear => Ok(T::lit(value)),
            Scale::Log if value > 0.0 => Ok(T::lit(value.ln())),
            Scale::Log => Err(bad("a physical quantity on the log scale must be positive")),
        }
    }
}

/// Where the value of one parameter of a model comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Slot {
    /// The estimated θ entry with this index.
    Free(usize),
    /// Held at this θ value (see [`Fixed`](super::Fixed)).
    Fixed(f64),
}

/// Models that describe their parameters physically: every parameter of the underlying
/// physical model, in order, with where its value comes from. Implemented by [`AutoDiff`](super::AutoDiff),
/// and by [`crate::Delayed`] (the delay τ, in s, on a linear scale) and [`Fixed`](super::Fixed) over such
/// models.
pub trait PhysicalParameters {
    /// One entry per physical parameter (free or fixed).
    fn physical_parameters(&self) -> Vec<(Parameter, Slot)>;

    /// Model-specific checks of a full-length, finite θ (default: none).
    ///
    /// # Errors
    /// As [`GreyBox::check_params`](super::GreyBox::check_params).
    fn check_theta(&self, theta: &[f64]) -> Result<()> {
        let _ = theta;
        Ok(())
    }

    /// θ from the physical values of the free parameters, in the order of θ (e.g.
    /// `[m, c, k]` in kg, N·s/m, N/m): θᵢ = ln(value) on the log scale.
    ///
    /// # Errors
    /// [`FdidError::LengthMismatch`] (what `"physical values"`) when the count differs from
    /// the number of free parameters; [`FdidError::InvalidArgument`] naming the parameter
    /// for a non-finite value or a non-positive one on the log scale.
    fn theta_from_physical<T: Real>(&self, values: &[f64]) -> Result<Vec<T>>
    where
        Self: Sized,
    {
        let mut free: Vec<(usize, Parameter)> = self
            .physical_parameters()
            .into_iter()
            .filter_map(|(p, s)| match s {
                Slot::Free(i) => Some((i, p)),
                Slot::Fixed(_) => None,
            })
            .collect();
        free.sort_by_key(|(i, _)| *i);
        if values.len() != free.len() {
            return Err(FdidError::LengthMismatch {
                what: "physical values",
                expected: free.len(),
                got: values.len(),
            });
        }
        free.iter()
            .zip(values)
            .map(|((_, p), v)| p.theta(*v))
            .collect()
    }
}

impl<M: PhysicalParameters> PhysicalParameters for Delayed<M> {
    /// The inner model's parameters, then the delay `tau` (s, linear scale).
    fn physical_parameters(&self) -> Vec<(Parameter, Slot)> {
        let mut params = self.inner().physical_parameters();
        let free = params
            .iter()
            .filter(|(_, s)| matches!(s, Slot::Free(_)))
            .count();
        params.push((Parameter::linear("tau", "s"), Slot::Free(free)));
        params
    }

    fn check_theta(&self, theta: &[f64]) -> Result<()> {
        let Some((tau, inner)) = theta.split_last() else {
            return Ok(());
        };
        self.check_delay(*tau)?;
        self.inner().check_theta(inner)
    }
}
