//! Prints the SIMD paths this processor can run, one name a line, from the plainest
//! (`scalar`, `avx2`, `avx512`): the values of `FDID_SIMD` that `.ci/simd_paths` runs the
//! tests and the program with, to check that every path gives the same results.
//!
//! Run: `cargo run --release --example simd_paths`

use fdid::linalg::simd::SimdPath;

fn main() {
    for path in SimdPath::supported() {
        println!("{path}");
    }
}
