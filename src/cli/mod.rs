//! The `fdid` command: argument handling, data preparation, estimation and output.

pub mod args;
mod budget;
mod data;
mod diagnose;
mod json_arrays;
mod ltv;
pub mod message;
mod mimo;
mod mimo_diagnose;
pub mod progress;
mod report;
mod saved;
mod stabilize;
#[cfg(feature = "plot")]
mod svg;

use args::{Cli, Command, CommonArgs, DomainArg, FitArgs, MAX_ORDER};
use data::Prepared;
use fdid::estimate::{DelayRange, Method, ModelSpec, Stability};
use fdid::prelude::*;
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
        Command::Ltv(args) => ltv::ltv(args),
        Command::Stabilize(args) => stabilize::stabilize(args),
    }
}

/// Refuses an output file `out` (of `flag`) that is the data file `data` itself, before
/// any work: writing it would destroy the measurement.
fn refuse_overwrite(
    data: &std::path::Path,
    out: &std::path::Path,
    flag: &str,
) -> Result<(), Failure> {
    let same = match (std::fs::canonicalize(data), std::fs::canonicalize(out)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if same {
        return Err(Failure::usage(format!(
            "{flag} {} is the data file: writing it would overwrite the measurement (choose \
             another file name)",
            out.display()
        )));
    }
    Ok(())
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

/// `fdid fit`: the flags as a [`ModelSpec`] (a delay over the unbounded range), its fit
/// ([`ModelSpec::fit`]) and the report.
fn fit(args: &FitArgs) -> Result<String, Failure> {
    let c = &args.common;
    check_orders(&[
        ("--na", c.na),
        ("--nb", c.nb),
        ("--noise-order", args.noise_order.unwrap_or(0)),
    ])?;
    let criterion = Method::from(args.criterion);
    check_combinations(c, criterion, args.noise_order)?;
    for (flag, out) in [("--plot", &args.plot), ("--save", &args.save)] {
        if let Some(out) = out {
            refuse_overwrite(&c.data, out, flag)?;
        }
    }
    if let Some(entries) = data::read_entries(c, args.full_covariance)? {
        return mimo::fit(args, entries);
    }
    if args.enforce_passivity {
        return Err(Failure::usage(
            "--enforce-passivity applies to S-parameter data fitted on every entry with \
             common poles (a Touchstone file of S without --port)"
                .to_string(),
        ));
    }
    let prepared = data::prepare(c, args.noise_order.is_some(), false)?;
    let file = c.data.display().to_string();
    let spec = ModelSpec {
        domain: prepared.domain,
        na: c.na,
        nb: c.nb,
        delay: c.delay,
        delay_range: DelayRange::Unbounded,
        transient: c.transient,
        noise_order: args.noise_order,
        criterion,
        stability: if args.stable {
            Stability::Enforced
        } else {
            Stability::Free
        },
    };
    check_data_kind(&spec, &file, &prepared)?;
    let (fitted, stopped) = budget::fit(&spec, &prepared.data, args.allow_long)?;
    let mut report = Report::of(&spec, &file, &prepared, &prepared.data, &fitted)?;
    if let Some(note) = stopped {
        report.add_note(note.into());
    }
    if let Some(path) = &args.plot {
        write_plot(path, &prepared, &report)?;
    }
    if let Some(path) = &args.save {
        let unresolved: Vec<Complex<f64>> = report.unresolved().iter().map(|u| u.pole).collect();
        saved::write(
            path,
            &saved::saved(&fitted, spec.domain, &file, &unresolved, report.marginal())?,
        )?;
    }
    Ok(if args.json {
        report.json()
    } else {
        report.text()
    })
}

/// The model domain of `--domain` with the model's sample time (z only).
fn domain(arg: DomainArg, ts: Option<f64>) -> Result<Domain<f64>, Failure> {
    match (arg, ts) {
        (DomainArg::S, _) => Ok(Domain::Continuous),
        (DomainArg::Z, Some(ts)) => Ok(Domain::Discrete { ts }),
        (DomainArg::Z, None) => Err(Failure::usage(
            "--domain z needs a sample time: pass --ts SECONDS".into(),
        )),
    }
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
    progress::write_atomic(path, figure.as_bytes())
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

/// Rejects the combinations of flags the estimators do not compose, naming both flags:
/// the model flags `common` with the criterion and the noise-model order.
fn check_combinations(
    common: &CommonArgs,
    criterion: Method,
    noise_order: Option<usize>,
) -> Result<(), Failure> {
    let c = criterion.name();
    if let Some(n) = noise_order {
        if n == 0 {
            return Err(Failure::usage(
                "invalid --noise-order 0: the noise model H = C/D needs order 1 or more \
                 (without --noise-order the noise is taken as white)"
                    .into(),
            ));
        }
        if criterion != Method::Ml {
            return Err(Failure::usage(format!(
                "--noise-order cannot be combined with --criterion {c}: the noise model is \
                 estimated by maximum likelihood (--criterion ml)"
            )));
        }
        if let Some(p) = common.periods.filter(|p| *p >= 2) {
            return Err(Failure::usage(format!(
                "--noise-order cannot be combined with --periods {p}: the noise model is \
                 estimated from one record (drop --periods, or use --periods {p} without \
                 --noise-order to weight by the nonparametric noise variances)"
            )));
        }
    }
    if common.delay && !matches!(criterion, Method::Ml | Method::Eiv) {
        return Err(Failure::usage(format!(
            "--delay cannot be combined with --criterion {c}: the delay enters nonlinearly \
             and is fitted by --criterion ml or eiv"
        )));
    }
    if common.transient && common.domain == DomainArg::S && common.nb > common.na {
        return Err(Failure::usage(format!(
            "--transient with --domain s needs --nb <= --na (the partial-fraction form), \
             got --na {} --nb {}",
            common.na, common.nb
        )));
    }
    Ok(())
}

/// Rejects what the kind of data at hand (from `file`) cannot serve in `spec`.
fn check_data_kind(spec: &ModelSpec, file: &str, prepared: &Prepared) -> Result<(), Failure> {
    if !prepared.time_record {
        if spec.transient {
            return Err(Failure::usage(format!(
                "--transient needs a time record (t,u,y): the transient of a non-periodic \
                 record is modelled on its DFT, but {file} holds frequency data"
            )));
        }
        if let Some(n) = spec.noise_order {
            return Err(Failure::usage(format!(
                "--noise-order {n} needs a time record (t,u,y): the noise model is estimated \
                 from the DFT of one record, but {file} holds frequency data"
            )));
        }
    }
    if spec.criterion == Method::Eiv {
        check_input_noise(file, prepared)?;
    }
    if spec.transient && spec.domain == Domain::Continuous && prepared.record_ts.is_none() {
        return Err(Failure::usage(
            "--transient needs a time record (t,u,y) for its sample time".into(),
        ));
    }
    Ok(())
}

/// Rejects data without input noise variances for `--criterion eiv`.
fn check_input_noise(file: &str, prepared: &Prepared) -> Result<(), Failure> {
    match prepared.data.noise() {
        None => Err(Failure::usage(format!(
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
        ))),
        Some(noise) if noise.var_u.iter().all(|v| *v == 0.0) => Err(Failure::runtime(format!(
            "--criterion eiv: the input noise variance var_u is zero on every line of \
             {file}: there is no input noise to model; use --criterion ml"
        ))),
        Some(_) => Ok(()),
    }
}
