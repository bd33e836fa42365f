//! Readers for interrogator and force-stand logs, with format detection.
//!
//! Every wavelength log, whatever its format, becomes a [`PeakLog`]: one timestamp per
//! row and a ragged list of peak wavelengths (nm) per row, each tagged with the
//! channel (or column) it came from. Which peak belongs to which grating is decided
//! later ([`crate::logs::assign`]) from the design's nominal wavelengths, so a
//! reader never has to guess grating names.
//!
//! Formats (see `docs/verify.md` for examples of each), one file each behind the
//! [`LogReader`] trait and registered in [`LogFormat::reader`]:
//! - [`LogFormat::EnlightPeaks`]: Micron Optics / Luna ENLIGHT "Peaks" export
//!   (`enlight_peaks.rs`);
//! - [`LogFormat::EnlightSensors`]: ENLIGHT "Sensors" export, one column per sensor
//!   (`enlight_sensors.rs`);
//! - [`LogFormat::Imon`]: Ibsen I-MON evaluation software log (`imon.rs`);
//! - [`LogFormat::Csv`]: plain delimited text, a time column then wavelength columns
//!   (`plain_csv.rs`; `<name> std_error_pm` columns, as `fbgforge peaks --out` writes
//!   them, carry each peak's standard error).
//!
//! Spectrum files ([`LogFormat::SPECTRA`], `spectrum.rs`) become the same rows: an
//! I-MON log's pixel columns read with the pixel-to-wavelength polynomial
//! ([`ReadOptions::imon_calibration`]; without it the I-MON software's own peaks are
//! read, as from a peak log), a Luna ENLIGHT / Hyperion spectrum export or an OSA CSV
//! (one acquisition each). Their peaks are found by the estimator
//! [`ReadOptions::estimator`] names (`fbgforge_spectra::find_peaks`) and keep their
//! uncertainty ([`PeakLog::uncertainty`]).
//!
//! A format is recognised in one place ([`detect_format`]); the row machinery every
//! format shares (chunked parallel parse, merge) is in `rows.rs`, the times (dates,
//! sorting, whole-second timestamps, the median sample period) in [`time`]. Force-stand logs are read by
//! [`read_force_log`] (`force.rs`); the small hand-written CSV tables (schedules, load
//! scripts, matrices) by [`csv_table`].
//!
//! Unreadable rows are skipped and counted ([`LogWarnings`]); a file where more than
//! half of the table is unreadable, or with no table at all, is an error that names the
//! file and the first bad line. Nothing here panics on user input.

pub mod assign;
pub mod csv_table;
mod detect;
mod enlight;
mod enlight_peaks;
mod enlight_sensors;
mod force;
mod imon;
mod imon_pixels;
pub mod num;
pub mod peaks;
mod plain_csv;
mod row_reader;
mod rows;
mod spectrum;
pub mod time;
mod write;

use anyhow::{bail, Context, Result};
use num::DateOrder;
use rows::{LineIssue, Partial};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

pub use detect::{detect_format, Detected};
pub use force::{
    force_unit_scale, parse_force_bytes, read_force_log, row_unit_scale, time_unit_scale,
    write_force_csv, write_force_stand_csv, ForceLog, ForceReadOptions,
};
pub use row_reader::{LogRow, RowReader};
pub use spectrum::{
    estimator_names, find_options, imon_calibration, read_spectrum_peaks, ChannelPeak, LineShape,
    SpectrumPeaks, SpectrumPeaksRow, SpectrumStyle, DEFAULT_ESTIMATOR,
};
pub use write::{write_log, LogStyle, LogTable};

/// A supported wavelength log format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
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
    /// Ibsen I-MON log whose pixel columns are read as spectra (with
    /// [`ReadOptions::imon_calibration`]); one acquisition per row.
    ImonPixels,
    /// Luna ENLIGHT / Hyperion spectrum export: one acquisition, one column per channel.
    EnlightSpectrum,
    /// OSA / swept-laser CSV: one acquisition, `Wavelength (nm)` then power columns.
    OsaCsv,
}

impl LogFormat {
    /// Every format, in the order detection tries them.
    pub const ALL: [LogFormat; 4] = [
        LogFormat::EnlightPeaks,
        LogFormat::EnlightSensors,
        LogFormat::Imon,
        LogFormat::Csv,
    ];

    /// The spectrum formats: their peaks are found, each with its uncertainty. Detected
    /// before the peak formats (`fbgforge_spectra::detect`); an I-MON log with pixels is
    /// read as [`LogFormat::ImonPixels`] only with a pixel calibration.
    pub const SPECTRA: [LogFormat; 3] = [
        LogFormat::ImonPixels,
        LogFormat::EnlightSpectrum,
        LogFormat::OsaCsv,
    ];

    /// The registry: each format's reader, one file each.
    pub(crate) fn reader(self) -> &'static dyn LogReader {
        match self {
            LogFormat::EnlightPeaks => &enlight_peaks::EnlightPeaks,
            LogFormat::EnlightSensors => &enlight_sensors::EnlightSensors,
            LogFormat::Imon => &imon::Imon,
            LogFormat::Csv => &plain_csv::PlainCsv,
            LogFormat::ImonPixels => &spectrum::IMON_PIXELS,
            LogFormat::EnlightSpectrum => &spectrum::ENLIGHT_SPECTRUM,
            LogFormat::OsaCsv => &spectrum::OSA_CSV,
        }
    }

    /// The format of a name given by [`LogFormat::name`] (peak and spectrum formats).
    pub fn from_name(name: &str) -> Option<LogFormat> {
        Self::ALL
            .into_iter()
            .chain(Self::SPECTRA)
            .find(|f| f.name() == name)
    }

    /// A spectrum format: peaks found by an estimator, each with its uncertainty.
    pub fn is_spectrum(self) -> bool {
        Self::SPECTRA.contains(&self)
    }

    /// The format's name (in JSON, and as the front ends name it).
    pub fn name(self) -> &'static str {
        self.reader().name()
    }

    /// Resolution of the interrogator that usually writes this format, pm (SM125:
    /// 1 pm; I-MON 512E: < 0.5 pm). Used for the resolution figure unless overridden.
    pub fn typical_resolution_pm(self) -> f64 {
        self.reader().typical_resolution_pm()
    }

    /// File extension of a log written in this format.
    pub fn extension(self) -> &'static str {
        self.reader().extension()
    }

    /// The clock of the times a log written in this format carries: wall-clock dates
    /// ([`LogTable::start_epoch_s`] + the row's time) or seconds from the first row.
    pub fn written_clock(self) -> Clock {
        self.reader().written_clock()
    }
}

/// One wavelength log format: how its table is recognised, how its rows are read, and
/// how the project writes it (synthetic logs). A new format is one file implementing
/// this, a [`LogFormat`] variant and its line in [`LogFormat::reader`].
pub(crate) trait LogReader: Sync {
    /// The format's name ([`LogFormat::name`]).
    fn name(&self) -> &'static str;

    /// What the format is called in messages.
    fn title(&self) -> &'static str;

    /// What its table looks like, for the error when it is not found.
    fn expected(&self) -> &'static str;

    /// Resolution of the interrogator that usually writes it, pm.
    fn typical_resolution_pm(&self) -> f64 {
        1.0
    }

    /// The order of day and month in slash dates when the file does not tell.
    fn default_date_order(&self) -> DateOrder {
        DateOrder::DayMonthYear
    }

    /// The field delimiter when `head` is this format's table header (the table starts
    /// on the next line), else None.
    fn header_delimiter(&self, _head: &detect::HeadLine) -> Option<u8> {
        None
    }

    /// For a format without a header line of its own: its table, when the file's first
    /// table line starts one (`forced`: the user named this format). Asked only when no
    /// format's header line is found.
    fn table_at_first_line(&self, _first: &detect::FirstLine, _forced: bool) -> Option<Detected> {
        None
    }

    /// How the rows of a detected table are read (`bytes`: the whole file, or what has
    /// been written of it; `opts`: the reading settings, for the spectrum formats).
    fn rows(&self, det: &Detected, bytes: &[u8], path: &Path, opts: &ReadOptions) -> Result<Rows>;

    /// Write `table` in this format.
    fn write(&self, w: &mut dyn Write, table: &LogTable, style: &LogStyle) -> std::io::Result<()>;

    /// File extension of a written log.
    fn extension(&self) -> &'static str {
        "txt"
    }

    /// The clock of the times written.
    fn written_clock(&self) -> Clock {
        Clock::Absolute
    }
}

/// The rows of a detected table: its channels (or value columns), their names, and the
/// parser of one row.
pub(crate) struct Rows {
    /// Number of channels or value columns.
    pub(crate) channels: usize,
    /// Column names (Sensors, CSV), empty otherwise.
    pub(crate) column_names: Vec<String>,
    /// Reads one row.
    pub(crate) parser: Box<dyn RowParser>,
    /// For rows of peaks found in spectra: the estimator's name (each row then adds one
    /// [`PeakQuality`] per peak).
    pub(crate) estimator: Option<String>,
}

/// Reads one table line of a format.
pub(crate) trait RowParser: Send + Sync {
    /// Parse `line` (neither blank nor a comment): add its peaks to `out` and close the
    /// row ([`Partial::end_row`]), or add nothing and say why the line cannot be used.
    /// `scratch` is kept from line to line.
    fn parse(
        &self,
        line: &[u8],
        out: &mut Partial,
        scratch: &mut Vec<usize>,
    ) -> std::result::Result<(), LineIssue>;

    /// Parse every line of `chunk`. Not to be overridden: the default is compiled for
    /// each format, so one call through the trait object per chunk, not per line, and
    /// [`RowParser::parse`] can inline into the loop over the lines.
    fn parse_chunk(&self, chunk: &[u8]) -> Partial {
        rows::parse_chunk(self, chunk)
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

/// What a peak found in a spectrum carries besides its wavelength
/// (`fbgforge_spectra::Peak`, docs/spectra.md); NaN where a peaks log did not state it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PeakQuality {
    /// Standard error of the wavelength, pm (from the fit's residuals).
    pub std_error_pm: f64,
    /// Cramér–Rao bound of the wavelength for the peak's width, noise and grid, pm.
    pub crb_pm: f64,
    /// Full width at half maximum, pm.
    pub fwhm_pm: f64,
    /// Peak height over the noise standard deviation.
    pub snr: f64,
    /// Quality flags (`undersampled`, `estimator_disagreement`, `overlap`, `low_snr`,
    /// `split`).
    pub flags: fbgforge_spectra::PeakFlags,
}

impl PeakQuality {
    /// A peak whose standard error alone is known (a peaks log's `std_error_pm` column).
    pub fn std_error_only(std_error_pm: f64) -> Self {
        PeakQuality {
            std_error_pm,
            crb_pm: f64::NAN,
            fwhm_pm: f64::NAN,
            snr: f64::NAN,
            flags: Default::default(),
        }
    }
}

impl From<&fbgforge_spectra::Peak> for PeakQuality {
    fn from(p: &fbgforge_spectra::Peak) -> Self {
        PeakQuality {
            std_error_pm: p.std_error_pm,
            crb_pm: p.crb_pm,
            fwhm_pm: p.fwhm_pm,
            snr: p.snr,
            flags: p.flags,
        }
    }
}

/// How a log's peaks were found and how well each is known.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PeakUncertainty {
    /// The peak estimator (`gaussian`, `parabola`, `centroid`, `xcorr`), as the
    /// spectrum reader used it or a peaks log states it.
    pub estimator: String,
    /// One per peak, parallel to [`PeakLog::peaks_nm`].
    pub peaks: Vec<PeakQuality>,
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
    /// Peaks of row i are `peaks_nm[row_start[i]..row_start[i + 1]]` (empty once
    /// [`PeakLog::drop_peaks`] freed them).
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
    /// Jumps of the clock back and long gaps between rows, in file order
    /// ([`time::ClockJump`]); each is also a warning (`clock_jump`, `clock_gap`).
    pub clock_jumps: Vec<time::ClockJump>,
    /// Counted problems.
    pub warnings: LogWarnings,
    /// Peaks found in spectra (or a peaks log with standard errors): the estimator and
    /// each peak's uncertainty; `None` for a plain peak log.
    pub uncertainty: Option<PeakUncertainty>,
}

impl PeakLog {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.time_s.len()
    }

    /// Peaks of row `i`: (wavelengths nm, channels).
    pub fn row(&self, i: usize) -> (&[f64], &[u16]) {
        let (a, b) = self.row_span(i);
        (&self.peaks_nm[a..b], &self.peak_channel[a..b])
    }

    /// Where row `i`'s peaks lie in the table (empty once the peaks were dropped).
    fn row_span(&self, i: usize) -> (usize, usize) {
        if self.row_start.is_empty() {
            return (0, 0);
        }
        (self.row_start[i], self.row_start[i + 1])
    }

    /// The rows `rows` (file order or any other, repeats allowed) as a log of their own:
    /// each row's time, file line, peaks, channels and peak uncertainties go with it;
    /// what describes the whole file (source, format, channels, warnings, clock jumps)
    /// is kept. Only the rows named are copied.
    pub fn with_rows(&self, rows: &[usize]) -> PeakLog {
        let n_peaks: usize = rows
            .iter()
            .map(|&i| self.row_span(i).1 - self.row_span(i).0)
            .sum();
        let mut out = PeakLog {
            source: self.source.clone(),
            format: self.format,
            time_s: Vec::with_capacity(rows.len()),
            clock: self.clock,
            row_start: Vec::with_capacity(rows.len() + 1),
            peaks_nm: Vec::with_capacity(n_peaks),
            peak_channel: Vec::with_capacity(n_peaks),
            channels: self.channels,
            column_names: self.column_names.clone(),
            line_of_row: Vec::with_capacity(rows.len()),
            time_uncertainty_s: self.time_uncertainty_s,
            clock_jumps: self.clock_jumps.clone(),
            warnings: self.warnings.clone(),
            uncertainty: self.uncertainty.as_ref().map(|u| PeakUncertainty {
                estimator: u.estimator.clone(),
                peaks: Vec::with_capacity(n_peaks),
            }),
        };
        out.row_start.push(0);
        for &i in rows {
            let (a, b) = self.row_span(i);
            out.peaks_nm.extend_from_slice(&self.peaks_nm[a..b]);
            out.peak_channel.extend_from_slice(&self.peak_channel[a..b]);
            if let (Some(from), Some(to)) = (&self.uncertainty, &mut out.uncertainty) {
                to.peaks.extend_from_slice(&from.peaks[a..b]);
            }
            out.row_start.push(out.peaks_nm.len());
            out.line_of_row.push(self.line_of_row[i]);
            out.time_s.push(self.time_s[i]);
        }
        out
    }

    /// Free the peaks (wavelengths, channels, their uncertainties) once they have been
    /// assigned to gratings, keeping the rows' times and lines and what describes the
    /// file: the table is most of a long log's memory (361 MB of an hour at 1 kHz with
    /// nine peaks a row). Afterwards every row reads as having no peaks.
    ///
    /// ```
    /// use fbgforge_core::logs::{read_peak_log, ReadOptions};
    /// let dir = tempfile::tempdir()?;
    /// let path = dir.path().join("peaks.csv");
    /// std::fs::write(&path, "time_s,a\n0.0,1546.295\n0.5,1546.296\n")?;
    /// let mut log = read_peak_log(&path, &ReadOptions::default())?;
    /// log.drop_peaks();
    /// assert_eq!(log.rows(), 2);
    /// assert!(log.row(1).0.is_empty());
    /// # Ok::<(), anyhow::Error>(())
    /// ```
    pub fn drop_peaks(&mut self) {
        self.peaks_nm = Vec::new();
        self.peak_channel = Vec::new();
        self.row_start = Vec::new();
        if let Some(u) = &mut self.uncertainty {
            u.peaks = Vec::new();
        }
    }

    /// Median sample period, s.
    pub fn median_period_s(&self) -> f64 {
        time::median_period(&self.time_s)
    }

    /// The uncertainty of the peaks of row `i`, parallel to [`PeakLog::row`] (`None` for
    /// a plain peak log).
    pub fn row_quality(&self, i: usize) -> Option<&[PeakQuality]> {
        let (a, b) = self.row_span(i);
        self.uncertainty.as_ref().map(|u| &u.peaks[a..b])
    }

    /// The peak estimator that made this log's peaks, if it was read from spectra or a
    /// peaks log states it.
    pub fn estimator(&self) -> Option<&str> {
        self.uncertainty.as_ref().map(|u| u.estimator.as_str())
    }
}

/// Options for reading a wavelength log.
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// Force a format instead of detecting it.
    pub format: Option<LogFormat>,
    /// Force the order of day and month in slash dates.
    pub date_order: Option<num::DateOrder>,
    /// I-MON pixel-to-wavelength polynomial a0, a1, … (nm; the pixel index from 1 as the
    /// header writes it, pixels in the file's order). With it an I-MON log's pixel
    /// columns are read as spectra ([`LogFormat::ImonPixels`]); without it the peaks the
    /// I-MON software wrote are read.
    pub imon_calibration: Option<Vec<f64>>,
    /// Peak estimator for spectra ([`estimator_names`]; default [`DEFAULT_ESTIMATOR`]).
    pub estimator: Option<String>,
}

/// Read a wavelength log from a file: its format detected (or named in `opts`), its
/// rows' peaks and times read, unreadable rows skipped and counted.
///
/// ```
/// use fbgforge_core::logs::{read_peak_log, Clock, LogFormat, ReadOptions};
///
/// let dir = tempfile::tempdir()?;
/// let path = dir.path().join("peaks.csv");
/// std::fs::write(
///     &path,
///     "time_s,lambda_11,lambda_12\n0.0,1546.2950,1524.5700\n0.5,1546.2961,\n1.0,1546.2970,1524.5710\n",
/// )?;
/// let log = read_peak_log(&path, &ReadOptions::default())?;
/// assert_eq!(log.format, LogFormat::Csv);
/// assert_eq!(log.clock, Clock::Relative);
/// assert_eq!(log.rows(), 3);
/// // The second row lost its second peak: one peak, from the first column.
/// assert_eq!(log.row(1), (&[1546.2961][..], &[0u16][..]));
/// assert_eq!(log.median_period_s(), 0.5);
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn read_peak_log(path: &Path, opts: &ReadOptions) -> Result<PeakLog> {
    read_peak_log_in_blocks(path, opts, rows::STREAM_BLOCK)
}

/// Bytes of a log's head read for detection before its body is streamed (detection
/// looks at the first 4 MiB).
const HEAD_BYTES: usize = 8 << 20;

/// [`read_peak_log`] reading `block` bytes at a time: a file over two blocks is never
/// held whole (its table is parsed block by block as it is read), a smaller one is read
/// at once.
pub(crate) fn read_peak_log_in_blocks(
    path: &Path,
    opts: &ReadOptions,
    block: usize,
) -> Result<PeakLog> {
    read_blocks(path, opts, block, None).map(|(log, _)| log)
}

/// A wavelength log read as [`read_peak_log`] reads it, with its peaks assigned to the
/// gratings of `windows` ([`assign::assign`]) and freed: a long log's rows are assigned
/// block by block as the file is read, so its peak table (317 MB of an hour at 1 kHz
/// with eight peaks a row) is never held whole. The log comes back without its peaks
/// ([`PeakLog::drop_peaks`]) and with the tracks, the same as `assign` gives on the
/// whole log. Rows arriving in file order are assigned in time order only when the
/// log's times never run back: a log whose rows must be sorted by time (or one of
/// spectra, or with peak uncertainties, or small) is read whole instead and comes back
/// with its peaks and no tracks (`None`), for the caller to assign.
///
/// ```
/// use fbgforge_core::logs::assign::{assign, GratingWindow};
/// use fbgforge_core::logs::{read_peak_log, read_peak_log_assigned, ReadOptions};
/// let dir = tempfile::tempdir()?;
/// let path = dir.path().join("peaks.csv");
/// std::fs::write(&path, "time_s,a\n0.0,1546.295\n0.5,1546.296\n")?;
/// let windows = [GratingWindow::new("a", 1546.3, 2.5)];
/// // A small file is read whole: its peaks kept, for the caller to assign.
/// let (log, tracks) = read_peak_log_assigned(&path, &ReadOptions::default(), &windows)?;
/// assert!(tracks.is_none());
/// assert_eq!(log, read_peak_log(&path, &ReadOptions::default())?);
/// assert_eq!(assign(&log, &windows)[0].rows_present, 2);
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn read_peak_log_assigned(
    path: &Path,
    opts: &ReadOptions,
    windows: &[assign::GratingWindow],
) -> Result<(PeakLog, Option<Vec<assign::GratingTrack>>)> {
    read_blocks(path, opts, rows::STREAM_BLOCK, Some(windows))
}

/// [`read_peak_log_in_blocks`], and with `windows` the peaks of a streamed log assigned
/// block by block ([`read_peak_log_assigned`]).
pub(crate) fn read_blocks(
    path: &Path,
    opts: &ReadOptions,
    block: usize,
    windows: Option<&[assign::GratingWindow]>,
) -> Result<(PeakLog, Option<Vec<assign::GratingTrack>>)> {
    use std::io::Read;
    let cannot = || format!("cannot read the log {}", path.display());
    let mut file = std::fs::File::open(path).with_context(cannot)?;
    let len = file.metadata().with_context(cannot)?.len();
    if len <= 2 * block as u64 {
        let mut bytes = Vec::with_capacity(len as usize);
        file.read_to_end(&mut bytes).with_context(cannot)?;
        return Ok((parse_wavelength_bytes(&bytes, path, opts)?, None));
    }
    // The head: what detection reads (a test's small blocks read a smaller one).
    let head_len = HEAD_BYTES.min(block.max(1 << 16));
    let mut head = Vec::with_capacity(head_len);
    (&mut file)
        .take(head_len as u64)
        .read_to_end(&mut head)
        .with_context(cannot)?;
    let det = spectrum::detect_table(&head, path, opts)?;
    if matches!(det.format, LogFormat::EnlightSpectrum | LogFormat::OsaCsv) {
        // A whole-file spectrum is one acquisition's table, not a stream of rows.
        let mut bytes = head;
        file.read_to_end(&mut bytes).with_context(cannot)?;
        return Ok((parse_wavelength_bytes(&bytes, path, opts)?, None));
    }
    let reader = det.format.reader();
    let table = reader.rows(&det, &head, path, opts)?;
    let body_offset = det.body_offset.min(head.len());
    head.drain(..body_offset);
    // Peaks with uncertainties go with their standard errors: read whole.
    let mut assigner = windows
        .filter(|_| table.estimator.is_none())
        .map(assign::StreamAssigner::new);
    let mut first_block = true;
    let mut take = |m: &mut rows::Merged, expected_rows: usize| {
        if let Some(a) = assigner.as_mut() {
            if std::mem::take(&mut first_block) {
                // Room for the whole body's rows, once.
                a.reserve(expected_rows);
            }
            m.take_peaks(|starts, peaks| a.push_rows(starts, peaks));
        }
    };
    let m = rows::parse_body_stream(
        &mut file,
        head,
        det.body_line,
        &*table.parser,
        (path, Some(len - body_offset as u64), block),
        Some(&mut take),
    )
    .with_context(cannot)?;
    let assigned = assigner.is_some();
    match (
        finish_table(m, &det, table, path, opts, assigned)?,
        assigner,
    ) {
        (Some(log), Some(a)) => Ok((log, Some(a.finish()))),
        (Some(log), None) => Ok((log, None)),
        // Rows to sort by time: assigned in file order they could differ from the
        // rows assigned in time order; read again, whole.
        (None, _) => Ok((read_peak_log_in_blocks(path, opts, block)?, None)),
    }
}

/// Parse a wavelength log held in memory: detect its format, read its rows with that
/// format's parser, resolve and order the times.
pub fn parse_wavelength_bytes(bytes: &[u8], path: &Path, opts: &ReadOptions) -> Result<PeakLog> {
    let det = spectrum::detect_table(bytes, path, opts)?;
    if matches!(det.format, LogFormat::EnlightSpectrum | LogFormat::OsaCsv) {
        let mut log = spectrum::read_whole_spectrum(bytes, path, det.format, opts)?;
        spectrum::warn_flagged_peaks(&mut log);
        return Ok(log);
    }
    let reader = det.format.reader();
    let table = reader.rows(&det, bytes, path, opts)?;
    let body = &bytes[det.body_offset.min(bytes.len())..];
    let m = rows::parse_body(body, det.body_line, &*table.parser, path);
    finish_peak_log(m, &det, table, path, opts)
}

/// The log from its parsed table: too many unreadable lines refused, the times
/// resolved, ordered and spread, the clock's jumps found.
fn finish_peak_log(
    m: rows::Merged,
    det: &Detected,
    table: Rows,
    path: &Path,
    opts: &ReadOptions,
) -> Result<PeakLog> {
    finish_table(m, det, table, path, opts, false)?.ok_or_else(|| {
        anyhow::anyhow!(
            "internal: {}: a table with its peaks was not finished",
            path.display()
        )
    })
}

/// [`finish_peak_log`]; with `peaks_taken` (the peaks were assigned as the table was
/// read, [`read_peak_log_assigned`]) the log has no peaks, and `None` is returned when
/// its rows must be sorted by time.
fn finish_table(
    mut m: rows::Merged,
    det: &Detected,
    table: Rows,
    path: &Path,
    opts: &ReadOptions,
    peaks_taken: bool,
) -> Result<Option<PeakLog>> {
    let reader = det.format.reader();
    let rows = m.lines.len();
    if rows == 0 || m.bad * 2 > m.table_lines {
        bail!(
            "{}: {} of {} table lines are unreadable as {} rows{}",
            path.display(),
            m.bad,
            m.table_lines,
            det.format.name(),
            m.first_bad
                .map(|msg| format!("; first: {msg}"))
                .unwrap_or_default()
        );
    }
    time::require_rows(path, rows, "the log")?;
    let (mut time_s, clock) = time::wavelength_times(
        &mut m.times,
        &m.lines,
        reader.default_date_order(),
        opts.date_order,
        path,
    )?;
    let mut log = PeakLog {
        source: path.to_path_buf(),
        format: det.format,
        time_s: Vec::new(),
        clock,
        row_start: m.row_start,
        peaks_nm: m.peaks,
        peak_channel: m.chans,
        channels: table.channels,
        column_names: table.column_names,
        line_of_row: m.lines,
        time_uncertainty_s: 0.0,
        clock_jumps: Vec::new(),
        warnings: m.warnings,
        uncertainty: table.estimator.map(|estimator| PeakUncertainty {
            estimator,
            peaks: m.quality,
        }),
    };
    if let Some(u) = &log.uncertainty {
        debug_assert_eq!(u.peaks.len(), log.peaks_nm.len());
    }
    log.clock_jumps = time::clock_jumps(path, &time_s, &log.line_of_row, &mut log.warnings);
    if peaks_taken {
        log.drop_peaks();
    }
    if let Some(order) = time::finish_times(path, &mut time_s, &log.line_of_row, &mut log.warnings)
    {
        if peaks_taken {
            return Ok(None);
        }
        time::reorder_rows(&mut log, &mut time_s, &order);
    }
    log.time_uncertainty_s = time::dequantize(path, &mut time_s, &mut log.warnings);
    log.time_s = time_s;
    spectrum::warn_flagged_peaks(&mut log);
    Ok(Some(log))
}

/// Resolved path display helper for messages.
pub(crate) fn at(path: &Path, line: usize) -> String {
    format!("{}:{line}", path.display())
}

#[cfg(test)]
mod tests;
