//! Fuzz target: `entries::saved_model` on arbitrary bytes (`cargo fuzz run saved_model`).
#![no_main]

#[path = "../entries.rs"]
mod entries;

libfuzzer_sys::fuzz_target!(|data: &[u8]| entries::saved_model(data));
