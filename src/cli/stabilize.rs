//! `fdid stabilize`: the stabilisation diagram of common-pole fits over a range of orders
//! ([`fdid::mimo::diagram_of_fits`]), as text, JSON and SVG.

use super::args::{CommonArgs, LinesArg, MAX_ORDER, StabilizeArgs};
use super::mimo::{Entries, Fitted, banded, options};
use super::{Failure, budget, data};
use fdid::data::FrfMatrix;
use fdid::mimo::{StabilisationDiagram, StabilityTolerances, diagram_of_fits};
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::result::Result;

/// Runs `fdid stabilize`.
pub(super) fn stabilize(args: &StabilizeArgs) -> Result<String, Failure> {
    let orders = parse_orders(&args.orders)?;
    let tolerances = tolerances(args)?;
    if let Some(out) = &args.plot {
        super::refuse_overwrite(&args.data, out, "--plot")?;
    }
    let common = common_args(args, orders[0]);
    let entries = match data::read_entries(&common, false)? {
        Some(e) => e,
        None => {
            let prepared = data::prepare(&common, false, false)?;
            Entries::Matrix {
                matrix: FrfMatrix::from_data(1, 1, vec![prepared.data])?,
                parameter: None,
            }
        }
    };
    let (data, _) = banded(&common, entries)?;
    let options = fdid::mimo::CommonPoleOptions {
        ml: args.ml,
        ..options(&common, data.ts(), args.stable)?
    };
    let tau = std::f64::consts::TAU;
    let band = data
        .omega()
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), w| {
            (lo.min(w / tau), hi.max(w / tau))
        });
    let (diagram, stopped) = budget::fit_common_poles(args.allow_long, || {
        diagram_of_fits(&orders, band, &tolerances, |n| data.fit(n, &options))
    })?;
    if let Some(path) = &args.plot {
        write_plot(path, &data, &diagram)?;
    }
    let report = Report {
        file: args.data.display().to_string(),
        data: &data,
        diagram: &diagram,
        tolerances,
        orders_text: &args.orders,
        stopped,
    };
    Ok(if args.json {
        report.json()?
    } else {
        report.text()
    })
}

/// The orders of `A:B[:STEP]` (STEP 2 by default), each 1 to [`MAX_ORDER`].
fn parse_orders(text: &str) -> Result<Vec<usize>, Failure> {
    let bad = |why: &str| Failure::usage(format!("invalid --orders {text}: {why}"));
    let parts: Vec<&str> = text.split(':').map(str::trim).collect();
    if !(2..=3).contains(&parts.len()) {
        return Err(bad("expected A:B or A:B:STEP (e.g. 2:40 or 1:10:1)"));
    }
    let number = |s: &str, what: &str| -> Result<usize, Failure> {
        s.parse::<usize>()
            .map_err(|_| bad(&format!("{what} `{s}` is not a whole number")))
    };
    let a = number(parts[0], "A")?;
    let b = number(parts[1], "B")?;
    let step = match parts.get(2) {
        Some(s) => number(s, "STEP")?,
        None => 2,
    };
    if a == 0 {
        return Err(bad("the orders start at 1 (a model needs a pole)"));
    }
    if b < a {
        return Err(bad("B is below A"));
    }
    if b > MAX_ORDER {
        return Err(bad(&format!("orders above {MAX_ORDER} are not supported")));
    }
    if step == 0 {
        return Err(bad("STEP must be 1 or more"));
    }
    Ok((a..=b).step_by(step).collect())
}

/// The tolerances of the flags, each checked.
fn tolerances(args: &StabilizeArgs) -> Result<StabilityTolerances<f64>, Failure> {
    for (flag, v, hi) in [
        ("--frequency-tol", args.frequency_tol, 1.0),
        ("--damping-tol", args.damping_tol, f64::INFINITY),
        ("--mac", args.mac, 1.0),
    ] {
        if !(v.is_finite() && v > 0.0 && v <= hi) {
            return Err(Failure::usage(format!(
                "invalid {flag} {v}: must be positive{}",
                if hi.is_finite() { " and at most 1" } else { "" }
            )));
        }
    }
    Ok(StabilityTolerances {
        frequency: args.frequency_tol,
        damping: args.damping_tol,
        mac: args.mac,
        min_orders: args.min_orders.max(1),
    })
}

/// The data flags of `fdid fit` for the data reader and the fit options (`na` = `order`,
/// `nb` = `na` with `--direct`, else `na` − 1).
fn common_args(args: &StabilizeArgs, order: usize) -> CommonArgs {
    CommonArgs {
        data: args.data.clone(),
        domain: args.domain,
        na: order,
        nb: if args.direct { order } else { order - 1 },
        ts: args.ts,
        band: args.band.clone(),
        periods: args.periods,
        delay: false,
        transient: args.transient,
        port: args.port.clone(),
        lines: LinesArg::Excited,
        skip_periods: args.skip_periods,
        realisations: None,
        input: args.input.clone(),
        output: args.output.clone(),
    }
}

struct Report<'a> {
    file: String,
    data: &'a Fitted,
    diagram: &'a StabilisationDiagram<f64>,
    tolerances: StabilityTolerances<f64>,
    orders_text: &'a str,
    stopped: Option<&'static str>,
}

impl Report<'_> {
    fn text(&self) -> String {
        let d = self.diagram;
        let (ny, nu) = self.data.shape();
        let mut w = String::new();
        let _ = writeln!(
            w,
            "file         {} ({ny} outputs x {nu} inputs, {} lines)",
            self.file,
            self.data.omega().len()
        );
        let _ = writeln!(
            w,
            "orders       {} ({} fits{})",
            self.orders_text,
            d.orders.len(),
            if d.failed.is_empty() {
                String::new()
            } else {
                format!(", {} failed", d.failed.len())
            }
        );
        let t = &self.tolerances;
        let _ = writeln!(
            w,
            "tolerances   frequency {} %, damping {} %, MAC {}; a physical mode is stable at {} orders or more",
            100.0 * t.frequency,
            100.0 * t.damping,
            t.mac,
            t.min_orders
        );
        let _ = writeln!(
            w,
            "modes        f_n (Hz) ± spread           damping ± spread      stable at orders"
        );
        if d.modes.is_empty() {
            let _ = writeln!(w, "  none (no cluster of stable poles)");
        }
        for m in &d.modes {
            let _ = writeln!(
                w,
                "  {:.6} ± {:.1e}   {:.5} ± {:.1e}   {} ({}..{})",
                m.f_n_hz,
                m.f_n_spread_hz,
                m.damping,
                m.damping_spread,
                m.orders.len(),
                m.orders[0],
                m.orders[m.orders.len() - 1]
            );
        }
        let _ = writeln!(
            w,
            "diagram      order: f_n (Hz) and mark of each stable pole in the band (o new, f \
             frequency, d + damping, v + shape, s stable)"
        );
        for n in &d.orders {
            let poles: Vec<String> = d
                .poles
                .iter()
                .filter(|p| p.order == *n)
                .map(|p| format!("{:.4}{}", p.mode.f_n_hz, p.mark.letter()))
                .collect();
            let _ = writeln!(w, "  {n:>4}: {}", poles.join(" "));
        }
        for (n, e) in &d.failed {
            let _ = writeln!(w, "failed       order {n}: {e}");
        }
        if let Some(note) = self.stopped {
            let _ = writeln!(w, "note         {note}");
        }
        w
    }

    fn json(&self) -> Result<String, Failure> {
        let d = self.diagram;
        let (ny, nu) = self.data.shape();
        let t = &self.tolerances;
        let v = json!({
            "file": self.file,
            "outputs": ny,
            "inputs": nu,
            "lines": self.data.omega().len(),
            "orders": d.orders,
            "tolerances": {
                "frequency": t.frequency,
                "damping": t.damping,
                "mac": t.mac,
                "min_orders": t.min_orders,
            },
            "poles": d.poles.iter().map(|p| json!({
                "order": p.order,
                "f_n_hz": p.mode.f_n_hz,
                "damping": p.mode.damping,
                "pole": [p.mode.pole.re, p.mode.pole.im],
                "mark": p.mark.letter().to_string(),
            })).collect::<Vec<Value>>(),
            "modes": d.modes.iter().map(|m| json!({
                "f_n_hz": m.f_n_hz,
                "f_n_spread_hz": m.f_n_spread_hz,
                "damping": m.damping,
                "damping_spread": m.damping_spread,
                "orders": m.orders,
            })).collect::<Vec<Value>>(),
            "failed": d.failed.iter().map(|(n, e)| json!({"order": n, "error": e}))
                .collect::<Vec<Value>>(),
            "notes": self.stopped.map(|n| vec![n]).unwrap_or_default(),
        });
        serde_json::to_string_pretty(&v)
            .map(|s| s + "\n")
            .map_err(|e| Failure::runtime(format!("cannot write the JSON report: {e}")))
    }
}

/// `--plot FILE`: the diagram as SVG.
#[cfg(feature = "plot")]
fn write_plot(
    path: &std::path::Path,
    data: &Fitted,
    diagram: &StabilisationDiagram<f64>,
) -> Result<(), Failure> {
    let figure = super::svg::stabilisation(diagram, &data.f_hz(), &data.summed_magnitude());
    super::mimo::write_figure(path, figure, "the stabilisation diagram")
}

/// Without the `plot` feature `--plot` is a usage error.
#[cfg(not(feature = "plot"))]
fn write_plot(
    path: &std::path::Path,
    _: &Fitted,
    _: &StabilisationDiagram<f64>,
) -> Result<(), Failure> {
    Err(Failure::usage(format!(
        "--plot {} needs the `plot` feature (build with default features)",
        path.display()
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orders_are_parsed_with_a_default_step_of_two() {
        assert_eq!(parse_orders("2:8").unwrap(), vec![2, 4, 6, 8]);
        assert_eq!(parse_orders("1:3:1").unwrap(), vec![1, 2, 3]);
        for bad in ["0:4", "4:2", "2:101", "2:8:0", "2", "a:4", "1:2:3:4"] {
            let e = parse_orders(bad).unwrap_err();
            assert_eq!(e.code, 2, "{bad}");
            assert!(e.message.contains(bad), "{}", e.message);
        }
    }
}
