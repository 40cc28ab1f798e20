//! `fdid diagnose` on every entry of a multi-port file or FRF matrix: the common-pole
//! workflow of [`fdid::workflow::diagnose_common_poles`] — per-entry cost and whiteness
//! verdicts, the missing resonance across entries, the pole pairs it adds.

use super::args::DiagnoseArgs;
use super::mimo::{Entries, Fitted, banded, options};
use super::{Failure, budget};
use fdid::workflow::{CommonPoleCheck, CommonPoleDiagnosis, diagnose_common_poles};
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::result::Result;

/// Runs the common-pole workflow on `entries` and reports it.
pub(super) fn diagnose(args: &DiagnoseArgs, entries: Entries) -> Result<String, Failure> {
    let c = &args.common;
    if matches!(entries, Entries::Spectra(_)) {
        return Err(Failure::usage(
            "diagnose compares a model with frequency response data entry by entry; a record \
             with several inputs has no FRF per entry: fit it with `fdid fit --input U1,U2 \
             --output Y1,Y2 --transient`"
                .into(),
        ));
    }
    check_flags(args)?;
    let (data, _) = banded(c, entries)?;
    let Fitted::Matrix(matrix) = &data else {
        unreachable!("spectra were refused above")
    };
    // the sample time of --domain z: the data's (a time record's t column) or --ts
    let options = options(c, data.ts(), args.stable)?;
    let (diagnosis, stopped) = budget::fit_common_poles(args.allow_long, || {
        diagnose_common_poles(matrix, c.na, &options, args.alpha, args.max_steps)
    })?;
    let report = Report {
        file: c.data.display().to_string(),
        shape: data.shape(),
        lines: matrix.len(),
        alpha: args.alpha,
        diagnosis: &diagnosis,
        stopped,
    };
    Ok(if args.json {
        report.json()?
    } else {
        report.text()
    })
}

/// The flags the common-pole workflow does not take.
fn check_flags(args: &DiagnoseArgs) -> Result<(), Failure> {
    let c = &args.common;
    let refused = [
        (c.delay, "--delay"),
        (c.transient, "--transient"),
        (args.report.is_some(), "--report"),
    ];
    if let Some((_, flag)) = refused.iter().find(|(on, _)| *on) {
        return Err(Failure::usage(format!(
            "{flag} is not available for the workflow on every entry with common poles (pick \
             one entry with --port IJ for it)"
        )));
    }
    if c.nb + 1 != c.na && c.nb != c.na {
        return Err(Failure::usage(format!(
            "the workflow on every entry is in partial fractions: --nb {} with --na {} must \
             be {} (strictly proper) or {} (with a direct term)",
            c.nb,
            c.na,
            c.na.saturating_sub(1),
            c.na
        )));
    }
    Ok(())
}

struct Report<'a> {
    file: String,
    shape: (usize, usize),
    lines: usize,
    alpha: f64,
    diagnosis: &'a CommonPoleDiagnosis,
    stopped: Option<&'static str>,
}

/// "ok" when neither the cost nor the whiteness test rejects at `alpha`.
fn verdict(cost_p: Option<f64>, white_p: Option<f64>, alpha: f64) -> &'static str {
    if cost_p.is_some_and(|p| p < alpha) || white_p.is_some_and(|p| p < alpha) {
        "model error"
    } else {
        "ok"
    }
}

fn optional(v: Option<f64>) -> String {
    v.map_or("-".into(), |p| format!("{p:.3}"))
}

impl Report<'_> {
    fn resonance_text(check: &CommonPoleCheck, alpha: f64) -> String {
        match &check.resonance {
            Some(r) => format!(
                "shared residual excess p = {:.3} at {:.6} Hz ({} lines, {:.3e} Hz wide){}",
                r.p_value,
                r.peak_hz,
                r.lines,
                r.width_hz,
                if check.relative_misfit < fdid::workflow::EXACT_FIT {
                    ", within the data's printed precision"
                } else if r.p_value < alpha {
                    ": missing resonance"
                } else {
                    ""
                }
            ),
            None => "too few lines for the resonance scan".into(),
        }
    }

    fn text(&self) -> String {
        let d = self.diagnosis;
        let a = self.alpha;
        let (ny, nu) = self.shape;
        let mut w = String::new();
        let _ = writeln!(
            w,
            "file         {} ({ny} outputs x {nu} inputs, {} entries, {} lines)",
            self.file,
            ny * nu,
            self.lines
        );
        for (s, step) in d.steps.iter().enumerate() {
            let lr = step.lr.as_ref().map_or(String::new(), |t| {
                format!(
                    "; likelihood ratio {:.3} (dof {}) p = {:.3e}: {}",
                    t.statistic,
                    t.dof,
                    t.p_value,
                    if step.accepted {
                        "accepted"
                    } else {
                        "rejected"
                    }
                )
            });
            let _ = writeln!(
                w,
                "step {}       {} common poles: cost {:.6e}, relative misfit {:.2e}{lr}",
                s + 1,
                step.order,
                step.fit.cost,
                step.check.relative_misfit
            );
            let _ = writeln!(w, "             {}", Self::resonance_text(&step.check, a));
        }
        let result = d.result();
        let _ = writeln!(w, "result       {} common poles ({})", result.order, d.stop);
        let _ = writeln!(
            w,
            "entries      output input  cost        E cost      p(cost)  whiteness p  verdict"
        );
        for e in &result.check.entries {
            let v = &e.validation;
            let _ = writeln!(
                w,
                "  {:>6} {:>5}  {:.4e}  {}  {:>7}  {:>11}  {}",
                e.output,
                e.input,
                v.cost,
                v.cost_expected
                    .map_or("-         ".into(), |x| format!("{x:.4e}")),
                optional(v.cost_p),
                optional(v.whiteness_p),
                verdict(v.cost_p, v.whiteness_p, a)
            );
        }
        if !result.check.noise_known {
            let _ = writeln!(
                w,
                "note         no noise variances: each entry's residuals are normalised by their RMS (no cost test)"
            );
        }
        let _ = writeln!(w, "modes        f_n (Hz)     damping");
        if let Ok(modes) = result.fit.model.modes() {
            for m in modes {
                let _ = writeln!(w, "  {:.6}   {:.5}", m.f_n_hz, m.damping);
            }
        }
        if let Some(note) = self.stopped {
            let _ = writeln!(w, "note         {note}");
        }
        w
    }

    fn json(&self) -> Result<String, Failure> {
        let d = self.diagnosis;
        let a = self.alpha;
        let check_json = |check: &CommonPoleCheck| -> Value {
            json!({
                "resonance": check.resonance.as_ref().map(|r| json!({
                    "peak_hz": r.peak_hz,
                    "width_hz": r.width_hz,
                    "lines": r.lines,
                    "p_value": r.p_value,
                    "found": r.p_value < a,
                    "shares": r.shares,
                })),
                "noise_known": check.noise_known,
                "relative_misfit": check.relative_misfit,
                "entries": check.entries.iter().map(|e| {
                    let v = &e.validation;
                    json!({
                        "output": e.output,
                        "input": e.input,
                        "cost": v.cost,
                        "cost_expected": v.cost_expected,
                        "cost_p": v.cost_p,
                        "whiteness_p": v.whiteness_p,
                        "max_residual": v.max_residual,
                        "verdict": verdict(v.cost_p, v.whiteness_p, a),
                    })
                }).collect::<Vec<Value>>(),
            })
        };
        let steps: Vec<Value> = d
            .steps
            .iter()
            .map(|s| {
                json!({
                    "order": s.order,
                    "cost": s.fit.cost,
                    "accepted": s.accepted,
                    "lr": s.lr.as_ref().map(|t| json!({
                        "statistic": t.statistic, "dof": t.dof, "p_value": t.p_value
                    })),
                    "check": check_json(&s.check),
                })
            })
            .collect();
        let result = d.result();
        let modes: Vec<Value> = result
            .fit
            .model
            .modes()
            .map_err(Failure::from)?
            .iter()
            .map(|m| {
                json!({"f_n_hz": m.f_n_hz, "damping": m.damping,
                            "pole": [m.pole.re, m.pole.im]})
            })
            .collect();
        let v = json!({
            "file": self.file,
            "outputs": self.shape.0,
            "inputs": self.shape.1,
            "lines": self.lines,
            "alpha": a,
            "steps": steps,
            "result": {
                "order": result.order,
                "cost": result.fit.cost,
                "stable": result.fit.model.poles.is_stable(result.fit.model.domain),
                "modes": modes,
                "check": check_json(&result.check),
            },
            "stop": d.stop,
            "notes": self.stopped.map(|n| vec![n]).unwrap_or_default(),
        });
        serde_json::to_string_pretty(&v)
            .map(|s| s + "\n")
            .map_err(|e| Failure::runtime(format!("cannot write the JSON report: {e}")))
    }
}
