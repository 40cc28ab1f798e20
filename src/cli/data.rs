//! Reading the data file and turning it into the frequency lines that are fitted.

use super::Failure;
use super::args::{CommonArgs, DomainArg, LinesArg, parse_band, parse_port};
use fdid::criterion::interior_lines;
use fdid::data::{
    EXCITATION_FRACTION, ExcitationRule, FrfMatrix, InputNoise, Normalisation,
    PERIODICITY_TOLERANCE, RealisationBla, UNEXCITED_NEIGHBOURS,
};
use fdid::io::{
    ChannelSelection, Column, Measurement, MultiChannelSelection, TouchstoneVersion,
    is_frf_matrix_csv, is_touchstone, read_channels, read_csv, read_multichannel, read_touchstone,
};
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
    /// The time record, for time-record files (without the periods --skip-periods drops).
    pub record: Option<TimeData<f64>>,
    /// Time records: how many of the lines fitted the input excites
    /// ([`FrequencyData::excitation`]).
    pub lines_excited: Option<usize>,
    /// Time records with --periods: the number of periods averaged (after
    /// --skip-periods).
    pub periods: Option<usize>,
    /// Time records with --realisations: the best linear approximation over them.
    pub realisations: Option<Realisations>,
    /// Time records whose input leaves lines unexcited (the gap or grid rule of
    /// [`FrequencyData::excitation`]): the excited lines in --band with output-error
    /// variances from the unexcited lines nearby ([`FrequencyData::unexcited_noise`]).
    pub unexcited_noise: Option<FrequencyData<f64>>,
}

/// The realisations of a periodic experiment (--realisations) behind the fitted BLA.
pub struct Realisations {
    /// The BLA with its noise and total variances.
    pub bla: RealisationBla<f64>,
    /// Each realisation's steady-state record (--skip-periods dropped).
    pub records: Vec<TimeData<f64>>,
    /// The BLA lines kept by --band, weighted by the noise variance (between periods);
    /// `None` with one period per realisation.
    pub noise_data: Option<FrequencyData<f64>>,
}

/// The lines of a time record and what the preparation learned about it.
struct TimeLines {
    data: FrequencyData<f64>,
    ts: Option<f64>,
    source: String,
    /// The frequencies of the excited lines (none for the BLA of realisations: every
    /// line is excited).
    excited: Option<Vec<f64>>,
    /// The excited lines with noise variances from the unexcited ones (gap or grid rule).
    unexcited_noise: Option<FrequencyData<f64>>,
    record: TimeData<f64>,
    periods: Option<usize>,
    realisations: Option<Realisations>,
}

/// Reads `args.data` and applies --periods, --ts and --band. `noise_model`: a noise model
/// will be fitted, so the lines without input are kept and the Nyquist line dropped.
pub fn prepare(args: &CommonArgs, noise_model: bool, normalise: bool) -> Result<Prepared, Failure> {
    let (measurement, entry, channels) = read(args)?;
    let mut notes = Vec::new();
    let measurement = if normalise {
        normalise_extremes(measurement, &mut notes)?
    } else {
        measurement
    };
    let time_record = matches!(measurement, Measurement::Time(_));
    let mut record = None;
    let mut periods = None;
    let mut realisations = None;
    let mut excited = None;
    let mut unexcited_noise = None;
    let (data, ts, source) = match measurement {
        Measurement::Frequency(data) => frequency_lines(args, data, entry.as_deref())?,
        Measurement::Matrix(_) => return unreachable_matrix(args),
        Measurement::Time(rec) => {
            let lines = time_lines(args, &rec, noise_model, channels, &mut notes)?;
            record = Some(lines.record);
            periods = lines.periods;
            realisations = lines.realisations;
            excited = lines.excited;
            unexcited_noise = lines.unexcited_noise;
            (lines.data, lines.ts, lines.source)
        }
    };
    let (data, source) = band(args, data, source)?;
    if let Some(r) = realisations.as_mut()
        && let Some(noise_data) = r.noise_data.take()
    {
        r.noise_data = Some(band(args, noise_data, String::new())?.0);
    }
    let unexcited_noise =
        unexcited_noise.and_then(|noisy| band(args, noisy, String::new()).ok().map(|b| b.0));
    let lines_excited = time_record.then(|| match &excited {
        Some(excited) => data
            .omega()
            .iter()
            .filter(|w| excited.binary_search_by(|e| e.total_cmp(w)).is_ok())
            .count(),
        None => data.len(),
    });
    let record_ts = data.ts();
    let (data, mut weighting) = weighting(data, &mut notes)?;
    if let Some(r) = &realisations
        && data.noise().is_some()
    {
        weighting = match r.bla.total_variance() {
            Some(_) => format!(
                "1/sigma_k from the total variance of the BLA over {} realisations (noise + \
                 nonlinear distortion)",
                r.bla.realisations()
            ),
            None => "1/sigma_k from the noise variance of the BLA between periods".into(),
        };
    }
    Ok(Prepared {
        data,
        domain: super::domain(args.domain, ts)?,
        record_ts,
        time_record,
        source,
        weighting,
        notes,
        record,
        lines_excited,
        periods,
        realisations,
        unexcited_noise,
    })
}

/// Binary exponent beyond which [`normalise_extremes`] scales the data: 2^200 ≈ 1.6e60,
/// so that squared data and their sums stay far inside f64.
const EXTREME_EXPONENT: i32 = 200;

/// `diagnose` on data of extreme magnitude (largest |y| or |u| beyond 2^±200): the output
/// and input scaled by powers of two (exact) so that the noise references, detectors and
/// tests see data of order one, with a note; other data unchanged.
fn normalise_extremes(
    m: Measurement<f64>,
    notes: &mut Vec<String>,
) -> Result<Measurement<f64>, Failure> {
    let n = match &m {
        Measurement::Frequency(d) => Normalisation::of(d),
        Measurement::Time(r) => Normalisation::of_samples(r.y(), r.u()),
        Measurement::Matrix(_) => return Ok(m),
    };
    if n.exponent() <= EXTREME_EXPONENT {
        return Ok(m);
    }
    notes.push(format!(
        "data of extreme magnitude: the output was scaled by 2^{} and the input by 2^{} \
         (exact) for the analysis; poles, zeros, delays and tests are unchanged by it, but \
         gains, parameters, costs without noise variances and figures are of the scaled data",
        n.output().log2().round(),
        n.input().log2().round()
    ));
    Ok(match m {
        Measurement::Frequency(d) => Measurement::Frequency(n.apply(&d)),
        Measurement::Matrix(x) => Measurement::Matrix(x),
        Measurement::Time(r) => {
            let scale = |x: &[f64], c: f64| x.iter().map(|v| v * c).collect();
            Measurement::Time(TimeData::new(
                scale(r.u(), n.input()),
                scale(r.y(), n.output()),
                r.ts(),
            )?)
        }
    })
}

/// The entries fitted with common poles: those of a Touchstone file of two or more ports
/// read without `--port`, or the outputs of a table of channels that `--output` lists
/// (each output's FRF prepared as [`prepare`] prepares one, with the outputs' noise
/// covariance between periods when `covariances`: `--full-covariance`); `None` for one
/// entry.
pub(super) fn read_entries(
    args: &CommonArgs,
    covariances: bool,
) -> Result<Option<super::mimo::Entries>, Failure> {
    if let Some(list) = args.input.as_deref().filter(|i| i.contains(',')) {
        return input_spectra(args, list).map(Some);
    }
    if let Some(list) = args.output.as_deref().filter(|o| o.contains(',')) {
        return output_entries(args, list, covariances).map(Some);
    }
    if args.port.is_some() || args.input.is_some() || args.output.is_some() {
        return Ok(None);
    }
    if is_frf_matrix_csv(&args.data) {
        return match read_csv::<f64>(&args.data).map_err(|e| name_file(args, e))? {
            Measurement::Matrix(matrix) if matrix.ny() * matrix.nu() > 1 => {
                Ok(Some(super::mimo::Entries::Matrix {
                    matrix,
                    parameter: None,
                }))
            }
            _ => Ok(None),
        };
    }
    if !is_touchstone(&args.data) {
        return Ok(None);
    }
    let file = read_touchstone(&args.data)?;
    if file.ports < 2 {
        return Ok(None);
    }
    Ok(Some(super::mimo::Entries::Matrix {
        matrix: file.frf_matrix::<f64>()?,
        parameter: Some(file.parameter),
    }))
}

/// The outputs of `list` (comma-separated) of a table of channels as one column of FRFs,
/// each prepared alone with the same options; they must share their lines.
fn output_entries(
    args: &CommonArgs,
    list: &str,
    covariances: bool,
) -> Result<super::mimo::Entries, Failure> {
    let names = column_list("--output", list)?;
    let mut data = Vec::with_capacity(names.len());
    for name in &names {
        let mut one = args.clone();
        one.output = Some((*name).to_string());
        let prepared = prepare(&one, false, false)?;
        if !prepared.time_record {
            return Err(Failure::usage(format!(
                "--output {list} lists the outputs of a table of channels, but {} holds \
                 frequency data",
                args.data.display()
            )));
        }
        data.push(prepared.data);
    }
    let ny = data.len();
    let matrix = FrfMatrix::from_data(ny, 1, data).map_err(|e| {
        Failure::runtime(format!(
            "--output {list}: the outputs' FRFs are not on the same lines ({e})"
        ))
    })?;
    let matrix = match covariances {
        true => match output_covariances(args, &names, &matrix)? {
            Some(noise) => matrix
                .with_covariances(vec![noise.covariances])?
                .with_input_noise(vec![noise.input])?,
            None => matrix,
        },
        false => matrix,
    };
    Ok(super::mimo::Entries::Matrix {
        matrix,
        parameter: None,
    })
}

/// The noise of the outputs' FRFs on each line of `matrix`, from the spread of the
/// spectra between the periods of a periodic record with one named input (`--input U
/// --periods P`, P > ny + 1 periods kept, no `--realisations`): the ny × ny covariance
/// C_Y/|U|² and the input's terms c_YU/|U|² and σ²_U/|U|² ([`fdid::data::InputNoise`]), with
/// C_Y, c_YU and σ²_U the output, output–input and input covariances of the averaged
/// spectra ([`fdid::data::MimoNoise`]); the fit forms the errors-in-variables covariance
/// C_Y − c_YU Gᴴ − G c_YUᴴ + GGᴴσ²_U (over |U|²) at its response. `None` when the record is
/// not of that kind.
fn output_covariances(
    args: &CommonArgs,
    names: &[&str],
    matrix: &FrfMatrix<f64>,
) -> Result<Option<OutputNoise>, Failure> {
    let (Some(input), Some(periods)) = (args.input.as_deref(), args.periods) else {
        return Ok(None);
    };
    if periods.saturating_sub(args.skip_periods) < names.len() + 2 || args.realisations.is_some() {
        return Ok(None);
    }
    let selection = MultiChannelSelection {
        inputs: vec![Column::parse(input)],
        outputs: names.iter().map(|n| Column::parse(n)).collect(),
        ts: args.ts,
        periods: Some(periods),
        skip_periods: args.skip_periods,
    };
    let spectra = read_multichannel::<f64>(&args.data, &selection).map_err(Failure::from)?;
    let Some(noise) = spectra.noise() else {
        return Ok(None);
    };
    let omega = spectra.omega();
    let mut out = OutputNoise {
        covariances: Vec::with_capacity(matrix.len()),
        input: Vec::with_capacity(matrix.len()),
    };
    for w in matrix.omega() {
        let Some(k) = omega
            .iter()
            .position(|v| (v - w).abs() <= 1e-9 * w.abs().max(1.0))
        else {
            return Ok(None);
        };
        let u2 = spectra.u(0)[k].norm_sqr();
        if u2.is_nan() || u2 <= 0.0 {
            return Ok(None);
        }
        out.covariances
            .push(noise.output_covariance(k).map(|c| c / u2));
        out.input.push(InputNoise {
            cross: noise.cross_covariance(k).column(0).map(|c| c / u2),
            relative_variance: noise.input_variance(0)[k] / u2,
        });
    }
    Ok(Some(out))
}

/// The outputs' FRF covariances and the input's noise terms, line by line.
struct OutputNoise {
    covariances: Vec<nalgebra::DMatrix<fdid::prelude::Complex<f64>>>,
    input: Vec<InputNoise<f64>>,
}

/// The column names of a comma-separated list, refusing an empty name.
fn column_list<'a>(flag: &str, list: &'a str) -> Result<Vec<&'a str>, Failure> {
    let names: Vec<&str> = list.split(',').map(str::trim).collect();
    if let Some(empty) = names.iter().position(|n| n.is_empty()) {
        return Err(Failure::usage(format!(
            "{flag} {list}: entry {} of the list is empty",
            empty + 1
        )));
    }
    Ok(names)
}

/// The spectra of a table's input columns `list` (comma-separated) and its `--output`
/// columns (one or a list), all read as one record whose inputs act together: the DFT of
/// the whole record, or with `--periods P [--skip-periods K]` the average over the
/// periods kept (with the output noise covariances between periods, whose variances
/// weight the fit), without the DC line (a record's offsets), for a common-pole fit of
/// every output on every input.
fn input_spectra(args: &CommonArgs, list: &str) -> Result<super::mimo::Entries, Failure> {
    let Some(outputs) = args.output.as_deref() else {
        return Err(Failure::usage(format!(
            "--input {list} needs --output: name the output columns (one or a comma-separated \
             list)"
        )));
    };
    if is_touchstone(&args.data) || args.port.is_some() {
        return Err(Failure::usage(format!(
            "--input {list} selects columns of a table of channels, not a Touchstone file or \
             an entry (--port)"
        )));
    }
    if args.realisations.is_some() {
        return Err(Failure::usage(format!(
            "--realisations is not available with several inputs in one record (--input \
             {list}): average the periods of one realisation (--periods P) or fit the record \
             as non-periodic (add --transient)"
        )));
    }
    if args.skip_periods > 0 && args.periods.is_none() {
        return Err(Failure::usage(format!(
            "--skip-periods {} needs --periods P: it drops whole periods",
            args.skip_periods
        )));
    }
    let selection = MultiChannelSelection {
        inputs: column_list("--input", list)?
            .into_iter()
            .map(Column::parse)
            .collect(),
        outputs: column_list("--output", outputs)?
            .into_iter()
            .map(Column::parse)
            .collect(),
        ts: args.ts,
        periods: args.periods,
        skip_periods: args.skip_periods,
    };
    let spectra = read_multichannel::<f64>(&args.data, &selection).map_err(|e| match e {
        FdidError::Parse { .. } | FdidError::Io(_) => Failure::from(e),
        e => Failure::runtime(format!("{}: {e}", args.data.display())),
    })?;
    let keep: Vec<bool> = spectra.omega().iter().map(|w| *w > 0.0).collect();
    let spectra = spectra.select_lines(&keep).map_err(Failure::from)?;
    Ok(super::mimo::Entries::Spectra(spectra))
}

/// Reads the data file: a Touchstone file (by extension) as the entry `--port` picks,
/// described, a table of several channels as the columns --input and --output pick, or a
/// CSV file. The flag is true for a table of channels (its sample time is checked).
fn read(args: &CommonArgs) -> Result<(Measurement<f64>, Option<String>, bool), Failure> {
    if is_touchstone(&args.data) {
        if args.input.is_some() || args.output.is_some() {
            return Err(Failure::usage(format!(
                "--input and --output select columns of a table, but {} is a Touchstone file \
                 (use --port)",
                args.data.display()
            )));
        }
        let (data, entry) = read_entry(args)?;
        return Ok((Measurement::Frequency(data), Some(entry), false));
    }
    if let Some(p) = &args.port {
        if is_frf_matrix_csv(&args.data) {
            let (data, entry) = matrix_entry(args, p)?;
            return Ok((Measurement::Frequency(data), Some(entry), false));
        }
        return Err(Failure::usage(format!(
            "--port {p} applies to Touchstone files (.sNp, .ts) and frequency response \
             matrix CSV files (re_IJ, im_IJ), but {} is neither",
            args.data.display()
        )));
    }
    if let Some(list) = [&args.input, &args.output]
        .into_iter()
        .flatten()
        .find(|c| c.contains(','))
    {
        return Err(Failure::usage(format!(
            "the column list `{list}` selects several channels: only `fdid fit` takes lists \
             (--output A,B: every output fitted with common poles; --input U1,U2 --output \
             Y1,Y2: a record with several inputs); pick one column here"
        )));
    }
    match (&args.input, &args.output) {
        (Some(input), Some(output)) => {
            let selection = ChannelSelection {
                input: Column::parse(input),
                output: Column::parse(output),
                ts: args.ts,
            };
            let record = read_channels::<f64>(&args.data, &selection).map_err(|e| match e {
                FdidError::Parse { .. } | FdidError::Io(_) => Failure::from(e),
                e => Failure::runtime(format!("{}: {e}", args.data.display())),
            })?;
            Ok((Measurement::Time(record), None, true))
        }
        (Some(_), None) | (None, Some(_)) => Err(Failure::usage(
            "--input and --output go together: name the input and the output column (by \
             header name or 1-based index)"
                .into(),
        )),
        (None, None) => match read_csv::<f64>(&args.data).map_err(|e| name_file(args, e))? {
            Measurement::Matrix(m) if m.ny() * m.nu() == 1 => {
                Ok((Measurement::Frequency(m.entry(0, 0).clone()), None, false))
            }
            Measurement::Matrix(m) => Err(Failure::usage(format!(
                "{} holds a {} x {} frequency response matrix: pick one entry with --port IJ \
                 (`fdid fit` without --port fits every entry with common poles)",
                args.data.display(),
                m.ny(),
                m.nu()
            ))),
            m => Ok((m, None, false)),
        },
    }
}

/// The entry `--port IJ` of a frequency response matrix CSV file, and its description.
fn matrix_entry(args: &CommonArgs, port: &str) -> Result<(FrequencyData<f64>, String), Failure> {
    let (i, j) = parse_port(port).map_err(Failure::usage)?;
    let matrix = match read_csv::<f64>(&args.data).map_err(|e| name_file(args, e))? {
        Measurement::Matrix(m) => m,
        _ => unreachable_matrix(args)?,
    };
    if i == 0 || j == 0 || i > matrix.ny() || j > matrix.nu() {
        return Err(Failure::usage(format!(
            "invalid --port {i}{j}: {} holds a {} x {} matrix (outputs 1..{}, inputs 1..{})",
            args.data.display(),
            matrix.ny(),
            matrix.nu(),
            matrix.ny(),
            matrix.nu()
        )));
    }
    Ok((
        matrix.entry(i - 1, j - 1).clone(),
        format!("entry {i}{j} (output {i}, input {j})"),
    ))
}

/// The error for a frequency response matrix where one entry was expected (`read` turns
/// a matrix into one entry or refuses it, so the preparation never sees one).
fn unreachable_matrix<T>(args: &CommonArgs) -> Result<T, Failure> {
    Err(Failure::runtime(format!(
        "{}: the header names a frequency response matrix but the file did not read as one",
        args.data.display()
    )))
}

/// A read error that names the file.
fn name_file(args: &CommonArgs, e: FdidError) -> Failure {
    match e {
        FdidError::Parse { ref message, .. }
            if message.contains("unknown column") || message.contains("unrecognized header") =>
        {
            Failure::runtime(format!(
                "{e} (a table of several channels: select them with --input NAME --output NAME)"
            ))
        }
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
        (DomainArg::S, Some(ts)) => {
            return Err(Failure::usage(format!(
                "--ts {ts} has no use with --domain s on frequency data ({}): a \
                 continuous-time model has no sample time (drop --ts, or fit --domain z)",
                args.data.display()
            )));
        }
        (DomainArg::S, None) => None,
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

/// The DFT lines of a time record (averaged over `--periods` after `--skip-periods`, or the
/// BLA over `--realisations`): without DC and, unless `--lines all`, the lines the input
/// does not excite (`noise_model`: every line but DC and Nyquist), with the model's sample
/// time (z only) and the description of the source. `channels`: the record comes from a
/// table of channels whose sample time was already checked against --ts.
fn time_lines(
    args: &CommonArgs,
    record: &TimeData<f64>,
    noise_model: bool,
    channels: bool,
    notes: &mut Vec<String>,
) -> Result<TimeLines, Failure> {
    let ts = record.ts();
    if !channels
        && let Some(given) = args.ts
        && (given.is_nan() || (given - ts).abs() > 1e-6 * ts)
    {
        return Err(Failure::usage(format!(
            "--ts {given} contradicts the time record, whose t column gives Ts = {ts} s \
             (--ts is for frequency data; rescale t to change Ts)"
        )));
    }
    if args.domain == DomainArg::S {
        notes.push(
            "continuous-time model fitted to the DFT lines of a sampled record: an \
             approximation, valid for band-limited data"
                .into(),
        );
    }
    let model_ts = match args.domain {
        DomainArg::Z => Some(ts),
        DomainArg::S => None,
    };
    if let Some(m) = args.realisations {
        return realisation_lines(args, record, m, noise_model, notes, model_ts);
    }
    if args.skip_periods > 0 && args.periods.is_none() {
        return Err(Failure::usage(format!(
            "--skip-periods {} needs --periods P (or --realisations M): it drops whole periods",
            args.skip_periods
        )));
    }
    let n = record.len();
    let (data, how, steady, periods) = match args.periods {
        Some(p) => {
            let (steady, kept) = steady_periods(args, record, p)?;
            let ratio = check_repeats(args, &steady, kept, None)?;
            let skipped = if args.skip_periods > 0 {
                format!(" ({} skipped)", args.skip_periods)
            } else {
                String::new()
            };
            let how = format!(
                "averaged over {kept} period{} of {} samples{skipped}{}",
                if kept == 1 { "" } else { "s" },
                steady.len() / kept,
                repeats_text(ratio)
            );
            (steady.average_periods(kept)?, how, steady, Some(kept))
        }
        None => (
            record.dft(),
            "DFT of the whole record".to_string(),
            record.clone(),
            None,
        ),
    };
    let total = data.len();
    let excitation = data.excitation(EXCITATION_FRACTION);
    let n_excited = excitation.count();
    if n_excited == 0 {
        return Err(Failure::runtime(if data.input_is_constant() {
            "the input is constant (every line above DC is below 1e-10 of the DC line): it \
             excites only DC, so the record carries no information about the dynamics"
                .into()
        } else {
            "the input spectrum is zero on every line above DC: the record carries no \
             information about the system"
                .into()
        }));
    }
    // a noise model is also identified from the lines without input
    let unexcited_noise = match excitation.rule() {
        ExcitationRule::Level => None,
        _ => data.unexcited_noise(&excitation, UNEXCITED_NEIGHBOURS).ok(),
    };
    let excited_omega: Vec<f64> = data
        .omega()
        .iter()
        .zip(excitation.lines())
        .filter(|(_, e)| **e)
        .map(|(w, _)| *w)
        .collect();
    let keep: Vec<bool> = if noise_model || args.lines == LinesArg::All {
        data.omega().iter().map(|w| *w > 0.0).collect()
    } else {
        excitation.lines().to_vec()
    };
    let data = select(&data, &keep)?;
    let (data, what) = if noise_model {
        (interior_lines(&data)?, "DC or Nyquist")
    } else if args.lines == LinesArg::All {
        (data, "DC")
    } else {
        (data, "DC or not excited")
    };
    let dropped = total - data.len();
    Ok(TimeLines {
        data,
        ts: model_ts,
        source: format!(
            "time record, {n} samples, Ts = {ts} s, {how}; {total} lines, {n_excited} \
             excited ({}), {dropped} dropped ({what})",
            excitation.describe()
        ),
        excited: Some(excited_omega),
        unexcited_noise,
        record: steady,
        periods,
        realisations: None,
    })
}

/// The record of `p` periods without the first `--skip-periods`, and the number of
/// periods left.
fn steady_periods(
    args: &CommonArgs,
    record: &TimeData<f64>,
    p: usize,
) -> Result<(TimeData<f64>, usize), Failure> {
    let n = record.len();
    if p == 0 {
        return Err(Failure::usage(
            "invalid --periods 0: at least one period is needed".into(),
        ));
    }
    if !n.is_multiple_of(p) {
        return Err(Failure::runtime(format!(
            "--periods {p}: the record of {n} samples is not a whole number of {p} periods"
        )));
    }
    let k = args.skip_periods;
    if k >= p {
        return Err(Failure::usage(format!(
            "--skip-periods {k} leaves no period of the {p} (--periods {p})"
        )));
    }
    let m = n / p;
    Ok((record.skip_samples(k * m)?, p - k))
}

/// Checks that the input of `record` repeats over its `periods` periods (to
/// [`PERIODICITY_TOLERANCE`], see [`TimeData::period_mismatch`]) and returns the ratio
/// (`None` for one period); `realisation`: which realisation the record is.
fn check_repeats(
    args: &CommonArgs,
    record: &TimeData<f64>,
    periods: usize,
    realisation: Option<usize>,
) -> Result<Option<f64>, Failure> {
    if periods < 2 {
        return Ok(None);
    }
    let ratio = record.period_mismatch(periods)?;
    if ratio <= PERIODICITY_TOLERANCE {
        return Ok(Some(ratio));
    }
    let p = args.periods.unwrap_or(periods);
    let level = if ratio.is_finite() {
        format!("{:.1} dB of", 10.0 * ratio.log10())
    } else {
        "more power than".to_string()
    };
    let whose = match realisation {
        Some(r) => format!("realisation {} of the record", r + 1),
        None => "the record".to_string(),
    };
    let hint = match realisation {
        Some(_) => "check --realisations and --periods".to_string(),
        None => format!(
            "if the {p} blocks are different realisations (new random phases, not periods), \
             use --realisations {p}"
        ),
    };
    Err(Failure::runtime(format!(
        "--periods {p}: the input of {whose} does not repeat from period to period: the \
         part that differs between periods has {level} the power of the part that repeats \
         (tolerance {:.0} dB); {hint}",
        10.0 * PERIODICITY_TOLERANCE.log10()
    )))
}

/// `, input repeats to X dB` for the ratio of [`check_repeats`], empty without one.
fn repeats_text(ratio: Option<f64>) -> String {
    match ratio {
        Some(r) if r > 0.0 => format!(", input repeats to {:.1} dB", 10.0 * r.log10()),
        Some(_) => ", input repeats exactly".into(),
        None => String::new(),
    }
}

/// The BLA over `m` realisations (`--realisations`), each of `--periods` periods (default
/// 1) without the first `--skip-periods`, weighted by the total variance.
fn realisation_lines(
    args: &CommonArgs,
    record: &TimeData<f64>,
    m: usize,
    noise_model: bool,
    notes: &mut Vec<String>,
    model_ts: Option<f64>,
) -> Result<TimeLines, Failure> {
    if m == 0 {
        return Err(Failure::usage(
            "invalid --realisations 0: at least one realisation is needed".into(),
        ));
    }
    if noise_model || args.transient || args.lines == LinesArg::All {
        let flag = if noise_model {
            "--noise-order"
        } else if args.transient {
            "--transient"
        } else {
            "--lines all"
        };
        return Err(Failure::usage(format!(
            "--realisations {m} cannot be combined with {flag}: the best linear \
             approximation of periodic realisations exists at the excited lines only, \
             without transient or noise model"
        )));
    }
    let n = record.len();
    if !n.is_multiple_of(m) {
        return Err(Failure::runtime(format!(
            "--realisations {m}: the record of {n} samples does not split into {m} equal \
             realisations"
        )));
    }
    let p = args.periods.unwrap_or(1);
    let mut records = Vec::with_capacity(m);
    let mut kept = p;
    let mut worst: Option<f64> = None;
    for (r, block) in record.split_blocks(m)?.iter().enumerate() {
        let (steady, k) = steady_periods(args, block, p)?;
        if let Some(ratio) = check_repeats(args, &steady, k, Some(r))? {
            worst = Some(worst.map_or(ratio, |w| w.max(ratio)));
        }
        records.push(steady);
        kept = k;
    }
    let bla = RealisationBla::new(&records, kept, EXCITATION_FRACTION)?;
    let data = bla.total_data()?;
    let noise_data = bla.noise_data().transpose()?;
    match (bla.total_variance().is_some(), kept >= 2) {
        (true, false) => notes.push(
            "one period per realisation: the noise and the nonlinear distortion cannot be \
             separated; the total variance (between realisations) holds both"
                .into(),
        ),
        (false, _) => notes.push(
            "one realisation: no total variance; the stochastic nonlinear distortion (if \
             any) is not in the weighting"
                .into(),
        ),
        (true, true) => {}
    }
    if let Some(test) = bla.spread_test() {
        notes.push(format!(
            "total variance (between realisations) {:+.1} dB relative to the noise variance \
             (between periods), p = {:.3e}{}",
            test.total_to_noise_db,
            test.p_value,
            if test.p_value < 0.01 {
                ": nonlinear distortion; the fit is the best linear approximation"
            } else {
                ": consistent with noise only"
            }
        ));
    }
    let len = records[0].len();
    let skipped = if args.skip_periods > 0 {
        format!(" ({} skipped)", args.skip_periods)
    } else {
        String::new()
    };
    let source = format!(
        "time record, {n} samples, Ts = {} s, {m} realisation{} x {kept} period{} of {} \
         samples{skipped}{}; best linear approximation on {} lines excited in every \
         realisation",
        record.ts(),
        if m == 1 { "" } else { "s" },
        if kept == 1 { "" } else { "s" },
        len / kept,
        repeats_text(worst),
        bla.lines().len(),
    );
    Ok(TimeLines {
        data,
        ts: model_ts,
        source,
        excited: None,
        unexcited_noise: None,
        record: record.clone(),
        periods: None,
        realisations: Some(Realisations {
            bla,
            records,
            noise_data,
        }),
    })
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
