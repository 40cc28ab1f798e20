//! The progress line of a command on a terminal (a spinner with the elapsed time and the
//! phase the library reports through [`fdid::progress`]), and its clean stop on Ctrl-C:
//! the line is cleared, no output file is left half written ([`write_atomic`]) and the
//! command exits with status 130.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Duration;

/// The files being written, removed by an interrupt.
static PARTIAL: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The exit status of a command stopped by Ctrl-C (128 + SIGINT, as shells report it).
pub const INTERRUPTED: u8 = 130;

/// Clears the progress line when the command ends, also by a panic.
struct Line(ProgressBar);

impl Drop for Line {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

/// Runs the command `f` with the progress line (drawn only when stderr is a terminal)
/// and the Ctrl-C handler.
pub fn run<R>(f: impl FnOnce() -> R) -> R {
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("{spinner} {elapsed} {wide_msg}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    let on_interrupt = bar.clone();
    // a second handler cannot be installed (only in tests calling `run` twice): keep the first
    let _ = ctrlc::set_handler(move || {
        on_interrupt.finish_and_clear();
        let removed = PARTIAL.lock().map(|p| p.clone()).unwrap_or_default();
        for path in removed {
            let _ = std::fs::remove_file(path);
        }
        eprintln!(
            "error: interrupted (Ctrl-C): stopped before the results; no output file was left half written"
        );
        std::process::exit(i32::from(INTERRUPTED));
    });
    let line = Line(bar.clone());
    let value = fdid::progress::observe(move |phase| bar.set_message(phase.to_string()), f);
    drop(line);
    value
}

/// Writes `contents` to `path` through a temporary file beside it and a rename, so that
/// `path` is either absent, as before, or complete — also when the command is
/// interrupted while writing.
pub fn write_atomic(path: &Path, contents: &[u8]) -> std::io::Result<()> {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".partial");
    let partial = path.with_file_name(name);
    if let Ok(mut p) = PARTIAL.lock() {
        p.push(partial.clone());
    }
    let written = std::fs::write(&partial, contents).and_then(|()| std::fs::rename(&partial, path));
    if written.is_err() {
        let _ = std::fs::remove_file(&partial);
    }
    if let Ok(mut p) = PARTIAL.lock() {
        p.retain(|q| *q != partial);
    }
    written
}
