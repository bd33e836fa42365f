//! Format detection and the row parsers behind [`super::read_peak_log`] and
//! [`super::read_force_log`].
//!
//! The table body is split at line boundaries into chunks parsed in parallel (rayon);
//! each line is cut into fields by slicing, and numbers are parsed from the bytes
//! ([`super::num`]), so no row allocates. Dates are interned per chunk (a log rarely
//! spans more than a few dates) and resolved once the whole file is known.

use super::num::{self, trim, DateOrder, RawDate};
use super::{at, Clock, ForceColumns, ForceLog, LogFormat, LogWarnings, PeakLog, ReadOptions};
use anyhow::{anyhow, bail, Result};
use rayon::prelude::*;
use std::path::Path;

const BOM: &[u8] = b"\xEF\xBB\xBF";

/// Where the table of a wavelength log starts and how its rows look.
#[derive(Debug, Clone, PartialEq)]
pub struct Detected {
    /// The format.
    pub format: LogFormat,
    /// Byte offset of the first line after the header (or of the first row when a
    /// CSV has no header).
    pub body_offset: usize,
    /// 1-based line number of the first body line.
    pub body_line: usize,
    /// Header fields (trimmed), empty for a header-less CSV.
    pub header: Vec<String>,
    /// Field delimiter.
    pub delimiter: u8,
}

fn strip_bom(b: &[u8]) -> (&[u8], usize) {
    if b.starts_with(BOM) {
        (&b[3..], 3)
    } else {
        (b, 0)
    }
}

/// Lines of `b` with their byte offsets (line without `\n` and trailing `\r`).
fn lines_with_offsets(b: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    lines_terminated(b).map(|(o, l, _)| (o, l))
}

/// Lines with offsets and whether each ended with a newline.
fn lines_terminated(b: &[u8]) -> impl Iterator<Item = (usize, &[u8], bool)> {
    let mut pos = 0;
    std::iter::from_fn(move || {
        if pos >= b.len() {
            return None;
        }
        let start = pos;
        let found = num::find_byte(&b[pos..], b'\n');
        let end = found.map_or(b.len(), |p| pos + p);
        pos = end + 1;
        let mut line = &b[start..end];
        if let [rest @ .., b'\r'] = line {
            line = rest;
        }
        Some((start, line, found.is_some()))
    })
}

fn fields(line: &[u8], delim: u8) -> Vec<String> {
    line.split(|&c| c == delim)
        .map(|f| String::from_utf8_lossy(unquote(trim(f))).into_owned())
        .collect()
}

/// A field without the double quotes Excel and Bluehill put around it.
fn unquote(f: &[u8]) -> &[u8] {
    match f {
        [b'"', inner @ .., b'"'] => inner,
        _ => f,
    }
}

/// A column name that counts samples rather than timing them (`id`, `index`, `sample`,
/// …): taken as seconds, it would silently give every row a one-second period.
fn is_index_column(name: &str) -> bool {
    let n = name
        .trim()
        .trim_start_matches('#')
        .trim()
        .to_ascii_lowercase();
    matches!(
        n.as_str(),
        "" | "id"
            | "index"
            | "idx"
            | "n"
            | "no"
            | "nr"
            | "row"
            | "sample"
            | "samples"
            | "frame"
            | "serial"
            | "count"
            | "seq"
            | "sequence"
    )
}

/// A units row under a force log's header: every field a unit in brackets, like
/// `(s),(mm),(kN)`.
fn is_units_row(line: &[u8], delim: u8) -> bool {
    let fs = fields(line, delim);
    fs.iter().any(|f| !f.is_empty())
        && fs.iter().all(|f| {
            f.is_empty()
                || (f.starts_with('(') && f.ends_with(')'))
                || (f.starts_with('[') && f.ends_with(']'))
        })
}

fn is_time_field(f: &[u8]) -> bool {
    num::parse_f64(f, false).is_some() || num::parse_datetime(f).is_some()
}

/// Find the table of a wavelength log. With `forced`, look only for that format's
/// header. The header must be within the first 4 MB.
pub fn detect_format(bytes: &[u8], path: &Path, forced: Option<LogFormat>) -> Result<Detected> {
    let (b, bom) = strip_bom(bytes);
    let window = &b[..b.len().min(4 << 20)];
    let mut first_content: Option<(usize, usize, &[u8])> = None;
    for (line_no, (off, line)) in lines_with_offsets(window).enumerate() {
        let mut it = line.split(|&c| c == b'\t');
        let f0 = trim(it.next().unwrap_or(b""));
        let f1 = trim(it.next().unwrap_or(b""));
        let next_line = || {
            let end = off + line.len();
            let nl = window[end..]
                .iter()
                .position(|&c| c == b'\n')
                .map_or(window.len(), |p| end + p + 1);
            (nl + bom, line_no + 2)
        };
        let want = |f: LogFormat| forced.is_none() || forced == Some(f);
        if f0.eq_ignore_ascii_case(b"Timestamp") && !f1.is_empty() {
            let peaks = f1.starts_with(b"# CH") || f1.starts_with(b"#CH");
            let format = if peaks {
                LogFormat::EnlightPeaks
            } else {
                LogFormat::EnlightSensors
            };
            if want(format) {
                let (body_offset, body_line) = next_line();
                return Ok(Detected {
                    format,
                    body_offset,
                    body_line,
                    header: fields(line, b'\t'),
                    delimiter: b'\t',
                });
            }
        }
        if f0.eq_ignore_ascii_case(b"Date")
            && f1.eq_ignore_ascii_case(b"Time")
            && want(LogFormat::Imon)
        {
            let (body_offset, body_line) = next_line();
            return Ok(Detected {
                format: LogFormat::Imon,
                body_offset,
                body_line,
                header: fields(line, b'\t'),
                delimiter: b'\t',
            });
        }
        let t = trim(line);
        if first_content.is_none() && !t.is_empty() && !t.starts_with(b"#") {
            first_content = Some((off, line_no, line));
        }
    }
    if forced.is_none() || forced == Some(LogFormat::Csv) {
        if let Some((off, line_no, line)) = first_content {
            let delim = guess_delimiter(line);
            let parts: Vec<&[u8]> = line.split(|&c| c == delim).collect();
            if parts.len() >= 2 {
                let headerless = is_time_field(parts[0]);
                let (body_offset, body_line, header) = if headerless {
                    (off + bom, line_no + 1, Vec::new())
                } else {
                    let end = off + line.len();
                    let nl = window[end..]
                        .iter()
                        .position(|&c| c == b'\n')
                        .map_or(window.len(), |p| end + p + 1);
                    (nl + bom, line_no + 2, fields(line, delim))
                };
                let looks_like_table = headerless
                    || header
                        .first()
                        .is_some_and(|h| h.to_ascii_lowercase().contains("time"));
                if looks_like_table || forced == Some(LogFormat::Csv) {
                    return Ok(Detected {
                        format: LogFormat::Csv,
                        body_offset,
                        body_line,
                        header,
                        delimiter: delim,
                    });
                }
            }
        }
    }
    match forced {
        Some(f) => bail!(
            "{}: no {} table header found; expected {}",
            path.display(),
            f.name(),
            match f {
                LogFormat::EnlightPeaks => "a line `Timestamp<TAB># CH 1<TAB>…`",
                LogFormat::EnlightSensors => "a line `Timestamp<TAB>sensor name<TAB>…`",
                LogFormat::Imon => "a line `Date<TAB>Time<TAB>Wavelength 1 [nm]<TAB>…`",
                LogFormat::Csv => "a delimited table whose first column is time",
            }
        ),
        None => bail!(
            "{}: cannot tell the log format: no ENLIGHT header (`Timestamp` then `# CH 1` or sensor names), no I-MON header (`Date<TAB>Time<TAB>…`) and no CSV whose first column is a time; name the format with --format",
            path.display()
        ),
    }
}

fn guess_delimiter(line: &[u8]) -> u8 {
    let count = |d: u8| line.iter().filter(|&&c| c == d).count();
    if count(b'\t') > 0 {
        b'\t'
    } else if count(b';') > 0 {
        b';'
    } else {
        b','
    }
}

/// How the body rows of a detected table are laid out.
#[derive(Debug, Clone, Copy)]
enum Layout {
    Peaks { channels: usize },
    Sensors { columns: usize },
    Imon { pixels: usize },
    Csv { columns: usize },
}

/// A line that could not be used: warning kind and message.
struct LineIssue {
    kind: &'static str,
    message: String,
}

fn issue(kind: &'static str, message: impl Into<String>) -> LineIssue {
    LineIssue {
        kind,
        message: message.into(),
    }
}

/// Times of the rows parsed so far: either a wall-clock date + seconds of day, or
/// plain seconds.
#[derive(Default)]
struct TimeAcc {
    dates: Vec<RawDate>,
    date_of_row: Vec<u32>,
    sec: Vec<f64>,
}

const NO_DATE: u32 = u32::MAX;

impl TimeAcc {
    fn push(&mut self, t: (Option<RawDate>, f64)) {
        let idx = match t.0 {
            None => NO_DATE,
            Some(d) => match self.dates.iter().rposition(|x| *x == d) {
                Some(i) => i as u32,
                None => {
                    self.dates.push(d);
                    (self.dates.len() - 1) as u32
                }
            },
        };
        self.date_of_row.push(idx);
        self.sec.push(t.1);
    }
}

fn parse_time_field(f: &[u8], decimal_comma: bool) -> Option<(Option<RawDate>, f64)> {
    if let Some((d, s)) = num::parse_datetime(f) {
        return Some((Some(d), s));
    }
    num::parse_f64(f, decimal_comma)
        .filter(|v| v.is_finite())
        .map(|v| (None, v))
}

/// Rows parsed from one chunk.
#[derive(Default)]
struct Partial {
    times: TimeAcc,
    row_start: Vec<usize>,
    peaks: Vec<f64>,
    chans: Vec<u16>,
    lines: Vec<u32>,
    issues: Vec<(usize, LineIssue)>,
    table_lines: usize,
    n_lines: usize,
}

/// The hot path: one ENLIGHT peaks row, read in a single pass with a cursor.
fn parse_peaks_row(
    line: &[u8],
    channels: usize,
    dc: bool,
    out: &mut Partial,
    counts: &mut Vec<usize>,
) -> Result<(), LineIssue> {
    let tab = num::find_byte(line, b'\t')
        .ok_or_else(|| issue("unreadable_line", "no tab-separated fields"))?;
    let time = parse_time_field(&line[..tab], dc)
        .ok_or_else(|| issue("unreadable_line", "unreadable timestamp"))?;
    let mut pos = tab + 1;
    let skip_spaces = |pos: &mut usize| {
        while *pos < line.len() && line[*pos] == b' ' {
            *pos += 1;
        }
    };
    // After a field: a tab (consumed), or the end of the line.
    let next_field = |pos: &mut usize| -> bool {
        skip_spaces(pos);
        if *pos < line.len() && line[*pos] == b'\t' {
            *pos += 1;
            true
        } else {
            *pos >= line.len()
        }
    };
    counts.clear();
    for c in 0..channels {
        skip_spaces(&mut pos);
        if pos >= line.len() {
            return Err(issue(
                "missing_channel",
                format!("row ends before the peak count of channel {}", c + 1),
            ));
        }
        let mut v = 0usize;
        let s0 = pos;
        while pos < line.len() && line[pos].is_ascii_digit() && pos - s0 < 9 {
            v = v * 10 + (line[pos] - b'0') as usize;
            pos += 1;
        }
        if pos == s0 || !next_field(&mut pos) {
            return Err(issue(
                "unreadable_line",
                format!("peak count of channel {} is not a whole number", c + 1),
            ));
        }
        counts.push(v);
    }
    let start = out.peaks.len();
    for (c, &n) in counts.iter().enumerate() {
        for _ in 0..n {
            skip_spaces(&mut pos);
            if pos >= line.len() {
                out.peaks.truncate(start);
                out.chans.truncate(start);
                return Err(issue(
                    "peak_count_mismatch",
                    "fewer wavelengths than the peak counts announce",
                ));
            }
            match num::parse_f64_prefix(&line[pos..], dc) {
                Some((v, k)) if v.is_finite() => {
                    pos += k;
                    if !next_field(&mut pos) {
                        out.peaks.truncate(start);
                        out.chans.truncate(start);
                        return Err(issue("unreadable_line", "unreadable wavelength"));
                    }
                    out.peaks.push(v);
                    out.chans.push(c as u16);
                }
                _ => {
                    out.peaks.truncate(start);
                    out.chans.truncate(start);
                    return Err(issue("unreadable_line", "unreadable wavelength"));
                }
            }
        }
    }
    if line[pos.min(line.len())..]
        .iter()
        .any(|c| !c.is_ascii_whitespace())
    {
        out.peaks.truncate(start);
        out.chans.truncate(start);
        return Err(issue(
            "peak_count_mismatch",
            "more wavelengths than the peak counts announce",
        ));
    }
    out.times.push(time);
    out.row_start.push(out.peaks.len());
    Ok(())
}

/// One table row of any layout: its time, then its wavelengths (a bad row adds none).
fn parse_line(
    line: &[u8],
    layout: Layout,
    delim: u8,
    dc: bool,
    out: &mut Partial,
    counts: &mut Vec<usize>,
) -> Result<(), LineIssue> {
    if let Layout::Peaks { channels } = layout {
        if delim == b'\t' {
            return parse_peaks_row(line, channels, dc, out, counts);
        }
    }
    let mut it = line.split(|&c| c == delim);
    let time = parse_row_time(&mut it, layout, dc)?;
    match layout {
        Layout::Peaks { channels } => parse_split_peaks(it, channels, dc, out, counts)?,
        Layout::Sensors { columns } | Layout::Csv { columns } => {
            parse_value_columns(it, columns, dc, out)?
        }
        Layout::Imon { pixels } => parse_imon_wavelengths(it, pixels, dc, out)?,
    }
    out.times.push(time);
    out.row_start.push(out.peaks.len());
    Ok(())
}

/// Drop the wavelengths a rejected row had already added (from `start` on).
fn rollback(out: &mut Partial, start: usize) {
    out.peaks.truncate(start);
    out.chans.truncate(start);
}

/// A row's time: I-MON's date and time-of-day fields, else one timestamp field.
fn parse_row_time<'a>(
    it: &mut impl Iterator<Item = &'a [u8]>,
    layout: Layout,
    dc: bool,
) -> Result<(Option<RawDate>, f64), LineIssue> {
    Ok(match layout {
        Layout::Imon { .. } => {
            let d = it.next().unwrap_or(b"");
            let t = it
                .next()
                .ok_or_else(|| issue("unreadable_line", "no time field"))?;
            let (date, n) = num::parse_date(trim(d))
                .ok_or_else(|| issue("unreadable_line", "unreadable date"))?;
            if n != trim(d).len() {
                return Err(issue("unreadable_line", "unreadable date"));
            }
            let sod = num::parse_time_of_day(t)
                .ok_or_else(|| issue("unreadable_line", "unreadable time of day"))?;
            (Some(date), sod)
        }
        _ => {
            let f = it.next().unwrap_or(b"");
            parse_time_field(f, dc)
                .ok_or_else(|| issue("unreadable_line", "unreadable timestamp"))?
        }
    })
}

/// A peaks row split on a delimiter other than tab: counts per channel, then wavelengths.
fn parse_split_peaks<'a>(
    mut it: impl Iterator<Item = &'a [u8]>,
    channels: usize,
    dc: bool,
    out: &mut Partial,
    counts: &mut Vec<usize>,
) -> Result<(), LineIssue> {
    let start = out.peaks.len();
    counts.clear();
    for c in 0..channels {
        let f = it.next().ok_or_else(|| {
            issue(
                "missing_channel",
                format!("row ends before the peak count of channel {}", c + 1),
            )
        })?;
        counts.push(num::parse_usize(f).ok_or_else(|| {
            issue(
                "unreadable_line",
                format!("peak count of channel {} is not a whole number", c + 1),
            )
        })?);
    }
    for (c, &n) in counts.iter().enumerate() {
        for _ in 0..n {
            let Some(f) = it.next() else {
                rollback(out, start);
                return Err(issue(
                    "peak_count_mismatch",
                    "fewer wavelengths than the peak counts announce",
                ));
            };
            match num::parse_f64(f, dc) {
                Some(v) if v.is_finite() => {
                    out.peaks.push(v);
                    out.chans.push(c as u16);
                }
                _ => {
                    rollback(out, start);
                    return Err(issue("unreadable_line", "unreadable wavelength"));
                }
            }
        }
    }
    if it.any(|f| !trim(f).is_empty()) {
        rollback(out, start);
        return Err(issue(
            "peak_count_mismatch",
            "more wavelengths than the peak counts announce",
        ));
    }
    Ok(())
}

/// A sensors or CSV row: one value per header column (empty or ≤ 0: no reading).
fn parse_value_columns<'a>(
    it: impl Iterator<Item = &'a [u8]>,
    columns: usize,
    dc: bool,
    out: &mut Partial,
) -> Result<(), LineIssue> {
    let start = out.peaks.len();
    let mut seen = 0;
    for (c, f) in it.enumerate() {
        let f = trim(f);
        if c >= columns {
            if !f.is_empty() {
                rollback(out, start);
                return Err(issue(
                    "unreadable_line",
                    format!("more than the {columns} value columns of the header"),
                ));
            }
            continue;
        }
        seen = c + 1;
        if f.is_empty() {
            continue;
        }
        match num::parse_f64(f, dc) {
            Some(v) if v.is_finite() && v > 0.0 => {
                out.peaks.push(v);
                out.chans.push(c as u16);
            }
            Some(_) => {}
            None => {
                rollback(out, start);
                return Err(issue(
                    "unreadable_line",
                    format!("column {} is not a number", c + 2),
                ));
            }
        }
    }
    if seen < columns {
        // Kept (the values present are good) but counted.
        out.issues.push((
            usize::MAX,
            issue(
                "short_row",
                format!("row has {seen} of {columns} value columns"),
            ),
        ));
    }
    Ok(())
}

/// An I-MON row's wavelengths (one channel), without the trailing spectrum if any.
fn parse_imon_wavelengths<'a>(
    it: impl Iterator<Item = &'a [u8]>,
    pixels: usize,
    dc: bool,
    out: &mut Partial,
) -> Result<(), LineIssue> {
    let start = out.peaks.len();
    let rest: Vec<&[u8]> = it.map(trim).collect();
    let mut n = rest.len();
    while n > 0 && rest[n - 1].is_empty() {
        n -= 1;
    }
    // Rows that also carry the spectrum end with `pixels` intensities.
    let n_wl = if pixels > 0 && n > pixels {
        n - pixels
    } else {
        n
    };
    for f in &rest[..n_wl] {
        match num::parse_f64(f, dc) {
            Some(v) if v.is_finite() && v > 0.0 => {
                out.peaks.push(v);
                out.chans.push(0);
            }
            Some(_) => {}
            None => {
                rollback(out, start);
                return Err(issue("unreadable_line", "unreadable wavelength"));
            }
        }
    }
    Ok(())
}

fn parse_chunk(chunk: &[u8], layout: Layout, delim: u8, dc: bool) -> Partial {
    let mut out = Partial::default();
    let mut counts = Vec::new();
    for (i, (_, line, terminated)) in lines_terminated(chunk).enumerate() {
        out.n_lines = i + 1;
        if line.is_empty() || line[0] == b'#' || trim(line).is_empty() {
            continue;
        }
        out.table_lines += 1;
        let before = out.issues.len();
        match parse_line(line, layout, delim, dc, &mut out, &mut counts) {
            Ok(()) => {
                out.lines.push(i as u32);
                for iss in &mut out.issues[before..] {
                    iss.0 = i;
                }
            }
            Err(mut e) => {
                if !terminated {
                    e.kind = "truncated_last_line";
                }
                out.issues.push((i, e));
            }
        }
    }
    out
}

/// The row layout and column names of a detected table (the body's first line is
/// read for a header-less CSV, to count its columns).
fn layout_of(det: &Detected, bytes: &[u8], path: &Path) -> Result<(Layout, Vec<String>)> {
    let header_line = det.body_line.saturating_sub(1);
    Ok(match det.format {
        LogFormat::EnlightPeaks => {
            let channels = det.header[1..]
                .iter()
                .take_while(|h| h.starts_with("# CH") || h.starts_with("#CH"))
                .count();
            if channels == 0 || channels > 256 {
                bail!(
                    "{}: the header declares {channels} channels; expected 1 to 256",
                    at(path, header_line)
                );
            }
            (Layout::Peaks { channels }, Vec::new())
        }
        LogFormat::EnlightSensors => {
            let names: Vec<String> = det.header[1..]
                .iter()
                .filter(|h| !h.is_empty())
                .cloned()
                .collect();
            (
                Layout::Sensors {
                    columns: names.len(),
                },
                names,
            )
        }
        LogFormat::Imon => {
            let pixels = det.header.iter().filter(|h| h.starts_with("Pixel")).count();
            (Layout::Imon { pixels }, Vec::new())
        }
        LogFormat::Csv => {
            if let Some(first) = det.header.first().filter(|h| is_index_column(h)) {
                bail!(
                    "{}: the first column `{first}` is a sample index, not a time: a CSV log needs its time first (seconds, or a date and time); export the log with its timestamps",
                    at(path, header_line)
                );
            }
            let names: Vec<String> = if det.header.is_empty() {
                let first = lines_with_offsets(&bytes[det.body_offset..])
                    .next()
                    .map(|(_, l)| l)
                    .unwrap_or(b"");
                (1..first.split(|&c| c == det.delimiter).count())
                    .map(|i| format!("column {}", i + 1))
                    .collect()
            } else {
                det.header[1..].to_vec()
            };
            (
                Layout::Csv {
                    columns: names.len(),
                },
                names,
            )
        }
    })
}

/// Cut the table body at line boundaries into chunks to parse in parallel (one chunk
/// for a body under 4 MiB).
fn chunk_bounds(body: &[u8]) -> Vec<(usize, usize)> {
    let n_chunks = if body.len() > (4 << 20) {
        rayon::current_num_threads() * 8
    } else {
        1
    };
    let mut bounds = vec![0usize];
    for k in 1..n_chunks {
        let target = body.len() * k / n_chunks;
        let last = *bounds.last().unwrap_or(&0);
        if target <= last {
            continue;
        }
        match body[target..].iter().position(|&c| c == b'\n') {
            Some(p) => bounds.push(target + p + 1),
            None => break,
        }
    }
    bounds.push(body.len());
    bounds.dedup();
    bounds.windows(2).map(|w| (w[0], w[1])).collect()
}

/// The chunks' rows merged in file order, with the dates interned once and the
/// unreadable lines counted.
struct Merged {
    dates: Vec<RawDate>,
    date_of_row: Vec<u32>,
    sec: Vec<f64>,
    row_start: Vec<usize>,
    peaks: Vec<f64>,
    chans: Vec<u16>,
    lines: Vec<u32>,
    warnings: LogWarnings,
    /// Lines unreadable as rows (not counting short or truncated ones).
    bad: usize,
    first_bad: Option<String>,
    table_lines: usize,
}

/// Merge the chunks in order: chunk-local line numbers become file line numbers,
/// chunk-local date indices global ones, and each issue a named warning.
fn merge_partials(partials: Vec<Partial>, body_line: usize, path: &Path) -> Merged {
    let rows: usize = partials.iter().map(|p| p.lines.len()).sum();
    let n_peaks: usize = partials.iter().map(|p| p.peaks.len()).sum();
    let mut m = Merged {
        dates: Vec::new(),
        date_of_row: Vec::with_capacity(rows),
        sec: Vec::with_capacity(rows),
        row_start: Vec::with_capacity(rows + 1),
        peaks: Vec::with_capacity(n_peaks),
        chans: Vec::with_capacity(n_peaks),
        lines: Vec::with_capacity(rows),
        warnings: LogWarnings::default(),
        bad: 0,
        first_bad: None,
        table_lines: partials.iter().map(|p| p.table_lines).sum(),
    };
    m.row_start.push(0usize);
    let mut first_line = body_line;
    for p in partials {
        let dates = &mut m.dates;
        let remap: Vec<u32> = p
            .times
            .dates
            .iter()
            .map(|d| match dates.iter().position(|x| x == d) {
                Some(i) => i as u32,
                None => {
                    dates.push(*d);
                    (dates.len() - 1) as u32
                }
            })
            .collect();
        m.date_of_row.extend(p.times.date_of_row.iter().map(|&i| {
            if i == NO_DATE {
                NO_DATE
            } else {
                remap[i as usize]
            }
        }));
        m.sec.extend_from_slice(&p.times.sec);
        let base = m.peaks.len();
        m.row_start.extend(p.row_start.iter().map(|&s| s + base));
        m.peaks.extend_from_slice(&p.peaks);
        m.chans.extend_from_slice(&p.chans);
        m.lines
            .extend(p.lines.iter().map(|&l| l + first_line as u32));
        for (local, iss) in p.issues {
            let line_no = local + first_line;
            if iss.kind != "short_row" && iss.kind != "truncated_last_line" {
                m.bad += 1;
                if m.first_bad.is_none() {
                    m.first_bad = Some(format!("{}: {}", at(path, line_no), iss.message));
                }
            }
            let msg = format!("{}: {}", at(path, line_no), iss.message);
            m.warnings.add(iss.kind, || msg);
        }
        first_line += p.n_lines;
    }
    m
}

/// The rows' times in seconds and their clock: plain seconds (wall-clock when they
/// are that large), or dates resolved in the day/month order the file tells or the
/// user names.
fn wavelength_times(
    m: &mut Merged,
    format: LogFormat,
    date_order: Option<DateOrder>,
    path: &Path,
) -> Result<(Vec<f64>, Clock)> {
    let rows = m.lines.len();
    let with_dates = m.date_of_row.iter().filter(|&&d| d != NO_DATE).count();
    if with_dates == 0 {
        let sec = std::mem::take(&mut m.sec);
        let clock = if sec.first().is_some_and(|&s| s > 1e8) {
            Clock::Absolute
        } else {
            Clock::Relative
        };
        return Ok((sec, clock));
    }
    if with_dates != rows {
        let i = m
            .date_of_row
            .iter()
            .position(|&d| d == NO_DATE)
            .unwrap_or(0);
        bail!(
            "{}: this row has a plain number for time while other rows have dates",
            at(path, m.lines[i] as usize)
        );
    }
    let default = if format == LogFormat::Imon {
        DateOrder::MonthDayYear
    } else {
        DateOrder::DayMonthYear
    };
    let order = match date_order {
        Some(o) => o,
        None => num::resolve_order(&m.dates, default)
            .map_err(|e| anyhow!("{}: {e}; name the order with --date-order", path.display()))?,
    };
    let mut days = Vec::with_capacity(m.dates.len());
    for (k, d) in m.dates.iter().enumerate() {
        match num::date_to_days(d, order) {
            Ok(v) => days.push(v),
            Err(e) => {
                let i = m
                    .date_of_row
                    .iter()
                    .position(|&x| x as usize == k)
                    .unwrap_or(0);
                bail!(
                    "{}: {e} (read as {:?})",
                    at(path, m.lines[i] as usize),
                    order
                );
            }
        }
    }
    let t = m
        .date_of_row
        .iter()
        .zip(&m.sec)
        .map(|(&d, &s)| days[d as usize] as f64 * 86400.0 + s)
        .collect();
    Ok((t, Clock::Absolute))
}

/// Put the log's rows (peaks, channels, lines, times) in the order `order`.
fn reorder_rows(log: &mut PeakLog, time_s: &mut Vec<f64>, order: &[usize]) {
    let rows = order.len();
    let mut rs = Vec::with_capacity(rows + 1);
    rs.push(0);
    let mut pk = Vec::with_capacity(log.peaks_nm.len());
    let mut ch = Vec::with_capacity(log.peaks_nm.len());
    let mut ln = Vec::with_capacity(rows);
    let mut ts = Vec::with_capacity(rows);
    for &i in order {
        let (a, b) = (log.row_start[i], log.row_start[i + 1]);
        pk.extend_from_slice(&log.peaks_nm[a..b]);
        ch.extend_from_slice(&log.peak_channel[a..b]);
        rs.push(pk.len());
        ln.push(log.line_of_row[i]);
        ts.push(time_s[i]);
    }
    log.row_start = rs;
    log.peaks_nm = pk;
    log.peak_channel = ch;
    log.line_of_row = ln;
    *time_s = ts;
}

/// Parse a wavelength log held in memory.
pub fn parse_wavelength_bytes(bytes: &[u8], path: &Path, opts: &ReadOptions) -> Result<PeakLog> {
    let det = detect_format(bytes, path, opts.format)?;
    let (layout, column_names) = layout_of(&det, bytes, path)?;
    let channels = match layout {
        Layout::Peaks { channels } => channels,
        Layout::Sensors { columns } | Layout::Csv { columns } => columns,
        Layout::Imon { .. } => 1,
    };
    let dc = det.delimiter != b',';
    let body = &bytes[det.body_offset.min(bytes.len())..];
    let partials: Vec<Partial> = chunk_bounds(body)
        .par_iter()
        .map(|&(a, b)| parse_chunk(&body[a..b], layout, det.delimiter, dc))
        .collect();
    let mut m = merge_partials(partials, det.body_line, path);
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
    super::require_rows(path, rows, "the log")?;
    let (mut time_s, clock) = wavelength_times(&mut m, det.format, opts.date_order, path)?;
    let mut log = PeakLog {
        source: path.to_path_buf(),
        format: det.format,
        time_s: Vec::new(),
        clock,
        row_start: m.row_start,
        peaks_nm: m.peaks,
        peak_channel: m.chans,
        channels,
        column_names,
        line_of_row: m.lines,
        time_uncertainty_s: 0.0,
        warnings: m.warnings,
    };
    if let Some(order) = super::finish_times(path, &mut time_s, &log.line_of_row, &mut log.warnings)
    {
        reorder_rows(&mut log, &mut time_s, &order);
    }
    log.time_uncertainty_s = super::dequantize(path, &mut time_s, &mut log.warnings);
    log.time_s = time_s;
    Ok(log)
}

/// A time for a message: plain decimals, scientific notation when absurdly large.
fn readable_s(t: f64) -> String {
    if t.abs() < 1e9 {
        format!("{t}")
    } else {
        format!("{t:e}")
    }
}

/// Refuse a force log whose time column runs backwards, naming the first lines where it
/// does.
fn check_force_times_increase(path: &Path, time_s: &[f64], line_nos: &[u32]) -> Result<()> {
    let backward: Vec<usize> = (1..time_s.len())
        .filter(|&i| time_s[i] < time_s[i - 1])
        .collect();
    if let Some(&i) = backward.first() {
        let lines: Vec<String> = backward
            .iter()
            .take(5)
            .map(|&k| line_nos[k].to_string())
            .collect();
        bail!(
            "{}: the force log's time runs backwards ({} s after {} s) at {} of its {} rows (lines {}{}); a force log's times must increase: fix or remove those rows",
            at(path, line_nos[i] as usize),
            readable_s(time_s[i]),
            readable_s(time_s[i - 1]),
            backward.len(),
            time_s.len(),
            lines.join(", "),
            if backward.len() > 5 { ", …" } else { "" }
        );
    }
    // A corrupted time at either end cannot run backwards, but it stretches the log:
    // a first or last step a hundred times longer than all the other samples span.
    let n = time_s.len();
    if n >= 4 {
        let inner = time_s[n - 2] - time_s[1];
        for (odd, step) in [
            (0, time_s[1] - time_s[0]),
            (n - 1, time_s[n - 1] - time_s[n - 2]),
        ] {
            if inner > 0.0 && step > 100.0 * inner {
                bail!(
                    "{}: the force log's time jumps by {} s to this sample, while the other {} samples span {} s: a corrupted time? fix or remove that row",
                    at(path, line_nos[odd] as usize),
                    readable_s(step),
                    n - 1,
                    readable_s(inner)
                );
            }
        }
    }
    Ok(())
}

/// A force log's header line: where it is, its delimiter and its column names.
struct ForceHeader<'a> {
    /// Index of the header line (0-based).
    idx: usize,
    line: &'a [u8],
    names: Vec<String>,
    /// True when the first line is already data (no header).
    headerless: bool,
}

impl ForceHeader<'_> {
    /// The column holding `what`: the one named by the user, else a default name, else a
    /// default with a unit suffix (`force [N]`, `Time (s)`); columns 1 and 2 without a
    /// header.
    fn column(
        &self,
        wanted: &Option<String>,
        defaults: &[&str],
        what: &str,
        path: &Path,
    ) -> Result<usize> {
        let header = &self.names;
        if self.headerless {
            return Ok(if what == "time" { 0 } else { 1 });
        }
        if let Some(w) = wanted {
            return header
                .iter()
                .position(|h| h.eq_ignore_ascii_case(w))
                .ok_or_else(|| {
                    anyhow!(
                        "{}: no {what} column named `{w}`; the header has: {}",
                        at(path, self.idx + 1),
                        header.join(", ")
                    )
                });
        }
        for d in defaults {
            if let Some(i) = header.iter().position(|h| h.eq_ignore_ascii_case(d)) {
                return Ok(i);
            }
        }
        for d in defaults {
            if let Some(i) = header.iter().position(|h| {
                let l = h.to_ascii_lowercase();
                l.starts_with(&d.to_ascii_lowercase())
                    && l[d.len()..].starts_with([' ', '_', '[', '('])
            }) {
                return Ok(i);
            }
        }
        bail!(
            "{}: cannot tell which column holds {what}; the header has: {}; name it with --force-{what}-column",
            at(path, self.idx + 1),
            header.join(", ")
        )
    }
}

/// Which columns of a force log hold time and force, and how to read them.
struct ForceLayout {
    delim: u8,
    /// Numbers use a decimal comma (any delimiter but a comma).
    dc: bool,
    ti: usize,
    fi: usize,
    time_column: String,
    force_column: String,
}

impl ForceLayout {
    /// The time column's factor to seconds and the force column's to newtons, from
    /// their names or the units row (`(s),(mm),(kN)`); newtons assumed, with a warning,
    /// when nothing names the force's unit.
    fn scales(
        &self,
        units: &[String],
        cols: &ForceColumns,
        path: &Path,
        warnings: &mut LogWarnings,
    ) -> (f64, f64) {
        let unit_of = |i: usize, name: &str| {
            units
                .get(i)
                .filter(|u| !u.is_empty())
                .map(|u| format!("{name} {u}"))
                .unwrap_or_else(|| name.to_string())
        };
        let time_named = unit_of(self.ti, &self.time_column);
        let force_named = unit_of(self.fi, &self.force_column);
        let time_scale_s = super::time_unit_scale(&time_named).unwrap_or(1.0);
        let scale = match (cols.scale_to_n, super::force_unit_scale(&force_named)) {
            (Some(s), _) => s,
            (None, Some(s)) => s,
            (None, None) => {
                let force_column = &self.force_column;
                warnings.add("force_unit_assumed", || {
                    format!(
                        "{}: force column `{force_column}` names no unit; newtons assumed",
                        path.display()
                    )
                });
                1.0
            }
        };
        (time_scale_s, scale)
    }
}

/// The readable rows of a force log.
struct ForceRows {
    times: TimeAcc,
    /// Force, N.
    force: Vec<f64>,
    /// File line of each row.
    line_nos: Vec<u32>,
}

/// Read the force log's rows; an unreadable line is counted and named, and more than
/// half of them unreadable (or none readable) is an error.
fn read_force_rows<'a>(
    b: &[u8],
    body: impl Iterator<Item = (usize, (usize, &'a [u8]))>,
    lay: &ForceLayout,
    scale: f64,
    path: &Path,
    warnings: &mut LogWarnings,
) -> Result<ForceRows> {
    let (time_column, force_column) = (&lay.time_column, &lay.force_column);
    let mut rows = ForceRows {
        times: TimeAcc::default(),
        force: Vec::new(),
        line_nos: Vec::new(),
    };
    let mut bad = 0usize;
    let mut total = 0usize;
    let mut first_bad = None;
    let unterminated = !b.ends_with(b"\n");
    let n_lines = b.iter().filter(|&&c| c == b'\n').count() + usize::from(unterminated);
    for (idx, (_, line)) in body {
        total += 1;
        let parts: Vec<&[u8]> = line
            .split(|&c| c == lay.delim)
            .map(|f| unquote(trim(f)))
            .collect();
        let t = parts.get(lay.ti).and_then(|f| parse_time_field(f, lay.dc));
        let f = parts
            .get(lay.fi)
            .and_then(|f| num::parse_f64(f, lay.dc))
            .filter(|v| v.is_finite());
        if let (Some(t), Some(f)) = (t, f) {
            rows.times.push(t);
            rows.force.push(f * scale);
            rows.line_nos.push((idx + 1) as u32);
            continue;
        }
        let kind = if unterminated && idx + 1 == n_lines {
            "truncated_last_line"
        } else {
            "unreadable_line"
        };
        if kind == "unreadable_line" {
            bad += 1;
        }
        let msg = format!(
            "{}: expected a time in `{time_column}` and a number in `{force_column}`",
            at(path, idx + 1)
        );
        if first_bad.is_none() {
            first_bad = Some(msg.clone());
        }
        warnings.add(kind, || msg);
    }
    if rows.force.is_empty() || bad * 2 > total {
        bail!(
            "{}: {bad} of {total} rows are unreadable{}",
            path.display(),
            first_bad
                .map(|m| format!("; first: {m}"))
                .unwrap_or_default()
        );
    }
    Ok(rows)
}

/// The force log's times in seconds and their clock: plain numbers in the column's
/// unit (`time_ms`, `Time [ms]`, a units row), or dates resolved to wall-clock time.
fn force_times(
    times: &TimeAcc,
    time_scale_s: f64,
    date_order: Option<DateOrder>,
    path: &Path,
) -> Result<(Vec<f64>, Clock)> {
    if times.dates.is_empty() {
        let sec: Vec<f64> = times.sec.iter().map(|t| t * time_scale_s).collect();
        let clock = if sec[0] > 1e8 {
            Clock::Absolute
        } else {
            Clock::Relative
        };
        return Ok((sec, clock));
    }
    if times.date_of_row.contains(&NO_DATE) {
        bail!(
            "{}: the time column mixes dates and plain numbers",
            path.display()
        );
    }
    let order = match date_order {
        Some(o) => o,
        None => num::resolve_order(&times.dates, DateOrder::DayMonthYear)
            .map_err(|e| anyhow!("{}: {e}", path.display()))?,
    };
    let days: Vec<i64> = times
        .dates
        .iter()
        .map(|d| num::date_to_days(d, order).map_err(|e| anyhow!("{}: {e}", path.display())))
        .collect::<Result<_>>()?;
    let t = times
        .date_of_row
        .iter()
        .zip(&times.sec)
        .map(|(&d, &s)| days[d as usize] as f64 * 86400.0 + s)
        .collect();
    Ok((t, Clock::Absolute))
}

/// Parse a force-stand CSV held in memory.
pub fn parse_force_bytes(bytes: &[u8], path: &Path, cols: &ForceColumns) -> Result<ForceLog> {
    let (b, _) = strip_bom(bytes);
    let mut lines = lines_with_offsets(b).enumerate().filter(|(_, (_, l))| {
        let t = trim(l);
        !t.is_empty() && !t.starts_with(b"#")
    });
    let Some((h_idx, (_, header_line))) = lines.next() else {
        bail!("{}: the force log is empty", path.display());
    };
    let delim = guess_delimiter(header_line);
    let header = ForceHeader {
        idx: h_idx,
        line: header_line,
        names: fields(header_line, delim),
        headerless: header_line.split(|&c| c == delim).all(is_time_field),
    };
    let mut warnings = LogWarnings::default();
    let time_defaults = ["time_s", "RelTime", "time", "t", "AbsTime", "Timestamp"];
    let ti = header.column(&cols.time, &time_defaults, "time", path)?;
    let fi = header.column(
        &cols.force,
        &["force_N", "force", "F", "load"],
        "force",
        path,
    )?;
    let name_of = |i: usize, fallback: &str| {
        header
            .names
            .get(i)
            .cloned()
            .unwrap_or_else(|| fallback.into())
    };
    let lay = ForceLayout {
        delim,
        dc: delim != b',',
        ti,
        fi,
        time_column: name_of(ti, "column 1"),
        force_column: name_of(fi, "column 2"),
    };
    let mut lines = lines.peekable();
    // A units row (`(s),(mm),(kN)`) names the units the header leaves out.
    let units: Vec<String> = match lines.peek() {
        Some((_, (_, l))) if !header.headerless && is_units_row(l, delim) => {
            let u = fields(l, delim);
            lines.next();
            u
        }
        _ => Vec::new(),
    };
    let (time_scale_s, scale) = lay.scales(&units, cols, path, &mut warnings);
    type Lines<'a> = Box<dyn Iterator<Item = (usize, (usize, &'a [u8]))> + 'a>;
    let body: Lines = if header.headerless {
        Box::new(std::iter::once((header.idx, (0, header.line))).chain(lines))
    } else {
        Box::new(lines)
    };
    let rows = read_force_rows(b, body, &lay, scale, path, &mut warnings)?;
    super::require_rows(path, rows.force.len(), "the force log")?;
    let (mut time_s, clock) = force_times(&rows.times, time_scale_s, cols.date_order, path)?;
    // A force stand writes its samples in time order: a time that runs backwards is a
    // corrupted or mis-parsed value, and sorting it in would stretch the log over the
    // wrong span (one time of -1e308 among 1836 samples gave K = -13 867 pm/N).
    check_force_times_increase(path, &time_s, &rows.line_nos)?;
    let time_uncertainty_s = super::dequantize(path, &mut time_s, &mut warnings);
    Ok(ForceLog {
        source: path.to_path_buf(),
        time_s,
        clock,
        force_n: rows.force,
        time_column: lay.time_column,
        force_column: lay.force_column,
        scale_to_n: scale,
        time_uncertainty_s,
        warnings,
    })
}

/// One row of a log read on its own: the live mode's tail of a file an interrogator
/// is still writing.
#[derive(Debug, Clone, PartialEq)]
pub struct LogRow {
    /// Time of the row, s: wall-clock seconds since 1970 when the row carries a date
    /// (resolved with the reader's date order), else the plain number written.
    pub time_s: f64,
    /// Peak wavelengths, nm.
    pub peaks_nm: Vec<f64>,
    /// Channel (ENLIGHT) or column (CSV, Sensors) of each peak, from 0.
    pub channels: Vec<u16>,
}

/// Parses the rows of a log one line at a time with the same row parsers as
/// [`parse_wavelength_bytes`], for a file that is still growing.
pub struct RowReader {
    format: LogFormat,
    layout: Layout,
    delimiter: u8,
    decimal_comma: bool,
    date_order: DateOrder,
    scratch: Partial,
    counts: Vec<usize>,
}

impl RowReader {
    /// Detect the table in `head` (the complete lines written so far) and return the
    /// reader with the byte offset of the first body line. A slash date is read in
    /// `opts.date_order`, else the format's usual order (a single row cannot tell).
    pub fn new(head: &[u8], path: &Path, opts: &ReadOptions) -> Result<(RowReader, usize)> {
        let det = detect_format(head, path, opts.format)?;
        let (layout, _) = layout_of(&det, head, path)?;
        let default_order = if det.format == LogFormat::Imon {
            DateOrder::MonthDayYear
        } else {
            DateOrder::DayMonthYear
        };
        Ok((
            RowReader {
                format: det.format,
                layout,
                delimiter: det.delimiter,
                decimal_comma: det.delimiter != b',',
                date_order: opts.date_order.unwrap_or(default_order),
                scratch: Partial::default(),
                counts: Vec::new(),
            },
            det.body_offset,
        ))
    }

    /// The detected format.
    pub fn format(&self) -> LogFormat {
        self.format
    }

    /// Parse one line (without its newline). `Ok(None)` for a blank or comment line;
    /// `Err((kind, message))` for a line that cannot be used, with the warning kind the
    /// whole-file reader would count.
    pub fn parse(&mut self, line: &[u8]) -> Result<Option<LogRow>, (&'static str, String)> {
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        if line.is_empty() || line[0] == b'#' || trim(line).is_empty() {
            return Ok(None);
        }
        let out = &mut self.scratch;
        *out = Partial::default();
        parse_line(
            line,
            self.layout,
            self.delimiter,
            self.decimal_comma,
            out,
            &mut self.counts,
        )
        .map_err(|e| (e.kind, e.message))?;
        let (date, sec) = (out.times.date_of_row[0], out.times.sec[0]);
        let time_s = if date == NO_DATE {
            sec
        } else {
            let days = num::date_to_days(&out.times.dates[date as usize], self.date_order)
                .map_err(|e| ("unreadable_line", e))?;
            days as f64 * 86400.0 + sec
        };
        Ok(Some(LogRow {
            time_s,
            peaks_nm: std::mem::take(&mut out.peaks),
            channels: std::mem::take(&mut out.chans),
        }))
    }
}
