//! The CSV and Touchstone readers on arbitrary bytes: any input gives a measurement (or
//! network data) or a typed error.
#![no_main]

use fdid::io::{Measurement, parse_csv, parse_touchstone, parse_touchstone_v2};
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
    // Touchstone version 1 or 2.0 as .s1p/.s2p, and version 2.0 as .ts; with a version 2
    // header in front, so that the keyword parser sees the bytes too
    let mut v2 = b"[Version] 2.0\n# Hz S RI\n".to_vec();
    v2.extend_from_slice(data);
    for bytes in [data, &v2[..]] {
        for ports in 1..=2 {
            if let Ok(t) = parse_touchstone(bytes, ports, "fuzz") {
                assert_eq!(t.ports, ports);
                assert_eq!(t.values.len(), t.freq_hz.len());
                let _ = t.frequency_data::<f64>((ports, 1));
            }
        }
        if let Ok(t) = parse_touchstone_v2(bytes, "fuzz") {
            assert!(t.values.iter().all(|m| m.len() == t.ports * t.ports));
        }
    }
});
