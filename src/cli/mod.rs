//! The `fdid` command: argument handling, data preparation, estimation and output.

pub mod args;
mod data;
mod report;

use args::{Cli, Command, CriterionArg, DomainArg, FitArgs, MAX_ORDER};
use fdid::fit::Stage;
use fdid::prelude::*;
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
    }
}

/// `fdid fit`.
fn fit(args: &FitArgs) -> Result<String, Failure> {
    for (name, v) in [("--na", args.na), ("--nb", args.nb)] {
        if v > MAX_ORDER {
            return Err(Failure::usage(format!(
                "invalid {name} {v}: orders above {MAX_ORDER} are not supported"
            )));
        }
    }
    let prepared = data::prepare(args)?;
    let data = &prepared.data;
    let p = args.na + args.nb + 1;
    if 2 * data.len() < p {
        return Err(FdidError::TooFewFrequencies {
            lines: data.len(),
            equations: 2 * data.len(),
            parameters: p,
        }
        .into());
    }
    let model = match (args.domain, prepared.ts) {
        (DomainArg::S, _) => Rational::continuous(args.na, args.nb, data.omega())?,
        (DomainArg::Z, Some(ts)) => Rational::discrete(args.na, args.nb, ts)?,
        (DomainArg::Z, None) => {
            return Err(Failure::usage(
                "--domain z needs a sample time: pass --ts SECONDS".into(),
            ));
        }
    };
    let fit = estimate_with(args.criterion, &model, data)?;
    let out = report::Report::new(args, &prepared, &fit)?;
    Ok(if args.json { out.json() } else { out.text() })
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
                name: "tls".into(),
                solution,
            }];
            Fit::new(model.clone(), data, theta, tls.weighting, stages)?
        }
    })
}
