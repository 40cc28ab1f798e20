//! `fdid fit --save FILE` and `fdid eval FILE`: a fitted model saved as JSON and evaluated
//! later, without the data.

use super::Failure;
use super::args::EvalArgs;
use super::mimo::matrix_json as rows;
use fdid::estimate::RationalFit;
use fdid::fitted::FittedModel;
use fdid::mimo::CommonPoleModel;
use fdid::model::{Delayed, WithNoiseModel};
use fdid::prelude::*;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::result::Result;

use fdid::fitted::{SAVED_FORMAT as FORMAT, SAVED_VERSION as VERSION};

/// The saved-model JSON object of `fit`, a fit in `domain` of the data in `source`:
/// `{"format":"fdid-model","version":1,"kind":..,"domain":"s"|"z","ts":x|null,
/// "source":FILE,"fitted":{model,theta,covariance,noise_variance,noise_known,cost,lines},
/// "unresolved_poles":[[re,im],..],"marginal_poles":[[re,im],..]}` with `unresolved`, the
/// poles the data did not resolve ([`Fit::unresolved_poles`]), and `marginal`, the stable
/// poles on the stability boundary ([`fdid::validation::marginal_poles`]); files without
/// the keys have none.
pub fn saved(
    fit: &RationalFit,
    domain: Domain<f64>,
    source: &str,
    unresolved: &[Complex<f64>],
    marginal: &[Complex<f64>],
) -> Result<Value, Failure> {
    let fitted = match fit {
        RationalFit::Plain(f) => fitted(f),
        RationalFit::Delayed(f) => fitted(f),
        RationalFit::NoiseModel(f) => fitted(f),
        RationalFit::DelayedNoiseModel(f) => fitted(f),
    }?;
    let (domain, ts) = match domain {
        Domain::Continuous => ("s", None),
        Domain::Discrete { ts } => ("z", Some(ts)),
    };
    Ok(json!({
        "format": FORMAT,
        "version": VERSION,
        "kind": fit.kind(),
        "domain": domain,
        "ts": ts,
        "source": source,
        "fitted": fitted,
        "unresolved_poles": pole_list(unresolved),
        "marginal_poles": pole_list(marginal),
    }))
}

/// The saved-model JSON object of a common-pole model fitted to every entry of the data in
/// `source`: `{"format":"fdid-model","version":1,"kind":"common_poles","domain":"s"|"z",
/// "ts":x|null,"source":FILE,"model":{domain,poles,residues,direct},"state_space":{a,b,c,d},
/// "matrix_fraction":{denominator,numerators}|null}` (the fields of
/// [`fdid::mimo::CommonPoleModel`]; the realisation and the common-denominator form are
/// for other tools: `fdid eval` reads `model`; the form is null when its coefficients
/// overflow, [`fdid::mimo::MatrixFraction::is_finite`]).
pub fn common_poles(model: &CommonPoleModel<f64>, source: &str) -> Result<Value, Failure> {
    let ss = model.state_space();
    let mf = model.matrix_fraction();
    let (domain, ts) = match model.domain {
        Domain::Continuous => ("s", None),
        Domain::Discrete { ts } => ("z", Some(ts)),
    };
    Ok(json!({
        "format": FORMAT,
        "version": VERSION,
        "kind": COMMON_POLES,
        "domain": domain,
        "ts": ts,
        "source": source,
        "model": serde_json::to_value(model)
            .map_err(|e| Failure::runtime(format!("cannot serialise the model: {e}")))?,
        "state_space": {
            "a": rows(&ss.a), "b": rows(&ss.b), "c": rows(&ss.c), "d": rows(&ss.d)
        },
        "matrix_fraction": mf.is_finite().then(|| {
            json!({"denominator": mf.denominator, "numerators": mf.numerators})
        }),
    }))
}

/// The `kind` of a saved common-pole model.
const COMMON_POLES: &str = "common_poles";

/// The `fitted` object of a saved model ([`FittedModel`]).
fn fitted<M: ModelStructure<f64> + Clone + Serialize>(fit: &Fit<f64, M>) -> Result<Value, Failure> {
    serde_json::to_value(FittedModel::of_fit(fit))
        .map_err(|e| Failure::runtime(format!("cannot serialise the fitted model: {e}")))
}

/// Poles as `[[re, im], …]` (null for a part that is not finite).
fn pole_list(poles: &[Complex<f64>]) -> Value {
    Value::Array(
        poles
            .iter()
            .map(|p| json!([finite(p.re), finite(p.im)]))
            .collect(),
    )
}

/// The keys of a saved-model object read besides `fitted`, each with a default so that
/// files written before the key existed still read.
#[derive(Debug, Serialize, Deserialize)]
struct Envelope {
    /// The poles the data did not resolve (one of each conjugate pair), `[re, im]` each.
    #[serde(default)]
    unresolved_poles: Vec<Complex<f64>>,
    /// The stable poles on the stability boundary (one of each conjugate pair).
    #[serde(default)]
    marginal_poles: Vec<Complex<f64>>,
    /// The sample time of a discrete-time model (s).
    #[serde(default)]
    ts: Option<f64>,
}

impl Envelope {
    /// A warning when frequencies of `f_hz` lie above the Nyquist frequency of a
    /// discrete-time model, where its response only repeats that below it.
    fn nyquist_warning(&self, f_hz: &[f64]) -> Option<String> {
        let ts = self.ts.filter(|t| t.is_finite() && *t > 0.0)?;
        let nyquist = 0.5 / ts;
        let above = f_hz
            .iter()
            .filter(|f| **f > nyquist * (1.0 + 1e-12))
            .count();
        (above > 0).then(|| {
            format!(
                "{above} of the {} frequencies lie above the Nyquist frequency 1/(2 Ts) = \
                 {nyquist} Hz of this discrete-time model (Ts = {ts} s): there its response \
                 repeats the one below (it is periodic in f with period 1/Ts)",
                f_hz.len()
            )
        })
    }
}

/// Writes `value` to `path`.
pub fn write(path: &std::path::Path, value: &Value) -> Result<(), Failure> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| Failure::runtime(format!("cannot serialise the fitted model: {e}")))?;
    super::progress::write_atomic(path, (text + "\n").as_bytes())
        .map_err(|e| Failure::runtime(format!("cannot write {}: {e}", path.display())))
}

/// `fdid eval MODEL --freq ...`: the response of a saved model, as CSV `f,re,im[,std]` or
/// as JSON `{"frf":[[f,re,im],..],"frf_std":[..]|null}`.
pub fn eval(args: &EvalArgs) -> Result<String, Failure> {
    let name = args.model.display().to_string();
    let f_hz = parse_freq(&args.freq).map_err(Failure::usage)?;
    let (value, envelope) = read(&args.model, &name)?;
    let omega: Vec<f64> = f_hz.iter().map(|f| std::f64::consts::TAU * f).collect();
    if value["kind"] == COMMON_POLES {
        return eval_common_poles(args, &f_hz, &value, &envelope, &name);
    }
    let fitted = &value["fitted"];
    let response = match value["kind"].as_str() {
        Some("rational") => respond::<Rational<f64>>(fitted, &omega, &name)?,
        Some("delayed") => respond::<Delayed<Rational<f64>>>(fitted, &omega, &name)?,
        Some("noise_model") => respond::<WithNoiseModel<Rational<f64>>>(fitted, &omega, &name)?,
        Some("delayed_noise_model") => {
            respond::<WithNoiseModel<Delayed<Rational<f64>>>>(fitted, &omega, &name)?
        }
        _ => {
            return Err(Failure::runtime(format!(
                "{name}: unknown model kind {}",
                value["kind"]
            )));
        }
    };
    Ok(if args.json {
        eval_json(&f_hz, &response, &envelope)
    } else {
        eval_csv(&f_hz, &response, &envelope, &value, &name)
    })
}

/// `fdid eval` of a saved common-pole model: every entry's response, as CSV in the
/// matrix layout `f,re_11,im_11,re_21,im_21,…` (`re_I_J` beyond 9; `fdid fit` reads it
/// back) or as JSON `{"entries":[{"output":i,"input":j,"frf":[[f,re,im],..]},..],
/// "warnings":[..]}`, entries column by column.
fn eval_common_poles(
    args: &EvalArgs,
    f_hz: &[f64],
    value: &Value,
    envelope: &Envelope,
    name: &str,
) -> Result<String, Failure> {
    let model: CommonPoleModel<f64> = serde_json::from_value(value["model"].clone())
        .map_err(|e| Failure::runtime(format!("{name}: bad saved model: {e}")))?;
    model
        .check()
        .map_err(|e| Failure::runtime(format!("{name}: bad saved model: {e}")))?;
    let omega: Vec<f64> = f_hz.iter().map(|f| std::f64::consts::TAU * f).collect();
    let g = model.response(&omega);
    let (ny, nu) = (model.ny(), model.nu());
    let pairs: Vec<(usize, usize)> = (0..nu).flat_map(|j| (0..ny).map(move |i| (i, j))).collect();
    let warnings: Vec<String> = envelope.nyquist_warning(f_hz).into_iter().collect();
    if args.json {
        let entries: Vec<Value> = pairs
            .iter()
            .map(|&(i, j)| {
                let frf: Vec<Value> = f_hz
                    .iter()
                    .zip(&g)
                    .map(|(f, m)| json!([f, finite(m[(i, j)].re), finite(m[(i, j)].im)]))
                    .collect();
                json!({"output": i + 1, "input": j + 1, "frf": frf})
            })
            .collect();
        return Ok(json!({"entries": entries, "warnings": warnings}).to_string() + "\n");
    }
    let label = |i: usize, j: usize| {
        if ny > 9 || nu > 9 {
            format!("{}_{}", i + 1, j + 1)
        } else {
            format!("{}{}", i + 1, j + 1)
        }
    };
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# common_poles model from {name} ({}): {ny} outputs x {nu} inputs, f in Hz",
        value["source"].as_str().unwrap_or("")
    );
    for w in &warnings {
        let _ = writeln!(out, "# warning: {w}");
    }
    out.push('f');
    for &(i, j) in &pairs {
        let l = label(i, j);
        let _ = write!(out, ",re_{l},im_{l}");
    }
    out.push('\n');
    for (f, m) in f_hz.iter().zip(&g) {
        let _ = write!(out, "{f:e}");
        for &(i, j) in &pairs {
            let _ = write!(out, ",{:e},{:e}", m[(i, j)].re, m[(i, j)].im);
        }
        out.push('\n');
    }
    Ok(out)
}

/// The saved-model object in `path` (named `name`), checked for its format and version,
/// and its keys besides `fitted`.
fn read(path: &std::path::Path, name: &str) -> Result<(Value, Envelope), Failure> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Failure::runtime(format!("cannot read {name}: {e}")))?;
    let value: Value = serde_json::from_str(&text)
        .map_err(|e| Failure::runtime(format!("{name}: not JSON: {e}")))?;
    if value["format"] != FORMAT {
        return Err(Failure::runtime(format!(
            "{name}: not a saved fdid model (no \"format\": \"{FORMAT}\"; write one with \
             `fdid fit ... --save {name}`)"
        )));
    }
    if value["version"] != VERSION {
        return Err(Failure::runtime(format!(
            "{name}: saved-model version {} is not supported (this fdid reads version \
             {VERSION})",
            value["version"]
        )));
    }
    let envelope: Envelope = serde_json::from_value(value.clone())
        .map_err(|e| Failure::runtime(format!("{name}: bad saved model: {e}")))?;
    Ok((value, envelope))
}

/// A JSON number, or null when not finite.
fn finite(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

/// The output of `fdid eval --json`: `{"frf":[[f,re,im],..],"frf_std":[..]|null,
/// "unresolved_poles":[[re,im],..],"marginal_poles":[[re,im],..],"warnings":[..]}`.
fn eval_json(f_hz: &[f64], (g, std): &Evaluated, envelope: &Envelope) -> String {
    let frf: Vec<Value> = f_hz
        .iter()
        .zip(g)
        .map(|(f, g)| json!([f, finite(g.re), finite(g.im)]))
        .collect();
    let frf_std = std
        .as_ref()
        .map(|s| Value::Array(s.iter().map(|x| finite(*x)).collect()));
    let unresolved: Vec<Value> = envelope
        .unresolved_poles
        .iter()
        .map(|p| json!([finite(p.re), finite(p.im)]))
        .collect();
    let warnings: Vec<String> = envelope.nyquist_warning(f_hz).into_iter().collect();
    json!({
        "frf": frf,
        "frf_std": frf_std,
        "unresolved_poles": unresolved,
        "marginal_poles": pole_list(&envelope.marginal_poles),
        "warnings": warnings,
    })
    .to_string()
        + "\n"
}

/// The CSV output of `fdid eval`: a comment line on the saved model `value` (from
/// `name`), a `# warning:` line for each unresolved pole, for each pole on the stability
/// boundary and one for frequencies above
/// the Nyquist frequency, then `f,re,im[,std]`.
fn eval_csv(
    f_hz: &[f64],
    (g, std): &Evaluated,
    envelope: &Envelope,
    value: &Value,
    name: &str,
) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# {} model from {name} ({}); std: standard deviation of G from the covariance of theta",
        value["kind"].as_str().unwrap_or(""),
        value["source"].as_str().unwrap_or("")
    );
    for p in &envelope.unresolved_poles {
        let _ = writeln!(
            out,
            "# warning: unresolved pole {} {} {}i: no line of the fitted data lay in its \
             half-power band, so its damping is not determined by the data",
            p.re,
            if p.im == 0.0 { "+" } else { "+/-" },
            p.im.abs()
        );
    }
    for p in &envelope.marginal_poles {
        let _ = writeln!(
            out,
            "# warning: pole {} {} {}i on the stability boundary: the data do not tell it \
             from a pole just across it (an undamped resonance, or an integrator over the band)",
            p.re,
            if p.im == 0.0 { "+" } else { "+/-" },
            p.im.abs()
        );
    }
    if let Some(w) = envelope.nyquist_warning(f_hz) {
        let _ = writeln!(out, "# warning: {w}");
    }
    let _ = writeln!(out, "f,re,im{}", if std.is_some() { ",std" } else { "" });
    for (k, (f, g)) in f_hz.iter().zip(g).enumerate() {
        let _ = write!(out, "{f:e},{:e},{:e}", g.re, g.im);
        if let Some(s) = std {
            let _ = write!(out, ",{:e}", s[k]);
        }
        out.push('\n');
    }
    out
}

/// A response and its standard deviation, when known.
type Evaluated = (Vec<Complex<f64>>, Option<Vec<f64>>);

/// The response and its standard deviation of the saved model in `fitted`.
fn respond<M: ModelStructure<f64> + DeserializeOwned>(
    fitted: &Value,
    omega: &[f64],
    name: &str,
) -> Result<Evaluated, Failure> {
    let model: FittedModel<f64, M> = serde_json::from_value(fitted.clone())
        .map_err(|e| Failure::runtime(format!("{name}: bad saved model: {e}")))?;
    model
        .check()
        .map_err(|e| Failure::runtime(format!("{name}: bad saved model: {e}")))?;
    Ok((model.response(omega), model.response_std(omega)))
}

/// The most frequencies `fdid eval` evaluates in one call (about 0.5 GB of output).
pub const MAX_EVAL_POINTS: usize = 10_000_000;

/// Parses `--freq`: a comma-separated list of frequencies in Hz, or `FMIN:FMAX:N` for N
/// log-spaced frequencies from FMIN to FMAX (both > 0).
pub fn parse_freq(text: &str) -> Result<Vec<f64>, String> {
    let bad = |why: &str| format!("invalid --freq {text}: {why}");
    let parts: Vec<&str> = text.split(':').collect();
    let f: Vec<f64> = match parts.as_slice() {
        [lo, hi, n] => {
            let lo: f64 = lo.trim().parse().map_err(|_| bad("FMIN is not a number"))?;
            let hi: f64 = hi.trim().parse().map_err(|_| bad("FMAX is not a number"))?;
            let n: usize = n
                .trim()
                .parse()
                .map_err(|_| bad("N is not a whole number"))?;
            if !(lo > 0.0 && hi > lo && hi.is_finite()) || n < 2 {
                return Err(bad("FMIN:FMAX:N needs 0 < FMIN < FMAX and N >= 2"));
            }
            if n > MAX_EVAL_POINTS {
                return Err(bad(&format!(
                    "N = {n} frequencies; at most {MAX_EVAL_POINTS} are evaluated at once"
                )));
            }
            let (a, b) = (lo.log10(), hi.log10());
            (0..n)
                .map(|k| 10f64.powf(a + (b - a) * k as f64 / (n - 1) as f64))
                .collect()
        }
        [list] => list
            .split(',')
            .map(|s| {
                s.trim()
                    .parse::<f64>()
                    .map_err(|_| bad(&format!("`{s}` is not a number")))
            })
            .collect::<Result<_, _>>()?,
        _ => return Err(bad("expected F1,F2,... or FMIN:FMAX:N")),
    };
    if let Some(x) = f.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
        return Err(bad(&format!(
            "frequency {x} must be finite and non-negative"
        )));
    }
    Ok(f)
}
