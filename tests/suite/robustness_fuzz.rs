//! The fuzz entry points (`fuzz/entries.rs`, driven by `cargo fuzz` in `fuzz/`) on a fast
//! arbitrary-input property in the suite: mutations of the committed seed corpus
//! (`fuzz/corpus/*/seed-*`: bytes replaced, inserted, deleted, chunks repeated, files cut)
//! and random bytes. Each entry must return without a panic.
#![cfg(feature = "cli")]

#[path = "../../fuzz/entries.rs"]
mod entries;

use quickcheck::{Arbitrary, Gen, TestResult};
use std::panic::{AssertUnwindSafe, catch_unwind};

/// The seed files of the corpus of `target`.
fn seeds(target: &str) -> Vec<Vec<u8>> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz/corpus")
        .join(target);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("seed-"))
        })
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no seeds in {}", dir.display());
    files.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

/// A mutation plan: which seed, and a list of edits (kind, position, byte).
#[derive(Clone, Debug)]
struct Mutation {
    seed: usize,
    edits: Vec<(u8, usize, u8)>,
    random: Option<Vec<u8>>,
}

impl Arbitrary for Mutation {
    fn arbitrary(g: &mut Gen) -> Self {
        let random = (u8::arbitrary(g) % 8 == 0).then(|| Vec::<u8>::arbitrary(g));
        let n = usize::arbitrary(g) % 6;
        Self {
            seed: usize::arbitrary(g),
            edits: (0..n)
                .map(|_| (u8::arbitrary(g), usize::arbitrary(g), u8::arbitrary(g)))
                .collect(),
            random,
        }
    }
}

/// The bytes of `m` applied to the seeds.
fn mutate(seeds: &[Vec<u8>], m: &Mutation) -> Vec<u8> {
    if let Some(r) = &m.random {
        return r.clone();
    }
    let mut b = seeds[m.seed % seeds.len()].clone();
    for &(kind, pos, byte) in &m.edits {
        let i = if b.is_empty() { 0 } else { pos % b.len() };
        match kind % 5 {
            0 if !b.is_empty() => b[i] = byte,
            1 => b.insert(i, byte),
            2 if !b.is_empty() => {
                b.remove(i);
            }
            3 => b.truncate(i),
            _ => {
                let end = (i + 1 + usize::from(byte)).min(b.len());
                let chunk = b[i..end].to_vec();
                b.splice(i..i, chunk);
            }
        }
    }
    b
}

/// One mutation of the seeds of `target` through `entry`: a panic fails with the input.
fn one(target: &str, entry: fn(&[u8]), m: &Mutation) -> TestResult {
    let bytes = mutate(&seeds(target), m);
    match catch_unwind(AssertUnwindSafe(|| entry(&bytes))) {
        Ok(()) => TestResult::passed(),
        Err(_) => TestResult::error(format!(
            "{target} panicked on {:?}",
            String::from_utf8_lossy(&bytes)
        )),
    }
}

/// Runs `prop` on 300 (or `QUICKCHECK_TESTS`) mutations, after `entry` on every seed as
/// it is.
fn survives(target: &str, seed: u64, entry: fn(&[u8]), prop: fn(Mutation) -> TestResult) {
    for s in &seeds(target) {
        entry(s);
    }
    let cases = std::env::var("QUICKCHECK_TESTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(300);
    crate::common::seeded(seed).tests(cases).quickcheck(prop);
}

macro_rules! target {
    ($test:ident, $name:ident, $seed:expr) => {
        #[test]
        fn $test() {
            fn prop(m: Mutation) -> TestResult {
                one(stringify!($name), entries::$name, &m)
            }
            survives(stringify!($name), $seed, entries::$name, prop);
        }
    };
}

target!(csv_and_touchstone_readers_survive_mutated_files, csv, 0xc5f);
target!(
    the_saved_model_loader_survives_mutated_files,
    saved_model,
    0x5a7
);
target!(eval_survives_mutated_models_and_frequencies, eval, 0xe7a);
