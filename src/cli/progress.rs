//! Terminal progress bars for the binary (and the studies, which include this file):
//! the one implementation of the library's [`Progress`] trait that draws. Shown on a
//! terminal only; hidden in pipes and when `CI` is set.

use fbgforge::progress::Progress;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// True when progress should be drawn: stderr is a terminal and `CI` is not set.
pub fn interactive() -> bool {
    std::io::stderr().is_terminal() && std::env::var_os("CI").is_none()
}

/// A bar on stderr that each stage of a run resets; hidden when not interactive.
pub struct Bar(ProgressBar);

impl Bar {
    /// A hidden bar until the first stage begins.
    pub fn new() -> Self {
        let pb = ProgressBar::hidden();
        if interactive() {
            pb.set_style(
                ProgressStyle::with_template("{msg:>12} [{bar:40}] {pos}/{len} ({eta})")
                    .expect("static template is valid")
                    .progress_chars("=> "),
            );
        }
        Bar(pb)
    }

    /// A bar of `steps` steps labelled `label`, already begun.
    pub fn with(label: &str, steps: u64) -> Self {
        let b = Bar::new();
        b.begin(label, steps);
        b
    }
}

impl Default for Bar {
    fn default() -> Self {
        Bar::new()
    }
}

impl Progress for Bar {
    fn begin(&self, label: &str, steps: u64) {
        if interactive() && self.0.is_hidden() {
            self.0.set_draw_target(ProgressDrawTarget::stderr());
        }
        self.0.reset();
        self.0.set_length(steps);
        self.0.set_message(label.to_string());
    }

    fn message(&self, message: &str) {
        self.0.set_message(message.to_string());
    }

    fn advance(&self, steps: u64) {
        self.0.inc(steps);
    }

    fn end(&self) {
        self.0.finish_and_clear();
    }
}
