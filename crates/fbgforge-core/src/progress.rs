//! Progress of long runs (sweeps, optimisation, big logs), as the library reports it.
//!
//! The library never draws: a long run takes a `&dyn Progress` and tells it when a stage
//! begins, how far it got and when it ended. Every method has a no-op default, so
//! [`Quiet`] (tests, Python, studies in pipes) costs nothing; the binary's terminal bars
//! implement the trait (`src/cli/progress.rs`) and stay hidden in pipes and CI.

/// Receives the progress of a long run. Implementations must be cheap and thread-safe:
/// parallel runs call [`Progress::advance`] from several threads.
pub trait Progress: Sync {
    /// A stage named `label` of `steps` steps begins (a new stage replaces the last).
    fn begin(&self, _label: &str, _steps: u64) {}
    /// The current stage's status line changes to `message` (a sub-stage, say).
    fn message(&self, _message: &str) {}
    /// `steps` more steps of the current stage are done.
    fn advance(&self, _steps: u64) {}
    /// The run is over: clear whatever was drawn.
    fn end(&self) {}
}

/// Reports nothing: for tests, Python and callers that do not show progress.
#[derive(Debug, Clone, Copy, Default)]
pub struct Quiet;

impl Progress for Quiet {}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicU64, Ordering};

    /// Counts steps, to check that the defaults forward nothing and a sink sees each call.
    struct Count(AtomicU64);

    impl Progress for Count {
        fn advance(&self, steps: u64) {
            self.0.fetch_add(steps, Ordering::Relaxed);
        }
    }

    #[test]
    fn a_sink_sees_every_step_from_several_threads() {
        let c = Count(AtomicU64::new(0));
        let p: &dyn Progress = &c;
        std::thread::scope(|s| {
            for _ in 0..4 {
                s.spawn(|| (0..250).for_each(|_| p.advance(1)));
            }
        });
        p.begin("ignored", 9);
        p.end();
        assert_eq!(c.0.load(Ordering::Relaxed), 1000);
    }
}
