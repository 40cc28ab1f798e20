//! The CSV reader on arbitrary bytes: any input gives a measurement or a typed error.
#![no_main]

use fdid::io::{Measurement, parse_csv};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(m) = parse_csv::<f64, _>(data, "fuzz") {
        // a time record goes through its DFT
        let f = m.into_frequency_data();
        assert!(!f.is_empty());
    }
    if let Ok(Measurement::Time(t)) = parse_csv::<f32, _>(data, "fuzz") {
        let _ = t.dft();
    }
});
