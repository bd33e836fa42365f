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

/// Fewest steps of a stage for which an ETA is drawn: below it a step is too coarse a
/// unit to extrapolate from (`place`'s held-out scoring is 2 steps), so the bar shows
/// the steps and the time spent. Every stage begins the bar afresh, so an ETA comes
/// from the steps of its own stage only (`place`'s search: one step per iteration).
pub const ETA_MIN_STEPS: u64 = 20;

/// The bar's template for a stage of `steps` steps: the stage's name, the steps done,
/// and a labelled ETA (`ETA 12s`) when the steps are fine enough to extrapolate from,
/// else the time spent (`4s so far`).
pub fn template(steps: u64) -> &'static str {
    if steps >= ETA_MIN_STEPS {
        "{msg:>12} [{bar:30}] {pos}/{len}, ETA {eta}"
    } else {
        "{msg:>12} [{bar:30}] {pos}/{len} done, {elapsed} so far"
    }
}

/// A bar on stderr that each stage of a run resets; hidden when not interactive.
pub struct Bar(ProgressBar);

impl Bar {
    /// A hidden bar until the first stage begins.
    pub fn new() -> Self {
        Bar(ProgressBar::hidden())
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
        if interactive() {
            self.0.set_style(
                ProgressStyle::with_template(template(steps))
                    .expect("static template is valid")
                    .progress_chars("=> "),
            );
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_eta_is_labelled_and_drawn_only_over_fine_steps() {
        for steps in [1, 3, ETA_MIN_STEPS - 1] {
            assert!(!template(steps).contains("{eta}"), "{steps}");
            assert!(template(steps).contains("{elapsed}"), "{steps}");
        }
        for steps in [ETA_MIN_STEPS, 1000] {
            assert!(template(steps).contains("ETA {eta}"), "{steps}");
        }
        for steps in [1, 1000] {
            ProgressStyle::with_template(template(steps)).unwrap();
        }
    }
}
