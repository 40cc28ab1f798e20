//! Time records, periodic averaging and the time-varying ODE on fuzzer-chosen values:
//! any input gives a result or a typed error, never a panic or a hang.
#![no_main]

mod common;

use common::Bytes;
use fdid::data::PeriodicAverage;
use fdid::ltv::Lines;
use fdid::prelude::*;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let n = usize::from(b.u8() % 65);
    let u = b.values(n);
    let y = b.values(n);
    let ts = b.f64();
    let periods = b.order();
    let (a, bo, p) = (b.order(), b.order(), b.order());
    let (lo, hi) = (b.f64(), b.f64());
    let indices: Vec<usize> = (0..b.u8() % 6).map(|_| b.order() % 40).collect();
    let _ = LtvOde::<f64>::new(a, bo, p).validate();
    let Ok(t) = TimeData::new(u, y, ts) else {
        return;
    };
    let _ = t.dft();
    let _ = t.average_periods(periods);
    let _ = PeriodicAverage::new(&t, periods % 7);
    let model = LtvOde::new(a % 4, bo % 4, p % 4);
    let _ = model.fit(&t, &Lines::band(lo, hi));
    let _ = model.fit(&t, &Lines::Indices(indices));
});
