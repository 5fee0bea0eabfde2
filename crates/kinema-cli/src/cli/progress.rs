//! The progress bar of long runs, on standard error (indicatif).
//!
//! It appears only when a run has taken more than [`DELAY`] and standard
//! error is a terminal; otherwise nothing is drawn and stepping costs one
//! clock read per step.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// How long a run goes before a bar is shown.
pub const DELAY: Duration = Duration::from_millis(300);

/// A bar over `total` steps that shows itself late, or never.
#[derive(Debug)]
pub struct Progress {
    total: u64,
    start: Instant,
    enabled: bool,
    bar: Option<ProgressBar>,
}

impl Progress {
    /// A bar over `total` steps, enabled when standard error is a terminal.
    pub fn new(total: usize) -> Progress {
        Progress {
            total: total as u64,
            start: Instant::now(),
            enabled: std::io::stderr().is_terminal(),
            bar: None,
        }
    }

    /// Step `done` (of `total`) has finished at time `t`.
    pub fn update(&mut self, done: usize, t: f64) {
        if !self.enabled {
            return;
        }
        match &self.bar {
            Some(bar) => {
                bar.set_position(done as u64);
                bar.set_message(format!("t = {t:.4}"));
            }
            None if self.start.elapsed() >= DELAY => {
                let bar = ProgressBar::new(self.total).with_elapsed(self.start.elapsed());
                let style = ProgressStyle::with_template(
                    "{spinner} {elapsed_precise} [{wide_bar}] {pos}/{len} steps, {msg} (eta {eta})",
                );
                if let Ok(style) = style {
                    bar.set_style(style.progress_chars("=> "));
                }
                bar.set_position(done as u64);
                self.bar = Some(bar);
            }
            None => {}
        }
    }

    /// Removes the bar, if one was shown.
    pub fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}
