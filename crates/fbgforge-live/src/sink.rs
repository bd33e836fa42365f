//! Where a live run's output goes: a [`LiveSink`] (ripgrep's `Sink`) told the run's
//! start, every frame's peaks, every reading, tare change, bad frame and event, the
//! counters after each batch, and the summary; every method has a no-op default. The
//! terminal view, the JSON-lines stream, the recording of the raw peaks, the MCAP file
//! and the browser view are implementations in `fbgforge-report`
//! (`fbgforge_report::live`), the Python package's is a channel to its iterator. A
//! `Vec<Box<dyn LiveSink>>` tells every sink in it.

use super::interpret::Reading;
use super::stats::{LiveSummary, Stats};
use super::tare::{TareChange, TareSettings};
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
    /// Module: the core plugged in.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub core: Option<String>,
    /// Array: each cell's centre on the sheet, mm, in the order of `outputs`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub cell_centers_mm: Vec<(f64, f64)>,
    /// Frames the tare window holds at least (0: no tare).
    pub tare_frames: usize,
    /// Frame time the tare window spans at least, s.
    pub tare_s: f64,
    /// How long a run waits for rest before refusing to tare, s.
    pub tare_wait_s: f64,
    /// The resolution the tare judges rest against, pm.
    pub resolution_pm: f64,
}

impl LiveInfo {
    /// The tare's settings as the run uses them.
    pub fn tare_settings(&self) -> TareSettings {
        TareSettings {
            frames: self.tare_frames,
            min_s: self.tare_s,
            wait_s: self.tare_wait_s,
            resolution_pm: self.resolution_pm,
        }
    }
}

/// One frame's peaks as read, before any reading: given to the sinks for every frame
/// with peaks (read, taken into the tare, refused or bad), in order.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct PeakFrame<'a> {
    /// The frame's number (1 = the first frame with peaks).
    pub frame: u64,
    /// The instrument's frame counter, if any.
    pub serial: Option<u64>,
    /// The frame's own time, s, if any.
    pub time_s: Option<f64>,
    /// When it was received, s after the first frame (for sources without a time).
    pub received_s: f64,
    /// Each tracked grating's wavelength, nm (NaN: no peak in its window).
    pub peaks_nm: &'a [f64],
    /// The shifts read from the tare, pm, when the frame is read.
    pub shifts_pm: Option<&'a [f64]>,
    /// `read`, `tare` (taken into the tare window), `refused` (not read: the tare was
    /// refused) or `bad` (not read: see the `bad` call that follows).
    pub outcome: &'static str,
}

/// One reading, as shown and streamed.
#[derive(Debug, Clone, Serialize)]
pub struct FrameReading {
    /// The frame's number (1 = the first frame with peaks).
    pub frame: u64,
    /// The instrument's frame counter, if any.
    pub serial: Option<u64>,
    /// The frame's own time, s, if any.
    pub time_s: Option<f64>,
    /// When it was received, s after the first frame.
    pub received_s: f64,
    /// Loads or forces.
    #[serde(flatten)]
    pub reading: Reading,
    /// The sensor reads below its tare: the tare held a load (or the temperature fell).
    pub below_tare: bool,
    /// Each tracked grating's wavelength, nm (`null`: no peak in its window).
    pub peaks_nm: Vec<f64>,
    /// Each tracked grating's shift from the tare, pm.
    pub shifts_pm: Vec<f64>,
    /// Receive → reading, µs.
    pub latency_us: f64,
    /// Instrument timestamp → reading, µs (wall-clock sources).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub age_us: Option<f64>,
}

impl FrameReading {
    /// Why the reading should not be trusted, one word each: the array's trust flags
    /// (`inconsistent`, `ceiling`, …) and `below_tare`; empty when it can be.
    pub fn flag_words(&self) -> Vec<&'static str> {
        let mut w = match &self.reading {
            Reading::Loads { flags, .. } => flags.words(),
            Reading::Forces { .. } => Vec::new(),
        };
        if self.below_tare {
            w.push("below_tare");
        }
        w
    }
}

/// Where a live run's output goes. An error ends the watch (the output closed).
pub trait LiveSink {
    /// Once, before the first frame.
    fn start(&mut self, _info: &LiveInfo) -> io::Result<()> {
        Ok(())
    }
    /// Every frame with peaks, in order, as soon as it is found in the peaks.
    fn peaks(&mut self, _f: &PeakFrame<'_>) -> io::Result<()> {
        Ok(())
    }
    /// Every reading, in order.
    fn reading(&mut self, _r: &FrameReading) -> io::Result<()> {
        Ok(())
    }
    /// The tare changed (waiting, tared at rest, refused), after the frame that
    /// changed it.
    fn tare(&mut self, _change: &TareChange) -> io::Result<()> {
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

/// The sink that keeps nothing.
impl LiveSink for () {}

/// Tell every sink in turn; the first error is returned after all were told.
fn each(
    sinks: &mut [Box<dyn LiveSink + '_>],
    mut f: impl FnMut(&mut dyn LiveSink) -> io::Result<()>,
) -> io::Result<()> {
    let mut first = Ok(());
    for s in sinks.iter_mut() {
        let r = f(s.as_mut());
        if first.is_ok() {
            first = r;
        }
    }
    first
}

/// Several outputs at once (the terminal view and a recording, say): each is told
/// everything; an error of one ends the watch, and every one still gets the summary.
impl LiveSink for Vec<Box<dyn LiveSink + '_>> {
    fn start(&mut self, info: &LiveInfo) -> io::Result<()> {
        each(self, |s| s.start(info))
    }
    fn peaks(&mut self, f: &PeakFrame<'_>) -> io::Result<()> {
        each(self, |s| s.peaks(f))
    }
    fn reading(&mut self, r: &FrameReading) -> io::Result<()> {
        each(self, |s| s.reading(r))
    }
    fn tare(&mut self, change: &TareChange) -> io::Result<()> {
        each(self, |s| s.tare(change))
    }
    fn bad(&mut self, kind: &str, message: &str) -> io::Result<()> {
        each(self, |s| s.bad(kind, message))
    }
    fn event(&mut self, event: &str, message: &str) -> io::Result<()> {
        each(self, |s| s.event(event, message))
    }
    fn tick(&mut self, stats: &Stats, elapsed: Duration) -> io::Result<()> {
        each(self, |s| s.tick(stats, elapsed))
    }
    fn finish(&mut self, summary: &LiveSummary) -> io::Result<()> {
        each(self, |s| s.finish(summary))
    }
}
