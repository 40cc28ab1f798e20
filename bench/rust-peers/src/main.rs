//! Fits the peers' benchmark cases (written by the harness's `make_cases.py`) with the Rust
//! crates `dsmc` (Levy, Sanathanan–Koerner, vector fitting, SML) and `vecfit` (relaxed vector
//! fitting), times the fits and writes the fitted models evaluated on each case's grid, for
//! `bench/score_rs.py` to score with the harness's own `score()`.
//!
//! ```text
//! PEERS_WORK=$HOME/fdid-peers cargo run --release     # reads $PEERS_WORK/cases, writes $PEERS_WORK/out-rs
//! ```
//!
//! Every method is given the true orders `na`, `nb` of the case, as in the harness. The data are
//! prepared as the harness's `load_case` does:
//!
//! * a known delay (case c) is removed from the data, `G_c = G e^{jωτ}`, before the fit; the
//!   scorer puts it back;
//! * periodic time data (case d) become the averaged FRF at the excited lines,
//!   `Ĝ(k) = Ȳ(k) / Ū(k)` over the `P` periods, with the weight `w_k = 1 / σ̂_k`,
//!   `σ̂_k² = s²_Y(k) / (P |Ū(k)|²)` (`s²_Y` the sample variance over the periods).
//!
//! `dsmc`'s frequency-domain fits and `vecfit` are continuous-time: a discrete-time case is fitted
//! in the bilinear variable `s' = j tan(ω/2)` (`z = (1 + s') / (1 - s')`, exact for a rational
//! `G(z)` of degree `na`, which becomes a proper rational in `s'` of degree `na`), as the
//! harness does for scikit-rf, and the poles are mapped back by `z = (1 + p) / (1 - p)`.
//!
//! Time: median of 5 runs after one warm-up, fit only (from the prepared arrays to the fitted
//! model and its poles; reading the files and evaluating the model on the grid excluded), one
//! thread (`faer`, the linear algebra under `vecfit`, is set to sequential).

use std::f64::consts::PI;
use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use dsmc::system_identification::frequency_response::levy::{self, SanathananKoernerOptions};
use dsmc::system_identification::frequency_response::sml::{self, SmlData, SmlOptions};
use dsmc::system_identification::frequency_response::vector_fitting::{
    self, VectorFittingOptions, VectorFittingResult,
};
use dsmc::{FrequencyResponse, Polynomial, TransferFunction};
use num_complex::Complex64 as C;
use rustfft::FftPlanner;
use serde_json::{Value, json};

const N_RUNS: usize = 5;

/// One case, prepared as the harness's `load_case`.
struct Case {
    name: String,
    ct: bool,
    na: usize,
    nb: usize,
    /// Angular frequency of the lines (rad/s, or rad/sample for DT).
    omega: Vec<f64>,
    /// Data with the known delay removed.
    gc: Vec<C>,
    /// Per-line weights (`None`: all ones).
    w: Option<Vec<f64>>,
    /// Periodic time data only: the per-period spectra at the excited lines for the SML fit
    /// (prepared outside the timing, as the averaged FRF of the other methods), or why
    /// `dsmc` rejects them.
    sml: Option<Result<SmlData<f64>, String>>,
}

impl Case {
    /// The continuous-time variable of each line: `jω` (CT) or `j tan(ω/2)` (DT, bilinear).
    fn s_axis(&self, omega: &[f64]) -> Vec<C> {
        omega
            .iter()
            .map(|&w| C::new(0.0, if self.ct { w } else { (w / 2.0).tan() }))
            .collect()
    }

    /// The (warped) frequency of each line in rad/s, as `dsmc` takes it.
    fn samples(&self) -> Vec<FrequencyResponse<f64>> {
        self.s_axis(&self.omega)
            .iter()
            .zip(&self.gc)
            .map(|(s, g)| FrequencyResponse {
                omega: s.im,
                value: *g,
            })
            .collect()
    }

    /// Poles in `s` (CT) or mapped back to `z` (DT).
    fn map_poles(&self, p: &[C]) -> Vec<C> {
        if self.ct {
            p.to_vec()
        } else {
            p.iter().map(|p| (1.0 + p) / (1.0 - p)).collect()
        }
    }

    /// Numerator degree of the fit in the CT variable: `nb` for CT, `na` for the bilinear
    /// image of a DT model.
    fn nb_s(&self) -> usize {
        if self.ct { self.nb } else { self.na }
    }
}

/// A fitted model: its poles (s- or z-plane) and its FRF on the case's grid.
struct Fitted {
    poles: Vec<C>,
    eval: Box<dyn Fn(&[f64]) -> Vec<C>>,
    info: Value,
}

fn read_csv(path: &Path) -> Vec<Vec<f64>> {
    let text = fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            l.split(',')
                .map(|v| v.trim().parse::<f64>().expect("a number"))
                .collect()
        })
        .collect()
}

fn load_case(dir: &Path, name: &str) -> Case {
    let meta: Value =
        serde_json::from_str(&fs::read_to_string(dir.join(format!("{name}.json"))).unwrap())
            .unwrap();
    let rows = read_csv(&dir.join(format!("{name}.csv")));
    let ct = meta["domain"] == "ct";
    let na = meta["na"].as_u64().unwrap() as usize;
    let nb = meta["nb"].as_u64().unwrap() as usize;
    let delay = meta["delay_samples"].as_f64().unwrap_or(0.0);
    if meta["kind"] == "frf" {
        let omega: Vec<f64> = rows.iter().map(|r| r[0]).collect();
        let gc = rows
            .iter()
            .map(|r| C::new(r[1], r[2]) * C::new(0.0, r[0] * delay).exp())
            .collect();
        Case {
            name: name.into(),
            ct,
            na,
            nb,
            omega,
            gc,
            w: None,
            sml: None,
        }
    } else {
        let n = meta["N"].as_u64().unwrap() as usize;
        let p = meta["P"].as_u64().unwrap() as usize;
        let (k0, k1) = (
            meta["excited_lines"][0].as_u64().unwrap() as usize,
            meta["excited_lines"][1].as_u64().unwrap() as usize,
        );
        let lines: Vec<usize> = (k0..=k1).collect();
        let u: Vec<f64> = rows.iter().map(|r| r[1]).collect();
        let y: Vec<f64> = rows.iter().map(|r| r[2]).collect();
        let fft = FftPlanner::<f64>::new().plan_fft_forward(n);
        let spectra = |x: &[f64]| -> Vec<Vec<C>> {
            (0..p)
                .map(|m| {
                    let mut buf: Vec<C> = x[m * n..(m + 1) * n]
                        .iter()
                        .map(|&v| C::new(v, 0.0))
                        .collect();
                    fft.process(&mut buf);
                    lines.iter().map(|&k| buf[k]).collect()
                })
                .collect()
        };
        let (us, ys) = (spectra(&u), spectra(&y));
        let mean = |s: &[Vec<C>], i: usize| s.iter().map(|v| v[i]).sum::<C>() / p as f64;
        let mut omega = Vec::new();
        let mut gc = Vec::new();
        let mut w = Vec::new();
        for (i, &k) in lines.iter().enumerate() {
            let (um, ym) = (mean(&us, i), mean(&ys, i));
            let var_y = ys.iter().map(|v| (v[i] - ym).norm_sqr()).sum::<f64>() / (p - 1) as f64;
            let var_g = var_y / p as f64 / um.norm_sqr();
            omega.push(2.0 * PI * k as f64 / n as f64);
            gc.push(ym / um);
            w.push(1.0 / var_g.sqrt());
        }
        Case {
            name: name.into(),
            ct,
            na,
            nb,
            omega,
            gc,
            w: Some(w),
            sml: Some(SmlData::from_periods(&u, &y, 1.0, n, &lines).map_err(|e| e.to_string())),
        }
    }
}

/// Horner evaluation of a descending real polynomial at `x`.
fn horner(c: &[f64], x: C) -> C {
    c.iter().fold(C::new(0.0, 0.0), |acc, &v| acc * x + v)
}

fn roots(c: &Polynomial<f64>) -> Vec<C> {
    dsmc::dka_method(&Polynomial(c.0.iter().map(|&v| C::new(v, 0.0)).collect())).unwrap_or_default()
}

/// A CT transfer function of `dsmc` (in `s`, or in the bilinear `s'` for DT).
fn from_tf(case: &Case, tf: TransferFunction<f64>, info: Value) -> Fitted {
    let poles = case.map_poles(&roots(&tf.denominator));
    let (b, a) = (tf.numerator.0.clone(), tf.denominator.0.clone());
    let ct = case.ct;
    let eval = Box::new(move |omega: &[f64]| {
        omega
            .iter()
            .map(|&w| {
                let s = C::new(0.0, if ct { w } else { (w / 2.0).tan() });
                horner(&b, s) / horner(&a, s)
            })
            .collect()
    });
    Fitted { poles, eval, info }
}

fn fit_dsmc_levy(case: &Case) -> Result<Fitted, String> {
    let samples = case.samples();
    let tf = match &case.w {
        None => levy::identify(&samples, case.na, case.nb_s()).map_err(|e| e.to_string())?,
        Some(w) => {
            let opts = SanathananKoernerOptions {
                max_iter: 1,
                ..Default::default()
            };
            levy::sanathanan_koerner_weighted(&samples, w, case.na, case.nb_s(), &opts)
                .map_err(|e| e.to_string())?
                .into()
        }
    };
    Ok(from_tf(case, tf, json!({})))
}

fn fit_dsmc_sk(case: &Case) -> Result<Fitted, String> {
    let samples = case.samples();
    let opts = SanathananKoernerOptions::default();
    let r = match &case.w {
        None => levy::sanathanan_koerner_identification(&samples, case.na, case.nb_s(), &opts),
        Some(w) => levy::sanathanan_koerner_weighted(&samples, w, case.na, case.nb_s(), &opts),
    }
    .map_err(|e| e.to_string())?;
    let info = json!({"iterations": r.iterations, "converged": r.converged});
    Ok(from_tf(case, r.transfer_function, info))
}

fn fit_dsmc_vf(case: &Case) -> Result<Fitted, String> {
    let samples = case.samples();
    // a constant term unless the CT model is strictly proper (as the harness's scikit-rf VF)
    let opts = VectorFittingOptions {
        fit_d: !(case.ct && case.nb < case.na),
        ..Default::default()
    };
    let r: VectorFittingResult<f64> = match &case.w {
        None => vector_fitting::identify(&samples, case.na, &opts),
        Some(w) => vector_fitting::identify_weighted(&samples, w, case.na, &opts),
    }
    .map_err(|e| e.to_string())?;
    let poles = case.map_poles(&r.poles);
    let info = json!({"iterations": r.rms_errors.len()});
    let ct = case.ct;
    let eval = Box::new(move |omega: &[f64]| {
        omega
            .iter()
            .map(|&w| {
                let s = C::new(0.0, if ct { w } else { (w / 2.0).tan() });
                r.poles
                    .iter()
                    .zip(&r.residues)
                    .map(|(p, c)| c / (s - p))
                    .sum::<C>()
                    + r.d
                    + s * r.e
            })
            .collect()
    });
    Ok(Fitted { poles, eval, info })
}

/// Periodic time data only: `dsmc`'s SML of `B(z^-1) / A(z^-1)` (orders `na`, `nb`, no extra
/// input delay) from the per-period spectra at the excited lines.
fn fit_dsmc_sml(case: &Case) -> Result<Fitted, String> {
    let data = case
        .sml
        .as_ref()
        .ok_or("SML needs periodic time data")?
        .as_ref()?;
    let r = sml::identify_discrete(data, 1.0, case.na, case.nb, 0, &SmlOptions::default())
        .map_err(|e| e.to_string())?;
    let poles = roots(&r.model.denominator);
    let (b, a) = (r.model.numerator.0.clone(), r.model.denominator.0.clone());
    let info = json!({"iterations": r.iterations, "termination": format!("{:?}", r.termination)});
    let eval = Box::new(move |omega: &[f64]| {
        omega
            .iter()
            .map(|&w| {
                let z = C::new(0.0, w).exp();
                horner(&b, z) / horner(&a, z)
            })
            .collect()
    });
    Ok(Fitted { poles, eval, info })
}

/// `vecfit`'s relaxed vector fitting with its default options (restarts, tolerance), `na` poles;
/// `mirror` also feeds the conjugate data at `conj(s)`.
fn fit_vecfit(case: &Case, mirror: bool) -> Result<Fitted, String> {
    let mut s = case.s_axis(&case.omega);
    let mut g = case.gc.clone();
    let mut w = case.w.clone();
    if mirror {
        s.extend(s.clone().iter().map(|v| v.conj()));
        g.extend(g.clone().iter().map(|v| v.conj()));
        if let Some(w) = w.as_mut() {
            w.extend(w.clone());
        }
    }
    let mut opts = vecfit::Options::new()
        .poles(case.na)
        .fit_constant(!(case.ct && case.nb < case.na));
    if let Some(w) = w {
        opts = opts.weights(w);
    }
    let model = vecfit::Model::fit_samples(vecfit::complex(&s), &g, vecfit::Shape::scalar(), opts)
        .map_err(|e| e.to_string())?;
    let poles = case.map_poles(model.poles());
    let r = model.report();
    let info = json!({"iterations": r.iterations, "converged": r.converged});
    let ct = case.ct;
    let eval = Box::new(move |omega: &[f64]| {
        let s: Vec<C> = omega
            .iter()
            .map(|&w| C::new(0.0, if ct { w } else { (w / 2.0).tan() }))
            .collect();
        model.eval_scalar(&s).expect("evaluation of a fitted model")
    });
    Ok(Fitted { poles, eval, info })
}

type Method = fn(&Case) -> Result<Fitted, String>;

fn methods() -> Vec<(&'static str, Method)> {
    vec![
        ("dsmc_levy", fit_dsmc_levy),
        ("dsmc_sk", fit_dsmc_sk),
        ("dsmc_vf", fit_dsmc_vf),
        ("dsmc_sml", fit_dsmc_sml),
        ("vecfit", |c| fit_vecfit(c, false)),
        ("vecfit_mirror", |c| fit_vecfit(c, true)),
    ]
}

fn pairs(v: &[C]) -> Value {
    Value::Array(v.iter().map(|c| json!([c.re, c.im])).collect())
}

fn run_one(case: &Case, f: Method) -> Value {
    if let Err(e) = f(case) {
        return json!({"error": e});
    }
    let mut times = Vec::with_capacity(N_RUNS);
    let mut last = None;
    for _ in 0..N_RUNS {
        let t0 = Instant::now();
        let fit = f(case);
        times.push(t0.elapsed().as_secs_f64());
        last = Some(fit);
    }
    let fit = match last.expect("N_RUNS > 0") {
        Ok(fit) => fit,
        Err(e) => return json!({"error": e}),
    };
    let mut sorted = times.clone();
    sorted.sort_by(f64::total_cmp);
    json!({
        "poles": pairs(&fit.poles),
        "frf": pairs(&(fit.eval)(&case.omega)),
        "time_s": sorted[N_RUNS / 2],
        "times_s": times,
        "info": fit.info,
    })
}

fn main() {
    faer::set_global_parallelism(faer::Par::Seq);
    let work = std::env::var("PEERS_WORK")
        .map(PathBuf::from)
        .unwrap_or_else(|_| {
            PathBuf::from(std::env::var("HOME").expect("HOME or PEERS_WORK")).join("fdid-peers")
        });
    let cases = work.join("cases");
    let out = work.join("out-rs");
    fs::create_dir_all(&out).expect("output directory");
    let only: Vec<String> = std::env::args().skip(1).collect();
    let mut names: Vec<String> = fs::read_dir(&cases)
        .unwrap_or_else(|e| panic!("{}: {e}", cases.display()))
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter_map(|f| f.strip_suffix(".json").map(str::to_owned))
        .filter(|n| only.is_empty() || only.contains(n))
        .collect();
    names.sort();
    for name in names {
        let case = load_case(&cases, &name);
        let mut res = serde_json::Map::new();
        for (m, f) in methods() {
            let r = if m == "dsmc_sml" && case.sml.is_none() {
                json!({"skipped": "SML needs periodic time data"})
            } else {
                run_one(&case, f)
            };
            let t = r["time_s"]
                .as_f64()
                .map_or("-".into(), |t| format!("{:.2} ms", 1e3 * t));
            let status = r
                .get("error")
                .or(r.get("skipped"))
                .map_or(String::new(), |v| v.to_string());
            eprintln!("{:12} {:14} {:>10} {}", case.name, m, t, status);
            res.insert(m.into(), r);
        }
        let doc = json!({"omega": case.omega, "methods": res});
        fs::write(out.join(format!("{name}.json")), doc.to_string()).expect("write results");
    }
}
