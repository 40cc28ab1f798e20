//! Fuzz target: `entries::eval` on arbitrary bytes (`cargo fuzz run eval`).
#![no_main]

#[path = "../entries.rs"]
mod entries;

libfuzzer_sys::fuzz_target!(|data: &[u8]| entries::eval(data));
