//! The line and row machinery every log format shares: lines with their offsets,
//! fields, the rows parsed so far ([`Partial`]), the chunked parallel parse of a table
//! body and the merge of its chunks in file order.
//!
//! The table body is split at line boundaries into chunks parsed in parallel (rayon);
//! each line is cut into fields by slicing, and numbers are parsed from the bytes
//! ([`super::num`]), so no row allocates. Dates are interned per chunk (a log rarely
//! spans more than a few dates) and resolved once the whole file is known
//! ([`super::time`]).

use super::num::{self, trim, RawDate};
use super::time::{TimeAcc, NO_DATE};
use super::{at, LogWarnings, RowParser};
use rayon::prelude::*;
use std::path::Path;

const BOM: &[u8] = b"\xEF\xBB\xBF";

/// The bytes without a leading UTF-8 byte-order mark, and the mark's length.
pub(crate) fn strip_bom(b: &[u8]) -> (&[u8], usize) {
    if b.starts_with(BOM) {
        (&b[3..], 3)
    } else {
        (b, 0)
    }
}

/// Lines of `b` with their byte offsets (line without `\n` and trailing `\r`).
pub(crate) fn lines_with_offsets(b: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
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
        let found = memchr::memchr(b'\n', &b[pos..]);
        let end = found.map_or(b.len(), |p| pos + p);
        pos = end + 1;
        let mut line = &b[start..end];
        if let [rest @ .., b'\r'] = line {
            line = rest;
        }
        Some((start, line, found.is_some()))
    })
}

/// Offset in `b` of the line after the one at `offset` (`line` as
/// [`lines_with_offsets`] gives it), or the end of `b`.
pub(crate) fn next_line_offset(b: &[u8], offset: usize, line: &[u8]) -> usize {
    let end = offset + line.len();
    memchr::memchr(b'\n', &b[end..]).map_or(b.len(), |p| end + p + 1)
}

/// The fields of a line, trimmed and without surrounding double quotes.
pub(crate) fn fields(line: &[u8], delim: u8) -> Vec<String> {
    line.split(|&c| c == delim)
        .map(|f| String::from_utf8_lossy(unquote(trim(f))).into_owned())
        .collect()
}

/// A field without the double quotes Excel and Bluehill put around it.
pub(crate) fn unquote(f: &[u8]) -> &[u8] {
    match f {
        [b'"', inner @ .., b'"'] => inner,
        _ => f,
    }
}

/// The delimiter of a delimited line: a tab if it has one, else a semicolon, else a
/// comma.
pub(crate) fn guess_delimiter(line: &[u8]) -> u8 {
    if memchr::memchr(b'\t', line).is_some() {
        b'\t'
    } else if memchr::memchr(b';', line).is_some() {
        b';'
    } else {
        b','
    }
}

/// A field holding a time: a number of seconds or a date and time.
pub(crate) fn is_time_field(f: &[u8]) -> bool {
    num::parse_f64(f, false).is_some() || num::parse_datetime(f).is_some()
}

/// A time field: a date and time of day, or plain (finite) seconds.
#[inline]
pub(crate) fn parse_time_field(f: &[u8], decimal_comma: bool) -> Option<(Option<RawDate>, f64)> {
    if let Some((d, s)) = num::parse_datetime(f) {
        return Some((Some(d), s));
    }
    num::parse_f64(f, decimal_comma)
        .filter(|v| v.is_finite())
        .map(|v| (None, v))
}

/// A line that could not be used: warning kind and message.
pub(crate) struct LineIssue {
    pub(crate) kind: &'static str,
    pub(crate) message: String,
}

/// A [`LineIssue`] of `kind`.
pub(crate) fn issue(kind: &'static str, message: impl Into<String>) -> LineIssue {
    LineIssue {
        kind,
        message: message.into(),
    }
}

/// Rows parsed from one chunk of a table (or one line, for the live reader).
#[derive(Default)]
pub(crate) struct Partial {
    pub(crate) times: TimeAcc,
    /// End of each row's peaks in `peaks` (the start of the next).
    pub(crate) row_start: Vec<usize>,
    /// Peak wavelengths, nm.
    pub(crate) peaks: Vec<f64>,
    /// Channel or column of each peak.
    pub(crate) chans: Vec<u16>,
    /// Uncertainty of each peak, for rows of peaks found in spectra (or read with
    /// their standard errors); empty otherwise.
    pub(crate) quality: Vec<super::PeakQuality>,
    /// Chunk-local line index of each row.
    pub(crate) lines: Vec<u32>,
    /// (chunk-local line, issue); a row parser pushes kept-but-counted issues with the
    /// line `usize::MAX`, which [`parse_chunk`] replaces.
    pub(crate) issues: Vec<(usize, LineIssue)>,
    table_lines: usize,
    n_lines: usize,
}

impl Partial {
    /// Close a row read whole: its time, after its peaks.
    #[inline]
    pub(crate) fn end_row(&mut self, time: (Option<RawDate>, f64)) {
        self.times.push(time);
        self.row_start.push(self.peaks.len());
    }

    /// Drop the wavelengths a rejected row had already added (from `start` on).
    #[inline]
    pub(crate) fn rollback(&mut self, start: usize) {
        self.peaks.truncate(start);
        self.chans.truncate(start);
        self.quality.truncate(start);
    }
}

/// Rows of one value per column after the time (ENLIGHT Sensors, plain CSV): an empty
/// value or one ≤ 0 is no reading.
pub(crate) struct ValueColumns {
    pub(crate) delimiter: u8,
    pub(crate) decimal_comma: bool,
    /// Number of value columns the header declares.
    pub(crate) columns: usize,
    /// For a peaks log with standard errors (`<name> std_error_pm` columns): per value
    /// column, `None` for a wavelength column, `Some(k)` for the standard error of the
    /// wavelength column k; empty when the log has none (then no quality is kept).
    pub(crate) std_error_of: Vec<Option<usize>>,
}

impl RowParser for ValueColumns {
    fn parse(
        &self,
        line: &[u8],
        out: &mut Partial,
        _scratch: &mut Vec<usize>,
    ) -> Result<(), LineIssue> {
        let (columns, dc) = (self.columns, self.decimal_comma);
        let mut it = line.split(|&c| c == self.delimiter);
        let time = parse_time_field(it.next().unwrap_or(b""), dc)
            .ok_or_else(|| issue("unreadable_line", "unreadable timestamp"))?;
        let start = out.peaks.len();
        let mut seen = 0;
        // (wavelength column, index of its peak in `out`) for the standard errors.
        let mut peak_of_column: Vec<(usize, usize)> = Vec::new();
        for (c, f) in it.enumerate() {
            let f = trim(f);
            if c >= columns {
                if !f.is_empty() {
                    out.rollback(start);
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
            if let Some(&Some(k)) = self.std_error_of.get(c) {
                // A standard error: it belongs to column k's peak, read before it.
                let se = num::parse_f64(f, dc).filter(|v| v.is_finite() && *v >= 0.0);
                match (se, peak_of_column.iter().find(|(col, _)| *col == k)) {
                    (Some(v), Some(&(_, i))) => out.quality[i].std_error_pm = v,
                    (Some(_), None) => {}
                    (None, _) => {
                        out.rollback(start);
                        return Err(issue(
                            "unreadable_line",
                            format!(
                                "column {} is not a standard error in pm (a number ≥ 0)",
                                c + 2
                            ),
                        ));
                    }
                }
                continue;
            }
            match num::parse_f64(f, dc) {
                Some(v) if v.is_finite() && v > 0.0 => {
                    if !self.std_error_of.is_empty() {
                        peak_of_column.push((c, out.peaks.len()));
                        out.quality
                            .push(super::PeakQuality::std_error_only(f64::NAN));
                    }
                    out.peaks.push(v);
                    out.chans.push(c as u16);
                }
                Some(_) => {}
                None => {
                    out.rollback(start);
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
        out.end_row(time);
        Ok(())
    }
}

/// Whether a line is blank or a `#` comment (not a table line).
#[inline]
pub(crate) fn is_blank_or_comment(line: &[u8]) -> bool {
    line.is_empty() || line[0] == b'#' || trim(line).is_empty()
}

/// Parse every line of `chunk` with `parser` (see [`RowParser::parse_chunk`]).
#[inline]
pub(crate) fn parse_chunk<P: RowParser + ?Sized>(parser: &P, chunk: &[u8]) -> Partial {
    let mut out = Partial::default();
    let mut scratch = Vec::new();
    for (i, (_, line, terminated)) in lines_terminated(chunk).enumerate() {
        out.n_lines = i + 1;
        if is_blank_or_comment(line) {
            continue;
        }
        out.table_lines += 1;
        let before = out.issues.len();
        match parser.parse(line, &mut out, &mut scratch) {
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
        match memchr::memchr(b'\n', &body[target..]) {
            Some(p) => bounds.push(target + p + 1),
            None => break,
        }
    }
    bounds.push(body.len());
    bounds.dedup();
    bounds.windows(2).map(|w| (w[0], w[1])).collect()
}

/// A table's rows in file order, with the dates interned once and the unreadable
/// lines counted.
pub(crate) struct Merged {
    pub(crate) times: TimeAcc,
    pub(crate) row_start: Vec<usize>,
    pub(crate) peaks: Vec<f64>,
    pub(crate) chans: Vec<u16>,
    pub(crate) quality: Vec<super::PeakQuality>,
    /// File line (1-based) of each row.
    pub(crate) lines: Vec<u32>,
    pub(crate) warnings: LogWarnings,
    /// Lines unreadable as rows (not counting short or truncated ones).
    pub(crate) bad: usize,
    /// The first unreadable line, named.
    pub(crate) first_bad: Option<String>,
    /// Lines that are neither blank nor comments.
    pub(crate) table_lines: usize,
}

/// Parse a table body (its first line is file line `body_line`) with `parser`, in
/// parallel chunks merged in file order.
pub(crate) fn parse_body(
    body: &[u8],
    body_line: usize,
    parser: &dyn RowParser,
    path: &Path,
) -> Merged {
    let partials: Vec<Partial> = chunk_bounds(body)
        .par_iter()
        .map(|&(a, b)| parser.parse_chunk(&body[a..b]))
        .collect();
    merge_partials(partials, body_line, path)
}

/// Merge the chunks in order: chunk-local line numbers become file line numbers,
/// chunk-local date indices global ones, and each issue a named warning.
fn merge_partials(partials: Vec<Partial>, body_line: usize, path: &Path) -> Merged {
    let mut m = Merged::with_table_lines(0);
    let mut first_line = body_line;
    m.reserve(&partials);
    m.append(partials, &mut first_line, path);
    m
}

impl Merged {
    /// An empty table.
    fn with_table_lines(table_lines: usize) -> Merged {
        Merged {
            times: TimeAcc {
                dates: Vec::new(),
                date_of_row: Vec::new(),
                sec: Vec::new(),
            },
            row_start: vec![0usize],
            peaks: Vec::new(),
            chans: Vec::new(),
            quality: Vec::new(),
            lines: Vec::new(),
            warnings: LogWarnings::default(),
            bad: 0,
            first_bad: None,
            table_lines,
        }
    }

    /// Room for `partials` more.
    fn reserve(&mut self, partials: &[Partial]) {
        let rows: usize = partials.iter().map(|p| p.lines.len()).sum();
        let n_peaks: usize = partials.iter().map(|p| p.peaks.len()).sum();
        self.reserve_rows(rows, n_peaks);
    }

    /// Room for `rows` more rows holding `n_peaks` more peaks.
    fn reserve_rows(&mut self, rows: usize, n_peaks: usize) {
        self.reserve_times(rows);
        self.row_start.reserve(rows);
        self.peaks.reserve(n_peaks);
        self.chans.reserve(n_peaks);
    }

    /// Room for `rows` more rows' times and lines (not their peaks).
    fn reserve_times(&mut self, rows: usize) {
        self.times.date_of_row.reserve(rows);
        self.times.sec.reserve(rows);
        self.lines.reserve(rows);
    }

    /// Take the peaks of the rows appended since the last call out of the table: `f`
    /// is handed their row starts (from 0) and peaks, then they are freed (the
    /// capacity kept for the next block). The rows' times and lines stay.
    pub(crate) fn take_peaks(&mut self, f: impl FnOnce(&[usize], &[f64])) {
        f(&self.row_start, &self.peaks);
        self.row_start.truncate(1);
        self.peaks.clear();
        self.chans.clear();
        self.quality.clear();
    }

    /// Append the chunks of the table that starts at file line `first_line` (moved on
    /// past them), each dropped once copied.
    fn append(&mut self, partials: Vec<Partial>, first_line: &mut usize, path: &Path) {
        for p in partials {
            self.table_lines += p.table_lines;
            self.append_one(p, first_line, path);
        }
    }

    fn append_one(&mut self, p: Partial, first_line: &mut usize, path: &Path) {
        let m = self;
        let dates = &mut m.times.dates;
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
        m.times
            .date_of_row
            .extend(p.times.date_of_row.iter().map(|&i| {
                if i == NO_DATE {
                    NO_DATE
                } else {
                    remap[i as usize]
                }
            }));
        m.times.sec.extend_from_slice(&p.times.sec);
        let base = m.peaks.len();
        m.row_start.extend(p.row_start.iter().map(|&s| s + base));
        m.peaks.extend_from_slice(&p.peaks);
        m.chans.extend_from_slice(&p.chans);
        m.quality.extend_from_slice(&p.quality);
        m.lines
            .extend(p.lines.iter().map(|&l| l + *first_line as u32));
        for (local, iss) in p.issues {
            let line_no = local + *first_line;
            if iss.kind != "short_row" && iss.kind != "truncated_last_line" {
                m.bad += 1;
                if m.first_bad.is_none() {
                    m.first_bad = Some(format!("{}: {}", at(path, line_no), iss.message));
                }
            }
            let msg = format!("{}: {}", at(path, line_no), iss.message);
            m.warnings.add(iss.kind, || msg);
        }
        *first_line += p.n_lines;
    }
}

/// Bytes read from the file at a time when a table body is streamed.
pub(crate) const STREAM_BLOCK: usize = 32 << 20;

/// What is done with each block's rows once appended to the table: `None` keeps them;
/// a hook is handed the table and the rows expected in the whole body (from the first
/// block, 5 % spare), and takes the block's peaks out (the table's `row_start`, `peaks`
/// and `chans` then hold only the blocks since it last ran).
pub(crate) type BlockHook<'a> = Option<&'a mut dyn FnMut(&mut Merged, usize)>;

/// Parse a table body read from `src` block by block (the file is never held whole):
/// each block cut after its last newline, parsed in parallel chunks and appended in
/// file order; `first`: body bytes already read; `total_hint`: the body's size in bytes,
/// to reserve the table once (None: grow); `block`: bytes read at a time; `hook`: run
/// after each block ([`BlockHook`]; with one, no room is reserved for the peaks).
pub(crate) fn parse_body_stream(
    src: &mut dyn std::io::Read,
    first: Vec<u8>,
    body_line: usize,
    parser: &dyn RowParser,
    (path, total_hint, block): (&Path, Option<u64>, usize),
    mut hook: BlockHook,
) -> std::io::Result<Merged> {
    let block_len = block.max(1);
    let mut m = Merged::with_table_lines(0);
    let mut first_line = body_line;
    let mut buf = first;
    let mut eof = false;
    let mut reserved = false;
    let mut expected_rows = 0;
    while !(eof && buf.is_empty()) {
        // Fill the block, then cut it after its last newline (all of it at the end).
        while !eof && buf.len() < block_len {
            let at = buf.len();
            buf.resize(block_len.max(at + (1 << 16)), 0);
            let n = src.read(&mut buf[at..])?;
            buf.truncate(at + n);
            eof = n == 0;
        }
        let cut = if eof {
            buf.len()
        } else {
            match memchr::memrchr(b'\n', &buf) {
                Some(p) => p + 1,
                // One line longer than a block: read on.
                None => {
                    buf.reserve(block_len);
                    let at = buf.len();
                    buf.resize(at + block_len, 0);
                    let n = src.read(&mut buf[at..])?;
                    buf.truncate(at + n);
                    eof = n == 0;
                    continue;
                }
            }
        };
        let part = &buf[..cut];
        let partials: Vec<Partial> = chunk_bounds(part)
            .par_iter()
            .map(|&(a, b)| parser.parse_chunk(&part[a..b]))
            .collect();
        if !reserved {
            // The first block's rows per byte, scaled to the whole body (5 % spare).
            if let Some(total) = total_hint.filter(|_| cut > 0) {
                let scale = total as f64 / cut as f64 * 1.05;
                let rows: usize = partials.iter().map(|p| p.lines.len()).sum();
                let peaks: usize = partials.iter().map(|p| p.peaks.len()).sum();
                expected_rows = (rows as f64 * scale) as usize;
                if hook.is_some() {
                    m.reserve_times(expected_rows);
                } else {
                    m.reserve_rows(expected_rows, (peaks as f64 * scale) as usize);
                }
            }
            reserved = true;
        }
        m.append(partials, &mut first_line, path);
        if let Some(h) = hook.as_mut() {
            h(&mut m, expected_rows);
        }
        buf.drain(..cut);
    }
    Ok(m)
}
