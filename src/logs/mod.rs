//! Readers for interrogator and force-stand logs, with format detection.
//!
//! Every wavelength log, whatever its format, becomes a [`PeakLog`]: one timestamp per
//! row and a ragged list of peak wavelengths (nm) per row, each tagged with the
//! channel (or column) it came from. Which peak belongs to which grating is decided
//! later ([`crate::verify::assign`]) from the design's nominal wavelengths, so a
//! reader never has to guess grating names.
//!
//! Formats (see `docs/verify.md` for examples of each):
//! - [`LogFormat::EnlightPeaks`]: Micron Optics / Luna ENLIGHT "Peaks" export;
//! - [`LogFormat::EnlightSensors`]: ENLIGHT "Sensors" export (one column per sensor);
//! - [`LogFormat::Imon`]: Ibsen I-MON evaluation software log;
//! - [`LogFormat::Csv`]: plain delimited text, a time column then wavelength columns.
//!
//! Force-stand logs are read by [`read_force_log`].
//!
//! Unreadable rows are skipped and counted ([`LogWarnings`]); a file where more than
//! half of the table is unreadable, or with no table at all, is an error that names the
//! file and the first bad line. Nothing here panics on user input.

pub mod num;
mod table;

use anyhow::{bail, Context, Result};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use table::{detect_format, parse_force_bytes, parse_wavelength_bytes};
pub use table::{LogRow, RowReader};

/// A supported wavelength log format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum LogFormat {
    /// ENLIGHT "Peaks" export: timestamp, peak count per channel, then the peaks.
    EnlightPeaks,
    /// ENLIGHT "Sensors" export: timestamp then one column per sensor.
    EnlightSensors,
    /// Ibsen I-MON log: date, time, then a varying number of wavelengths.
    Imon,
    /// Plain CSV (or TSV / semicolon-separated): time then wavelength columns, nm.
    Csv,
}

impl LogFormat {
    /// Every format, for loops in tests and benchmarks.
    pub const ALL: [LogFormat; 4] = [
        LogFormat::EnlightPeaks,
        LogFormat::EnlightSensors,
        LogFormat::Imon,
        LogFormat::Csv,
    ];

    /// Name as used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            LogFormat::EnlightPeaks => "enlight-peaks",
            LogFormat::EnlightSensors => "enlight-sensors",
            LogFormat::Imon => "imon",
            LogFormat::Csv => "csv",
        }
    }

    /// Resolution of the interrogator that usually writes this format, pm (SM125:
    /// 1 pm; I-MON 512E: < 0.5 pm). Used for the resolution figure unless overridden.
    pub fn typical_resolution_pm(self) -> f64 {
        match self {
            LogFormat::Imon => 0.5,
            _ => 1.0,
        }
    }
}

/// Whether times are wall-clock readings or seconds from the start of a recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Clock {
    /// Seconds since 1970-01-01 of the recording PC's local wall clock.
    Absolute,
    /// Seconds from an arbitrary origin (usually the start of the recording).
    Relative,
}

/// Counted, non-fatal problems found while reading a log.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct LogWarnings {
    /// kind → (count, first example with its line number).
    pub counts: BTreeMap<String, WarningCount>,
}

/// One kind of warning: how often, and the first occurrence.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WarningCount {
    /// How many times it occurred.
    pub count: usize,
    /// The first occurrence, naming file and line where known.
    pub first: String,
}

impl LogWarnings {
    /// Record one occurrence of `kind`.
    pub fn add(&mut self, kind: &str, message: impl FnOnce() -> String) {
        self.add_n(kind, 1, message);
    }

    /// Record `n` occurrences of `kind`.
    pub fn add_n(&mut self, kind: &str, n: usize, message: impl FnOnce() -> String) {
        if n == 0 {
            return;
        }
        match self.counts.get_mut(kind) {
            Some(w) => w.count += n,
            None => {
                self.counts.insert(
                    kind.to_string(),
                    WarningCount {
                        count: n,
                        first: message(),
                    },
                );
            }
        }
    }

    /// Merge another set in.
    pub fn merge(&mut self, other: LogWarnings) {
        for (k, w) in other.counts {
            match self.counts.get_mut(&k) {
                Some(mine) => mine.count += w.count,
                None => {
                    self.counts.insert(k, w);
                }
            }
        }
    }

    /// Total number of warnings.
    pub fn total(&self) -> usize {
        self.counts.values().map(|w| w.count).sum()
    }

    /// Count of one kind.
    pub fn count(&self, kind: &str) -> usize {
        self.counts.get(kind).map_or(0, |w| w.count)
    }
}

/// A wavelength log: timestamps and ragged peak lists.
#[derive(Debug, Clone, PartialEq)]
pub struct PeakLog {
    /// The file read.
    pub source: PathBuf,
    /// Its format.
    pub format: LogFormat,
    /// Time of each row, s (see [`PeakLog::clock`]); sorted ascending.
    pub time_s: Vec<f64>,
    /// Absolute wall-clock or relative times.
    pub clock: Clock,
    /// Peaks of row i are `peaks_nm[row_start[i]..row_start[i + 1]]`.
    pub row_start: Vec<usize>,
    /// Every peak wavelength, nm, row after row.
    pub peaks_nm: Vec<f64>,
    /// Channel (ENLIGHT) or column (CSV, Sensors) of each peak, from 0.
    pub peak_channel: Vec<u16>,
    /// Number of channels or wavelength columns declared by the header.
    pub channels: usize,
    /// Column names for Sensors and CSV logs (empty otherwise).
    pub column_names: Vec<String>,
    /// File line number of each row (1-based), for messages.
    pub line_of_row: Vec<u32>,
    /// Bound on the error of each row's absolute time, s: half the range of phases
    /// the timestamps allow when they were written in whole seconds and spread onto
    /// their sampling grid (±0.25 s at 2 Hz), 0 otherwise.
    pub time_uncertainty_s: f64,
    /// Counted problems.
    pub warnings: LogWarnings,
}

impl PeakLog {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.time_s.len()
    }

    /// Peaks of row `i`: (wavelengths nm, channels).
    pub fn row(&self, i: usize) -> (&[f64], &[u16]) {
        let (a, b) = (self.row_start[i], self.row_start[i + 1]);
        (&self.peaks_nm[a..b], &self.peak_channel[a..b])
    }

    /// Median sample period, s.
    pub fn median_period_s(&self) -> f64 {
        median_period(&self.time_s)
    }
}

/// Median of the positive time steps (0 when fewer than two samples).
pub fn median_period(t: &[f64]) -> f64 {
    let mut d: Vec<f64> = t
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .collect();
    if d.is_empty() {
        return 0.0;
    }
    let mid = d.len() / 2;
    *d.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1
}

/// Options for reading a wavelength log.
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// Force a format instead of detecting it.
    pub format: Option<LogFormat>,
    /// Force the order of day and month in slash dates.
    pub date_order: Option<num::DateOrder>,
}

/// Read a wavelength log from a file.
pub fn read_peak_log(path: &Path, opts: &ReadOptions) -> Result<PeakLog> {
    let bytes =
        std::fs::read(path).with_context(|| format!("cannot read the log {}", path.display()))?;
    parse_wavelength_bytes(&bytes, path, opts)
}

/// A force-stand log: time and force.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceLog {
    /// The file read.
    pub source: PathBuf,
    /// Time of each sample, s, ascending.
    pub time_s: Vec<f64>,
    /// Absolute wall-clock or relative times.
    pub clock: Clock,
    /// Force, N (compression positive as the stand reports it).
    pub force_n: Vec<f64>,
    /// Name of the time column used.
    pub time_column: String,
    /// Name of the force column used.
    pub force_column: String,
    /// Factor applied to reach N (from the column's unit).
    pub scale_to_n: f64,
    /// Bound on the error of each sample's absolute time, s (see
    /// [`PeakLog::time_uncertainty_s`]).
    pub time_uncertainty_s: f64,
    /// Counted problems.
    pub warnings: LogWarnings,
}

/// Which columns of a force-stand CSV hold time and force.
#[derive(Debug, Clone, Default)]
pub struct ForceColumns {
    /// Time column name (default: the first of `time_s`, `RelTime`, `time`, `t`,
    /// `AbsTime`, `Timestamp`, matched without case).
    pub time: Option<String>,
    /// Force column name (default: the first of `force_N`, `force`, `F`, `load`).
    pub force: Option<String>,
    /// Factor to N; default from the unit in the column name (`_N`, `[kN]`, `(g)`, …)
    /// or in a units row under the header (`(s),(mm),(kN)`, as Bluehill writes it).
    pub scale_to_n: Option<f64>,
    /// Order of day and month in slash dates (detected when the file tells, else
    /// day first).
    pub date_order: Option<num::DateOrder>,
}

/// Read a force-stand CSV.
pub fn read_force_log(path: &Path, cols: &ForceColumns) -> Result<ForceLog> {
    let bytes = std::fs::read(path)
        .with_context(|| format!("cannot read the force log {}", path.display()))?;
    parse_force_bytes(&bytes, path, cols)
}

/// Factor to N from a force column name's unit, if it names one.
pub fn force_unit_scale(name: &str) -> Option<f64> {
    let lower = name.to_ascii_lowercase();
    let unit = lower
        .rsplit(['_', '[', '(', ' ', '/'])
        .next()
        .unwrap_or("")
        .trim_end_matches([']', ')'])
        .trim();
    match unit {
        "n" => Some(1.0),
        "kn" => Some(1000.0),
        "mn" => Some(1e-3),
        "g" | "gf" => Some(9.80665e-3),
        "kg" | "kgf" => Some(9.80665),
        "lbf" => Some(4.448_221_615),
        _ => None,
    }
}

/// Factor to seconds from a time column name's unit (`time_ms`, `Time [ms]`, `(s)`),
/// if it names one.
pub fn time_unit_scale(name: &str) -> Option<f64> {
    let lower = name.to_lowercase();
    let unit = lower
        .rsplit(['_', '[', '(', ' ', '/'])
        .next()
        .unwrap_or("")
        .trim_end_matches([']', ')'])
        .trim();
    match unit {
        "s" | "sec" | "secs" | "seconds" => Some(1.0),
        "ms" | "msec" => Some(1e-3),
        "us" | "µs" | "μs" => Some(1e-6),
        "min" => Some(60.0),
        "h" | "hr" => Some(3600.0),
        _ => None,
    }
}

/// Resolved path display helper for messages.
pub(crate) fn at(path: &Path, line: usize) -> String {
    format!("{}:{line}", path.display())
}

/// Sort rows by time if needed (counting every backward step), and spread rows that
/// share a whole-second timestamp (I-MON, 12-hour ENLIGHT exports) uniformly.
pub(crate) fn finish_times(
    path: &Path,
    time_s: &mut [f64],
    lines: &[u32],
    warnings: &mut LogWarnings,
) -> Option<Vec<usize>> {
    let mut backward = 0;
    let mut first_line = 0;
    for i in 1..time_s.len() {
        if time_s[i] < time_s[i - 1] {
            if backward == 0 {
                first_line = lines[i];
            }
            backward += 1;
        }
    }
    let order = if backward > 0 {
        warnings.add_n("non_monotonic_timestamp", backward, || {
            format!(
                "{}: time runs backwards; rows were sorted by time ({backward} backward steps)",
                at(path, first_line as usize)
            )
        });
        let mut idx: Vec<usize> = (0..time_s.len()).collect();
        idx.sort_by(|&a, &b| time_s[a].total_cmp(&time_s[b]));
        Some(idx)
    } else {
        None
    };
    order
}

/// Spread timestamps quantised to whole seconds (several rows per second) onto the
/// uniform grid they were sampled on: t_i = t0 + i·dt with dt from the first and last
/// change of the written second, and t0 the centre of the offsets allowed by
/// floor(t_i) = written time. Returns the half-width of that range of offsets, the
/// bound on each time's error (0.25 s at 2 Hz), or 0 when the times were left as
/// they are.
pub(crate) fn dequantize(path: &Path, time_s: &mut [f64], warnings: &mut LogWarnings) -> f64 {
    let n = time_s.len();
    if n < 4 || time_s.iter().any(|t| t.fract() != 0.0) {
        return 0.0;
    }
    let repeats = time_s.windows(2).filter(|w| w[0] == w[1]).count();
    if repeats * 2 < n {
        return 0.0;
    }
    let base = time_s[0];
    // The written second changes where the true time crosses a whole second; the
    // first and last such crossings give the period without the bias a regression
    // on floored values has.
    let changes: Vec<usize> = (1..n).filter(|&i| time_s[i] != time_s[i - 1]).collect();
    let dt = match (changes.first(), changes.last()) {
        (Some(&a), Some(&b)) if b > a => (time_s[b] - time_s[a]) / (b - a) as f64,
        _ => {
            let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
            for (i, &t) in time_s.iter().enumerate() {
                let (x, y) = (i as f64, t - base);
                sx += x;
                sy += y;
                sxx += x * x;
                sxy += x * y;
            }
            let nf = n as f64;
            (nf * sxy - sx * sy) / (nf * sxx - sx * sx)
        }
    };
    if dt.is_nan() || dt <= 0.0 {
        return 0.0;
    }
    let (mut lo, mut hi) = (f64::MIN, f64::MAX);
    for (i, &t) in time_s.iter().enumerate() {
        let q = t - base - i as f64 * dt;
        lo = lo.max(q);
        hi = hi.min(q + 1.0);
    }
    let (t0, half) = if lo <= hi {
        ((lo + hi) / 2.0, (hi - lo) / 2.0)
    } else {
        (lo, 0.5)
    };
    for (i, t) in time_s.iter_mut().enumerate() {
        *t = base + t0 + i as f64 * dt;
    }
    warnings.add("whole_second_timestamps", || {
        format!(
            "{}: timestamps have a resolution of 1 s with several rows per second; rows were spread uniformly at {:.4} Hz, each time uncertain by up to ±{half:.3} s",
            path.display(),
            1.0 / dt
        )
    });
    half
}

/// Reject logs with fewer rows than an analysis can use.
pub(crate) fn require_rows(path: &Path, rows: usize, what: &str) -> Result<()> {
    if rows < 2 {
        bail!(
            "{}: {what} holds {rows} readable rows; at least 2 are needed",
            path.display()
        );
    }
    Ok(())
}
