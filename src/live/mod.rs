//! The live mode: a running interrogator stream in, what the sensor feels out, frame
//! by frame.
//!
//! * [`source`]: where frames come from — a log file still being written (tail), standard
//!   input (one frame of peaks per line) or a Luna Hyperion peak stream over TCP
//!   ([`hyperion`] holds the protocol), read on their own thread into a bounded queue;
//! * [`interpret`]: each frame's peaks to gratings, shifts from a tare, then the
//!   array's cell loads (its default reconstruction method) or the module's
//!   temperature-compensated force per grating (predicted or calibrated K);
//! * [`stats`]: frames, drops, bad frames by kind, reconnections, latency;
//! * [`view`]: the terminal view (text heat map) and the JSON-lines stream;
//! * [`synth`]: a simulated Hyperion on loopback, for tests and demos.
//!
//! The use case is [`run`]: `fbgforge live` and the tests call it. A bad frame is
//! counted and named, never fatal; a dropped connection is reopened; frames that
//! arrive faster than they can be read are dropped at the queue and counted, so the
//! reader never falls behind the instrument.

pub mod hyperion;
pub mod interpret;
pub mod source;
pub mod stats;
pub mod synth;
pub mod view;

use anyhow::Result;
use interpret::{InterpretOptions, Interpreter, Skip};
use source::{Outlet, SourceEvent, SourceSpec};
use stats::{Dropped, LiveSummary, Stats};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, RecvTimeoutError};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use view::{FrameReading, LiveInfo, LiveSink};

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
    /// Frames the queue between reader and interpreter holds (beyond it frames are
    /// dropped and counted).
    pub queue_frames: usize,
}

impl LiveRequest {
    /// A request with every default.
    pub fn new(design: PathBuf, source: SourceSpec) -> Self {
        LiveRequest {
            design,
            source,
            interpret: InterpretOptions::default(),
            max_frames: None,
            duration_s: None,
            queue_frames: 8192,
        }
    }
}

/// Frames handled per batch at most (the interpreter solves a batch in parallel).
const BATCH: usize = 256;

fn wall_now_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// Watch a stream until it ends, `stop` is set, or a limit of the request is reached;
/// every reading, bad frame and event goes to `sink`. Returns the summary (also given to
/// the sink). Errors only for a bad request (design, options); nothing in the stream is
/// fatal.
pub fn run(req: &LiveRequest, sink: &mut dyn LiveSink, stop: &AtomicBool) -> Result<LiveSummary> {
    if let Some(d) = req.duration_s.filter(|d| !(d.is_finite() && *d > 0.0)) {
        anyhow::bail!("--duration-s must be a positive number of seconds, got {d}");
    }
    if req.queue_frames == 0 {
        anyhow::bail!("the queue must hold at least one frame");
    }
    let design = crate::design::load(&req.design)?;
    let mut interp = Interpreter::new(&design, &req.interpret)?;
    let info = LiveInfo {
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
        tare_frames: req.interpret.tare_frames,
    };
    let (tx, rx) = sync_channel(req.queue_frames);
    let source_stop = Arc::new(AtomicBool::new(false));
    let outlet = Outlet::new(tx, source_stop.clone());
    let overflow = outlet.overflow.clone();
    // The source thread is not joined: one blocked on standard input cannot be woken;
    // every other source sees `source_stop` within 200 ms and exits.
    let _reader = source::spawn(req.source.clone(), outlet);

    let mut stats = Stats::default();
    let mut connections = 0u64;
    let started = Instant::now();
    let mut first_frame: Option<Instant> = None;
    let mut last_frame: Option<Instant> = None;
    let mut ended: Option<String> = None;
    let mut batch: Vec<SourceEvent> = Vec::with_capacity(BATCH);
    let mut prepared = Vec::with_capacity(BATCH);
    let mut meta: Vec<(Option<u64>, Option<f64>, bool, Instant)> = Vec::with_capacity(BATCH);
    let sink_error = |e: std::io::Error| format!("output closed ({e})");
    if let Err(e) = sink.start(&info) {
        ended = Some(sink_error(e));
    }
    while ended.is_none() {
        if stop.load(Ordering::Relaxed) {
            ended = Some("stopped".into());
            break;
        }
        if let Some(d) = req.duration_s {
            if started.elapsed().as_secs_f64() >= d {
                ended = Some(format!("--duration-s {d} reached"));
                break;
            }
        }
        batch.clear();
        match rx.recv_timeout(Duration::from_millis(50)) {
            Ok(ev) => batch.push(ev),
            Err(RecvTimeoutError::Timeout) => {
                let el = first_frame.map_or(Duration::ZERO, |t| t.elapsed());
                stats.dropped.queue_overflow = overflow.load(Ordering::Relaxed);
                if let Err(e) = sink.tick(&stats, el) {
                    ended = Some(sink_error(e));
                }
                continue;
            }
            Err(RecvTimeoutError::Disconnected) => {
                ended = Some("the source stopped".into());
                break;
            }
        }
        while batch.len() < BATCH {
            match rx.try_recv() {
                Ok(ev) => batch.push(ev),
                Err(_) => break,
            }
        }
        prepared.clear();
        meta.clear();
        let mut out_err: Option<std::io::Error> = None;
        for ev in batch.drain(..) {
            let r = match ev {
                SourceEvent::Frame(f) => {
                    first_frame.get_or_insert(f.received);
                    last_frame = Some(f.received);
                    stats.frames_in += 1;
                    let (p, ambiguous) = interp.prepare(&f);
                    stats.ambiguous_frames += ambiguous as u64;
                    match p {
                        Ok(p) => {
                            prepared.push(p);
                            meta.push((f.serial, f.time_s, f.wall_clock, f.received));
                            Ok(())
                        }
                        Err(Skip::Tare) => {
                            stats.tare_frames += 1;
                            Ok(())
                        }
                        Err(Skip::Bad(kind, message)) => {
                            stats.bad_frames += 1;
                            let m = message.clone();
                            stats.bad.add(kind, || m);
                            sink.bad(kind, &message)
                        }
                    }
                }
                SourceEvent::Bad { kind, message } => {
                    stats.bad_frames += 1;
                    let m = message.clone();
                    stats.bad.add(&kind, || m);
                    sink.bad(&kind, &message)
                }
                SourceEvent::Missed(n) => {
                    stats.dropped.serial_gaps += n;
                    Ok(())
                }
                SourceEvent::Connected(what) => {
                    connections += 1;
                    if connections > 1 {
                        stats.reconnects += 1;
                    }
                    sink.event(
                        if connections > 1 {
                            "reconnected"
                        } else {
                            "connected"
                        },
                        &what,
                    )
                }
                SourceEvent::Disconnected(why) => {
                    let m = why.clone();
                    stats.bad.add("disconnected", || m);
                    sink.event("disconnected", &why)
                }
                SourceEvent::End(why) => {
                    ended = Some(why);
                    Ok(())
                }
            };
            if let Err(e) = r {
                out_err = Some(e);
                break;
            }
        }
        let readings = interp.solve(&prepared);
        let now = Instant::now();
        let wall = wall_now_s();
        for (reading, &(serial, time_s, wall_clock, received)) in readings.into_iter().zip(&meta) {
            if out_err.is_some() {
                break;
            }
            let latency_us = now.duration_since(received).as_secs_f64() * 1e6;
            let age_us = time_s.filter(|_| wall_clock).map(|t| (wall - t) * 1e6);
            stats.latency.add(latency_us);
            if let Some(a) = age_us {
                stats.age.add(a);
            }
            if let interpret::Reading::Loads {
                converged: false, ..
            } = reading
            {
                stats.not_converged += 1;
            }
            stats.frames_out += 1;
            let r = FrameReading {
                serial,
                time_s,
                reading,
                latency_us,
                age_us,
            };
            if let Err(e) = sink.reading(&r) {
                out_err = Some(e);
            }
            if req.max_frames.is_some_and(|m| stats.frames_out >= m) {
                ended.get_or_insert_with(|| format!("{} frames read", stats.frames_out));
                break;
            }
        }
        stats.dropped.queue_overflow = overflow.load(Ordering::Relaxed);
        let el = first_frame.map_or(Duration::ZERO, |t| t.elapsed());
        if let Some(e) = out_err {
            ended = Some(sink_error(e));
        } else if let Err(e) = sink.tick(&stats, el) {
            ended = Some(sink_error(e));
        }
    }
    source_stop.store(true, Ordering::Relaxed);
    drop(rx);
    stats.dropped.queue_overflow = overflow.load(Ordering::Relaxed);
    let elapsed_s = first_frame.map_or(0.0, |t| t.elapsed().as_secs_f64());
    // The rate over the frames themselves (not the wait for a source that ended).
    let span_s = match (first_frame, last_frame) {
        (Some(a), Some(b)) => b.duration_since(a).as_secs_f64(),
        _ => 0.0,
    };
    let d = stats.dropped;
    let summary = LiveSummary {
        design: design.name.clone(),
        source: req.source.describe(),
        ended: ended.unwrap_or_else(|| "stopped".into()),
        elapsed_s,
        frames_in: stats.frames_in,
        frames_out: stats.frames_out,
        rate_hz: if span_s > 0.0 {
            (stats.frames_in.saturating_sub(1)) as f64 / span_s
        } else {
            0.0
        },
        tare_frames: stats.tare_frames,
        bad_frames: stats.bad_frames,
        bad: stats.bad.clone(),
        ambiguous_frames: stats.ambiguous_frames,
        dropped: Dropped {
            total: d.serial_gaps + d.queue_overflow,
            ..d
        },
        reconnects: stats.reconnects,
        not_converged: stats.not_converged,
        latency: stats.latency.summary(),
        age: stats.age.summary(),
    };
    // The output may be gone (a closed pipe): the summary is still returned.
    let _ = sink.finish(&summary);
    Ok(summary)
}
