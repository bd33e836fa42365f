//! The live mode: a running interrogator stream in, what the sensor feels out, frame
//! by frame.
//!
//! * [`source`]: where frames come from — a log file still being written (tail), standard
//!   input (one frame of peaks per line) or a Luna Hyperion peak stream over TCP
//!   ([`hyperion`] holds the protocol), read on their own thread into a bounded queue;
//! * [`interpret`]: each frame's peaks to gratings, shifts from a tare, then the
//!   array's cell loads (its default reconstruction method) or the module's
//!   temperature-compensated force per grating (predicted or calibrated K);
//! * [`tare`]: the zero-load wavelengths, taken only from a window at rest;
//! * [`replay`]: a finished log read the same way, its shifts from the tare (for
//!   `reconstruct --log`);
//! * [`control`]: stop a run or tare again while it runs;
//! * [`stats`]: frames, drops, bad frames by kind, reconnections, latency;
//! * [`sink`]: where the output goes ([`sink::LiveSink`]; the terminal view and the
//!   JSON-lines stream are `fbgforge_report::live`'s);
//!
//! The use case is [`run`]: `fbgforge live` and the tests call it. A bad frame is
//! counted once and named, never fatal; a dropped connection is reopened; frames of an
//! instrument that arrive faster than they can be read are dropped at the queue and
//! counted, so the reader never falls behind the instrument, while a file or standard
//! input is read whole (every frame, none dropped) unless [`LiveRequest::realtime`].

// Sibling crates under the names the modules used inside one crate.
#[allow(unused_imports)]
use fbgforge_array as array;
#[allow(unused_imports)]
use fbgforge_core::{design, family, grating, logs, output, profile, progress, spec};
#[allow(unused_imports)]
use fbgforge_model::{fem, model, prediction, solvers};

pub mod control;
pub mod hyperion;
pub mod interpret;
pub mod replay;
pub mod sink;
pub mod source;
pub mod stats;
pub mod tare;

use anyhow::Result;
use control::LiveControl;
use interpret::{InterpretOptions, Interpreter, Prepared, Skip};
use sink::{FrameReading, LiveInfo, LiveSink, PeakFrame};
use source::{Outlet, SourceEvent, SourceSpec};
use stats::{Dropped, LiveSummary, Stats};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use tare::TareChange;

/// What to watch and how.
#[derive(Debug, Clone)]
pub struct LiveRequest {
    /// Design spec (TOML): an array or a module.
    pub design: PathBuf,
    /// Where the frames come from.
    pub source: SourceSpec,
    /// How frames are read.
    pub interpret: InterpretOptions,
    /// Stop after this many readings.
    pub max_frames: Option<u64>,
    /// Stop after this long, s.
    pub duration_s: Option<f64>,
    /// Frames the queue between reader and interpreter holds. An instrument's frames
    /// that find it full are dropped and counted; a file or standard input waits for
    /// room (nothing is lost) unless `realtime`.
    pub queue_frames: usize,
    /// Read a file or standard input at the pace it comes, dropping (and counting)
    /// frames that find the queue full, as for an instrument. Off: every frame is read.
    pub realtime: bool,
}

impl LiveRequest {
    /// Check the request's limits, queue size and reading settings (the source's
    /// options are checked when it is parsed, [`SourceSpec::parse`]).
    pub fn validate(&self) -> Result<()> {
        self.interpret.validate()?;
        if let Some(d) = self.duration_s.filter(|d| !(d.is_finite() && *d > 0.0)) {
            anyhow::bail!("LiveRequest.duration_s must be a positive number of seconds, got {d}");
        }
        if self.queue_frames == 0 {
            anyhow::bail!("LiveRequest.queue_frames: the queue must hold at least one frame");
        }
        if let Some(path) = self.source.path() {
            if !path.is_file() {
                anyhow::bail!(
                    "LiveRequest.source: {} {}: expected a log file the interrogator writes (or `-` for standard input, `hyperion://HOST`)",
                    path.display(),
                    if path.exists() {
                        "is not a file"
                    } else {
                        "does not exist"
                    }
                );
            }
        }
        Ok(())
    }

    /// A request with every default.
    pub fn new(design: PathBuf, source: SourceSpec) -> Self {
        LiveRequest {
            design,
            source,
            interpret: InterpretOptions::default(),
            max_frames: None,
            duration_s: None,
            queue_frames: 8192,
            realtime: false,
        }
    }
}

/// Frames handled per batch at most (the interpreter solves a batch in parallel).
const BATCH: usize = 256;

/// How far a stream's timestamps may be from this machine's clock and still be taken
/// for the wall clock, s: above any plausible lag of a live stream, below the 15 min
/// step of time zones (a log written in local time elsewhere is not the wall clock).
pub(crate) const WALL_CLOCK_TOLERANCE_S: f64 = 300.0;

/// Whether the stream's timestamps are this machine's wall clock, decided on the
/// first frame that claims so after each (re)connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum StreamClock {
    Undecided,
    Wall,
    Other,
}

/// A span of seconds as a person reads it: `42.0 s`, `7.5 min`, `3.2 h`, `1.2 days`.
fn span_text(s: f64) -> String {
    let a = s.abs();
    if a < 120.0 {
        format!("{a:.1} s")
    } else if a < 7200.0 {
        format!("{:.1} min", a / 60.0)
    } else if a < 2.0 * 86400.0 {
        format!("{:.1} h", a / 3600.0)
    } else {
        format!("{:.1} days", a / 86400.0)
    }
}

fn wall_now_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// What the sink is told before the first frame: the design, the source and the outputs.
fn live_info(design: &crate::spec::Design, interp: &Interpreter, req: &LiveRequest) -> LiveInfo {
    let tare = interp.tare_settings();
    LiveInfo {
        design: design.name.clone(),
        kind: if interp.array_grid().is_some() {
            "array"
        } else {
            "module"
        },
        source: req.source.describe(),
        description: interp.description().to_string(),
        outputs: interp.outputs().to_vec(),
        gratings: interp.gratings(),
        grid: interp.array_grid(),
        method: interp.method().map(|m| m.name().to_string()),
        sensitivities_pm_per_n: interp.sensitivities_pm_per_n(),
        core: interp.core().map(str::to_string),
        cell_centers_mm: interp.cell_centers_mm().to_vec(),
        tare_frames: tare.frames,
        tare_s: tare.min_s,
        tare_wait_s: tare.wait_s,
        resolution_pm: tare.resolution_pm,
    }
}

/// Why the watch ends: the output closed.
fn sink_error(e: std::io::Error) -> String {
    format!("output closed ({e})")
}

/// Where and when a prepared frame was read, and what it held.
struct FrameMeta {
    frame: u64,
    serial: Option<u64>,
    time_s: Option<f64>,
    wall_clock: bool,
    received: Instant,
    received_s: f64,
    peaks_nm: Vec<f64>,
    below_tare: bool,
}

/// A watch in progress: the interpreter, the counters, the frames of the current batch
/// and why the watch ended, once it has.
struct Watch<'a> {
    interp: Interpreter,
    sink: &'a mut dyn LiveSink,
    stats: Stats,
    overflow: Arc<AtomicU64>,
    connections: u64,
    first_frame: Option<Instant>,
    last_frame: Option<Instant>,
    /// The first and last frame's own time (instrument or log clock), s.
    clock_s: Option<(f64, f64)>,
    ended: Option<String>,
    source_lost: bool,
    output_closed: bool,
    clock: StreamClock,
    prepared: Vec<Prepared>,
    meta: Vec<FrameMeta>,
    max_frames: Option<u64>,
}

impl Watch<'_> {
    /// Interpret one batch of source events and pass their readings on.
    fn batch(&mut self, batch: &mut Vec<SourceEvent>) {
        self.prepared.clear();
        self.meta.clear();
        let mut out_err: Option<std::io::Error> = None;
        for ev in batch.drain(..) {
            if let Err(e) = self.event(ev) {
                out_err = Some(e);
                break;
            }
        }
        self.readings(&mut out_err);
        self.tick(out_err);
    }

    /// Count one source event and prepare a frame; an error when the output closed.
    fn event(&mut self, ev: SourceEvent) -> std::io::Result<()> {
        match ev {
            SourceEvent::Frame(f) => self.frame(&f),
            SourceEvent::Bad { kind, message } => self.bad(&kind, message),
            SourceEvent::Missed(n) => {
                self.stats.dropped.serial_gaps += n;
                Ok(())
            }
            SourceEvent::Connected(what) => {
                self.connections += 1;
                self.clock = StreamClock::Undecided;
                if self.connections > 1 {
                    self.stats.reconnects += 1;
                }
                let event = if self.connections > 1 {
                    "reconnected"
                } else {
                    "connected"
                };
                self.sink.event(event, &what)
            }
            SourceEvent::Disconnected(why) => {
                let m = why.clone();
                self.stats.bad.add("disconnected", || m);
                self.sink.event("disconnected", &why)
            }
            SourceEvent::End(why) => {
                self.ended = Some(why);
                Ok(())
            }
            SourceEvent::Lost(why) => {
                self.ended = Some(why);
                self.source_lost = true;
                Ok(())
            }
        }
    }

    /// Prepare one frame: a tare frame, a refused one, a bad one, or shifts to solve
    /// with the batch. Its peaks and any tare change go to the sink at once.
    fn frame(&mut self, f: &source::Frame) -> std::io::Result<()> {
        let first = *self.first_frame.get_or_insert(f.received);
        self.last_frame = Some(f.received);
        if let Some(t) = f.time_s.filter(|t| t.is_finite()) {
            self.clock_s = Some(self.clock_s.map_or((t, t), |(a, _)| (a, t)));
        }
        self.stats.frames_in += 1;
        let wall_clock = self.clock_is_wall(f)?;
        let a = self.interp.prepare(f);
        self.stats.ambiguous_frames += u64::from(a.ambiguous);
        let received_s = f.received.saturating_duration_since(first).as_secs_f64();
        self.sink.peaks(&PeakFrame {
            frame: a.frame,
            serial: f.serial,
            time_s: f.time_s,
            received_s,
            peaks_nm: &a.peaks_nm,
            shifts_pm: a.result.as_ref().ok().map(|p| p.shifts_pm.as_slice()),
            outcome: match &a.result {
                Ok(_) => "read",
                Err(Skip::Tare) => "tare",
                Err(Skip::Refused) => "refused",
                Err(Skip::Bad(..)) => "bad",
            },
        })?;
        self.tare_changes()?;
        match a.result {
            Ok(p) => {
                self.meta.push(FrameMeta {
                    frame: a.frame,
                    serial: f.serial,
                    time_s: f.time_s,
                    wall_clock,
                    received: f.received,
                    received_s,
                    peaks_nm: a.peaks_nm,
                    below_tare: p.below_tare,
                });
                self.prepared.push(p);
                Ok(())
            }
            Err(Skip::Tare) => {
                self.stats.tare_frames += 1;
                Ok(())
            }
            Err(Skip::Refused) => {
                self.stats.refused_frames += 1;
                Ok(())
            }
            Err(Skip::Bad(kind, message)) => self.bad(kind, message),
        }
    }

    /// Pass the tare's changes on.
    fn tare_changes(&mut self) -> std::io::Result<()> {
        for c in self.interp.take_tare_changes() {
            self.stats.tare = c.state;
            if c.origin == "below_tare" && c.state == tare::TareState::Resting {
                self.stats.retares_below_tare += 1;
            }
            self.tare_change(&c)?;
        }
        Ok(())
    }

    fn tare_change(&mut self, c: &TareChange) -> std::io::Result<()> {
        self.sink.tare(c)
    }

    /// Apply the requests made since the last batch: a new tare for each; pass the
    /// notes of whatever steers the run on as events.
    fn requests(&mut self, control: &LiveControl) -> std::io::Result<()> {
        for (event, message) in control.take_notes() {
            self.sink.event(&event, &message)?;
        }
        for origin in control.take_tare_requests() {
            self.stats.tare_requests += 1;
            self.interp.request_tare(&origin);
        }
        self.tare_changes()
    }

    /// Whether `f`'s time is this machine's wall clock, so that its age means
    /// something: the source must say so, and the first such frame of a connection
    /// must be within [`WALL_CLOCK_TOLERANCE_S`] of this machine's clock (else an
    /// event says why no age is measured).
    fn clock_is_wall(&mut self, f: &source::Frame) -> std::io::Result<bool> {
        let Some(t) = f.time_s.filter(|_| f.wall_clock) else {
            return Ok(false);
        };
        if self.clock == StreamClock::Undecided {
            let behind_s = wall_now_s() - t;
            if behind_s.abs() <= WALL_CLOCK_TOLERANCE_S {
                self.clock = StreamClock::Wall;
            } else {
                self.clock = StreamClock::Other;
                let side = if behind_s > 0.0 { "behind" } else { "ahead of" };
                self.sink.event(
                    "clock",
                    &format!(
                        "the stream's timestamps are {} {side} this machine's clock (another clock, or a log in another time zone): frame age is not measured",
                        span_text(behind_s)
                    ),
                )?;
            }
        }
        Ok(self.clock == StreamClock::Wall)
    }

    /// Count a bad frame by kind and pass it on.
    fn bad(&mut self, kind: &str, message: String) -> std::io::Result<()> {
        self.stats.bad_frames += 1;
        let m = message.clone();
        self.stats.bad.add(kind, || m);
        self.sink.bad(kind, &message)
    }

    /// Solve the batch's prepared frames and pass each reading on with its latency,
    /// until the output closes or the frame limit is reached.
    fn readings(&mut self, out_err: &mut Option<std::io::Error>) {
        let readings = self.interp.solve(&self.prepared);
        let now = Instant::now();
        let wall = wall_now_s();
        let meta = std::mem::take(&mut self.meta);
        let prepared = std::mem::take(&mut self.prepared);
        for ((reading, m), p) in readings.into_iter().zip(meta).zip(prepared) {
            if out_err.is_some() {
                break;
            }
            let stats = &mut self.stats;
            let latency_us = now.duration_since(m.received).as_secs_f64() * 1e6;
            let age_us = m.time_s.filter(|_| m.wall_clock).map(|t| (wall - t) * 1e6);
            stats.latency.add(latency_us);
            if let Some(a) = age_us {
                stats.age.add(a);
            }
            if let interpret::Reading::Loads { converged, .. } = &reading {
                stats.not_converged += u64::from(!converged);
            }
            stats.frames_out += 1;
            let r = FrameReading {
                frame: m.frame,
                serial: m.serial,
                time_s: m.time_s,
                received_s: m.received_s,
                reading,
                below_tare: m.below_tare,
                peaks_nm: m.peaks_nm,
                shifts_pm: p.shifts_pm,
                latency_us,
                age_us,
            };
            stats.below_tare += u64::from(r.below_tare);
            stats.flagged += u64::from(!r.flag_words().is_empty());
            if let Err(e) = self.sink.reading(&r) {
                *out_err = Some(e);
            }
            if self
                .max_frames
                .is_some_and(|limit| self.stats.frames_out >= limit)
            {
                let n = self.stats.frames_out;
                self.ended.get_or_insert_with(|| format!("{n} frames read"));
                break;
            }
        }
    }

    /// Give the sink the counters so far; the watch ends if the output closed.
    fn tick(&mut self, out_err: Option<std::io::Error>) {
        self.stats.dropped.queue_overflow = self.overflow.load(Ordering::Relaxed);
        let el = self.first_frame.map_or(Duration::ZERO, |t| t.elapsed());
        let err = match out_err {
            Some(e) => Some(e),
            None => self.sink.tick(&self.stats, el).err(),
        };
        if let Some(e) = err {
            self.output_closed = true;
            self.ended = Some(sink_error(e));
        }
    }

    /// The watch's summary: counts, rate over the frames themselves (not the wait for
    /// a source that ended), drops, latency.
    fn summary(&mut self, design: String, source: String) -> LiveSummary {
        let stats = &mut self.stats;
        stats.dropped.queue_overflow = self.overflow.load(Ordering::Relaxed);
        let elapsed_s = self.first_frame.map_or(0.0, |t| t.elapsed().as_secs_f64());
        let read_span_s = match (self.first_frame, self.last_frame) {
            (Some(a), Some(b)) => b.duration_since(a).as_secs_f64(),
            _ => 0.0,
        };
        // A replayed log is read far faster than it was written: its rate is that of
        // its own clock, not of the reading (which a finished file makes near zero).
        let clock_span_s = self.clock_s.map(|(a, b)| b - a).filter(|s| *s > 0.0);
        let span_s = clock_span_s.unwrap_or(read_span_s);
        let d = stats.dropped;
        LiveSummary {
            design,
            source,
            ended: self.ended.take().unwrap_or_else(|| "stopped".into()),
            source_lost: self.source_lost,
            output_closed: self.output_closed,
            elapsed_s,
            clock_span_s,
            frames_in: stats.frames_in,
            frames_out: stats.frames_out,
            rate_hz: if span_s > 0.0 {
                (stats.frames_in.saturating_sub(1)) as f64 / span_s
            } else {
                0.0
            },
            tare: stats.tare,
            tare_frames: stats.tare_frames,
            refused_frames: stats.refused_frames,
            tare_requests: stats.tare_requests,
            retares_below_tare: stats.retares_below_tare,
            bad_frames: stats.bad_frames,
            bad: stats.bad.clone(),
            ambiguous_frames: stats.ambiguous_frames,
            dropped: Dropped {
                total: d.serial_gaps + d.queue_overflow,
                ..d
            },
            reconnects: stats.reconnects,
            not_converged: stats.not_converged,
            flagged: stats.flagged,
            below_tare: stats.below_tare,
            latency: stats.latency.summary(),
            age: stats.age.summary(),
        }
    }
}

/// Watch a stream until it ends, `control` asks it to stop, or a limit of the request
/// is reached; every frame, reading, tare change, bad frame and event goes to `sink`,
/// and `control`'s tare requests are applied between batches. Returns the summary
/// (also given to the sink). Errors only for a bad request (design, options, a source
/// file that does not exist); nothing in the stream is fatal.
///
/// ```
/// use fbgforge_live::{control::LiveControl, source::{SourceOptions, SourceSpec}, run, LiveRequest};
/// use std::path::PathBuf;
///
/// let dir = tempfile::tempdir()?;
/// let log = dir.path().join("peaks.csv");
/// // 60 frames at rest of the 34 mm module's core psc2 (strain gratings and reference).
/// let rows: String = (0..60).map(|k| format!("{},1540.06,1530.701,1560.146\n", k as f64 * 0.01)).collect();
/// std::fs::write(&log, format!("time_s,a,b,c\n{rows}"))?;
/// let source = SourceSpec::parse(log.to_str().unwrap(), SourceOptions { from_start: true, idle_exit_s: Some(0.2), ..SourceOptions::default() })?;
/// let design = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../designs/clip-on-34mm.toml");
/// let mut req = LiveRequest::new(design, source);
/// req.interpret.core = Some("psc2".into());
/// req.interpret.tare_s = 0.2;
/// let summary = run(&req, &mut (), &LiveControl::new())?;
/// // Tared on the first 50 frames (at rest), the next 10 read; none dropped.
/// assert_eq!((summary.tare_frames, summary.frames_out, summary.dropped.total), (50, 10, 0));
/// assert_eq!(summary.tare.word(), "resting");
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn run(
    req: &LiveRequest,
    sink: &mut dyn LiveSink,
    control: &LiveControl,
) -> Result<LiveSummary> {
    req.validate()?;
    let design = crate::design::load(&req.design)?;
    let interp = Interpreter::new(&design, &req.interpret)?;
    let info = live_info(&design, &interp, req);
    let (tx, rx) = sync_channel(req.queue_frames);
    let source_stop = Arc::new(AtomicBool::new(false));
    let outlet =
        Outlet::new(tx, source_stop.clone()).waiting(req.source.holds_frames() && !req.realtime);
    let overflow = outlet.overflow.clone();
    // The source thread is not joined: one blocked on standard input cannot be woken;
    // every other source sees `source_stop` within 200 ms and exits.
    let _reader = source::spawn(req.source.clone(), outlet);
    let mut w = Watch {
        stats: Stats {
            tare: interp.tare_state(),
            ..Stats::default()
        },
        interp,
        sink,
        overflow,
        connections: 0,
        first_frame: None,
        last_frame: None,
        clock_s: None,
        ended: None,
        source_lost: false,
        output_closed: false,
        clock: StreamClock::Undecided,
        prepared: Vec::with_capacity(BATCH),
        meta: Vec::with_capacity(BATCH),
        max_frames: req.max_frames,
    };
    if let Err(e) = w.sink.start(&info) {
        w.output_closed = true;
        w.ended = Some(sink_error(e));
    }
    watch(&mut w, req, &rx, control);
    source_stop.store(true, Ordering::Relaxed);
    drop(rx);
    let summary = w.summary(design.name.clone(), req.source.describe());
    // The output may be gone (a closed pipe): the summary is still returned.
    let _ = w.sink.finish(&summary);
    Ok(summary)
}

/// The watch's loop: batches of events until the watch ends.
fn watch(w: &mut Watch<'_>, req: &LiveRequest, rx: &Receiver<SourceEvent>, control: &LiveControl) {
    let started = Instant::now();
    let mut batch: Vec<SourceEvent> = Vec::with_capacity(BATCH);
    while w.ended.is_none() {
        if control.stopped() {
            w.ended = Some(control.stop_reason().unwrap_or_else(|| "stopped".into()));
            break;
        }
        if let Err(e) = w.requests(control) {
            w.tick(Some(e));
            break;
        }
        if let Some(d) = req.duration_s {
            if started.elapsed().as_secs_f64() >= d {
                w.ended = Some(format!("LiveRequest.duration_s {d} reached"));
                break;
            }
        }
        batch.clear();
        match rx.recv_timeout(Duration::from_millis(50)) {
            Ok(ev) => batch.push(ev),
            Err(RecvTimeoutError::Timeout) => {
                w.tick(None);
                continue;
            }
            Err(RecvTimeoutError::Disconnected) => {
                w.ended = Some("the source stopped".into());
                break;
            }
        }
        while batch.len() < BATCH {
            match rx.try_recv() {
                Ok(ev) => batch.push(ev),
                Err(_) => break,
            }
        }
        w.batch(&mut batch);
    }
}
