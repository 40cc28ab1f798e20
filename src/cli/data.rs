//! Reading the data file and turning it into the frequency lines that are fitted.

use super::Failure;
use super::args::{CommonArgs, DomainArg, parse_band, parse_port};
use fdid::criterion::interior_lines;
use fdid::io::{Measurement, TouchstoneVersion, is_touchstone, read_csv, read_touchstone};
use fdid::prelude::*;
use std::result::Result;

/// The frequency lines to fit, with a description of where they came from.
pub struct Prepared {
    /// The lines fitted.
    pub data: FrequencyData<f64>,
    /// The model domain of `--domain`, with the model's sample time in z.
    pub domain: Domain<f64>,
    /// Sample time of the measurement: the time record's, or --ts for frequency data.
    pub record_ts: Option<f64>,
    /// Whether the data come from a time record (t,u,y).
    pub time_record: bool,
    /// One-line description of the source.
    pub source: String,
    /// How the lines are weighted.
    pub weighting: String,
    /// Remarks for the text output.
    pub notes: Vec<String>,
    /// The time record, for time-record files.
    pub record: Option<TimeData<f64>>,
}

/// Reads `args.data` and applies --periods, --ts and --band. `noise_model`: a noise model
/// will be fitted, so the lines without input are kept and the Nyquist line dropped.
pub fn prepare(args: &CommonArgs, noise_model: bool) -> Result<Prepared, Failure> {
    let (measurement, entry) = read(args)?;
    let mut notes = Vec::new();
    let time_record = matches!(measurement, Measurement::Time(_));
    let record = match &measurement {
        Measurement::Time(r) => Some(r.clone()),
        Measurement::Frequency(_) => None,
    };
    let (data, ts, source) = match measurement {
        Measurement::Frequency(data) => frequency_lines(args, data, entry.as_deref())?,
        Measurement::Time(record) => time_lines(args, &record, noise_model, &mut notes)?,
    };
    let (data, source) = band(args, data, source)?;
    let record_ts = data.ts();
    let (data, weighting) = weighting(data, &mut notes)?;
    Ok(Prepared {
        data,
        domain: super::domain(args.domain, ts)?,
        record_ts,
        time_record,
        source,
        weighting,
        notes,
        record,
    })
}

/// Reads the data file: a Touchstone file (by extension) as the entry `--port` picks,
/// described, or a CSV file.
fn read(args: &CommonArgs) -> Result<(Measurement<f64>, Option<String>), Failure> {
    if is_touchstone(&args.data) {
        let (data, entry) = read_entry(args)?;
        return Ok((Measurement::Frequency(data), Some(entry)));
    }
    if let Some(p) = &args.port {
        return Err(Failure::usage(format!(
            "--port {p} applies to Touchstone files (.s1p, .s2p, .ts), but {} is not one",
            args.data.display()
        )));
    }
    Ok((
        read_csv::<f64>(&args.data).map_err(|e| name_file(args, e))?,
        None,
    ))
}

/// A read error that names the file.
fn name_file(args: &CommonArgs, e: FdidError) -> Failure {
    match e {
        // these already name the file
        FdidError::Parse { .. } | FdidError::Io(_) => Failure::from(e),
        e => Failure::runtime(format!("{}: {e}", args.data.display())),
    }
}

/// The entry X_ij of the Touchstone file `args.data` that `--port` picks (default 11 for
/// one port, 21 for two), and its description.
fn read_entry(args: &CommonArgs) -> Result<(FrequencyData<f64>, String), Failure> {
    let port = match &args.port {
        Some(text) => Some(parse_port(text).map_err(Failure::usage)?),
        None => None,
    };
    let file = read_touchstone(&args.data).map_err(|e| name_file(args, e))?;
    let ports = file.ports;
    let port = port.unwrap_or(if ports == 1 { (1, 1) } else { (2, 1) });
    if port.0 > ports || port.1 > ports {
        return Err(Failure::usage(format!(
            "invalid --port {}{}: {} is a {ports}-port file (ports 1..{ports})",
            port.0,
            port.1,
            args.data.display()
        )));
    }
    let data = file
        .frequency_data::<f64>(port)
        .map_err(|e| name_file(args, e))?;
    let version = match file.version {
        TouchstoneVersion::V1 => "",
        TouchstoneVersion::V2 => " (version 2.0)",
    };
    let reference = match file.references.as_slice() {
        [r1, r2] if r1 != r2 => format!("references {r1}, {r2} ohm"),
        [r, ..] => format!("R = {r} ohm"),
        [] => format!("R = {} ohm", file.reference),
    };
    let entry = format!(
        "Touchstone{version} {}{}{} ({reference})",
        file.parameter.letter(),
        port.0,
        port.1,
    );
    Ok((data, entry))
}

/// The lines of frequency data with the sample time of `--ts` (z only) and the
/// description of the source (`entry`, a Touchstone entry, when given).
fn frequency_lines(
    args: &CommonArgs,
    data: FrequencyData<f64>,
    entry: Option<&str>,
) -> Result<(FrequencyData<f64>, Option<f64>, String), Failure> {
    if let Some(p) = args.periods {
        return Err(Failure::usage(format!(
            "--periods {p} applies to time records only, but {} holds frequency data",
            args.data.display()
        )));
    }
    let ts = match (args.domain, args.ts) {
        (_, Some(ts)) if !(ts.is_finite() && ts > 0.0) => {
            return Err(Failure::usage(format!(
                "invalid --ts {ts}: the sample time must be positive and finite"
            )));
        }
        (DomainArg::Z, None) => {
            return Err(Failure::usage(format!(
                "--domain z needs the sample time of the frequency data in {}: pass --ts SECONDS",
                args.data.display()
            )));
        }
        (DomainArg::Z, Some(ts)) => Some(ts),
        (DomainArg::S, _) => None,
    };
    let n = data.len();
    let data = data.with_ts(ts)?;
    let kind = if data.u().iter().all(|u| *u == Complex::new(1.0, 0.0)) {
        "frequency response"
    } else {
        "input/output spectra"
    };
    let source = match entry {
        Some(entry) => format!("{entry}, {n} lines"),
        None => format!("{kind}, {n} lines"),
    };
    Ok((data, ts, source))
}

/// The DFT lines of a time record (averaged over `--periods`), without DC and the lines
/// without input (`noise_model`: with them, without Nyquist), with the model's sample
/// time (z only) and the description of the source.
fn time_lines(
    args: &CommonArgs,
    record: &TimeData<f64>,
    noise_model: bool,
    notes: &mut Vec<String>,
) -> Result<(FrequencyData<f64>, Option<f64>, String), Failure> {
    let ts = record.ts();
    if let Some(given) = args.ts
        && (given.is_nan() || (given - ts).abs() > 1e-6 * ts)
    {
        return Err(Failure::usage(format!(
            "--ts {given} contradicts the time record, whose t column gives Ts = {ts} s \
             (--ts is for frequency data; rescale t to change Ts)"
        )));
    }
    let n = record.len();
    let (data, how) = match args.periods {
        Some(p) => (
            record.average_periods(p)?,
            format!(
                "averaged over {p} period{} of {} samples",
                if p == 1 { "" } else { "s" },
                n / p.max(1)
            ),
        ),
        None => (record.dft(), "DFT of the whole record".to_string()),
    };
    let total = data.len();
    // a noise model is also identified from the lines without input
    let data = drop_uninformative(data, noise_model)?;
    let (data, what) = if noise_model {
        (interior_lines(&data)?, "DC or Nyquist")
    } else {
        (data, "DC or zero input")
    };
    let dropped = total - data.len();
    if args.domain == DomainArg::S {
        notes.push(
            "continuous-time model fitted to the DFT lines of a sampled record: an \
             approximation, valid for band-limited data"
                .into(),
        );
    }
    Ok((
        data,
        match args.domain {
            DomainArg::Z => Some(ts),
            DomainArg::S => None,
        },
        format!(
            "time record, {n} samples, Ts = {ts} s, {how}; {total} lines, {dropped} \
             dropped ({what})"
        ),
    ))
}

/// The lines `--band` keeps, with the description of the source extended by it.
fn band(
    args: &CommonArgs,
    data: FrequencyData<f64>,
    mut source: String,
) -> Result<(FrequencyData<f64>, String), Failure> {
    let Some(text) = &args.band else {
        return Ok((data, source));
    };
    let (lo, hi) = parse_band(text).map_err(Failure::usage)?;
    let f = data.freq_hz();
    let lo = lo.unwrap_or(0.0);
    let hi = hi.unwrap_or_else(|| f.last().copied().unwrap_or(0.0));
    let before = data.len();
    let banded = data.band_hz(lo, hi).map_err(|e| match e {
        FdidError::EmptyBand { .. } => Failure::runtime(format!(
            "--band {text} selects no frequency lines: the data span {} .. {} Hz",
            f.first().copied().unwrap_or(f64::NAN),
            f.last().copied().unwrap_or(f64::NAN)
        )),
        e => Failure::from(e),
    })?;
    source.push_str(&format!(
        "; band {lo}..{hi} Hz keeps {} of {before}",
        banded.len()
    ));
    Ok((banded, source))
}

/// Drops the DC line and, unless `keep_unexcited`, every line with an exactly zero input
/// spectrum; fails when the input is zero on every line above DC.
fn drop_uninformative(
    data: FrequencyData<f64>,
    keep_unexcited: bool,
) -> Result<FrequencyData<f64>, Failure> {
    let excited = |w: f64, u: &Complex<f64>| w > 0.0 && u.norm_sqr() > 0.0;
    if !data
        .omega()
        .iter()
        .zip(data.u())
        .any(|(w, u)| excited(*w, u))
    {
        return Err(Failure::runtime(
            "the input spectrum is zero on every line above DC: the record carries no \
             information about the system"
                .into(),
        ));
    }
    let keep: Vec<bool> = data
        .omega()
        .iter()
        .zip(data.u())
        .map(|(w, u)| excited(*w, u) || (keep_unexcited && *w > 0.0))
        .collect();
    select(&data, &keep)
}

/// The lines where `keep` is true, with their noise variances and sample time.
fn select(data: &FrequencyData<f64>, keep: &[bool]) -> Result<FrequencyData<f64>, Failure> {
    Ok(data.select_lines(keep)?)
}

/// Decides the line weighting: the output noise variances when every line has a positive
/// one, flat otherwise.
fn weighting(
    data: FrequencyData<f64>,
    notes: &mut Vec<String>,
) -> Result<(FrequencyData<f64>, String), Failure> {
    let Some(noise) = data.noise() else {
        return Ok((
            data,
            "flat (noise variance estimated from the residuals)".into(),
        ));
    };
    if noise.var_y.iter().all(|v| *v > 0.0) {
        return Ok((
            data,
            "1/sigma_k from the per-line output noise variance".into(),
        ));
    }
    let zeros = noise
        .var_y
        .iter()
        .filter(|v| v.is_nan() || **v <= 0.0)
        .count();
    notes.push(format!(
        "the output noise variance is zero on {zeros} line(s): noise variances ignored, flat \
         weighting used"
    ));
    Ok((
        data.without_noise(),
        "flat (noise variance estimated from the residuals)".into(),
    ))
}
