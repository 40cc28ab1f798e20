//! `fdid diagnose`: the discrepancy workflow ([`fdid::workflow`]) on a data file, reported
//! as text, as one JSON object, and as a report directory (text, JSON and SVG figures).
//!
//! The data are read and prepared as for `fdid fit`; the noise reference that normalises
//! the residuals r_k = (Y_k − Ŷ_k)/σ_k of McKelvey's ML cost (eq. 23) comes from the
//! periods, the file, the local polynomial method or — with nothing known — from the
//! residuals themselves. Nothing is refitted here: the initial and final models are the
//! fits the workflow made ([`fdid::workflow::Report::initial_fit`] and
//! [`fdid::workflow::Report::final_fit`], each on the data it was fitted on), rendered by
//! the same report as `fdid fit` ([`super::Report::of`]), so `initial` and `final` in the
//! JSON carry exactly the keys of `fdid fit --json`; the detectors' findings on the final
//! fit are the workflow's ([`fdid::workflow::Report::remaining`]).

use super::args::DiagnoseArgs;
use super::data::{self, Prepared};
use super::report::{g, num};
use super::{Failure, Report, check_combinations, check_data_kind, check_orders};
use fdid::data::{DistortionAnalysis, Lpm};
use fdid::estimate::{Method, ModelSpec, Stability};
use fdid::prelude::*;
use fdid::workflow::Report as WorkflowReport;
use fdid::workflow::{
    Attempt, Context, Effect, Elimination, Finding, Outcome, SpecFit, Step, Workflow,
    disagreement_bands, segment_disagreement,
};
use serde_json::{Map, Value, json};
use std::fmt::Write as _;
use std::path::Path;
use std::result::Result;

/// Where the noise level σ_k² that normalises the residuals comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum NoiseReference {
    /// Sample variances over P ≥ 2 periods of a periodic record.
    Periods(usize),
    /// Variances given in the data file.
    Given,
    /// The local polynomial method on one non-periodic record, with `dof` complex degrees
    /// of freedom per line.
    Lpm {
        /// Residual degrees of freedom q of each line's variance.
        dof: usize,
    },
    /// The unexcited lines of a multisine or sweep next to each excited line
    /// ([`FrequencyData::unexcited_noise`]), `lines` of them per variance.
    Unexcited {
        /// Unexcited lines averaged per variance (its complex degrees of freedom).
        lines: usize,
    },
    /// The best linear approximation over `realisations` realisations of `periods`
    /// periods: with `periods ≥ 2` the noise variance between periods (the
    /// nonlinear-distortion detector compares it with the total variance between
    /// realisations); with one period the total variance, noise and distortion together.
    Realisations {
        /// Number of realisations R.
        realisations: usize,
        /// Number of periods P averaged per realisation.
        periods: usize,
    },
    /// Nothing known: λ is estimated from the residuals; `why` says why no better
    /// reference exists.
    Estimated {
        /// The reason.
        why: String,
    },
}

impl NoiseReference {
    /// The JSON name: `periods`, `given`, `lpm`, `unexcited`, `realisations` or `estimated`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Periods(_) => "periods",
            Self::Given => "given",
            Self::Lpm { .. } => "lpm",
            Self::Unexcited { .. } => "unexcited",
            Self::Realisations { .. } => "realisations",
            Self::Estimated { .. } => "estimated",
        }
    }

    /// One line for the text report.
    fn describe(&self) -> String {
        match self {
            Self::Periods(p) => format!(
                "periods: sample variances over {p} periods ({} degrees of freedom per line)",
                p - 1
            ),
            Self::Given => "given: the noise variances of the data file".into(),
            Self::Lpm { dof } => format!(
                "local polynomial method (dof {dof}): per-line output noise variances from \
                 local polynomial fits of G and the transient over neighbouring lines"
            ),
            Self::Unexcited { lines } => format!(
                "unexcited lines: per excited line, the output error Y - G U on the {lines} \
                 nearest lines the input does not excite (G interpolated from the excited \
                 lines): noise and nonlinear distortion together"
            ),
            Self::Realisations {
                realisations,
                periods,
            } if *periods >= 2 && *realisations >= 2 => format!(
                "realisations: the BLA over {realisations} realisations, weighted by its noise \
                 variance between {periods} periods; the total variance between realisations \
                 (noise + nonlinear distortion) is the nonlinear_distortion detector's reference"
            ),
            Self::Realisations {
                realisations,
                periods,
            } if *realisations >= 2 => format!(
                "realisations: the BLA over {realisations} realisations of {periods} period, \
                 weighted by its total variance between realisations; with one period the \
                 noise and the nonlinear distortion cannot be separated"
            ),
            Self::Realisations { periods, .. } => format!(
                "realisations: one realisation, the noise variance between {periods} periods; \
                 without a second realisation the nonlinear distortion at the excited lines \
                 is not seen"
            ),
            Self::Estimated { why } => format!(
                "estimated: lambda from the residuals ({why}); the cost test is skipped and \
                 the detectors have reduced power"
            ),
        }
    }
}

/// Why the workflow stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stop {
    /// The residuals are consistent with the noise.
    Consistent,
    /// No detector fired, or no proposal passed the likelihood-ratio test.
    NothingAccepted,
    /// `--max-steps` augmentations were accepted.
    StepLimit,
}

/// Everything `fdid diagnose` reports.
struct Diagnosis {
    file: String,
    alpha: f64,
    max_steps: usize,
    context: &'static str,
    noise: NoiseReference,
    source: String,
    notes: Vec<String>,
    steps: Vec<Step>,
    /// Named effects the final model does not absorb.
    unmodelled: Vec<Effect>,
    /// The final model's disagreement per time segment (one non-periodic record).
    segments: Option<String>,
    /// `fits[0]` is the starting model's, `fits[i]` the fit after step `i`.
    fits: Vec<SpecFit>,
    stop: Stop,
    /// The detectors' findings on the final fit.
    remaining: Vec<Finding>,
    /// The refits tried at the last step when none was accepted, with their outcome.
    attempts: Vec<Attempt>,
    /// The steps the backward-elimination pass removed.
    eliminated: Vec<Elimination>,
    /// The effects in the final model, in order.
    effects: Vec<Effect>,
    /// Effects named from the measurement alone (coloured noise in the reference).
    named: Vec<Finding>,
    initial: Report,
    last: Report,
    /// The time-varying ODE fitted after naming time variation on a continuous-time spec,
    /// with the time of the record's first sample (s).
    ltv: Option<(fdid::workflow::LtvStep, f64)>,
    /// The data the workflow ran on (for the figures).
    #[cfg_attr(not(feature = "plot"), allow(dead_code))]
    prepared: Prepared,
}

/// `fdid diagnose`: the workflow from the flags' starting model, reported from the fits
/// it made.
pub fn diagnose(args: &DiagnoseArgs) -> Result<String, Failure> {
    let c = &args.common;
    check_usage(args)?;
    if let Some(entries) = data::read_entries(c, false)? {
        return super::mimo_diagnose::diagnose(args, entries);
    }
    let mut prepared = data::prepare(c, false, true)?;
    let lines = prepared.data.len();
    if lines > MAX_LINES && !args.allow_long {
        return Err(Failure::usage(format!(
            "{} gives {lines} lines, more than the {MAX_LINES} diagnose works on by default: \
             its refits grow faster than the lines (measured on 2 cores: 10 000 lines 14 s, \
             20 000 lines 143 s); select the band of interest with --band FMIN:FMAX, average \
             periods with --periods P, or pass --allow-long to run anyway (`fdid fit` takes \
             any number of lines)",
            c.data.display()
        )));
    }
    let file = c.data.display().to_string();
    let start = ModelSpec {
        domain: prepared.domain,
        delay: c.delay,
        transient: c.transient,
        stability: if args.stable {
            Stability::Enforced
        } else {
            Stability::Free
        },
        ..ModelSpec::continuous(c.na, c.nb)
    };
    check_data_kind(&start, &file, &prepared)?;
    // a report directory that cannot be made is a usage problem found before the work
    if let Some(dir) = &args.report {
        for name in REPORT_FILES {
            super::refuse_overwrite(&c.data, &dir.join(name), "--report")?;
        }
        std::fs::create_dir_all(dir).map_err(|e| {
            Failure::runtime(format!(
                "cannot create the report directory {}: {e}",
                dir.display()
            ))
        })?;
    }
    let noise = noise_reference(prepared.periods, &mut prepared);
    let (ctx, context) = context(args, &prepared);
    let workflow = Workflow {
        max_steps: args.max_steps,
        ..Workflow::default()
    };
    let report = if args.allow_long {
        workflow.run(&prepared.data, start, ctx)?
    } else {
        let (report, stopped) =
            fdid::solver::work::within(DIAGNOSE_WORK, || workflow.run(&prepared.data, start, ctx));
        if stopped {
            return Err(Failure::runtime(format!(
                "diagnose stopped: its fits used up the work budget that keeps it to a minute \
                 or two on two cores ({DIAGNOSE_WORK:.0e} multiply-adds of the solvers; the \
                 F-16 FRF at order 8 uses 8e9), so its refits and tests are not trustworthy; \
                 lower the orders, select the band of interest with --band FMIN:FMAX, or pass \
                 --allow-long to run without the budget"
            )));
        }
        report?
    };
    if !report.final_fit.is_stable() {
        return Err(Failure::runtime(format!(
            "no stable model: the fit of {} stays unstable even with the stability \
             constraint (poles {}); try other orders or a narrower --band",
            describe(&report.final_fit.spec),
            report
                .final_fit
                .poles
                .iter()
                .filter(|p| match report.final_fit.spec.domain {
                    Domain::Continuous => p.re >= 0.0,
                    Domain::Discrete { .. } => p.norm() >= 1.0,
                })
                .map(|p| format!("{} {:+}i", g(p.re), g(p.im)))
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let diagnosis = Diagnosis::new(args, file, context, noise, prepared, report)?;
    let text = diagnosis.text();
    let json = diagnosis.json();
    let mut out = if args.json {
        json.clone()
    } else {
        text.clone()
    };
    if let Some(dir) = &args.report {
        let written = write_report(dir, &diagnosis, &text, &json)?;
        if !args.json {
            let _ = writeln!(out, "\nreport       {}", written.join(", "));
        }
    }
    Ok(out)
}

/// The usage checks of `fdid diagnose` before the data are read: the orders, `--alpha`
/// and the model flags (the starting model is fitted by ML, without a noise model).
fn check_usage(args: &DiagnoseArgs) -> Result<(), Failure> {
    let c = &args.common;
    check_orders(&[("--na", c.na), ("--nb", c.nb)])?;
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        return Err(Failure::usage(format!(
            "invalid --alpha {}: the false-alarm level lies strictly between 0 and 1",
            args.alpha
        )));
    }
    check_combinations(c, Method::Ml, None)
}

/// What the data are (periodic record, one non-periodic record, frequency data): the
/// workflow's context at `--alpha`, and its description.
fn context(args: &DiagnoseArgs, prepared: &Prepared) -> (Context, &'static str) {
    if let Some(r) = &prepared.realisations {
        return (
            realisations_context(args.alpha, r, &prepared.data),
            "periodic realisations (the best linear approximation at the excited lines)",
        );
    }
    match (prepared.time_record, prepared.periods) {
        (true, Some(p)) => {
            // with two or more periods the measurement-level detectors (input noise,
            // time variation) see the record; a record they cannot use leaves them out
            let plain = Context::periodic(args.alpha);
            let ctx = match prepared.record.clone() {
                Some(record) if p >= 2 => plain.clone().with_record(record, p).unwrap_or(plain),
                _ => plain,
            };
            (
                ctx,
                "periodic record (whole periods: no leakage, no transient)",
            )
        }
        (true, None) => (
            // the record itself, for the tests that split it in time (parameter drift)
            match prepared.record.clone() {
                Some(record) => Context::non_periodic(args.alpha).with_time_record(record),
                None => Context::non_periodic(args.alpha),
            },
            "one non-periodic record (DFT of the whole record: a transient can exist)",
        ),
        (false, _) => (
            Context::frequency_data(args.alpha),
            "frequency data (no time record: no transient, no noise model)",
        ),
    }
}

/// The workflow's context for the BLA of several realisations: periodic, with the
/// distortion analysis of the realisations (their spread against the noise between
/// periods, and the detection lines when the band holds some) at the fitted lines `data`,
/// when there are two or more realisations of two or more periods.
fn realisations_context(alpha: f64, r: &data::Realisations, data: &FrequencyData<f64>) -> Context {
    let plain = Context::periodic(alpha);
    if r.bla.realisations() < 2 || r.bla.periods() < 2 {
        return plain;
    }
    let fitted = data.omega();
    let (Some(lo), Some(hi)) = (fitted.first(), fitted.last()) else {
        return plain;
    };
    let lines: Vec<usize> = r
        .bla
        .lines()
        .iter()
        .zip(r.bla.omega())
        .filter(|(_, w)| *w >= lo && *w <= hi)
        .map(|(k, _)| *k)
        .collect();
    let (Some(first), Some(last)) = (lines.first(), lines.last()) else {
        return plain;
    };
    match DistortionAnalysis::from_realisations(
        &r.records,
        r.bla.periods(),
        &lines,
        [*first, *last],
    ) {
        Ok(analysis) => plain.with_distortion(analysis),
        Err(_) => plain,
    }
}

/// Attaches the best available noise reference to the data and says which it is: the
/// data's own variances (periods or file), else for a time record the local polynomial
/// method, else none (λ estimated).
fn noise_reference(periods: Option<usize>, prepared: &mut Prepared) -> NoiseReference {
    if let Some(r) = &prepared.realisations {
        let (realisations, periods) = (r.bla.realisations(), r.bla.periods());
        if realisations >= 2
            && let Some(noise_data) = &r.noise_data
        {
            prepared.data = noise_data.clone();
            prepared.weighting = "1/sigma_k from the noise variance of the BLA between periods \
                                  (the total variance is the distortion detector's reference)"
                .into();
        }
        return NoiseReference::Realisations {
            realisations,
            periods,
        };
    }
    if prepared.data.noise().is_some() {
        return match periods {
            Some(p) if prepared.time_record && p >= 2 => NoiseReference::Periods(p),
            _ => NoiseReference::Given,
        };
    }
    if !prepared.time_record {
        return NoiseReference::Estimated {
            why: "frequency data without variances".into(),
        };
    }
    if periods.is_some_and(|p| p >= 2) {
        // the sample variances were zero somewhere and dropped by the preparation
        return NoiseReference::Estimated {
            why: "the sample variances are zero on some lines".into(),
        };
    }
    if let Some(noisy) = prepared.unexcited_noise.take()
        && noisy.omega() == prepared.data.omega()
        && let Some(lines) = noisy.variance_dof()
    {
        prepared.data = noisy;
        prepared.weighting =
            format!("1/sigma_k from the output error on the {lines} nearest unexcited lines");
        return NoiseReference::Unexcited { lines };
    }
    let lpm = Lpm::new();
    match lpm
        .estimate(&prepared.data)
        .and_then(|estimate| estimate.spectra_data())
    {
        Ok(data)
            if data
                .noise()
                .is_some_and(|n| n.var_y.iter().all(|v| *v > 0.0)) =>
        {
            prepared.data = data;
            prepared.weighting = format!(
                "1/sigma_k from the output noise variances of the local polynomial method \
                 (R = {}, {} lines, dof {})",
                lpm.degree(),
                lpm.window(),
                lpm.dof()
            );
            NoiseReference::Lpm { dof: lpm.dof() }
        }
        Ok(_) => NoiseReference::Estimated {
            why: "the local polynomial method gives a zero noise variance on some line".into(),
        },
        Err(e) => NoiseReference::Estimated {
            why: format!("the local polynomial method does not apply: {e}"),
        },
    }
}

/// The frequency bands where `fit` and the data disagree at family-wise level α
/// ([`disagreement_bands`]), as JSON objects with frequencies in Hz.
fn bands_json(fit: &SpecFit, alpha: f64) -> Value {
    let hz = 1.0 / (2.0 * std::f64::consts::PI);
    let bands: Vec<Value> = disagreement_bands(fit, alpha)
        .unwrap_or_default()
        .iter()
        .map(|b| {
            json!({
                "f_lo_hz": num(b.omega_lo * hz),
                "f_hi_hz": num(b.omega_hi * hz),
                "lines": b.lines,
                "power": num(b.power),
                "expected": num(b.expected),
                "p_value": num(b.p_value),
            })
        })
        .collect();
    Value::Array(bands)
}

/// For one non-periodic record, the final model's cost per time segment against its
/// expected value ([`segment_disagreement`], 4 segments when they divide the record, else
/// 2), in one line of text; `None` when it does not apply.
fn segments_text(
    prepared: &Prepared,
    non_periodic: bool,
    fits: &[SpecFit],
    alpha: f64,
) -> Option<String> {
    let record = prepared.record.as_ref().filter(|_| non_periodic)?;
    let last = fits.last()?;
    let count = if record.len().is_multiple_of(4) { 4 } else { 2 };
    let segments = segment_disagreement(last, record, count, alpha).ok()?;
    let parts: Vec<String> = segments
        .iter()
        .map(|s| {
            format!(
                "{} .. {} s: V {} vs {}{}",
                g(s.t_start),
                g(s.t_end),
                g(s.cost),
                g(s.expected),
                if s.p_value < alpha {
                    format!(" (p = {})", short(s.p_value))
                } else {
                    String::new()
                }
            )
        })
        .collect();
    Some(format!("{count} segments: {}", parts.join("; ")))
}

/// The bands of [`bands_json`] in one line of text.
fn bands_text(fit: &SpecFit, alpha: f64) -> String {
    let hz = 1.0 / (2.0 * std::f64::consts::PI);
    let bands = disagreement_bands(fit, alpha).unwrap_or_default();
    if bands.is_empty() {
        return "no band exceeds the noise".into();
    }
    let parts: Vec<String> = bands
        .iter()
        .map(|b| {
            format!(
                "{} .. {} Hz ({} lines, power {} vs {}, p = {})",
                g(b.omega_lo * hz),
                g(b.omega_hi * hz),
                b.lines,
                g(b.power),
                g(b.expected),
                short(b.p_value)
            )
        })
        .collect();
    parts.join("; ")
}

/// max_k |r_k| in noise standard deviations.
fn max_residual(fit: &SpecFit) -> f64 {
    fit.validation.max_residual / fit.residual_scale().sqrt()
}

/// The model structure in words: domain, orders and factors.
fn describe(spec: &ModelSpec) -> String {
    let mut s = match spec.domain {
        Domain::Continuous => "s".to_string(),
        Domain::Discrete { ts } => format!("z (Ts = {} s)", g(ts)),
    };
    let _ = write!(s, ", na = {}, nb = {}", spec.na, spec.nb);
    if spec.delay {
        s.push_str(", delay");
    }
    if spec.transient {
        s.push_str(", transient");
    }
    if let Some(n) = spec.noise_order {
        let _ = write!(s, ", noise model ({n}, {n})");
    }
    if spec.criterion == Method::Eiv {
        s.push_str(", errors-in-variables");
    }
    if spec.stability == Stability::Enforced {
        s.push_str(", stability enforced");
    }
    s
}

/// A p-value or `-`.
fn p_text(p: Option<f64>) -> String {
    p.map_or_else(|| "-".into(), short)
}

/// Three significant digits.
fn short(x: f64) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    if x == 0.0 {
        return "0".into();
    }
    if (1e-3..1e5).contains(&x.abs()) {
        let digits = (2 - x.abs().log10().floor() as i32).max(0) as usize;
        format!("{x:.digits$}")
    } else {
        format!("{x:.2e}")
    }
}

/// One row of the table of steps: `cells` = step number, effect, detector p and LR p,
/// then the cost (from `before`, when given), expected cost, max |r| and whiteness p of
/// `fit`.
fn step_row(w: &mut String, cells: [&str; 4], fit: &SpecFit, before: Option<f64>) {
    let [n, effect, p, lr] = cells;
    let v = match before {
        Some(b) => format!("{} -> {}", short(b), short(fit.cost)),
        None => short(fit.cost),
    };
    let _ = writeln!(
        w,
        "  {:<2} {:<18} {:>9} {:>9} {:>23} {:>10} {:>8} {:>9}",
        n,
        effect,
        p,
        lr,
        v,
        p_text(fit.validation.cost_expected),
        short(max_residual(fit)),
        p_text(fit.validation.whiteness_p)
    );
}

impl Diagnosis {
    /// The diagnosis of the workflow's `report` on `prepared` (from `file`, with the noise
    /// reference `noise`): the initial and final reports render the fits the workflow
    /// made, each with the data it was fitted on.
    fn new(
        args: &DiagnoseArgs,
        file: String,
        context: &'static str,
        noise: NoiseReference,
        prepared: Prepared,
        report: WorkflowReport,
    ) -> Result<Self, Failure> {
        let render = |fit: &SpecFit, data: &FrequencyData<f64>| {
            let typed = fit.fit.as_ref().ok_or_else(|| {
                Failure::runtime(format!(
                    "the workflow kept no fit of the model {}",
                    describe(&fit.spec)
                ))
            })?;
            Report::of(&fit.spec, &file, &prepared, data, typed)
        };
        let initial = render(&report.initial_fit, &prepared.data)?;
        let final_data = report.final_data.as_ref().unwrap_or(&prepared.data);
        let last = render(&report.final_fit, final_data)?;
        let stop = if report.consistent_with_noise {
            Stop::Consistent
        } else if report.steps.len() >= args.max_steps {
            Stop::StepLimit
        } else {
            Stop::NothingAccepted
        };
        let mut fits = vec![report.initial_fit];
        fits.extend(report.step_fits);
        // the revision pass may change the final model after the last step fit was recorded
        if let Some(last) = fits.last_mut() {
            *last = report.final_fit;
        }
        let non_periodic = prepared.periods.is_none() && prepared.realisations.is_none();
        let t0 = super::ltv::first_time(&args.common.data).unwrap_or(0.0);
        Ok(Self {
            ltv: report.ltv.map(|step| (step, t0)),
            alpha: args.alpha,
            max_steps: args.max_steps,
            context,
            noise,
            source: prepared.source.clone(),
            notes: prepared.notes.clone(),
            segments: segments_text(&prepared, non_periodic, &fits, args.alpha),
            steps: report.steps,
            unmodelled: report.unmodelled,
            fits,
            stop,
            remaining: report.remaining,
            attempts: report.attempts,
            eliminated: report.eliminated,
            effects: report.effects,
            named: report.named,
            initial,
            last,
            file,
            prepared,
        })
    }

    fn last_fit(&self) -> &SpecFit {
        self.fits.last().expect("the starting fit is always there")
    }

    /// The JSON object (one line): steps, effects, the verdict, the noise reference and
    /// the `fdid fit --json` objects of the initial and final models.
    fn json(&self) -> String {
        let steps: Vec<Value> = self
            .steps
            .iter()
            .map(|s| {
                let detail: Map<String, Value> = s
                    .detail
                    .entries()
                    .into_iter()
                    .map(|(k, v)| (k.to_string(), num(v)))
                    .collect();
                json!({
                    "effect": s.effect.as_str(),
                    "p_value": num(s.p_value),
                    "cost_before": num(s.cost_before),
                    "cost_after": num(s.cost_after),
                    "lr_p": num(s.lr_p),
                    "detail": detail,
                    "revised": s.revised,
                })
            })
            .collect();
        let effects: Vec<&str> = self.effects.iter().map(|e| e.as_str()).collect();
        let attempts: Vec<Value> = self
            .attempts
            .iter()
            .map(|a| {
                let mut o = json!({
                    "effect": a.effect.as_str(),
                    "p_value": num(a.p_value),
                    "outcome": outcome_name(&a.outcome),
                });
                match &a.outcome {
                    Outcome::Failed { reason } => o["reason"] = json!(reason),
                    Outcome::Rejected { lr_p, level } => {
                        o["lr_p"] = num(*lr_p);
                        o["level"] = num(*level);
                    }
                    Outcome::Outexplained { lr_p } | Outcome::Accepted { lr_p } => {
                        o["lr_p"] = num(*lr_p);
                    }
                    Outcome::NotApplicable | Outcome::NotLarger | Outcome::Unstable => {}
                }
                o
            })
            .collect();
        let eliminated: Vec<Value> = self
            .eliminated
            .iter()
            .map(|e| {
                json!({
                    "effect": e.effect.as_str(),
                    "step": e.step + 1,
                    "cost_with": num(e.cost_with),
                    "cost_without": num(e.cost_without),
                    "lr_p": num(e.lr_p),
                })
            })
            .collect();
        let obj = json!({
            "steps": steps,
            "effects": effects,
            "refits_rejected": attempts,
            "eliminated": eliminated,
            "named": self.named.iter().map(named_json).collect::<Vec<_>>(),
            "consistent_with_noise": self.stop == Stop::Consistent,
            "unmodelled": self.unmodelled.iter().map(|e| e.as_str()).collect::<Vec<_>>(),
            "noise_reference": self.noise.name(),
            "bands": {
                "initial": bands_json(&self.fits[0], self.alpha),
                "final": bands_json(self.last_fit(), self.alpha),
            },
            "initial": self.initial.json_value(),
            "final": self.last.json_value(),
            "time_varying_ode": self
                .ltv
                .as_ref()
                .map_or(Value::Null, |(step, t0)| super::ltv::diagnose_json(step, *t0)),
        });
        let mut s = obj.to_string();
        s.push('\n');
        s
    }

    /// The text report.
    fn text(&self) -> String {
        let mut o = String::new();
        let w = &mut o;
        self.header_text(w);
        self.steps_text(w);
        self.ltv_text(w);
        self.final_text(w);
        self.conclusion_text(w);
        o
    }

    /// The settings, the data, the context, the noise reference and the starting model.
    fn header_text(&self, w: &mut String) {
        let _ = writeln!(
            w,
            "fdid diagnose: discrepancy workflow, alpha = {}, at most {} step{}",
            self.alpha,
            self.max_steps,
            if self.max_steps == 1 { "" } else { "s" }
        );
        let _ = writeln!(w, "data         {}: {}", self.file, self.source);
        let _ = writeln!(w, "context      {}", self.context);
        let _ = writeln!(w, "noise ref.   {}", self.noise.describe());
        let _ = writeln!(
            w,
            "start        {} ({} parameters)",
            describe(&self.fits[0].spec),
            self.fits[0].n_params
        );
        for n in &self.notes {
            let _ = writeln!(w, "note         {n}");
        }
    }

    /// The table of steps (the start first) with the revised and unmodelled effects and
    /// each step's detail, after an empty line.
    fn steps_text(&self, w: &mut String) {
        let _ = writeln!(w);
        let _ = writeln!(
            w,
            "steps (p: detector; LR p: likelihood-ratio test; V: cost; E V: expected cost; \
             max |r| in noise std; white p: Ljung-Box)"
        );
        let _ = writeln!(
            w,
            "  {:<2} {:<18} {:>9} {:>9} {:>23} {:>10} {:>8} {:>9}",
            "#", "effect", "p", "LR p", "V before -> after", "E V", "max |r|", "white p"
        );
        step_row(w, ["0", "(start)", "", ""], &self.fits[0], None);
        for (i, (s, fit)) in self.steps.iter().zip(&self.fits[1..]).enumerate() {
            let name = if s.revised {
                format!("{}*", s.effect)
            } else {
                s.effect.to_string()
            };
            let (n, p, lr) = ((i + 1).to_string(), short(s.p_value), short(s.lr_p));
            step_row(w, [&n, &name, &p, &lr], fit, Some(s.cost_before));
        }
        if self.steps.iter().any(|s| s.revised) {
            let _ = writeln!(
                w,
                "  * revised: swapped for this one-parameter effect once the other effects \
                 were in the model; V before is the final model's without it"
            );
        }
        for e in &self.unmodelled {
            let _ = writeln!(
                w,
                "  {e}: named, but the model class cannot absorb it (the residual holds it, \
                 not a model error)"
            );
        }
        for f in &self.named {
            let _ = writeln!(w, "  {}", named_text(f));
        }
        for e in &self.eliminated {
            let _ = writeln!(
                w,
                "  {} (step {}): removed by backward elimination, no longer significant given \
                 the other effects (V {} without vs {} with, LR p = {} >= alpha)",
                e.effect,
                e.step + 1,
                g(e.cost_without),
                g(e.cost_with),
                short(e.lr_p)
            );
        }
        for s in &self.steps {
            let entries = s.detail.entries();
            if !entries.is_empty() {
                let parts: Vec<String> = entries
                    .iter()
                    .map(|(k, v)| format!("{k} = {}", g(*v)))
                    .collect();
                let _ = writeln!(w, "  {}: {}", s.effect, parts.join(", "));
            }
        }
    }

    /// The time-varying ODE fitted after naming time variation, after an empty line.
    fn ltv_text(&self, w: &mut String) {
        if let Some((step, t0)) = &self.ltv {
            let _ = writeln!(w);
            w.push_str(&super::ltv::diagnose_text(step, *t0));
        }
    }

    /// The final model: its structure, its validation and the model part of its report,
    /// after an empty line.
    fn final_text(&self, w: &mut String) {
        let last = self.last_fit();
        let _ = writeln!(w);
        let _ = writeln!(
            w,
            "final model  {} ({} parameters), {} step{}",
            describe(&last.spec),
            last.n_params,
            self.steps.len(),
            if self.steps.len() == 1 { "" } else { "s" }
        );
        let v = &last.validation;
        let cost = match (v.cost_expected, v.cost_p) {
            (Some(e), Some(p)) => {
                format!("V = {} vs expected {} (p = {})", g(v.cost), g(e), short(p))
            }
            (Some(e), None) => format!(
                "V = {} vs expected {} (no cost test: the sample variances have too few \
                 degrees of freedom)",
                g(v.cost),
                g(e)
            ),
            _ => format!("V = {} (lambda estimated: no cost test)", g(v.cost)),
        };
        let _ = writeln!(
            w,
            "validation   {cost}; whiteness p = {}",
            p_text(v.whiteness_p)
        );
        let _ = write!(w, "{}", self.last.model_text());
    }

    /// Where start and final model disagree with the data, the verdict and its warnings,
    /// and the detectors' findings on the final fit, after an empty line.
    fn conclusion_text(&self, w: &mut String) {
        let _ = writeln!(w);
        for (name, fit) in [("start", &self.fits[0]), ("final", self.last_fit())] {
            let _ = writeln!(w, "disagree     {name}: {}", bands_text(fit, self.alpha));
        }
        if let Some(segments) = &self.segments {
            let _ = writeln!(w, "in time      final model on {segments}");
        }
        let _ = writeln!(w, "verdict      {}", self.verdict());
        let n = self.last.unresolved().len();
        if n > 0 {
            let _ = writeln!(
                w,
                "warning      the final model has {n} pole{} the data do not resolve (listed \
                 above): a consistent residual does not make {} trustworthy",
                if n == 1 { "" } else { "s" },
                if n == 1 { "it" } else { "them" }
            );
        }
        let fired: Vec<String> = self
            .remaining
            .iter()
            .map(|f| format!("{} p = {}", f.effect, short(f.p_value)))
            .collect();
        if !fired.is_empty() {
            let _ = writeln!(w, "detectors    on the final fit: {}", fired.join(", "));
        }
        let firing = self.remaining.iter().any(|f| f.p_value < self.alpha);
        let no_cost_test = self.last_fit().validation.cost_p.is_none();
        if self.stop == Stop::Consistent && firing && no_cost_test {
            let _ = writeln!(
                w,
                "warning      detectors fire below alpha on the final fit, but without a cost \
                 test (noise level estimated, or sample variances with 2 or fewer degrees of \
                 freedom) only the whiteness test decides consistency and the workflow \
                 stopped; more periods (P >= 4) or given noise variances make the cost test \
                 available"
            );
        }
    }

    /// Whether the final residuals are consistent with the noise, and if not what is
    /// left.
    fn verdict(&self) -> String {
        let last = self.last_fit();
        let level = self.alpha / 2.0;
        if self.stop == Stop::Consistent {
            return format!(
                "the residuals are consistent with the noise at alpha = {} (cost and whiteness \
                 tests at alpha/2 each)",
                self.alpha
            );
        }
        let v = &last.validation;
        let mut failing = Vec::new();
        if let Some(p) = v.cost_p.filter(|p| *p < level) {
            failing.push(format!(
                "the cost exceeds what the noise explains (p = {})",
                short(p)
            ));
        }
        if let Some(p) = v.whiteness_p.filter(|p| *p < level) {
            failing.push(format!("the residual is not white (p = {})", short(p)));
        }
        let why = match self.stop {
            Stop::StepLimit => format!("the step limit --max-steps {} was reached", self.max_steps),
            _ => {
                let fired: Vec<&str> = self
                    .remaining
                    .iter()
                    .filter(|f| f.p_value < self.alpha)
                    .map(|f| f.effect.as_str())
                    .collect();
                if fired.is_empty() {
                    "no detector fires".into()
                } else if self.attempts.is_empty() {
                    format!(
                        "{} fire{} on the final fit",
                        fired.join(", "),
                        if fired.len() == 1 { "s" } else { "" }
                    )
                } else {
                    let tried: Vec<String> = self
                        .attempts
                        .iter()
                        .map(|a| format!("{} ({})", a.effect, a.outcome.describe()))
                        .collect();
                    format!("no refit is accepted: {}", tried.join(", "))
                }
            }
        };
        format!(
            "not consistent with the noise: {why}; {}",
            if failing.is_empty() {
                "the tests fail at alpha/2".to_string()
            } else {
                failing.join("; ")
            }
        )
    }
}

/// The most lines `fdid diagnose` works on without `--allow-long`.
const MAX_LINES: usize = 10_000;

/// The work budget of the solvers in `fdid diagnose` without `--allow-long`
/// ([`fdid::solver::work`]; measured on two cores: the dryer from order 1/0 uses 1.4·10⁹
/// in 13 s, the F-16 FRF from order 8/8 7.9·10⁹ in 21 s).
const DIAGNOSE_WORK: f64 = 2e10;

/// The files `--report DIR` writes.
const REPORT_FILES: [&str; 4] = ["report.txt", "report.json", "bode.svg", "residuals.svg"];

/// Writes report.txt, report.json and (with the `plot` feature) the SVG figures into
/// `dir`; returns the paths written.
fn write_report(
    dir: &Path,
    diagnosis: &Diagnosis,
    text: &str,
    json: &str,
) -> Result<Vec<String>, Failure> {
    let mut written = Vec::new();
    let mut put = |name: &str, contents: &str| -> Result<(), Failure> {
        let path = dir.join(name);
        super::progress::write_atomic(&path, contents.as_bytes())
            .map_err(|e| Failure::runtime(format!("cannot write {}: {e}", path.display())))?;
        written.push(path.display().to_string());
        Ok(())
    };
    put("report.txt", text)?;
    put("report.json", json)?;
    #[cfg(feature = "plot")]
    {
        let first = &diagnosis.fits[0];
        let last = diagnosis.last_fit();
        let bode = super::svg::bode(&diagnosis.prepared.data, first, last)
            .map_err(|e| Failure::runtime(format!("cannot draw bode.svg: {e}")))?;
        put("bode.svg", &bode)?;
        let residuals = super::svg::residuals(first, last, diagnosis.alpha)
            .map_err(|e| Failure::runtime(format!("cannot draw residuals.svg: {e}")))?;
        put("residuals.svg", &residuals)?;
    }
    #[cfg(not(feature = "plot"))]
    {
        let _ = diagnosis;
        written.push(
            "(no SVG figures: they need the `plot` feature, cargo build --features plot)".into(),
        );
    }
    Ok(written)
}

/// The JSON name of a refit's outcome.
fn outcome_name(outcome: &Outcome) -> &'static str {
    match outcome {
        Outcome::Failed { .. } => "failed",
        Outcome::NotApplicable => "not_applicable",
        Outcome::NotLarger => "not_larger",
        Outcome::Unstable => "unstable",
        Outcome::Rejected { .. } => "rejected",
        Outcome::Outexplained { .. } => "outexplained",
        Outcome::Accepted { .. } => "accepted",
    }
}

/// The text of an effect named from the measurement alone.
fn named_text(f: &Finding) -> String {
    match f.detail.colored_noise() {
        Some(d) => format!(
            "{}: named from the noise reference (p = {}): its per-line variances vary by a \
             factor {} over {} frequency blocks; the reference already weights each line by \
             them; a parametric noise model is offered (fdid fit ... --noise-order 1)",
            f.effect,
            short(f.p_value),
            g(d.ratio),
            d.blocks
        ),
        None => format!(
            "{}: named from the measurement (p = {})",
            f.effect,
            short(f.p_value)
        ),
    }
}

/// The JSON object of an effect named from the measurement alone.
fn named_json(f: &Finding) -> Value {
    let detail: Map<String, Value> = f
        .detail
        .entries()
        .into_iter()
        .map(|(k, v)| (k.to_string(), num(v)))
        .collect();
    json!({
        "effect": f.effect.as_str(),
        "p_value": num(f.p_value),
        "detail": detail,
        "offer": {"noise_order": f.proposal.noise_order},
    })
}
