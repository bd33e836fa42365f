//! Plain delimited text (CSV, TSV or semicolon-separated, decimal commas with the
//! latter two): a time column (seconds, or a date and time) then one wavelength column
//! per grating, nm, with or without a header. Recognised by its first table line, and
//! only when no interrogator header is found.

use super::detect::{Detected, FirstLine};
use super::rows::{fields, guess_delimiter, is_time_field, lines_with_offsets, ValueColumns};
use super::write::write_number;
use super::{at, Clock, LogReader, LogStyle, LogTable, Rows};
use anyhow::{bail, Result};
use std::io::Write;
use std::path::Path;

/// The plain CSV format.
pub(crate) struct PlainCsv;

impl LogReader for PlainCsv {
    fn name(&self) -> &'static str {
        "csv"
    }

    fn title(&self) -> &'static str {
        "plain CSV"
    }

    fn expected(&self) -> &'static str {
        "a delimited table whose first column is time"
    }

    fn table_at_first_line(&self, first: &FirstLine, forced: bool) -> Option<Detected> {
        let line = first.line;
        let delimiter = guess_delimiter(line);
        let mut parts = line.split(|&c| c == delimiter);
        let time_first = parts.next().is_some_and(is_time_field);
        // A table has at least two columns.
        parts.next()?;
        let (body_offset, body_line, header) = if time_first {
            (first.offset, first.index + 1, Vec::new())
        } else {
            (first.next_offset, first.index + 2, fields(line, delimiter))
        };
        let looks_like_table = time_first
            || header
                .first()
                .is_some_and(|h| h.to_ascii_lowercase().contains("time"));
        (looks_like_table || forced).then_some(Detected {
            format: super::LogFormat::Csv,
            body_offset,
            body_line,
            header,
            delimiter,
        })
    }

    fn rows(
        &self,
        det: &Detected,
        bytes: &[u8],
        path: &Path,
        _opts: &super::ReadOptions,
    ) -> Result<Rows> {
        if let Some(first) = det.header.first().filter(|h| is_index_column(h)) {
            bail!(
                "{}: the first column `{first}` is a sample index, not a time: a CSV log needs its time first (seconds, or a date and time); export the log with its timestamps",
                at(path, det.header_line())
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
        let std_error_of = std_error_columns(&names)
            .map_err(|e| anyhow::anyhow!("{}: {e}", at(path, det.header_line())))?;
        let estimator = (!std_error_of.is_empty())
            .then(|| stated_estimator(&bytes[..det.body_offset.min(bytes.len())]));
        Ok(Rows {
            channels: names.len(),
            parser: Box::new(ValueColumns {
                delimiter: det.delimiter,
                decimal_comma: det.decimal_comma(),
                columns: names.len(),
                std_error_of,
            }),
            column_names: names,
            estimator,
        })
    }

    fn extension(&self) -> &'static str {
        "csv"
    }

    /// Seconds from the first row.
    fn written_clock(&self) -> Clock {
        Clock::Relative
    }

    fn write(&self, w: &mut dyn Write, table: &LogTable, style: &LogStyle) -> std::io::Result<()> {
        let comma = style.decimal_comma;
        let d = if comma { ";" } else { "," };
        writeln!(w, "time_s{d}{}", table.names.join(d))?;
        for (i, row) in table.wavelength_nm.iter().enumerate() {
            write_number(w, table.time_s[i], 6, comma)?;
            for v in row {
                w.write_all(d.as_bytes())?;
                if v.is_finite() {
                    write_number(w, *v, 6, comma)?;
                }
            }
            writeln!(w)?;
        }
        Ok(())
    }
}

/// The suffix of a column holding the standard errors of the wavelength column named
/// before it (`FBG1,FBG1 std_error_pm`), as `fbgforge peaks --out` writes.
pub(crate) const STD_ERROR_SUFFIX: &str = "std_error_pm";

/// Per value column: `Some(k)` when it holds the standard errors of wavelength column
/// k (named `<name of k> std_error_pm` or `<name of k>_std_error_pm`, after column k);
/// empty when no column does.
fn std_error_columns(names: &[String]) -> std::result::Result<Vec<Option<usize>>, String> {
    let mut of = vec![None; names.len()];
    for (c, name) in names.iter().enumerate() {
        let Some(base) = name.strip_suffix(STD_ERROR_SUFFIX) else {
            continue;
        };
        let base = base.trim_end_matches([' ', '_']);
        match names.iter().position(|n| n == base) {
            Some(k) if k < c => of[c] = Some(k),
            Some(_) => {
                return Err(format!(
                    "the column `{name}` comes before the wavelength column `{base}` it belongs to"
                ))
            }
            None => {
                return Err(format!(
                    "the column `{name}` names no wavelength column `{base}`"
                ))
            }
        }
    }
    Ok(if of.iter().any(Option::is_some) {
        of
    } else {
        Vec::new()
    })
}

/// The estimator a peaks log states in a comment line before its table
/// (`# estimator: gaussian`), else `stated in no comment`.
fn stated_estimator(head: &[u8]) -> String {
    lines_with_offsets(head)
        .filter_map(|(_, l)| {
            String::from_utf8_lossy(l)
                .trim()
                .strip_prefix('#')
                .map(str::to_string)
        })
        .find_map(|c| {
            c.trim()
                .strip_prefix("estimator:")
                .map(|e| e.split_whitespace().next().unwrap_or("").to_string())
        })
        .filter(|e| !e.is_empty())
        .unwrap_or_else(|| "stated in no comment".into())
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
