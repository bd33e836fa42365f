//! A simulated Hyperion interrogator on loopback: a design and a load script in, a
//! peak stream on `127.0.0.1` out, in the instrument's framing ([`crate::live::hyperion`]),
//! so the live mode can be tested end to end without hardware.
//!
//! Frame k is the sensor's state at t = k / rate on the script's clock (the script
//! repeats). Array frames carry each grating's shift under the scripted cell loads
//! (the design's model sensing matrix, with the array protocol's noise model, or only
//! the interrogator's resolution, or none); module frames carry K·F plus the thermal
//! shift on each strain grating (K from the same prediction `live` uses) and the
//! thermal shift on the reference. Each grating sits a fixed, seeded offset from its
//! nominal wavelength (as a printed grating does), so a tare is needed.
//!
//! The server listens on 127.0.0.1 only, serves one client at a time and stops by itself
//! after its duration (at most [`MAX_DURATION_S`]). Its frame counter ([`Pacer`]) runs
//! on one of two clocks ([`FrameClock`]): the instrument's, which keeps numbering frames
//! while no client is connected (a reconnecting client sees the gap), or the client's,
//! which counts only while a client reads, so that what a client receives does not
//! depend on when it connected or on the machine's load (the end-to-end tests' clock).

use crate::array::kernel::matrix_from_design;
use crate::array::protocol::NoiseModel;
use crate::live::hyperion::{encode_end_of_stream, encode_peaks, PeaksFrame};
use crate::live::interpret::{InterpretOptions, Interpreter};
use crate::logs::csv_table;
use crate::model::LoadCase;
use crate::spec::Design;
use anyhow::{bail, Context, Result};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// The longest a simulated stream runs, s.
pub(crate) const MAX_DURATION_S: f64 = 3600.0;
/// The fastest frame rate served, Hz.
pub(crate) const MAX_RATE_HZ: f64 = 100_000.0;
/// Interrogator resolution of the simulated instrument, pm (one standard deviation).
pub const RESOLUTION_PM: f64 = 0.5;

/// Noise on the simulated shifts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SynthNoise {
    /// None: exact shifts.
    None,
    /// The interrogator's resolution only (Gaussian, 0.5 pm).
    Resolution,
    /// Array: the reconstruction protocol's noise model (resolution, hysteresis,
    /// linearity, additivity of simultaneous loads); module: the resolution.
    Paper,
}

/// How long the server refuses connections after the deliberate drop, s.
pub const REFUSAL_S: f64 = 0.25;
/// With the client's clock: how long the server waits for a client before it gives up, s.
pub(crate) const CLIENT_WAIT_S: f64 = 30.0;

/// How the simulated instrument counts its frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrameClock {
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

/// A load script: steps held for a time each, repeated.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoadScript {
    /// Column names after `hold_s`: cell labels (g) for an array; `force_n` and
    /// `delta_t_k` for a module.
    pub columns: Vec<String>,
    /// (hold time s, value per column).
    pub steps: Vec<(f64, Vec<f64>)>,
}

impl LoadScript {
    /// Length of one pass, s.
    pub fn period_s(&self) -> f64 {
        self.steps.iter().map(|s| s.0).sum()
    }

    /// The values at time `t_s` (the script repeats).
    pub fn at(&self, t_s: f64) -> &[f64] {
        let period = self.period_s();
        let mut t = if period > 0.0 {
            t_s.rem_euclid(period)
        } else {
            0.0
        };
        for (hold, v) in &self.steps {
            if t < *hold {
                return v;
            }
            t -= hold;
        }
        &self.steps.last().expect("a script has a step").1
    }
}

/// What columns a design's script has.
fn script_columns(design: &Design) -> Result<Vec<String>> {
    if design.array.is_some() {
        Ok(matrix_from_design(design)?.0.cells)
    } else if design.module.is_some() {
        Ok(vec!["force_n".into(), "delta_t_k".into()])
    } else {
        bail!(
            "design `{}` has neither an [array] nor a [module] section",
            design.name
        )
    }
}

/// Read a load script CSV: header `hold_s,<columns…>` (array: any of the cell labels,
/// loads in g; module: `force_n` and optionally `delta_t_k`), one step per row. Columns
/// left out are 0. Errors name the file and line.
pub(crate) fn read_script(path: &Path, design: &Design) -> Result<LoadScript> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the load script {}", path.display()))?;
    parse_script(&text, path, design)
}

/// Parse a load script held in memory (see [`read_script`]); a CSV, so fields and the
/// header may be quoted.
pub fn parse_script(text: &str, path: &Path, design: &Design) -> Result<LoadScript> {
    let columns = script_columns(design)?;
    let records = csv_table::records(text, b',', path)?;
    let Some((header, rows)) = records.split_first() else {
        bail!(
            "{} is empty: expected a header `hold_s,<columns…>` and steps",
            path.display()
        );
    };
    let (hline, names) = (header.line, &header.fields);
    if names[0] != "hold_s" {
        bail!(
            "{}:{hline}: the header must start with `hold_s` (seconds each step is held), found `{}`",
            path.display(),
            names[0]
        );
    }
    let mut index = Vec::new();
    for n in &names[1..] {
        match columns.iter().position(|c| c == n) {
            Some(i) if !index.contains(&i) => index.push(i),
            Some(_) => bail!("{}:{hline}: column `{n}` appears twice", path.display()),
            None => bail!(
                "{}:{hline}: unknown column `{n}`; design `{}` takes: {}",
                path.display(),
                design.name,
                columns.join(", ")
            ),
        }
    }
    let unit = if design.array.is_some() {
        "a load in g ≥ 0"
    } else {
        "a number"
    };
    let mut steps = Vec::new();
    for rec in rows {
        let (line, fields) = (rec.line, &rec.fields);
        if fields.len() != names.len() {
            bail!(
                "{}:{line}: {} fields, expected {} (as the header)",
                path.display(),
                fields.len(),
                names.len()
            );
        }
        let hold: f64 = fields[0]
            .parse()
            .ok()
            .filter(|h: &f64| h.is_finite() && *h > 0.0)
            .with_context(|| {
                format!(
                    "{}:{line}: hold_s `{}` is not a positive number of seconds",
                    path.display(),
                    fields[0]
                )
            })?;
        let mut v = vec![0.0; columns.len()];
        for (k, f) in fields[1..].iter().enumerate() {
            let x: f64 = f
                .parse()
                .ok()
                .filter(|x: &f64| x.is_finite() && (design.array.is_none() || *x >= 0.0))
                .with_context(|| {
                    format!(
                        "{}:{line}: column `{}`: `{f}` is not {unit}",
                        path.display(),
                        names[k + 1]
                    )
                })?;
            v[index[k]] = x;
        }
        steps.push((hold, v));
    }
    if steps.is_empty() {
        bail!("{}: no steps after the header", path.display());
    }
    Ok(LoadScript { columns, steps })
}

/// How long the demo script rests at the start of each pass, s: longer than the tare
/// window (`live` takes 1 s at rest by default), so a `live` started during one of its
/// loads waits for it and tares there. Every load step is held 0.5 s, shorter than the
/// tare window, so none of them can pass for rest.
pub const DEMO_REST_S: f64 = 1.5;

/// The script used when none is given: a rest of [`DEMO_REST_S`], then each cell (or
/// force level) in turn for 0.5 s.
pub fn default_script(design: &Design) -> Result<LoadScript> {
    let columns = script_columns(design)?;
    let mut steps = vec![(DEMO_REST_S, vec![0.0; columns.len()])];
    if design.array.is_some() {
        for k in 0..columns.len() {
            let mut v = vec![0.0; columns.len()];
            v[k] = 100.0;
            steps.push((0.5, v));
        }
        let mut two = vec![0.0; columns.len()];
        two[1] = 50.0;
        two[columns.len() - 2] = 200.0;
        steps.push((0.5, two));
    } else {
        for f in [2.0, 5.0, 10.0, 5.0] {
            steps.push((0.5, vec![f, 0.0]));
        }
        steps.push((0.5, vec![5.0, 2.0]));
    }
    Ok(LoadScript { columns, steps })
}

/// What to serve.
#[derive(Debug, Clone)]
pub struct SynthRequest {
    /// The design.
    pub design: PathBuf,
    /// Load script (default: [`default_script`]).
    pub script: Option<PathBuf>,
    /// Port on 127.0.0.1 (0: any free port).
    pub port: u16,
    /// Frames per second.
    pub rate_hz: f64,
    /// How long to serve, s (at most [`MAX_DURATION_S`]).
    pub duration_s: f64,
    /// Noise.
    pub noise: SynthNoise,
    /// Seed of every random draw.
    pub seed: u64,
    /// Peaks of other sensors added to every frame (on a second channel).
    pub extra_peaks: usize,
    /// Every n-th frame is corrupted (a NaN peak, a missing grating, counts that do
    /// not match the peaks, in turn).
    pub bad_every: Option<u64>,
    /// Close the client's connection once at this time, s (and refuse connections for
    /// [`REFUSAL_S`]), to exercise reconnection.
    pub drop_after_s: Option<f64>,
    /// Whose clock numbers the frames.
    pub clock: FrameClock,
    /// Largest fabrication offset of a grating from its nominal wavelength, pm.
    pub offset_pm: f64,
    /// Module: core, case and insert (as `live` takes them).
    pub core: Option<String>,
    /// Module: load case.
    pub case: Option<LoadCase>,
    /// Module: insert.
    pub insert: Option<String>,
}

impl SynthRequest {
    /// A request with every default: 1 kHz for 10 s, paper noise, seed 1, the
    /// instrument's clock.
    pub fn new(design: PathBuf) -> Self {
        SynthRequest {
            design,
            script: None,
            port: crate::live::hyperion::PEAK_STREAM_PORT,
            rate_hz: 1000.0,
            duration_s: 10.0,
            noise: SynthNoise::Paper,
            seed: 1,
            extra_peaks: 0,
            bad_every: None,
            drop_after_s: None,
            clock: FrameClock::Instrument,
            offset_pm: 80.0,
            core: None,
            case: None,
            insert: None,
        }
    }
}

/// What kind of corruption frame `serial` carries, if any.
pub(crate) fn corruption(bad_every: Option<u64>, serial: u64) -> Option<&'static str> {
    let n = bad_every.filter(|&n| n > 0)?;
    if serial % n != n - 1 {
        return None;
    }
    Some(match (serial / n) % 3 {
        0 => "nan_peak",
        1 => "missing_peak",
        _ => "count_mismatch",
    })
}

/// Makes the frames of a simulated stream.
pub struct Generator {
    /// The script.
    pub script: LoadScript,
    /// Frames per second.
    pub rate_hz: f64,
    nominal_nm: Vec<f64>,
    offsets_nm: Vec<f64>,
    kind: GeneratorKind,
    noise: SynthNoise,
    rng: ChaCha8Rng,
    resolution: Normal<f64>,
    extra_nm: Vec<f64>,
    bad_every: Option<u64>,
}

enum GeneratorKind {
    Array {
        matrix: DMatrix<f64>,
        model: NoiseModel,
    },
    Module {
        k_pm_per_n: Vec<f64>,
        thermal_pm_per_k: Vec<f64>,
        strain_count: usize,
    },
}

impl Generator {
    /// Prepare the frames of `req`.
    pub fn new(req: &SynthRequest) -> Result<Self> {
        let design = crate::design::load(&req.design)?;
        let script = match &req.script {
            Some(p) => read_script(p, &design)?,
            None => default_script(&design)?,
        };
        Self::with_script(&design, script, req)
    }

    /// Prepare the frames of `req` for a loaded design and script.
    pub fn with_script(design: &Design, script: LoadScript, req: &SynthRequest) -> Result<Self> {
        if !(req.rate_hz.is_finite() && req.rate_hz > 0.0 && req.rate_hz <= MAX_RATE_HZ) {
            bail!(
                "SynthRequest.rate_hz must be in (0, {MAX_RATE_HZ}] frames per second, got {}",
                req.rate_hz
            );
        }
        if !(req.offset_pm.is_finite() && req.offset_pm >= 0.0) {
            bail!(
                "the grating offset must be a number of pm ≥ 0, got {}",
                req.offset_pm
            );
        }
        // The same gratings, in the same order, and the same K that `live` uses.
        let interp = Interpreter::new(
            design,
            &InterpretOptions {
                tare_frames: 0,
                core: req.core.clone(),
                case: req.case,
                insert: req.insert.clone(),
                ..InterpretOptions::default()
            },
        )?;
        let nominal_nm = interp
            .baseline_nm()
            .map(<[f64]>::to_vec)
            .unwrap_or_default();
        let mut rng = ChaCha8Rng::seed_from_u64(req.seed);
        let offsets_nm = nominal_nm
            .iter()
            .map(|_| rng.random_range(-1.0..=1.0) * req.offset_pm * 1e-3)
            .collect();
        let kind = if design.array.is_some() {
            GeneratorKind::Array {
                matrix: matrix_from_design(design)?.0.sensitivity_pm_per_g,
                model: NoiseModel::paper(),
            }
        } else {
            let k = interp.sensitivities_pm_per_n();
            GeneratorKind::Module {
                thermal_pm_per_k: nominal_nm
                    .iter()
                    .map(|&l| design.fiber.temperature_sensitivity_pm_per_k(l))
                    .collect(),
                strain_count: k.len(),
                k_pm_per_n: k,
            }
        };
        let top = nominal_nm.iter().copied().fold(0.0, f64::max);
        let extra_nm = (0..req.extra_peaks)
            .map(|i| top + 10.0 + 1.5 * i as f64)
            .collect();
        Ok(Generator {
            script,
            rate_hz: req.rate_hz,
            nominal_nm,
            offsets_nm,
            kind,
            noise: req.noise,
            rng,
            resolution: Normal::new(0.0, RESOLUTION_PM).expect("a positive deviation"),
            extra_nm,
            bad_every: req.bad_every,
        })
    }

    /// The script's values for frame `serial`.
    pub fn truth(&self, serial: u64) -> &[f64] {
        self.script.at(serial as f64 / self.rate_hz)
    }

    /// Frame `serial` (timestamped `timestamp_s`), and the corruption it carries.
    pub fn frame(&mut self, serial: u64, timestamp_s: f64) -> (PeaksFrame, Option<&'static str>) {
        let t = serial as f64 / self.rate_hz;
        let values = self.script.at(t).to_vec();
        let shifts_pm: Vec<f64> = match &self.kind {
            GeneratorKind::Array { matrix, model } => match self.noise {
                SynthNoise::Paper => model.measure(matrix, &values, &mut self.rng),
                _ => {
                    let y = matrix * nalgebra::DVector::from_column_slice(&values);
                    y.iter().copied().collect()
                }
            },
            GeneratorKind::Module {
                k_pm_per_n,
                thermal_pm_per_k,
                strain_count,
            } => {
                let (f, dt) = (values[0], values[1]);
                thermal_pm_per_k
                    .iter()
                    .enumerate()
                    .map(|(i, th)| {
                        th * dt
                            + if i < *strain_count {
                                k_pm_per_n[i] * f
                            } else {
                                0.0
                            }
                    })
                    .collect()
            }
        };
        let add_resolution = match (&self.kind, self.noise) {
            (_, SynthNoise::None) => false,
            (GeneratorKind::Array { .. }, SynthNoise::Paper) => false, // in the model already
            _ => true,
        };
        let mut peaks: Vec<f64> = Vec::with_capacity(self.nominal_nm.len() + self.extra_nm.len());
        for ((nominal, offset), shift) in
            self.nominal_nm.iter().zip(&self.offsets_nm).zip(&shifts_pm)
        {
            let noise = if add_resolution {
                self.resolution.sample(&mut self.rng)
            } else {
                0.0
            };
            peaks.push(nominal + offset + (shift + noise) * 1e-3);
        }
        // Gratings on one fiber come back in wavelength order.
        peaks.sort_by(|a, b| a.total_cmp(b));
        let mut counts = vec![peaks.len() as u16];
        if !self.extra_nm.is_empty() {
            for k in 0..self.extra_nm.len() {
                let noise = self.resolution.sample(&mut self.rng) * 1e-3;
                peaks.push(self.extra_nm[k] + noise);
            }
            counts.push(self.extra_nm.len() as u16);
        }
        let bad = corruption(self.bad_every, serial);
        match bad {
            Some("nan_peak") => peaks[0] = f64::NAN,
            Some("missing_peak") => {
                peaks.remove(0);
                counts[0] -= 1;
            }
            _ => {}
        }
        (
            PeaksFrame {
                serial_number: serial,
                timestamp_s,
                peak_counts: counts,
                peaks_nm: peaks,
            },
            bad,
        )
    }

    /// Frame `serial` as bytes on the wire (a `count_mismatch` frame announces one peak
    /// more than it carries, with its framing intact).
    pub fn encoded(&mut self, serial: u64, timestamp_s: f64) -> (Vec<u8>, Option<&'static str>) {
        let (f, bad) = self.frame(serial, timestamp_s);
        let mut bytes = encode_peaks(&f);
        if bad == Some("count_mismatch") {
            // The first channel's count sits after the 8-byte response header and the
            // 24-byte peaks header.
            let at = 8 + 24;
            let n = i16::from_le_bytes([bytes[at], bytes[at + 1]]) + 1;
            bytes[at..at + 2].copy_from_slice(&n.to_le_bytes());
        }
        (bytes, bad)
    }
}

/// What a simulated stream did.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SynthSummary {
    /// The address served.
    pub address: String,
    /// Frames generated (serial numbers used).
    pub frames_generated: u64,
    /// Frames written to a client.
    pub frames_sent: u64,
    /// Clients served.
    pub clients: u64,
    /// Corrupted frames sent, by kind.
    pub bad_sent: BTreeMap<String, u64>,
    /// Whether the connection was dropped on purpose (`drop_after_s`).
    pub dropped_connection: bool,
    /// Time served, s.
    pub duration_s: f64,
}

fn wall_now_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// The frame counter of a simulated stream: which frames are due, when the deliberate
/// drop happens, when connections are refused and when the stream ends. Every method
/// is given the time, so the counter can be driven without waiting (its tests do).
#[derive(Debug, Clone)]
pub(crate) struct Pacer {
    clock: FrameClock,
    rate_hz: f64,
    duration_s: f64,
    drop_after_s: Option<f64>,
    started: Instant,
    last: Instant,
    /// How long the counter has run, s: since the start (instrument's clock) or while a
    /// client was connected (client's clock).
    run_s: f64,
    next_serial: u64,
    /// Serials skipped at the drop (client's clock).
    skipped: u64,
    dropped: bool,
    refuse_until: Option<Instant>,
    /// The last time a client was connected, or the start.
    last_client: Instant,
}

impl Pacer {
    /// A counter starting at `now`.
    pub fn new(req: &SynthRequest, now: Instant) -> Self {
        Pacer {
            clock: req.clock,
            rate_hz: req.rate_hz,
            duration_s: req.duration_s,
            drop_after_s: req.drop_after_s,
            started: now,
            last: now,
            run_s: 0.0,
            next_serial: 0,
            skipped: 0,
            dropped: false,
            refuse_until: None,
            last_client: now,
        }
    }

    /// Serial number of the next frame (= frames numbered so far).
    pub(crate) fn next_serial(&self) -> u64 {
        self.next_serial
    }

    /// With the client's clock, the frames a stream numbers: duration × rate.
    fn total_frames(&self) -> u64 {
        (self.duration_s * self.rate_hz).round() as u64
    }

    /// With the client's clock, the serial before which the client is dropped.
    fn drop_serial(&self) -> Option<u64> {
        self.drop_after_s.map(|d| (d * self.rate_hz).round() as u64)
    }

    /// Let the clock run to `now`; `connected`: whether a client was connected since
    /// the last call.
    pub fn advance(&mut self, now: Instant, connected: bool) {
        match self.clock {
            FrameClock::Instrument => {
                self.run_s = now.saturating_duration_since(self.started).as_secs_f64();
            }
            FrameClock::Client if connected => {
                self.run_s += now.saturating_duration_since(self.last).as_secs_f64();
            }
            FrameClock::Client => {}
        }
        if connected {
            self.last_client = now;
        }
        self.last = now;
    }

    /// Whether the stream is over: its duration has passed (instrument's clock), or all
    /// its frames are numbered or no client came for [`CLIENT_WAIT_S`] (client's clock).
    pub fn finished(&self, now: Instant, connected: bool) -> bool {
        match self.clock {
            FrameClock::Instrument => self.run_s >= self.duration_s,
            FrameClock::Client => {
                let waited = now.saturating_duration_since(self.last_client);
                self.next_serial >= self.total_frames()
                    || (!connected && waited.as_secs_f64() >= CLIENT_WAIT_S)
            }
        }
    }

    /// Whether a connection may be accepted at `now` (not during the refusal).
    pub(crate) fn accepting(&self, now: Instant) -> bool {
        self.refuse_until.is_none_or(|u| now >= u)
    }

    /// Whether the connected client is to be dropped now (once per stream).
    pub(crate) fn drop_due(&self) -> bool {
        if self.dropped {
            return false;
        }
        match (self.clock, self.drop_after_s) {
            (_, None) => false,
            (FrameClock::Instrument, Some(d)) => self.run_s >= d,
            (FrameClock::Client, Some(_)) => {
                self.drop_serial().is_some_and(|d| d <= self.next_serial)
            }
        }
    }

    /// The client was dropped at `now`: refuse connections for [`REFUSAL_S`]
    /// (instrument's clock), or skip that many frames (client's clock).
    pub fn dropped(&mut self, now: Instant) {
        self.dropped = true;
        match self.clock {
            FrameClock::Instrument => {
                self.refuse_until = Some(now + Duration::from_secs_f64(REFUSAL_S));
            }
            FrameClock::Client => {
                let n = (REFUSAL_S * self.rate_hz).round() as u64;
                self.skipped += n;
                self.next_serial += n;
            }
        }
    }

    /// Number the frames due now and return their serials. With the client's clock
    /// none is due without a client, none past the drop before the drop, and none past
    /// the stream's end.
    pub(crate) fn take_due(&mut self, connected: bool) -> std::ops::Range<u64> {
        let on_clock = (self.run_s * self.rate_hz).floor() as u64 + 1;
        let due = match self.clock {
            FrameClock::Instrument => on_clock,
            FrameClock::Client if !connected => self.next_serial,
            FrameClock::Client => {
                let mut due = (on_clock + self.skipped).min(self.total_frames());
                if !self.dropped {
                    due = due.min(self.drop_serial().unwrap_or(u64::MAX));
                }
                due
            }
        };
        let first = self.next_serial;
        self.next_serial = self.next_serial.max(due);
        first..self.next_serial
    }

    /// How long to sleep before the next frame is due (at most 5 ms, so a client
    /// arriving is accepted soon).
    pub fn wait(&self) -> Duration {
        let next_at_s = (self.next_serial - self.skipped) as f64 / self.rate_hz;
        Duration::from_secs_f64((next_at_s - self.run_s).max(0.0)).min(Duration::from_millis(5))
    }
}

/// Accept a waiting client, if any, set up for streaming.
fn accept(listener: &TcpListener) -> Result<Option<TcpStream>> {
    match listener.accept() {
        Ok((s, _)) => {
            s.set_nonblocking(false)?;
            s.set_nodelay(true).ok();
            s.set_write_timeout(Some(Duration::from_secs(2))).ok();
            Ok(Some(s))
        }
        Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => Ok(None),
        Err(e) => Err(e).context("accepting a client"),
    }
}

/// Serve `req` on 127.0.0.1 until its duration is over. `on_listening` is called with
/// the bound address before the first frame (with port 0 it tells the port chosen).
pub fn serve(req: &SynthRequest, on_listening: &mut dyn FnMut(SocketAddr)) -> Result<SynthSummary> {
    if !(req.duration_s.is_finite() && req.duration_s > 0.0 && req.duration_s <= MAX_DURATION_S) {
        bail!(
            "SynthRequest.duration_s must be in (0, {MAX_DURATION_S}] seconds (the stream stops by itself), got {}",
            req.duration_s
        );
    }
    let mut gen = Generator::new(req)?;
    // Loopback only: this is a test instrument, never a server on the network.
    let listener = TcpListener::bind(("127.0.0.1", req.port))
        .with_context(|| format!("cannot listen on 127.0.0.1:{}", req.port))?;
    listener.set_nonblocking(true)?;
    let addr = listener.local_addr()?;
    on_listening(addr);
    let mut summary = SynthSummary {
        address: addr.to_string(),
        ..SynthSummary::default()
    };
    let t0 = Instant::now();
    let mut pacer = Pacer::new(req, t0);
    let mut client: Option<TcpStream> = None;
    let mut buf = Vec::new();
    loop {
        let now = Instant::now();
        pacer.advance(now, client.is_some());
        if pacer.finished(now, client.is_some()) {
            break;
        }
        if client.is_none() && pacer.accepting(now) {
            client = accept(&listener)?;
            summary.clients += u64::from(client.is_some());
        }
        if client.is_some() && pacer.drop_due() {
            if let Some(c) = client.take() {
                let _ = c.shutdown(std::net::Shutdown::Both);
            }
            summary.dropped_connection = true;
            pacer.dropped(now);
        }
        let serials = pacer.take_due(client.is_some());
        summary.frames_generated = pacer.next_serial();
        if let Some(c) = client.as_mut().filter(|_| !serials.is_empty()) {
            buf.clear();
            let mut batch_bad: Vec<&'static str> = Vec::new();
            let stamp = wall_now_s();
            let n_batch = serials.end - serials.start;
            for serial in serials {
                let (bytes, bad) = gen.encoded(serial, stamp);
                buf.extend_from_slice(&bytes);
                batch_bad.extend(bad);
            }
            match c.write_all(&buf) {
                Ok(()) => {
                    summary.frames_sent += n_batch;
                    for b in batch_bad {
                        *summary.bad_sent.entry(b.to_string()).or_default() += 1;
                    }
                }
                Err(_) => client = None,
            }
        }
        let wait = pacer.wait();
        if !wait.is_zero() {
            std::thread::sleep(wait);
        }
    }
    summary.duration_s = t0.elapsed().as_secs_f64();
    // Close the listener before the client, so a client that reconnects at once is
    // refused rather than accepted by the closing socket.
    drop(listener);
    // The stream is finite: say so, so the client ends rather than reconnecting.
    if let Some(mut c) = client {
        let why = format!(
            "fbgforge synth-stream served its {} s ({} frames)",
            req.duration_s, summary.frames_generated
        );
        let _ = c.write_all(&encode_end_of_stream(&why));
        let _ = c.flush();
        let _ = c.shutdown(std::net::Shutdown::Write);
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::live::hyperion::StreamDecoder;

    fn array() -> Design {
        crate::design::parse(include_str!("../../../designs/tactile-array-60x80.toml")).unwrap()
    }

    #[test]
    fn scripts_are_read_by_column_name_and_repeat() {
        let d = array();
        let s = parse_script(
            "# steps\nhold_s,C,A\n0.5,0,0\n1.0,100,25\n",
            Path::new("s.csv"),
            &d,
        )
        .unwrap();
        assert_eq!(s.period_s(), 1.5);
        assert_eq!(s.at(0.2), &[0.0; 8]);
        assert_eq!(s.at(0.7)[0], 25.0);
        assert_eq!(s.at(0.7)[2], 100.0);
        assert_eq!(s.at(1.5 + 0.2), &[0.0; 8]);
        let e = parse_script("hold_s,Z\n1,2\n", Path::new("s.csv"), &d)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("unknown column `Z`") && e.contains("A, B, C"),
            "{e}"
        );
        let e = parse_script("hold_s,A\n1,-5\n", Path::new("s.csv"), &d)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.csv:2") && e.contains("not a load in g"),
            "{e}"
        );
        let e = parse_script("time,A\n1,5\n", Path::new("s.csv"), &d)
            .unwrap_err()
            .to_string();
        assert!(e.contains("must start with `hold_s`"), "{e}");
        let e = parse_script("hold_s,A\n0,5\n", Path::new("s.csv"), &d)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a positive number of seconds"), "{e}");
    }

    /// Drive a pacer as `serve` does, on made-up time: `steps` are the seconds between
    /// turns of the loop; a client connects once `connect_after_s` have passed and again
    /// at the first turn it may after the drop. Returns the serials the client got and
    /// the frames numbered.
    fn drive(req: &SynthRequest, steps: &[f64], connect_after_s: f64) -> (Vec<u64>, u64) {
        let t0 = Instant::now();
        let mut p = Pacer::new(req, t0);
        let (mut now, mut connected, mut got) = (t0, false, Vec::new());
        for dt in steps.iter().cycle() {
            now += Duration::from_secs_f64(*dt);
            p.advance(now, connected);
            if p.finished(now, connected) {
                return (got, p.next_serial());
            }
            let late_enough = now.duration_since(t0).as_secs_f64() >= connect_after_s;
            if !connected && late_enough && p.accepting(now) {
                connected = true;
            }
            if connected && p.drop_due() {
                connected = false;
                p.dropped(now);
            }
            let serials = p.take_due(connected);
            if connected {
                got.extend(serials);
            }
        }
        unreachable!("a cycle never ends")
    }

    /// Loop turns of a loaded machine: mostly a few ms apart, now and then stalled.
    fn uneven_steps(seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..500)
            .map(|_| {
                if rng.random_bool(0.02) {
                    rng.random_range(0.1..1.5)
                } else {
                    rng.random_range(0.0..0.006)
                }
            })
            .collect()
    }

    #[test]
    fn the_clients_clock_gives_every_client_the_same_frames_under_any_timing() {
        let mut req = SynthRequest::new(PathBuf::from("unused"));
        req.rate_hz = 500.0;
        req.duration_s = 2.0;
        req.drop_after_s = Some(0.8);
        req.clock = FrameClock::Client;
        // 1000 frames; the client is dropped after 400 and 125 (0.25 s) are skipped.
        let want: Vec<u64> = (0..400).chain(525..1000).collect();
        for (seed, connect_after_s) in [(1, 0.0), (2, 3.0), (3, 0.37)] {
            let (got, numbered) = drive(&req, &uneven_steps(seed), connect_after_s);
            assert_eq!(numbered, 1000, "seed {seed}");
            assert_eq!(got, want, "seed {seed}, client after {connect_after_s} s");
        }
        // Steady 1 ms turns give the same.
        assert_eq!(drive(&req, &[1e-3], 0.0).0, want);
    }

    #[test]
    fn the_instruments_clock_numbers_frames_nobody_reads() {
        let mut req = SynthRequest::new(PathBuf::from("unused"));
        req.rate_hz = 500.0;
        req.duration_s = 2.0;
        req.drop_after_s = Some(0.8);
        let (got, numbered) = drive(&req, &[1e-3], 0.5);
        // The frames of the first half second passed before the client came, and a
        // quarter second's worth while it was refused after the drop.
        assert!((249..=251).contains(&got[0]), "{}", got[0]);
        let hole: u64 = got.windows(2).map(|w| w[1] - w[0] - 1).sum();
        assert!((124..=127).contains(&hole), "{hole}");
        assert!((999..=1001).contains(&numbered), "{numbered}");
        assert_eq!(got.len() as u64, numbered - got[0] - hole);
    }

    #[test]
    fn a_quoted_script_reads_as_a_plain_one() {
        let d = array();
        let p = Path::new("s.csv");
        let plain = parse_script("hold_s,C,A\n0.5,0,0\n1.0,100,25\n", p, &d).unwrap();
        let quoted = parse_script(
            "\u{feff}\"hold_s\",\"C\",\"A\"\r\n\"0.5\",\"0\",\"0\"\r\n\"1.0\",\"100\",\"25\"\r\n",
            p,
            &d,
        )
        .unwrap();
        assert_eq!(quoted, plain);
        let e = parse_script("\"hold_s\",\"A\"\n\n\"1\",\"-5\"\n", p, &d)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.csv:3") && e.contains("column `A`: `-5` is not a load in g"),
            "{e}"
        );
        let e = parse_script("\"hold_s\",\"Z\"\n1,2\n", p, &d)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.csv:1") && e.contains("unknown column `Z`"),
            "{e}"
        );
    }

    #[test]
    fn noise_free_frames_carry_the_model_shifts_and_corruptions_decode_as_bad() {
        let d = array();
        let script = parse_script("hold_s,B\n1,150\n", Path::new("s.csv"), &d).unwrap();
        let mut req = SynthRequest::new(PathBuf::from("unused"));
        req.noise = SynthNoise::None;
        req.offset_pm = 0.0;
        req.extra_peaks = 3;
        req.bad_every = Some(4);
        let mut g = Generator::with_script(&d, script, &req).unwrap();
        let (m, _) = matrix_from_design(&d).unwrap();
        let (f, bad) = g.frame(0, 1.0);
        assert_eq!(bad, None);
        assert_eq!(f.peak_counts, vec![6, 3]);
        let nominal: Vec<f64> = d
            .array
            .as_ref()
            .unwrap()
            .gratings
            .iter()
            .map(|g| g.bragg_wavelength_nm)
            .collect();
        for (i, l) in nominal.iter().enumerate() {
            let want = l + m.sensitivity_pm_per_g[(i, 1)] * 150.0 * 1e-3;
            assert!(
                f.peaks_nm.iter().any(|p| (p - want).abs() < 1e-9),
                "grating {i}"
            );
        }
        // Frames 3, 7, 11 carry the three corruptions in turn.
        let mut dec = StreamDecoder::new();
        let mut kinds = Vec::new();
        for serial in 0..12 {
            let (bytes, bad) = g.encoded(serial, 1.0);
            dec.push(&bytes);
            let r = dec.next_frame().unwrap();
            match bad {
                None => assert!(r.is_ok()),
                Some("missing_peak") => assert_eq!(r.unwrap().peaks_nm.len(), 8),
                Some(_) => assert_eq!(r.unwrap_err().kind(), "malformed_frame"),
            }
            kinds.extend(bad);
        }
        assert_eq!(kinds, vec!["nan_peak", "missing_peak", "count_mismatch"]);
    }
}
