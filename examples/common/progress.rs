//! Progress bars of the long examples: drawn on stderr when it is a terminal, nothing
//! otherwise (output piped or redirected to a file stays plain).

use indicatif::{ProgressBar, ProgressFinish, ProgressIterator, ProgressStyle};
use std::io::IsTerminal;

/// A bar of `len` steps labelled `what`, hidden when stderr is not a terminal; cleared
/// when it is dropped or its iterator ends.
pub fn bar(len: u64, what: &str) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let style = ProgressStyle::with_template(
        "{msg:>16} [{bar:40}] {pos}/{len} runs, {elapsed} elapsed, eta {eta}",
    )
    .unwrap_or_else(|_| ProgressStyle::default_bar())
    .progress_chars("=> ");
    ProgressBar::new(len)
        .with_style(style)
        .with_message(what.to_string())
        .with_finish(ProgressFinish::AndClear)
}

/// `0..n`, ticking a bar labelled `what` (see [`bar`]).
#[allow(dead_code)]
pub fn runs<I>(n: I, what: &str) -> impl Iterator<Item = I>
where
    I: Copy + Default + TryInto<u64>,
    std::ops::Range<I>: Iterator<Item = I>,
{
    let len = n.try_into().unwrap_or(0);
    (I::default()..n).progress_with(bar(len, what))
}
