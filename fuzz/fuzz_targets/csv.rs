//! The CSV and Touchstone readers on arbitrary bytes (`entries::csv`): any input gives a
//! measurement (or network data) or a typed error.
#![no_main]

#[path = "../entries.rs"]
mod entries;

libfuzzer_sys::fuzz_target!(|data: &[u8]| entries::csv(data));
