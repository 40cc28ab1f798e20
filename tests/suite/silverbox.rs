//! The Silverbox benchmark (`data/silverbox.csv`: ten realisations of an odd random-phase
//! multisine, one steady-state period of 8192 samples each): the file layout, the design,
//! why the distortion analysis does not apply (one period per realisation), and the best
//! linear approximation (BLA) fitted by the discrepancy workflow. See
//! `examples/silverbox.rs` for the printed analysis.
#![cfg(feature = "csv")]

use fdid::data::DistortionAnalysis;
use fdid::io::{Measurement, read_csv};
use fdid::model::Domain;
use fdid::workflow::{Context, ModelSpec, SpecFit, Workflow, fit_spec};
use fdid::{Complex, FdidError, FrequencyData, NoiseVariances, Real, TimeData};
use quickcheck::TestResult;
use std::f64::consts::TAU;
use std::path::Path;
use std::sync::OnceLock;

/// Samples per period, realisations, highest excited line.
const M: usize = 8192;
const R: usize = 10;
const K_MAX: usize = 2683;
/// Ts = 2¹⁴ / 10 MHz.
const TS: f64 = 0.0016384;
/// The resonance of the benchmark's BLA (Hz), from the data README.
const F_RES: f64 = 69.8;

fn path() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/silverbox.csv")
}

fn record<T: Real>() -> TimeData<T> {
    match read_csv::<T>(&path()).expect("data/silverbox.csv parses") {
        Measurement::Time(d) => d,
        other => panic!("expected a time record, got {other:?}"),
    }
}

/// The ten periods, each with its mean removed.
fn split<T: Real>(rec: &TimeData<T>) -> Vec<TimeData<T>> {
    (0..R)
        .map(|r| {
            let centred = |x: &[T]| {
                let x = &x[r * M..(r + 1) * M];
                let mean = x.iter().fold(T::zero(), |a, b| a + *b) / T::from_usize_lossy(M);
                x.iter().map(|v| *v - mean).collect::<Vec<T>>()
            };
            TimeData::new(centred(rec.u()), centred(rec.y()), rec.ts()).unwrap()
        })
        .collect()
}

struct Silverbox {
    record: TimeData<f64>,
    periods: Vec<TimeData<f64>>,
    dfts: Vec<FrequencyData<f64>>,
}

/// The file is read once for all tests.
fn silverbox() -> &'static Silverbox {
    static DATA: OnceLock<Silverbox> = OnceLock::new();
    DATA.get_or_init(|| {
        let record = record::<f64>();
        let periods = split(&record);
        let dfts = periods.iter().map(TimeData::dft).collect();
        Silverbox {
            record,
            periods,
            dfts,
        }
    })
}

fn excited() -> Vec<usize> {
    (1..=K_MAX).step_by(2).collect()
}

fn mean_power(x: &[Complex<f64>], lines: impl Iterator<Item = usize>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for k in lines {
        s += x[k].norm_sqr();
        n += 1;
    }
    s / n as f64
}

/// The BLA Ĝ_k = mean_r Y_r,k/U_r,k over the realisations `which`, at the excited lines up
/// to `f_max` Hz, with the variance of the mean from their spread (|which| − 1 dof).
fn bla(which: &[usize], f_max: f64) -> FrequencyData<f64> {
    let sb = silverbox();
    let df = 1.0 / (M as f64 * TS);
    let lines: Vec<usize> = excited()
        .into_iter()
        .filter(|&k| k as f64 * df <= f_max)
        .collect();
    let r = which.len() as f64;
    let g_r: Vec<Vec<Complex<f64>>> = which
        .iter()
        .map(|&i| {
            let d = &sb.dfts[i];
            lines.iter().map(|&k| d.y()[k] / d.u()[k]).collect()
        })
        .collect();
    let g: Vec<Complex<f64>> = (0..lines.len())
        .map(|i| g_r.iter().map(|v| v[i]).sum::<Complex<f64>>() / r)
        .collect();
    let var: Vec<f64> = (0..lines.len())
        .map(|i| g_r.iter().map(|v| (v[i] - g[i]).norm_sqr()).sum::<f64>() / (r * (r - 1.0)))
        .collect();
    let omega = lines.iter().map(|&k| TAU * k as f64 * df).collect();
    FrequencyData::from_frf(omega, g, Some(TS))
        .unwrap()
        .with_noise(NoiseVariances::output_only(var))
        .unwrap()
        .with_variance_dof(which.len() - 1)
        .unwrap()
}

/// Natural frequency (Hz) and damping of the lightest-damped complex pole pair.
fn resonance(fit: &SpecFit) -> (f64, f64) {
    let s = fit
        .poles
        .iter()
        .map(|p| match fit.spec.domain {
            Domain::Continuous => *p,
            Domain::Discrete { ts } => p.ln() / ts,
        })
        .filter(|s| s.im > 0.0)
        .min_by(|a, b| a.re.abs().total_cmp(&b.re.abs()))
        .expect("a complex pole pair");
    (s.norm() / TAU, -s.re / s.norm())
}

fn stable(fit: &SpecFit) -> bool {
    fit.poles.iter().all(|p| match fit.spec.domain {
        Domain::Continuous => p.re < 0.0,
        Domain::Discrete { .. } => p.norm() < 1.0,
    })
}

#[test]
fn file_holds_the_ten_periods_unchanged() {
    let rec = &silverbox().record;
    assert_eq!(rec.len(), R * M);
    assert!((rec.ts() - TS).abs() < 1e-12 * TS, "Ts = {}", rec.ts());
    // first and last samples as in SNLS80mV.csv (rows 40986 and 127405, 0-based)
    assert_eq!((rec.u()[0], rec.y()[0]), (0.0030594, 0.036534));
    assert_eq!(
        (rec.u()[R * M - 1], rec.y()[R * M - 1]),
        (-0.018723, -0.025914)
    );
    let rec32 = record::<f32>();
    assert_eq!(rec32.len(), R * M);
    assert_eq!(rec32.u()[0], 0.0030594f32);
}

#[test]
fn design_excites_every_odd_line_up_to_2683() {
    // measured: even lines −41.0 … −40.0 dB, odd lines above the band −64.2 … −56.0 dB
    for (r, d) in silverbox().dfts.iter().enumerate() {
        let odd = mean_power(d.u(), excited().into_iter());
        let even = mean_power(d.u(), (2..K_MAX).step_by(2));
        let above = mean_power(d.u(), (K_MAX + 2..M / 2).step_by(2));
        assert!(
            even < 10f64.powf(-3.8) * odd,
            "realisation {r}: even/odd {}",
            even / odd
        );
        assert!(
            above < 1e-5 * odd,
            "realisation {r}: above/odd {}",
            above / odd
        );
    }
}

#[test]
fn distortion_analysis_needs_two_periods_per_realisation() {
    let sb = silverbox();
    let err = DistortionAnalysis::from_realisations(&sb.periods, 1, &excited(), [1, K_MAX])
        .expect_err("one period per realisation gives no noise estimate");
    assert!(
        matches!(&err, FdidError::InvalidArgument { name: "periods", value, .. } if value == "1"),
        "{err}"
    );
    let err = Context::frequency_data(0.05)
        .with_record(sb.periods[0].clone(), 1)
        .expect_err("one period is no periodic record");
    assert!(
        matches!(
            &err,
            FdidError::InvalidArgument {
                name: "periods",
                ..
            }
        ),
        "{err}"
    );
}

/// Descriptive, not a noise test (no noise level per line exists with one period): the
/// output at the even lines near the resonance stands far above the input's even-line
/// content there and above the even-line output at 160–200 Hz. Measured: 32.2 dB and
/// 33.0 dB.
#[test]
fn even_lines_near_the_resonance_stand_out() {
    let sb = silverbox();
    let df = 1.0 / (M as f64 * TS);
    let even =
        |lo: f64, hi: f64| ((lo / df).ceil() as usize..=(hi / df) as usize).filter(|k| k % 2 == 0);
    let level =
        |f: &dyn Fn(&FrequencyData<f64>) -> f64| sb.dfts.iter().map(f).sum::<f64>() / R as f64;
    let y_res = level(&|d| mean_power(d.y(), even(60.0, 80.0)));
    let u_res = level(&|d| mean_power(d.u(), even(60.0, 80.0)));
    let y_high = level(&|d| mean_power(d.y(), even(160.0, 200.0)));
    assert!(y_res > 100.0 * u_res, "{y_res} vs input {u_res}");
    assert!(y_res > 100.0 * y_high, "{y_res} vs 160–200 Hz {y_high}");
}

#[test]
fn bla_peak_is_at_the_resonance() {
    let data = bla(&(0..R).collect::<Vec<_>>(), 200.0);
    let (i, g) = data
        .y()
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.norm().total_cmp(&b.1.norm()))
        .unwrap();
    let f = data.omega()[i] / TAU;
    // measured: 69.812 Hz, |Ĝ| = 10.75
    assert!((f - F_RES).abs() < 0.2, "peak at {f} Hz");
    assert!((g.norm() - 10.8).abs() < 0.5, "|Ĝ| = {}", g.norm());

    // the same peak line in f32
    let periods = split(&record::<f32>());
    let ratio = |k: usize| {
        periods
            .iter()
            .map(|p| {
                let d = p.dft();
                d.y()[k] / d.u()[k]
            })
            .fold(Complex::new(0.0f32, 0.0), |a, b| a + b)
            .norm()
            / R as f32
    };
    let k = (f * M as f64 * TS).round() as usize;
    assert!(
        ((ratio(k) - g.norm() as f32) / g.norm() as f32).abs() < 1e-3,
        "f32 {} vs f64 {}",
        ratio(k),
        g.norm()
    );
}

#[test]
fn workflow_fits_a_stable_second_order_bla() {
    let data = bla(&(0..R).collect::<Vec<_>>(), 200.0);
    let report = Workflow::default()
        .run(
            &data,
            ModelSpec::continuous(2, 0),
            Context::frequency_data(0.05),
        )
        .unwrap();
    let fit = &report.final_fit;
    assert!(stable(fit), "poles {:?}", fit.poles);
    let (f_n, zeta) = resonance(fit);
    // measured: f_n = 69.530 Hz, ζ = 0.0488, cost p = 0.387, no effect named
    assert!((f_n - F_RES).abs() < 1.0, "f_n = {f_n}");
    assert!((0.03..0.07).contains(&zeta), "ζ = {zeta}");
    assert!(report.effects.is_empty(), "{:?}", report.effects);
    assert!(report.consistent_with_noise, "{:?}", fit.validation);

    // discrete time on the lines up to 150 Hz: a zero and a delay are added, still stable
    let band = bla(&(0..R).collect::<Vec<_>>(), 150.0);
    let report = Workflow::default()
        .run(
            &band,
            ModelSpec::discrete(2, 2, TS),
            Context::frequency_data(0.05),
        )
        .unwrap();
    let fit = &report.final_fit;
    assert!(stable(fit), "poles {:?}", fit.poles);
    let (f_n, _) = resonance(fit);
    assert!((f_n - F_RES).abs() < 1.0, "f_n = {f_n}");
}

/// Any four or more of the ten realisations give a stable second-order BLA with its
/// resonance within 1 Hz of 69.8 Hz.
#[test]
fn bla_from_any_subset_of_realisations() {
    fn prop(mask: u16) -> TestResult {
        let which: Vec<usize> = (0..R).filter(|r| mask & (1 << r) != 0).collect();
        if which.len() < 4 {
            return TestResult::discard();
        }
        let fit = fit_spec(&ModelSpec::continuous(2, 0), &bla(&which, 200.0)).unwrap();
        let (f_n, _) = resonance(&fit);
        TestResult::from_bool(stable(&fit) && (f_n - F_RES).abs() < 1.0)
    }
    crate::common::seeded(0x5f9e17db)
        .tests(40)
        .quickcheck(prop as fn(u16) -> TestResult);
}
