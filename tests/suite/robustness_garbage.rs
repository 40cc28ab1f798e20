//! Garbage in, typed error out: random inputs into every public entry point never panic
//! and never hang.
//!
//! Each property draws small random inputs — random bytes and CSV-like text; f64 values
//! that are often NaN, ±∞, ±0, huge, tiny (subnormal), duplicated or out of order; orders
//! from 0 to `usize::MAX`; sample times ≤ 0; bands outside Nyquist — and runs the entry
//! points on them in a guarded thread: a panic (caught with `catch_unwind`) or a run
//! longer than [`TIMEOUT`] fails the property with the input. Results are not checked:
//! `Ok` and any `Err` are both fine here (tests/robustness_input.rs checks the variants).
//!
//! `QUICKCHECK_TESTS=N` sets the number of cases of every property (the defaults keep the
//! file at a few seconds); e.g. `QUICKCHECK_TESTS=100000 cargo test --release
//! --all-features --test suite robustness_garbage::` for a long run.

use fdid::data::{PeriodicAverage, merge};
use fdid::estimate::Method;
use fdid::estimate::ModalOptions;
use fdid::io::parse_csv;
use fdid::ltv::{FrequencyBasis, Lines};
use fdid::model::remove_delay;
use fdid::prelude::*;
use fdid::workflow::{Context, ModelSpec, Workflow, fit_spec};
use quickcheck::{Arbitrary, Gen, TestResult};
use std::fmt::Debug;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::mpsc;
use std::time::Duration;

/// Longest time one entry point may take on one garbage input: a hang never returns, so
/// the limit sits far above the time of any garbage input, clear of the slowdown of a
/// loaded machine.
const TIMEOUT: Duration = Duration::from_secs(120);

/// Cases per property: `QUICKCHECK_TESTS` when set, else `default`.
fn cases(default: u64) -> u64 {
    std::env::var("QUICKCHECK_TESTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

fn run<A: Arbitrary + Debug>(default: u64, prop: fn(A) -> TestResult) {
    crate::common::seeded_sized(24, 0xd6c2a212)
        .tests(cases(default))
        .max_tests(cases(default) * 10)
        .quickcheck(prop);
}

/// Runs `f` on its own thread under `catch_unwind`; a panic or a run longer than
/// [`TIMEOUT`] is returned as a message naming the entry point and the input.
fn guarded<I: Debug>(name: &str, input: &I, f: impl FnOnce() + Send + 'static) -> Option<String> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let r = catch_unwind(AssertUnwindSafe(f));
        let _ = tx.send(r.map_err(|p| {
            p.downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "non-text panic".into())
        }));
    });
    match rx.recv_timeout(TIMEOUT) {
        Ok(Ok(())) => None,
        Ok(Err(msg)) => Some(format!("{name} panicked ({msg}) on {input:?}")),
        Err(_) => Some(format!(
            "{name} did not return within {TIMEOUT:?} on {input:?}"
        )),
    }
}

/// Runs every `(name, f)` guarded; the first failure fails the property.
/// Named entry-point calls.
type Entries = Vec<(&'static str, Box<dyn FnOnce() + Send>)>;

fn all<I: Debug>(input: &I, entries: Entries) -> TestResult {
    for (name, f) in entries {
        if let Some(msg) = guarded(name, input, f) {
            return TestResult::error(msg);
        }
    }
    TestResult::passed()
}

/// A named entry point: clones `$x` into a boxed closure that evaluates `$body`.
macro_rules! entry {
    ($name:expr, $x:ident, $body:expr) => {{
        let $x = $x.clone();
        (
            $name,
            Box::new(move || drop($body)) as Box<dyn FnOnce() + Send>,
        )
    }};
}

// ---------------------------------------------------------------------------------------
// Generators

/// A float that is often pathological.
#[derive(Clone, Copy, Debug)]
struct Bad(f64);

impl Arbitrary for Bad {
    fn arbitrary(g: &mut Gen) -> Self {
        let r = f64::from(u16::arbitrary(g)) / f64::from(u16::MAX);
        Bad(match u8::arbitrary(g) % 20 {
            0 => f64::NAN,
            1 => f64::INFINITY,
            2 => f64::NEG_INFINITY,
            3 => 0.0,
            4 => -0.0,
            5 => 1e308,
            6 => -1e308,
            7 => f64::MAX,
            8 => 1e-308,
            9 => 5e-324,
            10 => -1.0 - 10.0 * r,
            11 => 1e154 * r,
            12 => 1e-154 * r,
            _ => 10.0 * r,
        })
    }
}

/// An order: mostly small, sometimes huge.
#[derive(Clone, Copy, Debug)]
struct Order(usize);

impl Arbitrary for Order {
    fn arbitrary(g: &mut Gen) -> Self {
        Order(match u8::arbitrary(g) % 16 {
            0 => usize::MAX,
            1 => usize::MAX / 2,
            2 => 1 << 40,
            3 => 1000,
            4 => 40,
            k => usize::from(k % 5),
        })
    }
}

/// A frequency grid: sorted and positive, with a duplicate, unsorted, with a bad value,
/// or raw garbage; 0 to ~24 lines.
fn grid(g: &mut Gen, n: usize) -> Vec<f64> {
    let step = |g: &mut Gen| 0.05 + 0.5 * f64::from(u8::arbitrary(g)) / 255.0;
    let mut w = Vec::with_capacity(n);
    let mut acc = if bool::arbitrary(g) { 0.0 } else { step(g) };
    for _ in 0..n {
        w.push(acc);
        acc += step(g);
    }
    match u8::arbitrary(g) % 8 {
        0 => w.iter_mut().for_each(|x| *x = Bad::arbitrary(g).0),
        1 if n >= 2 => {
            let i = usize::arbitrary(g) % (n - 1);
            w[i + 1] = w[i];
        }
        2 if n >= 2 => {
            let i = usize::arbitrary(g) % (n - 1);
            w.swap(i, i + 1);
        }
        3 if n >= 1 => {
            let i = usize::arbitrary(g) % n;
            w[i] = Bad::arbitrary(g).0;
        }
        _ => {}
    }
    w
}

/// Mostly finite values with an occasional pathological one.
fn values(g: &mut Gen, n: usize) -> Vec<f64> {
    (0..n)
        .map(|_| {
            if u8::arbitrary(g) % 6 == 0 {
                Bad::arbitrary(g).0
            } else {
                f64::from(i16::arbitrary(g)) / 4096.0
            }
        })
        .collect()
}

/// Garbage frequency-domain inputs.
#[derive(Clone, Debug)]
struct FreqInput {
    omega: Vec<f64>,
    y: Vec<Complex<f64>>,
    u: Vec<Complex<f64>>,
    var: Option<Vec<f64>>,
    ts: Option<f64>,
    na: usize,
    nb: usize,
    band: (f64, f64),
    tau: f64,
}

fn length(g: &mut Gen) -> usize {
    match u8::arbitrary(g) % 8 {
        0 => 0,
        1 => 1,
        2 => 2,
        _ => usize::arbitrary(g) % 25,
    }
}

impl Arbitrary for FreqInput {
    fn arbitrary(g: &mut Gen) -> Self {
        let n = length(g);
        // lengths occasionally mismatch
        let m = if u8::arbitrary(g) % 10 == 0 {
            length(g)
        } else {
            n
        };
        let omega = grid(g, n);
        let cplx = |g: &mut Gen, k: usize| -> Vec<Complex<f64>> {
            let re = values(g, k);
            let im = values(g, k);
            re.into_iter()
                .zip(im)
                .map(|(r, i)| Complex::new(r, i))
                .collect()
        };
        let y = cplx(g, m);
        let mut u = if bool::arbitrary(g) {
            vec![Complex::new(1.0, 0.0); n]
        } else {
            cplx(g, n)
        };
        if n > 0 && u8::arbitrary(g) % 4 == 0 {
            let i = usize::arbitrary(g) % n;
            u[i] = Complex::new(0.0, 0.0);
        }
        let var = bool::arbitrary(g).then(|| {
            (0..n)
                .map(|_| {
                    let v = Bad::arbitrary(g).0;
                    if u8::arbitrary(g) % 4 == 0 {
                        v
                    } else {
                        v.abs()
                    }
                })
                .collect()
        });
        let ts = match u8::arbitrary(g) % 4 {
            0 => None,
            1 => Some(Bad::arbitrary(g).0),
            _ => Some(0.1 + f64::from(u8::arbitrary(g)) / 64.0),
        };
        Self {
            omega,
            y,
            u,
            var,
            ts,
            na: Order::arbitrary(g).0,
            nb: Order::arbitrary(g).0,
            band: (Bad::arbitrary(g).0, Bad::arbitrary(g).0),
            tau: Bad::arbitrary(g).0 * 0.1,
        }
    }
}

impl FreqInput {
    /// The data, when they pass validation.
    fn data(&self) -> Option<FrequencyData<f64>> {
        let d =
            FrequencyData::new(self.omega.clone(), self.y.clone(), self.u.clone(), self.ts).ok()?;
        match &self.var {
            Some(v) => d.with_noise(NoiseVariances::output_only(v.clone())).ok(),
            None => Some(d),
        }
    }

    /// Small orders for the fits (huge ones go to the constructors).
    fn small(&self) -> (usize, usize) {
        (self.na.min(6), self.nb.min(6))
    }
}

// ---------------------------------------------------------------------------------------
// Frequency data, models and fits

fn frequency_entries(x: FreqInput) -> TestResult {
    let mut e: Entries = vec![
        entry!("FrequencyData::new", x, {
            FrequencyData::new(x.omega, x.y, x.u, x.ts)
        }),
        entry!("FrequencyData::from_frf", x, {
            FrequencyData::from_frf(x.omega, x.y, x.ts)
        }),
        entry!("Rational::continuous", x, {
            Rational::continuous(x.na, x.nb, &x.omega)
        }),
        entry!("Rational::polynomial", x, {
            Rational::polynomial(x.na, x.nb, &x.omega)
        }),
        entry!("Rational::partial_fractions_on", x, {
            Rational::partial_fractions_on(x.na, x.nb, &x.omega)
        }),
        entry!("Rational::discrete", x, {
            Rational::discrete(x.na, x.nb, x.ts.unwrap_or(-1.0))
                .and_then(|m| m.with_sampled_transient(x.band.0))
        }),
        entry!("NoiseModel::new", x, {
            fdid::model::NoiseModel::new(x.na, x.nb, x.ts.unwrap_or(0.0))
        }),
        entry!("Modal::new", x, {
            Modal::continuous(x.na, x.nb, true)
                .and_then(|m| m.with_transient(x.ts.unwrap_or(f64::NAN)))
        }),
        entry!("Delayed::with_bounds", x, {
            let m = Rational::<f64>::discrete(1, 0, 1.0).unwrap();
            Delayed::new(m).with_bounds(x.band.0, x.band.1)
        }),
    ];
    let Some(d) = x.data() else {
        return all(&x, e);
    };
    let (na, nb) = x.small();
    let (lo, hi) = x.band;
    e.push(entry!("FrequencyData::band", d, {
        (d.band(lo, hi), d.band_hz(lo, hi), d.etfe())
    }));
    let keep: Vec<bool> = x.omega.iter().map(|w| *w > lo).collect();
    e.push(entry!("FrequencyData::select_lines", d, {
        (d.select_lines(&keep), d.clone().with_ts(Some(lo)))
    }));
    let tau = x.tau;
    e.push(entry!("remove_delay", d, remove_delay(&d, tau)));
    e.push(entry!("merge", d, merge(&[d.clone(), d.without_noise()])));
    e.push(entry!("Pipeline::fit continuous", d, {
        Rational::continuous(na, nb, d.omega()).and_then(|m| Pipeline::default().fit(&m, &d))
    }));
    e.push(entry!("Pipeline::fit polynomial + transient", d, {
        Rational::polynomial(na, nb, d.omega())
            .and_then(|m| m.with_transient())
            .and_then(|m| Pipeline::default().fit(&m, &d))
    }));
    let ts = x.ts.unwrap_or(1.0);
    e.push(entry!("Pipeline::fit discrete", d, {
        Rational::discrete(na, nb, ts).and_then(|m| Pipeline::default().fit(&m, &d))
    }));
    let (big_a, big_b) = (x.na, x.nb);
    e.push(entry!("Pipeline::fit at any order", d, {
        (
            Rational::discrete(big_a, big_b, ts)
                .and_then(|m| m.with_transient())
                .and_then(|m| Pipeline::default().fit(&m, &d)),
            Rational::continuous(big_a, big_b, d.omega())
                .and_then(|m| Pipeline::default().fit(&m, &d)),
        )
    }));
    e.push(entry!("fit_delayed", d, {
        Rational::discrete(na.min(2), nb.min(2), ts)
            .and_then(|m| fit_delayed(&Pipeline::default(), &m, &d))
    }));
    e.push(entry!("fit_eiv", d, {
        Rational::discrete(na, nb, ts).and_then(|m| fit_eiv(&Pipeline::default(), &m, &d))
    }));
    e.push(entry!("fit_noise_model", d, {
        Rational::discrete(na.min(2), nb.min(2), ts)
            .and_then(|m| fit_noise_model(&Pipeline::default(), &m, &d, na % 3, nb % 3))
    }));
    e.push(entry!("fit_modal", d, {
        fit_modal(
            &Pipeline::default(),
            &d,
            na.min(2),
            nb.min(2),
            ModalOptions::continuous(),
        )
    }));
    let (deg, half) = (x.na, x.nb);
    e.push(entry!("lpm", d, {
        (
            lpm(&d, Lpm::new().with_degree(deg)),
            lpm(&d, Lpm::new().with_degree(deg % 4).with_half_width(half)),
        )
    }));
    all(&x, e)
}

#[test]
fn frequency_data_models_and_fits_never_panic() {
    run(300, frequency_entries);
}

/// The workflow on garbage frequency data and garbage specs (fewer cases: each run fits
/// several models).
fn workflow_entries(x: FreqInput) -> TestResult {
    let Some(data) = x.data() else {
        return TestResult::discard();
    };
    let (na, nb) = (x.na.min(3), x.nb.min(3));
    let ts = x.ts.unwrap_or(x.band.1);
    let spec = ModelSpec {
        domain: if x.na.is_multiple_of(2) {
            Domain::Discrete { ts }
        } else {
            Domain::Continuous
        },
        na,
        nb,
        delay: x.nb.is_multiple_of(3),
        delay_range: Default::default(),
        stability: Default::default(),
        transient: x.na % 3 == 1,
        noise_order: (x.nb % 4 == 1).then_some(1),
        criterion: if x.var.is_some() && x.na % 2 == 1 {
            Method::Eiv
        } else {
            Method::Ml
        },
    };
    let alpha = x.band.0;
    let d = data;
    let s2 = spec.clone();
    let e = vec![
        entry!("fit_spec", d, fit_spec(&s2, &d)),
        entry!("Workflow::run", d, {
            Workflow::default().run(&d, spec.clone(), Context::frequency_data(alpha))
        }),
    ];
    all(&x, e)
}

#[test]
fn workflow_never_panics() {
    run(40, workflow_entries);
}

// ---------------------------------------------------------------------------------------
// Time records, periodic averaging and the time-varying ODE

#[derive(Clone, Debug)]
struct TimeInput {
    u: Vec<f64>,
    y: Vec<f64>,
    ts: f64,
    periods: usize,
    orders: (usize, usize, usize),
    band: (f64, f64),
    indices: Vec<usize>,
}

impl Arbitrary for TimeInput {
    fn arbitrary(g: &mut Gen) -> Self {
        let n = match u8::arbitrary(g) % 6 {
            0 => length(g),
            _ => usize::arbitrary(g) % 65,
        };
        let m = if u8::arbitrary(g) % 10 == 0 {
            length(g)
        } else {
            n
        };
        let ts = match u8::arbitrary(g) % 3 {
            0 => Bad::arbitrary(g).0,
            _ => 0.01 + f64::from(u8::arbitrary(g)) / 128.0,
        };
        let indices = (0..usize::arbitrary(g) % 6)
            .map(|_| Order::arbitrary(g).0 % 1_000_000 * (usize::arbitrary(g) % 3))
            .collect();
        Self {
            u: values(g, n),
            y: values(g, m),
            ts,
            periods: match u8::arbitrary(g) % 6 {
                0 => Order::arbitrary(g).0,
                k => usize::from(k),
            },
            orders: (
                Order::arbitrary(g).0,
                Order::arbitrary(g).0,
                Order::arbitrary(g).0,
            ),
            band: (Bad::arbitrary(g).0, Bad::arbitrary(g).0),
            indices,
        }
    }
}

fn time_entries(x: TimeInput) -> TestResult {
    let mut e: Entries = vec![
        entry!("TimeData::new", x, TimeData::new(x.u, x.y, x.ts)),
        entry!("LtvOde::validate", x, {
            let (a, b, p) = x.orders;
            (
                LtvOde::<f64>::new(a, b, p).validate(),
                FrequencyBasis::legendre(x.band.0),
            )
        }),
    ];
    let Ok(d) = TimeData::new(x.u.clone(), x.y.clone(), x.ts) else {
        return all(&x, e);
    };
    let periods = x.periods;
    e.push(entry!("TimeData::dft + average_periods", d, {
        (
            d.dft(),
            d.average_periods(periods),
            PeriodicAverage::new(&d, periods),
        )
    }));
    let (a, b, p) = x.orders;
    let (a, b, p) = (a.min(3), b.min(3), p.min(3));
    let (lo, hi) = x.band;
    e.push(entry!("LtvOde::fit band", d, {
        let model = LtvOde::new(a, b, p);
        (
            model.fit(&d, &Lines::band(lo, hi)),
            model.fit(&d, &Lines::band(lo.abs(), 0.5 / d.ts())),
        )
    }));
    let idx = x.indices.clone();
    e.push(entry!("LtvOde::fit indices", d, {
        LtvOde::new(a, b, p).fit(&d, &Lines::Indices(idx.clone()))
    }));
    e.push(entry!("Workflow::run on the DFT", d, {
        let f = d.dft();
        Workflow::default().run(
            &f,
            ModelSpec::discrete(a.min(2), b.min(2), d.ts()),
            Context::non_periodic(0.05),
        )
    }));
    all(&x, e)
}

#[test]
fn time_records_and_ltv_never_panic() {
    run(150, time_entries);
}

// ---------------------------------------------------------------------------------------
// CSV readers

/// Random bytes, or text that looks like one of the three file layouts with garbage
/// fields.
#[derive(Clone, Debug)]
struct CsvInput(Vec<u8>);

impl Arbitrary for CsvInput {
    fn arbitrary(g: &mut Gen) -> Self {
        if u8::arbitrary(g) % 4 == 0 {
            return CsvInput(Vec::<u8>::arbitrary(g));
        }
        const HEADERS: [&str; 8] = [
            "f,re,im",
            "f,re,im,var",
            "F, Re ,\"im\"",
            "f,u_re,u_im,y_re,y_im",
            "f,u_re,u_im,y_re,y_im,var_u,var_y",
            "t,u,y",
            "t,u",
            "f,re,re",
        ];
        const TOKENS: [&str; 24] = [
            "0", "1", "-1", "0.5", "2", "1e308", "1e309", "-1e309", "nan", "NaN", "inf", "-inf",
            "1e-320", "3.4e38", "3.5e38", "", " ", "\"1\"", "\"", "x", "1,2", "#", "\u{feff}",
            "0.25",
        ];
        let header = HEADERS[usize::arbitrary(g) % HEADERS.len()];
        let cols = header.split(',').count();
        let mut text = String::new();
        if bool::arbitrary(g) {
            text.push_str("# comment\n");
        }
        text.push_str(header);
        text.push('\n');
        let rows = usize::arbitrary(g) % 12;
        let mut t = 0.0f64;
        for r in 0..rows {
            let fields: Vec<String> = (0..cols)
                .map(|c| {
                    if c == 0 && u8::arbitrary(g) % 3 != 0 {
                        // mostly increasing first column
                        t += f64::from(u8::arbitrary(g) % 3) * 0.5;
                        format!("{t}")
                    } else if u8::arbitrary(g) % 3 == 0 {
                        TOKENS[usize::arbitrary(g) % TOKENS.len()].to_string()
                    } else {
                        format!("{}", f64::from(i16::arbitrary(g)) / 100.0)
                    }
                })
                .collect();
            text.push_str(&fields.join(","));
            text.push_str(if r % 3 == 0 { "\r\n" } else { "\n" });
        }
        let mut bytes = text.into_bytes();
        if u8::arbitrary(g) % 8 == 0 && !bytes.is_empty() {
            let i = usize::arbitrary(g) % bytes.len();
            bytes[i] = u8::arbitrary(g);
        }
        CsvInput(bytes)
    }
}

fn csv_entries(x: CsvInput) -> TestResult {
    let (a, b) = (x.0.clone(), x.0.clone());
    let path = std::env::temp_dir().join(format!(
        "fdid-garbage-{}-{:?}.csv",
        std::process::id(),
        std::thread::current().id()
    ));
    let c = x.0.clone();
    all(
        &String::from_utf8_lossy(&x.0),
        vec![
            entry!("parse_csv f64", a, {
                parse_csv::<f64, _>(a.as_slice(), "garbage")
                    .and_then(fdid::io::Measurement::into_frequency_data)
            }),
            entry!("parse_csv f32", b, {
                parse_csv::<f32, _>(b.as_slice(), "garbage")
                    .and_then(fdid::io::Measurement::into_frequency_data)
            }),
            entry!("read_csv", c, {
                std::fs::write(&path, &c).unwrap();
                let r = fdid::io::read_csv::<f64>(&path);
                let _ = std::fs::remove_file(&path);
                r
            }),
        ],
    )
}

#[test]
fn csv_readers_never_panic() {
    run(400, csv_entries);
}
