//! Physical parameterisations shipped as examples of the [`GreyBox`] pattern: a
//! mass–spring–damper, a two-mass flexible drive, an RLC circuit and a DC motor.
//!
//! Every physical quantity is positive, so each is estimated through its logarithm
//! (θᵢ = ln vᵢ, [`super::Scale::Log`]); [`crate::estimate::greybox::physical_values`] reports the values and their
//! standard deviations in physical units (std(vᵢ) = vᵢ·std(θᵢ)). An optional gain g > 0
//! ([`MassSpringDamper::with_gain`], …) multiplies G for sensors in other units; it is
//! confounded with the overall scale of the other parameters, so fit it with one of them
//! held at a known value ([`super::Fixed`]).
//!
//! **Identifiability.** A parameter set is identifiable from G only when its map to the
//! transfer-function coefficients is one to one. Where it is not (the DC motor's five
//! parameters give four coefficients; the capacitor voltage of an RLC circuit depends on
//! LC and RC only), the docs say which parameter to fix.
//!
//! **Starting values.** A grey-box fit starts from a physical guess θ₀. A rational fit
//! gives one: for G = 1/(m s² + c s + k) with fitted poles p, p̄ and static gain G(0),
//! k = 1/G(0), m = k/|p|², c = −2 Re(p)·m (see `examples/greybox.rs`).

use super::{DualScalar, GreyBox, Parameter};
use crate::scalar::Complex;

/// The gain parameter g (sensor units per model unit).
fn gain_parameter() -> Parameter {
    Parameter::log("g", "1")
}

/// e^θ of every entry.
#[inline]
fn exps<S: DualScalar, const P: usize>(theta: &[S]) -> [S; P] {
    std::array::from_fn(|i| theta[i].exp())
}

/// The gain factor e^{θ_last} when `gain`, else one.
#[inline]
fn gain_factor<S: DualScalar>(theta: &[S], gain: bool, index: usize) -> S {
    if gain { theta[index].exp() } else { S::one() }
}

/// A mass–spring–damper, force → displacement:
///
/// ```text
/// G(s) = g / (m s² + c s + k),   θ = [ln m, ln c, ln k (, ln g)]
/// ```
///
/// (m in kg, c in N·s/m, k in N/m). All three are identifiable from G; with the gain g,
/// fix one of them.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::greybox::{AutoDiff, physical::MassSpringDamper};
/// use fdid::estimate::greybox::{fit_ml_from, physical_values};
/// let model = AutoDiff::new(MassSpringDamper::new());
/// let truth: Vec<f64> = model.theta_from_physical(&[2.0, 0.3, 50.0]).unwrap();
/// let omega: Vec<f64> = (1..=100).map(|k| 0.1 * k as f64).collect();
/// let data = FrequencyData::from_frf(omega.clone(), model.response(&truth, &omega), None).unwrap();
/// let start = model.theta_from_physical(&[1.5, 0.5, 40.0]).unwrap();
/// let fit = fit_ml_from(&model, &data, &start).unwrap();
/// let m = &physical_values(&fit)[0];
/// assert_eq!((m.name.as_str(), m.unit.as_str()), ("m", "kg"));
/// assert!((m.value - 2.0).abs() < 1e-9);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct MassSpringDamper {
    gain: bool,
}

impl MassSpringDamper {
    /// θ = [ln m, ln c, ln k].
    pub fn new() -> Self {
        Self { gain: false }
    }

    /// Adds the sensor gain g: θ = [ln m, ln c, ln k, ln g].
    #[must_use]
    pub fn with_gain(self) -> Self {
        Self { gain: true }
    }
}

impl GreyBox for MassSpringDamper {
    fn n_params(&self) -> usize {
        3 + usize::from(self.gain)
    }

    /// g / (m s² + c s + k).
    fn response<S: DualScalar>(&self, theta: &[S], s: Complex<S>) -> Complex<S> {
        let [m, c, k] = exps(theta);
        let g = gain_factor(theta, self.gain, 3);
        let den = s * s * m + s * c + Complex::new(k, S::zero());
        den.inv() * g
    }

    /// [k, c, m]: m s² + c s + k.
    fn denominator<S: DualScalar>(&self, theta: &[S]) -> Option<Vec<S>> {
        let [m, c, k] = exps(theta);
        Some(vec![k, c, m])
    }

    fn parameters(&self) -> Vec<Parameter> {
        let mut p = vec![
            Parameter::log("m", "kg"),
            Parameter::log("c", "N·s/m"),
            Parameter::log("k", "N/m"),
        ];
        if self.gain {
            p.push(gain_parameter());
        }
        p
    }
}

/// The measured output of a [`TwoMassDrive`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum DriveOutput {
    /// Motor speed ω₁ (rad/s): anti-resonance √(k/J₂), then resonance.
    #[default]
    MotorSpeed,
    /// Motor acceleration s·ω₁.
    MotorAcceleration,
    /// Load speed ω₂: resonance only.
    LoadSpeed,
    /// Load acceleration s·ω₂.
    LoadAcceleration,
}

/// A two-mass flexible drive, motor torque → motor or load speed or acceleration (the
/// robot-arm type of system): motor inertia J₁ and load inertia J₂ coupled by a shaft of
/// stiffness k and damping c, with optional viscous frictions b₁ (motor) and b₂ (load).
/// With the shaft's impedance on the speed difference and the frictions,
///
/// ```text
/// D(s)   = s (J₁ s + b₁)(J₂ s + b₂) + (c s + k)((J₁ + J₂) s + b₁ + b₂),
/// ω₁/τ   = (J₂ s² + (c + b₂) s + k) / D(s),
/// ω₂/τ   = (c s + k) / D(s),
/// ```
///
/// and the accelerations s·ω/τ; without friction D(s) = s·D₀(s),
/// D₀ = J₁J₂ s² + c(J₁ + J₂) s + k(J₁ + J₂), and the common s is cancelled (so the
/// acceleration outputs stay finite at ω = 0). The motor side has the anti-resonance
/// ω_a = √(k/J₂) below the resonance ω_r = √(k(J₁ + J₂)/(J₁J₂)).
///
/// θ = [ln J₁, ln J₂, ln k, ln c (, ln b₁, ln b₂) (, ln g)] (J in kg·m², k in N·m/rad, c
/// and b in N·m·s/rad).
///
/// **Identifiability.** The motor-side outputs determine every parameter. The load-side
/// outputs determine one fewer: without friction ω₂/τ = (cs + k)/(s·D₀) depends on
/// J₁ + J₂, c/k and J₁J₂/((J₁ + J₂)k) only, so hold one parameter (e.g. J₁ from the motor's
/// data sheet) with [`super::Fixed`]; with friction hold one friction (e.g. b₂). The gain g
/// costs one more fixed parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct TwoMassDrive {
    output: DriveOutput,
    friction: bool,
    gain: bool,
}

impl TwoMassDrive {
    /// Without frictions or gain: θ = [ln J₁, ln J₂, ln k, ln c].
    pub fn new(output: DriveOutput) -> Self {
        Self {
            output,
            friction: false,
            gain: false,
        }
    }

    /// Adds the viscous frictions b₁, b₂ after c in θ.
    #[must_use]
    pub fn with_friction(mut self) -> Self {
        self.friction = true;
        self
    }

    /// Adds the sensor gain g at the end of θ.
    #[must_use]
    pub fn with_gain(mut self) -> Self {
        self.gain = true;
        self
    }

    /// The measured output.
    pub fn output(&self) -> DriveOutput {
        self.output
    }
}

impl GreyBox for TwoMassDrive {
    fn n_params(&self) -> usize {
        4 + 2 * usize::from(self.friction) + usize::from(self.gain)
    }

    /// See the type's docs.
    fn response<S: DualScalar>(&self, theta: &[S], s: Complex<S>) -> Complex<S> {
        let [j1, j2, k, c] = exps(theta);
        let g = gain_factor(theta, self.gain, self.n_params() - 1);
        let re = |v: S| Complex::new(v, S::zero());
        let shaft = s * c + re(k);
        let (num, den, integrates) = if self.friction {
            let (b1, b2) = (theta[4].exp(), theta[5].exp());
            let den =
                s * (s * j1 + re(b1)) * (s * j2 + re(b2)) + shaft * (s * (j1 + j2) + re(b1 + b2));
            let num = match self.output {
                DriveOutput::MotorSpeed | DriveOutput::MotorAcceleration => {
                    s * s * j2 + s * (c + b2) + re(k)
                }
                _ => shaft,
            };
            (num, den, false)
        } else {
            let den = s * s * (j1 * j2) + s * (c * (j1 + j2)) + re(k * (j1 + j2));
            let num = match self.output {
                DriveOutput::MotorSpeed | DriveOutput::MotorAcceleration => {
                    s * s * j2 + s * c + re(k)
                }
                _ => shaft,
            };
            (num, den, true)
        };
        let acceleration = matches!(
            self.output,
            DriveOutput::MotorAcceleration | DriveOutput::LoadAcceleration
        );
        // speed = num/den (friction) or num/(s·den₀); acceleration = s·speed
        let r = num / den * g;
        match (acceleration, integrates) {
            (true, true) => r,
            (true, false) => r * s,
            (false, true) => r / s,
            (false, false) => r,
        }
    }

    /// With friction D(s) (degree 3); without, s·D₀(s) for the speeds and D₀(s) for the
    /// accelerations (the common s cancelled), D₀ = J₁J₂ s² + c(J₁ + J₂) s + k(J₁ + J₂).
    fn denominator<S: DualScalar>(&self, theta: &[S]) -> Option<Vec<S>> {
        let [j1, j2, k, c] = exps(theta);
        if self.friction {
            let (b1, b2) = (theta[4].exp(), theta[5].exp());
            return Some(vec![
                k * (b1 + b2),
                b1 * b2 + c * (b1 + b2) + k * (j1 + j2),
                j1 * b2 + j2 * b1 + c * (j1 + j2),
                j1 * j2,
            ]);
        }
        let d0 = [k * (j1 + j2), c * (j1 + j2), j1 * j2];
        Some(match self.output {
            DriveOutput::MotorSpeed | DriveOutput::LoadSpeed => {
                std::iter::once(S::zero()).chain(d0).collect()
            }
            _ => d0.to_vec(),
        })
    }

    fn parameters(&self) -> Vec<Parameter> {
        let mut p = vec![
            Parameter::log("J1", "kg·m²"),
            Parameter::log("J2", "kg·m²"),
            Parameter::log("k", "N·m/rad"),
            Parameter::log("c", "N·m·s/rad"),
        ];
        if self.friction {
            p.push(Parameter::log("b1", "N·m·s/rad"));
            p.push(Parameter::log("b2", "N·m·s/rad"));
        }
        if self.gain {
            p.push(gain_parameter());
        }
        p
    }
}

/// The measured output of an [`Rlc`] circuit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum RlcOutput {
    /// The loop current (A): an admittance.
    #[default]
    Current,
    /// The capacitor voltage (V).
    CapacitorVoltage,
}

/// A series RLC circuit driven by a voltage:
///
/// ```text
/// I/V   = C s / (L C s² + R C s + 1),
/// V_C/V = 1 / (L C s² + R C s + 1),      θ = [ln R, ln L, ln C (, ln g)]
/// ```
///
/// (R in Ω, L in H, C in F). From the current all three are identifiable; the capacitor
/// voltage depends on LC and RC only, so fix one of them (e.g. C from its marking).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Rlc {
    output: RlcOutput,
    gain: bool,
}

impl Rlc {
    /// θ = [ln R, ln L, ln C].
    pub fn new(output: RlcOutput) -> Self {
        Self {
            output,
            gain: false,
        }
    }

    /// Adds the sensor gain g at the end of θ.
    #[must_use]
    pub fn with_gain(mut self) -> Self {
        self.gain = true;
        self
    }
}

impl GreyBox for Rlc {
    fn n_params(&self) -> usize {
        3 + usize::from(self.gain)
    }

    /// See the type's docs.
    fn response<S: DualScalar>(&self, theta: &[S], s: Complex<S>) -> Complex<S> {
        let [r, l, c] = exps(theta);
        let g = gain_factor(theta, self.gain, 3);
        let den = s * s * (l * c) + s * (r * c) + Complex::new(S::one(), S::zero());
        let num = match self.output {
            RlcOutput::Current => s * (c * g),
            RlcOutput::CapacitorVoltage => Complex::new(g, S::zero()),
        };
        num / den
    }

    /// [1, RC, LC]: L C s² + R C s + 1.
    fn denominator<S: DualScalar>(&self, theta: &[S]) -> Option<Vec<S>> {
        let [r, l, c] = exps(theta);
        Some(vec![S::one(), r * c, l * c])
    }

    fn parameters(&self) -> Vec<Parameter> {
        let mut p = vec![
            Parameter::log("R", "Ω"),
            Parameter::log("L", "H"),
            Parameter::log("C", "F"),
        ];
        if self.gain {
            p.push(gain_parameter());
        }
        p
    }
}

/// A permanent-magnet DC motor, armature voltage → shaft speed, with the electrical
/// (L/R) and mechanical (J/b) time constants and the motor constant K (torque per ampere =
/// back-EMF per rad/s):
///
/// ```text
/// G(s) = g K / ((L s + R)(J s + b) + K²),   θ = [ln K, ln R, ln L, ln J, ln b (, ln g)]
/// ```
///
/// (K in N·m/A, R in Ω, L in H, J in kg·m², b in N·m·s/rad). **Not identifiable as a
/// whole:** G = 1/((LJ/K) s² + ((Lb + RJ)/K) s + (Rb + K²)/K) determines three
/// combinations of the five parameters, so hold two at measured values with
/// [`super::Fixed`] — R and L (an ohmmeter and an LCR meter) leave J = LJ/L, b and K
/// unique; with the gain g hold three.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DcMotor {
    gain: bool,
}

impl DcMotor {
    /// θ = [ln K, ln R, ln L, ln J, ln b].
    pub fn new() -> Self {
        Self { gain: false }
    }

    /// Adds the sensor gain g at the end of θ.
    #[must_use]
    pub fn with_gain(self) -> Self {
        Self { gain: true }
    }
}

impl GreyBox for DcMotor {
    fn n_params(&self) -> usize {
        5 + usize::from(self.gain)
    }

    /// g K / ((L s + R)(J s + b) + K²).
    fn response<S: DualScalar>(&self, theta: &[S], s: Complex<S>) -> Complex<S> {
        let [k, r, l, j, b] = exps(theta);
        let g = gain_factor(theta, self.gain, 5);
        let re = |v: S| Complex::new(v, S::zero());
        let den = (s * l + re(r)) * (s * j + re(b)) + re(k * k);
        den.inv() * (g * k)
    }

    /// [R b + K², L b + R J, L J]: (L s + R)(J s + b) + K².
    fn denominator<S: DualScalar>(&self, theta: &[S]) -> Option<Vec<S>> {
        let [k, r, l, j, b] = exps(theta);
        Some(vec![r * b + k * k, l * b + r * j, l * j])
    }

    fn parameters(&self) -> Vec<Parameter> {
        let mut p = vec![
            Parameter::log("K", "N·m/A"),
            Parameter::log("R", "Ω"),
            Parameter::log("L", "H"),
            Parameter::log("J", "kg·m²"),
            Parameter::log("b", "N·m·s/rad"),
        ];
        if self.gain {
            p.push(gain_parameter());
        }
        p
    }
}
