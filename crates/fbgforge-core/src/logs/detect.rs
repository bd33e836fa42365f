//! The one place a wavelength log's format is recognised: each registered format
//! ([`LogFormat::ALL`], in that order) is asked about every line of the file's head for
//! its table header; a format recognised by its first table line instead (plain CSV)
//! is asked only when no header is found.

use super::num::trim;
use super::rows::{fields, guess_delimiter, lines_with_offsets, next_line_offset, strip_bom};
use super::LogFormat;
use anyhow::{bail, Result};
use std::path::Path;

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

impl Detected {
    /// Numbers use a decimal comma when the fields are not separated by commas (the
    /// recording PC's locale).
    pub(crate) fn decimal_comma(&self) -> bool {
        self.delimiter != b','
    }

    /// 1-based line number of the header (0 when there is none before the body).
    pub(crate) fn header_line(&self) -> usize {
        self.body_line.saturating_sub(1)
    }
}

/// A line of the file's head, offered to each format's header test: its first two
/// tab-separated fields, trimmed (the interrogators' exports are tab-separated).
pub(crate) struct HeadLine<'a> {
    /// First tab-separated field.
    pub(crate) first: &'a [u8],
    /// Second tab-separated field (empty if none).
    pub(crate) second: &'a [u8],
}

/// The file's first line that is neither blank nor a `#` comment, offered to formats
/// recognised by their table's first line.
pub(crate) struct FirstLine<'a> {
    /// The line, without its line end.
    pub(crate) line: &'a [u8],
    /// Byte offset of the line in the file.
    pub(crate) offset: usize,
    /// Byte offset of the next line in the file.
    pub(crate) next_offset: usize,
    /// 0-based line index in the file.
    pub(crate) index: usize,
}

/// Find the table of a wavelength log. With `forced`, look only for that format. The
/// header must be within the first 4 MB.
pub fn detect_format(bytes: &[u8], path: &Path, forced: Option<LogFormat>) -> Result<Detected> {
    let (b, bom) = strip_bom(bytes);
    let window = &b[..b.len().min(4 << 20)];
    if let Some(kind) = spectrum_export(window) {
        bail!(
            "{}: this is a spectrum export ({kind}), not peaks, in a layout fbgforge does not read as a spectrum: the spectra it reads are a Luna ENLIGHT / Hyperion export (a `Wvl (nm)<TAB>CH 1…` header), an I-MON log with `Pixel n` columns (with its pixel calibration) and an OSA CSV with a `Wavelength (nm),<power (unit)>` header line; or export Peaks instead (ENLIGHT: the Peaks data, `Timestamp` then `# CH n` columns, or the Sensors data; I-MON: the peak log, `Date`, `Time`, `Wavelength 1 [nm]`, …)",
            path.display()
        );
    }
    let candidates: &[LogFormat] = match &forced {
        Some(f) => std::slice::from_ref(f),
        None => &LogFormat::ALL,
    };
    let mut first_content: Option<(usize, usize, &[u8])> = None;
    for (index, (off, line)) in lines_with_offsets(window).enumerate() {
        // A plain CSV is scanned to the end of the window: memchr finds its tabs (or
        // their absence) faster than a split.
        let (first, rest) = match memchr::memchr(b'\t', line) {
            Some(p) => (&line[..p], &line[p + 1..]),
            None => (line, &b""[..]),
        };
        let second = &rest[..memchr::memchr(b'\t', rest).unwrap_or(rest.len())];
        let head = HeadLine {
            first: trim(first),
            second: trim(second),
        };
        for &format in candidates {
            if let Some(delimiter) = format.reader().header_delimiter(&head) {
                return Ok(Detected {
                    format,
                    body_offset: next_line_offset(window, off, line) + bom,
                    body_line: index + 2,
                    header: fields(line, delimiter),
                    delimiter,
                });
            }
        }
        let t = trim(line);
        if first_content.is_none() && !t.is_empty() && !t.starts_with(b"#") {
            first_content = Some((off, index, line));
        }
    }
    if let Some((off, index, line)) = first_content {
        let first = FirstLine {
            line,
            offset: off + bom,
            next_offset: next_line_offset(window, off, line) + bom,
            index,
        };
        for &format in candidates {
            if let Some(det) = format
                .reader()
                .table_at_first_line(&first, forced.is_some())
            {
                return Ok(det);
            }
        }
    }
    match forced {
        Some(f) => bail!(
            "{}: no {} table header found; expected {}",
            path.display(),
            f.name(),
            f.reader().expected()
        ),
        None => {
            let absent: Vec<String> = LogFormat::ALL
                .iter()
                .map(|f| {
                    format!(
                        "no {} table ({})",
                        f.reader().title(),
                        f.reader().expected()
                    )
                })
                .collect();
            let (last, rest) = absent.split_last().expect("formats are registered");
            bail!(
                "{}: cannot tell the log format: {} and {last}; name the format with ReadOptions.format",
                path.display(),
                rest.join(", ")
            )
        }
    }
}

/// A spectrum (optical power against wavelength) rather than a peak log, and what it
/// looks like: an ENLIGHT spectrum export (`Wvl (nm)` then one power column per
/// channel), a spectrum CSV (`Wavelength (nm),Amplitude (AU)`, as I-MON tools save it),
/// or a header-less table whose first column climbs through the infrared in steps
/// under 0.1 nm while the next is not a wavelength. Only the head of the file is read.
pub(crate) fn spectrum_export(window: &[u8]) -> Option<&'static str> {
    let is_wavelength = |v: f64| (800.0..=1700.0).contains(&v);
    let mut run: Vec<(f64, f64)> = Vec::new();
    for (_, line) in lines_with_offsets(window).take(400) {
        let line = trim(line);
        if line.is_empty() || line.starts_with(b"#") {
            continue;
        }
        let delim = guess_delimiter(line);
        let parts: Vec<&[u8]> = line.split(|&c| c == delim).map(trim).collect();
        let first = parts[0].to_ascii_lowercase();
        // A column header, not a metadata line (`Wavelength Tracking: 400 pm`).
        let named_wavelength = !first.contains(&b':')
            && parts.len() >= 2
            && !parts[1].is_empty()
            && (first.starts_with(b"wvl") || first.starts_with(b"wavelength"));
        if named_wavelength {
            let rest = parts[1..]
                .iter()
                .map(|p| p.to_ascii_lowercase())
                .collect::<Vec<_>>();
            let power = |w: &[u8]| {
                [
                    b"ch" as &[u8],
                    b"amplitude",
                    b"power",
                    b"intensity",
                    b"dbm",
                    b"au",
                ]
                .iter()
                .any(|k| w.windows(k.len()).any(|x| x == *k))
            };
            if rest.iter().any(|w| power(w)) {
                return Some(if first.starts_with(b"wvl") {
                    "ENLIGHT: wavelength against optical power per channel"
                } else {
                    "wavelength against amplitude"
                });
            }
        }
        let nums: Vec<Option<f64>> = parts
            .iter()
            .map(|p| super::num::parse_f64(p, delim != b','))
            .collect();
        match (
            nums.first().copied().flatten(),
            nums.get(1).copied().flatten(),
        ) {
            (Some(x), Some(y)) if nums.iter().all(Option::is_some) && nums.len() <= 9 => {
                run.push((x, y));
                if run.len() >= 50 {
                    let climbs = run
                        .windows(2)
                        .all(|w| w[1].0 > w[0].0 && w[1].0 - w[0].0 < 0.1);
                    let median_y = {
                        let mut ys: Vec<f64> = run.iter().map(|p| p.1).collect();
                        ys.sort_by(f64::total_cmp);
                        ys[ys.len() / 2]
                    };
                    // A peak log's next column is a wavelength within a few nm.
                    let y_is_peak = run
                        .iter()
                        .all(|p| is_wavelength(p.1) && (p.1 - median_y).abs() < 5.0);
                    if climbs && run.iter().all(|p| is_wavelength(p.0)) && !y_is_peak {
                        return Some("a table of wavelength against optical power");
                    }
                    return None;
                }
            }
            _ => run.clear(),
        }
    }
    None
}
