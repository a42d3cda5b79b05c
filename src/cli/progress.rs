//! The library's progress reports drawn on the terminal: a bar with ETA for work of known length,
//! a spinner otherwise (indicatif draws neither when stderr is not a terminal); notes go to
//! stderr. `--quiet` shows neither.

use dualhair::progress::{Progress, Task};
use indicatif::{ProgressBar, ProgressStyle};
use std::time::Duration;

/// Progress on stderr, or nothing when `quiet`.
pub struct Terminal {
    pub quiet: bool,
}

impl Terminal {
    /// Progress shown unless `quiet`.
    pub fn new(quiet: bool) -> Terminal {
        Terminal { quiet }
    }
}

/// A bar or spinner, cleared when dropped.
struct Bar(ProgressBar);

impl Drop for Bar {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

impl Progress for Terminal {
    fn task(&self, what: &str, len: Option<u64>) -> Box<dyn Task + '_> {
        if self.quiet {
            return Box::new(Bar(ProgressBar::hidden()));
        }
        let bar = match len {
            Some(len) => {
                let template =
                    format!("{{spinner}} {what} [{{bar:40}}] {{percent}}%, {{msg}} {{elapsed}} elapsed, ETA {{eta}}");
                let style = ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar());
                ProgressBar::new(len).with_style(style.progress_chars("=> "))
            }
            None => {
                let spinner = ProgressBar::new_spinner().with_message(what.to_string());
                spinner.enable_steady_tick(Duration::from_millis(120));
                spinner
            }
        };
        Box::new(Bar(bar))
    }

    fn note(&self, line: &str) {
        if !self.quiet {
            eprintln!("{line}");
        }
    }
}

impl Task for Bar {
    fn advance(&self, steps: u64) {
        self.0.inc(steps);
    }

    fn status(&self, status: &str) {
        self.0.set_message(format!("{status},"));
    }
}
