//! The results of a fit, as text or as one JSON object.

use super::Failure;
use super::args::CriterionArg;
use super::data::Prepared;
use fdid::basis::PolyBasis;
use fdid::data::Normalisation;
use fdid::estimate::{Method, ModelSpec, RationalFit};
use fdid::fit::Stage;
use fdid::model::Output;
use fdid::prelude::*;
use fdid::solver::Termination;
use fdid::validation::Validation;
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::result::Result;

/// One estimation stage.
struct StageRow {
    name: String,
    iterations: usize,
    termination: &'static str,
    cost: f64,
    /// Lines the stage ran on, when fewer than the data's.
    lines: Option<usize>,
}

impl StageRow {
    fn of(stage: &Stage<f64>) -> Self {
        Self {
            name: stage.kind.name(),
            iterations: stage.solution.iterations,
            termination: match stage.solution.termination {
                Termination::Direct => "direct",
                Termination::Converged => "converged",
                Termination::MaxIterations => "iteration cap reached",
            },
            cost: stage.solution.cost,
            lines: stage.lines,
        }
    }
}

/// How θ parameterises the fitted model.
enum Form {
    /// Polynomials in the basis orthonormal on the data grid (s).
    Orthonormal,
    /// Partial fractions over fixed basis poles (s; the barycentric form).
    PartialFractions(Vec<Complex<f64>>),
    /// Polynomials in z⁻¹.
    DelayPowers,
}

impl Form {
    fn of(basis: &PolyBasis<f64>) -> Self {
        match basis {
            PolyBasis::Orthonormal { .. } => Self::Orthonormal,
            PolyBasis::PartialFractions { poles } => Self::PartialFractions(poles.clone()),
            PolyBasis::DelayPowers { .. } => Self::DelayPowers,
        }
    }

    fn name(&self) -> &'static str {
        match self {
            Self::Orthonormal => "orthonormal_polynomials",
            Self::PartialFractions(_) => "partial_fractions",
            Self::DelayPowers => "delay_powers",
        }
    }
}

/// What the fitted model holds besides its rational part, and how it was estimated.
struct Parts<'a> {
    /// The (inner) rational model: the form and naming of its θ entries, which come first.
    rational: &'a Rational<f64>,
    /// θ holds a delay τ (s) after the rational entries.
    delay: bool,
    /// θ ends with the parameters η = [c₁ … c_nc, d₁ … d_nd] of this noise model.
    noise: Option<NoiseModel<f64>>,
    /// What the estimator ran.
    description: String,
    /// How the lines are weighted, when the criterion decides it (else the data's).
    weighting: Option<String>,
}

impl<'a> Parts<'a> {
    /// The parts of `fit`, a fit of `spec`.
    fn of(spec: &ModelSpec, fit: &'a RationalFit) -> Self {
        let (description, weighting) = estimator(spec);
        Self {
            rational: fit.rational(),
            delay: fit.has_delay(),
            noise: fit.noise_model(),
            description,
            weighting,
        }
    }
}

/// How `spec` is estimated, for the report: what the estimator runs, and the line
/// weighting when the criterion decides it (else the data's weighting applies).
fn estimator(spec: &ModelSpec) -> (String, Option<String>) {
    let eiv = spec.criterion == Method::Eiv;
    let mut description = if spec.delay {
        "delay from the phase slope, the minima of Levy's cost over delays and, unless one \
         reaches the noise level, a search of candidates, each by Levy -> \
         Sanathanan-Koerner on the delay-compensated lines and maximum likelihood of the \
         delayed model, then maximum likelihood of the delayed model (eq. 23) from the best"
            .to_string()
    } else {
        CriterionArg::from(spec.criterion).description().to_string()
    };
    let mut weighting = None;
    if spec.delay && eiv {
        description.push_str(", errors-in-variables maximum likelihood (eq. 42)");
    }
    if eiv {
        weighting = Some(
            "1/sigma_k(theta), sigma_k^2 = var_y + |G|^2 var_u - 2 Re(conj(G) cov_yu) \
             (errors-in-variables, eq. 42)"
                .into(),
        );
    }
    if let Some(n) = spec.noise_order {
        description = format!(
            "start: {description}, with flat weighting; then maximum likelihood with the \
             noise model H = C/D of orders ({n}, {n}) (eq. 26)"
        );
        weighting =
            Some("1/|H_k| from the estimated noise model; lambda estimated (eq. 25)".into());
    }
    (description, weighting)
}

/// A pole the data do not resolve, with why: with s = σ + iω_p (s = p, or ln(p)/Ts), no
/// line lies in its half-power band |ω − ω_p| ≤ |σ|.
#[derive(Debug, Clone, PartialEq)]
pub struct UnresolvedPole {
    /// The pole, in the plane of the poles (s, or z).
    pub pole: Complex<f64>,
    /// s = σ + iω_p (rad/s): the pole itself, or ln(z)/Ts.
    pub s: Complex<f64>,
    /// The nearest line below the band (rad/s), if any.
    pub below: Option<f64>,
    /// The nearest line above the band (rad/s), if any.
    pub above: Option<f64>,
}

impl UnresolvedPole {
    /// The details of `pole` (one [`Fit::unresolved_poles`] flagged) on the lines `omega`
    /// (rad/s, ascending).
    pub fn of(domain: Domain<f64>, omega: &[f64], pole: Complex<f64>) -> Self {
        let s = s_of(domain, pole);
        let (lo, _) = Self::band_of(s);
        let k = omega.partition_point(|x| *x < lo);
        Self {
            pole,
            s,
            below: k.checked_sub(1).and_then(|k| omega.get(k)).copied(),
            above: omega.get(k).copied(),
        }
    }

    /// The half-power band ω_p ∓ |σ| (rad/s) of s.
    fn band_of(s: Complex<f64>) -> (f64, f64) {
        let (sigma, w) = (s.re.abs(), s.im.abs());
        (w - sigma, w + sigma)
    }

    /// The warning line of the text report (without the `warning` label).
    pub fn text(&self, domain: Domain<f64>) -> String {
        let hz = |w: f64| g(w / std::f64::consts::TAU);
        let plane = plane(domain);
        let sign = if self.pole.im == 0.0 { "+" } else { "+/-" };
        let s = match domain {
            Domain::Continuous => String::new(),
            Domain::Discrete { .. } => format!(
                "; s = ln(z)/Ts = {} {sign} {}i rad/s",
                g(self.s.re),
                g(self.s.im.abs())
            ),
        };
        let nearest: Vec<String> = [self.below, self.above]
            .into_iter()
            .flatten()
            .map(hz)
            .collect();
        let (lo, hi) = Self::band_of(self.s);
        format!(
            "unresolved pole {} {sign} {}i ({plane}{s}): no line in its half-power band \
             {} .. {} Hz (|w - w_p| <= |sigma| = {} rad/s; nearest lines {} Hz), so the data \
             do not determine its damping; it may be spurious (a resonance placed between two \
             lines)",
            g(self.pole.re),
            g(self.pole.im.abs()),
            hz(lo),
            hz(hi),
            g(self.s.re.abs()),
            nearest.join(" and ")
        )
    }

    /// The JSON object: `{"pole":[re,im],"s":[σ,ω_p],"band_hz":[lo,hi],
    /// "nearest_lines_hz":[below|null,above|null]}`.
    pub fn json(&self) -> Value {
        let hz = |w: f64| num(w / std::f64::consts::TAU);
        let opt = |w: Option<f64>| w.map_or(Value::Null, hz);
        let (lo, hi) = Self::band_of(self.s);
        json!({
            "pole": [num(self.pole.re), num(self.pole.im)],
            "s": [num(self.s.re), num(self.s.im.abs())],
            "band_hz": [hz(lo), hz(hi)],
            "nearest_lines_hz": [opt(self.below), opt(self.above)],
        })
    }
}

/// The poles that [`fdid::validation::unresolved_poles`] (the rule of
/// [`Fit::unresolved_poles`]) flags for a model in `domain` whose poles are `poles`
/// (those of its rational part) fitted on the lines `omega` (rad/s, ascending), for any
/// fit.
pub fn unresolved_poles(
    domain: Domain<f64>,
    omega: &[f64],
    poles: &[Complex<f64>],
) -> Vec<Complex<f64>> {
    fdid::validation::unresolved_poles(poles, domain, omega)
}

/// The warning line (without its label) of a pole `p` on the stability boundary
/// ([`fdid::validation::marginal_poles`]).
fn marginal_text(domain: Domain<f64>, p: Complex<f64>) -> String {
    let s = s_of(domain, p);
    let sign = if p.im == 0.0 { "" } else { " +/- " };
    let im = if p.im == 0.0 {
        String::new()
    } else {
        format!("{}i", g(p.im.abs()))
    };
    let plane = plane(domain);
    let zeta = if s.norm() > 0.0 {
        -s.re / s.norm()
    } else {
        0.0
    };
    format!(
        "pole {}{sign}{im} ({plane}) on the stability boundary: -Re s = {} rad/s (damping {}), \
         below 1e-6 of |s| or 1e-4 of the lowest fitted frequency, so the data do not tell it \
         from a pole just across the boundary (an undamped resonance, or an integrator over \
         the band; a stability-constrained fit stops poles there)",
        g(p.re),
        g(-s.re),
        g(zeta)
    )
}

/// s of a pole: itself (s), or ln(z)/Ts (z).
fn s_of(domain: Domain<f64>, p: Complex<f64>) -> Complex<f64> {
    match domain {
        Domain::Continuous => p,
        Domain::Discrete { ts } => p.ln() / ts,
    }
}

/// The plane of the poles and zeros: `rad/s` (s) or `z-plane` (z).
fn plane(domain: Domain<f64>) -> &'static str {
    match domain {
        Domain::Continuous => "rad/s",
        Domain::Discrete { .. } => "z-plane",
    }
}

/// The fitted noise model H = C/D.
struct NoiseRow {
    c: Vec<f64>,
    d: Vec<f64>,
    zeros: Vec<Complex<f64>>,
    poles: Vec<Complex<f64>>,
}

impl NoiseRow {
    /// The noise model `h` at its parameters `eta`.
    fn of(h: &NoiseModel<f64>, eta: &[f64]) -> Result<Self, Failure> {
        let (c, d) = h.polynomials(eta);
        Ok(Self {
            c,
            d,
            zeros: h.zeros(eta)?,
            poles: h.poles(eta)?,
        })
    }
}

/// What a report is made of besides the fit: the spec fitted, the file and how it was
/// prepared, and the lines the fit was made on.
#[derive(Clone, Copy)]
struct Source<'a> {
    spec: &'a ModelSpec,
    file: &'a str,
    prepared: &'a Prepared,
    data: &'a FrequencyData<f64>,
}

/// `roots` sorted by natural frequency (those without one first), then imaginary part.
fn sorted_roots(domain: Domain<f64>, mut roots: Vec<Complex<f64>>) -> Vec<Complex<f64>> {
    let key = |z: &Complex<f64>| {
        let (wn, _) = natural(domain, *z);
        (if wn.is_finite() { wn } else { -1.0 }, z.im)
    };
    roots.sort_by(|a, b| {
        key(a)
            .partial_cmp(&key(b))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    roots
}

/// Everything printed about a fit.
pub struct Report {
    form: Form,
    domain: Domain<f64>,
    record_ts: Option<f64>,
    na: usize,
    nb: usize,
    criterion: &'static str,
    criterion_description: String,
    file: String,
    source: String,
    /// Time records: how many of the fitted lines the input excites.
    lines_excited: Option<usize>,
    weighting: String,
    notes: Vec<String>,
    f_hz: Vec<f64>,
    frf: Vec<Complex<f64>>,
    frf_std: Option<Vec<f64>>,
    cost: f64,
    noise_variance: f64,
    noise_known: bool,
    errors_in_variables: bool,
    relative_residual: f64,
    poles: Vec<Complex<f64>>,
    zeros: Vec<Complex<f64>>,
    gain: f64,
    stable: bool,
    theta: Vec<f64>,
    theta_std: Option<Vec<f64>>,
    covariance: Option<Vec<Vec<f64>>>,
    validation: Validation,
    /// Number of θ entries of the rational part without its transient coefficients.
    n_rational: usize,
    /// Number of transient coefficients.
    n_transient: usize,
    /// τ (s) and its standard deviation.
    delay: Option<(f64, Option<f64>)>,
    noise_model: Option<NoiseRow>,
    /// The poles the data do not resolve.
    unresolved: Vec<UnresolvedPole>,
    /// The stable poles on the stability boundary ([`fdid::validation::marginal_poles`]),
    /// one per conjugate pair.
    marginal: Vec<Complex<f64>>,
    stages: Vec<StageRow>,
}

impl Report {
    /// Adds a note, printed after the fit's own.
    pub fn add_note(&mut self, note: String) {
        self.notes.push(note);
    }

    /// The fitted response on the data's lines and its standard deviation, if known.
    pub fn response(&self) -> (&[Complex<f64>], Option<&[f64]>) {
        (&self.frf, self.frf_std.as_deref())
    }

    /// The report of `fit`, the fit of `spec` on `data` (prepared as `prepared` says; the
    /// lines of `data` give the relative residual).
    pub fn of(
        spec: &ModelSpec,
        file: &str,
        prepared: &Prepared,
        data: &FrequencyData<f64>,
        fit: &RationalFit,
    ) -> Result<Self, Failure> {
        let parts = Parts::of(spec, fit);
        let source = Source {
            spec,
            file,
            prepared,
            data,
        };
        match fit {
            RationalFit::Plain(f) => Self::new(&source, f, parts),
            RationalFit::Delayed(f) => Self::new(&source, f, parts),
            RationalFit::NoiseModel(f) => Self::new(&source, f, parts),
            RationalFit::DelayedNoiseModel(f) => Self::new(&source, f, parts),
        }
    }

    /// Collects the results of `fit`, a model whose θ is laid out as `parts` says:
    /// [rational (with its transient coefficients last), τ, c₁ … c_nc, d₁ … d_nd].
    fn new<M: ModelStructure<f64> + PolesZeros<f64>>(
        source: &Source<'_>,
        fit: &Fit<f64, M>,
        parts: Parts<'_>,
    ) -> Result<Self, Failure> {
        let Source {
            spec,
            file,
            prepared,
            data,
        } = *source;
        let domain = spec.domain;
        let poles = sorted_roots(domain, fit.poles()?);
        let zeros = sorted_roots(domain, fit.zeros()?);
        let stable = match domain {
            Domain::Continuous => poles.iter().all(|p| p.re < 0.0),
            Domain::Discrete { .. } => poles.iter().all(|p| p.norm() < 1.0),
        };
        let theta = fit.theta().to_vec();
        let theta_std = fit.theta_std();
        let n_transient = parts.rational.n_transient();
        let n_rp = parts.rational.n_params();
        let delay = parts
            .delay
            .then(|| {
                theta
                    .get(n_rp)
                    .map(|t| (*t, theta_std.as_ref().map(|s| s[n_rp])))
            })
            .flatten();
        let noise_model = match parts.noise {
            None => None,
            Some(h) => Some(NoiseRow::of(&h, &theta[theta.len() - h.n_params()..])?),
        };
        let unresolved = unresolved_poles(domain, fit.omega(), &fit.poles()?)
            .into_iter()
            .map(|p| UnresolvedPole::of(domain, fit.omega(), p))
            .collect();
        // unstable poles have their own warning
        let marginal = fdid::validation::marginal_poles(&poles, domain, fit.omega())
            .into_iter()
            .filter(|p| p.im >= 0.0 && s_of(domain, *p).re < 0.0)
            .collect();
        let covariance = fit.covariance().map(|c| {
            c.row_iter()
                .map(|r| r.iter().copied().collect())
                .collect::<Vec<Vec<f64>>>()
        });
        Ok(Self {
            form: Form::of(parts.rational.basis()),
            domain,
            record_ts: prepared.record_ts,
            na: spec.na,
            nb: spec.nb,
            criterion: spec.criterion.name(),
            criterion_description: parts.description,
            file: file.to_string(),
            source: prepared.source.clone(),
            lines_excited: prepared.lines_excited,
            weighting: parts
                .weighting
                .unwrap_or_else(|| prepared.weighting.clone()),
            notes: prepared.notes.clone(),
            f_hz: fit
                .omega()
                .iter()
                .map(|w| w / std::f64::consts::TAU)
                .collect(),
            frf: fit.response().to_vec(),
            frf_std: fit.response_std().map(<[f64]>::to_vec),
            cost: fit.cost(),
            noise_variance: fit.noise_variance(),
            noise_known: fit.noise_known(),
            errors_in_variables: spec.criterion == Method::Eiv,
            relative_residual: relative_residual(fit.model(), fit.theta(), data),
            poles,
            zeros,
            gain: fit.gain(),
            stable,
            theta,
            theta_std,
            covariance,
            validation: fit.validation().clone(),
            n_rational: n_rp - n_transient,
            n_transient,
            delay,
            noise_model,
            unresolved,
            marginal,
            stages: fit.stages().iter().map(StageRow::of).collect(),
        })
    }

    /// The model's sample time (z only).
    fn ts(&self) -> Option<f64> {
        match self.domain {
            Domain::Continuous => None,
            Domain::Discrete { ts } => Some(ts),
        }
    }

    fn domain_name(&self) -> &'static str {
        match self.domain {
            Domain::Continuous => "s",
            Domain::Discrete { .. } => "z",
        }
    }

    /// Names of the parameters θ, and what they are: the rational part, then t1 … tn
    /// (transient), tau (delay), nc1 …, nd1 … (noise model H = C/D: the names of the
    /// rational part's coefficients are taken).
    fn theta_names(&self) -> (Vec<String>, &'static str) {
        let (mut names, caption) = self.rational_names();
        names.extend((1..=self.n_transient).map(|k| format!("t{k}")));
        if self.delay.is_some() {
            names.push("tau".into());
        }
        if let Some(h) = &self.noise_model {
            names.extend((1..h.c.len()).map(|k| format!("nc{k}")));
            names.extend((1..h.d.len()).map(|k| format!("nd{k}")));
        }
        if names.len() == self.theta.len() {
            (names, caption)
        } else {
            (
                (1..=self.theta.len()).map(|k| format!("p{k}")).collect(),
                caption,
            )
        }
    }

    /// Names of the entries of θ of the rational part (without the transient).
    fn rational_names(&self) -> (Vec<String>, &'static str) {
        let (na, nb) = (self.na, self.nb);
        let (a, b, caption): (Vec<String>, Vec<String>, _) = match self.form {
            Form::Orthonormal => (
                (0..na).map(|k| format!("a{k}")).collect(),
                (0..=nb).map(|k| format!("b{k}")).collect(),
                "polynomials in the basis phi_n orthonormal on the data grid: \
                 A = phi_na + sum a_n phi_n, B = sum b_n phi_n",
            ),
            Form::PartialFractions(_) if nb + 1 < na => (
                (1..=na).map(|k| format!("d{k}")).collect(),
                (0..=nb).map(|k| format!("w{k}")).collect(),
                "partial fractions phi_n over the basis poles: G = N/D, \
                 D = 1 + sum d_n phi_n, N = sum c_n phi_n with c = Z w, Z an orthonormal \
                 basis of the numerators of relative degree na - nb",
            ),
            Form::PartialFractions(_) => (
                (1..=na).map(|k| format!("d{k}")).collect(),
                (na.saturating_sub(nb)..=na)
                    .map(|k| format!("c{k}"))
                    .collect(),
                "partial fractions phi_n over the basis poles: G = N/D, \
                 D = 1 + sum d_n phi_n, N = sum c_n phi_n",
            ),
            Form::DelayPowers => (
                (1..=na).map(|k| format!("a{k}")).collect(),
                (0..=nb).map(|k| format!("b{k}")).collect(),
                "A = 1 + a1 z^-1 + ..., B = b0 + b1 z^-1 + ...",
            ),
        };
        let names: Vec<String> = a.into_iter().chain(b).collect();
        if names.len() == self.n_rational {
            (names, caption)
        } else {
            (
                (1..=self.n_rational).map(|k| format!("p{k}")).collect(),
                caption,
            )
        }
    }

    /// Cost against its expected value and whiteness of the residuals, on one line.
    fn validation_line(&self) -> String {
        let v = &self.validation;
        let cost = match (v.cost_expected, v.cost_p) {
            (Some(e), Some(p)) => format!("V = {} vs expected {} (p = {})", g(v.cost), g(e), g(p)),
            (Some(e), None) => format!("V = {} vs expected {}", g(v.cost), g(e)),
            _ => "cost test n/a (noise level estimated from the residuals)".to_string(),
        };
        let white = match v.whiteness_p {
            Some(p) => format!(
                "whiteness p = {} ({} lags, Ljung-Box)",
                g(p),
                v.whiteness_lags
            ),
            None => "whiteness test n/a (fewer than 8 lines)".to_string(),
        };
        format!("{cost}; {white}")
    }

    /// The delay line (nothing without a delay).
    fn delay_text(&self, w: &mut String) {
        if let Some((tau, std)) = self.delay {
            let pm = |s: Option<f64>| s.map_or_else(String::new, |s| format!(" +/- {}", g(s)));
            let samples = self.record_ts.map_or_else(String::new, |ts| {
                format!(
                    " = {}{} samples of Ts = {} s",
                    g(tau / ts),
                    pm(std.map(|s| s / ts)),
                    g(ts)
                )
            });
            let _ = writeln!(
                w,
                "delay        tau = {}{} s{samples}  (G = G_0 exp(-i w tau))",
                g(tau),
                pm(std)
            );
        }
    }

    /// The tables of poles and zeros, each after an empty line.
    fn roots_text(&self, w: &mut String) {
        let plane = plane(self.domain);
        for (title, roots) in [("poles", &self.poles), ("zeros", &self.zeros)] {
            let _ = writeln!(w);
            if roots.is_empty() {
                let _ = writeln!(w, "{title} ({plane}): none");
                continue;
            }
            let _ = writeln!(
                w,
                "{title} ({plane}){}",
                match self.domain {
                    Domain::Continuous => "",
                    Domain::Discrete { .. } => "; f_n and damping of s = ln(z)/Ts",
                }
            );
            let _ = writeln!(
                w,
                "  {:>14} {:>14}  {:>12} {:>10}",
                "re", "im", "f_n (Hz)", "damping"
            );
            for z in roots.iter() {
                let (wn, zeta) = natural(self.domain, *z);
                let _ = writeln!(
                    w,
                    "  {:>14} {:>14}  {:>12} {:>10}",
                    g(z.re),
                    g(z.im),
                    if wn.is_finite() {
                        g(wn / std::f64::consts::TAU)
                    } else {
                        "-".into()
                    },
                    if zeta.is_finite() {
                        format!("{zeta:.4}")
                    } else {
                        "-".into()
                    }
                );
            }
        }
    }

    /// Orders, delay, transient and the table of poles and zeros: the model part of the
    /// text report.
    pub fn model_text(&self) -> String {
        let mut o = String::new();
        let w = &mut o;
        let _ = writeln!(
            w,
            "orders       na = {}, nb = {} ({} parameters)",
            self.na,
            self.nb,
            self.theta.len()
        );
        self.delay_text(w);
        if self.n_transient > 0 {
            let _ = writeln!(
                w,
                "transient    Y = G U + T, {} coefficients",
                self.n_transient
            );
        }
        if let Some(h) = &self.noise_model {
            let _ = writeln!(
                w,
                "noise model  H = C/D, orders ({}, {})",
                h.c.len() - 1,
                h.d.len() - 1
            );
        }
        let _ = writeln!(w, "stable       {}", if self.stable { "yes" } else { "no" });
        self.unresolved_text(w);
        self.roots_text(w);
        o
    }

    /// One `warning` line for each pole the data do not resolve and for each pole on the
    /// stability boundary.
    fn unresolved_text(&self, w: &mut String) {
        for p in &self.unresolved {
            let _ = writeln!(w, "warning      {}", p.text(self.domain));
        }
        for p in &self.marginal {
            let _ = writeln!(w, "warning      {}", marginal_text(self.domain, *p));
        }
    }

    /// The poles the data do not resolve.
    pub fn unresolved(&self) -> &[UnresolvedPole] {
        &self.unresolved
    }

    /// The stable poles on the stability boundary, one per conjugate pair.
    pub fn marginal(&self) -> &[Complex<f64>] {
        &self.marginal
    }

    /// The JSON object (one line).
    pub fn json(&self) -> String {
        let mut s = self.json_value().to_string();
        s.push('\n');
        s
    }

    /// The JSON object as a value.
    pub fn json_value(&self) -> Value {
        let pairs = |v: &[Complex<f64>]| -> Value {
            Value::Array(v.iter().map(|z| json!([num(z.re), num(z.im)])).collect())
        };
        let frf: Vec<Value> = self
            .f_hz
            .iter()
            .zip(&self.frf)
            .map(|(f, g)| json!([num(*f), num(g.re), num(g.im)]))
            .collect();
        let nums = |v: &[f64]| Value::Array(v.iter().map(|x| num(*x)).collect());
        let stages: Vec<Value> = self
            .stages
            .iter()
            .map(|s| {
                json!({
                    "name": s.name,
                    "iterations": s.iterations,
                    "termination": s.termination,
                    "cost": num(s.cost),
                    "lines": s.lines,
                })
            })
            .collect();
        let v = &self.validation;
        let opt = |x: Option<f64>| x.map_or(Value::Null, num);
        let (delay, delay_std) = match self.delay {
            Some((t, s)) => (num(t), opt(s)),
            None => (Value::Null, Value::Null),
        };
        let delay_samples = match (self.delay, self.record_ts) {
            (Some((t, _)), Some(ts)) => num(t / ts),
            _ => Value::Null,
        };
        let noise_model = self.noise_model.as_ref().map_or(Value::Null, |h| {
            json!({
                "c": nums(&h.c),
                "d": nums(&h.d),
                "zeros": pairs(&h.zeros),
                "poles": pairs(&h.poles),
            })
        });
        let covariance = self.covariance.as_ref().map_or(Value::Null, |c| {
            Value::Array(c.iter().map(|row| nums(row)).collect())
        });
        json!({
            "domain": self.domain_name(),
            "poles": pairs(&self.poles),
            "zeros": pairs(&self.zeros),
            "pole_details": root_details(self.domain, &self.poles),
            "zero_details": root_details(self.domain, &self.zeros),
            "cost": num(self.cost),
            "noise_variance": num(self.noise_variance),
            "frf": frf,
            "na": self.na,
            "nb": self.nb,
            "ts": self.ts().map_or(Value::Null, num),
            "criterion": self.criterion,
            "lines": self.f_hz.len(),
            "lines_excited": self.lines_excited,
            "gain": num(self.gain),
            "stable": self.stable,
            "theta": nums(&self.theta),
            "theta_std": self.theta_std.as_deref().map_or(Value::Null, nums),
            "frf_std": self.frf_std.as_deref().map_or(Value::Null, nums),
            "noise_known": self.noise_known,
            "relative_residual": num(self.relative_residual),
            "weighting": self.weighting,
            "notes": self.notes,
            "form": self.form.name(),
            "basis_poles": match &self.form {
                Form::PartialFractions(q) => pairs(q),
                _ => Value::Null,
            },
            "stages": stages,
            "theta_names": self.theta_names().0,
            "covariance": covariance,
            "delay": delay,
            "delay_std": delay_std,
            "delay_samples": delay_samples,
            "transient": self.n_transient,
            "noise_order": self.noise_model.as_ref().map_or(Value::Null, |h| json!(h.d.len() - 1)),
            "noise_model": noise_model,
            "cost_expected": opt(v.cost_expected),
            "cost_p": opt(v.cost_p),
            "whiteness_p": opt(v.whiteness_p),
            "whiteness_lags": v.whiteness_lags,
            "unresolved_poles": Value::Array(self.unresolved.iter().map(UnresolvedPole::json).collect()),
            "marginal_poles": pairs(&self.marginal),
        })
    }

    /// The human-readable report.
    pub fn text(&self) -> String {
        let mut o = String::new();
        let w = &mut o;
        self.setup_text(w);
        self.statistics_text(w);
        self.roots_text(w);
        self.noise_model_text(w);
        self.stages_text(w);
        self.parameters_text(w);
        o
    }

    /// Data, domain, orders, criterion, lines and weighting.
    fn setup_text(&self, w: &mut String) {
        let (fmin, fmax) = (
            self.f_hz.first().copied().unwrap_or(f64::NAN),
            self.f_hz.last().copied().unwrap_or(f64::NAN),
        );
        let _ = writeln!(w, "data         {}: {}", self.file, self.source);
        match self.domain {
            Domain::Discrete { ts } => {
                let _ = writeln!(w, "domain       z (discrete time, Ts = {} s)", g(ts));
            }
            _ => {
                let _ = writeln!(w, "domain       s (continuous time)");
            }
        }
        let _ = writeln!(
            w,
            "orders       na = {}, nb = {} ({} parameters)",
            self.na,
            self.nb,
            self.theta.len()
        );
        let _ = writeln!(
            w,
            "criterion    {} ({})",
            self.criterion, self.criterion_description
        );
        let _ = writeln!(
            w,
            "lines        {} used{}, {} .. {} Hz",
            self.f_hz.len(),
            self.lines_excited
                .map_or(String::new(), |e| format!(" ({e} excited)")),
            g(fmin),
            g(fmax)
        );
        let _ = writeln!(w, "weighting    {}", self.weighting);
    }

    /// Cost, noise variance, validation, delay, transient, relative residual, gain,
    /// stability, the unresolved poles and the notes.
    fn statistics_text(&self, w: &mut String) {
        let resid = if self.n_transient > 0 {
            "Y - G U - T"
        } else {
            "Y - G U"
        };
        let scale = if self.noise_model.is_some() {
            " / |H_k|^2"
        } else if self.errors_in_variables {
            " / sigma_k(theta)^2"
        } else if self.noise_known {
            " / sigma_k^2"
        } else {
            ""
        };
        let _ = writeln!(
            w,
            "cost         V = {} (sum of |{resid}|^2{scale})",
            g(self.cost)
        );
        let _ = writeln!(w, "noise var.   lambda = V/N = {}", g(self.noise_variance));
        let _ = writeln!(w, "validation   {}", self.validation_line());
        self.delay_text(w);
        if self.n_transient > 0 {
            let _ = writeln!(
                w,
                "transient    Y = G U + T, {} coefficients t1..t{} (leakage of a non-periodic record)",
                self.n_transient, self.n_transient
            );
        }
        let _ = writeln!(
            w,
            "rel. resid.  {} (sqrt(sum |{resid}|^2 / sum |Y|^2), unweighted)",
            g(self.relative_residual)
        );
        let _ = writeln!(
            w,
            "gain         {}{}",
            g(self.gain),
            match self.domain {
                Domain::Continuous => "  (G = gain * prod(s - zero) / prod(s - pole))",
                Domain::Discrete { .. } =>
                    "  (first nonzero b coefficient: G = gain * z^k * prod(z - zero) / prod(z - pole))",
            }
        );
        let _ = writeln!(w, "stable       {}", if self.stable { "yes" } else { "no" });
        if !self.stable {
            let _ = writeln!(
                w,
                "warning      the model is unstable (a pole in the right half plane or outside the unit circle); --stable fits a stable one"
            );
        }
        self.unresolved_text(w);
        for n in &self.notes {
            let _ = writeln!(w, "note         {n}");
        }
    }

    /// The noise model H = C/D with its zeros and poles, after an empty line (nothing
    /// without one).
    fn noise_model_text(&self, w: &mut String) {
        let Some(h) = &self.noise_model else {
            return;
        };
        let _ = writeln!(w);
        let poly = |p: &[f64]| {
            let mut t = String::from("1");
            for (k, v) in p.iter().enumerate().skip(1) {
                let sign = if *v < 0.0 { '-' } else { '+' };
                let _ = write!(t, " {sign} {} z^-{k}", g(v.abs()));
            }
            t
        };
        let _ = writeln!(
            w,
            "noise model  H = C/D, orders ({}, {}); lambda = {} is the innovation variance",
            h.c.len() - 1,
            h.d.len() - 1,
            g(self.noise_variance)
        );
        let _ = writeln!(w, "  C = {}", poly(&h.c));
        let _ = writeln!(w, "  D = {}", poly(&h.d));
        for (title, roots) in [("zeros", &h.zeros), ("poles", &h.poles)] {
            let list: Vec<String> = roots
                .iter()
                .map(|z| {
                    format!(
                        "{} {} {}i",
                        g(z.re),
                        if z.im < 0.0 { "-" } else { "+" },
                        g(z.im.abs())
                    )
                })
                .collect();
            let _ = writeln!(
                w,
                "  {title} of H (z-plane): {}",
                if list.is_empty() {
                    "none".into()
                } else {
                    list.join(", ")
                }
            );
        }
    }

    /// The table of estimation stages, after an empty line.
    fn stages_text(&self, w: &mut String) {
        let _ = writeln!(w);
        let _ = writeln!(w, "stages");
        let width = self.stages.iter().map(|s| s.name.len()).max().unwrap_or(0);
        for s in &self.stages {
            let on = s
                .lines
                .map_or_else(String::new, |l| format!(" (on {l} lines)"));
            let _ = writeln!(
                w,
                "  {:<width$} {:>5} iterations  {:<22} cost {}{on}",
                s.name,
                s.iterations,
                s.termination,
                g(s.cost)
            );
        }
    }

    /// The table of θ with standard deviations (and the basis poles of a partial-fraction
    /// form), after an empty line.
    fn parameters_text(&self, w: &mut String) {
        let _ = writeln!(w);
        let (names, caption) = self.theta_names();
        let _ = writeln!(w, "parameters theta ({caption})");
        if let Form::PartialFractions(q) = &self.form {
            let list: Vec<String> = q
                .iter()
                .map(|q| {
                    if q.im == 0.0 {
                        g(q.re)
                    } else {
                        format!("{} +/- {}i", g(q.re), g(q.im))
                    }
                })
                .collect();
            let _ = writeln!(w, "  basis poles (rad/s): {}", list.join(", "));
        }
        let _ = writeln!(w, "  {:<6} {:>14} {:>14}", "", "value", "std");
        for (i, name) in names.iter().enumerate() {
            let std = self
                .theta_std
                .as_ref()
                .map_or_else(|| "-".to_string(), |s| g(s[i]));
            let _ = writeln!(w, "  {:<6} {:>14} {:>14}", name, g(self.theta[i]), std);
        }
        if self.theta_std.is_none() {
            let _ = writeln!(
                w,
                "  (no standard deviations: the Jacobian is singular or there are no degrees of freedom)"
            );
        }
    }
}

/// sqrt(Σ|Y − Ŷ|² / Σ|Y|²) over the lines fitted, Ŷ = G U + T.
fn relative_residual<M: ModelStructure<f64>>(
    model: &M,
    theta: &[f64],
    data: &FrequencyData<f64>,
) -> f64 {
    let mut out = Output::new(data.len(), model.n_params());
    if !out.evaluate(model, theta, data, false) {
        return f64::NAN;
    }
    // both sums of the output scaled by the same power of two (exact), so that neither
    // underflows nor overflows for data near the limits of f64
    let c = Normalisation::of(data).output();
    let (mut r, mut y) = (0.0, 0.0);
    for (yh, yk) in out.yhat.iter().zip(data.y()) {
        r += ((*yk - *yh) * c).norm_sqr();
        y += (*yk * c).norm_sqr();
    }
    (r / y).sqrt()
}

/// Each root as `{"re","im","f_n_hz","damping"}`: its natural frequency in Hz and damping
/// ratio ([`natural`]; null where undefined).
fn root_details(domain: Domain<f64>, roots: &[Complex<f64>]) -> Value {
    Value::Array(
        roots
            .iter()
            .map(|z| {
                let (wn, zeta) = natural(domain, *z);
                json!({
                    "re": num(z.re),
                    "im": num(z.im),
                    "f_n_hz": num(wn / std::f64::consts::TAU),
                    "damping": num(zeta),
                })
            })
            .collect(),
    )
}

/// Natural frequency (rad/s) and damping ratio of a root: of s itself, or of s = ln(z)/Ts.
fn natural(domain: Domain<f64>, z: Complex<f64>) -> (f64, f64) {
    let s = match domain {
        Domain::Continuous => z,
        Domain::Discrete { ts } if z.norm() > 0.0 => z.ln() / ts,
        _ => return (f64::NAN, f64::NAN),
    };
    let wn = s.norm();
    if wn > 0.0 {
        (wn, -s.re / wn)
    } else {
        (0.0, f64::NAN)
    }
}

/// A JSON number, or null when not finite.
pub fn num(x: f64) -> Value {
    serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number)
}

/// About seven significant digits, fixed-point when reasonable.
pub fn g(x: f64) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    if x == 0.0 {
        return "0".into();
    }
    let a = x.abs();
    if (1e-3..1e6).contains(&a) {
        let digits = (6 - a.log10().floor() as i32).max(0) as usize;
        format!("{x:.digits$}")
    } else {
        format!("{x:.6e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn number_format() {
        assert_eq!(g(0.0), "0");
        assert_eq!(g(1.5), "1.500000");
        assert_eq!(g(-123.25), "-123.2500");
        assert_eq!(g(1e-7), "1.000000e-7");
        assert_eq!(g(f64::NAN), "NaN");
    }

    #[test]
    fn json_never_holds_non_finite_numbers() {
        assert_eq!(num(f64::NAN), Value::Null);
        assert_eq!(num(f64::INFINITY), Value::Null);
        assert_eq!(num(2.0), json!(2.0));
    }

    /// The lines 0.1 .. 100 rad/s without those within 2·10⁻³ of 1 rad/s.
    fn gap_grid() -> Vec<f64> {
        (0..600)
            .map(|k| 10f64.powf(-1.0 + 3.0 * k as f64 / 599.0))
            .filter(|w| (w - 1.0).abs() > 2e-3)
            .collect()
    }

    #[test]
    fn unresolved_poles_as_the_library_defines_them() {
        let omega = gap_grid();
        let poles = [
            Complex::new(-1e-4, 1.0),
            Complex::new(-1.0, 19.97),
            Complex::new(-0.5, 0.0),
        ];
        let frf: Vec<Complex<f64>> = omega
            .iter()
            .map(|w| {
                let s = Complex::new(0.0, *w);
                poles
                    .iter()
                    .map(|p| {
                        if p.im == 0.0 {
                            Complex::new(1.0, 0.0) / (s - p)
                        } else {
                            Complex::new(1.0, 0.0) / ((s - p) * (s - p.conj()))
                        }
                    })
                    .sum()
            })
            .collect();
        let data = FrequencyData::from_frf(omega.clone(), frf, None).unwrap();
        let model = Rational::continuous(5, 4, data.omega()).unwrap();
        let fit = Pipeline::default().fit(&model, &data).unwrap();
        let lib = fit.unresolved_poles().unwrap();
        assert_eq!(lib.len(), 1, "{lib:?}");
        let fitted = fit.poles().unwrap();
        assert_eq!(
            unresolved_poles(Domain::Continuous, fit.omega(), &fitted),
            lib
        );
        let u = UnresolvedPole::of(Domain::Continuous, fit.omega(), lib[0]);
        assert!(u.below.unwrap() < 1.0 - 2e-3 && u.above.unwrap() > 1.0 + 2e-3);
        assert!(
            u.text(Domain::Continuous)
                .starts_with("unresolved pole -1.000000e-4 +/- ")
        );
    }

    #[test]
    fn unresolved_pole_in_z() {
        let omega = gap_grid();
        let ts = 0.01;
        let flagged = (Complex::new(-1e-4, 1.0) * ts).exp();
        let resolved = (Complex::new(-1.0, 19.97) * ts).exp();
        let poles = [flagged, flagged.conj(), resolved, resolved.conj()];
        assert_eq!(
            unresolved_poles(Domain::Discrete { ts }, &omega, &poles),
            vec![flagged]
        );
        let text = UnresolvedPole::of(Domain::Discrete { ts }, &omega, flagged)
            .text(Domain::Discrete { ts });
        assert!(
            text.contains("(z-plane; s = ln(z)/Ts = -1.000000e-4 +/- 1.000000i rad/s)"),
            "{text}"
        );
        // without lines nothing is flagged
        assert!(unresolved_poles(Domain::Discrete { ts }, &[], &poles).is_empty());
    }

    #[test]
    fn natural_frequency_and_damping() {
        let (wn, zeta) = natural(Domain::Continuous, Complex::new(-0.2, 0.96f64.sqrt()));
        assert!((wn - 1.0).abs() < 1e-12 && (zeta - 0.2).abs() < 1e-12);
        let z = (Complex::new(-0.2, 0.96f64.sqrt()) * 0.1).exp();
        let (wn, zeta) = natural(Domain::Discrete { ts: 0.1 }, z);
        assert!((wn - 1.0).abs() < 1e-12 && (zeta - 0.2).abs() < 1e-12);
    }
}
