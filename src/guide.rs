//! The front page (`README.md`) and the chapters of the guide (`docs/`) as doc tests:
//! every Rust code block in them is compiled and run by `cargo test --doc`. Shell
//! commands and program output are fenced as `sh` and `text`, which rustdoc skips.

/// The front page.
#[doc = include_str!("../README.md")]
pub struct Readme;

/// The guide's index.
#[doc = include_str!("../docs/README.md")]
pub struct Guide;

/// Library usage, grey-box models, time-varying systems.
#[doc = include_str!("../docs/library.md")]
pub struct Library;

/// The discrepancy workflow.
#[doc = include_str!("../docs/workflow.md")]
pub struct Workflow;

/// The `fdid` command.
#[doc = include_str!("../docs/command-line.md")]
pub struct CommandLine;

/// Tests, examples and benchmarks.
#[doc = include_str!("../docs/testing.md")]
pub struct Testing;

/// Performance.
#[doc = include_str!("../docs/performance.md")]
pub struct Performance;

/// Limitations.
#[doc = include_str!("../docs/limitations.md")]
pub struct Limitations;
