//! ENLIGHT "Peaks" export (Micron Optics / Luna sm125, sm130, si155): after a metadata
//! block, the header `Timestamp<TAB># CH 1<TAB>…<TAB>Wavelengths (nm)`; each row holds a
//! timestamp, the number of peaks found on each channel, then those peaks, channel after
//! channel. The hot path of the log readers: a row is read in one pass with a cursor.

use super::detect::{Detected, HeadLine};
use super::enlight::{is_channel_column, is_timestamp_header, write_metadata, write_timestamp};
use super::num;
use super::rows::{issue, parse_time_field, LineIssue, Partial};
use super::write::write_number;
use super::{at, LogReader, LogStyle, LogTable, RowParser, Rows};
use anyhow::{bail, Result};
use std::io::Write;
use std::path::Path;

/// The ENLIGHT Peaks format.
pub(crate) struct EnlightPeaks;

impl LogReader for EnlightPeaks {
    fn name(&self) -> &'static str {
        "enlight-peaks"
    }

    fn title(&self) -> &'static str {
        "ENLIGHT Peaks"
    }

    fn expected(&self) -> &'static str {
        "a line `Timestamp<TAB># CH 1<TAB>…`"
    }

    fn header_delimiter(&self, head: &HeadLine) -> Option<u8> {
        (is_timestamp_header(head) && is_channel_column(head.second)).then_some(b'\t')
    }

    fn rows(
        &self,
        det: &Detected,
        _bytes: &[u8],
        path: &Path,
        _opts: &super::ReadOptions,
    ) -> Result<Rows> {
        let channels = det.header[1..]
            .iter()
            .take_while(|h| is_channel_column(h.as_bytes()))
            .count();
        if channels == 0 || channels > 256 {
            bail!(
                "{}: the header declares {channels} channels; expected 1 to 256",
                at(path, det.header_line())
            );
        }
        Ok(Rows {
            channels,
            column_names: Vec::new(),
            parser: Box::new(PeaksRows {
                channels,
                decimal_comma: det.decimal_comma(),
            }),
            estimator: None,
        })
    }

    fn write(&self, w: &mut dyn Write, table: &LogTable, style: &LogStyle) -> std::io::Result<()> {
        let t0 = table.start_epoch_s;
        let channels = table.names.len().min(4);
        write_metadata(w, style.metadata_lines, table.sample_rate_hz, t0)?;
        write!(w, "Timestamp")?;
        for c in 0..channels {
            write!(w, "\t# CH {}", c + 1)?;
        }
        writeln!(w, "\tWavelengths (nm)")?;
        let chan_of: Vec<usize> = (0..table.names.len()).map(|g| g % channels).collect();
        for (i, row) in table.wavelength_nm.iter().enumerate() {
            write_timestamp(w, t0 + table.time_s[i], style)?;
            for c in 0..channels {
                let n = row
                    .iter()
                    .enumerate()
                    .filter(|(g, v)| chan_of[*g] == c && v.is_finite())
                    .count();
                write!(w, "\t{n}")?;
            }
            for c in 0..channels {
                for (g, v) in row.iter().enumerate() {
                    if chan_of[g] == c && v.is_finite() {
                        w.write_all(b"\t")?;
                        write_number(w, *v, 6, style.decimal_comma)?;
                    }
                }
            }
            writeln!(w)?;
        }
        Ok(())
    }
}

/// The rows of a Peaks table with `channels` channels (always tab-separated).
struct PeaksRows {
    channels: usize,
    decimal_comma: bool,
}

impl RowParser for PeaksRows {
    fn parse(
        &self,
        line: &[u8],
        out: &mut Partial,
        counts: &mut Vec<usize>,
    ) -> Result<(), LineIssue> {
        let dc = self.decimal_comma;
        let tab = memchr::memchr(b'\t', line)
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
        for c in 0..self.channels {
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
                    out.rollback(start);
                    return Err(issue(
                        "peak_count_mismatch",
                        "fewer wavelengths than the peak counts announce",
                    ));
                }
                match num::parse_f64_prefix(&line[pos..], dc) {
                    Some((v, k)) if v.is_finite() => {
                        pos += k;
                        if !next_field(&mut pos) {
                            out.rollback(start);
                            return Err(issue("unreadable_line", "unreadable wavelength"));
                        }
                        out.peaks.push(v);
                        out.chans.push(c as u16);
                    }
                    _ => {
                        out.rollback(start);
                        return Err(issue("unreadable_line", "unreadable wavelength"));
                    }
                }
            }
        }
        if line[pos.min(line.len())..]
            .iter()
            .any(|c| !c.is_ascii_whitespace())
        {
            out.rollback(start);
            return Err(issue(
                "peak_count_mismatch",
                "more wavelengths than the peak counts announce",
            ));
        }
        out.end_row(time);
        Ok(())
    }
}
