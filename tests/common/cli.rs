//! Helpers shared by the tests of the `fdid` command (`tests/suite/cli*.rs` and the command
//! test of `tests/suite/io_touchstone_v2.rs`, each with `use crate::cli_common as cli;`):
//! running the built binary, reading what it printed, scratch files, and the bundled data
//! sets.

#![allow(dead_code)]

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A scratch directory removed on drop.
pub struct Scratch(PathBuf);

impl Scratch {
    pub fn new(name: &str) -> Self {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("fdid-cli-test-{}-{n}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }

    /// The path of `name` in the directory (not created).
    pub fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    /// Writes `contents` to `name` in the directory and returns its path.
    pub fn file(&self, name: &str, contents: &str) -> PathBuf {
        let p = self.path(name);
        std::fs::write(&p, contents).unwrap();
        p
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Runs `fdid ARGS…`.
pub fn fdid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fdid"))
        .args(args)
        .output()
        .expect("run fdid")
}

/// Runs `fdid SUBCOMMAND PATH ARGS…`.
pub fn run(subcommand: &str, path: &Path, args: &[&str]) -> Output {
    let mut all = vec![subcommand, path.to_str().unwrap()];
    all.extend_from_slice(args);
    fdid(&all)
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8(o.stdout.clone()).unwrap()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8(o.stderr.clone()).unwrap()
}

/// The stdout of a run that must have succeeded.
pub fn stdout_ok(o: &Output) -> String {
    assert!(o.status.success(), "fdid failed: {}", stderr(o));
    stdout(o)
}

/// The JSON on the stdout of a run that must have succeeded.
pub fn json_of(o: &Output) -> Value {
    serde_json::from_str(&stdout_ok(o)).expect("valid JSON")
}

/// Runs `fdid SUBCOMMAND PATH ARGS… --json`, expecting success and one JSON object.
pub fn json(subcommand: &str, path: &Path, args: &[&str]) -> Value {
    let mut all = args.to_vec();
    all.push("--json");
    let o = run(subcommand, path, &all);
    assert!(
        o.status.success(),
        "fdid {subcommand} {path:?} {all:?} failed: {}",
        stderr(&o)
    );
    let text = stdout(&o);
    assert_eq!(
        text.trim().lines().count(),
        1,
        "one JSON line expected: {text}"
    );
    serde_json::from_str(&text).expect("valid JSON")
}

/// The `theta_names` of a JSON report.
pub fn theta_names(v: &Value) -> Vec<&str> {
    v["theta_names"]
        .as_array()
        .expect("theta_names")
        .iter()
        .map(|n| n.as_str().expect("a name"))
        .collect()
}

/// The path of the bundled data file `data/NAME`.
pub fn bundled(name: &str) -> String {
    format!("{}/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// The shared data file `../shared/data/REL` (beside the crate root), which must exist.
pub fn shared(rel: &str) -> PathBuf {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(rel);
    assert!(p.exists(), "shared data file {} is missing", p.display());
    p
}

/// The F-16 ground vibration test's level-1 record, relative to `../shared/data`.
pub const F16_LEVEL1: &str = "f16-gvt/F16Data_FullMSine_Level1.csv";

/// The options that prepare the F-16 record as its README says: the shaker force as the
/// input, 400 Hz, the 9 periods averaged after the first (transient) one is dropped.
pub const F16_RECORD: [&str; 8] = [
    "--input",
    "Force",
    "--ts",
    "0.0025",
    "--periods",
    "9",
    "--skip-periods",
    "1",
];
