//! The SVG figures (feature `plot`): for `fdid diagnose --report DIR` a Bode plot of the
//! data and the initial and final models and the spectrum of the normalised residuals;
//! for `fdid fit --plot FILE` a Bode plot of the data, the model with its uncertainty
//! band and the residual; for `fdid stabilize --plot FILE` the stabilisation diagram.

use fdid::prelude::*;
use fdid::workflow::SpecFit;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
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

/// Bins of the frequency axis (log scale) a series is thinned to: one per pixel column.
const COLUMNS: usize = SIZE.0 as usize;

/// `points` (sorted by frequency, positive) thinned for drawing: within each of
/// [`COLUMNS`] log-spaced bins of their frequency range only the first, lowest, highest
/// and last points are kept, in order. The drawn envelope is that of all the points, and
/// a curve holds at most 4·[`COLUMNS`] points whatever the number of lines.
fn decimate(points: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    if points.len() <= 4 * COLUMNS {
        return points;
    }
    let (lo, hi) = (points[0].0.ln(), points[points.len() - 1].0.ln());
    let width = (hi - lo) / COLUMNS as f64;
    let bin = |x: f64| {
        if width > 0.0 {
            (((x.ln() - lo) / width) as usize).min(COLUMNS - 1)
        } else {
            0
        }
    };
    let mut kept = Vec::with_capacity(4 * COLUMNS);
    let mut start = 0;
    while start < points.len() {
        let b = bin(points[start].0);
        let end = start + points[start..].partition_point(|p| bin(p.0) == b);
        let group = &points[start..end];
        let (mut low, mut high) = (0, 0);
        for (i, p) in group.iter().enumerate() {
            if p.1 < group[low].1 {
                low = i;
            }
            if p.1 > group[high].1 {
                high = i;
            }
        }
        let mut idx = [0, low, high, group.len() - 1];
        idx.sort_unstable();
        let mut last = None;
        for i in idx {
            if last != Some(i) {
                kept.push(group[i]);
                last = Some(i);
            }
        }
        start = end;
    }
    kept
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
    pieces.into_iter().map(decimate).collect()
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
    let bode = Bode::new(data, curves, residual)?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(text)?;
        let (upper, lower) = root.split_vertically(SIZE.1 / 2);
        bode.draw_magnitude(&upper, curves)?;
        bode.draw_phase(&lower, curves)?;
        root.present().map_err(text)?;
    }
    Ok(svg)
}

/// A drawing area of an SVG figure.
type Area<'b> = DrawingArea<SVGBackend<'b>, Shift>;

/// The magnitude chart of a Bode plot: frequency on a log scale, magnitude in dB.
type MagnitudeChart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<LogCoord<f64>, RangedCoordf64>>;

/// What a Bode plot shows besides its model curves.
struct Bode {
    /// Frequency (Hz) of each line of the data.
    f: Vec<f64>,
    /// The data Y/U.
    ratio: Vec<Complex<f64>>,
    /// The noise level σ_G = sqrt(var_y)/|U|, when the data carry noise variances.
    sigma: Option<Vec<f64>>,
    /// The residual Y/U − Ĝ of the last curve, when asked for.
    resid: Option<Vec<Complex<f64>>>,
    /// The frequency axis (Hz).
    freq: (f64, f64),
    /// The magnitude axis (dB).
    magnitude: (f64, f64),
}

impl Bode {
    /// The series of `data` and the axes that hold them and the `curves`.
    fn new(
        data: &FrequencyData<f64>,
        curves: &[Curve<'_>],
        residual: bool,
    ) -> Result<Self, String> {
        let f: Vec<f64> = data.omega().iter().map(|w| w / TAU).collect();
        let ratio: Vec<Complex<f64>> = data.y().iter().zip(data.u()).map(|(y, u)| y / u).collect();
        let sigma: Option<Vec<f64>> = data.noise().map(|n| {
            n.var_y
                .iter()
                .zip(data.u())
                .map(|(v, u)| v.sqrt() / u.norm())
                .collect()
        });
        let freq = frequency_axis(&f)?;
        let resid: Option<Vec<Complex<f64>>> = curves
            .last()
            .filter(|_| residual)
            .map(|c| ratio.iter().zip(c.response).map(|(r, g)| r - g).collect());
        let magnitude = magnitude_axis(&ratio, curves, sigma.as_deref(), resid.as_deref());
        Ok(Self {
            f,
            ratio,
            sigma,
            resid,
            freq,
            magnitude,
        })
    }

    /// The magnitude chart: data, curves with their bands, residual, noise level, legend.
    fn draw_magnitude(&self, area: &Area<'_>, curves: &[Curve<'_>]) -> Result<(), String> {
        let mut mag = ChartBuilder::on(area)
            .caption("Bode plot: magnitude", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(
                (self.freq.0..self.freq.1).log_scale(),
                self.magnitude.0..self.magnitude.1,
            )
            .map_err(text)?;
        mag.configure_mesh()
            .x_desc("frequency (Hz)")
            .y_desc("|G| (dB)")
            .draw()
            .map_err(text)?;
        mag.draw_series(
            points(&self.f, &self.ratio, db)
                .into_iter()
                .map(|p| Circle::new(p, 2, DATA.filled())),
        )
        .map_err(text)?
        .label("data Y/U")
        .legend(|(x, y)| Circle::new((x, y), 3, DATA.filled()));
        for (i, curve) in curves.iter().enumerate() {
            draw_model(&mut mag, &self.f, curve, curve_colour(i, curves.len()))?;
        }
        if let Some(r) = &self.resid {
            mag.draw_series(
                points(&self.f, r, db)
                    .into_iter()
                    .map(|p| Cross::new(p, 2, RESIDUAL.stroke_width(1))),
            )
            .map_err(text)?
            .label("residual |Y/U - G|")
            .legend(|(x, y)| Cross::new((x, y), 3, RESIDUAL.stroke_width(1)));
        }
        if let Some(s) = &self.sigma {
            draw_noise_level(&mut mag, &self.f, s)?;
        }
        mag.configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(text)
    }

    /// The phase chart: data and curves, each curve split where its phase wraps.
    fn draw_phase(&self, area: &Area<'_>, curves: &[Curve<'_>]) -> Result<(), String> {
        let mut phase = ChartBuilder::on(area)
            .caption("Bode plot: phase", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d((self.freq.0..self.freq.1).log_scale(), -180.0..180.0)
            .map_err(text)?;
        phase
            .configure_mesh()
            .x_desc("frequency (Hz)")
            .y_desc("phase (degrees)")
            .draw()
            .map_err(text)?;
        phase
            .draw_series(
                points(&self.f, &self.ratio, |z| z.arg().to_degrees())
                    .into_iter()
                    .map(|p| Circle::new(p, 2, DATA.filled())),
            )
            .map_err(text)?;
        for (i, curve) in curves.iter().enumerate() {
            let colour = curve_colour(i, curves.len());
            for piece in phase_pieces(&self.f, curve.response) {
                phase
                    .draw_series(LineSeries::new(
                        piece.into_iter().filter(|(x, _)| *x > 0.0),
                        colour.stroke_width(2),
                    ))
                    .map_err(text)?;
            }
        }
        Ok(())
    }
}

/// The frequency axis (Hz) of the lines `f` with a positive frequency.
fn frequency_axis(f: &[f64]) -> Result<(f64, f64), String> {
    let fp: Vec<f64> = f.iter().copied().filter(|x| *x > 0.0).collect();
    match (fp.first(), fp.last()) {
        (Some(a), Some(b)) if b > a => Ok((*a, *b)),
        (Some(a), _) => Ok((*a * 0.5, *a * 2.0)),
        _ => Err("no line with a positive frequency to plot".into()),
    }
}

/// The magnitude axis (dB) of the data, the curves, the noise level and the residual.
fn magnitude_axis(
    ratio: &[Complex<f64>],
    curves: &[Curve<'_>],
    sigma: Option<&[f64]>,
    resid: Option<&[Complex<f64>]>,
) -> (f64, f64) {
    let mags = ratio
        .iter()
        .chain(curves.iter().flat_map(|c| c.response.iter()))
        .map(|z| db(*z))
        .chain(sigma.iter().copied().flatten().map(|s| 20.0 * s.log10()));
    let (mut mlo, mhi) = range(mags, 0.05, (-1.0, 1.0));
    if let Some(r) = resid {
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
    (mlo, mhi)
}

/// The colour of curve `i` of `n`: the last one is the final model.
fn curve_colour(i: usize, n: usize) -> RGBColor {
    if i + 1 == n { FINAL } else { INITIAL }
}

/// The points `(f, val(g))` at positive frequencies where the value is finite,
/// thinned by [`decimate`].
fn points(f: &[f64], g: &[Complex<f64>], val: fn(Complex<f64>) -> f64) -> Vec<(f64, f64)> {
    decimate(
        f.iter()
            .zip(g)
            .filter(|(x, z)| **x > 0.0 && val(**z).is_finite())
            .map(|(x, z)| (*x, val(*z)))
            .collect(),
    )
}

/// One model curve on the magnitude chart, with its band |Ĝ| ± 2σ_G when σ_G is given.
fn draw_model(
    mag: &mut MagnitudeChart<'_, '_>,
    f: &[f64],
    curve: &Curve<'_>,
    colour: RGBColor,
) -> Result<(), String> {
    mag.draw_series(LineSeries::new(
        points(f, curve.response, db),
        colour.stroke_width(2),
    ))
    .map_err(text)?
    .label(curve.name)
    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
    let Some(std) = curve.std else {
        return Ok(());
    };
    for sign in [1.0, -1.0] {
        let band: Vec<(f64, f64)> = f
            .iter()
            .zip(curve.response.iter().zip(std))
            .map(|(x, (g, s))| (*x, g.norm() + sign * 2.0 * s))
            .filter(|(x, m)| *x > 0.0 && *m > 0.0 && m.is_finite())
            .map(|(x, m)| (x, 20.0 * m.log10()))
            .collect();
        let band = decimate(band);
        let series = mag
            .draw_series(LineSeries::new(band, colour.mix(0.5).stroke_width(1)))
            .map_err(text)?;
        if sign > 0.0 {
            series
                .label("model +/- 2 sigma_G")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.mix(0.5)));
        }
    }
    Ok(())
}

/// The noise level σ_G of the data on the magnitude chart.
fn draw_noise_level(
    mag: &mut MagnitudeChart<'_, '_>,
    f: &[f64],
    sigma: &[f64],
) -> Result<(), String> {
    let line: Vec<(f64, f64)> = f
        .iter()
        .zip(sigma)
        .filter(|(x, v)| **x > 0.0 && **v > 0.0 && v.is_finite())
        .map(|(x, v)| (*x, 20.0 * v.log10()))
        .collect();
    mag.draw_series(LineSeries::new(decimate(line), NOISE.stroke_width(1)))
        .map_err(text)?
        .label("noise level sigma_G = sqrt(var_y)/|U|")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], NOISE));
    Ok(())
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
    let (a, b) = (
        decimate(normalised_residuals(initial)),
        decimate(normalised_residuals(last)),
    );
    let level = level_per_line(last, alpha);
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
    let axes = ((fmin, fmax), (rlo.exp(), rhi.exp()));
    let mut svg = String::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (SIZE.0, SIZE.1 / 2 + 100)).into_drawing_area();
        root.fill(&WHITE).map_err(text)?;
        draw_residuals(&root, axes, [a, b], level, alpha)?;
        root.present().map_err(text)?;
    }
    Ok(svg)
}

/// The points (f in Hz, |r_k| in noise standard deviations) of a fit's residuals at
/// positive frequencies (in order).
fn normalised_residuals(fit: &SpecFit) -> Vec<(f64, f64)> {
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
}

/// The level c that one line of a correct model exceeds with probability `alpha`.
fn level_per_line(last: &SpecFit, alpha: f64) -> f64 {
    match last.variance_dof.filter(|_| last.noise_known) {
        Some(nu) if nu > 0 => {
            let nu = nu as f64;
            (nu * (alpha.powf(-1.0 / nu) - 1.0)).sqrt()
        }
        _ => (-alpha.ln()).sqrt(),
    }
}

/// The residual chart on `root` with the axes `((fmin, fmax), (rlo, rhi))`: the initial
/// and final residuals `fits`, the level 1 and the level per line.
fn draw_residuals(
    root: &Area<'_>,
    axes: ((f64, f64), (f64, f64)),
    fits: [Vec<(f64, f64)>; 2],
    level: f64,
    alpha: f64,
) -> Result<(), String> {
    let ((fmin, fmax), (rlo, rhi)) = axes;
    let mut chart = ChartBuilder::on(root)
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
    let [a, b] = fits;
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
        .map_err(text)
}

/// The stabilisation diagram: each pole of the diagram as a mark at (natural frequency,
/// order) — o new (grey circle), f frequency (blue), d + damping (green), v + shape
/// (orange), s stable (red, filled) — over the summed magnitude Σ|G_ij| of the data in dB
/// (grey line, right axis), with the physical modes as vertical dashed lines.
///
/// # Errors
/// The drawing backend's, as text.
pub fn stabilisation(
    diagram: &fdid::mimo::StabilisationDiagram<f64>,
    f_hz: &[f64],
    summed: &[f64],
) -> Result<String, String> {
    use fdid::mimo::PoleMark;
    let freq = range(f_hz.iter().copied(), 0.0, (0.0, 1.0));
    let top = diagram.orders.last().copied().unwrap_or(1) as f64;
    let orders = (0.0, top + 1.0);
    let level: Vec<f64> = summed.iter().map(|m| 20.0 * m.log10()).collect();
    let db = range(level.iter().copied(), 0.05, (-1.0, 1.0));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(text)?;
        let mut chart = ChartBuilder::on(&root)
            .caption("Stabilisation diagram", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(50)
            .right_y_label_area_size(60)
            .build_cartesian_2d(freq.0..freq.1, orders.0..orders.1)
            .map_err(text)?
            .set_secondary_coord(freq.0..freq.1, db.0..db.1);
        chart
            .configure_mesh()
            .x_desc("frequency (Hz)")
            .y_desc("model order (poles)")
            .draw()
            .map_err(text)?;
        chart
            .configure_secondary_axes()
            .y_desc("sum of |G_ij| (dB)")
            .draw()
            .map_err(text)?;
        chart
            .draw_secondary_series(LineSeries::new(
                f_hz.iter().copied().zip(level.iter().copied()),
                DATA.mix(0.6).stroke_width(1),
            ))
            .map_err(text)?
            .label("sum of |G_ij| (right axis)")
            .legend(|(x, y)| PathElement::new(vec![(x - 8, y), (x + 8, y)], DATA));
        for m in &diagram.modes {
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(m.f_n_hz, orders.0), (m.f_n_hz, orders.1)],
                    4,
                    4,
                    FINAL.mix(0.4).stroke_width(1),
                ))
                .map_err(text)?;
        }
        let marks = [
            (PoleMark::New, "o  new", RGBColor(150, 150, 150)),
            (PoleMark::Frequency, "f  frequency", INITIAL),
            (PoleMark::Damping, "d  + damping", NOISE),
            (PoleMark::Shape, "v  + mode shape", RGBColor(255, 127, 14)),
            (PoleMark::Stable, "s  stable", FINAL),
        ];
        for (mark, name, colour) in marks {
            let filled = mark == PoleMark::Stable;
            let style = if filled {
                colour.filled()
            } else {
                colour.stroke_width(1)
            };
            chart
                .draw_series(
                    diagram
                        .poles
                        .iter()
                        .filter(|p| p.mark == mark)
                        .map(|p| Circle::new((p.mode.f_n_hz, p.order as f64), 3, style)),
                )
                .map_err(text)?
                .label(name)
                .legend(move |(x, y)| Circle::new((x, y), 3, style));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(text)?;
        root.present().map_err(text)?;
    }
    Ok(svg)
}

/// One magnitude panel per entry of a common-pole fit, in a grid of ny rows (outputs) by
/// nu columns (inputs): |G_ij| in dB against frequency (Hz, log scale) of the data (points,
/// when given: an FRF matrix) and of the model (line).
///
/// # Errors
/// The drawing backend's, as text; no line above 0 Hz.
pub fn bode_grid(
    f_hz: &[f64],
    data: Option<&[Vec<Complex<f64>>]>,
    model: &[Vec<Complex<f64>>],
    (ny, nu): (usize, usize),
) -> Result<String, String> {
    const PANEL: (u32, u32) = (300, 220);
    let size = (PANEL.0 * nu as u32, PANEL.1 * ny as u32 + 30);
    let freq = frequency_axis(f_hz)?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(text)?;
        let root = root
            .titled("Common-pole model: |G_ij| per entry", ("sans-serif", 18))
            .map_err(text)?;
        let panels = root.split_evenly((ny, nu));
        for (p, area) in panels.iter().enumerate() {
            let (i, j) = (p / nu, p % nu);
            let e = j * ny + i;
            let all = model[e]
                .iter()
                .chain(data.map_or(&[][..], |d| d[e].as_slice()))
                .map(|z| db(*z));
            let mag = range(all, 0.05, (-1.0, 1.0));
            let mut chart = ChartBuilder::on(area)
                .caption(
                    format!("G{}{} (output {}, input {})", i + 1, j + 1, i + 1, j + 1),
                    ("sans-serif", 13),
                )
                .margin(6)
                .x_label_area_size(25)
                .y_label_area_size(45)
                .build_cartesian_2d((freq.0..freq.1).log_scale(), mag.0..mag.1)
                .map_err(text)?;
            chart
                .configure_mesh()
                .x_labels(4)
                .y_labels(5)
                .label_style(("sans-serif", 10))
                .draw()
                .map_err(text)?;
            if let Some(d) = data {
                chart
                    .draw_series(
                        points(f_hz, &d[e], db)
                            .into_iter()
                            .map(|p| Circle::new(p, 1, DATA.filled())),
                    )
                    .map_err(text)?;
            }
            chart
                .draw_series(LineSeries::new(
                    points(f_hz, &model[e], db),
                    FINAL.stroke_width(2),
                ))
                .map_err(text)?;
        }
        root.present().map_err(text)?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_million_points_thin_to_a_few_per_column_with_their_envelope() {
        let n = 1_000_000;
        let pts: Vec<(f64, f64)> = (1..=n)
            .map(|k| {
                let f = k as f64 * 0.01;
                (f, (k as f64 * 0.7).sin() * 10.0 - f.ln())
            })
            .collect();
        let kept = decimate(pts.clone());
        assert!(kept.len() <= 4 * COLUMNS, "{} points", kept.len());
        assert!(kept.windows(2).all(|w| w[0].0 < w[1].0));
        let extreme = |v: &[(f64, f64)], max: bool| {
            v.iter()
                .map(|p| p.1)
                .fold(if max { f64::MIN } else { f64::MAX }, |a, b| {
                    if max { a.max(b) } else { a.min(b) }
                })
        };
        assert_eq!(extreme(&kept, true), extreme(&pts, true));
        assert_eq!(extreme(&kept, false), extreme(&pts, false));
        assert_eq!(kept.first(), pts.first());
        assert_eq!(kept.last(), pts.last());
        // few points are left alone
        let few = pts[..100].to_vec();
        assert_eq!(decimate(few.clone()), few);
    }
}
