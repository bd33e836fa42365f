//! `fbgforge live` and `fbgforge synth-stream`: a running interrogator stream read
//! frame by frame (the work is `fbgforge::live::run`), and a simulated Hyperion on
//! loopback to test it against (`fbgforge::synth::stream::serve`).

use super::predict::{CaseArg, FidelityArg};
use super::verify::{read_options, DateOrderArg, LogFormatArg};
use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use fbgforge::live::interpret::{calibration_from_verify_json, InterpretOptions};
use fbgforge::live::sink::LiveSink;
use fbgforge::live::source::{SourceOptions, SourceSpec};
use fbgforge::live::{self, LiveRequest};
use fbgforge::model::LoadCase;
use fbgforge::report::live::{summary_text_in, JsonlSink, TerminalSink};
use fbgforge::synth::stream::{self as synth, FrameClock, SynthNoise, SynthRequest};
use std::collections::BTreeMap;
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// These subcommands' request fields and the flags that fill them (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[
    // live
    ("LiveRequest.source", "--from"),
    ("LiveRequest.duration_s", "--duration-s"),
    ("LiveRequest.max_frames", "--frames"),
    ("LiveRequest.queue_frames", "--queue"),
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
/// could no longer be read. A supervisor restarts on it; 0 is a clean end.
pub const EXIT_SOURCE_LOST: u8 = 3;

/// Arguments of `fbgforge live`.
#[derive(Debug, Args)]
#[command(
    after_help = "Exit status: 0 when the stream was read to its end or a limit (--frames, \
--duration-s, --idle-exit-s, Ctrl-C); 1 for a bad request (design, options); 3 when the source \
was lost: the instrument could not be (re)connected within --give-up-s, or the followed log \
could no longer be read."
)]
pub struct LiveArgs {
    /// Design spec (TOML): an array (cell loads) or a module (force per grating).
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
    /// Frames averaged as the zero-load baseline; keep the sensor unloaded meanwhile.
    #[arg(long, default_value_t = 50)]
    pub tare_frames: usize,
    /// Take shifts from the design's nominal wavelengths instead of a tare.
    #[arg(long, conflicts_with = "tare_frames")]
    pub no_tare: bool,
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
    pub spectrum: super::peaks::SpectrumArgs,
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
    /// Frames the queue holds before frames are dropped (and counted).
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

/// Stop on Ctrl-C (the summary is still printed).
fn stop_flag() -> Arc<AtomicBool> {
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    // Failing to install the handler only loses the summary on Ctrl-C.
    let _ = ctrlc::set_handler(move || s.store(true, Ordering::Relaxed));
    stop
}

/// Run `fbgforge live`. Exit status 0 when the stream was read to its end or a limit
/// (bad and dropped frames are reported, not fatal), [`EXIT_SOURCE_LOST`] when the
/// source was lost.
pub fn run_live(a: LiveArgs) -> Result<ExitCode> {
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
    let stop = stop_flag();
    let stdout = std::io::stdout();
    let mut sink: Box<dyn LiveSink> = if a.jsonl {
        Box::new(JsonlSink::new(std::io::BufWriter::new(stdout.lock())).with_words(in_flag_words))
    } else {
        let tty = stdout.is_terminal();
        Box::new(
            TerminalSink::new(std::io::BufWriter::new(stdout.lock()), tty)
                .with_words(in_flag_words),
        )
    };
    let summary = live::run(&req, sink.as_mut(), &stop)?;
    drop(sink);
    if a.jsonl {
        // The summary is the last JSON line; say it for a person too.
        eprintln!("{}", summary_text_in(&summary, in_flag_words));
    }
    if summary.source_lost {
        return Ok(ExitCode::from(EXIT_SOURCE_LOST));
    }
    Ok(ExitCode::SUCCESS)
}

/// Arguments of `fbgforge synth-stream`.
#[derive(Debug, Args)]
pub struct SynthStreamArgs {
    /// Design spec (TOML): an array or a module.
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
