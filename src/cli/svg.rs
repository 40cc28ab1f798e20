//! The SVG figures (feature `plot`): for `fdid diagnose --report DIR` a Bode plot of the
//! data and the initial and final models and the spectrum of the normalised residuals;
//! for `fdid fit --plot FILE` a Bode plot of the data, the model with its uncertainty
//! band and the residual.

use fdid::prelude::*;
use fdid::workflow::SpecFit;
use plotters::prelude::*;
use std::f64::consts::TAU;
use std::result::Result;

/// Figure size in pixels.
const SIZE: (u32, u32) = (900, 700);

const DATA: RGBColor = RGBColor(90, 90, 90);
const INITIAL: RGBColor = RGBColor(31, 119, 180);
const FINAL: RGBColor = RGBColor(214, 39, 40);
const NOISE: RGBColor = RGBColor(44, 160, 44);
const RESIDUAL: RGBColor = RGBColor(148, 103, 189);

/// A drawing error as text.
fn text<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// `20 log10 |z|`.
fn db(z: Complex<f64>) -> f64 {
    20.0 * z.norm().log10()
}

/// The range of the finite values of `v`, widened by a margin; `fallback` when empty.
fn range(v: impl Iterator<Item = f64>, margin: f64, fallback: (f64, f64)) -> (f64, f64) {
    let (lo, hi) = v
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    if lo > hi {
        return fallback;
    }
    if hi - lo < 1e-12 {
        return (lo - 1.0, hi + 1.0);
    }
    (lo - margin * (hi - lo), hi + margin * (hi - lo))
}

/// Pieces of a phase curve (degrees, wrapped to (−180, 180]) split where it wraps, so
/// that no vertical line joins −180 and 180.
fn phase_pieces(f: &[f64], g: &[Complex<f64>]) -> Vec<Vec<(f64, f64)>> {
    let mut pieces: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    let mut prev: Option<f64> = None;
    for (x, z) in f.iter().zip(g) {
        let p = z.arg().to_degrees();
        if !p.is_finite() {
            continue;
        }
        if prev.is_some_and(|q| (p - q).abs() > 180.0) {
            pieces.push(Vec::new());
        }
        if let Some(last) = pieces.last_mut() {
            last.push((*x, p));
        }
        prev = Some(p);
    }
    pieces.retain(|p| p.len() > 1);
    pieces
}

/// One model curve of a Bode plot: its response on the data's lines and, optionally,
/// the standard deviation σ_G of each line (drawn as the band |Ĝ| ± 2σ_G).
pub struct Curve<'a> {
    /// Legend entry.
    pub name: &'a str,
    /// Ĝ(ω_k).
    pub response: &'a [Complex<f64>],
    /// σ_G(ω_k), if known.
    pub std: Option<&'a [f64]>,
}

/// The Bode plot of `fdid diagnose`: the data and the initial and final models ([`bode_curves`]).
///
/// # Errors
/// The drawing backend's, as text.
pub fn bode(
    data: &FrequencyData<f64>,
    initial: &SpecFit,
    last: &SpecFit,
) -> Result<String, String> {
    let curves = [
        Curve {
            name: "initial model",
            response: &initial.response,
            std: None,
        },
        Curve {
            name: "final model",
            response: &last.response,
            std: None,
        },
    ];
    bode_curves(data, &curves, false)
}

/// The Bode plot: magnitude (dB) and phase (degrees) against frequency (Hz, log scale) of
/// the data Y/U (points), each model curve (lines; with its band |Ĝ| ± 2σ_G as thin lines
/// when σ_G is given), with `residual` the residual |Y/U − Ĝ| of the last curve (points),
/// and, when the data carry noise variances, the noise level σ_G = sqrt(var_y)/|U| (line,
/// magnitude only).
///
/// # Errors
/// The drawing backend's, as text.
pub fn bode_curves(
    data: &FrequencyData<f64>,
    curves: &[Curve<'_>],
    residual: bool,
) -> Result<String, String> {
    let f: Vec<f64> = data.omega().iter().map(|w| w / TAU).collect();
    let keep: Vec<bool> = f.iter().map(|x| *x > 0.0).collect();
    let ratio: Vec<Complex<f64>> = data.y().iter().zip(data.u()).map(|(y, u)| y / u).collect();
    let sigma: Option<Vec<f64>> = data.noise().map(|n| {
        n.var_y
            .iter()
            .zip(data.u())
            .map(|(v, u)| v.sqrt() / u.norm())
            .collect()
    });
    let pos = |v: &[f64]| -> Vec<f64> {
        v.iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(x, _)| *x)
            .collect()
    };
    let fp = pos(&f);
    let (fmin, fmax) = match (fp.first(), fp.last()) {
        (Some(a), Some(b)) if b > a => (*a, *b),
        (Some(a), _) => (*a * 0.5, *a * 2.0),
        _ => return Err("no line with a positive frequency to plot".into()),
    };
    let resid: Option<Vec<Complex<f64>>> = curves
        .last()
        .filter(|_| residual)
        .map(|c| ratio.iter().zip(c.response).map(|(r, g)| r - g).collect());
    let mags = ratio
        .iter()
        .chain(curves.iter().flat_map(|c| c.response.iter()))
        .map(|z| db(*z))
        .chain(sigma.iter().flatten().map(|s| 20.0 * s.log10()));
    let (mut mlo, mhi) = range(mags, 0.05, (-1.0, 1.0));
    if let Some(r) = &resid {
        // the residual may sit far below the response (down to rounding on noise-free
        // data): show at most 60 dB below the lowest curve
        let rlo = r
            .iter()
            .map(|z| db(*z))
            .filter(|v| v.is_finite())
            .fold(f64::INFINITY, f64::min);
        if rlo.is_finite() {
            mlo = rlo.max(mlo - 60.0).min(mlo);
        }
    }

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(text)?;
        let (upper, lower) = root.split_vertically(SIZE.1 / 2);
        let mut mag = ChartBuilder::on(&upper)
            .caption("Bode plot: magnitude", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d((fmin..fmax).log_scale(), mlo..mhi)
            .map_err(text)?;
        mag.configure_mesh()
            .x_desc("frequency (Hz)")
            .y_desc("|G| (dB)")
            .draw()
            .map_err(text)?;
        let points = |g: &[Complex<f64>], val: fn(Complex<f64>) -> f64| -> Vec<(f64, f64)> {
            f.iter()
                .zip(g)
                .filter(|(x, z)| **x > 0.0 && val(**z).is_finite())
                .map(|(x, z)| (*x, val(*z)))
                .collect()
        };
        mag.draw_series(
            points(&ratio, db)
                .into_iter()
                .map(|p| Circle::new(p, 2, DATA.filled())),
        )
        .map_err(text)?
        .label("data Y/U")
        .legend(|(x, y)| Circle::new((x, y), 3, DATA.filled()));
        for (i, curve) in curves.iter().enumerate() {
            let colour = if i + 1 == curves.len() {
                FINAL
            } else {
                INITIAL
            };
            mag.draw_series(LineSeries::new(
                points(curve.response, db),
                colour.stroke_width(2),
            ))
            .map_err(text)?
            .label(curve.name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
            if let Some(std) = curve.std {
                for sign in [1.0, -1.0] {
                    let band: Vec<(f64, f64)> = f
                        .iter()
                        .zip(curve.response.iter().zip(std))
                        .map(|(x, (g, s))| (*x, g.norm() + sign * 2.0 * s))
                        .filter(|(x, m)| *x > 0.0 && *m > 0.0 && m.is_finite())
                        .map(|(x, m)| (x, 20.0 * m.log10()))
                        .collect();
                    let series = mag
                        .draw_series(LineSeries::new(band, colour.mix(0.5).stroke_width(1)))
                        .map_err(text)?;
                    if sign > 0.0 {
                        series.label("model +/- 2 sigma_G").legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 20, y)], colour.mix(0.5))
                        });
                    }
                }
            }
        }
        if let Some(r) = &resid {
            mag.draw_series(
                points(r, db)
                    .into_iter()
                    .map(|p| Cross::new(p, 2, RESIDUAL.stroke_width(1))),
            )
            .map_err(text)?
            .label("residual |Y/U - G|")
            .legend(|(x, y)| Cross::new((x, y), 3, RESIDUAL.stroke_width(1)));
        }
        if let Some(s) = &sigma {
            let line: Vec<(f64, f64)> = f
                .iter()
                .zip(s)
                .filter(|(x, v)| **x > 0.0 && **v > 0.0 && v.is_finite())
                .map(|(x, v)| (*x, 20.0 * v.log10()))
                .collect();
            mag.draw_series(LineSeries::new(line, NOISE.stroke_width(1)))
                .map_err(text)?
                .label("noise level sigma_G = sqrt(var_y)/|U|")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], NOISE));
        }
        mag.configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(text)?;

        let mut phase = ChartBuilder::on(&lower)
            .caption("Bode plot: phase", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d((fmin..fmax).log_scale(), -180.0..180.0)
            .map_err(text)?;
        phase
            .configure_mesh()
            .x_desc("frequency (Hz)")
            .y_desc("phase (degrees)")
            .draw()
            .map_err(text)?;
        phase
            .draw_series(
                points(&ratio, |z| z.arg().to_degrees())
                    .into_iter()
                    .map(|p| Circle::new(p, 2, DATA.filled())),
            )
            .map_err(text)?;
        for (i, curve) in curves.iter().enumerate() {
            let colour = if i + 1 == curves.len() {
                FINAL
            } else {
                INITIAL
            };
            for piece in phase_pieces(&f, curve.response) {
                phase
                    .draw_series(LineSeries::new(
                        piece.into_iter().filter(|(x, _)| *x > 0.0),
                        colour.stroke_width(2),
                    ))
                    .map_err(text)?;
            }
        }
        root.present().map_err(text)?;
    }
    Ok(svg)
}

/// The residual spectrum: |r_k| in noise standard deviations (r_k/√λ̂ when λ is
/// estimated) of the initial and final fits against frequency (Hz, log scale), with the
/// level 1 and the level c exceeded with probability α by one line of a correct model:
/// c² = −ln α for |r|² ~ Exp(1) (exact variances), c² = ν(α^{−1/ν} − 1) for |r|² ~
/// F(2, 2ν) (sample variances with ν degrees of freedom).
///
/// # Errors
/// The drawing backend's, as text.
pub fn residuals(initial: &SpecFit, last: &SpecFit, alpha: f64) -> Result<String, String> {
    let series = |fit: &SpecFit| -> Vec<(f64, f64)> {
        let scale = if fit.noise_known {
            1.0
        } else {
            let dof = fit.residuals.len() as f64 - fit.n_params as f64 / 2.0;
            if dof > 0.0 {
                fit.cost / dof
            } else {
                fit.noise_variance
            }
        };
        fit.omega
            .iter()
            .zip(&fit.residuals)
            .map(|(w, r)| (w / TAU, r.norm() / scale.sqrt()))
            .filter(|(f, r)| *f > 0.0 && *r > 0.0 && r.is_finite())
            .collect()
    };
    let (a, b) = (series(initial), series(last));
    let level = match last.variance_dof.filter(|_| last.noise_known) {
        Some(nu) if nu > 0 => {
            let nu = nu as f64;
            (nu * (alpha.powf(-1.0 / nu) - 1.0)).sqrt()
        }
        _ => (-alpha.ln()).sqrt(),
    };
    let (fmin, fmax) = range(a.iter().chain(&b).map(|p| p.0.ln()), 0.0, (0.0, 1.0));
    let (fmin, fmax) = (fmin.exp(), fmax.exp());
    if fmax.partial_cmp(&fmin) != Some(std::cmp::Ordering::Greater) {
        return Err("fewer than two lines with a positive frequency to plot".into());
    }
    let (rlo, rhi) = range(
        a.iter()
            .chain(&b)
            .map(|p| p.1.ln())
            .chain([level.ln(), 0.0]),
        0.05,
        (-1.0, 1.0),
    );
    let (rlo, rhi) = (rlo.exp(), rhi.exp());

    let mut svg = String::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (SIZE.0, SIZE.1 / 2 + 100)).into_drawing_area();
        root.fill(&WHITE).map_err(text)?;
        let mut chart = ChartBuilder::on(&root)
            .caption("Normalised residual spectrum |r_k|", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d((fmin..fmax).log_scale(), (rlo..rhi).log_scale())
            .map_err(text)?;
        chart
            .configure_mesh()
            .x_desc("frequency (Hz)")
            .y_desc("|r_k| (noise std)")
            .draw()
            .map_err(text)?;
        for (pts, colour, name) in [(a, INITIAL, "initial fit"), (b, FINAL, "final fit")] {
            chart
                .draw_series(LineSeries::new(pts, colour.stroke_width(1)))
                .map_err(text)?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
        }
        chart
            .draw_series(LineSeries::new([(fmin, 1.0), (fmax, 1.0)], BLACK))
            .map_err(text)?
            .label("1 (noise level)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
        chart
            .draw_series(LineSeries::new(
                [(fmin, level), (fmax, level)],
                NOISE.stroke_width(2),
            ))
            .map_err(text)?
            .label(format!("alpha = {alpha} level per line ({level:.3})"))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], NOISE.stroke_width(2)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(text)?;
        root.present().map_err(text)?;
    }
    Ok(svg)
}
