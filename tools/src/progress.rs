//! Progress of the long commands: an indicatif bar on stderr with count, elapsed time and
//! ETA, which indicatif hides by itself when stderr is not a terminal; and, either way, one
//! summary line at the end, so a log shows what ran and how long it took.

use std::borrow::Cow;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};

/// A bar counting `len` items of a kind named in the summary (e.g. "runs").
#[derive(Debug, Clone)]
pub struct Progress {
    bar: ProgressBar,
    what: Cow<'static, str>,
}

impl Progress {
    /// A bar on stderr, drawn only when stderr is a terminal.
    pub fn new(len: u64, what: impl Into<Cow<'static, str>>) -> Self {
        Self::with_bar(ProgressBar::new(len), what)
    }

    /// A bar that draws nothing and prints no summary (for tests and quiet callers).
    pub fn hidden(len: u64) -> Self {
        let bar = ProgressBar::hidden();
        bar.set_length(len);
        Self {
            bar,
            what: Cow::Borrowed(""),
        }
    }

    fn with_bar(bar: ProgressBar, what: impl Into<Cow<'static, str>>) -> Self {
        let style = ProgressStyle::with_template(
            "[{elapsed_precise}] {bar:30} {pos:>4}/{len} eta {eta:>3} {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar());
        bar.set_style(style);
        bar.enable_steady_tick(Duration::from_millis(500));
        Self {
            bar,
            what: what.into(),
        }
    }

    /// One more item done; `msg` (e.g. the item's name) is shown after the bar.
    pub fn inc(&self, msg: impl Into<Cow<'static, str>>) {
        self.bar.set_message(msg);
        self.bar.inc(1);
    }

    /// Shows `msg` after the bar without counting an item.
    pub fn message(&self, msg: impl Into<Cow<'static, str>>) {
        self.bar.set_message(msg);
    }

    /// Adds `n` items to the work to do, for work found while running.
    pub fn add_work(&self, n: u64) {
        self.bar.inc_length(n);
    }

    /// Removes the bar and prints the summary line: count, kind and elapsed seconds.
    /// Runs `f` (which may print) with the bar hidden.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        self.bar.suspend(f)
    }

    pub fn finish(&self) {
        self.bar.finish_and_clear();
        if !self.what.is_empty() {
            eprintln!(
                "{}/{} {} in {:.1} s",
                self.bar.position(),
                self.bar.length().unwrap_or(0),
                self.what,
                self.bar.elapsed().as_secs_f64()
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_items() {
        let p = Progress::hidden(3);
        p.add_work(1);
        for item in ["a", "b", "c", "d"] {
            p.inc(item);
        }
        assert_eq!((p.bar.position(), p.bar.length()), (4, Some(4)));
        p.finish();
        assert!(p.bar.is_finished());
    }
}
