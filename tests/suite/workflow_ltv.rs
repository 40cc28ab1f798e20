//! The time-varying ODE the workflow fits when it names time variation on a
//! continuous-time spec ([`fdid::workflow::time_varying_ode`], [`Report::ltv`]): the
//! choice of N_p and the gap on simulated records, and `fdid diagnose` on a periodic
//! record of a drifting system (time variation named, the gap shrinking, the frozen poles
//! in the text and JSON) and of a time-invariant one (nothing of the kind).
//!
//! The records come from the library's time-varying ODE integrator
//! ([`TimeVaryingOde`], Dormand–Prince) driven by a random-phase multisine: the system
//! ÿ + 0.4 ẏ + a₀(t) y = 4 u with a₀(t) = a + c t (c = 0: time-invariant), frozen poles
//! −0.2 ± j√(a₀(t) − 0.04) (Lataire–Pintelon eq. 4).
//!
//! [`Report::ltv`]: fdid::workflow::Report::ltv

use crate::common::Noise;
use fdid::prelude::*;
use fdid::simulate::{DormandPrince, LineSelection, Multisine, TimeVaryingOde};
use fdid::workflow::{ModelSpec, fit_spec, time_varying_ode};

/// Sample time (s) of the simulated records.
pub const TS: f64 = 0.1;

/// A simulated record of ÿ + 0.4 ẏ + (a0 + slope t) y = 4 u.
pub struct LtvRecord {
    /// The samples.
    pub data: TimeData<f64>,
    /// a₀(t) = a0 + slope · (t + offset).
    pub a0: f64,
    /// See `a0`.
    pub slope: f64,
    /// Time (s) from the start of the simulation to the first kept sample.
    pub offset: f64,
}

impl LtvRecord {
    /// `n` samples at [`TS`] of the response from rest to a multisine of period
    /// M = `n / periods` samples on its lines 1 … `lines` (unit RMS), after `warmup`
    /// periods that are simulated and dropped, with white output noise of standard
    /// deviation `sigma` (seeded by `seed`).
    #[allow(clippy::too_many_arguments)]
    pub fn simulate(
        a0: f64,
        slope: f64,
        n: usize,
        periods: usize,
        lines: usize,
        sigma: f64,
        seed: u64,
        warmup: usize,
    ) -> Self {
        let ode = TimeVaryingOde::from_polynomials(
            vec![vec![a0, slope], vec![0.4], vec![1.0]],
            vec![vec![4.0]],
        )
        .unwrap();
        let m = n / periods;
        let period = m as f64 * TS;
        let df = 1.0 / period;
        let u = Multisine::new(
            period,
            [df, lines as f64 * df],
            1.0 / TS,
            LineSelection::All,
            seed,
        )
        .unwrap();
        let skip = warmup * m;
        let clean = ode
            .simulate_record(&u, TS, n + skip, &[0.0, 0.0], &DormandPrince::new())
            .unwrap();
        let mut noise = Noise::new(seed ^ 0x5eed);
        let y: Vec<f64> = clean.y()[skip..]
            .iter()
            .map(|v| v + sigma * noise.gauss())
            .collect();
        Self {
            data: TimeData::new(clean.u()[skip..].to_vec(), y, TS).unwrap(),
            a0,
            slope,
            offset: skip as f64 * TS,
        }
    }

    /// The true frozen pole with positive imaginary part at t (s from the first kept
    /// sample).
    pub fn pole(&self, t: f64) -> Complex<f64> {
        let a = self.a0 + self.slope * (t + self.offset);
        Complex::new(-0.2, (a - 0.04).sqrt())
    }

    /// The `t,u,y` CSV, the time column starting at `t0`.
    pub fn csv(&self, t0: f64) -> String {
        let mut s = String::from("# simulated time-varying record\nt,u,y\n");
        for (k, (u, y)) in self.data.u().iter().zip(self.data.y()).enumerate() {
            s.push_str(&format!("{},{u:e},{y:e}\n", t0 + k as f64 * TS));
        }
        s
    }
}

/// The worst relative error of the upper frozen pole over the instants of `poles`.
fn worst_pole_error(rec: &LtvRecord, instants: &[f64], poles: &[Vec<Complex<f64>>]) -> f64 {
    instants
        .iter()
        .zip(poles)
        .map(|(t, p)| {
            assert_eq!(p.len(), 2, "t = {t}: {p:?}");
            let truth = rec.pole(*t);
            (p[1] - truth).norm() / truth.norm()
        })
        .fold(0.0, f64::max)
}

/// The CT spec fitted on the DFT lines 1 … 100 of a one-period record (the LTI fit the
/// workflow would start from), then [`time_varying_ode`] on the record.
fn ltv_of(rec: &LtvRecord) -> fdid::workflow::LtvStep {
    let all = rec.data.dft();
    let keep: Vec<bool> = (0..all.len()).map(|k| (1..=100).contains(&k)).collect();
    let data = all.select_lines(&keep).unwrap();
    let fit = fit_spec(&ModelSpec::continuous(2, 0), &data).unwrap();
    time_varying_ode(&fit, &rec.data, 0.01).unwrap().unwrap()
}

/// A drifting system (a₀ from 3 to 5 over the record, 40 dB output SNR): the F tests
/// choose N_p = 1 (the true order), the gap V(0) → V(1) shrinks by more than 100×, and the
/// frozen poles at the 11 instants are within 0.5 % of the truth (the pole moves 26 %
/// over the record).
#[test]
fn drifting_system_chooses_linear_coefficients() {
    let rec = LtvRecord::simulate(3.0, 2.0 / 102.4, 1024, 1, 100, 0.01, 21, 0);
    let step = ltv_of(&rec);
    let costs: Vec<(usize, f64, Option<f64>)> = step
        .candidates
        .iter()
        .map(|c| (c.n_p, c.cost, c.p_value))
        .collect();
    println!("candidates {costs:?}, chosen {}", step.n_p);
    assert_eq!(step.n_p, 1);
    assert_eq!(step.cost_before, step.candidates[0].cost);
    assert_eq!(step.cost_after, step.candidates[1].cost);
    assert!(step.cost_after < 0.01 * step.cost_before);
    assert_eq!(step.instants.len(), 11);
    assert_eq!(step.instants[0], 0.0);
    assert!((step.instants[10] - 1023.0 * TS).abs() < 1e-9);
    let worst = worst_pole_error(&rec, &step.instants, &step.poles);
    println!("worst relative frozen-pole error {worst:.2e}");
    assert!(worst < 5e-3, "{worst:.2e}");
}

/// A time-invariant system: the F test of N_p = 1 against 0 does not reject, N_p = 0 is
/// kept, and the frozen poles are the true ones at every instant.
#[test]
fn time_invariant_system_keeps_constant_coefficients() {
    let rec = LtvRecord::simulate(4.0, 0.0, 1024, 1, 100, 0.01, 22, 0);
    let step = ltv_of(&rec);
    let costs: Vec<(usize, f64, Option<f64>)> = step
        .candidates
        .iter()
        .map(|c| (c.n_p, c.cost, c.p_value))
        .collect();
    println!("candidates {costs:?}, chosen {}", step.n_p);
    assert_eq!(step.n_p, 0);
    assert_eq!(step.cost_before, step.cost_after);
    let worst = worst_pole_error(&rec, &step.instants, &step.poles);
    println!("worst relative frozen-pole error {worst:.2e}");
    assert!(worst < 5e-3, "{worst:.2e}");
}

/// `fdid diagnose --domain s` on a periodic record (8 periods after one warm-up period).
#[cfg(feature = "cli")]
mod diagnose {
    use super::LtvRecord;
    use crate::cli_common as cli;
    use cli::{Scratch, json, run, stdout_ok};

    /// The band keeps the excited range: the sampled multisine's DFT is not exactly zero
    /// between the excited lines (rounding), so without it every line up to Nyquist is
    /// fitted, where the equation noise (output noise times |A(jω)|) hides the time
    /// variation's null space: there N_p = 1 lowers V 5× (F p = 0) but its two smallest
    /// singular values are within the factor 3 and N_p = 0 is kept.
    const ARGS: [&str; 10] = [
        "--domain",
        "s",
        "--na",
        "2",
        "--nb",
        "0",
        "--periods",
        "8",
        "--band",
        ":1",
    ];

    /// 8 periods of 256 samples, lines 1 … 25 of the period (up to 0.98 Hz), 60 dB SNR.
    fn record(slope: f64, seed: u64) -> LtvRecord {
        LtvRecord::simulate(3.0, slope, 2048, 8, 25, 0.001, seed, 1)
    }

    /// A drifting system (a₀ from 3.1 to 5.1 over the record): `time_variation` named, the
    /// time-varying ODE's gap shrinks (N_p ≥ 1 by the F test, V(N_p) < V(0)), and the frozen
    /// poles at the 11 instants (first to last sample) are in the JSON and the text,
    /// within 2 % of the truth.
    #[test]
    fn drifting_system_shows_the_gap_shrink() {
        let dir = Scratch::new("diagnose-ltv");
        let rec = record(2.0 / 204.8, 31);
        let path = dir.file("record.csv", &rec.csv(0.0));
        let v = json("diagnose", &path, &ARGS);
        let effects: Vec<&str> = v["effects"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e.as_str().unwrap())
            .collect();
        println!("effects {effects:?}");
        assert!(effects.contains(&"time_variation"), "{effects:?}");
        let ode = &v["time_varying_ode"];
        println!("{}", serde_json::to_string(&ode["candidates"]).unwrap());
        let n_p = ode["n_p"].as_u64().unwrap();
        let (before, after) = (
            ode["cost_before"].as_f64().unwrap(),
            ode["cost_after"].as_f64().unwrap(),
        );
        println!("N_p {n_p}: V {before:.3e} -> {after:.3e}");
        assert!(n_p >= 1);
        assert!(after < before, "{before} -> {after}");
        let inst = ode["instantaneous"].as_array().unwrap();
        assert_eq!(inst.len(), 11);
        let last = 2047.0 * super::TS;
        let mut worst: f64 = 0.0;
        for (i, x) in inst.iter().enumerate() {
            let t = x["t"].as_f64().unwrap();
            assert!((t - last * i as f64 / 10.0).abs() < 1e-9, "{t}");
            let poles = x["poles"].as_array().unwrap();
            assert_eq!(poles.len(), 2);
            let upper = poles
                .iter()
                .map(|p| fdid::Complex::new(p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
                .max_by(|a, b| a.im.total_cmp(&b.im))
                .unwrap();
            let truth = rec.pole(t);
            worst = worst.max((upper - truth).norm() / truth.norm());
        }
        println!("worst relative frozen-pole error {worst:.2e}");
        assert!(worst < 2e-2, "{worst:.2e}");
        let text = stdout_ok(&run("diagnose", &path, &ARGS));
        println!("{text}");
        assert!(
            text.contains("time-varying ODE (Lataire-Pintelon"),
            "{text}"
        );
        assert!(text.contains("<- chosen"), "{text}");
        assert!(text.contains("gap          V "), "{text}");
        assert!(!text.contains("not confirmed"), "{text}");
        let instants = text
            .lines()
            .filter(|l| l.trim_start().starts_with("t = "))
            .count();
        assert_eq!(instants, 11, "{text}");
    }

    /// A time-invariant system: no time variation named, no time-varying ODE.
    #[test]
    fn time_invariant_system_has_no_time_varying_ode() {
        let dir = Scratch::new("diagnose-lti");
        let rec = record(0.0, 32);
        let path = dir.file("record.csv", &rec.csv(0.0));
        let v = json("diagnose", &path, &ARGS);
        let effects = v["effects"].as_array().unwrap();
        println!("effects {effects:?}");
        assert!(
            !effects.iter().any(|e| e == "time_variation"),
            "{effects:?}"
        );
        assert!(v["time_varying_ode"].is_null());
        let text = stdout_ok(&run("diagnose", &path, &ARGS));
        assert!(!text.contains("time-varying ODE"), "{text}");
    }
}
