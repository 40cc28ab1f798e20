//! Command-line syntax (clap derive) and the translation of clap's errors into one line.

use clap::{Args, Parser, Subcommand, ValueEnum};
use fdid::estimate::Method;
use std::path::PathBuf;
use std::process::ExitCode;

/// Highest model order `--na`/`--nb` accepted.
pub const MAX_ORDER: usize = 100;

const MAIN_HELP: &str = "\
Examples:
  fdid fit data/eis_battery.csv --domain s --na 6 --nb 6 --band :1000
  fdid fit data/robot_arm.csv --domain z --na 4 --nb 4 --periods 1
  fdid fit frf.csv --domain z --ts 0.001 --na 2 --nb 2 --json
  fdid fit step.csv --domain z --na 2 --nb 1 --transient --noise-order 1 --delay
  fdid diagnose data/dryer.csv --domain z --na 2 --nb 2 --report report
  fdid fit data/rlc_bandpass.s2p --domain s --na 2 --nb 1 --port 21 --save rlc.json
  fdid eval rlc.json --freq 1e6:1e7:20
  fdid ltv record.csv --na 2 --nb 0 --np 1 --band :1

Run `fdid fit --help` for the data file formats (CSV, Touchstone .sNp/.ts) and every
option, `fdid diagnose --help` for the discrepancy workflow, `fdid eval --help` for saved
models, `fdid ltv --help` for time-varying systems.";

const FIT_HELP: &str = "\
Data files (CSV, header names the columns, any order, case-insensitive; `#` lines are comments):
  f,re,im[,var]                         frequency response G(f) = re + i im, f in Hz;
                                        var = noise variance E|N_G|^2 of each line
  f,u_re,u_im,y_re,y_im[,var_u,var_y]   input and output spectra U(f), Y(f), f in Hz
  t,u,y                                 time record, uniform t in s (sets Ts)
Frequencies must be non-negative and strictly increasing; every value finite.
Touchstone files (by extension): .sNp (N ports, 1 to 64), version 1 or 2.0, and .ts
(version 2.0); option line `# Hz|kHz|MHz|GHz S|Y|Z|H|G RI|MA|DB R <ohms>`, `!`
comments; --port IJ picks the entry X_IJ fitted as an FRF; without it a file of 2 or
more ports has every entry fitted with common poles (partial fractions, --nb na-1 or
na; modes, residue matrices, state space, per-entry errors, passivity of S). Version 1:
2-port columns S11 S21 S12 S22, 3 or more ports row by row; Y, Z, H, G values are
de-normalised by R. Version 2.0: [Version] 2.0, the option line, [Number of Ports] N, then
[Two-Port Data Order] 12_21|21_12 (2 ports), [Number of Frequencies] N (checked),
[Reference] r1 r2, [Matrix Format] Full|Lower|Upper, [Number of Noise Frequencies],
[Begin Information]..[End Information], then [Network Data], rows, [Noise Data]
(skipped), [End]; values are not normalised (as the specification says).
[Mixed-Mode Order] and more than 64 ports are rejected.

Time records are transformed by the DFT (or averaged over --periods P periods, which
also estimates per-line noise variances when P >= 2; --skip-periods K drops the first K
as transients). --periods checks that the input repeats: the part that differs between
periods may carry at most -10 dB of the power of the part that repeats, else the command
fails and suggests --realisations. The DC line (f = 0) and, with --lines excited (the
default), every line the input does not excite are dropped: a line is excited when
|U_k| > 1e-6 max_j |U_j| (the lines a multisine leaves out sit at the rounding level,
not at zero); --lines all keeps every line above DC. The text (`lines ... (N excited)`)
and the JSON (lines_excited) give the number of excited lines fitted.
--realisations M: the record is M realisations of a periodic experiment (new random
phases), each of --periods P periods (default 1); the fit is made on the best linear
approximation at the lines excited in every realisation, weighted by its total variance
(between realisations: noise + nonlinear distortion); P >= 2 also estimates the noise
variance (between periods) and a note compares the two; with P = 1 they cannot be
separated.
Raw tables of several channels: --input NAME|INDEX --output NAME|INDEX pick the columns
(header names, quotes and a trailing empty field accepted; 1-based indices, also for
whitespace-separated files without a header such as DaISy .dat); without a t column
--ts S gives the sample time. --domain s on a time record fits a continuous-time model to
the DFT lines; this is an approximation, valid for band-limited data well below Nyquist.
With --noise-order the lines without input are kept (they inform the noise model) and
the Nyquist line is dropped as well (the DFT of a real record is real there).

Frequency data carry no sample time: --domain z needs --ts. For a time record Ts comes
from the t column; --ts may only repeat it.

Output: domain, orders, criterion, lines used, cost V = sum |Y - G U|^2 / sigma^2,
noise variance lambda = V/N, the validation line (V against its expected value under the
noise model with its p-value, and the Ljung-Box whiteness p-value of the normalised
residuals across frequency), poles (rad/s, or z-plane for z, with natural frequency in
Hz and damping ratio), zeros, gain, what each estimation stage did, and theta with
standard deviations. A `warning` line names each pole the data do not resolve: with
s = sigma + i w_p (s = the pole, or ln(z)/Ts), no line lies in its half-power band
|w - w_p| <= |sigma|, so its damping is not determined (often a spurious resonance
placed between two lines); the line gives the band and the nearest lines.
With --json one JSON object:
  {\"domain\":\"s\"|\"z\", \"poles\":[[re,im],..], \"zeros\":[[re,im],..], \"cost\":x,
   \"noise_variance\":x, \"frf\":[[f_hz,re,im],..], \"delay\":x|null,
   \"cost_expected\":x|null, \"cost_p\":x|null, \"whiteness_p\":x|null,
   \"covariance\":[[..],..]|null, \"noise_model\":{\"c\":[1,c1,..],\"d\":[1,d1,..],..}|null, ...}
where poles and zeros are in rad/s (s) or in the z-plane (z; zeros at the origin left
out) and frf is the fitted model (with the delay) at the frequencies (Hz) used in the
fit. delay is tau in seconds, null without --delay; cost_expected and cost_p are null
when the noise level is estimated from the residuals (flat weighting, noise model);
covariance is that of theta (rows in the order of theta_names); noise_model holds C and
D in ascending powers of z^-1 and the zeros and poles of H, null without --noise-order.
pole_details and zero_details list the same roots as objects {\"re\":x, \"im\":x,
\"f_n_hz\":x, \"damping\":x}: natural frequency in Hz and damping ratio of s (of
s = ln(z)/Ts for z; null where undefined). Further keys: na, nb, criterion, ts, lines,
lines_excited (time records: the excited lines among those fitted, null for frequency
data), gain, stable, theta, theta_names, theta_std,
frf_std, stages, weighting, noise_known, relative_residual, notes, form (how theta
parameterises the model), basis_poles, delay_std, delay_samples (tau/Ts, null without a
sample time), transient (number of transient coefficients, 0 without --transient),
noise_order, whiteness_lags, unresolved_poles ([{\"pole\":[re,im], \"s\":[sigma,w_p],
\"band_hz\":[lo,hi], \"nearest_lines_hz\":[below,above]},..], [] when none),
marginal_poles ([[re,im],..]: stable poles on the stability boundary, damping below 1e-6
or closer to s = 0 than 1e-4 of the lowest fitted frequency; one per pair). theta is [rational part, t1..tn (--transient), tau
(--delay), nc1..ncN, nd1..ndN (--noise-order: H = C/D)]. Values that are not finite are written as null.

Model extensions (they combine: --delay --transient --noise-order N all at once works):
  --delay           G(iw) e^{-i w tau}; with --criterion ml or eiv
  --transient       Y = G U + T for a non-periodic time record; any criterion
  --noise-order N   ML with H = C/D of orders (N, N) on one time record; --criterion ml
  --criterion eiv   input noise variances from --periods P >= 2 or var_u,var_y columns;
                    combines with --delay and --transient, not with --noise-order

Errors are reported on one line starting with `error:`; the exit status is 1 for bad
data or a failed fit and 2 for bad usage.

Examples:
  fdid fit data/eis_battery.csv --domain s --na 6 --nb 6 --band :1000
  fdid fit data/robot_arm.csv --domain z --na 4 --nb 4 --periods 1
  fdid fit record.csv --domain z --na 2 --nb 1 --periods 4 --json
  fdid fit record.csv --domain z --na 2 --nb 1 --periods 4 --criterion eiv --delay
  fdid fit step.csv --domain z --na 2 --nb 1 --transient --noise-order 1
  fdid fit data/rlc_bandpass.s2p --domain s --na 2 --nb 1 --port 21 --save rlc.json
  fdid eval rlc.json --freq 1e6:1e7:20
  fdid fit data/silverbox.csv --realisations 10 --band :200 --domain s --na 2 --nb 0
  fdid fit data/cd_player_arm.csv --input u1 --output y1 --domain z --na 4 --nb 4";

const DIAGNOSE_HELP: &str = "\
The discrepancy workflow. The data file, --port, --ts, --band, --periods and the
starting model (--domain, --na, --nb, --delay, --transient) are as for `fdid fit` (see
`fdid fit --help` for the file formats). Each step fits the current model by maximum likelihood (McKelvey
eq. 23), runs every detector on the normalised residuals r_k (time_delay,
missing_resonance, transient, colored_noise, missing_pole, missing_zero: score tests with
a p-value), refits the proposals below --alpha and keeps the one a likelihood-ratio test
accepts at --alpha. It stops when the cost and whiteness tests pass at --alpha (the
residuals are consistent with the noise), when nothing is accepted, or after --max-steps.

Context: a time record with --periods P is taken as periodic (whole periods, no leakage);
a time record without --periods as one non-periodic record (a transient can exist);
frequency files as frequency data (no transient, no noise model).

Noise reference (how r_k is normalised):
  periods    sample variances over P >= 2 periods
  given      var / var_y columns of the data file
  realisations  --realisations M: the BLA over M realisations; with P >= 2 periods
             weighted by its noise variance between periods, and nonlinear_distortion
             is named when the total variance between realisations significantly
             exceeds it; with P = 1 weighted by the total variance (noise and
             distortion cannot be separated)
  lpm        one non-periodic record: per-line output noise variances from the local
             polynomial method (R = 2 over 11 lines, 5 degrees of freedom)
  estimated  nothing known: lambda is estimated from the residuals, the cost test is
             skipped and the detectors have reduced power
The DC line is dropped, so the means of u and y do not matter.

Output: a text report (noise reference, starting model, the table of steps, the final model
with its delay and poles, a warning for each pole the data do not resolve, whether the
residuals are consistent with the noise), or with
--json one JSON object:
  {\"steps\":[{\"effect\":NAME,\"p_value\":x,\"cost_before\":x,\"cost_after\":x,
   \"lr_p\":x,\"detail\":{..}},..], \"effects\":[NAME,..], \"consistent_with_noise\":bool,
   \"noise_reference\":\"periods\"|\"given\"|\"lpm\"|\"realisations\"|\"estimated\",
   \"initial\":{..}, \"final\":{..}}
where initial and final hold the keys of `fdid fit --json` for the starting and the final
model. When time_variation is named on a continuous-time spec (--domain s) of a time
record, the time-varying ODE of `fdid ltv` is fitted with the spec's orders (N_p = 0..3
raised while the F test on the TLS costs is below --alpha and the two smallest singular
values stay a factor 3 apart; Legendre bases, N_tr = 2 max(na, nb) + 1, every DFT
line of the record in the fitted band): a report section shows the gap V(0) -> V(N_p) and
the instantaneous poles at 11 instants, and the JSON key \"time_varying_ode\" holds
{\"n_p\", \"candidates\", \"cost_before\", \"cost_after\", \"instantaneous\":[{\"t\",
\"poles\"},..], ..} (null otherwise). --report DIR writes report.txt, report.json and, when built with the `plot` feature
(on by default), bode.svg (data Y/U, initial and final model, noise level) and
residuals.svg (|r_k| of the initial and final fits with the 1 and alpha levels).

Errors are reported on one line starting with `error:`; the exit status is 1 for bad
data or a failed fit and 2 for bad usage.

Examples:
  fdid diagnose data/dryer.csv --domain z --na 2 --nb 2 --report report
  fdid diagnose data/robot_arm.csv --domain z --na 4 --nb 4 --periods 1 --json
  fdid diagnose data/rlc_bandpass.s2p --domain s --na 1 --nb 1 --port 21
  fdid diagnose record.csv --domain z --na 2 --nb 1 --periods 4 --alpha 0.05";

const EVAL_HELP: &str = "\
The saved file is one JSON object {\"format\":\"fdid-model\", \"version\":1, \"kind\":
\"rational\"|\"delayed\"|\"noise_model\"|\"delayed_noise_model\", \"domain\", \"ts\", \"source\",
\"fitted\":{\"model\", \"theta\", \"covariance\", \"noise_variance\", \"noise_known\", \"cost\",
\"lines\"}, \"unresolved_poles\":[[re,im],..], \"marginal_poles\":[[re,im],..]} (the poles the
data did not resolve, and the stable poles on the stability boundary; files without the keys
have none). Numbers are written so that they read back exactly: the response is that of
the fitted model to the last bit. The output is CSV f,re,im[,std] (a comment line first,
then a `# warning:` line for each unresolved pole and each pole on the stability boundary),
std the standard deviation of G from the covariance of theta (no column without one); with
--json one object {\"frf\":[[f,re,im],..], \"frf_std\":[..]|null,
\"unresolved_poles\":[[re,im],..], \"marginal_poles\":[[re,im],..]}.

A common-pole model (`fdid fit` of every entry with --save; \"kind\":\"common_poles\",
\"model\":{\"domain\", \"poles\", \"residues\", \"direct\"}) prints every entry in the
matrix CSV layout f,re_11,im_11,re_21,im_21,.. (which `fdid fit` reads back); with --json
{\"entries\":[{\"output\":i, \"input\":j, \"frf\":[[f,re,im],..]},..]}.

Examples:
  fdid fit data/eis_battery.csv --domain s --na 6 --nb 6 --band :1000 --save eis.json
  fdid eval eis.json --freq 0.01:1000:50
  fdid eval eis.json --freq 1,10,100 --json";

const LTV_HELP: &str = "\
The Lataire-Pintelon estimator of a continuous-time, time-varying system from one t,u,y
record (J. Lataire and R. Pintelon, Frequency domain total least squares estimator of
time-varying systems). The model is the ODE with coefficients polynomial in time,
  sum_{n=0}^{na} alpha_n(t) d^n y/dt^n = sum_{n=0}^{nb} beta_n(t) d^n u/dt^n,
  alpha_n(t) = sum_{p=0}^{np} alpha~_{n,p} b_p(t),  beta_n(t) likewise,
written in the frequency domain on the DFT lines k of --band (eqs. 11, 15: products with
b_p(t) by iDFT/DFT) with a transient + alias polynomial I(w_k) = sum_m gamma_m Phi_m(w_k)
of order --ntr (eq. 18). theta is the right singular vector of the smallest singular value
of the real-stacked regressor with unit-norm columns (total least squares, eq. 19),
normalised so that a_na(T/2) = 1 (T = N Ts). --basis legendre (default) uses
b_p(t) = P_p(2t/T - 1) and Psi_n(jw) = j^(n mod 2) P_n(w/w_max), w_max the band's top
line (eq. 20); --basis monomial uses t^p (t from the first sample) and s^n.

The instantaneous (frozen) system at t* is G_t*(s) = B(s)/A(s), A(s) = sum alpha_n(t*)
Psi_n(s), B likewise (eq. 4); its poles are the roots of A. It is reported at 11 evenly
spaced instants from the first to the last sample.

Identifiability: orders above the system's (e.g. --np above its time variation) leave a
null space of more than one dimension (the ODE times any polynomial c(t) fits as well);
then the two smallest singular values are close, and the text report warns when their
ratio is below 3.

Output: the record, orders and bases, the lines used, the TLS cost V = sigma_min^2, the
smallest singular values and the gap sigma_(p-1)/sigma_p, the instantaneous poles (rad/s,
natural frequency f_n in Hz, damping ratio) at the 11 instants, and theta. With --json
one JSON object:
  {\"theta\":[..], \"singular_values\":[..] (largest first),
   \"instantaneous\":[{\"t\":x, \"poles\":[[re,im],..], \"frf\":[[f_hz,re,im],..]},..]}
with t in the time of the file's t column (s), poles in rad/s, frf the frozen FRF on the
band's DFT lines.

Errors are reported on one line starting with `error:`; the exit status is 1 for bad
data or a failed fit and 2 for bad usage (a frequency file, an empty band, --np above
floor(sqrt(N)), fewer real equations 2L than parameters
(na + 1 + nb + 1)(np + 1) + ntr + 1).

Examples:
  fdid ltv record.csv --na 2 --nb 0 --np 1 --band :1
  fdid ltv record.csv --na 2 --nb 1 --np 2 --ntr 5 --band 0.01:1 --json
  fdid ltv record.csv --na 1 --nb 0 --np 1 --basis monomial";

const STABILIZE_HELP: &str = "\
Every order N of --orders A:B[:STEP] (STEP 2 by default: one more pole pair per order) is
fitted with poles common to every entry (as `fdid fit` without --port) by pole
relocation (relaxed vector fitting); --ml refines every order by maximum likelihood
(variable projection, several times slower). Each stable pole with its
natural frequency inside the data's band is compared with the nearest pole (in
frequency) of the previous order and marked
  o  new (the first order, or no pole within the frequency tolerance)
  f  frequency within 1 %          d  frequency and damping (within 5 %)
  v  frequency and mode shape (MAC >= 0.95)
  s  frequency, damping and mode shape: stable
(--frequency-tol, --damping-tol, --mac). The stable poles (s) are sorted by frequency and
split where neighbours differ by more than the frequency tolerance; a cluster stable at
--min-orders orders or more (default 3) is a physical mode, reported with the mean and
spread (standard deviation) of its natural frequency and damping over its orders. With a
single output the mode shape is one number and every MAC is 1.

Data: as `fdid fit` (Touchstone of any number of ports, a matrix CSV, a table's outputs
--output A,B,C with one --input, a record with several inputs --input U1,U2 --output
Y1,Y2 --transient, or any single-channel file).

Output: the physical modes, then the diagram (for each order its poles' frequencies with
their marks). --json: {\"orders\":[..], \"poles\":[{\"order\",\"f_n_hz\",\"damping\",
\"pole\":[re,im],\"mark\"}..], \"modes\":[{\"f_n_hz\",\"f_n_spread_hz\",\"damping\",
\"damping_spread\",\"orders\":[..]}..], \"failed\":[{\"order\",\"error\"}..]}. --plot FILE
writes the classic diagram as SVG: the marks at (frequency, order) over the sum of the
entries' magnitudes (dB, right axis).

Examples:
  fdid stabilize F16Data.csv --input Force --output Acceleration1,Acceleration2,Acceleration3 \\
      --ts 0.0025 --periods 9 --skip-periods 1 --band 2:15 --domain s --orders 2:40 --stable
  fdid stabilize data/rlc_bandpass.s2p --domain s --orders 1:6:1 --direct --json";

/// Frequency-domain system identification: fit rational transfer functions in s or z to
/// measured frequency responses (CSV or Touchstone), spectra or time records.
#[derive(Debug, Parser)]
#[command(name = "fdid", version, after_help = MAIN_HELP)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Fit a rational model G = B/A to a data file and print poles, zeros, gain, cost,
    /// noise level and parameters with standard deviations.
    #[command(after_help = FIT_HELP)]
    Fit(FitArgs),
    /// Run the discrepancy workflow from a starting model: find where model and data
    /// disagree, name the missing effect (time delay, resonance, pole, zero, transient,
    /// coloured noise), add it when a likelihood-ratio test accepts it, and repeat.
    #[command(after_help = DIAGNOSE_HELP)]
    Diagnose(DiagnoseArgs),
    /// Evaluate a model saved by `fdid fit --save` at given frequencies: the response G and
    /// its standard deviation from the covariance of theta, as CSV f,re,im,std.
    #[command(after_help = EVAL_HELP)]
    Eval(EvalArgs),
    /// Fit a continuous-time, time-varying ODE (Lataire-Pintelon: coefficients polynomial
    /// in time, frequency-domain total least squares) to a t,u,y record and print the
    /// instantaneous poles and FRF at 11 instants over the record.
    #[command(after_help = LTV_HELP)]
    Ltv(LtvArgs),
    /// Stabilisation diagram: fit every entry with common poles at each order of a range,
    /// mark each pole stable in frequency, damping and mode shape against the previous
    /// order, and cluster the stable poles into physical modes.
    #[command(after_help = STABILIZE_HELP)]
    Stabilize(StabilizeArgs),
}

/// The data file, how it is prepared, and the model structure: the options `fdid fit` and
/// `fdid diagnose` share.
#[derive(Debug, Clone, Args)]
pub struct CommonArgs {
    /// Data file: CSV (a frequency response, input/output spectra or a time record) or
    /// Touchstone .sNp (version 1 or 2.0) or .ts (version 2.0) (the formats are in
    /// `fdid fit --help`)
    #[arg(value_name = "DATA")]
    pub data: PathBuf,

    /// Model domain: s (continuous time, poles in rad/s) or z (discrete time, needs Ts)
    #[arg(long, value_enum)]
    pub domain: DomainArg,

    /// Denominator degree (number of poles), at most 100
    #[arg(long, value_name = "N")]
    pub na: usize,

    /// Numerator degree: in s, nb = na gives a feedthrough and nb < na a strictly proper
    /// model, both in the partial-fraction form (well conditioned over many decades);
    /// nb > na (improper) uses polynomials orthonormal on the data grid; in z,
    /// B = b0 + b1 z^-1 + ... + b_nb z^-nb. At most 100
    #[arg(long, value_name = "M")]
    pub nb: usize,

    /// Sample time in seconds, for --domain z with frequency data
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub ts: Option<f64>,

    /// Keep only lines with FMIN <= f <= FMAX (Hz); either side may be empty (`:100`,
    /// `0.5:`)
    #[arg(long, value_name = "FMIN:FMAX", allow_hyphen_values = true)]
    pub band: Option<String>,

    /// Time records: number of periods P in the record; the DFT is averaged over them
    /// (P >= 2 also estimates noise variances used to weight the lines). Without it the
    /// whole record is transformed
    #[arg(long, value_name = "P", value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    pub periods: Option<usize>,

    /// Fit a delayed model G(iw) e^{-i w tau}: tau (s) is one more parameter, started from
    /// the phase slope (McKelvey section 4). With --criterion ml or eiv
    #[arg(long)]
    pub delay: bool,

    /// Add the transient (leakage) term T of a non-periodic record, Y = G U + T: in z,
    /// T = (t1 + t2 z^-1 + ...)/A (eqs. 4-5); in s, the sampled transient of eqs. 9-10
    /// (needs nb <= na). Needs a time record
    #[arg(long)]
    pub transient: bool,

    /// Touchstone files (.sNp, .ts): the entry X_ij to fit, output port i and input port j,
    /// written `ij` (`21` is S21). Without it `fit` fits every entry of a file of 2 or
    /// more ports with common poles (--nb na-1 or na), and `diagnose` runs the workflow on
    /// every entry; a 1-port file has 11
    #[arg(long, value_name = "IJ")]
    pub port: Option<String>,

    /// Time records: the lines fitted. excited = the lines where the input spectrum |U_k|
    /// exceeds 1e-6 of its largest line (the others, e.g. the detection lines of a
    /// multisine, serve as noise and distortion lines); all = every line above DC
    #[arg(long, value_enum, default_value_t = LinesArg::Excited)]
    pub lines: LinesArg,

    /// Time records with --periods or --realisations: drop the first K periods of the
    /// record (of each realisation) as transients before averaging
    #[arg(long, value_name = "K", default_value_t = 0)]
    pub skip_periods: usize,

    /// Time records: the record holds M realisations of a periodic experiment one after
    /// the other (each of --periods P periods, default 1). The fit is made on their best
    /// linear approximation weighted by its total variance (noise + nonlinear distortion,
    /// from the spread between realisations); P >= 2 also gives the noise variance (from
    /// the spread between periods)
    #[arg(long, value_name = "M", value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    pub realisations: Option<usize>,

    /// Raw tables of several channels (a benchmark CSV with a header, a whitespace-separated
    /// file without one): the input column, by header name or 1-based index; for `fit`, a
    /// comma-separated list (`u1,u2`) reads a record in which the inputs act together and
    /// fits every --output on every input with common poles (add --transient)
    #[arg(long, value_name = "NAME|INDEX[,...]")]
    pub input: Option<String>,

    /// Raw tables of several channels: the output column, by header name or 1-based index;
    /// for `fit`, a comma-separated list (`Acceleration1,Acceleration2`) fits every output
    /// with common poles, each output's FRF prepared as one would be alone
    #[arg(long, value_name = "NAME|INDEX[,...]")]
    pub output: Option<String>,
}

/// Which lines of a time record are fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LinesArg {
    /// The lines the input excites (|U_k| above 1e-6 of the largest line)
    Excited,
    /// Every line above DC
    All,
}

/// Parses `--port IJ` (`11`, `21`, ...) into (i, j), 1-based.
pub fn parse_port(text: &str) -> Result<(usize, usize), String> {
    let digits: Vec<usize> = text
        .chars()
        .map(|c| c.to_digit(10).map(|d| d as usize))
        .collect::<Option<_>>()
        .unwrap_or_default();
    match digits.as_slice() {
        [i, j] if *i >= 1 && *j >= 1 => Ok((*i, *j)),
        _ => Err(format!(
            "invalid --port {text}: expected two port digits, output then input (11, 21, 12, 22)"
        )),
    }
}

/// Options of `fdid fit`.
#[derive(Debug, Args)]
pub struct FitArgs {
    /// The data and the model structure.
    #[command(flatten)]
    pub common: CommonArgs,

    /// Estimator: ml = Levy, then Sanathanan-Koerner, then maximum likelihood
    /// (Levenberg-Marquardt); levy = Levy linear least squares only; sk = Levy, then
    /// Sanathanan-Koerner; tls = total least squares on the equation error; eiv =
    /// errors-in-variables maximum likelihood (noise on the input too; needs input noise
    /// variances: a time record with --periods P >= 2 or a spectra file with var_u,var_y)
    #[arg(long, value_enum, default_value_t = CriterionArg::Ml)]
    pub criterion: CriterionArg,

    /// Estimate a noise model H = C/D of orders (N, N) in z^-1 with the system, by maximum
    /// likelihood (McKelvey eq. 26). Needs one time record (no --periods P >= 2) and
    /// --criterion ml. At most 100
    #[arg(long, value_name = "N")]
    pub noise_order: Option<usize>,

    /// Print one JSON object instead of text
    #[arg(long)]
    pub json: bool,

    /// Write a Bode plot (SVG) of the data, the model with its 2-sigma uncertainty band
    /// and the residual |Y/U - G| to FILE (needs the `plot` feature, on by default)
    #[arg(long, value_name = "FILE")]
    pub plot: Option<std::path::PathBuf>,

    /// Save the fitted model (structure, theta, covariance, noise level) as JSON to FILE,
    /// for `fdid eval FILE`
    #[arg(long, value_name = "FILE")]
    pub save: Option<std::path::PathBuf>,

    /// Return a stable model by construction: unstable poles of every linear stage are
    /// reflected into the stable region (|G| unchanged) and maximum likelihood rejects
    /// every step that would leave it. Without it an unstable fit is reported with a
    /// warning line (JSON: "stable":false)
    #[arg(long)]
    pub stable: bool,

    /// S-parameter data fitted on every entry with common poles: perturb the residues so
    /// that the largest singular value of S is at most 1 on the passivity check's grid,
    /// with the least change over the fitted lines (poles kept); the report gives the
    /// check before and after and the change
    #[arg(long)]
    pub enforce_passivity: bool,

    /// Several outputs fitted with common poles from a periodic record (--output A,B,...
    /// with --periods P, P minus the skipped periods > outputs + 1): weight each line's
    /// residual vector r by the inverse of the noise covariance C between periods (r'C^-1
    /// r, the maximum likelihood when the sensors' noise is correlated) instead of by the
    /// outputs' variances alone; C includes the input's noise (errors in variables, at the
    /// model's response, by reweighting). It lowers the poles' variance when the model is right;
    /// when model errors (e.g. nonlinear distortion) dominate the residual it weights
    /// them by a noise correlation they do not share
    #[arg(long)]
    pub full_covariance: bool,

    /// Every entry of a frequency response matrix (n-port, matrix CSV, --output A,B,...)
    /// as B_ij/A with one denominator A of degree --na and numerators of any degree
    /// --nb <= --na (the single-channel structure: in z polynomials in z^-1, in s any
    /// relative degree), by Levy, Sanathanan-Koerner and maximum likelihood over A
    #[arg(long)]
    pub common_denominator: bool,

    /// Lift the limits that keep a fit to about a minute: without it a delay search
    /// (--delay) or noise model (--noise-order) estimated to take longer is refused, and
    /// the iterative solvers stop at a work budget (with a note in the report)
    #[arg(long)]
    pub allow_long: bool,
}

/// Options of `fdid eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// A model saved by `fdid fit ... --save FILE`
    #[arg(value_name = "MODEL")]
    pub model: PathBuf,

    /// Frequencies in Hz: a list `F1,F2,...` or `FMIN:FMAX:N` for N log-spaced ones
    #[arg(long, value_name = "LIST")]
    pub freq: String,

    /// Print one JSON object {"frf":[[f,re,im],..],"frf_std":[..]|null} instead of CSV
    #[arg(long)]
    pub json: bool,
}

/// Default false-alarm level of `fdid diagnose`.
pub const DEFAULT_ALPHA: f64 = 0.01;

/// Options of `fdid diagnose`.
#[derive(Debug, Args)]
pub struct DiagnoseArgs {
    /// The data and the starting model structure.
    #[command(flatten)]
    pub common: CommonArgs,

    /// False-alarm level of every test (detectors, likelihood-ratio tests, the final cost
    /// and whiteness tests), in (0, 1)
    #[arg(long, value_name = "A", default_value_t = DEFAULT_ALPHA, allow_negative_numbers = true)]
    pub alpha: f64,

    /// Most augmentations accepted
    #[arg(
        long,
        value_name = "K",
        default_value_t = 4,
        allow_negative_numbers = true
    )]
    pub max_steps: usize,

    /// Print one JSON object instead of text
    #[arg(long)]
    pub json: bool,

    /// Also write report.txt, report.json and (with the `plot` feature) bode.svg and
    /// residuals.svg into this directory, created if missing
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,

    /// Fit every model stable by construction (as `fdid fit --stable`)
    #[arg(long)]
    pub stable: bool,

    /// Run on more than 10000 lines (refused by default: the workflow's many refits take
    /// minutes there; select a band with --band or average periods with --periods), and
    /// without the work budget that stops a diagnosis after a minute or two
    #[arg(long)]
    pub allow_long: bool,
}

/// Options of `fdid ltv`.
#[derive(Debug, Args)]
pub struct LtvArgs {
    /// Time record: CSV with columns t,u,y (uniform t in s)
    #[arg(value_name = "DATA")]
    pub data: PathBuf,

    /// N_alpha: highest derivative of y in the ODE (instantaneous poles), 1 to 100
    #[arg(long, value_name = "N")]
    pub na: usize,

    /// N_beta: highest derivative of u in the ODE, at most 100
    #[arg(long, value_name = "M")]
    pub nb: usize,

    /// N_p: order in t of every coefficient alpha_n(t), beta_n(t) (0: time-invariant), at
    /// most floor(sqrt(N)) for N samples
    #[arg(long, value_name = "P")]
    pub np: usize,

    /// N_tr: order of the transient + alias polynomial (default max(na, nb) - 1)
    #[arg(long, value_name = "K")]
    pub ntr: Option<usize>,

    /// Time and frequency bases: legendre (shifted Legendre polynomials in t on the record,
    /// Legendre in w/w_max with w_max the band edge) or monomial (t^p and s^n)
    #[arg(long, value_enum, default_value_t = LtvBasisArg::Legendre)]
    pub basis: LtvBasisArg,

    /// DFT lines with FMIN <= f <= FMAX (Hz) the ODE is evaluated on; either side may be
    /// empty (`:2`, `0.1:`). Default: every line from DC to Nyquist
    #[arg(long, value_name = "FMIN:FMAX", allow_hyphen_values = true)]
    pub band: Option<String>,

    /// Print one JSON object instead of text
    #[arg(long)]
    pub json: bool,

    /// Run a fit whose regressor (2 x lines rows, one column per parameter) is estimated
    /// to take more than about a minute (refused by default, with the estimate)
    #[arg(long)]
    pub allow_long: bool,
}

/// Options of `fdid stabilize`.
#[derive(Debug, Args)]
pub struct StabilizeArgs {
    /// Data file, as for `fdid fit`
    #[arg(value_name = "DATA")]
    pub data: PathBuf,

    /// Model domain: s or z (z needs a sample time)
    #[arg(long, value_enum)]
    pub domain: DomainArg,

    /// The orders (numbers of poles) A:B or A:B:STEP, from A to B (at most 100) in steps
    /// of STEP (default 2)
    #[arg(long, value_name = "A:B[:STEP]")]
    pub orders: String,

    /// Estimate a direct term D in every fit
    #[arg(long)]
    pub direct: bool,

    /// Sample time in seconds, as for `fdid fit`
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub ts: Option<f64>,

    /// Frequency band FMIN:FMAX in Hz, as for `fdid fit`
    #[arg(long, value_name = "FMIN:FMAX", allow_hyphen_values = true)]
    pub band: Option<String>,

    /// Time records: average P periods, as for `fdid fit`
    #[arg(long, value_name = "P", value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    pub periods: Option<usize>,

    /// With --periods: drop the first K periods, as for `fdid fit`
    #[arg(long, value_name = "K", default_value_t = 0)]
    pub skip_periods: usize,

    /// Touchstone or matrix CSV: one entry IJ only
    #[arg(long, value_name = "IJ")]
    pub port: Option<String>,

    /// Tables of channels: the input column(s), as for `fdid fit`
    #[arg(long, value_name = "NAME|INDEX[,...]")]
    pub input: Option<String>,

    /// Tables of channels: the output column(s), as for `fdid fit`
    #[arg(long, value_name = "NAME|INDEX[,...]")]
    pub output: Option<String>,

    /// Records with several inputs: estimate the transient of the record
    #[arg(long)]
    pub transient: bool,

    /// Fit stable models (unstable poles reflected at every relocation)
    #[arg(long)]
    pub stable: bool,

    /// Refine every order by maximum likelihood (variable projection); without it each
    /// order is fitted by pole relocation alone, several times faster
    #[arg(long)]
    pub ml: bool,

    /// Relative frequency tolerance of a repeated pole
    #[arg(long, value_name = "X", default_value_t = 0.01)]
    pub frequency_tol: f64,

    /// Relative damping tolerance of a repeated pole
    #[arg(long, value_name = "X", default_value_t = 0.05)]
    pub damping_tol: f64,

    /// Least modal assurance criterion of a repeated mode shape
    #[arg(long, value_name = "X", default_value_t = 0.95)]
    pub mac: f64,

    /// Least number of orders at which a physical mode is stable
    #[arg(long, value_name = "K", default_value_t = 3)]
    pub min_orders: usize,

    /// Print one JSON object instead of text
    #[arg(long)]
    pub json: bool,

    /// Write the diagram as SVG (feature `plot`)
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,

    /// Run even when the fits are estimated to take more than about a minute
    #[arg(long)]
    pub allow_long: bool,
}

/// Bases of `fdid ltv`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LtvBasisArg {
    /// Shifted Legendre polynomials in t, Legendre in w/w_max in frequency (eq. 20)
    Legendre,
    /// Monomials t^p and s^n (eqs. 1-2)
    Monomial,
}

/// Model domain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DomainArg {
    /// Continuous time (Laplace variable s)
    S,
    /// Discrete time (z = exp(i w Ts))
    Z,
}

/// Estimation criterion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CriterionArg {
    /// Levy -> Sanathanan-Koerner -> maximum likelihood
    Ml,
    /// Levy linear least squares
    Levy,
    /// Levy -> Sanathanan-Koerner
    Sk,
    /// Total least squares (SVD null vector)
    Tls,
    /// Levy -> Sanathanan-Koerner -> ML -> errors-in-variables maximum likelihood
    Eiv,
}

impl From<CriterionArg> for Method {
    fn from(c: CriterionArg) -> Self {
        match c {
            CriterionArg::Ml => Method::Ml,
            CriterionArg::Levy => Method::Levy,
            CriterionArg::Sk => Method::Sk,
            CriterionArg::Tls => Method::Tls,
            CriterionArg::Eiv => Method::Eiv,
        }
    }
}

impl From<Method> for CriterionArg {
    fn from(m: Method) -> Self {
        match m {
            Method::Ml => CriterionArg::Ml,
            Method::Levy => CriterionArg::Levy,
            Method::Sk => CriterionArg::Sk,
            Method::Tls => CriterionArg::Tls,
            Method::Eiv => CriterionArg::Eiv,
        }
    }
}

impl CriterionArg {
    /// What the criterion runs.
    pub fn description(self) -> &'static str {
        match self {
            Self::Ml => "Levy -> Sanathanan-Koerner -> maximum likelihood",
            Self::Levy => "Levy linear least squares",
            Self::Sk => "Levy -> Sanathanan-Koerner",
            Self::Tls => "total least squares",
            Self::Eiv => {
                "Levy -> Sanathanan-Koerner -> maximum likelihood -> errors-in-variables \
                 maximum likelihood (eq. 42)"
            }
        }
    }
}

/// Parses `FMIN:FMAX` (Hz); an empty side is `None`.
pub fn parse_band(text: &str) -> Result<(Option<f64>, Option<f64>), String> {
    let bad = |why: &str| format!("invalid --band `{text}`: {why} (expected FMIN:FMAX in Hz)");
    let (lo, hi) = text
        .split_once(':')
        .ok_or_else(|| bad("missing `:` separator"))?;
    let side = |s: &str, name: &str| -> Result<Option<f64>, String> {
        let s = s.trim();
        if s.is_empty() {
            return Ok(None);
        }
        let v: f64 = s
            .parse()
            .map_err(|_| bad(&format!("{name} `{s}` is not a number")))?;
        if !v.is_finite() || v < 0.0 {
            return Err(bad(&format!(
                "{name} = {s} must be finite and non-negative"
            )));
        }
        Ok(Some(v))
    };
    let (lo, hi) = (side(lo, "FMIN")?, side(hi, "FMAX")?);
    if let (Some(a), Some(b)) = (lo, hi)
        && a > b
    {
        return Err(bad(&format!("FMIN = {a} exceeds FMAX = {b}")));
    }
    Ok((lo, hi))
}

/// Prints clap's help or version, or its error condensed to one `error:` line.
pub fn clap_failure(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp
        | ErrorKind::DisplayVersion
        | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            // `fdid` alone shows the help (on stderr) and fails; --help succeeds
            let _ = e.print();
            return if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                ExitCode::from(2)
            } else {
                ExitCode::SUCCESS
            };
        }
        _ => {}
    }
    let text = e.to_string();
    let mut parts: Vec<&str> = Vec::new();
    for line in text.lines().map(str::trim) {
        if line.starts_with("Usage:") || line.starts_with("For more information") {
            break;
        }
        if line.is_empty() || line.starts_with("tip:") {
            continue;
        }
        parts.push(line);
    }
    let msg = parts.join(" ");
    let msg = msg.strip_prefix("error:").unwrap_or(&msg).trim();
    let command = match std::env::args().nth(1).as_deref() {
        Some("diagnose") => "diagnose",
        Some("ltv") => "ltv",
        _ => "fit",
    };
    eprintln!(
        "error: {} (see `fdid {command} --help`)",
        super::message::one_line(msg)
    );
    ExitCode::from(2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_syntax() {
        assert_eq!(parse_band("1:10"), Ok((Some(1.0), Some(10.0))));
        assert_eq!(parse_band(":10"), Ok((None, Some(10.0))));
        assert_eq!(parse_band("0.5:"), Ok((Some(0.5), None)));
        assert!(parse_band("10").is_err());
        assert!(parse_band("a:b").is_err());
        assert!(parse_band("10:1").is_err());
        assert!(parse_band("-1:1").is_err());
        assert!(parse_band("1:inf").is_err());
    }

    #[test]
    fn cli_is_consistent() {
        use clap::CommandFactory;
        Cli::command().debug_assert();
    }
}
