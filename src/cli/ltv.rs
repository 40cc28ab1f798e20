//! `fdid ltv`: the Lataire–Pintelon frequency-domain TLS estimate of a continuous-time,
//! time-varying ODE ([`fdid::ltv`]) on a `t,u,y` record, with the instantaneous (frozen)
//! system at 11 evenly spaced instants.
//!
//! The model (Lataire–Pintelon eqs. 1–3, 11, 18) is
//!
//! ```text
//! Σ_{n=0}^{N_α} Σ_{p=0}^{N_p} α̃ₙ,ₚ b_p(t) Ψₙ{y}(t) = Σ_{n=0}^{N_β} Σ_{p=0}^{N_p} β̃ₙ,ₚ b_p(t) Ψₙ{u}(t)
//! ```
//!
//! evaluated on the DFT lines 𝕂 of `--band` with the transient + alias polynomial of
//! order N_tr; θ̂ is the right singular vector of the smallest singular value of the
//! column-scaled, real-stacked regressor (eq. 19), normalised to a_{N_α}(T/2) = 1. The
//! frozen system at t* is G_{t*}(s) = Σₙ βₙ(t*) Ψₙ(s) / Σₙ αₙ(t*) Ψₙ(s) (eq. 4).

use super::Failure;
use super::args::{LtvArgs, LtvBasisArg, MAX_ORDER, parse_band};
use super::report::{g, num};
use fdid::io::{Measurement, is_touchstone, read_csv};
use fdid::ltv::max_time_order;
use fdid::ltv::{FrequencyBasis, InstantaneousModel, Lines, LtvFit, LtvOde, TimeBasis};
use fdid::prelude::*;
use fdid::workflow::LtvStep;
use serde_json::{Value, json};
use std::f64::consts::TAU;
use std::fmt::Write as _;
use std::path::Path;
use std::result::Result;

/// Number of instants t* at which the frozen system is reported: the first sample, the
/// last, and 9 evenly spaced in between.
pub const INSTANTS: usize = 11;

/// One instant of the report: t* on the file's clock (s) and the frozen system there.
struct Instant {
    /// t* in the time of the file's `t` column (s).
    t: f64,
    /// The frozen poles (rad/s), sorted by imaginary part then real part.
    poles: Vec<Complex<f64>>,
    /// The frozen FRF on the band's DFT lines.
    frf: Vec<Complex<f64>>,
}

/// Everything `fdid ltv` reports.
struct LtvReport {
    file: String,
    n: usize,
    ts: f64,
    t0: f64,
    basis: LtvBasisArg,
    fit: LtvFit<f64>,
    instants: Vec<Instant>,
}

/// `fdid ltv`: reads the record, checks the settings against it, fits the time-varying
/// ODE and reports θ̂, the singular values and the frozen system at [`INSTANTS`] instants.
pub fn ltv(args: &LtvArgs) -> Result<String, Failure> {
    check_usage(args)?;
    let file = args.data.display().to_string();
    let (record, t0) = read_record(&args.data)?;
    let (n, ts) = (record.len(), record.ts());
    let lines = band_lines(args, n, ts)?;
    check_sizes(args, n, lines.len())?;
    let omega_top = lines
        .last()
        .map_or(0.0, |k| TAU * *k as f64 / (n as f64 * ts));
    // the Legendre frequency basis is scaled to the band's upper edge (eq. 20); a band of
    // the DC line alone takes the first line's frequency
    let omega_max = if omega_top > 0.0 {
        omega_top
    } else {
        TAU / (n as f64 * ts)
    };
    let mut model = LtvOde::new(args.na, args.nb, args.np);
    if let Some(k) = args.ntr {
        model = model.with_transient(Some(k));
    }
    let model = match args.basis {
        LtvBasisArg::Legendre => model
            .with_time_basis(TimeBasis::Legendre)
            .with_frequency_basis(FrequencyBasis::legendre(omega_max)?),
        LtvBasisArg::Monomial => model
            .with_time_basis(TimeBasis::Monomial)
            .with_frequency_basis(FrequencyBasis::Monomial),
    };
    let fit = model
        .fit(&record, &Lines::Indices(lines))
        .map_err(|e| Failure::runtime(format!("{file}: the time-varying fit failed: {e}")))?;
    let instants = instants(&fit, n, ts, t0)?;
    let report = LtvReport {
        file,
        n,
        ts,
        t0,
        basis: args.basis,
        fit,
        instants,
    };
    Ok(if args.json {
        report.json()
    } else {
        report.text()
    })
}

/// The checks that need no data: the orders.
fn check_usage(args: &LtvArgs) -> Result<(), Failure> {
    for (name, v) in [
        ("--na", args.na),
        ("--nb", args.nb),
        ("--np", args.np),
        ("--ntr", args.ntr.unwrap_or(0)),
    ] {
        if v > MAX_ORDER {
            return Err(Failure::usage(format!(
                "invalid {name} {v}: orders above {MAX_ORDER} are not supported"
            )));
        }
    }
    if args.na == 0 {
        return Err(Failure::usage(
            "invalid --na 0: the time-varying ODE needs an output derivative order of 1 or \
             more (the instantaneous poles are the roots of its output side)"
                .into(),
        ));
    }
    Ok(())
}

/// Reads the `t,u,y` record of `path` and the time of its first sample (s).
fn read_record(path: &Path) -> Result<(TimeData<f64>, f64), Failure> {
    let file = path.display().to_string();
    if is_touchstone(path) {
        return Err(Failure::usage(format!(
            "fdid ltv needs a time record (t,u,y), but {file} is a Touchstone file \
             (frequency data)"
        )));
    }
    let record = match read_csv::<f64>(path) {
        Ok(Measurement::Time(r)) => r,
        Ok(Measurement::Frequency(_) | Measurement::Matrix(_)) => {
            return Err(Failure::usage(format!(
                "fdid ltv needs a time record (t,u,y), but {file} holds frequency data"
            )));
        }
        Err(e @ (FdidError::Parse { .. } | FdidError::Io(_))) => return Err(Failure::from(e)),
        Err(e) => return Err(Failure::runtime(format!("{file}: {e}"))),
    };
    Ok((record, first_time(path).unwrap_or(0.0)))
}

/// The `t` value of the first data row of a CSV file that [`read_csv`] accepted as a time
/// record (the record itself keeps only Ts): the first non-blank, non-`#` line is the
/// header, the next such line the first row.
pub fn first_time(path: &Path) -> Option<f64> {
    let text = std::fs::read_to_string(path).ok()?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let mut rows = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'));
    let field = |s: &str| s.trim().trim_matches('"').trim().to_string();
    let header: Vec<String> = rows
        .next()?
        .split(',')
        .map(|s| field(s).to_lowercase())
        .collect();
    let col = header.iter().position(|h| h == "t")?;
    let first = rows.next()?;
    field(first.split(',').nth(col)?).parse().ok()
}

/// The DFT lines k of `--band` on a record of `n` samples at `ts`: f_lo ≤ k/(N Ts) ≤ f_hi,
/// by default every line from DC to Nyquist.
fn band_lines(args: &LtvArgs, n: usize, ts: f64) -> Result<Vec<usize>, Failure> {
    let nyquist = 0.5 / ts;
    let df = 1.0 / (n as f64 * ts);
    let (lo, hi) = match &args.band {
        Some(text) => parse_band(text).map_err(Failure::usage)?,
        None => (None, None),
    };
    let lo = lo.unwrap_or(0.0);
    let hi = hi.unwrap_or(nyquist);
    if hi > nyquist * (1.0 + 1e-12) {
        return Err(Failure::usage(format!(
            "invalid --band {}: FMAX = {hi} Hz is above the Nyquist frequency {} Hz of the \
             record (Ts = {} s)",
            args.band.as_deref().unwrap_or(""),
            g(nyquist),
            g(ts)
        )));
    }
    Lines::band(lo, hi.min(nyquist))
        .resolve(n, ts)
        .map_err(|e| match e {
            FdidError::EmptyBand { .. } => Failure::usage(format!(
                "--band {} holds no DFT line of the record: the lines are k/(N Ts) = k x {} Hz, \
             k = 0 .. {} (N = {n}, Ts = {} s)",
                args.band.as_deref().unwrap_or(""),
                g(df),
                n / 2,
                g(ts)
            )),
            e => Failure::from(e),
        })
}

/// N_p against the record length, the parameter count against the lines and the cost
/// of the fit against a minute: usage errors naming the flags.
fn check_sizes(args: &LtvArgs, n: usize, lines: usize) -> Result<(), Failure> {
    let max = max_time_order(n);
    if args.np > max {
        return Err(Failure::usage(format!(
            "invalid --np {}: a record of {n} samples resolves time polynomials up to order \
             floor(sqrt(N)) = {max}",
            args.np
        )));
    }
    let ntr = args
        .ntr
        .or(args.na.max(args.nb).checked_sub(1))
        .map_or(0, |k| k + 1);
    let params = (args.na + 1 + args.nb + 1) * (args.np + 1) + ntr;
    if 2 * lines < params {
        return Err(Failure::usage(format!(
            "too few lines: the band holds {lines} DFT line{} ({} real equations) but the model \
             has {params} parameters ((na + 1 + nb + 1)(np + 1) + ntr + 1); widen --band or \
             lower --na, --nb, --np or --ntr",
            if lines == 1 { "" } else { "s" },
            2 * lines
        )));
    }
    super::budget::check_ltv(2 * lines, params, args.allow_long)
}

/// The frozen system at the [`INSTANTS`] instants t_i = i (N − 1) Ts / 10 from the first
/// sample, reported on the file's clock (t0 + t_i).
fn instants(fit: &LtvFit<f64>, n: usize, ts: f64, t0: f64) -> Result<Vec<Instant>, Failure> {
    let last = (n - 1) as f64 * ts;
    (0..INSTANTS)
        .map(|i| {
            let t = last * i as f64 / (INSTANTS - 1) as f64;
            let frozen: InstantaneousModel<f64> = fit.instantaneous(t);
            let mut poles = frozen.poles().map_err(|e| {
                Failure::runtime(format!(
                    "the instantaneous poles at t = {} s cannot be computed: {e}",
                    g(t0 + t)
                ))
            })?;
            poles.sort_by(|a, b| a.im.total_cmp(&b.im).then(a.re.total_cmp(&b.re)));
            Ok(Instant {
                t: t0 + t,
                poles,
                frf: frozen.frf(&fit.omega),
            })
        })
        .collect()
}

/// A pole with its natural frequency (Hz) and damping ratio: `re +/- im i (f_n Hz, zeta)`
/// for one of a conjugate pair (the one with positive imaginary part), `re` for a real one.
fn pole_text(p: Complex<f64>) -> String {
    let wn = p.norm();
    let (fn_hz, zeta) = if wn > 0.0 {
        (wn / TAU, -p.re / wn)
    } else {
        (0.0, f64::NAN)
    };
    let head = if p.im == 0.0 {
        g(p.re)
    } else {
        format!("{} +/- {}i", g(p.re), g(p.im.abs()))
    };
    format!("{head} (f_n {} Hz, zeta {})", g(fn_hz), g(zeta))
}

/// The poles of one instant, one of each conjugate pair.
fn poles_text(poles: &[Complex<f64>]) -> String {
    if poles.is_empty() {
        return "none".into();
    }
    let parts: Vec<String> = poles
        .iter()
        .filter(|p| p.im >= 0.0)
        .map(|p| pole_text(*p))
        .collect();
    parts.join(", ")
}

impl LtvReport {
    /// `{"theta":[…],"singular_values":[…],"instantaneous":[{"t":x,"poles":[[re,im],…],
    /// "frf":[[f_hz,re,im],…]},…]}` on one line.
    fn json(&self) -> String {
        let f_hz: Vec<f64> = self.fit.omega.iter().map(|w| w / TAU).collect();
        let instants: Vec<Value> = self
            .instants
            .iter()
            .map(|i| {
                json!({
                    "t": num(i.t),
                    "poles": i.poles.iter().map(|p| json!([num(p.re), num(p.im)])).collect::<Vec<_>>(),
                    "frf": f_hz
                        .iter()
                        .zip(&i.frf)
                        .map(|(f, h)| json!([num(*f), num(h.re), num(h.im)]))
                        .collect::<Vec<_>>(),
                })
            })
            .collect();
        let obj = json!({
            "theta": self.fit.theta.iter().map(|v| num(*v)).collect::<Vec<_>>(),
            "singular_values": self.fit.singular_values.iter().map(|v| num(*v)).collect::<Vec<_>>(),
            "instantaneous": instants,
        });
        let mut s = obj.to_string();
        s.push('\n');
        s
    }

    /// The text report.
    fn text(&self) -> String {
        let mut o = String::new();
        let w = &mut o;
        let fit = &self.fit;
        let model = &fit.model;
        let last = self.t0 + (self.n - 1) as f64 * self.ts;
        let _ = writeln!(
            w,
            "fdid ltv: time-varying ODE, Lataire-Pintelon frequency-domain total least squares"
        );
        let _ = writeln!(
            w,
            "data         {}: time record of {} samples, Ts = {} s, t = {} .. {} s (T = N Ts = {} s)",
            self.file,
            self.n,
            g(self.ts),
            g(self.t0),
            g(last),
            g(fit.record)
        );
        let transient = match model.transient_order() {
            Some(k) => format!("N_tr = {k}"),
            None => "no transient polynomial".into(),
        };
        let _ = writeln!(
            w,
            "model        sum_n alpha_n(t) d^n y/dt^n = sum_n beta_n(t) d^n u/dt^n, N_alpha = {}, \
             N_beta = {}, coefficients of order N_p = {} in t; {transient}",
            model.n_alpha(),
            model.n_beta(),
            model.n_p()
        );
        let basis = match (self.basis, model.frequency_basis()) {
            (LtvBasisArg::Legendre, FrequencyBasis::Legendre { omega_max }) => format!(
                "Legendre: b_p(t) = P_p(2t/T - 1) on the record, Psi_n(jw) = j^(n mod 2) \
                 P_n(w/w_max), w_max = {} rad/s ({} Hz)",
                g(omega_max),
                g(omega_max / TAU)
            ),
            _ => "monomial: b_p(t) = t^p (t in s from the first sample), Psi_n(s) = s^n".into(),
        };
        let _ = writeln!(w, "basis        {basis}");
        let (k_lo, k_hi) = (
            fit.lines.first().copied().unwrap_or(0),
            fit.lines.last().copied().unwrap_or(0),
        );
        let df = 1.0 / fit.record;
        let _ = writeln!(
            w,
            "lines        {} DFT lines k = {k_lo} .. {k_hi} ({} .. {} Hz), {} real equations, \
             {} parameters",
            fit.lines.len(),
            g(k_lo as f64 * df),
            g(k_hi as f64 * df),
            2 * fit.lines.len(),
            fit.theta.len()
        );
        self.cost_text(w);
        let _ = writeln!(w);
        let _ = writeln!(
            w,
            "instantaneous poles (rad/s; natural frequency f_n in Hz, damping ratio zeta)"
        );
        for i in &self.instants {
            let _ = writeln!(
                w,
                "  t = {:<12} {}",
                format!("{} s", g(i.t)),
                poles_text(&i.poles)
            );
        }
        let _ = writeln!(w);
        let _ = writeln!(
            w,
            "theta        (alpha~[n][p], beta~[n][p], then gamma_m of the transient; \
             a_N_alpha(T/2) = 1)"
        );
        let np1 = model.n_p() + 1;
        for n in 0..=model.n_alpha() {
            let row: Vec<String> = (0..np1)
                .map(|p| g(fit.theta[model.alpha_index(n, p)]))
                .collect();
            let _ = writeln!(w, "  alpha~_{n}  {}", row.join("  "));
        }
        for n in 0..=model.n_beta() {
            let row: Vec<String> = (0..np1)
                .map(|p| g(fit.theta[model.beta_index(n, p)]))
                .collect();
            let _ = writeln!(w, "  beta~_{n}   {}", row.join("  "));
        }
        if !fit.transient().is_empty() {
            let row: Vec<String> = fit.transient().iter().map(|v| g(*v)).collect();
            let _ = writeln!(w, "  gamma      {}", row.join("  "));
        }
        o
    }

    /// The TLS cost, the smallest singular values and the gap between the two smallest.
    fn cost_text(&self, w: &mut String) {
        let sv = &self.fit.singular_values;
        let p = sv.len();
        let smallest: Vec<String> = sv.iter().rev().take(4).map(|v| g(*v)).collect();
        let s_min = sv.last().copied().unwrap_or(f64::NAN);
        let _ = writeln!(
            w,
            "cost         V = sigma_min^2 = {} (TLS cost |M c|^2, M the regressor with unit-norm \
             columns, |c| = 1); relative residual sigma_min/sigma_max = {}",
            g(s_min * s_min),
            g(s_min / sv.first().copied().unwrap_or(f64::NAN))
        );
        let _ = writeln!(
            w,
            "singular     {p} values; smallest: {} (sigma_{p} first)",
            smallest.join(", ")
        );
        if p >= 2 {
            let ratio = sv[p - 2] / s_min;
            let _ = writeln!(w, "gap          sigma_{}/sigma_{p} = {}", p - 1, g(ratio));
            if ratio < GAP_WARNING {
                let _ = writeln!(
                    w,
                    "warning      the two smallest singular values are within a factor {GAP_WARNING}: \
                     the null space is not clearly one-dimensional, so theta is not well \
                     determined (orders above the system's, e.g. --np above its time \
                     variation: the ODE times any polynomial c(t) fits as well; the frozen \
                     FRF B/A is still determined wherever c(t) != 0)"
                );
            }
        }
    }
}

/// Below this ratio σ_{p−1}/σ_p the text report warns that the null space is not clearly
/// one-dimensional.
pub const GAP_WARNING: f64 = 3.0;

/// The section of `fdid diagnose`'s text report for the time-varying ODE it fitted after
/// naming time variation on a continuous-time spec ([`fdid::workflow::Report::ltv`]):
/// the candidate orders N_p with their TLS costs and F tests, the gap before → after, and
/// the frozen poles at the 11 instants (on the file's clock, first sample at `t0`).
pub fn diagnose_text(step: &LtvStep, t0: f64) -> String {
    let mut o = String::new();
    let w = &mut o;
    let fit = &step.fit;
    let model = &fit.model;
    let df = 1.0 / fit.record;
    let (k_lo, k_hi) = (
        fit.lines.first().copied().unwrap_or(0),
        fit.lines.last().copied().unwrap_or(0),
    );
    let _ = writeln!(
        w,
        "time-varying ODE (Lataire-Pintelon TLS on the time record; `fdid ltv` fits it alone)"
    );
    let _ = writeln!(
        w,
        "  N_alpha = {}, N_beta = {}, N_tr = {}, Legendre bases; {} DFT lines k = {k_lo} .. {k_hi} \
         ({} .. {} Hz, the lines between the excited ones included)",
        model.n_alpha(),
        model.n_beta(),
        model.transient_order().unwrap_or(0),
        fit.lines.len(),
        g(k_lo as f64 * df),
        g(k_hi as f64 * df)
    );
    let _ = writeln!(
        w,
        "  {:<4} {:>6} {:>12} {:>10}   (V = sigma_min^2 of the regressor with unit-norm columns; \
         F test against N_p - 1)",
        "N_p", "params", "V", "F p"
    );
    for c in &step.candidates {
        let _ = writeln!(
            w,
            "  {:<4} {:>6} {:>12} {:>10}{}",
            c.n_p,
            c.params,
            g(c.cost),
            c.p_value.map_or_else(|| "-".into(), g),
            if c.n_p == step.n_p {
                "   <- chosen"
            } else {
                ""
            }
        );
    }
    let ratio = step.cost_before / step.cost_after;
    let _ = writeln!(
        w,
        "  gap          V {} (N_p = 0, time-invariant) -> {} (N_p = {}): {} times smaller",
        g(step.cost_before),
        g(step.cost_after),
        step.n_p,
        g(ratio)
    );
    if step.n_p == 0 {
        let _ = writeln!(
            w,
            "  not confirmed: no order N_p >= 1 of the coefficients in t passes its F test, so \
             the time-varying ODE of these orders does not shrink the gap; the evidence for \
             time variation is the test that named it alone"
        );
    }
    let _ = writeln!(
        w,
        "  instantaneous poles (rad/s; natural frequency f_n in Hz, damping ratio zeta)"
    );
    for (t, poles) in step.instants.iter().zip(&step.poles) {
        let _ = writeln!(
            w,
            "    t = {:<12} {}",
            format!("{} s", g(t0 + t)),
            poles_text(poles)
        );
    }
    o
}

/// The JSON object of [`diagnose_text`]: `{"n_alpha", "n_beta", "n_p", "n_tr", "lines",
/// "band_hz":[lo,hi], "candidates":[{"n_p","params","cost","p_value"},..], "cost_before",
/// "cost_after", "theta", "singular_values", "instantaneous":[{"t","poles":[[re,im],..]},..]}`.
pub fn diagnose_json(step: &LtvStep, t0: f64) -> Value {
    let fit = &step.fit;
    let model = &fit.model;
    let df = 1.0 / fit.record;
    let candidates: Vec<Value> = step
        .candidates
        .iter()
        .map(|c| {
            json!({
                "n_p": c.n_p,
                "params": c.params,
                "cost": num(c.cost),
                "p_value": c.p_value.map_or(Value::Null, num),
            })
        })
        .collect();
    let instants: Vec<Value> = step
        .instants
        .iter()
        .zip(&step.poles)
        .map(|(t, poles)| {
            json!({
                "t": num(t0 + t),
                "poles": poles.iter().map(|p| json!([num(p.re), num(p.im)])).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({
        "n_alpha": model.n_alpha(),
        "n_beta": model.n_beta(),
        "n_p": step.n_p,
        "n_tr": model.transient_order(),
        "lines": fit.lines.len(),
        "band_hz": [
            num(fit.lines.first().copied().unwrap_or(0) as f64 * df),
            num(fit.lines.last().copied().unwrap_or(0) as f64 * df),
        ],
        "candidates": candidates,
        "cost_before": num(step.cost_before),
        "cost_after": num(step.cost_after),
        "theta": fit.theta.iter().map(|v| num(*v)).collect::<Vec<_>>(),
        "singular_values": fit.singular_values.iter().map(|v| num(*v)).collect::<Vec<_>>(),
        "instantaneous": instants,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use fdid::simulate::SplitMix64;
    use fdid::workflow::{ModelSpec, fit_spec, time_varying_ode};

    /// A time-invariant first-order record: the time-varying ODE keeps N_p = 0, and the
    /// text says that it does not confirm time variation.
    #[test]
    fn a_time_invariant_ode_is_reported_as_not_confirming() {
        let n = 1024;
        let mut rng = SplitMix64::new(3);
        let u: Vec<f64> = (0..n).map(|_| rng.gaussian()).collect();
        let mut y = vec![0.0; n];
        for t in 1..n {
            y[t] = 0.9 * y[t - 1] + 0.1 * u[t - 1];
        }
        let y: Vec<f64> = y.iter().map(|v| v + 1e-3 * rng.gaussian()).collect();
        let record = TimeData::new(u, y, 0.01).unwrap();
        let all = record.dft();
        let keep: Vec<bool> = (0..all.len()).map(|k| (1..=100).contains(&k)).collect();
        let data = all.select_lines(&keep).unwrap();
        let fit = fit_spec(&ModelSpec::continuous(1, 0), &data).unwrap();
        let step = time_varying_ode(&fit, &record, 0.01).unwrap().unwrap();
        assert_eq!(step.n_p, 0);
        let text = diagnose_text(&step, 0.0);
        assert!(text.contains("not confirmed"), "{text}");
    }
}
