//! Frequency data, models and the fit entry points on fuzzer-chosen values: any input
//! gives a result or a typed error, never a panic or a hang.
#![no_main]

mod common;

use common::Bytes;
use fdid::data::merge;
use fdid::model::remove_delay;
use fdid::estimate::ModalOptions;
use fdid::prelude::*;
use fdid::workflow::{Context, ModelSpec, SpecCriterion, SpecDomain, Workflow, fit_spec};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let n = usize::from(b.u8() % 33);
    let omega = b.grid(n);
    let y: Vec<Complex<f64>> = (0..n).map(|_| Complex::new(b.f64(), b.f64())).collect();
    let u: Vec<Complex<f64>> = if b.bool() {
        vec![Complex::new(1.0, 0.0); n]
    } else {
        (0..n).map(|_| Complex::new(b.f64(), b.f64())).collect()
    };
    let ts = if b.bool() { Some(b.f64().abs()) } else { None };
    let var = b.bool().then(|| b.values(n));
    let (na, nb) = (b.order(), b.order());
    let (lo, hi) = (b.f64(), b.f64());
    let tau = b.f64();
    let flags = b.u8();

    let _ = Rational::continuous(na, nb, &omega);
    let _ = Rational::discrete(na, nb, ts.unwrap_or(lo));
    let _ = Modal::<f64>::continuous(na, nb, true);
    let Ok(mut d) = FrequencyData::new(omega, y, u, ts) else {
        return;
    };
    if let Some(v) = var {
        match d.clone().with_noise(NoiseVariances::output_only(v)) {
            Ok(with) => d = with,
            Err(_) => return,
        }
    }
    let _ = (
        d.band(lo, hi),
        d.band_hz(lo, hi),
        d.etfe(),
        d.clone().with_ts(Some(lo)),
    );
    let _ = remove_delay(&d, tau);
    let _ = merge(&[d.clone(), d.clone().without_noise()]);
    let _ = lpm(&d, Lpm::new().with_degree(na).with_half_width(nb));

    let p = Pipeline::default();
    let ts1 = ts.unwrap_or(1.0);
    let (sa, sb) = (na % 5, nb % 5);
    match flags % 8 {
        0 => drop(Rational::continuous(na, nb, d.omega()).and_then(|m| p.fit(&m, &d))),
        1 => drop(Rational::discrete(na, nb, ts1).and_then(|m| p.fit(&m, &d))),
        2 => drop(
            Rational::discrete(sa, sb, ts1)
                .and_then(|m| m.with_transient())
                .and_then(|m| fit_delayed(&p, &m, &d)),
        ),
        3 => drop(Rational::discrete(sa, sb, ts1).and_then(|m| fit_eiv(&p, &m, &d))),
        4 => drop(
            Rational::discrete(sa % 3, sb % 3, ts1)
                .and_then(|m| fit_noise_model(&p, &m, &d, na % 3, nb % 3)),
        ),
        5 => drop(fit_modal(
            &p,
            &d,
            sa % 3,
            sb % 3,
            ModalOptions::continuous(),
        )),
        6 => {
            let spec = ModelSpec {
                domain: if flags & 16 == 0 {
                    SpecDomain::S
                } else {
                    SpecDomain::Z { ts: ts1 }
                },
                na: sa % 4,
                nb: sb % 4,
                delay: flags & 32 != 0,
                transient: flags & 64 != 0,
                noise_order: (flags & 128 != 0).then_some(1),
                criterion: if d.noise().is_some() {
                    SpecCriterion::Eiv
                } else {
                    SpecCriterion::Ml
                },
            };
            let _ = fit_spec(&spec, &d);
        }
        _ => {
            let spec = ModelSpec::discrete(sa % 3, sb % 3, ts1);
            let _ = Workflow::default().run(&d, spec, Context::frequency_data(lo.abs()));
        }
    }
});
