//! Stage timings of the standard chain on the order-10 case (b_ct10, 20 000 lines) and on
//! a_ct4 against the number of lines: `cargo run --release --example stage_timings`
//! (`PROBE=full`, `PROBE=ct4` (`LINES` lines) or `PROBE=fitnew` repeat one part for a profiler, `REPS` times, `PROBE=dft` times the
//! DFT of 10⁷ samples).
#[path = "../tests/common/mod.rs"]
mod common;
use common::{Noise, a_ct4, b_ct10, noisy_frf, rel_rms};
use fdid::criterion::NoiseWeighting;
use fdid::estimate::estimate;
use fdid::solver::{GramLevenbergMarquardt, LevenbergMarquardt};
use fdid::{Fit, MaximumLikelihood, Pipeline, Rational};
use std::time::Instant;

fn best<R>(n: usize, mut f: impl FnMut() -> R) -> (f64, R) {
    let mut out = f();
    let mut t = f64::INFINITY;
    for _ in 0..n {
        let s = Instant::now();
        out = f();
        t = t.min(s.elapsed().as_secs_f64() * 1e3);
    }
    (t, out)
}

/// Repetitions of a probe: `REPS`, else `default`.
fn reps(default: usize) -> usize {
    std::env::var("REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn main() {
    if std::env::var("PROBE").as_deref() == Ok("dft") {
        let n = 10_000_000usize;
        let mut noise = Noise::new(3);
        let u: Vec<f64> = (0..n).map(|_| noise.gauss()).collect();
        let y: Vec<f64> = u.iter().map(|v| 0.5 * v + 0.01 * noise.gauss()).collect();
        let rec = fdid::TimeData::new(u, y, 1e-3).unwrap();
        let (t, f) = best(3, || rec.dft());
        println!("dft 1e7: {t:.1} ms ({} lines)", f.len());
        return;
    }
    if std::env::var("PROBE").as_deref() == Ok("ct4") {
        // `LINES` lines (default 2 000), e.g. LINES=200000 for the lines-scaling case
        let lines = std::env::var("LINES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(2_000);
        let (data, _) = noisy_frf(&a_ct4(), lines, 11);
        let model = Rational::continuous(4, 3, data.omega()).unwrap();
        for _ in 0..reps(2000) {
            Pipeline::default().fit(&model, &data).unwrap();
        }
        return;
    }
    let (data, g0) = noisy_frf(&b_ct10(), 20_000, 7);
    let start = Rational::continuous(10, 9, data.omega()).unwrap();
    let fit = Pipeline::default().fit(&start, &data).unwrap();
    let mth = fit.theta().to_vec();
    let fm = fit.model().clone();
    match std::env::var("PROBE").as_deref() {
        Ok("fitnew") => {
            for _ in 0..40 {
                Fit::new(fm.clone(), &data, mth.clone(), NoiseWeighting::Auto, vec![]).unwrap();
            }
            return;
        }
        Ok("full") => {
            for _ in 0..reps(20) {
                Pipeline::default().fit(&start, &data).unwrap();
            }
            return;
        }
        _ => {}
    }
    let (t, fit) = best(5, || Pipeline::default().fit(&start, &data).unwrap());
    let st: Vec<String> = fit
        .stages()
        .iter()
        .map(|s| format!("{} {}", s.kind, s.solution.iterations))
        .collect();
    println!(
        "full ct10: {t:.2} ms cost {:.6} rel_rms {:.4e} {st:?}",
        fit.cost(),
        rel_rms(fit.response(), &g0)
    );
    let (t, _) = best(5, || Pipeline::levy().fit(&start, &data).unwrap());
    println!("levy (QR)+Fit: {t:.2} ms");
    let (t, sk) = best(5, || Pipeline::sk().fit(&start, &data).unwrap());
    println!("levy+sk (QR)+Fit: {t:.2} ms");
    let model = sk.model().clone();
    let th = sk.theta().to_vec();
    let ml = MaximumLikelihood::default();
    let (t, s) = best(5, || {
        estimate(
            &model,
            &data,
            &ml,
            &LevenbergMarquardt::default(),
            Some(&th),
        )
        .unwrap()
    });
    println!("ml crate: {t:.2} ms cost {:.6} it {}", s.cost, s.iterations);
    let (t, s) = best(5, || {
        estimate(
            &model,
            &data,
            &ml,
            &GramLevenbergMarquardt::default(),
            Some(&th),
        )
    });
    println!(
        "ml gram: {t:.2} ms {:?}",
        s.as_ref().map(|s| (s.cost, s.iterations))
    );
    let (t, _) = best(5, || {
        Fit::new(fm.clone(), &data, mth.clone(), NoiseWeighting::Auto, vec![]).unwrap()
    });
    println!("Fit::new: {t:.2} ms");
    for n in [2_000usize, 20_000, 200_000] {
        let (data, g0) = noisy_frf(&a_ct4(), n, 11);
        let model = Rational::continuous(4, 3, data.omega()).unwrap();
        let (t, fit) = best(3, || Pipeline::default().fit(&model, &data).unwrap());
        let st: Vec<String> = fit
            .stages()
            .iter()
            .map(|s| format!("{} {}", s.kind, s.solution.iterations))
            .collect();
        println!(
            "lines_ct4/{n}: {t:.2} ms cost {:.6} rel_rms {:.4e} {st:?}",
            fit.cost(),
            rel_rms(fit.response(), &g0)
        );
    }
}
