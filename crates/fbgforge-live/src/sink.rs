//! Where a live run's output goes: a [`LiveSink`] (ripgrep's `Sink`) told the run's
//! start, every reading, bad frame and event, the counters after each batch, and the
//! summary; every method has a no-op default. The terminal view and the JSON-lines
//! stream are implementations in `fbgforge-report` (`fbgforge_report::live`), the
//! Python package's is a channel to its iterator.

use super::interpret::Reading;
use super::stats::{LiveSummary, Stats};
use serde::Serialize;
use std::io;
use std::time::Duration;

/// What the view needs to know about the run, once.
#[derive(Debug, Clone, Serialize)]
pub struct LiveInfo {
    /// Design name.
    pub design: String,
    /// `array` or `module`.
    pub kind: &'static str,
    /// The source.
    pub source: String,
    /// One line on what is read and how.
    pub description: String,
    /// Cell labels (array) or strain gratings (module), in the order of each reading.
    pub outputs: Vec<String>,
    /// Gratings tracked in each frame.
    pub gratings: Vec<String>,
    /// Array: cells along x and y, and ulimit, g.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid: Option<(usize, usize, f64)>,
    /// Array: reconstruction method.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// Module: K per strain grating, pm/N.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub sensitivities_pm_per_n: Vec<f64>,
    /// Frames averaged for the tare.
    pub tare_frames: usize,
}

/// One reading, as shown and streamed.
#[derive(Debug, Clone, Serialize)]
pub struct FrameReading {
    /// The instrument's frame counter, if any.
    pub serial: Option<u64>,
    /// The frame's own time, s, if any.
    pub time_s: Option<f64>,
    /// Loads or forces.
    #[serde(flatten)]
    pub reading: Reading,
    /// Receive → reading, µs.
    pub latency_us: f64,
    /// Instrument timestamp → reading, µs (wall-clock sources).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub age_us: Option<f64>,
}

/// Where a live run's output goes. An error ends the watch (the output closed).
pub trait LiveSink {
    /// Once, before the first frame.
    fn start(&mut self, _info: &LiveInfo) -> io::Result<()> {
        Ok(())
    }
    /// Every reading, in order.
    fn reading(&mut self, _r: &FrameReading) -> io::Result<()> {
        Ok(())
    }
    /// A bad frame (counted by kind, named by message).
    fn bad(&mut self, _kind: &str, _message: &str) -> io::Result<()> {
        Ok(())
    }
    /// A connection event (`connected`, `disconnected`).
    fn event(&mut self, _event: &str, _message: &str) -> io::Result<()> {
        Ok(())
    }
    /// After each batch of frames, with the counters so far and the time since the
    /// first frame.
    fn tick(&mut self, _stats: &Stats, _elapsed: Duration) -> io::Result<()> {
        Ok(())
    }
    /// Once, at the end.
    fn finish(&mut self, _summary: &LiveSummary) -> io::Result<()> {
        Ok(())
    }
}
