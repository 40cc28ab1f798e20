//! `fdid fit` on every entry of a multi-port file: a common-pole model ([`fdid::mimo`]),
//! its modes, residue matrices, state-space realisation and per-entry errors.

use super::args::{CriterionArg, DomainArg, FitArgs, parse_band};
use super::{Failure, budget};
use fdid::data::FrfMatrix;
use fdid::io::NetworkParameter;
use fdid::mimo::{CommonPoleFit, CommonPoleOptions, MlOutcome, passivity};
use fdid::prelude::*;
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::result::Result;

/// Grid points of the passivity check of scattering data.
const PASSIVITY_POINTS: usize = 4000;

/// A multi-entry data set: the matrix, and the network parameter for Touchstone data.
pub(super) struct Entries {
    pub matrix: FrfMatrix<f64>,
    pub parameter: Option<NetworkParameter>,
}

/// Fits the common-pole model the flags name to every entry and reports it.
pub(super) fn fit(args: &FitArgs, entries: Entries) -> Result<String, Failure> {
    let c = &args.common;
    check_flags(args)?;
    let mut matrix = entries.matrix;
    if let Some(band) = &c.band {
        let (lo, hi) = parse_band(band).map_err(Failure::usage)?;
        matrix = matrix
            .band_hz(lo.unwrap_or(0.0), hi.unwrap_or(f64::INFINITY))
            .map_err(Failure::from)?;
    }
    let domain = super::domain(c.domain, c.ts.or(matrix.ts()))?;
    let options = CommonPoleOptions {
        domain,
        direct: c.nb == c.na,
        stable: args.stable,
        ..CommonPoleOptions::default()
    };
    let (fit, stopped) = budget::fit_common_poles(&matrix, c.na, &options, args.allow_long)?;
    let report = Report {
        file: c.data.display().to_string(),
        matrix: &matrix,
        fit: &fit,
        parameter: entries.parameter,
        stopped,
    };
    Ok(if args.json {
        report.json()?
    } else {
        report.text()?
    })
}

/// The flags a common-pole fit does not take, each refused with what to do instead.
fn check_flags(args: &FitArgs) -> Result<(), Failure> {
    let c = &args.common;
    let one_entry = "pick one entry with --port IJ for it";
    let refused = [
        (c.delay, "--delay"),
        (c.transient, "--transient"),
        (args.noise_order.is_some(), "--noise-order"),
        (
            args.criterion != CriterionArg::Ml,
            "--criterion other than ml",
        ),
        (args.save.is_some(), "--save"),
        (args.plot.is_some(), "--plot"),
    ];
    if let Some((_, flag)) = refused.iter().find(|(on, _)| *on) {
        return Err(Failure::usage(format!(
            "{flag} is not available for a fit of every entry with common poles ({one_entry})"
        )));
    }
    if c.nb + 1 != c.na && c.nb != c.na {
        return Err(Failure::usage(format!(
            "a fit of every entry with common poles is in partial fractions: --nb {} with \
             --na {} must be {} (strictly proper) or {} (with a direct term)",
            c.nb,
            c.na,
            c.na.saturating_sub(1),
            c.na
        )));
    }
    if c.domain == DomainArg::Z && c.ts.is_none() {
        return Err(Failure::usage(
            "--domain z needs a sample time: pass --ts SECONDS".into(),
        ));
    }
    Ok(())
}

struct Report<'a> {
    file: String,
    matrix: &'a FrfMatrix<f64>,
    fit: &'a CommonPoleFit<f64>,
    parameter: Option<NetworkParameter>,
    stopped: Option<&'static str>,
}

/// Per entry: (output, input) 1-based, RMS error and RMS of the data.
fn entry_errors(
    matrix: &FrfMatrix<f64>,
    fit: &CommonPoleFit<f64>,
) -> Vec<(usize, usize, f64, f64)> {
    let g = fit.model.response(matrix.omega());
    matrix
        .entries()
        .iter()
        .enumerate()
        .map(|(e, entry)| {
            let (i, j) = matrix.position(e);
            let n = entry.len() as f64;
            let err = entry
                .y()
                .iter()
                .zip(&g)
                .map(|(h, m)| (h - m[(i, j)]).norm_sqr())
                .sum::<f64>();
            let size = entry.y().iter().map(|h| h.norm_sqr()).sum::<f64>();
            (i + 1, j + 1, (err / n).sqrt(), (size / n).sqrt())
        })
        .collect()
}

fn ml_text(ml: MlOutcome) -> &'static str {
    match ml {
        MlOutcome::Skipped => "skipped",
        MlOutcome::Kept { converged: true } => "kept",
        MlOutcome::Kept { converged: false } => "kept (stopped before converging)",
        MlOutcome::Failed => "not kept (it did not lower the cost)",
        MlOutcome::Unstable => "not kept (unstable under --stable)",
    }
}

fn pair(c: Complex<f64>) -> Value {
    json!([c.re, c.im])
}

fn matrix_json(m: &nalgebra::DMatrix<f64>) -> Value {
    Value::Array(
        (0..m.nrows())
            .map(|i| json!((0..m.ncols()).map(|j| m[(i, j)]).collect::<Vec<f64>>()))
            .collect(),
    )
}

impl Report<'_> {
    fn stable(&self) -> bool {
        self.fit.model.poles.is_stable(self.fit.model.domain)
    }

    fn passivity(&self) -> Option<fdid::mimo::Passivity<f64>> {
        (self.parameter == Some(NetworkParameter::S)).then(|| {
            let f_max =
                self.matrix.omega().iter().copied().fold(0.0, f64::max) / std::f64::consts::TAU;
            passivity(&self.fit.model, f_max, PASSIVITY_POINTS)
        })
    }

    fn text(&self) -> Result<String, Failure> {
        let fit = self.fit;
        let model = &fit.model;
        let mut w = String::new();
        let _ = writeln!(
            w,
            "file         {} ({} outputs x {} inputs, {} entries, {} lines)",
            self.file,
            model.ny(),
            model.nu(),
            fit.entries,
            fit.lines
        );
        let _ = writeln!(
            w,
            "model        common poles, order {} in {}{}, {} relocations, ML {}",
            model.order(),
            if model.domain == Domain::Continuous {
                "s"
            } else {
                "z"
            },
            if model.direct.is_some() {
                " with a direct term"
            } else {
                ""
            },
            fit.relocations,
            ml_text(fit.ml)
        );
        let _ = writeln!(
            w,
            "cost         {:.6e} ({}); rms error {:.6e}",
            fit.cost,
            if fit.weighted {
                "weighted by the variances"
            } else {
                "unweighted"
            },
            fit.rms(self.matrix)
        );
        let modes = model.modes().map_err(Failure::from)?;
        let std = fit.mode_std();
        let _ = writeln!(
            w,
            "modes        f_n (Hz)          damping        shape (|u| per output)"
        );
        let slots = model.poles.slots();
        for m in &modes {
            let sd = std.as_ref().and_then(|s| {
                let slot = slots.iter().position(|p| match model.domain {
                    Domain::Continuous => (*p - m.pole).norm() == 0.0,
                    Domain::Discrete { .. } => false,
                })?;
                s.get(slot).copied()
            });
            let f = match sd {
                Some((sf, sz)) => format!(
                    "{:.6} ± {:.2e}   {:.5} ± {:.1e}",
                    m.f_n_hz, sf, m.damping, sz
                ),
                None => format!("{:.6}   {:.5}", m.f_n_hz, m.damping),
            };
            let shape: Vec<String> = m.shape.iter().map(|u| format!("{:.3}", u.norm())).collect();
            let _ = writeln!(w, "  {f}   [{}]", shape.join(", "));
        }
        let _ = writeln!(w, "entries      output input  rms error      rms of data");
        for (i, j, err, size) in entry_errors(self.matrix, fit) {
            let _ = writeln!(w, "  {i:>6} {j:>5}  {err:.6e}   {size:.6e}");
        }
        let _ = writeln!(
            w,
            "state space  {} states (A {0}x{0}, B {0}x{1}, C {2}x{0}, D {2}x{1}; in --json)",
            model.order() * model.nu(),
            model.nu(),
            model.ny()
        );
        if let Some(p) = self.passivity() {
            let _ = writeln!(
                w,
                "passivity    max singular value of S {:.6} at {:.6e} Hz: {} ({} of {} grid points above 1 + 1e-6)",
                p.max_singular_value,
                p.at_hz,
                if p.passive() {
                    "passive"
                } else {
                    "NOT passive"
                },
                p.violations,
                p.points
            );
        }
        if !self.stable() {
            let _ = writeln!(
                w,
                "warning      the model is unstable (a pole in the right half plane or outside the unit circle); --stable fits a stable one"
            );
        }
        if let Some(note) = self.stopped {
            let _ = writeln!(w, "note         {note}");
        }
        Ok(w)
    }

    fn json(&self) -> Result<String, Failure> {
        let fit = self.fit;
        let model = &fit.model;
        let modes = model.modes().map_err(Failure::from)?;
        let ss = model.state_space();
        let g = model.response(self.matrix.omega());
        let f_hz = self
            .matrix
            .omega()
            .iter()
            .map(|w| w / std::f64::consts::TAU);
        let f_hz: Vec<f64> = f_hz.collect();
        let errors = entry_errors(self.matrix, fit);
        let entries: Vec<Value> = errors
            .iter()
            .map(|(i, j, err, size)| {
                let frf: Vec<Value> = f_hz
                    .iter()
                    .zip(&g)
                    .map(|(f, m)| {
                        let v = m[(i - 1, j - 1)];
                        json!([f, v.re, v.im])
                    })
                    .collect();
                json!({"output": i, "input": j, "rms_error": err, "rms_data": size, "frf": frf})
            })
            .collect();
        let residues: Vec<Value> = model
            .residues
            .iter()
            .map(|r| {
                Value::Array(
                    (0..r.nrows())
                        .map(|i| Value::Array((0..r.ncols()).map(|j| pair(r[(i, j)])).collect()))
                        .collect(),
                )
            })
            .collect();
        let std = fit.mode_std();
        let modes_json: Vec<Value> = modes
            .iter()
            .map(|m| {
                json!({
                    "pole": pair(m.pole),
                    "f_n_hz": m.f_n_hz,
                    "damping": m.damping,
                    "shape": m.shape.iter().map(|c| pair(*c)).collect::<Vec<_>>(),
                    "participation": m.participation.iter().map(|c| pair(*c)).collect::<Vec<_>>(),
                    "rank_one_error": m.rank_one_error,
                })
            })
            .collect();
        let slot_std: Value = match &std {
            Some(s) => json!(
                s.iter()
                    .map(|(f, z)| json!({"f_n_std_hz": f, "damping_std": z}))
                    .collect::<Vec<_>>()
            ),
            None => Value::Null,
        };
        let passivity = self.passivity().map(|p| {
            json!({
                "max_singular_value": p.max_singular_value,
                "at_hz": p.at_hz,
                "passive": p.passive(),
                "violations": p.violations,
                "points": p.points,
            })
        });
        let v = json!({
            "file": self.file,
            "model": "common_poles",
            "domain": if model.domain == Domain::Continuous { "s" } else { "z" },
            "order": model.order(),
            "outputs": model.ny(),
            "inputs": model.nu(),
            "lines": fit.lines,
            "poles": model.poles.all().iter().map(|p| pair(*p)).collect::<Vec<_>>(),
            "stable": self.stable(),
            "pole_slots": model.poles.slots().iter().map(|p| pair(*p)).collect::<Vec<_>>(),
            "pole_slot_std": slot_std,
            "residues": residues,
            "direct": model.direct.as_ref().map(matrix_json),
            "modes": modes_json,
            "state_space": {
                "a": matrix_json(&ss.a),
                "b": matrix_json(&ss.b),
                "c": matrix_json(&ss.c),
                "d": matrix_json(&ss.d),
            },
            "cost": fit.cost,
            "weighted": fit.weighted,
            "rms_error": fit.rms(self.matrix),
            "relocations": fit.relocations,
            "ml": ml_text(fit.ml),
            "passivity": passivity,
            "entries": entries,
            "notes": self.stopped.map(|n| vec![n]).unwrap_or_default(),
        });
        serde_json::to_string_pretty(&v)
            .map(|s| s + "\n")
            .map_err(|e| Failure::runtime(format!("cannot write the JSON report: {e}")))
    }
}
