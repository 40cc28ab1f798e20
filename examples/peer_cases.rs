//! Fits the peers' shared cases with fdid, timing the fit alone as the peers' harness does
//! (median of 5 runs after a warm-up), and writes one JSON per case with the fitted
//! response on the case's grid and the poles, for `bench/score_fdid.py` to score with the
//! harness's own `score()`. Driven by `bench/compare.sh`.
//!
//! Run: `cargo run --release --example peer_cases -- CASES_DIR OUT_DIR` (`PEER_CASE=NAME`:
//! that case only; `PEER_REPS=K`: K timed runs instead of 5).

use fdid::prelude::*;
use serde_json::{Value, json};
use std::path::Path;
use std::time::Instant;

fn read_rows(path: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            l.split(',')
                .map(|v| v.trim().parse::<f64>().expect("number"))
                .collect()
        })
        .collect()
}

/// The case's data as fdid sees them (delay removed as the peers get it).
fn case_data(dir: &Path, name: &str, meta: &Value) -> FrequencyData<f64> {
    let rows = read_rows(&dir.join(format!("{name}.csv")));
    let ts = (meta["domain"] == "dt").then_some(1.0);
    if meta["kind"] == "frf" {
        let delay = meta["delay_samples"].as_f64().unwrap_or(0.0);
        let omega: Vec<f64> = rows.iter().map(|r| r[0]).collect();
        let g: Vec<Complex<f64>> = rows
            .iter()
            .map(|r| Complex::new(r[1], r[2]) * Complex::new(0.0, r[0] * delay).exp())
            .collect();
        FrequencyData::from_frf(omega, g, ts).expect("frf data")
    } else {
        let u = rows.iter().map(|r| r[1]).collect();
        let y = rows.iter().map(|r| r[2]).collect();
        let periods = meta["P"].as_u64().expect("P") as usize;
        let n = meta["N"].as_u64().expect("N") as f64;
        let (k0, k1) = (
            meta["excited_lines"][0].as_f64().expect("lines"),
            meta["excited_lines"][1].as_f64().expect("lines"),
        );
        let avg = TimeData::new(u, y, 1.0)
            .and_then(|t| t.average_periods(periods))
            .expect("time data");
        let two_pi = 2.0 * std::f64::consts::PI;
        avg.band(two_pi * (k0 - 0.5) / n, two_pi * (k1 + 0.5) / n)
            .expect("band")
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (cases, out) = (Path::new(&args[1]), Path::new(&args[2]));
    std::fs::create_dir_all(out).expect("output dir");
    let mut names: Vec<String> = std::fs::read_dir(cases)
        .expect("cases dir")
        .filter_map(|e| {
            let n = e.ok()?.file_name().into_string().ok()?;
            n.strip_suffix(".json").map(str::to_string)
        })
        .collect();
    names.sort();
    // `PEER_CASE=NAME` fits only that case (e.g. for a profiler), `PEER_REPS` times
    if let Ok(only) = std::env::var("PEER_CASE") {
        names.retain(|n| *n == only);
    }
    let reps: usize = std::env::var("PEER_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5);
    for name in names {
        let meta: Value = serde_json::from_str(
            &std::fs::read_to_string(cases.join(format!("{name}.json"))).expect("meta"),
        )
        .expect("json");
        let data = case_data(cases, &name, &meta);
        let (na, nb) = (
            meta["na"].as_u64().expect("na") as usize,
            meta["nb"].as_u64().expect("nb") as usize,
        );
        let model = if meta["domain"] == "ct" {
            Rational::continuous(na, nb, data.omega()).expect("model")
        } else {
            Rational::discrete(na, nb, 1.0).expect("model")
        };
        let pipeline = Pipeline::default();
        let mut fit = pipeline.fit(&model, &data).expect("fit"); // warm-up
        let mut times = vec![];
        for _ in 0..reps.max(1) {
            let t = Instant::now();
            fit = pipeline.fit(&model, &data).expect("fit");
            times.push(t.elapsed().as_secs_f64());
        }
        let mut sorted = times.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        let frf: Vec<[f64; 2]> = fit.response().iter().map(|g| [g.re, g.im]).collect();
        let poles: Vec<[f64; 2]> = fit
            .poles()
            .expect("poles")
            .iter()
            .map(|p| [p.re, p.im])
            .collect();
        let stages: Vec<Value> = fit
            .stages()
            .iter()
            .map(|s| json!({"name": s.kind.name(), "iterations": s.solution.iterations}))
            .collect();
        let doc = json!({
            "time_s": median, "times_s": times, "omega": data.omega(),
            "frf": frf, "poles": poles, "stages": stages,
        });
        std::fs::write(out.join(format!("{name}.json")), doc.to_string()).expect("write");
        eprintln!("{name}: {:.2} ms", 1e3 * median);
    }
}
