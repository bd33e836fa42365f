//! Small CSV tables a person writes by hand or exports from a spreadsheet (array
//! calibration schedules, live load scripts, sensing matrices and shift streams), read
//! with the `csv` crate: quoted fields and headers (`"hold_s","A"`, as Excel writes
//! them), a UTF-8 byte-order mark, blank lines and `#` comment lines, each record with
//! the file line it starts on so errors can name it.
//!
//! The interrogator logs are not read here: they run to millions of rows and have their
//! own allocation-free readers (the rest of [`crate::logs`]).

use anyhow::{Context, Result};
use std::path::Path;

/// One record of a table.
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    /// 1-based line of the file the record starts on.
    pub line: u64,
    /// Its fields, trimmed, without their quotes.
    pub fields: Vec<String>,
}

/// The records of `text` (the file `path`, named in errors), fields separated by
/// `delimiter`. Blank lines, lines of empty fields and lines whose first field starts
/// with `#` are left out; records may differ in length (the caller says which length
/// it expects, naming the line).
pub fn records(text: &str, delimiter: u8, path: &Path) -> Result<Vec<Record>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let bytes = text.as_bytes();
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .flexible(true)
        .trim(csv::Trim::All)
        .has_headers(false)
        .delimiter(delimiter)
        .from_reader(bytes);
    let mut out = Vec::new();
    // (byte offset, its 1-based line), advanced record by record.
    let mut counted = (0usize, 1u64);
    for rec in reader.records() {
        let rec = rec.with_context(|| format!("cannot read {}", path.display()))?;
        if rec.iter().all(str::is_empty) || rec.get(0).is_some_and(|f| f.starts_with('#')) {
            continue;
        }
        // The reader's own line count lags behind the blank and comment lines it skips
        // (and counts a CRLF oddly), so the line is counted here from the byte offset.
        let read_from = rec.position().map_or(0, |p| p.byte() as usize);
        let start = record_start(bytes, read_from.max(counted.0));
        counted = (
            start,
            counted.1 + memchr::memchr_iter(b'\n', &bytes[counted.0..start]).count() as u64,
        );
        out.push(Record {
            line: counted.1,
            fields: rec.iter().map(str::to_string).collect(),
        });
    }
    Ok(out)
}

/// The first byte of the record the reader read from `at`: past the line ends and the
/// `#` comment lines it skips before a record.
fn record_start(b: &[u8], mut at: usize) -> usize {
    loop {
        match b.get(at) {
            Some(b'\r' | b'\n') => at += 1,
            Some(b'#') => at = memchr::memchr(b'\n', &b[at..]).map_or(b.len(), |p| at + p + 1),
            _ => return at.min(b.len()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoted_fields_comments_and_line_numbers() {
        let text = "\u{feff}# a comment\n\"hold_s\",\"A\"\n\n  # indented comment\n\"1.5\",\"2,5\"\r\n   \n3,4,\n";
        let r = records(text, b',', Path::new("t.csv")).unwrap();
        let got: Vec<(u64, Vec<&str>)> = r
            .iter()
            .map(|r| (r.line, r.fields.iter().map(String::as_str).collect()))
            .collect();
        assert_eq!(
            got,
            vec![
                (2, vec!["hold_s", "A"]),
                (5, vec!["1.5", "2,5"]),
                (7, vec!["3", "4", ""]),
            ]
        );
    }

    #[test]
    fn lines_are_counted_past_blank_lines_comments_and_crlf() {
        let text = "a\r\n\r\nb\r\n# x\r\n#y\r\n\r\nc\r\n\n\nd";
        let r = records(text, b',', Path::new("t.csv")).unwrap();
        let lines: Vec<(u64, &str)> = r.iter().map(|r| (r.line, r.fields[0].as_str())).collect();
        assert_eq!(lines, vec![(1, "a"), (3, "b"), (7, "c"), (10, "d")]);
    }

    #[test]
    fn other_delimiters() {
        let r = records("a;b\n1;\"x;y\"\n", b';', Path::new("t.csv")).unwrap();
        assert_eq!(r[1].fields, vec!["1", "x;y"]);
        let r = records("a\tb\n1\t2\n", b'\t', Path::new("t.tsv")).unwrap();
        assert_eq!(r[1].fields, vec!["1", "2"]);
    }
}
