//! The `fdid` command: argument handling, data preparation, estimation and output.

pub mod args;
mod data;
mod diagnose;
mod report;
mod saved;
#[cfg(feature = "plot")]
mod svg;

use args::{Cli, Command, CriterionArg, DomainArg, FitArgs, MAX_ORDER};
use data::Prepared;
use fdid::estimate::fit_eiv_delayed;
use fdid::fit::Stage;
use fdid::prelude::*;
use fdid::workflow::ModelSpec;
use report::Parts;
pub use report::Report;
use std::result::Result;

/// A failure, reported as one `error:` line with exit status `code`.
#[derive(Debug)]
pub struct Failure {
    /// Exit status.
    pub code: u8,
    /// The message (without the `error:` prefix).
    pub message: String,
}

impl Failure {
    /// Bad usage (exit status 2).
    pub fn usage(message: String) -> Self {
        Self { code: 2, message }
    }

    /// Bad data or a failed estimation (exit status 1).
    pub fn runtime(message: String) -> Self {
        Self { code: 1, message }
    }
}

impl From<FdidError> for Failure {
    fn from(e: FdidError) -> Self {
        Self::runtime(e.to_string())
    }
}

/// Runs the command and returns what to print on stdout.
pub fn run(cli: &Cli) -> Result<String, Failure> {
    match &cli.command {
        Command::Fit(args) => fit(args),
        Command::Diagnose(args) => diagnose::diagnose(args),
        Command::Eval(args) => saved::eval(args),
    }
}

/// A model structure and its estimator: what `fdid fit` reads from its flags and what
/// `fdid diagnose` reads from a workflow [`ModelSpec`]. One dispatch ([`fit_report`])
/// serves both.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FitSpec {
    /// Model domain.
    pub domain: DomainArg,
    /// Denominator degree.
    pub na: usize,
    /// Numerator degree.
    pub nb: usize,
    /// With a delay e^{−iωτ}.
    pub delay: bool,
    /// With the transient term of a non-periodic record.
    pub transient: bool,
    /// Order (n, n) of a noise model H = C/D.
    pub noise_order: Option<usize>,
    /// The estimator.
    pub criterion: CriterionArg,
}

impl FitSpec {
    /// The spec of `fdid fit`'s flags.
    fn of_fit(args: &FitArgs) -> Self {
        Self {
            domain: args.common.domain,
            na: args.common.na,
            nb: args.common.nb,
            delay: args.common.delay,
            transient: args.common.transient,
            noise_order: args.noise_order,
            criterion: args.criterion,
        }
    }

    /// The spec of a workflow [`ModelSpec`].
    pub fn of_model_spec(spec: &ModelSpec) -> Self {
        Self {
            domain: match spec.domain {
                Domain::Continuous => DomainArg::S,
                Domain::Discrete { .. } => DomainArg::Z,
            },
            na: spec.na,
            nb: spec.nb,
            delay: spec.delay,
            transient: spec.transient,
            noise_order: spec.noise_order,
            criterion: match spec.criterion {
                fdid::estimate::Method::Ml => CriterionArg::Ml,
                fdid::estimate::Method::Eiv => CriterionArg::Eiv,
                fdid::estimate::Method::Levy => CriterionArg::Levy,
                fdid::estimate::Method::Sk => CriterionArg::Sk,
                fdid::estimate::Method::Tls => CriterionArg::Tls,
            },
        }
    }
}

/// Rejects model orders above [`MAX_ORDER`], naming the flag.
fn check_orders(orders: &[(&str, usize)]) -> Result<(), Failure> {
    for (name, v) in orders {
        if *v > MAX_ORDER {
            return Err(Failure::usage(format!(
                "invalid {name} {v}: orders above {MAX_ORDER} are not supported"
            )));
        }
    }
    Ok(())
}

/// `fdid fit`.
fn fit(args: &FitArgs) -> Result<String, Failure> {
    check_orders(&[
        ("--na", args.common.na),
        ("--nb", args.common.nb),
        ("--noise-order", args.noise_order.unwrap_or(0)),
    ])?;
    let spec = FitSpec::of_fit(args);
    check_combinations(&spec, args.common.periods)?;
    let prepared = data::prepare(&args.common, args.noise_order.is_some())?;
    let file = args.common.data.display().to_string();
    check_data_kind(&spec, &file, &prepared)?;
    let report = fit_report(&spec, &file, &prepared)?;
    if let Some(path) = &args.plot {
        write_plot(path, &prepared, &report)?;
    }
    if let (Some(path), Some(value)) = (&args.save, &report.saved) {
        saved::write(path, value)?;
    }
    Ok(if args.json {
        report.json()
    } else {
        report.text()
    })
}

/// `fdid fit --plot FILE`: the Bode plot of the data, the model with its uncertainty band
/// and the residual.
#[cfg(feature = "plot")]
fn write_plot(path: &std::path::Path, prepared: &Prepared, report: &Report) -> Result<(), Failure> {
    let (response, std) = report.response();
    let curve = svg::Curve {
        name: "model",
        response,
        std,
    };
    let figure = svg::bode_curves(&prepared.data, &[curve], true)
        .map_err(|e| Failure::runtime(format!("cannot draw the Bode plot: {e}")))?;
    std::fs::write(path, figure)
        .map_err(|e| Failure::runtime(format!("cannot write {}: {e}", path.display())))
}

/// Without the `plot` feature `--plot` is a usage error.
#[cfg(not(feature = "plot"))]
fn write_plot(path: &std::path::Path, _: &Prepared, _: &Report) -> Result<(), Failure> {
    Err(Failure::usage(format!(
        "--plot {} needs the `plot` feature (build with default features)",
        path.display()
    )))
}

/// Fits `spec` to the prepared data with the estimator it names and collects the report
/// (the one dispatch of `fdid fit` and `fdid diagnose`).
pub fn fit_report(spec: &FitSpec, file: &str, prepared: &Prepared) -> Result<Report, Failure> {
    let data = &prepared.data;
    let p = spec.na + spec.nb + 1;
    if 2 * data.len() < p {
        return Err(FdidError::TooFewFrequencies {
            lines: data.len(),
            equations: 2 * data.len(),
            parameters: p,
        }
        .into());
    }
    let model = model(spec, prepared)?;
    let method = Method::of(spec);
    match (spec.delay, spec.noise_order) {
        (false, None) => {
            let fit = estimate_with(spec.criterion, &model, data)?;
            let unresolved = fit.unresolved_poles()?;
            let parts = method.parts(fit.model(), false, None, unresolved);
            finish(saved::Kind::Rational, spec, file, prepared, &fit, parts)
        }
        (true, None) => {
            let fit = fit_with_delay(spec.criterion, &model, data)?;
            let unresolved = unresolved_of(spec, prepared, &fit)?;
            let parts = method.parts(fit.model().inner(), true, None, unresolved);
            finish(saved::Kind::Delayed, spec, file, prepared, &fit, parts)
        }
        (false, Some(n)) => {
            let fit = fit_noise_model(&Pipeline::default(), &model, data, n, n)?;
            let unresolved = unresolved_of(spec, prepared, &fit)?;
            let noise = fit.model().noise::<f64>();
            let parts = method.parts(fit.model().system(), false, Some(noise), unresolved);
            finish(saved::Kind::NoiseModel, spec, file, prepared, &fit, parts)
        }
        (true, Some(n)) => {
            let fit = fit_delay_noise_model(&model, data, n)?;
            let unresolved = unresolved_of(spec, prepared, &fit)?;
            let noise = fit.model().noise::<f64>();
            let parts = method.parts(fit.model().system().inner(), true, Some(noise), unresolved);
            finish(
                saved::Kind::DelayedNoiseModel,
                spec,
                file,
                prepared,
                &fit,
                parts,
            )
        }
    }
}

/// The report of `fit` with its saved-model object.
fn finish<M: ModelStructure<f64> + PolesZeros<f64> + Clone + serde::Serialize>(
    kind: saved::Kind,
    spec: &FitSpec,
    file: &str,
    prepared: &Prepared,
    fit: &Fit<f64, M>,
    parts: Parts<'_>,
) -> Result<Report, Failure> {
    let saved = saved::saved(kind, spec.domain, prepared.ts, file, fit, &parts.unresolved)?;
    Report::new(spec, file, prepared, fit, parts).map(|r| r.with_saved(saved))
}

/// The poles of a delayed or noise-model fit that the data do not resolve, by the
/// definition of [`Fit::unresolved_poles`] (which serves the rational fits).
fn unresolved_of<M: ModelStructure<f64> + PolesZeros<f64>>(
    spec: &FitSpec,
    prepared: &Prepared,
    fit: &Fit<f64, M>,
) -> Result<Vec<Complex<f64>>, Failure> {
    Ok(report::unresolved_poles(
        spec.domain,
        prepared.ts,
        fit.omega(),
        &fit.poles()?,
    ))
}

/// Rejects the combinations of flags the estimators do not compose, naming both flags.
fn check_combinations(args: &FitSpec, periods: Option<usize>) -> Result<(), Failure> {
    let c = args.criterion.name();
    if let Some(n) = args.noise_order {
        if n == 0 {
            return Err(Failure::usage(
                "invalid --noise-order 0: the noise model H = C/D needs order 1 or more \
                 (without --noise-order the noise is taken as white)"
                    .into(),
            ));
        }
        if args.criterion != CriterionArg::Ml {
            return Err(Failure::usage(format!(
                "--noise-order cannot be combined with --criterion {c}: the noise model is \
                 estimated by maximum likelihood (--criterion ml)"
            )));
        }
        if let Some(p) = periods.filter(|p| *p >= 2) {
            return Err(Failure::usage(format!(
                "--noise-order cannot be combined with --periods {p}: the noise model is \
                 estimated from one record (drop --periods, or use --periods {p} without \
                 --noise-order to weight by the nonparametric noise variances)"
            )));
        }
    }
    if args.delay && !matches!(args.criterion, CriterionArg::Ml | CriterionArg::Eiv) {
        return Err(Failure::usage(format!(
            "--delay cannot be combined with --criterion {c}: the delay enters nonlinearly \
             and is fitted by --criterion ml or eiv"
        )));
    }
    if args.transient && args.domain == DomainArg::S && args.nb > args.na {
        return Err(Failure::usage(format!(
            "--transient with --domain s needs --nb <= --na (the partial-fraction form), \
             got --na {} --nb {}",
            args.na, args.nb
        )));
    }
    Ok(())
}

/// Rejects flags that the kind of data at hand (from `file`) cannot serve.
fn check_data_kind(args: &FitSpec, file: &str, prepared: &Prepared) -> Result<(), Failure> {
    if !prepared.time_record {
        if args.transient {
            return Err(Failure::usage(format!(
                "--transient needs a time record (t,u,y): the transient of a non-periodic \
                 record is modelled on its DFT, but {file} holds frequency data"
            )));
        }
        if let Some(n) = args.noise_order {
            return Err(Failure::usage(format!(
                "--noise-order {n} needs a time record (t,u,y): the noise model is estimated \
                 from the DFT of one record, but {file} holds frequency data"
            )));
        }
    }
    if args.criterion == CriterionArg::Eiv {
        match prepared.data.noise() {
            None => {
                return Err(Failure::usage(format!(
                    "--criterion eiv needs input and output noise variances: pass a time \
                     record with --periods P >= 2 or a spectra file with var_u,var_y columns \
                     ({file} with these options gives none{})",
                    if prepared
                        .notes
                        .iter()
                        .any(|n| n.contains("variance is zero"))
                    {
                        ": its noise variances are zero"
                    } else {
                        ""
                    }
                )));
            }
            Some(noise) if noise.var_u.iter().all(|v| *v == 0.0) => {
                return Err(Failure::runtime(format!(
                    "--criterion eiv: the input noise variance var_u is zero on every line of \
                     {file}: there is no input noise to model; use --criterion ml"
                )));
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// The rational model of the flags, with the transient term when asked for.
fn model(args: &FitSpec, prepared: &Prepared) -> Result<Rational<f64>, Failure> {
    let model = match (args.domain, prepared.ts) {
        (DomainArg::S, _) => Rational::continuous(args.na, args.nb, prepared.data.omega())?,
        (DomainArg::Z, Some(ts)) => Rational::discrete(args.na, args.nb, ts)?,
        (DomainArg::Z, None) => {
            return Err(Failure::usage(
                "--domain z needs a sample time: pass --ts SECONDS".into(),
            ));
        }
    };
    if !args.transient {
        return Ok(model);
    }
    Ok(match (args.domain, prepared.record_ts) {
        (DomainArg::Z, _) => model.with_transient()?,
        (DomainArg::S, Some(ts)) => model.with_sampled_transient(ts)?,
        (DomainArg::S, None) => {
            return Err(Failure::usage(
                "--transient needs a time record (t,u,y) for its sample time".into(),
            ));
        }
    })
}

/// How the estimate was made, for the report.
struct Method {
    description: String,
    weighting: Option<String>,
}

impl Method {
    fn of(args: &FitSpec) -> Self {
        let mut description = if args.delay {
            "delay from the phase slope, Levy -> Sanathanan-Koerner -> maximum likelihood on \
             the delay-compensated lines, maximum likelihood of the delayed model (eq. 23)"
                .to_string()
        } else {
            args.criterion.description().to_string()
        };
        let mut weighting = None;
        if args.delay && args.criterion == CriterionArg::Eiv {
            description.push_str(", errors-in-variables maximum likelihood (eq. 42)");
        }
        if args.criterion == CriterionArg::Eiv {
            weighting = Some(
                "1/sigma_k(theta), sigma_k^2 = var_y + |G|^2 var_u - 2 Re(conj(G) cov_yu) \
                 (errors-in-variables, eq. 42)"
                    .into(),
            );
        }
        if let Some(n) = args.noise_order {
            description = format!(
                "start: {description}, with flat weighting; then maximum likelihood with the \
                 noise model H = C/D of orders ({n}, {n}) (eq. 26)"
            );
            weighting =
                Some("1/|H_k| from the estimated noise model; lambda estimated (eq. 25)".into());
        }
        Self {
            description,
            weighting,
        }
    }

    fn parts<'a>(
        &self,
        rational: &'a Rational<f64>,
        delay: bool,
        noise: Option<NoiseModel<f64>>,
        unresolved: Vec<Complex<f64>>,
    ) -> Parts<'a> {
        Parts {
            unresolved,
            rational,
            delay,
            noise,
            description: self.description.clone(),
            weighting: self.weighting.clone(),
        }
    }
}

/// Runs the chosen estimator.
fn estimate_with(
    criterion: CriterionArg,
    model: &Rational<f64>,
    data: &FrequencyData<f64>,
) -> Result<Fit<f64, Rational<f64>>, Failure> {
    Ok(match criterion {
        CriterionArg::Ml => Pipeline::default().fit(model, data)?,
        CriterionArg::Levy => Pipeline::levy().fit(model, data)?,
        CriterionArg::Sk => Pipeline::sk().fit(model, data)?,
        CriterionArg::Tls => {
            let tls = TotalLeastSquares::default();
            let solution = estimate(model, data, &tls, &SvdNullVector, None)?;
            let theta = solution.theta.clone();
            let stages = vec![Stage {
                kind: StageKind::Tls,
                solution,
            }];
            Fit::new(model.clone(), data, theta, tls.weighting, stages)?
        }
        CriterionArg::Eiv => fit_eiv(&Pipeline::default(), model, data)?,
    })
}

/// The delayed model G e^{−iωτ}: [`fit_delayed`] (output-error ML, eq. 23) and, for
/// `eiv`, errors-in-variables ML (eq. 42) from there.
fn fit_with_delay(
    criterion: CriterionArg,
    model: &Rational<f64>,
    data: &FrequencyData<f64>,
) -> Result<Fit<f64, Delayed<Rational<f64>>>, Failure> {
    match criterion {
        CriterionArg::Ml => Ok(fit_delayed(&Pipeline::default(), model, data)?),
        CriterionArg::Eiv => Ok(fit_eiv_delayed(
            &Pipeline::default(),
            &Delayed::new(model.clone()),
            data,
        )?),
        c => Err(Failure::usage(format!(
            "--delay cannot be combined with --criterion {}",
            c.name()
        ))),
    }
}

/// A delayed rational model with a noise model.
type DelayedWithNoise = WithNoiseModel<Delayed<Rational<f64>>>;

/// The delayed model with a noise model H = C/D of orders (n, n), as
/// [`fit_noise_model`] does for an undelayed one: [`fit_delayed`] with flat weighting on
/// the excited lines as the start (η = 0, H = 1), then the concentrated ML criterion of
/// McKelvey eq. 26.
fn fit_delay_noise_model(
    model: &Rational<f64>,
    data: &FrequencyData<f64>,
    n: usize,
) -> Result<Fit<f64, DelayedWithNoise>, Failure> {
    let excited: Vec<bool> = data.u().iter().map(|u| u.norm_sqr() > 0.0).collect();
    let flat = Pipeline {
        weighting: NoiseWeighting::Flat,
        ..Pipeline::default()
    };
    let start = fit_delayed(&flat, model, &data.select_lines(&excited)?.without_noise())?;
    let fit = noise_model_ml(start, data, n)?;
    let delayed = fit.model().system();
    if let Some(tau) = delayed.delay(fit.model().split(fit.theta()).0) {
        delayed.check_delay(tau)?;
    }
    Ok(fit)
}

/// Maximum likelihood with a noise model H = C/D of orders (n, n) (McKelvey eq. 26,
/// [`NoiseModelMl`]) from the system estimate `start` and η = 0; H made stable and
/// inversely stable ([`NoiseModel::stabilised`], which leaves the criterion unchanged) and
/// polished once more when a root was reflected; statistics from the innovations
/// (Y − Ŷ)/H (λ estimated).
fn noise_model_ml<M: ModelStructure<f64> + Clone>(
    start: Fit<f64, M>,
    data: &FrequencyData<f64>,
    n: usize,
) -> Result<Fit<f64, WithNoiseModel<M>>, FdidError> {
    let ts = data.ts().ok_or_else(|| FdidError::InvalidArgument {
        name: "ts",
        value: "none".into(),
        reason: "a noise model H(z) is discrete time: the data need a sample time".into(),
    })?;
    let noise = NoiseModel::new(n, n, ts)?;
    fdid::estimate::refine_noise_model(&start, data, noise, &LevenbergMarquardt::default())
}
