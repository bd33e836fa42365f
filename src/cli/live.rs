//! `fbgforge live` and `fbgforge synth-stream`: a running interrogator stream read
//! frame by frame (the work is `fbgforge::live::run`), and a simulated Hyperion on
//! loopback to test it against (`fbgforge::synth::stream::serve`).

mod steer;

use super::log_args::{read_options, DateOrderArg, LogFormatArg};
use super::predict::{CaseArg, FidelityArg};
use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use fbgforge::live::control::LiveControl;
use fbgforge::live::interpret::{calibration_from_verify_json, InterpretOptions};
use fbgforge::live::sink::LiveSink;
use fbgforge::live::source::{SourceOptions, SourceSpec};
use fbgforge::live::{self, LiveRequest};
use fbgforge::model::LoadCase;
use fbgforge::report::live::publish::{McapSink, WebSink};
use fbgforge::report::live::record::{shifts_path, RecordSink};
use fbgforge::report::live::{summary_text_in, JsonlSink, TerminalSink};
use fbgforge::synth::stream::{self as synth, FrameClock, SynthNoise, SynthRequest};
use std::collections::BTreeMap;
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

/// These subcommands' request fields and the flags that fill them (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[
    // live
    ("LiveRequest.source", "--from"),
    ("LiveRequest.duration_s", "--duration-s"),
    ("LiveRequest.max_frames", "--frames"),
    ("LiveRequest.queue_frames", "--queue"),
    ("LiveRequest.realtime", "--realtime"),
    ("SourceOptions.give_up_s", "--give-up-s"),
    ("SourceOptions.idle_exit_s", "--idle-exit-s"),
    ("SourceOptions.from_start", "--from-start"),
    ("InterpretOptions.insert", "--insert"),
    ("InterpretOptions.case", "--case"),
    ("InterpretOptions.core", "--core"),
    ("InterpretOptions.method", "--method"),
    ("InterpretOptions.resolution_pm", "--resolution-pm"),
    ("InterpretOptions.budget_us", "--budget-us"),
    ("InterpretOptions.window_half_width_nm", "--window-nm"),
    ("InterpretOptions.tare_frames", "--tare-frames"),
    ("InterpretOptions.tare_s", "--tare-s"),
    ("InterpretOptions.tare_wait_s", "--tare-wait-s"),
    // synth-stream
    ("SynthRequest.rate_hz", "--rate-hz"),
    ("SynthRequest.duration_s", "--duration-s"),
];

/// A library text in this file's flags ([`FLAGS`]): what the sinks write.
fn in_flag_words(text: &str) -> String {
    fbgforge::fields::in_words(text, FLAGS)
}

/// Noise of the simulated stream on the command line ([`SynthNoise`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SynthNoiseArg {
    /// None: exact shifts.
    None,
    /// The interrogator's resolution only (Gaussian, 0.5 pm).
    Resolution,
    /// Array: the reconstruction protocol's noise model (resolution, hysteresis,
    /// linearity, additivity of simultaneous loads); module: the resolution.
    Paper,
}

impl From<SynthNoiseArg> for SynthNoise {
    fn from(n: SynthNoiseArg) -> Self {
        match n {
            SynthNoiseArg::None => SynthNoise::None,
            SynthNoiseArg::Resolution => SynthNoise::Resolution,
            SynthNoiseArg::Paper => SynthNoise::Paper,
        }
    }
}

/// Whose clock numbers the simulated frames, on the command line ([`FrameClock`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FrameClockArg {
    /// As an instrument does: frame k is due k / rate after the server starts, read or
    /// not. A client that connects late or reconnects misses frames, and how many
    /// depends on when it (re)connects.
    Instrument,
    /// Only while a client reads: frame 0 goes to the first client, the count stands
    /// still while no client is connected, the deliberate drop skips exactly
    /// [`REFUSAL_S`] × rate frames, and the stream ends after exactly duration × rate
    /// frames. What a client receives is the same on any machine under any load.
    Client,
}

impl From<FrameClockArg> for FrameClock {
    fn from(c: FrameClockArg) -> Self {
        match c {
            FrameClockArg::Instrument => FrameClock::Instrument,
            FrameClockArg::Client => FrameClock::Client,
        }
    }
}

/// Exit status of `fbgforge live` when the source was lost: reconnecting (or
/// connecting) to the instrument was given up after `--give-up-s`, or the followed log
/// could no longer be read (deleted while it was followed). A supervisor restarts on
/// it; 0 is a clean end.
pub const EXIT_SOURCE_LOST: u8 = 3;

/// Arguments of `fbgforge live`.
#[derive(Debug, Args)]
#[command(
    after_help = "Exit status: 0 when the run ended as asked or as its source did: the \
stream's end (a file or standard input read to its end, --idle-exit-s, a finite stream \
such as synth-stream ending), a limit (--frames, --duration-s), a stop (Ctrl-C, SIGTERM, \
SIGHUP, q, a `stop` control line) or its output closed (a pipe whose reader ended); the \
summary is printed in every case, on standard error where standard output is gone. 1 for \
a bad request (design, options, a source file that does not exist). 3 when the source was \
lost: the instrument could not be (re)connected within --give-up-s, or the followed log \
could no longer be read (deleted).

Keys in the terminal view (when standard input is a terminal): t tare again, q quit. \
Control lines (--control): `tare`, `stop`."
)]
pub struct LiveArgs {
    /// Design spec (TOML) or a shipped design's name: an array (cell loads) or a
    /// module (force per grating).
    #[arg(value_parser = super::designs::design_arg)]
    pub design: PathBuf,
    /// Where the frames come from: a log file being written (ENLIGHT, I-MON, CSV;
    /// followed as it grows), `-` for standard input (one frame of peak wavelengths in
    /// nm per line), or `hyperion://HOST[:PORT]` / `tcp://HOST:PORT` for a Hyperion peak
    /// stream (port 51972 by default).
    #[arg(long = "from", value_name = "SOURCE")]
    pub from: String,
    /// One JSON object per line (start, frame, bad, event, summary) instead of the
    /// terminal view.
    #[arg(long)]
    pub jsonl: bool,
    /// Frames the tare window holds at least (at least 8); the tare is taken only when
    /// every grating's spread and trend over the window are within --resolution-pm.
    #[arg(long, default_value_t = 50)]
    pub tare_frames: usize,
    /// Frame time the tare window spans at least, s.
    #[arg(long, default_value_t = 1.0)]
    pub tare_s: f64,
    /// After the first full tare window, wait this long for one at rest, s; then refuse
    /// to show loads (naming the moving gratings) until a re-tare.
    #[arg(long, default_value_t = 30.0)]
    pub tare_wait_s: f64,
    /// Take shifts from the design's nominal wavelengths instead of a tare.
    #[arg(long, conflicts_with = "tare_frames")]
    pub no_tare: bool,
    /// Record the raw peaks (each grating's wavelength, nm, the frame serials, the tare
    /// and every re-tare marked) as a CSV log that verify, calibrate-array and live read
    /// back; an array also writes STEM.shifts.csv for reconstruct --shifts.
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// Record ROS 2 messages (CDR) in an MCAP file: a module's force per core on
    /// /fbgforge/<core>/wrench, an array's cells and contact, peaks, flags, tare.
    #[arg(long, value_name = "FILE")]
    pub mcap: Option<PathBuf>,
    /// Serve a browser view on HOST:PORT (e.g. 127.0.0.1:8642; port 0 picks one): the
    /// heat map or force traces, flags and tare state, updated live.
    #[arg(long, value_name = "HOST:PORT")]
    pub serve: Option<String>,
    /// Read control lines (`tare`, `stop`) from this file or named pipe as they are
    /// written, or `-` for standard input (when the frames do not come from it).
    #[arg(long, value_name = "FILE")]
    pub control: Option<String>,
    /// A file or standard input: read at the pace it comes, dropping (and counting)
    /// frames that find the queue full, as for an instrument. Default: every frame.
    #[arg(long)]
    pub realtime: bool,
    /// Half-width of each grating's wavelength window, nm (default: half the smallest
    /// spacing, at most 2.5 nm).
    #[arg(long)]
    pub window_nm: Option<f64>,
    /// Array: reconstruction method (default: the array's default method).
    #[arg(long)]
    pub method: Option<String>,
    /// Array: the interrogator's resolution, the noise standard deviation of a shift,
    /// pm; sets the ℓ0 penalty of support and bnb to 16 × resolution², as in
    /// `reconstruct` (default: the paper's 0.5 pm, λ = 4).
    #[arg(long, default_value_t = 0.5)]
    pub resolution_pm: f64,
    /// Array: per-frame time budget of the default method choice, µs (10 000
    /// frames/s on one thread by default). Ignored with --method.
    #[arg(long, default_value_t = 100.0)]
    pub budget_us: f64,
    /// Module: the core plugged in (default: the design's first core).
    #[arg(long)]
    pub core: Option<String>,
    /// Module: load case (default: I with --insert, II without).
    #[arg(long, value_enum)]
    pub case: Option<CaseArg>,
    /// Module: the insert (Case I).
    #[arg(long)]
    pub insert: Option<String>,
    /// Module: which model predicts K.
    #[arg(long, value_enum, default_value_t = FidelityArg::Auto)]
    pub fidelity: FidelityArg,
    /// Module: a calibrated K, `GRATING=PM_PER_N` (repeatable); replaces the prediction.
    #[arg(
        long = "k",
        value_name = "GRATING=PM_PER_N",
        allow_hyphen_values = true
    )]
    pub k: Vec<String>,
    /// Module: calibrated K from a `fbgforge verify --json` report.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Log file: format (detected if omitted).
    #[arg(long, value_enum)]
    pub format: Option<LogFormatArg>,
    #[command(flatten)]
    pub spectrum: super::log_args::SpectrumArgs,
    /// Log file: order of day and month in slash dates.
    #[arg(long, value_enum)]
    pub date_order: Option<DateOrderArg>,
    /// Log file: replay the rows already written (default: only new rows).
    #[arg(long)]
    pub from_start: bool,
    /// Log file: stop when it has not grown for this long, s.
    #[arg(long)]
    pub idle_exit_s: Option<f64>,
    /// Hyperion: stop after failing to (re)connect for this long, s.
    #[arg(long, default_value_t = 30.0)]
    pub give_up_s: f64,
    /// Stop after this many readings.
    #[arg(long)]
    pub frames: Option<u64>,
    /// Stop after this long, s.
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Frames the queue holds: an instrument's frames that find it full are dropped
    /// (and counted); a file or standard input waits, unless --realtime.
    #[arg(long, default_value_t = 8192)]
    pub queue: usize,
}

fn parse_k(items: &[String]) -> Result<BTreeMap<String, f64>> {
    let mut out = BTreeMap::new();
    for item in items {
        let Some((name, v)) = item.split_once('=') else {
            bail!("--k `{item}`: expected GRATING=PM_PER_N, e.g. --k lambda_21=-170.5");
        };
        let k: f64 = v
            .trim()
            .parse()
            .map_err(|_| anyhow::anyhow!("--k `{item}`: `{v}` is not a number of pm/N"))?;
        if !(k.is_finite() && k != 0.0) {
            bail!("--k `{item}`: K must be a finite, non-zero number of pm/N");
        }
        out.insert(name.trim().to_string(), k);
    }
    Ok(out)
}

fn case(c: Option<CaseArg>) -> Option<LoadCase> {
    c.map(LoadCase::from)
}

/// Stop on SIGINT (Ctrl-C), SIGTERM and SIGHUP: the run ends with its summary.
fn stop_on_signals(control: &Arc<LiveControl>) {
    let c = control.clone();
    // Failing to install the handler only loses the summary on a signal.
    let _ = ctrlc::set_handler(move || {
        c.stop_because("stopped by a signal (SIGINT, SIGTERM or SIGHUP)")
    });
}

/// The request from the flags.
fn live_request(a: &LiveArgs) -> Result<LiveRequest> {
    let source = SourceSpec::parse(
        &a.from,
        SourceOptions {
            read: read_options(a.format, a.date_order, &a.spectrum),
            from_start: a.from_start,
            idle_exit_s: a.idle_exit_s,
            give_up_s: a.give_up_s,
        },
    )?;
    let mut calibrated = match &a.calibration {
        Some(p) => calibration_from_verify_json(p)?,
        None => BTreeMap::new(),
    };
    calibrated.extend(parse_k(&a.k)?);
    let mut req = LiveRequest::new(a.design.clone(), source);
    req.interpret = InterpretOptions {
        tare_frames: if a.no_tare { 0 } else { a.tare_frames },
        tare_s: a.tare_s,
        tare_wait_s: a.tare_wait_s,
        window_half_width_nm: a.window_nm,
        core: a.core.clone(),
        case: case(a.case),
        insert: a.insert.clone(),
        fidelity: a.fidelity.into(),
        calibrated_k_pm_per_n: calibrated,
        method: a.method.clone(),
        resolution_pm: a.resolution_pm,
        budget_us: a.budget_us,
    };
    req.max_frames = a.frames;
    req.duration_s = a.duration_s;
    req.queue_frames = a.queue;
    req.realtime = a.realtime;
    req.validate()?;
    Ok(req)
}

/// The outputs besides the view: the record, the MCAP file, the browser view. Each
/// fails here, naming its file or address, before the run starts.
fn extra_sinks(a: &LiveArgs) -> Result<Vec<Box<dyn LiveSink>>> {
    let mut sinks: Vec<Box<dyn LiveSink>> = Vec::new();
    if let Some(p) = &a.record {
        sinks.push(Box::new(RecordSink::create(p).map_err(|e| {
            anyhow::anyhow!("--record: cannot write {}: {e}", p.display())
        })?));
    }
    if let Some(p) = &a.mcap {
        sinks.push(Box::new(McapSink::create(p).map_err(|e| {
            anyhow::anyhow!("--mcap: cannot write {}: {e}", p.display())
        })?));
    }
    if let Some(addr) = &a.serve {
        let view = fbgforge::publish::serve(addr.as_str())
            .map_err(|e| anyhow::anyhow!("--serve {addr}: cannot listen: {e}"))?;
        let web = WebSink::new(view);
        eprintln!("browser view: {}", web.url());
        sinks.push(Box::new(web));
    }
    Ok(sinks)
}

/// Run `fbgforge live`. Exit status 0 when the run ended as asked or as its source did
/// (bad and dropped frames are reported, not fatal), [`EXIT_SOURCE_LOST`] when the
/// source was lost.
pub fn run_live(a: LiveArgs) -> Result<ExitCode> {
    let req = live_request(&a)?;
    let control = Arc::new(LiveControl::new());
    if let Some(c) = &a.control {
        if c == "-" && a.from == "-" {
            bail!("--control -: standard input already carries the frames (--from -); give the control a file or named pipe");
        }
        steer::control_input(c, &control)?;
    }
    let extra = extra_sinks(&a)?;
    // A closed output is an error to write to, not a kill: the run ends with its
    // summary (on standard error) and its files finished.
    steer::ignore_sigpipe();
    stop_on_signals(&control);
    let stdout = std::io::stdout();
    let tty = stdout.is_terminal();
    let keys = !a.jsonl && tty && a.from != "-" && a.control.as_deref() != Some("-");
    let _keys = if keys { steer::keys(&control) } else { None };
    let view: Box<dyn LiveSink> = if a.jsonl {
        Box::new(JsonlSink::new(std::io::BufWriter::new(stdout.lock())).with_words(in_flag_words))
    } else {
        Box::new(
            TerminalSink::new(std::io::BufWriter::new(stdout.lock()), tty)
                .with_words(in_flag_words)
                .with_keys(_keys.is_some()),
        )
    };
    let mut sinks: Vec<Box<dyn LiveSink>> = vec![view];
    sinks.extend(extra);
    let summary = live::run(&req, &mut sinks, &control)?;
    drop(sinks);
    drop(_keys);
    if a.jsonl || summary.output_closed {
        // The summary is the last JSON line, or standard output is gone: say it for a
        // person on standard error.
        eprintln!("{}", summary_text_in(&summary, in_flag_words));
    }
    if let Some(p) = &a.record {
        if p.exists() {
            eprintln!("recorded the peaks in {}", p.display());
            let shifts = shifts_path(p);
            if shifts.exists() {
                eprintln!("recorded the shifts in {}", shifts.display());
            }
        }
    }
    if summary.source_lost {
        return Ok(ExitCode::from(EXIT_SOURCE_LOST));
    }
    Ok(ExitCode::SUCCESS)
}

/// Arguments of `fbgforge synth-stream`.
#[derive(Debug, Args)]
pub struct SynthStreamArgs {
    /// Design spec (TOML) or a shipped design's name: an array or a module.
    #[arg(value_parser = super::designs::design_arg)]
    pub design: PathBuf,
    /// Load script CSV: `hold_s,<cells…>` (g) for an array, `hold_s,force_n[,delta_t_k]`
    /// for a module; repeated for the whole run (default: a built-in demo script).
    #[arg(long)]
    pub script: Option<PathBuf>,
    /// Port on 127.0.0.1 (0: any free port; the port is printed first).
    #[arg(long, default_value_t = fbgforge::live::hyperion::PEAK_STREAM_PORT)]
    pub port: u16,
    /// Frames per second.
    #[arg(long, default_value_t = 1000.0)]
    pub rate_hz: f64,
    /// How long to serve, s (the stream stops by itself; at most 3600).
    #[arg(long, default_value_t = 10.0)]
    pub duration_s: f64,
    /// Noise on the shifts.
    #[arg(long, value_enum, default_value_t = SynthNoiseArg::Paper)]
    pub noise: SynthNoiseArg,
    /// Seed of every random draw.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Peaks of other sensors added to every frame (on a second channel).
    #[arg(long, default_value_t = 0)]
    pub extra_peaks: usize,
    /// Corrupt every n-th frame (a NaN peak, a missing grating, a count mismatch).
    #[arg(long)]
    pub bad_every: Option<u64>,
    /// Drop the client's connection once at this time, s.
    #[arg(long)]
    pub drop_after_s: Option<f64>,
    /// Whose clock numbers the frames: the instrument's (frames pass while no client
    /// reads them, as with the real one) or the client's (the count stands still
    /// without a client, so a client gets the same frames on any machine: for tests).
    #[arg(long, value_enum, default_value_t = FrameClockArg::Instrument)]
    pub frame_clock: FrameClockArg,
    /// Largest offset of a grating from its nominal wavelength, pm.
    #[arg(long, default_value_t = 80.0)]
    pub offset_pm: f64,
    /// Module: the core plugged in (default: the first).
    #[arg(long)]
    pub core: Option<String>,
    /// Module: load case.
    #[arg(long, value_enum)]
    pub case: Option<CaseArg>,
    /// Module: the insert (Case I).
    #[arg(long)]
    pub insert: Option<String>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Run `fbgforge synth-stream`.
pub fn run_synth_stream(a: SynthStreamArgs) -> Result<ExitCode> {
    let req = SynthRequest {
        script: a.script,
        port: a.port,
        rate_hz: a.rate_hz,
        duration_s: a.duration_s,
        noise: a.noise.into(),
        seed: a.seed,
        extra_peaks: a.extra_peaks,
        bad_every: a.bad_every,
        drop_after_s: a.drop_after_s,
        clock: a.frame_clock.into(),
        offset_pm: a.offset_pm,
        core: a.core,
        case: case(a.case),
        insert: a.insert,
        ..SynthRequest::new(a.design)
    };
    let summary = synth::serve(&req, &mut |addr| {
        println!("listening on {addr}");
        let _ = std::io::stdout().flush();
    })?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        println!(
            "served {} of {} frames to {} client(s) in {:.2} s{}",
            summary.frames_sent,
            summary.frames_generated,
            summary.clients,
            summary.duration_s,
            if summary.bad_sent.is_empty() {
                String::new()
            } else {
                format!("; corrupted: {:?}", summary.bad_sent)
            }
        );
    }
    Ok(ExitCode::SUCCESS)
}
