//! `fdid fit` on every entry of a multi-port file: a common-pole model ([`fdid::mimo`]),
//! its modes, residue matrices, state-space realisation and per-entry errors.

use super::args::{CommonArgs, CriterionArg, FitArgs, parse_band};
use super::json_arrays::{Response, Rows};
use super::{Failure, budget};
use fdid::data::{FrfMatrix, MimoSpectra};
use fdid::io::NetworkParameter;
use fdid::mimo::{
    CommonPoleFit, CommonPoleOptions, Enforcement, MlOutcome, enforce_passivity, passivity,
};
use fdid::prelude::*;
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::result::Result;

/// The note of a report whose common-denominator form overflows (`matrix_fraction` null).
const OVERFLOW_NOTE: &str = "matrix_fraction is null: its polynomial \
     coefficients overflow double precision at this order and frequency scale (use the \
     poles and residues or the state space)";

/// Grid points of the passivity check of scattering data.
const PASSIVITY_POINTS: usize = 4000;

/// A multi-entry data set: an FRF matrix (with the network parameter of Touchstone
/// data), or the spectra of a record with several inputs.
pub(super) enum Entries {
    /// One FRF per entry.
    Matrix {
        matrix: FrfMatrix<f64>,
        parameter: Option<NetworkParameter>,
    },
    /// The DFT of a record whose inputs act together.
    Spectra(MimoSpectra<f64>),
}

/// Fits the common-pole model the flags name to every entry and reports it.
pub(super) fn fit(args: &FitArgs, entries: Entries) -> Result<String, Failure> {
    let c = &args.common;
    let spectra = matches!(entries, Entries::Spectra(_));
    check_flags(args, spectra)?;
    let (data, parameter) = banded(c, entries)?;
    let options = CommonPoleOptions {
        full_covariance: args.full_covariance,
        ..options(c, data.ts(), args.stable)?
    };
    let (fit, stopped) = match (&data, args.common_denominator) {
        (Fitted::Matrix(m), true) => budget::fit_common_poles(args.allow_long, || {
            fdid::mimo::fit_common_denominator(m, c.na, c.nb, &options)
        })?,
        _ => budget::fit_common_poles(args.allow_long, || data.fit(c.na, &options))?,
    };
    if args.full_covariance && !fit.correlated {
        return Err(Failure::usage(
            "--full-covariance needs the outputs' noise covariance: several outputs of a \
             periodic record (--output A,B,... with --periods P, more than outputs + 1 \
             periods kept)"
                .to_string(),
        ));
    }
    let (fit, enforcement) = match (args.enforce_passivity, parameter, &data) {
        (false, ..) => (fit, None),
        (true, Some(NetworkParameter::S), Fitted::Matrix(matrix)) => {
            let e = enforce_passivity(
                &fit.model,
                matrix.omega(),
                f_max_hz(&data),
                PASSIVITY_POINTS,
            )
            .map_err(Failure::from)?;
            (fit.with_model(e.model.clone(), matrix)?, Some(e))
        }
        (true, ..) => {
            return Err(Failure::usage(
                "--enforce-passivity applies to S-parameter data (a Touchstone file of S)"
                    .to_string(),
            ));
        }
    };
    if let Some(path) = &args.plot {
        write_plot(path, &data, &fit)?;
    }
    if let Some(path) = &args.save {
        let source = c.data.display().to_string();
        super::saved::write(path, &super::saved::common_poles(&fit.model, &source)?)?;
    }
    let report = Report {
        file: c.data.display().to_string(),
        data: &data,
        fit: &fit,
        parameter,
        stopped,
        enforcement: enforcement.as_ref(),
        common_denominator: args.common_denominator.then_some(c.nb),
    };
    Ok(if args.json {
        report.json()?
    } else {
        report.text()?
    })
}

/// `--plot FILE`: one magnitude panel per entry, data and model.
#[cfg(feature = "plot")]
fn write_plot(
    path: &std::path::Path,
    data: &Fitted,
    fit: &CommonPoleFit<f64>,
) -> Result<(), Failure> {
    let g = fit.model.response(data.omega());
    let (ny, nu) = data.shape();
    let entry = |e: usize| -> Vec<Complex<f64>> { g.iter().map(|m| m[(e % ny, e / ny)]).collect() };
    let model: Vec<Vec<Complex<f64>>> = (0..ny * nu).map(entry).collect();
    let measured: Option<Vec<Vec<Complex<f64>>>> = match data {
        Fitted::Matrix(m) => Some(m.entries().iter().map(|e| e.y().to_vec()).collect()),
        Fitted::Spectra(_) => None,
    };
    let figure = super::svg::bode_grid(&data.f_hz(), measured.as_deref(), &model, (ny, nu));
    write_figure(path, figure, "the Bode grid")
}

/// Writes an SVG `figure` (or reports why `what` could not be drawn) to `path`.
#[cfg(feature = "plot")]
pub(super) fn write_figure(
    path: &std::path::Path,
    figure: Result<String, String>,
    what: &str,
) -> Result<(), Failure> {
    let figure = figure.map_err(|e| Failure::runtime(format!("cannot draw {what}: {e}")))?;
    super::progress::write_atomic(path, figure.as_bytes())
        .map_err(|e| Failure::runtime(format!("cannot write {}: {e}", path.display())))
}

/// Without the `plot` feature `--plot` is a usage error.
#[cfg(not(feature = "plot"))]
fn write_plot(path: &std::path::Path, _: &Fitted, _: &CommonPoleFit<f64>) -> Result<(), Failure> {
    Err(Failure::usage(format!(
        "--plot {} needs the `plot` feature (build with default features)",
        path.display()
    )))
}

/// The entries within `--band`, and the network parameter of Touchstone data.
pub(super) fn banded(
    c: &CommonArgs,
    entries: Entries,
) -> Result<(Fitted, Option<NetworkParameter>), Failure> {
    let band = c
        .band
        .as_deref()
        .map(parse_band)
        .transpose()
        .map_err(Failure::usage)?
        .map(|(lo, hi)| (lo.unwrap_or(0.0), hi.unwrap_or(f64::INFINITY)));
    Ok(match entries {
        Entries::Matrix { matrix, parameter } => {
            let matrix = match band {
                Some((lo, hi)) => matrix.band_hz(lo, hi).map_err(Failure::from)?,
                None => matrix,
            };
            (Fitted::Matrix(matrix), parameter)
        }
        Entries::Spectra(spectra) => {
            let spectra = match band {
                Some((lo, hi)) => spectra.band_hz(lo, hi).map_err(Failure::from)?,
                None => spectra,
            };
            (Fitted::Spectra(spectra), None)
        }
    })
}

/// The options of a common-pole fit from the flags (`--nb` = `--na`: a direct term).
pub(super) fn options(
    c: &CommonArgs,
    ts: Option<f64>,
    stable: bool,
) -> Result<CommonPoleOptions<f64>, Failure> {
    Ok(CommonPoleOptions {
        domain: super::domain(c.domain, c.ts.or(ts))?,
        direct: c.nb == c.na,
        stable,
        transient: c.transient,
        ..CommonPoleOptions::default()
    })
}

/// The data a common-pole model is fitted to.
pub(super) enum Fitted {
    Matrix(FrfMatrix<f64>),
    Spectra(MimoSpectra<f64>),
}

impl Fitted {
    /// True for an FRF matrix whose columns carry their input's noise.
    fn has_input_noise(&self) -> bool {
        matches!(self, Fitted::Matrix(m) if m.has_input_noise())
    }

    /// The common-pole fit of `order` poles.
    pub(super) fn fit(
        &self,
        order: usize,
        options: &CommonPoleOptions<f64>,
    ) -> fdid::Result<CommonPoleFit<f64>> {
        match self {
            Self::Matrix(m) => fdid::mimo::fit_common_poles(m, order, options),
            Self::Spectra(s) => fdid::mimo::fit_common_poles_spectra(s, order, options),
        }
    }

    /// Outputs and inputs.
    pub(super) fn shape(&self) -> (usize, usize) {
        match self {
            Self::Matrix(m) => (m.ny(), m.nu()),
            Self::Spectra(s) => (s.ny(), s.nu()),
        }
    }

    /// The sum over the entries of |G_ij| per line (FRF matrix), or over the outputs of
    /// |Y_i| (spectra).
    #[cfg(feature = "plot")]
    pub(super) fn summed_magnitude(&self) -> Vec<f64> {
        match self {
            Self::Matrix(m) => (0..m.len())
                .map(|k| m.entries().iter().map(|e| e.y()[k].norm()).sum())
                .collect(),
            Self::Spectra(s) => (0..s.len())
                .map(|k| (0..s.ny()).map(|i| s.y(i)[k].norm()).sum())
                .collect(),
        }
    }

    /// The lines' frequencies in Hz.
    #[cfg(feature = "plot")]
    pub(super) fn f_hz(&self) -> Vec<f64> {
        self.omega()
            .iter()
            .map(|w| w / std::f64::consts::TAU)
            .collect()
    }

    pub(super) fn omega(&self) -> &[f64] {
        match self {
            Self::Matrix(m) => m.omega(),
            Self::Spectra(s) => s.omega(),
        }
    }

    pub(super) fn ts(&self) -> Option<f64> {
        match self {
            Self::Matrix(m) => m.ts(),
            Self::Spectra(s) => s.ts(),
        }
    }
}

/// The flags a common-pole fit does not take, each refused with what to do instead.
fn check_flags(args: &FitArgs, spectra: bool) -> Result<(), Failure> {
    let c = &args.common;
    let one_entry = if spectra {
        "select one input and one output for it"
    } else {
        "pick one entry with --port IJ for it"
    };
    let refused = [
        (c.delay, "--delay"),
        (c.transient && !spectra, "--transient"),
        (args.noise_order.is_some(), "--noise-order"),
        (
            args.criterion != CriterionArg::Ml,
            "--criterion other than ml",
        ),
    ];
    if let Some((_, flag)) = refused.iter().find(|(on, _)| *on) {
        return Err(Failure::usage(format!(
            "{flag} is not available for a fit of every entry with common poles ({one_entry})"
        )));
    }
    if args.common_denominator {
        if spectra || c.nb > c.na || args.full_covariance {
            return Err(Failure::usage(format!(
                "--common-denominator fits a frequency response matrix (not a record with \
                 several inputs) with --nb <= --na, weighted by the variances (not \
                 --full-covariance); got --na {} --nb {}",
                c.na, c.nb
            )));
        }
        return Ok(());
    }
    if c.nb + 1 != c.na && c.nb != c.na {
        return Err(Failure::usage(format!(
            "a fit of every entry with common poles is in partial fractions: --nb {} with \
             --na {} must be {} (strictly proper) or {} (with a direct term); \
             --common-denominator takes any --nb <= --na",
            c.nb,
            c.na,
            c.na.saturating_sub(1),
            c.na
        )));
    }
    // --domain z takes its sample time from --ts or the data (`options`)
    Ok(())
}

struct Report<'a> {
    file: String,
    data: &'a Fitted,
    fit: &'a CommonPoleFit<f64>,
    parameter: Option<NetworkParameter>,
    stopped: Option<&'static str>,
    /// `--enforce-passivity`: the check before, and the change made.
    enforcement: Option<&'a Enforcement>,
    /// `--common-denominator`: the numerators' degree nb.
    common_denominator: Option<usize>,
}

/// The highest line's frequency (Hz): the passivity grid reaches 1.5 times it.
fn f_max_hz(data: &Fitted) -> f64 {
    data.omega().iter().copied().fold(0.0, f64::max) / std::f64::consts::TAU
}

/// Per entry of an FRF matrix: (output, input) 1-based, RMS error and RMS of the data.
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

/// Per output of a record's spectra: output 1-based, RMS error of Y − Ŷ (Ŷ with the
/// transient) and RMS of Y over the lines, from the fit's per-output residual powers
/// (without the weights).
fn output_errors(spectra: &MimoSpectra<f64>, fit: &CommonPoleFit<f64>) -> Vec<(usize, f64, f64)> {
    let n = spectra.len() as f64;
    fit.residual_power
        .iter()
        .enumerate()
        .map(|(i, cost)| {
            let size = spectra.y(i).iter().map(|y| y.norm_sqr()).sum::<f64>();
            (i + 1, (cost / n).sqrt(), (size / n).sqrt())
        })
        .collect()
}

/// The RMS error over every entry and line (FRF matrix) or output and line (spectra).
fn rms_error(data: &Fitted, fit: &CommonPoleFit<f64>) -> f64 {
    match data {
        Fitted::Matrix(m) => fit.rms(m),
        Fitted::Spectra(s) => {
            (fit.residual_power.iter().sum::<f64>() / (s.len() * s.ny()) as f64).sqrt()
        }
    }
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

/// A real matrix as a JSON array of rows.
pub(super) fn matrix_json(m: &nalgebra::DMatrix<f64>) -> Value {
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
        (self.parameter == Some(NetworkParameter::S))
            .then(|| passivity(&self.fit.model, f_max_hz(self.data), PASSIVITY_POINTS))
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
        if let Some(nb) = self.common_denominator {
            let _ = writeln!(
                w,
                "model        common denominator in {}: B_ij/A, na = {}, nb = {} (shown in \
                 partial fractions below), {} SK iterations, ML {}",
                if model.domain == Domain::Continuous {
                    "s"
                } else {
                    "z (polynomials in z^-1)"
                },
                model.order(),
                nb,
                fit.relocations,
                ml_text(fit.ml)
            );
        } else {
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
        }
        let _ = writeln!(
            w,
            "cost         {:.6e} ({}); rms error {:.6e}",
            fit.cost,
            if fit.correlated && self.data.has_input_noise() {
                "weighted by the noise covariance of outputs and input (errors in \
                 variables, at the model's response), sum of r'C^-1 r per line"
            } else if fit.correlated {
                "weighted by the outputs' noise covariance, sum of r'C^-1 r per line"
            } else if fit.weighted {
                "weighted by the variances"
            } else {
                "unweighted"
            },
            rms_error(self.data, fit)
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
        match self.data {
            Fitted::Matrix(m) => {
                let _ = writeln!(w, "entries      output input  rms error      rms of data");
                for (i, j, err, size) in entry_errors(m, fit) {
                    let _ = writeln!(w, "  {i:>6} {j:>5}  {err:.6e}   {size:.6e}");
                }
            }
            Fitted::Spectra(s) => {
                if let Some((periods, rho)) = noise_correlation(s) {
                    let _ = writeln!(
                        w,
                        "noise        between the {periods} periods averaged; each output weighted by \
                         its noise variance; correlation of the outputs' noise (mean |rho| over \
                         the lines): {}",
                        matrix_text(&rho)
                    );
                }
                let _ = writeln!(
                    w,
                    "outputs      output  rms error      rms of data    explained (1 - error/data)"
                );
                for (i, err, size) in output_errors(s, fit) {
                    let _ = writeln!(
                        w,
                        "  {i:>6}  {err:.6e}   {size:.6e}   {:.1} %",
                        100.0 * (1.0 - err / size)
                    );
                }
            }
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
        if let Some(e) = self.enforcement {
            let _ = writeln!(
                w,
                "enforced     passivity by {}: max singular value {:.6} before ({} violations); the model changed by {:.3e} relative over the fitted lines",
                if e.scaled {
                    "scaling S (the residue perturbation changed it more or did not converge)"
                        .to_string()
                } else {
                    format!("residue perturbation in {} iteration(s)", e.iterations)
                },
                e.before.max_singular_value,
                e.before.violations,
                e.relative_change
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
        // the passivity check (a dense grid) runs beside the model's other forms
        let (checked, (modes, ss, mf, g)) = rayon::join(
            || self.passivity(),
            || {
                (
                    model.modes(),
                    model.state_space(),
                    model.matrix_fraction(),
                    model.response(self.data.omega()),
                )
            },
        );
        let modes = modes.map_err(Failure::from)?;
        let f_hz: Vec<f64> = self
            .data
            .omega()
            .iter()
            .map(|w| w / std::f64::consts::TAU)
            .collect();
        let entry = |i: usize, j: usize, errors: Option<(f64, f64)>| Entry {
            output: i,
            input: j,
            rms_error: errors.map(|e| e.0),
            rms_data: errors.map(|e| e.1),
            frf: Response {
                f_hz: &f_hz,
                g: &g,
                i: i - 1,
                j: j - 1,
            },
        };
        let (entries, output_errors_json): (Vec<Entry>, Value) = match self.data {
            Fitted::Matrix(m) => (
                entry_errors(m, fit)
                    .iter()
                    .map(|(i, j, err, size)| entry(*i, *j, Some((*err, *size))))
                    .collect(),
                Value::Null,
            ),
            Fitted::Spectra(s) => (
                (1..=s.nu())
                    .flat_map(|j| (1..=s.ny()).map(move |i| (i, j)))
                    .map(|(i, j)| entry(i, j, None))
                    .collect(),
                Value::Array(
                    output_errors(s, fit)
                        .iter()
                        .map(|(i, err, size)| {
                            json!({"output": i, "rms_error": err, "rms_data": size,
                                   "explained": 1.0 - err / size})
                        })
                        .collect(),
                ),
            ),
        };
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
        let passivity = checked.map(|p| {
            let mut v = json!({
                "max_singular_value": p.max_singular_value,
                "at_hz": p.at_hz,
                "passive": p.passive(),
                "violations": p.violations,
                "points": p.points,
            });
            if let Some(e) = self.enforcement {
                v["enforced"] = json!({
                    "method": if e.scaled { "scaling" } else { "residue perturbation" },
                    "iterations": e.iterations,
                    "max_singular_value_before": e.before.max_singular_value,
                    "violations_before": e.before.violations,
                    "relative_change": e.relative_change,
                });
            }
            v
        });
        let v = json!({
            "file": self.file,
            "model": if self.common_denominator.is_some() {
                "common_denominator"
            } else {
                "common_poles"
            },
            "nb": self.common_denominator,
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
            "matrix_fraction": mf.is_finite().then(|| json!({
                "denominator": mf.denominator,
                "numerators": mf.numerators,
            })),
            "cost": fit.cost,
            "weighted": fit.weighted,
            "weighting": if fit.correlated && self.data.has_input_noise() {
                "errors_in_variables"
            } else if fit.correlated {
                "output_covariance"
            } else if fit.weighted {
                "variances"
            } else {
                "none"
            },
            "noise": match self.data {
                Fitted::Spectra(s) => noise_correlation(s).map(|(periods, rho)| {
                    json!({"periods": periods, "output_correlation": matrix_json(&rho)})
                }),
                Fitted::Matrix(_) => None,
            },
            "rms_error": rms_error(self.data, fit),
            "relocations": fit.relocations,
            "ml": ml_text(fit.ml),
            "passivity": passivity,
            "output_errors": output_errors_json,
            "notes": self
                .stopped
                .into_iter()
                .chain((!mf.is_finite()).then_some(OVERFLOW_NOTE))
                .collect::<Vec<_>>(),
        });
        let document = Document {
            summary: v,
            state_space: StateSpace {
                a: Rows(&ss.a),
                b: Rows(&ss.b),
                c: Rows(&ss.c),
                d: Rows(&ss.d),
            },
            entries,
        };
        serde_json::to_string(&document)
            .map(|s| s + "\n")
            .map_err(|e| Failure::runtime(format!("cannot write the JSON report: {e}")))
    }
}

/// The `--json` report of a common-pole fit: the summary's fields, then the state space
/// and the entries' responses, written from the numbers (see [`super::json_arrays`]).
#[derive(serde::Serialize)]
struct Document<'a> {
    #[serde(flatten)]
    summary: Value,
    state_space: StateSpace<'a>,
    entries: Vec<Entry<'a>>,
}

/// The real realisation (A, B, C, D) of the model.
#[derive(serde::Serialize)]
struct StateSpace<'a> {
    a: Rows<'a>,
    b: Rows<'a>,
    c: Rows<'a>,
    d: Rows<'a>,
}

/// One entry of the report: its indices (from 1), its RMS error and the data's RMS (FRF
/// matrices) and the model's response over the lines.
#[derive(serde::Serialize)]
struct Entry<'a> {
    output: usize,
    input: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    rms_error: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rms_data: Option<f64>,
    frf: Response<'a>,
}

/// The periods a record's spectra were averaged over and the correlation of the outputs'
/// noise between periods, |C_ab| / √(C_aa C_bb) averaged over the lines (1 on the
/// diagonal); `None` without periods.
fn noise_correlation(s: &MimoSpectra<f64>) -> Option<(usize, nalgebra::DMatrix<f64>)> {
    let noise = s.noise()?;
    let ny = s.ny();
    let mut rho = nalgebra::DMatrix::zeros(ny, ny);
    for k in 0..s.len() {
        let c = noise.output_covariance(k);
        for a in 0..ny {
            for b in 0..ny {
                let scale = (c[(a, a)].re * c[(b, b)].re).sqrt();
                if scale > 0.0 {
                    rho[(a, b)] += c[(a, b)].norm() / scale / s.len() as f64;
                }
            }
        }
    }
    Some((noise.periods(), rho))
}

/// A small matrix as text, rows in brackets: [[1.000, 0.120], [0.120, 1.000]].
fn matrix_text(m: &nalgebra::DMatrix<f64>) -> String {
    let rows: Vec<String> = (0..m.nrows())
        .map(|i| {
            let row: Vec<String> = (0..m.ncols())
                .map(|j| format!("{:.3}", m[(i, j)]))
                .collect();
            format!("[{}]", row.join(", "))
        })
        .collect();
    format!("[{}]", rows.join(", "))
}
