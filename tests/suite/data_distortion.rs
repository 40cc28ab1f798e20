//! Nonlinear distortion detection with odd random-phase multisines and the best linear
//! approximation (`OddMultisineDesign`, `DistortionAnalysis`).
//!
//! Simulation: a Wiener system — the 2nd-order discrete-time filter
//! G(z) = (0.5 + 0.3 z⁻¹)/(1 − 1.2 z⁻¹ + 0.5 z⁻²) followed by y = x + a x² + b x³ — driven
//! by a random odd multisine (one odd line in 3 left out) on lines 1…60 of a 256-sample
//! period (Ts = 1), warm-up periods dropped, white Gaussian output noise.
//!
//! - Design: the line sets partition the band, one detection line per full group
//!   (quickcheck), and the multisine has energy only at the excited lines.
//! - Noise-free linear system: the BLA equals G to rounding (f64, f32, and a quickcheck over
//!   random 2nd-order systems).
//! - Linear system with noise: the false-alarm rate at α = 0.05 over 200 seeds for
//!   P = 2, 4, 8; the BLA is unbiased and its predicted standard deviation matches the
//!   Monte Carlo spread.
//! - Cubic only: odd lines fire, even do not; quadratic only: even lines fire, odd do not.
//! - Detection power against the distortion level (table printed with `--nocapture`).
//! - Several phase realisations: the total BLA variance from their spread against the
//!   single-realisation estimate interpolated from the odd detection lines.
//! - Bad inputs give typed errors.

use fdid::data::DistortionAnalysis;
use fdid::simulate::{DtFilter, OddMultisineDesign, SplitMix64};
use fdid::{Complex, FdidError, Real, TimeData};
use quickcheck::TestResult;

use crate::common;

/// Samples per period.
const M: usize = 256;
/// The analysed band (lines of one period).
const BAND: [usize; 2] = [1, 60];
/// Odd lines per group (one left out).
const GROUP: usize = 3;

/// G(z) = (0.5 + 0.3 z⁻¹) / (1 − 1.2 z⁻¹ + 0.5 z⁻²): poles at radius √0.5.
fn g_filter() -> DtFilter {
    DtFilter::new(vec![0.5, 0.3], vec![1.0, -1.2, 0.5]).unwrap()
}

/// One experiment's settings.
#[derive(Clone, Copy)]
struct Setup {
    periods: usize,
    warmup: usize,
    /// y = x + a x² + b x³
    a: f64,
    b: f64,
    noise_sd: f64,
}

impl Setup {
    fn linear(periods: usize, noise_sd: f64) -> Self {
        Self {
            periods,
            warmup: 2,
            a: 0.0,
            b: 0.0,
            noise_sd,
        }
    }
}

/// The Wiener system's steady-state record (warm-up dropped) for phase realisation
/// `phase_seed` and noise `noise_seed`, and the linear part x's samples too.
fn simulate<T: Real>(
    design: &OddMultisineDesign,
    filter: &DtFilter,
    s: Setup,
    phase_seed: u64,
    noise_seed: u64,
) -> TimeData<T> {
    let total = (s.warmup + s.periods) * M;
    let u: Vec<f64> = design
        .multisine(M as f64, phase_seed)
        .unwrap()
        .sample(1.0, total);
    let x = filter.filter(&u);
    let mut rng = SplitMix64::new(noise_seed);
    let y: Vec<f64> = x
        .iter()
        .map(|x| x + s.a * x * x + s.b * x * x * x + s.noise_sd * rng.gaussian())
        .collect();
    let keep = s.warmup * M;
    let to_t = |v: &[f64]| v[keep..].iter().map(|x| T::lit(*x)).collect::<Vec<T>>();
    TimeData::new(to_t(&u), to_t(&y), T::one()).unwrap()
}

fn design(seed: u64) -> OddMultisineDesign {
    OddMultisineDesign::new(BAND, GROUP, seed).unwrap()
}

/// G at line k of a period of M samples (Ts = 1).
fn g_at(filter: &DtFilter, k: usize) -> Complex<f64> {
    filter.response(std::f64::consts::TAU * k as f64 / M as f64)
}

fn c64<T: Real>(c: Complex<T>) -> Complex<f64> {
    Complex::new(c.re.to_f64_lossless(), c.im.to_f64_lossless())
}

/// max_k |Ĝ_k − G_k| / |G_k| over the excited lines.
fn bla_rel_error<T: Real>(nl: &DistortionAnalysis<T>, filter: &DtFilter) -> f64 {
    nl.excited()
        .iter()
        .zip(nl.bla())
        .map(|(&k, g)| {
            let g0 = g_at(filter, k);
            (c64(*g) - g0).norm() / g0.norm()
        })
        .fold(0.0, f64::max)
}

// ---------------------------------------------------------------------------------------
// Design
// ---------------------------------------------------------------------------------------

#[test]
fn design_partitions_the_band() {
    fn prop(seed: u64, lo: u8, width: u8, group: u8) -> TestResult {
        let lo = 1 + lo as usize % 50;
        let hi = lo + width as usize % 200;
        let group = 2 + group as usize % 4;
        let d = match OddMultisineDesign::new([lo, hi], group, seed) {
            Ok(d) => d,
            Err(FdidError::TooShort { needed, got, .. }) => {
                let odd = (lo..=hi).filter(|k| k % 2 == 1).count();
                return TestResult::from_bool(needed == group && got == odd && odd < group);
            }
            Err(e) => return TestResult::error(format!("{e}")),
        };
        let mut all: Vec<usize> = d
            .excited()
            .iter()
            .chain(d.odd_detection())
            .chain(d.even_detection())
            .copied()
            .collect();
        all.sort_unstable();
        let band: Vec<usize> = (lo..=hi).collect();
        let odd: Vec<usize> = band.iter().copied().filter(|k| k % 2 == 1).collect();
        // one detection line in every full group, none in the incomplete last one
        let per_group = odd.chunks(group).all(|c| {
            let n = c.iter().filter(|k| d.odd_detection().contains(k)).count();
            n == usize::from(c.len() == group)
        });
        let sorted = |v: &[usize]| v.windows(2).all(|w| w[0] < w[1]);
        TestResult::from_bool(
            all == band
                && per_group
                && d.excited().iter().all(|k| k % 2 == 1)
                && d.even_detection().iter().all(|k| k % 2 == 0)
                && sorted(d.excited())
                && sorted(d.odd_detection())
                && d.band() == [lo, hi]
                && d.group() == group,
        )
    }
    crate::common::seeded(0x85474af0)
        .tests(300)
        .quickcheck(prop as fn(u64, u8, u8, u8) -> TestResult);
}

#[test]
fn design_multisine_excites_only_its_lines() {
    let d = design(5);
    let u = d.multisine(M as f64, 9).unwrap();
    assert_eq!(u.lines(), d.excited());
    assert!((u.rms() - 1.0f64).abs() < 1e-12);
    let x = fdid::data::dft_lines(&u.sample(1.0, M));
    let amp = u.amplitudes()[0] * (M as f64).sqrt() / 2.0;
    for (k, xk) in x.iter().enumerate() {
        let want = if d.excited().contains(&k) { amp } else { 0.0 };
        assert!(
            (xk.norm() - want).abs() < 1e-11 * amp,
            "line {k}: |U| = {}, want {want}",
            xk.norm()
        );
    }
    // another seed, another phase realisation, same lines
    let v = d.multisine(M as f64, 10).unwrap();
    assert_eq!(v.lines(), u.lines());
    assert_ne!(v.phases(), u.phases());
}

// ---------------------------------------------------------------------------------------
// Noise-free recovery of the BLA (= G for a linear system)
// ---------------------------------------------------------------------------------------

fn noise_free_recovery<T: Real>(tol: f64) -> f64 {
    let f = g_filter();
    let d = design(1);
    let rec = simulate::<T>(&d, &f, Setup::linear(4, 0.0), 2, 3);
    let nl = DistortionAnalysis::new(&rec, 4, d.excited(), BAND).unwrap();
    assert_eq!(nl.excited(), d.excited());
    let err = bla_rel_error(&nl, &f);
    assert!(err < tol, "BLA relative error {err:.3e} ≥ {tol:.1e}");
    for (w, &k) in nl.omega().iter().zip(nl.excited()) {
        let want = std::f64::consts::TAU * k as f64 / M as f64;
        assert!((w.to_f64_lossless() - want).abs() < 1e-6 * want);
    }
    err
}

#[test]
fn noise_free_bla_equals_g_f64() {
    let err = noise_free_recovery::<f64>(1e-12);
    println!("noise-free BLA, f64: max relative error {err:.2e}");
}

#[test]
fn noise_free_bla_equals_g_f32() {
    let err = noise_free_recovery::<f32>(1e-4);
    println!("noise-free BLA, f32: max relative error {err:.2e}");
}

/// Random stable 2nd-order discrete-time systems (tests/common), noise free: Ĝ = G.
fn random_system_recovery<T: Real>(seed: u64, nb: usize, tol: f64) -> TestResult {
    let sys = common::random_dt_system(seed, 2, nb);
    let theta = common::dt_theta(&sys);
    let (a, b) = (
        [vec![1.0], theta[..2].to_vec()].concat(),
        theta[2..].to_vec(),
    );
    let f = DtFilter::new(b, a).unwrap();
    let d = OddMultisineDesign::new([1, 100], 4, seed).unwrap();
    // poles up to radius 0.95: 4 warm-up periods leave 0.95^1024 ≈ 1e-23 of the transient
    let s = Setup {
        warmup: 4,
        ..Setup::linear(3, 0.0)
    };
    let rec = simulate::<T>(&d, &f, s, seed ^ 0x55, 0);
    let nl = DistortionAnalysis::new(&rec, 3, d.excited(), [1, 100]).unwrap();
    let err = bla_rel_error(&nl, &f);
    TestResult::from_bool(err < tol)
}

#[test]
fn noise_free_bla_random_systems_f64() {
    fn prop(seed: u64, nb: u8) -> TestResult {
        random_system_recovery::<f64>(seed, nb as usize % 3, 1e-9)
    }
    crate::common::seeded(0xf2407a66)
        .tests(50)
        .quickcheck(prop as fn(u64, u8) -> TestResult);
}

#[test]
fn noise_free_bla_random_systems_f32() {
    fn prop(seed: u64, nb: u8) -> TestResult {
        random_system_recovery::<f32>(seed, nb as usize % 3, 1e-3)
    }
    crate::common::seeded(0x6b492bdc)
        .tests(50)
        .quickcheck(prop as fn(u64, u8) -> TestResult);
}

// ---------------------------------------------------------------------------------------
// Linear system with noise: false alarms and the BLA's statistics
// ---------------------------------------------------------------------------------------

/// Rates over `seeds` linear runs at α: (is_nonlinear, odd Fisher, even Fisher, odd sum,
/// even sum) — the single tests at α, the decision with Bonferroni α/2.
fn false_alarms(periods: usize, seeds: u64, alpha: f64) -> [f64; 5] {
    let f = g_filter();
    let mut counts = [0usize; 5];
    for seed in 0..seeds {
        let d = design(seed);
        let rec = simulate::<f64>(&d, &f, Setup::linear(periods, 0.05), seed, 1000 + seed);
        let nl = DistortionAnalysis::new(&rec, periods, d.excited(), BAND).unwrap();
        let (odd, even) = (nl.odd().unwrap(), nl.even().unwrap());
        let hits = [
            nl.is_nonlinear(alpha).unwrap(),
            odd.p_fisher < alpha,
            even.p_fisher < alpha,
            odd.p_sum.is_some_and(|p| p < alpha),
            even.p_sum.is_some_and(|p| p < alpha),
        ];
        for (c, h) in counts.iter_mut().zip(hits) {
            *c += usize::from(h);
        }
    }
    counts.map(|c| c as f64 / seeds as f64)
}

#[test]
fn false_alarm_rate_linear_1000_seeds() {
    // 1000 seeds: a binomial rate of 5 % has a standard deviation of 0.7 %
    let alpha = 0.05;
    println!("false-alarm rates at α = {alpha} over 1000 seeds (linear system, noise only)");
    println!("  P   decision  odd(Fisher) even(Fisher) odd(sum) even(sum)");
    for periods in [2, 4, 8] {
        let r = false_alarms(periods, 1000, alpha);
        println!(
            "  {periods}   {:.3}     {:.3}       {:.3}        {:.3}    {:.3}",
            r[0], r[1], r[2], r[3], r[4]
        );
        assert!(r[0] <= 0.07, "P = {periods}: false-alarm rate {}", r[0]);
        assert!(
            r.iter().all(|x| *x <= 0.07),
            "P = {periods}: single rates {r:?}"
        );
    }
}

/// Linear system with noise: Ĝ − G over seeds has no bias beyond its standard error and
/// its spread matches the predicted noise variance.
#[test]
fn bla_monte_carlo_linear() {
    let (periods, seeds) = (4usize, 1000u64);
    let f = g_filter();
    let d = design(3);
    let lines = d.excited().len();
    let mut err_sum = vec![Complex::new(0.0, 0.0); lines];
    let mut err2 = vec![0.0; lines];
    let mut pred = vec![0.0; lines];
    let mut total_over_noise = 0.0;
    for seed in 0..seeds {
        // one phase realisation: a linear system has no stochastic nonlinear part
        let rec = simulate::<f64>(&d, &f, Setup::linear(periods, 0.1), 7, 5000 + seed);
        let nl = DistortionAnalysis::new(&rec, periods, d.excited(), BAND).unwrap();
        for (i, (&k, g)) in nl.excited().iter().zip(nl.bla()).enumerate() {
            let e = *g - g_at(&f, k);
            err_sum[i] += e;
            err2[i] += e.norm_sqr();
            pred[i] += nl.bla_noise_variance()[i];
        }
        total_over_noise += nl.bla_total_variance().iter().sum::<f64>()
            / nl.bla_noise_variance().iter().sum::<f64>();
    }
    let n = seeds as f64;
    // bias: |mean error| / (std/√n), averaged over lines: E|z|² = 1 for a complex z-score
    let bias_z2 = (0..lines)
        .map(|i| (err_sum[i] / n).norm_sqr() / (err2[i] / n / n))
        .sum::<f64>()
        / lines as f64;
    // spread vs prediction: E σ̂² = σ², so mean |e|² / mean σ̂² → 1
    let ratio = (0..lines).map(|i| (err2[i] / pred[i]).sqrt()).sum::<f64>() / lines as f64;
    println!(
        "BLA Monte Carlo (linear, P = {periods}, {seeds} runs, {lines} lines): mean |bias z|² = {bias_z2:.3} (≈ 1 without bias), sample std / predicted std = {ratio:.3}, total/noise variance {:.3}",
        total_over_noise / n
    );
    // mean of 20 values of mean 1 and standard deviation ≈ 1: 1.5 is +2.2 σ
    assert!(bias_z2 < 1.5, "bias z² {bias_z2}");
    assert!((ratio - 1.0).abs() < 0.03, "std ratio {ratio}");
    // the interpolated nonlinear variance is noise-level small for a linear system
    assert!(
        total_over_noise / n < 1.6,
        "total/noise {}",
        total_over_noise / n
    );
}

// ---------------------------------------------------------------------------------------
// Odd and even distortion
// ---------------------------------------------------------------------------------------

fn rates(s: Setup, seeds: u64, alpha: f64) -> (f64, f64, f64) {
    let f = g_filter();
    let (mut any, mut odd, mut even) = (0, 0, 0);
    for seed in 0..seeds {
        let d = design(seed);
        let rec = simulate::<f64>(&d, &f, s, 100 + seed, 7000 + seed);
        let nl = DistortionAnalysis::new(&rec, s.periods, d.excited(), BAND).unwrap();
        any += usize::from(nl.is_nonlinear(alpha).unwrap());
        odd += usize::from(nl.odd().unwrap().p_value() < alpha / 2.0);
        even += usize::from(nl.even().unwrap().p_value() < alpha / 2.0);
    }
    let n = seeds as f64;
    (any as f64 / n, odd as f64 / n, even as f64 / n)
}

#[test]
fn cubic_fires_odd_lines_only() {
    let s = Setup {
        b: 0.02,
        ..Setup::linear(4, 0.05)
    };
    let (any, odd, even) = rates(s, 100, 0.05);
    println!("y = x + 0.02 x³: detected {any:.2}, odd {odd:.2}, even {even:.2}");
    assert_eq!(odd, 1.0);
    assert_eq!(any, 1.0);
    assert!(even <= 0.06, "even false alarms {even}");
    // the levels: odd distortion well above, even not
    let f = g_filter();
    let d = design(0);
    let rec = simulate::<f64>(&d, &f, s, 1, 2);
    let nl = DistortionAnalysis::new(&rec, 4, d.excited(), BAND).unwrap();
    let odd_db = nl.odd().unwrap().distortion_db.unwrap();
    assert!(
        odd_db > nl.noise_db() + 10.0,
        "{odd_db} vs {}",
        nl.noise_db()
    );
    assert!(
        nl.even()
            .unwrap()
            .distortion_db
            .is_none_or(|e| e < nl.noise_db() + 3.0)
    );
    print!("{}", nl.summary(0.05).unwrap());
    assert!(nl.summary(0.05).unwrap().contains("cannot remove"));
}

#[test]
fn quadratic_fires_even_lines_only() {
    let s = Setup {
        a: 0.02,
        ..Setup::linear(4, 0.05)
    };
    let (any, odd, even) = rates(s, 100, 0.05);
    println!("y = x + 0.02 x²: detected {any:.2}, odd {odd:.2}, even {even:.2}");
    assert_eq!(even, 1.0);
    assert_eq!(any, 1.0);
    assert!(odd <= 0.06, "odd false alarms {odd}");
}

/// Strong cubic distortion with 1e-3 noise: the odd test rejects overwhelmingly and the
/// even test does not reject at 1e-6, for random designs and phases (f64 and f32).
fn odd_even_property<T: Real>(seed: u64) -> bool {
    let f = g_filter();
    let d = design(seed);
    let s = Setup {
        b: 0.05,
        ..Setup::linear(3, 1e-3)
    };
    let rec = simulate::<T>(&d, &f, s, seed.wrapping_add(1), seed.wrapping_add(2));
    let nl = DistortionAnalysis::new(&rec, 3, d.excited(), BAND).unwrap();
    nl.odd().unwrap().p_value() < 1e-12
        && nl.even().unwrap().p_value() > 1e-6
        && nl.is_nonlinear(1e-6).unwrap()
}

#[test]
fn odd_even_property_f64() {
    crate::common::seeded(0x1c4e1b4a)
        .tests(40)
        .quickcheck(odd_even_property::<f64> as fn(u64) -> bool);
}

#[test]
fn odd_even_property_f32() {
    crate::common::seeded(0x822a8ee9)
        .tests(40)
        .quickcheck(odd_even_property::<f32> as fn(u64) -> bool);
}

// ---------------------------------------------------------------------------------------
// Detection power against the distortion level
// ---------------------------------------------------------------------------------------

/// Distortion-to-noise ratio per odd detection line: D/σ², with D the mean distortion
/// power at the odd detection lines (noise free, b = 1: the x³ term is exactly linear in b
/// there because x has no energy at those lines) and σ² = σ_e²/P the noise variance of the
/// mean. For a target ratio ρ, b = √(ρ σ_e² / (P D₁)).
///
/// Returns the detection rates of `is_nonlinear` and of the same Bonferroni decision made
/// with the scaled-χ² sum test instead (`p_sum`; Fisher's for P < 4).
fn power_at(db: Option<f64>, periods: usize, seeds: u64, alpha: f64) -> (f64, f64) {
    let f = g_filter();
    let sd = 0.05;
    let (mut hits, mut hits_sum) = (0, 0);
    for seed in 0..seeds {
        let d = design(seed);
        let b = match db {
            None => 0.0,
            Some(db) => {
                let clean = Setup {
                    b: 1.0,
                    ..Setup::linear(2, 0.0)
                };
                let rec = simulate::<f64>(&d, &f, clean, 300 + seed, 0);
                let nl = DistortionAnalysis::new(&rec, 2, d.excited(), BAND).unwrap();
                let d1 = nl.odd().unwrap().distortion_power;
                (10f64.powf(db / 10.0) * sd * sd / (periods as f64 * d1)).sqrt()
            }
        };
        let s = Setup {
            b,
            ..Setup::linear(periods, sd)
        };
        let rec = simulate::<f64>(&d, &f, s, 300 + seed, 9000 + seed);
        let nl = DistortionAnalysis::new(&rec, periods, d.excited(), BAND).unwrap();
        hits += usize::from(nl.is_nonlinear(alpha).unwrap());
        let p_sum = |t: &fdid::data::DetectionTest| t.p_sum.unwrap_or(t.p_fisher);
        hits_sum +=
            usize::from(p_sum(nl.odd().unwrap()).min(p_sum(nl.even().unwrap())) < alpha / 2.0);
    }
    (hits as f64 / seeds as f64, hits_sum as f64 / seeds as f64)
}

#[test]
fn detection_power_table() {
    let (periods, seeds, alpha) = (4, 300, 0.05);
    println!(
        "detection rate of y = x + b x³ at α = {alpha}, P = {periods}, {seeds} seeds, 20 odd detection lines"
    );
    println!("  distortion/noise per odd line   is_nonlinear   (sum test)");
    let mut table = vec![];
    let levels = [
        None,
        Some(-10.0),
        Some(-6.0),
        Some(-3.0),
        Some(0.0),
        Some(3.0),
        Some(6.0),
        Some(10.0),
    ];
    for db in levels {
        let (r, r_sum) = power_at(db, periods, seeds, alpha);
        match db {
            None => println!("  none (linear)                  {r:.3}          ({r_sum:.3})"),
            Some(db) => {
                println!("  {db:+5.1} dB                       {r:.3}          ({r_sum:.3})")
            }
        }
        table.push(r);
    }
    // 300 seeds: 5 % plus 3 binomial standard deviations (the 1000-seed test is tighter)
    assert!(table[0] <= 0.088, "linear false alarms {}", table[0]);
    // the rate grows with the level, and +6 dB per line over 20 lines is a sure detection
    assert!(table.windows(2).all(|w| w[1] >= w[0] - 0.03), "{table:?}");
    assert!(table[4] > 0.3, "{table:?}");
    assert!(table[6..].iter().all(|r| *r >= 0.99), "{table:?}");
}

// ---------------------------------------------------------------------------------------
// Several phase realisations
// ---------------------------------------------------------------------------------------

#[test]
fn realisations_total_variance_matches_interpolated_nonlinear_variance() {
    let (periods, r) = (4usize, 16u64);
    let f = g_filter();
    let d = design(4);
    let s = Setup {
        b: 0.03,
        ..Setup::linear(periods, 0.01)
    };
    let records: Vec<TimeData<f64>> = (0..r)
        .map(|i| simulate::<f64>(&d, &f, s, 40 + i, 60 + i))
        .collect();
    let all = DistortionAnalysis::from_realisations(&records, periods, d.excited(), BAND).unwrap();
    assert_eq!(all.realisations(), r as usize);
    assert_eq!(all.bla_variance_dof(), Some(r as usize - 1));
    assert!(all.is_nonlinear(0.05).unwrap());
    // per-realisation nonlinear variance: from the spread (× R) and from the single
    // realisations' interpolation, averaged over the lines
    let spread: f64 = all.bla_nonlinear_variance().unwrap().iter().sum::<f64>() * r as f64;
    let mut interp = 0.0;
    for rec in &records {
        let one = DistortionAnalysis::new(rec, periods, d.excited(), BAND).unwrap();
        interp += one.bla_nonlinear_variance().unwrap().iter().sum::<f64>() / r as f64;
    }
    let noise: f64 = all.bla_noise_variance().iter().sum::<f64>() * r as f64;
    println!(
        "nonlinear variance of Ĝ per realisation (sum over lines): spread {spread:.3e}, interpolated {interp:.3e}, noise {noise:.3e}"
    );
    assert!(
        spread > 5.0 * noise,
        "the distortion dominates the noise here"
    );
    // R = 16 gives the spread a relative precision of about √(1/15) ≈ 0.26 per line;
    // summed over 40 lines it is close, and the interpolation must agree within 40 %
    assert!(
        (interp / spread - 1.0).abs() < 0.4,
        "interpolated {interp:.3e} vs spread {spread:.3e}"
    );
    // the averaged BLA lies within its total uncertainty of G (1 + 3 b σ_x²), the
    // Gaussian-input BLA of a Wiener cubic
    let sigma_x2: f64 = {
        let u = d.multisine(M as f64, 40).unwrap();
        let a2 = u.amplitudes()[0] * u.amplitudes()[0];
        d.excited()
            .iter()
            .map(|&k| g_at(&f, k).norm_sqr() * a2 / 2.0)
            .sum()
    };
    let gain = 1.0 + 3.0 * s.b * sigma_x2;
    let mut z2 = 0.0;
    for ((&k, g), v) in all
        .excited()
        .iter()
        .zip(all.bla())
        .zip(all.bla_total_variance())
    {
        z2 += (*g - g_at(&f, k) * gain).norm_sqr() / v;
    }
    z2 /= all.excited().len() as f64;
    println!(
        "BLA vs G (1 + 3bσ²) = G × {gain:.4}: mean |z|² = {z2:.3} (F(2, 30) mean 1.07 if the Gaussian BLA were exact)"
    );
    assert!(z2 < 2.0, "mean |z|² {z2}");
    // the BLA differs from G itself by far more than its uncertainty
    let far: f64 = all
        .excited()
        .iter()
        .zip(all.bla())
        .zip(all.bla_total_variance())
        .map(|((&k, g), v)| (*g - g_at(&f, k)).norm_sqr() / v)
        .sum::<f64>()
        / all.excited().len() as f64;
    assert!(far > 10.0, "BLA vs G: mean |z|² {far}");
    // and the data for a parametric fit of the BLA
    let data = all.bla_data().unwrap();
    assert_eq!(data.len(), all.excited().len());
    assert_eq!(data.variance_dof(), Some(r as usize - 1));
}

// ---------------------------------------------------------------------------------------
// Bad inputs
// ---------------------------------------------------------------------------------------

#[test]
fn bad_inputs_give_typed_errors() {
    let f = g_filter();
    let d = design(2);
    let rec = simulate::<f64>(&d, &f, Setup::linear(4, 0.01), 1, 1);
    let exc = d.excited();
    let name = |r: fdid::Result<DistortionAnalysis<f64>>| match r {
        Err(FdidError::InvalidArgument { name, value, .. }) => (name, value),
        other => panic!("expected InvalidArgument, got {other:?}"),
    };
    // P < 2
    assert_eq!(
        name(DistortionAnalysis::new(&rec, 1, exc, BAND)),
        ("periods", "1".into())
    );
    assert_eq!(
        name(DistortionAnalysis::new(&rec, 0, exc, BAND)),
        ("periods", "0".into())
    );
    // N not a multiple of P
    assert_eq!(
        name(DistortionAnalysis::new(&rec, 3, exc, BAND)).0,
        "periods"
    );
    // excited line outside the record (⌊M/2⌋ = 128)
    assert_eq!(
        name(DistortionAnalysis::new(&rec, 4, &[3, 129], BAND)),
        ("excited", "129".into())
    );
    // band at or above Nyquist, DC in the band, reversed band
    assert_eq!(
        name(DistortionAnalysis::new(&rec, 4, exc, [1, 128])).0,
        "band"
    );
    assert_eq!(
        name(DistortionAnalysis::new(&rec, 4, exc, [0, 60])).0,
        "band"
    );
    assert_eq!(
        name(DistortionAnalysis::new(&rec, 4, exc, [61, 60])).0,
        "band"
    );
    // no detection line: every line of the band excited
    let every: Vec<usize> = (1..=60).collect();
    assert!(matches!(
        DistortionAnalysis::new(&rec, 4, &every, BAND),
        Err(FdidError::TooShort {
            needed: 1,
            got: 0,
            ..
        })
    ));
    // no excited line, or none in the band
    assert!(matches!(
        DistortionAnalysis::new(&rec, 4, &[], BAND),
        Err(FdidError::TooShort {
            what: "excited lines",
            ..
        })
    ));
    assert!(matches!(
        DistortionAnalysis::new(&rec, 4, &[101], BAND),
        Err(FdidError::TooShort {
            what: "excited lines in the band",
            ..
        })
    ));
    // an "excited" line without input
    assert!(matches!(
        DistortionAnalysis::new(&rec, 4, &[2, exc[0]], BAND),
        Err(FdidError::ZeroInput { index: 2, .. })
    ));
    // α outside (0, 1)
    let nl = DistortionAnalysis::new(&rec, 4, exc, BAND).unwrap();
    for alpha in [0.0, 1.0, -0.1, f64::NAN] {
        assert!(matches!(
            nl.is_nonlinear(alpha),
            Err(FdidError::InvalidArgument { name: "alpha", .. })
        ));
    }
    // realisations: none, different lengths, different sample times
    assert!(matches!(
        DistortionAnalysis::<f64>::from_realisations(&[], 4, exc, BAND),
        Err(FdidError::TooShort {
            what: "realisations",
            ..
        })
    ));
    let short = simulate::<f64>(&d, &f, Setup::linear(2, 0.01), 1, 1);
    assert!(matches!(
        DistortionAnalysis::from_realisations(&[rec.clone(), short], 4, exc, BAND),
        Err(FdidError::LengthMismatch { .. })
    ));
    let other_ts = TimeData::new(rec.u().to_vec(), rec.y().to_vec(), 0.5).unwrap();
    assert_eq!(
        name(DistortionAnalysis::from_realisations(
            &[rec.clone(), other_ts],
            4,
            exc,
            BAND
        ))
        .0,
        "ts"
    );
    // design
    assert!(matches!(
        OddMultisineDesign::new([0, 10], 3, 0),
        Err(FdidError::InvalidArgument { name: "band", .. })
    ));
    assert!(matches!(
        OddMultisineDesign::new([1, 10], 1, 0),
        Err(FdidError::InvalidArgument { name: "group", .. })
    ));
    assert!(matches!(
        OddMultisineDesign::new([3, 5], 3, 0),
        Err(FdidError::TooShort {
            needed: 3,
            got: 2,
            ..
        })
    ));
    assert!(matches!(
        design(0).multisine(-1.0f64, 0),
        Err(FdidError::InvalidArgument { name: "period", .. })
    ));
}

/// With only even detection lines (every odd line of the band excited) the odd test is
/// absent and the decision uses the even test alone.
#[test]
fn only_even_detection_lines() {
    let f = g_filter();
    // a design whose first odd detection line is 5 (one in three), so that lines 1…4
    // have odd lines 1, 3 excited and even lines 2, 4 free
    let d = (0..100)
        .map(design)
        .find(|d| d.odd_detection()[0] == 5)
        .unwrap();
    let rec = simulate::<f64>(
        &d,
        &f,
        Setup {
            a: 0.05,
            ..Setup::linear(4, 0.01)
        },
        1,
        1,
    );
    let nl = DistortionAnalysis::new(&rec, 4, d.excited(), [1, 4]).unwrap();
    assert_eq!(nl.excited(), &[1, 3]);
    assert!(nl.odd().is_none());
    assert!(nl.excited_distortion_power().is_none());
    assert_eq!(nl.even().unwrap().terms, 2);
    assert!(nl.is_nonlinear(0.05).unwrap());
    assert!(nl.bla_nonlinear_variance().is_none());
    assert_eq!(nl.bla_total_variance(), nl.bla_noise_variance());
}
