//! What a long computation is doing, for a caller that shows it: [`observe`] runs a
//! computation with a sink that receives a short line at each phase (a workflow step, the
//! detectors, a delay search, a fit's stages). Without a sink nothing is formatted.

use std::cell::RefCell;
use std::rc::Rc;

/// A receiver of phase lines.
type Sink = Rc<dyn Fn(&str)>;

thread_local! {
    /// The sink of this thread, if any.
    static SINK: RefCell<Option<Sink>> = const { RefCell::new(None) };
}

/// Runs `f` with `sink` receiving the phase lines of the computations on this thread;
/// the previous sink (if any) is restored afterwards.
///
/// ```
/// use std::cell::RefCell;
/// use std::rc::Rc;
/// let seen = Rc::new(RefCell::new(Vec::<String>::new()));
/// let log = Rc::clone(&seen);
/// let n = fdid::progress::observe(move |line| log.borrow_mut().push(line.into()), || 2 + 2);
/// assert_eq!(n, 4);
/// ```
pub fn observe<R>(sink: impl Fn(&str) + 'static, f: impl FnOnce() -> R) -> R {
    let previous = SINK.with(|s| s.borrow_mut().replace(Rc::new(sink)));
    let value = f();
    SINK.with(|s| *s.borrow_mut() = previous);
    value
}

/// Runs `f` with no sink on this thread (the sink before is restored afterwards): work
/// forked to other threads, which have none, reports the same on every thread.
pub(crate) fn silenced<R>(f: impl FnOnce() -> R) -> R {
    /// Puts the sink back when dropped (also on a panic).
    struct Restore(Option<Sink>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let sink = self.0.take();
            SINK.with(|s| *s.borrow_mut() = sink);
        }
    }
    let _restore = Restore(SINK.with(|s| s.borrow_mut().take()));
    f()
}

/// Sends the line `what()` to this thread's sink; formats nothing without one.
pub(crate) fn report(what: impl FnOnce() -> String) {
    let sink = SINK.with(|s| s.borrow().clone());
    if let Some(sink) = sink {
        sink(&what());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::RefCell;

    #[test]
    fn lines_reach_the_sink_of_their_scope_only() {
        let seen = Rc::new(RefCell::new(Vec::<String>::new()));
        report(|| unreachable!("formatted without a sink"));
        let log = Rc::clone(&seen);
        observe(
            move |l| log.borrow_mut().push(l.into()),
            || {
                report(|| "outer".into());
                observe(|_| {}, || report(|| "inner".into()));
                report(|| "outer again".into());
                silenced(|| report(|| unreachable!("formatted while silenced")));
                report(|| "after the silence".into());
            },
        );
        report(|| unreachable!("the sink outlived its scope"));
        assert_eq!(
            *seen.borrow(),
            ["outer", "outer again", "after the silence"]
        );
    }
}
