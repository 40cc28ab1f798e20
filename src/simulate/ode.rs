//! Time-varying linear ODEs `Σ αₙ(t) y⁽ⁿ⁾ = Σ βₙ(t) u⁽ⁿ⁾` integrated by an adaptive
//! Dormand–Prince 5(4) method.

use crate::data::TimeData;
use crate::error::{FdidError, Result};
use crate::scalar::Real;
use crate::simulate::Excitation;
use crate::simulate::multisine::Multisine;
use std::fmt;
use std::sync::Arc;

/// A coefficient function `c(t)` of a time-varying ODE.
#[derive(Clone)]
pub enum Coefficient {
    /// A polynomial `c(t) = Σ_p c_p t^p` (ascending powers, `t` in seconds), the form of
    /// Lataire & Pintelon's eq. 2.
    Polynomial(Vec<f64>),
    /// Any function of time.
    Function(Arc<dyn Fn(f64) -> f64 + Send + Sync>),
}

impl Coefficient {
    /// The constant `c(t) = c`.
    pub fn constant(c: f64) -> Self {
        Self::Polynomial(vec![c])
    }

    /// The polynomial `c(t) = Σ_p c_p t^p` (ascending powers).
    pub fn polynomial(c: Vec<f64>) -> Self {
        Self::Polynomial(c)
    }

    /// The function `c(t) = f(t)`.
    pub fn function(f: impl Fn(f64) -> f64 + Send + Sync + 'static) -> Self {
        Self::Function(Arc::new(f))
    }

    /// `c(t)` (Horner's scheme for a polynomial).
    pub fn eval(&self, t: f64) -> f64 {
        match self {
            Self::Polynomial(c) => c.iter().rev().fold(0.0, |acc, cp| acc * t + cp),
            Self::Function(f) => f(t),
        }
    }
}

impl fmt::Debug for Coefficient {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Polynomial(c) => f.debug_tuple("Polynomial").field(c).finish(),
            Self::Function(_) => f.write_str("Function(..)"),
        }
    }
}

/// Settings of the adaptive Dormand–Prince 5(4) integrator (the method of MATLAB's
/// `ode45`, which Lataire & Pintelon use in their section V).
///
/// | setting      | default | meaning                                                 |
/// |--------------|---------|---------------------------------------------------------|
/// | `rtol`       | 1e-12   | relative tolerance on each state                        |
/// | `atol`       | 1e-15   | absolute tolerance on each state                        |
/// | `max_step`   | `T_s`   | largest step (s); the integrator also stops on each sample instant |
/// | `max_steps`  | 2·10⁷   | accepted + rejected steps before giving up              |
///
/// A step of size `h` is accepted when the embedded error estimate `e` satisfies
/// `√(mean_i (e_i / sc_i)²) ≤ 1` with `sc_i = atol + rtol · max(|x_i|, |x_i⁺|, peak_i)`,
/// `peak_i` the largest `|x_i|` seen so far on the record: for oscillating states the
/// tolerance is relative to the signal level rather than to its value near a zero
/// crossing. The next step is `h · min(5, max(0.2, 0.9 · err^{−1/5}))`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DormandPrince {
    rtol: f64,
    atol: f64,
    max_step: Option<f64>,
    max_steps: usize,
}

impl Default for DormandPrince {
    fn default() -> Self {
        Self::new()
    }
}

impl DormandPrince {
    /// The defaults of the table above.
    pub fn new() -> Self {
        Self {
            rtol: 1e-12,
            atol: 1e-15,
            max_step: None,
            max_steps: 20_000_000,
        }
    }

    /// Relative tolerance `rtol` (`sc_i = atol + rtol · max(|x_i|, |x_i⁺|, peak_i)`).
    #[must_use]
    pub fn with_rtol(mut self, rtol: f64) -> Self {
        self.rtol = rtol;
        self
    }

    /// Absolute tolerance `atol`.
    #[must_use]
    pub fn with_atol(mut self, atol: f64) -> Self {
        self.atol = atol;
        self
    }

    /// Largest step `h_max` (s); the default is the sample time.
    #[must_use]
    pub fn with_max_step(mut self, max_step: f64) -> Self {
        self.max_step = Some(max_step);
        self
    }

    /// Step budget (accepted + rejected) for a whole record.
    #[must_use]
    pub fn with_max_steps(mut self, max_steps: usize) -> Self {
        self.max_steps = max_steps;
        self
    }

    fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, v: f64, reason: &str| {
            Err(FdidError::InvalidArgument {
                name,
                value: format!("{v}"),
                reason: reason.into(),
            })
        };
        if !(self.rtol.is_finite() && self.rtol > 0.0 && self.rtol < 1.0) {
            return bad("rtol", self.rtol, "must lie in (0, 1)");
        }
        if !(self.atol.is_finite() && self.atol >= 0.0) {
            return bad("atol", self.atol, "must be finite and non-negative");
        }
        if let Some(h) = self.max_step
            && !(h.is_finite() && h > 0.0)
        {
            return bad("max_step", h, "must be positive and finite");
        }
        if self.max_steps == 0 {
            return bad("max_steps", 0.0, "must be at least 1");
        }
        Ok(())
    }
}

/// The sampled output of [`TimeVaryingOde::simulate`] with the integrator's work.
#[derive(Debug, Clone, PartialEq)]
pub struct OdeSolution {
    /// `y(k T_s)`, `k = 0, …, N − 1`.
    pub y: Vec<f64>,
    /// The state `[y, y', …, y^{(N_α−1)}]` at the last sample instant.
    pub final_state: Vec<f64>,
    /// Accepted steps.
    pub steps: usize,
    /// Rejected steps.
    pub rejected: usize,
}

/// A time-varying linear ODE (Lataire & Pintelon, eq. 1)
///
/// ```text
/// Σ_{n=0}^{N_α} αₙ(t) dⁿy/dtⁿ = Σ_{n=0}^{N_β} βₙ(t) dⁿu/dtⁿ,   α_{N_α}(t) ≠ 0,
/// ```
///
/// with coefficients given as polynomials in `t` (their eq. 2) or as any functions, and
/// its simulation for an input whose derivatives are known analytically (an
/// [`Excitation`], e.g. a [`Multisine`]).
///
/// # Realisation
/// The right-hand side is a known function of time,
/// `f(t) = Σₙ βₙ(t) u⁽ⁿ⁾(t)`, computed from the input's exact derivatives, so no
/// derivative of `u` is ever taken numerically and time-varying `βₙ(t)` need no product
/// rule. The state is the output and its derivatives, `x = [y, y', …, y^{(N_α−1)}]`
/// (companion form of the left-hand side):
///
/// ```text
/// ẋᵢ = xᵢ₊₁  (i < N_α − 1),   ẋ_{N_α−1} = ( f(t) − Σ_{n<N_α} αₙ(t) xₙ ) / α_{N_α}(t),
/// y = x₀,
/// ```
///
/// i.e. `ẋ = A(t) x + e_last f(t) / α_{N_α}(t)`, started from the physical initial
/// conditions `x(0) = [y(0), y'(0), …]`. For `N_α = 0` the equation is static,
/// `y(t) = f(t) / α₀(t)`, and there is no state. Any `N_β` is allowed (the input is
/// smooth); `N_β ≤ N_α` gives a proper instantaneous system (their eq. 4).
///
/// The state is integrated with [`DormandPrince`] from `t = 0`, stopping exactly on
/// every sample instant `t_k = k T_s`, with as many adaptive sub-steps in between as the
/// tolerance needs. Everything is computed in `f64`; [`TimeVaryingOde::simulate_record`]
/// rounds the samples to `T`.
///
/// ```
/// use fdid::simulate::{Coefficient, DormandPrince, LineSelection, Multisine, TimeVaryingOde};
///
/// // ẏ + (2 + t) y = 2 u, from rest, u a 1 … 20 Hz multisine
/// let ode = TimeVaryingOde::new(
///     vec![Coefficient::polynomial(vec![2.0, 1.0]), Coefficient::constant(1.0)],
///     vec![Coefficient::constant(2.0)],
/// )
/// .unwrap();
/// let fs = 256.0;
/// let u = Multisine::new(1.0, [1.0, 20.0], fs, LineSelection::All, 1).unwrap();
/// let record: fdid::TimeData<f64> = ode
///     .simulate_record(&u, 1.0 / fs, 256, &[0.0], &DormandPrince::new())
///     .unwrap();
/// assert_eq!(record.len(), 256);
/// assert_eq!(record.y()[0], 0.0);
/// // a looser tolerance agrees to about its size
/// let loose = ode
///     .simulate(&u, 1.0 / fs, 256, &[0.0], &DormandPrince::new().with_rtol(1e-8))
///     .unwrap();
/// let diff = loose.y.iter().zip(record.y()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
/// assert!(diff < 1e-7);
/// ```
#[derive(Debug, Clone)]
pub struct TimeVaryingOde {
    alpha: Vec<Coefficient>,
    beta: Vec<Coefficient>,
}

impl TimeVaryingOde {
    /// The ODE with `alpha = [α₀, …, α_{N_α}]` and `beta = [β₀, …, β_{N_β}]`.
    ///
    /// # Errors
    /// - [`FdidError::TooShort`] when `alpha` or `beta` is empty;
    /// - [`FdidError::NonFinite`] naming `"alpha"` or `"beta"` (index = the derivative
    ///   order `n`) when a polynomial coefficient is NaN or infinite.
    ///
    /// That `α_{N_α}(t)` does not vanish is checked during the simulation, where it is
    /// evaluated.
    pub fn new(alpha: Vec<Coefficient>, beta: Vec<Coefficient>) -> Result<Self> {
        for (what, c) in [("alpha", &alpha), ("beta", &beta)] {
            if c.is_empty() {
                return Err(FdidError::TooShort {
                    what,
                    needed: 1,
                    got: 0,
                });
            }
            for (n, cn) in c.iter().enumerate() {
                if let Coefficient::Polynomial(p) = cn
                    && let Some(v) = p.iter().find(|v| !v.is_finite())
                {
                    return Err(FdidError::NonFinite {
                        what,
                        index: n,
                        value: format!("{v}"),
                    });
                }
            }
        }
        Ok(Self { alpha, beta })
    }

    /// The ODE with polynomial coefficients `αₙ(t) = Σ_p alpha[n][p] t^p` and
    /// `βₙ(t) = Σ_p beta[n][p] t^p` (Lataire & Pintelon eq. 2).
    ///
    /// # Errors
    /// As [`TimeVaryingOde::new`].
    pub fn from_polynomials(alpha: Vec<Vec<f64>>, beta: Vec<Vec<f64>>) -> Result<Self> {
        Self::new(
            alpha.into_iter().map(Coefficient::Polynomial).collect(),
            beta.into_iter().map(Coefficient::Polynomial).collect(),
        )
    }

    /// `N_α`, the order of the ODE (and the number of states).
    pub fn order(&self) -> usize {
        self.alpha.len() - 1
    }

    /// `N_β`, the highest input derivative.
    pub fn input_order(&self) -> usize {
        self.beta.len() - 1
    }

    /// The coefficients `αₙ`.
    pub fn alpha(&self) -> &[Coefficient] {
        &self.alpha
    }

    /// The coefficients `βₙ`.
    pub fn beta(&self) -> &[Coefficient] {
        &self.beta
    }

    /// The right-hand side `f(t) = Σₙ βₙ(t) u⁽ⁿ⁾(t)`; `du` is scratch of length `N_β + 1`.
    fn forcing<I: Excitation + ?Sized>(&self, input: &I, t: f64, du: &mut [f64]) -> f64 {
        input.derivatives_into(t, du);
        self.beta
            .iter()
            .zip(du.iter())
            .map(|(b, d)| b.eval(t) * d)
            .sum()
    }

    /// `α_{N_α}(t)`, checked to be finite and non-zero.
    fn leading(&self, t: f64) -> Result<f64> {
        let a = self.alpha[self.order()].eval(t);
        if !(a.is_finite() && a != 0.0) {
            return Err(FdidError::InvalidArgument {
                name: "alpha",
                value: format!("α_{}({t}) = {a}", self.order()),
                reason: "the leading coefficient must be finite and non-zero on the record".into(),
            });
        }
        Ok(a)
    }

    /// For a polynomial `α_{N_α}(t)`: no real root in `[0, t_end]` (roots as eigenvalues
    /// of the companion matrix; a root counts as real when `|Im r| ≤ 1e-9 (1 + |r|)`).
    fn check_leading_polynomial(&self, t_end: f64) -> Result<()> {
        let Coefficient::Polynomial(c) = &self.alpha[self.order()] else {
            return Ok(());
        };
        let deg = match c.iter().rposition(|v| *v != 0.0) {
            None => return self.leading(0.0).map(|_| ()),
            Some(d) => d,
        };
        if deg == 0 {
            return Ok(());
        }
        let mut m = nalgebra::DMatrix::<f64>::zeros(deg, deg);
        for j in 0..deg {
            m[(0, j)] = -c[deg - 1 - j] / c[deg];
        }
        for i in 1..deg {
            m[(i, i - 1)] = 1.0;
        }
        for r in crate::roots::eigenvalues(m)?.iter() {
            if r.im.abs() <= 1e-9 * (1.0 + r.norm()) && r.re >= 0.0 && r.re <= t_end {
                return Err(FdidError::InvalidArgument {
                    name: "alpha",
                    value: format!("α_{}(t) = 0 at t ≈ {}", self.order(), r.re),
                    reason: format!(
                        "the leading coefficient must not vanish on the record [0, {t_end}] s"
                    ),
                });
            }
        }
        Ok(())
    }

    /// `ẋ = A(t) x + e_last f(t) / α_{N_α}(t)` (companion form, see the type's doc).
    fn rhs<I: Excitation + ?Sized>(
        &self,
        input: &I,
        t: f64,
        x: &[f64],
        dx: &mut [f64],
        du: &mut [f64],
    ) -> Result<()> {
        let na = self.order();
        let lead = self.leading(t)?;
        dx[..na - 1].copy_from_slice(&x[1..na]);
        let mut acc = self.forcing(input, t, du);
        for (a, xn) in self.alpha[..na].iter().zip(x) {
            acc -= a.eval(t) * xn;
        }
        dx[na - 1] = acc / lead;
        if !dx[na - 1].is_finite() {
            return Err(FdidError::Numerical {
                what: format!("ODE right-hand side at t = {t}: d^{na}y/dt^{na} = {acc} / {lead}"),
            });
        }
        Ok(())
    }

    /// Simulates the ODE from the initial state `x0 = [y(0), y'(0), …, y^{(N_α−1)}(0)]`
    /// at `t = 0` and returns `y(k T_s)`, `k = 0, …, n − 1` (see the type's doc for the
    /// realisation).
    ///
    /// # Errors
    /// - [`FdidError::InvalidArgument`] named `"ts"` when `T_s` is not positive and
    ///   finite, named after an integrator setting when it is out of range, or named
    ///   `"alpha"` when `α_{N_α}(t)` vanishes on the record: for a polynomial, when it
    ///   has a real root in `[0, (n − 1) T_s]` (checked before integrating); for a
    ///   function, when it is zero or not finite where evaluated (a solution that blows
    ///   up as `α_{N_α}` approaches zero may instead end in `NotConverged`);
    /// - [`FdidError::TooShort`] when `n = 0`;
    /// - [`FdidError::LengthMismatch`] when `x0.len() != N_α`;
    /// - [`FdidError::NonFinite`] naming `"x0"`;
    /// - [`FdidError::Numerical`] when the solution stops being finite (e.g. a
    ///   coefficient function returns NaN);
    /// - [`FdidError::NotConverged`] when the step size underflows or the step budget is
    ///   spent.
    pub fn simulate<I: Excitation + ?Sized>(
        &self,
        input: &I,
        ts: f64,
        n: usize,
        x0: &[f64],
        integrator: &DormandPrince,
    ) -> Result<OdeSolution> {
        integrator.validate()?;
        if !(ts.is_finite() && ts > 0.0) {
            return Err(FdidError::InvalidArgument {
                name: "ts",
                value: format!("{ts}"),
                reason: "must be positive and finite".into(),
            });
        }
        if n == 0 {
            return Err(FdidError::TooShort {
                what: "samples",
                needed: 1,
                got: 0,
            });
        }
        let na = self.order();
        if x0.len() != na {
            return Err(FdidError::LengthMismatch {
                what: "x0",
                expected: na,
                got: x0.len(),
            });
        }
        crate::error::check_finite("x0", x0)?;
        self.check_leading_polynomial((n - 1) as f64 * ts)?;
        let mut du = vec![0.0; self.beta.len()];
        if na == 0 {
            // static: y = f(t) / α₀(t)
            let y = (0..n)
                .map(|k| {
                    let t = k as f64 * ts;
                    let lead = self.leading(t)?;
                    Ok(self.forcing(input, t, &mut du) / lead)
                })
                .collect::<Result<Vec<f64>>>()?;
            return Ok(OdeSolution {
                y,
                final_state: Vec::new(),
                steps: 0,
                rejected: 0,
            });
        }
        let mut run = Run::new(self, input, integrator, ts, x0, &mut du)?;
        let mut y = Vec::with_capacity(n);
        y.push(x0[0]);
        for k in 1..n {
            run.advance_to(k as f64 * ts)?;
            y.push(run.x[0]);
        }
        Ok(OdeSolution {
            y,
            final_state: run.x.clone(),
            steps: run.steps,
            rejected: run.rejected,
        })
    }

    /// Simulates the ODE driven by the multisine `u` ([`TimeVaryingOde::simulate`]) and
    /// returns the sampled record `(u(k T_s), y(k T_s))`, `k = 0, …, n − 1`, as
    /// [`TimeData`] in `T`.
    ///
    /// # Errors
    /// As [`TimeVaryingOde::simulate`]; also [`FdidError::TooShort`] when `n < 2` and the
    /// errors of [`TimeData::new`].
    pub fn simulate_record<T: Real>(
        &self,
        u: &Multisine<T>,
        ts: T,
        n: usize,
        x0: &[f64],
        integrator: &DormandPrince,
    ) -> Result<TimeData<T>> {
        let sol = self.simulate(u, ts.to_f64_lossless(), n, x0, integrator)?;
        let y = sol.y.into_iter().map(T::lit).collect();
        TimeData::new(u.sample(ts, n), y, ts)
    }
}

// Dormand–Prince 5(4) tableau (Hairer, Nørsett & Wanner, Table II.5.2).
const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
/// 5th-order weights minus the embedded 4th-order weights.
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

/// The integrator's state along one record.
struct Run<'a, I: Excitation + ?Sized> {
    ode: &'a TimeVaryingOde,
    input: &'a I,
    opts: &'a DormandPrince,
    du: &'a mut [f64],
    h_max: f64,
    t: f64,
    h: f64,
    x: Vec<f64>,
    peak: Vec<f64>,
    /// stages k₁ … k₇ (k₁ = f(t, x) thanks to FSAL)
    k: [Vec<f64>; 7],
    xs: Vec<f64>,
    steps: usize,
    rejected: usize,
}

impl<'a, I: Excitation + ?Sized> Run<'a, I> {
    fn new(
        ode: &'a TimeVaryingOde,
        input: &'a I,
        opts: &'a DormandPrince,
        ts: f64,
        x0: &[f64],
        du: &'a mut [f64],
    ) -> Result<Self> {
        let na = x0.len();
        let h_max = opts.max_step.unwrap_or(ts);
        let mut run = Self {
            ode,
            input,
            opts,
            du,
            h_max,
            t: 0.0,
            // a small first step; the controller grows it by up to 5× per step
            h: 1e-3 * h_max.min(ts),
            x: x0.to_vec(),
            peak: x0.iter().map(|v| v.abs()).collect(),
            k: std::array::from_fn(|_| vec![0.0; na]),
            xs: vec![0.0; na],
            steps: 0,
            rejected: 0,
        };
        let mut k0 = std::mem::take(&mut run.k[0]);
        run.ode.rhs(run.input, 0.0, &run.x, &mut k0, run.du)?;
        run.k[0] = k0;
        Ok(run)
    }

    /// Integrates from the current time to `t_end`, landing exactly on it.
    fn advance_to(&mut self, t_end: f64) -> Result<()> {
        let na = self.x.len();
        while self.t < t_end {
            if self.steps + self.rejected >= self.opts.max_steps {
                return Err(FdidError::NotConverged {
                    method: "Dormand–Prince",
                    reason: format!(
                        "step budget of {} spent at t = {}",
                        self.opts.max_steps, self.t
                    ),
                });
            }
            let h_prop = self.h.min(self.h_max);
            let mut h = h_prop;
            let last = self.t + h >= t_end - 1e-12 * h;
            if last {
                h = t_end - self.t;
            }
            if !(h > 1e-15 * self.t.abs().max(self.h_max)) {
                return Err(FdidError::NotConverged {
                    method: "Dormand–Prince",
                    reason: format!("step size underflow (h = {h:e}) at t = {}", self.t),
                });
            }
            // stages 2 … 7
            for s in 1..7 {
                for i in 0..na {
                    let mut acc = 0.0;
                    for (j, a) in A[s][..s].iter().enumerate() {
                        acc += a * self.k[j][i];
                    }
                    self.xs[i] = self.x[i] + h * acc;
                }
                let mut ks = std::mem::take(&mut self.k[s]);
                let r = self
                    .ode
                    .rhs(self.input, self.t + C[s] * h, &self.xs, &mut ks, self.du);
                self.k[s] = ks;
                r?;
            }
            // xs holds the 5th-order solution (stage 7 is evaluated at it: FSAL)
            let mut err2 = 0.0;
            for i in 0..na {
                let e: f64 = h * (0..7).map(|j| E[j] * self.k[j][i]).sum::<f64>();
                let sc = self.opts.atol
                    + self.opts.rtol * self.x[i].abs().max(self.xs[i].abs()).max(self.peak[i]);
                err2 += if sc > 0.0 {
                    (e / sc) * (e / sc)
                } else if e == 0.0 {
                    0.0
                } else {
                    f64::INFINITY
                };
            }
            let err = (err2 / na as f64).sqrt();
            if !err.is_finite() && !self.xs.iter().all(|v| v.is_finite()) {
                return Err(FdidError::Numerical {
                    what: format!("ODE solution at t = {}", self.t + h),
                });
            }
            let factor = if err == 0.0 {
                5.0
            } else {
                (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
            };
            if err <= 1.0 {
                self.t = if last { t_end } else { self.t + h };
                self.x.copy_from_slice(&self.xs);
                for (p, v) in self.peak.iter_mut().zip(&self.x) {
                    *p = p.max(v.abs());
                }
                self.k.swap(0, 6);
                self.steps += 1;
                // a step shortened to land on t_end keeps the proposal for the next one
                if h >= h_prop {
                    self.h = h * factor;
                }
            } else {
                self.rejected += 1;
                self.h = h * factor.min(1.0);
            }
        }
        Ok(())
    }
}
