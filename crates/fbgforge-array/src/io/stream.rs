//! A shifts file read a chunk of frames at a time ([`ShiftReader`]), so that a run
//! holds at most one chunk of the file, whatever its length. The rules are the
//! whole-file reader's ([`super::read_shifts`], which collects this reader's chunks):
//! the separator decided by the first data line, a UTF-8 byte-order mark, blank and
//! `#` comment lines skipped, quoted fields, a header (or numbers only beside a
//! matrix without one), every error naming the file and the line. A record is one
//! line: a quoted field may hold a separator but not a line break.

use super::{all_numbers, parse_value, shift_columns, Separator, ShiftColumns, ShiftStream};
use anyhow::{anyhow, bail, Context, Result};
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

/// Frames of a shifts file, read in order a chunk at a time (see the module doc).
pub struct ShiftReader {
    path: PathBuf,
    input: BufReader<File>,
    text: String,
    line: u64,
    sep: Separator,
    /// The first record, when it is a frame (a file without header).
    pending: Option<(u64, Vec<String>)>,
    columns: ShiftColumns,
    width: usize,
    /// How a wrong-length record is told: (`fields` or `numbers`, `as in the header`
    /// or `as on line N`).
    shape: (&'static str, String),
    gratings: Vec<String>,
    frames: usize,
    most_held: usize,
}

/// The separator of a data line (the first one decides for the file).
fn separator_of(line: &str) -> Separator {
    if line.contains(',') {
        Separator::Byte(b',')
    } else if line.contains('\t') {
        Separator::Byte(b'\t')
    } else if line.contains(';') {
        Separator::Byte(b';')
    } else {
        Separator::Whitespace
    }
}

impl ShiftReader {
    /// Open `path` for the matrix's `gratings` and read its header (or first row);
    /// `headerless_ok` (the matrix had no header) also accepts numbers only: one
    /// column per grating in the matrix's row order, or a first column of times in s
    /// and then those.
    ///
    /// ```
    /// use fbgforge_array::io::ShiftReader;
    ///
    /// let dir = tempfile::tempdir()?;
    /// let path = dir.path().join("shifts.csv");
    /// std::fs::write(&path, "time_s,fbg2,fbg1\n0.0,3,4\n0.1,5,6\n0.2,7,8\n")?;
    /// let gratings = vec!["fbg1".to_string(), "fbg2".to_string()];
    /// let mut r = ShiftReader::open(&path, &gratings, false)?;
    /// let first = r.next_chunk(2)?.expect("two frames");
    /// assert_eq!(first.frames_pm, vec![vec![4.0, 3.0], vec![6.0, 5.0]]);
    /// assert_eq!(first.time_s, Some(vec![0.0, 0.1]));
    /// assert_eq!(r.next_chunk(2)?.expect("one more").frames_pm, vec![vec![8.0, 7.0]]);
    /// assert!(r.next_chunk(2)?.is_none());
    /// // Never more than a chunk held at once.
    /// assert_eq!((r.frames(), r.most_frames_held()), (3, 2));
    /// # Ok::<(), anyhow::Error>(())
    /// ```
    pub fn open(path: &Path, gratings: &[String], headerless_ok: bool) -> Result<Self> {
        let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
        let mut r = ShiftReader {
            path: path.to_path_buf(),
            input: BufReader::new(file),
            text: String::new(),
            line: 0,
            sep: Separator::Whitespace,
            pending: None,
            columns: ShiftColumns {
                time: None,
                gratings: Vec::new(),
            },
            width: 0,
            shape: ("fields", "as in the header".into()),
            gratings: gratings.to_vec(),
            frames: 0,
            most_held: 0,
        };
        let Some((hline, header)) = r.record(true)? else {
            bail!(
                "{} is empty: expected a header line and data rows",
                path.display()
            );
        };
        if all_numbers(&header) {
            if !headerless_ok {
                bail!(
                    "{}:{hline}: the shifts have no header; name the columns ({}) — a shifts file without header is read only with a matrix without header",
                    path.display(),
                    gratings.join(",")
                );
            }
            r.headerless_columns(hline, header.len())?;
            r.shape = ("numbers", format!("as on line {hline}"));
            r.pending = Some((hline, header));
            return Ok(r);
        }
        r.columns = shift_columns(&header, gratings)
            .map_err(|e| anyhow!("{}:{hline}: {e}", path.display()))?;
        r.width = header.len();
        Ok(r)
    }

    /// A file without header: `m` columns, or `m + 1` with times first.
    fn headerless_columns(&mut self, line: u64, width: usize) -> Result<()> {
        let m = self.gratings.len();
        let timed = if width == m {
            false
        } else if width == m + 1 {
            true
        } else {
            bail!(
                "{}:{line}: {width} numbers, expected {m} shifts (one per row of the matrix), or a time in s and {m} shifts",
                self.path.display()
            );
        };
        let first = usize::from(timed);
        self.columns = ShiftColumns {
            time: timed.then_some(0),
            gratings: (first..first + m).collect(),
        };
        self.width = width;
        Ok(())
    }

    /// The next record (line, fields), skipping blank and comment lines; `first`
    /// decides the separator.
    fn record(&mut self, first: bool) -> Result<Option<(u64, Vec<String>)>> {
        loop {
            self.text.clear();
            let read = self
                .input
                .read_line(&mut self.text)
                .with_context(|| format!("cannot read {}", self.path.display()))?;
            if read == 0 {
                return Ok(None);
            }
            self.line += 1;
            let mut l = self.text.as_str();
            if self.line == 1 {
                l = l.strip_prefix('\u{feff}').unwrap_or(l);
            }
            let l = l.trim();
            if l.is_empty() || l.starts_with('#') {
                continue;
            }
            if first {
                self.sep = separator_of(l);
            }
            let fields = self.fields(l)?;
            if fields.iter().all(String::is_empty) || fields[0].starts_with('#') {
                continue;
            }
            return Ok(Some((self.line, fields)));
        }
    }

    /// The fields of one line, trimmed and unquoted.
    fn fields(&self, l: &str) -> Result<Vec<String>> {
        let d = match self.sep {
            Separator::Whitespace => return Ok(l.split_whitespace().map(str::to_string).collect()),
            Separator::Byte(d) => d,
        };
        if !l.contains('"') {
            return Ok(l.split(d as char).map(|f| f.trim().to_string()).collect());
        }
        if l.matches('"').count() % 2 == 1 {
            bail!(
                "{}:{}: a quoted field is not closed on its line (a frame is one line)",
                self.path.display(),
                self.line
            );
        }
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .delimiter(d)
            .from_reader(l.as_bytes());
        let rec = reader
            .records()
            .next()
            .transpose()
            .with_context(|| format!("cannot read {}:{}", self.path.display(), self.line))?
            .unwrap_or_default();
        Ok(rec.iter().map(str::to_string).collect())
    }

    /// One frame from its record: (time, shifts in the matrix's grating order).
    fn frame(&self, line: u64, rec: &[String]) -> Result<(Option<f64>, Vec<f64>)> {
        if rec.len() != self.width {
            bail!(
                "{}:{line}: {} {}, expected {} {}",
                self.path.display(),
                rec.len(),
                self.shape.0,
                self.width,
                self.shape.1
            );
        }
        let time = match self.columns.time {
            Some(t) => Some(parse_value(
                &self.path,
                line,
                "time_s",
                &rec[t],
                "a time in s",
            )?),
            None => None,
        };
        let shifts = self
            .columns
            .gratings
            .iter()
            .zip(&self.gratings)
            .map(|(&k, g)| parse_value(&self.path, line, g, &rec[k], "a shift in pm"))
            .collect::<Result<Vec<f64>>>()?;
        Ok((time, shifts))
    }

    /// The next at most `max` frames (None at the end of the file).
    pub fn next_chunk(&mut self, max: usize) -> Result<Option<ShiftStream>> {
        let timed = self.columns.time.is_some();
        let mut times = Vec::new();
        let mut frames = Vec::with_capacity(max.min(4096));
        while frames.len() < max.max(1) {
            let next = match self.pending.take() {
                Some(rec) => Some(rec),
                None => self.record(false)?,
            };
            let Some((line, rec)) = next else { break };
            let (t, y) = self.frame(line, &rec)?;
            if let Some(t) = t {
                times.push(t);
            }
            frames.push(y);
        }
        if frames.is_empty() {
            return Ok(None);
        }
        self.frames += frames.len();
        self.most_held = self.most_held.max(frames.len());
        Ok(Some(ShiftStream {
            time_s: timed.then_some(times),
            frames_pm: frames,
        }))
    }

    /// Whether the frames carry a time column.
    pub fn timed(&self) -> bool {
        self.columns.time.is_some()
    }

    /// Frames read so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// The most frames one chunk held.
    pub fn most_frames_held(&self) -> usize {
        self.most_held
    }
}
