//! Steering a run while it runs: stop it, or tare again. A [`LiveControl`] is shared
//! between the run and whatever steers it (the terminal's keys, a control input, a
//! signal handler, the Python stream's `tare()` and `close()`); the run looks at it
//! between batches of frames.
//!
//! The control input's words, one command per line ([`LiveControl::apply_line`]):
//!
//! | line | does |
//! |---|---|
//! | `tare` | tare again: the frames are not read until a window is at rest |
//! | `stop` (or `quit`) | end the run, with its summary |
//!
//! Blank lines and `#` comments are ignored; anything else is an error naming the line.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// Requests to a running watch.
///
/// ```
/// use fbgforge_live::control::LiveControl;
///
/// let c = LiveControl::new();
/// c.apply_line("tare", "control").unwrap();
/// c.apply_line("  # a comment", "control").unwrap();
/// assert!(c.apply_line("zero", "control").unwrap_err().contains("`tare` or `stop`"));
/// assert!(!c.stopped());
/// c.apply_line("stop", "control").unwrap();
/// assert!(c.stopped());
/// ```
#[derive(Debug, Default)]
pub struct LiveControl {
    stop: AtomicBool,
    why: Mutex<Option<String>>,
    tare_requests: Mutex<Vec<String>>,
    notes: Mutex<Vec<(String, String)>>,
}

impl LiveControl {
    /// No request yet.
    pub fn new() -> Self {
        LiveControl::default()
    }

    /// Ask the run to end (its summary is still given).
    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }

    /// Ask the run to end, saying why (`SIGTERM`): the summary's `ended`.
    pub fn stop_because(&self, why: &str) {
        self.why
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get_or_insert_with(|| why.to_string());
        self.stop();
    }

    /// Why the run was asked to end, if it was said.
    pub fn stop_reason(&self) -> Option<String> {
        self.why.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// Whether the run was asked to end.
    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// Ask for a new tare; `origin` says who asked (`key`, `control`, `python`).
    pub fn request_tare(&self, origin: &str) {
        self.tare_requests
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(origin.to_string());
    }

    /// Say something to the run's outputs as an event (`control`, a bad control line),
    /// from whatever steers the run.
    pub fn note(&self, event: &str, message: &str) {
        self.notes
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push((event.to_string(), message.to_string()));
    }

    /// The notes not yet taken, oldest first.
    pub(crate) fn take_notes(&self) -> Vec<(String, String)> {
        std::mem::take(&mut *self.notes.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// The tare requests not yet taken, oldest first.
    pub(crate) fn take_tare_requests(&self) -> Vec<String> {
        std::mem::take(&mut *self.tare_requests.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// Apply one line of a control input (see the [module](self)); `origin` names the
    /// input in the tare's record. An error says what was expected.
    pub fn apply_line(&self, line: &str, origin: &str) -> Result<(), String> {
        let t = line.trim();
        match t.to_ascii_lowercase().as_str() {
            "" => Ok(()),
            _ if t.starts_with('#') => Ok(()),
            "tare" => {
                self.request_tare(origin);
                Ok(())
            }
            "stop" | "quit" => {
                self.stop();
                Ok(())
            }
            _ => Err(format!(
                "unknown command `{t}`: a control line is `tare` or `stop`"
            )),
        }
    }
}
