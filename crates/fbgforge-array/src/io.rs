//! Sensing matrices and shift streams in, reconstructed loads out (CSV).
//!
//! Formats (agreed with the calibration/verification area, which writes matrices):
//! * sensing matrix: header `grating,<cell labels…>`, then one row per grating: its
//!   name and its sensitivity to each cell in pm/g; or numbers only (no header, no
//!   names: one row per grating, one column per cell), as `numpy.savetxt` and MATLAB
//!   `writematrix` write it, in which case the gratings are named `fbg1`, `fbg2`, …
//!   and the cells `A`, `B`, … (row-major order of the rows and columns given);
//! * shifts: header `[time_s,]<grating names…>`, one row per frame, shifts in pm;
//!   columns are matched to the matrix's gratings by name, in any order. When the
//!   matrix had no header the shifts may have none either: one column per grating in
//!   the matrix's row order (or a first column of times in s and then those);
//! * reconstruction: header `time_s,<cell labels…>` (or `frame,…` when the shifts had
//!   no time column), loads in g.
//!
//! Fields are separated by commas, tabs, semicolons or (numpy's default) runs of
//! spaces, decided by the first data line; delimited fields may be quoted, as a
//! spreadsheet writes them (read by [`crate::logs::csv_table`]). Lines starting with `#`
//! are comments, a UTF-8 byte-order mark is ignored. Every error names the file and the
//! line.

use super::SensingMatrix;
use anyhow::{anyhow, bail, Context, Result};
use nalgebra::DMatrix;
use std::collections::HashSet;
use std::path::Path;

mod stream;
pub use stream::ShiftReader;

/// How the fields of a line are separated.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Separator {
    Byte(u8),
    Whitespace,
}

fn parse_value(path: &Path, line: u64, column: &str, text: &str, unit: &str) -> Result<f64> {
    let v: f64 = text.parse().map_err(|_| {
        anyhow!(
            "{}:{line}: column `{column}`: `{text}` is not a number (expected {unit})",
            path.display()
        )
    })?;
    if !v.is_finite() {
        bail!(
            "{}:{line}: column `{column}`: {text} is not a finite value (expected {unit})",
            path.display()
        );
    }
    Ok(v)
}

/// Read the records of a delimited text file: (line number, fields). Errors on an
/// empty file.
fn records(path: &Path) -> Result<Vec<(u64, Vec<String>)>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot open {}", path.display()))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let first = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'));
    let Some(first) = first else {
        bail!(
            "{} is empty: expected a header line and data rows",
            path.display()
        );
    };
    let sep = if first.contains(',') {
        Separator::Byte(b',')
    } else if first.contains('\t') {
        Separator::Byte(b'\t')
    } else if first.contains(';') {
        Separator::Byte(b';')
    } else {
        Separator::Whitespace
    };
    let mut out = Vec::new();
    match sep {
        Separator::Byte(d) => {
            for r in crate::logs::csv_table::records(text, d, path)? {
                out.push((r.line, r.fields));
            }
        }
        Separator::Whitespace => {
            for (k, l) in text.lines().enumerate() {
                let l = l.trim();
                if l.is_empty() || l.starts_with('#') {
                    continue;
                }
                out.push((
                    k as u64 + 1,
                    l.split_whitespace().map(str::to_string).collect(),
                ));
            }
        }
    }
    if out.is_empty() {
        bail!(
            "{} is empty: expected a header line and data rows",
            path.display()
        );
    }
    Ok(out)
}

/// Whether a record is numbers only (a headerless file's first row).
fn all_numbers(rec: &[String]) -> bool {
    !rec.is_empty() && rec.iter().all(|f| f.parse::<f64>().is_ok())
}

/// A sensing matrix as read from a file, and whether its names were generated (the
/// file was numbers only).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MatrixFile {
    /// The matrix.
    pub matrix: SensingMatrix,
    /// True when the file had no header: gratings `fbg1…`, cells `A…`.
    pub generated_names: bool,
}

/// Read a headerless (numbers only) matrix: one row per grating.
fn read_matrix_numbers(path: &Path, recs: &[(u64, Vec<String>)]) -> Result<SensingMatrix> {
    let n = recs[0].1.len();
    let mut values = Vec::with_capacity(recs.len() * n);
    for (line, rec) in recs {
        if rec.len() != n {
            bail!(
                "{}:{line}: {} numbers, expected {n} as on line {} (a matrix without header has one row per grating and one column per cell)",
                path.display(),
                rec.len(),
                recs[0].0
            );
        }
        for (j, text) in rec.iter().enumerate() {
            let cell = crate::profile::cell_label(j);
            values.push(parse_value(
                path,
                *line,
                &format!("{} (cell {cell})", j + 1),
                text,
                "a sensitivity in pm/g",
            )?);
        }
    }
    let m = recs.len();
    Ok(SensingMatrix {
        gratings: (1..=m).map(|i| format!("fbg{i}")).collect(),
        cells: (0..n).map(crate::profile::cell_label).collect(),
        sensitivity_pm_per_g: DMatrix::from_row_slice(m, n, &values),
    })
}

/// Read a sensing matrix CSV (`grating,<cells…>`, values in pm/g, or numbers only).
pub fn read_matrix(path: &Path) -> Result<SensingMatrix> {
    read_matrix_file(path).map(|f| f.matrix)
}

/// Read a sensing matrix and say whether its names were generated (no header).
pub(crate) fn read_matrix_file(path: &Path) -> Result<MatrixFile> {
    let recs = records(path)?;
    if all_numbers(&recs[0].1) {
        return Ok(MatrixFile {
            matrix: read_matrix_numbers(path, &recs)?,
            generated_names: true,
        });
    }
    let (hline, header) = &recs[0];
    if !header[0].eq_ignore_ascii_case("grating") {
        bail!(
            "{}:{hline}: the header must start with `grating`, then one column per cell (or give numbers only, without header); found `{}`",
            path.display(),
            header[0]
        );
    }
    let cells: Vec<String> = header[1..].to_vec();
    if cells.is_empty() {
        bail!(
            "{}:{hline}: the header names no cell columns",
            path.display()
        );
    }
    let mut seen = HashSet::new();
    for c in &cells {
        if c.is_empty() || !seen.insert(c.clone()) {
            bail!(
                "{}:{hline}: cell label `{c}` is empty or repeated",
                path.display()
            );
        }
    }
    if recs.len() < 2 {
        bail!("{}: no grating rows after the header", path.display());
    }
    let mut gratings = Vec::new();
    let mut values = Vec::new();
    let mut seen = HashSet::new();
    for (line, rec) in &recs[1..] {
        if rec.len() != cells.len() + 1 {
            bail!(
                "{}:{line}: {} fields, expected {} (a grating name and {} sensitivities)",
                path.display(),
                rec.len(),
                cells.len() + 1,
                cells.len()
            );
        }
        let name = rec[0].clone();
        if name.is_empty() || !seen.insert(name.clone()) {
            bail!(
                "{}:{line}: grating name `{name}` is empty or repeated",
                path.display()
            );
        }
        for (c, text) in cells.iter().zip(&rec[1..]) {
            values.push(parse_value(path, *line, c, text, "a sensitivity in pm/g")?);
        }
        gratings.push(name);
    }
    let m = gratings.len();
    let n = cells.len();
    Ok(MatrixFile {
        matrix: SensingMatrix {
            gratings,
            cells,
            sensitivity_pm_per_g: DMatrix::from_row_slice(m, n, &values),
        },
        generated_names: false,
    })
}

/// Write a sensing matrix with `#` comment lines first (where it came from), atomically.
pub fn write_matrix_with_comments(
    path: &Path,
    m: &SensingMatrix,
    comments: &[String],
) -> Result<()> {
    crate::output::write_atomic_with(path, |w| {
        for c in comments {
            writeln!(w, "# {c}")?;
        }
        writeln!(w, "grating,{}", m.cells.join(","))?;
        for i in 0..m.n_gratings() {
            let vals: Vec<String> = (0..m.n_cells())
                .map(|j| format!("{:.6}", m.sensitivity_pm_per_g[(i, j)]))
                .collect();
            writeln!(w, "{},{}", m.gratings[i], vals.join(","))?;
        }
        Ok(())
    })
}

/// Frames of grating shifts, columns in the matrix's grating order.
#[derive(Debug, Clone, PartialEq)]
pub struct ShiftStream {
    /// Time of each frame, s, when the file has a `time_s` column.
    pub time_s: Option<Vec<f64>>,
    /// One frame per row: shift of each grating, pm, in the matrix's row order.
    pub frames_pm: Vec<Vec<f64>>,
}

/// Read shifts (`[time_s,]<gratings…>`, pm), reordering columns to `gratings`. A
/// header is required.
pub fn read_shifts(path: &Path, gratings: &[String]) -> Result<ShiftStream> {
    read_shifts_for(path, gratings, false)
}

/// Read shifts for a matrix; `headerless_ok` (the matrix had no header) also accepts
/// numbers only: one column per grating in the matrix's row order, or a first column
/// of times in s and then those. The whole file, through [`ShiftReader`].
pub(crate) fn read_shifts_for(
    path: &Path,
    gratings: &[String],
    headerless_ok: bool,
) -> Result<ShiftStream> {
    let mut reader = ShiftReader::open(path, gratings, headerless_ok)?;
    let mut all = ShiftStream {
        time_s: reader.timed().then(Vec::new),
        frames_pm: Vec::new(),
    };
    while let Some(chunk) = reader.next_chunk(usize::MAX)? {
        all.frames_pm.extend(chunk.frames_pm);
        if let (Some(t), Some(c)) = (&mut all.time_s, chunk.time_s) {
            t.extend(c);
        }
    }
    if all.frames_pm.is_empty() {
        bail!("{}: no frames after the header", path.display());
    }
    Ok(all)
}

/// Where each grating's shifts are among named columns.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShiftColumns {
    /// The `time_s` column (any case), if there is one.
    pub time: Option<usize>,
    /// For each grating of the matrix, in its row order, the column that holds it.
    pub gratings: Vec<usize>,
}

/// Match named shift columns to a matrix's gratings: one column per grating, in any
/// order, plus an optional `time_s`. Every other column, a repeated column and a
/// grating without a column are refused. The one rule for a shifts file's header and
/// for the Python binding's DataFrame columns.
pub fn shift_columns(names: &[String], gratings: &[String]) -> Result<ShiftColumns, String> {
    let time = names.iter().position(|h| h.eq_ignore_ascii_case("time_s"));
    let mut seen = HashSet::new();
    for (k, h) in names.iter().enumerate() {
        if Some(k) == time {
            continue;
        }
        if !seen.insert(h.as_str()) {
            return Err(format!("column `{h}` appears twice"));
        }
        if !gratings.iter().any(|g| g == h) {
            return Err(format!(
                "column `{h}` is not a grating of the sensing matrix (its gratings: {})",
                gratings.join(", ")
            ));
        }
    }
    let mut cols = Vec::with_capacity(gratings.len());
    for g in gratings {
        match names.iter().position(|h| h == g) {
            Some(k) => cols.push(k),
            None => {
                return Err(format!(
                    "no column for grating `{g}` of the sensing matrix (header: {})",
                    names.join(",")
                ))
            }
        }
    }
    Ok(ShiftColumns {
        time,
        gratings: cols,
    })
}

/// Reconstructed loads with each frame's trust, written a chunk at a time:
/// `time_s,<cells…>,residual_pm,flags` (loads in g, residual in pm, the flags as
/// words joined by `;`, empty when the frame can be trusted); without times the
/// first column is `frame`, the 0-based row index.
pub(crate) struct LoadsWriter<'w> {
    csv: csv::Writer<&'w mut dyn std::io::Write>,
    next: usize,
}

impl<'w> LoadsWriter<'w> {
    /// Start the file: its header.
    pub(crate) fn start(
        w: &'w mut dyn std::io::Write,
        cells: &[String],
        timed: bool,
    ) -> Result<Self> {
        let mut csv = csv::Writer::from_writer(w);
        let mut header = vec![if timed { "time_s" } else { "frame" }.to_string()];
        header.extend(cells.iter().cloned());
        header.push("residual_pm".into());
        header.push("flags".into());
        csv.write_record(&header)?;
        Ok(LoadsWriter { csv, next: 0 })
    }

    /// The next frames' rows (`time_s` as the header said).
    pub(crate) fn rows(
        &mut self,
        time_s: Option<&[f64]>,
        frames: &[crate::methods::Reconstruction],
    ) -> Result<()> {
        for (k, r) in frames.iter().enumerate() {
            let mut row = vec![match time_s {
                Some(t) => format!("{}", t[k]),
                None => (self.next + k).to_string(),
            }];
            row.extend(r.loads_g.iter().map(|v| format!("{v:.3}")));
            row.push(format!("{:.4}", r.residual_pm));
            row.push(r.flags.field());
            self.csv.write_record(&row)?;
        }
        self.next += frames.len();
        Ok(())
    }

    /// End the file.
    pub(crate) fn finish(mut self) -> Result<()> {
        self.csv.flush()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn quoted_matrices_and_shifts_read_as_plain_ones() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let plain = read_matrix(&file(
            d,
            "m.csv",
            "grating,A,B\nfbg1,0.5,0.25\nfbg2,0.125,1\n",
        ))
        .unwrap();
        // As a spreadsheet saves it: every field quoted, a comma inside a name.
        let quoted = read_matrix(&file(
            d,
            "mq.csv",
            "\"grating\",\"A\",\"B\"\n\"fbg1\",\"0.5\",\"0.25\"\n\"fbg2\",\"0.125\",\"1\"\n",
        ))
        .unwrap();
        assert_eq!(quoted, plain);
        let named = read_matrix(&file(d, "mn.csv", "grating,A,B\n\"fbg 1, top\",1,2\n")).unwrap();
        assert_eq!(named.gratings, vec!["fbg 1, top"]);
        let s = read_shifts(
            &file(
                d,
                "s.csv",
                "\"time_s\",\"fbg2\",\"fbg1\"\n\"0.5\",\"3\",\"4\"\n",
            ),
            &plain.gratings,
        )
        .unwrap();
        assert_eq!(s.time_s, Some(vec![0.5]));
        assert_eq!(s.frames_pm, vec![vec![4.0, 3.0]]);
        // A quoted bad value is named by file, line and column.
        let e = read_shifts(
            &file(
                d,
                "sb.csv",
                "\"time_s\",\"fbg1\",\"fbg2\"\n0,1,2\n\"1\",\"x\",\"2\"\n",
            ),
            &plain.gratings,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("sb.csv:3") && e.contains("column `fbg1`") && e.contains("`x`"),
            "{e}"
        );
    }
}
