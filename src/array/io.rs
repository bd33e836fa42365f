//! Sensing matrices and shift streams in, reconstructed loads out (CSV).
//!
//! Formats (agreed with the calibration/verification area, which writes matrices):
//! * sensing matrix: header `grating,<cell labels…>`, then one row per grating: its
//!   name and its sensitivity to each cell in pm/g;
//! * shifts: header `[time_s,]<grating names…>`, one row per frame, shifts in pm;
//!   columns are matched to the matrix's gratings by name, in any order;
//! * reconstruction: header `time_s,<cell labels…>` (or `frame,…` when the shifts had
//!   no time column), loads in g.
//!
//! Lines starting with `#` are comments. Every error names the file and the line.

use super::SensingMatrix;
use anyhow::{anyhow, bail, Context, Result};
use nalgebra::DMatrix;
use std::collections::HashSet;
use std::path::Path;

fn reader(path: &Path) -> Result<csv::Reader<std::fs::File>> {
    let file =
        std::fs::File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    Ok(csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .flexible(true)
        .trim(csv::Trim::All)
        .has_headers(false)
        .from_reader(file))
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

/// Read the records of a CSV file: (line number, fields). Errors on an empty file.
fn records(path: &Path) -> Result<Vec<(u64, Vec<String>)>> {
    let mut out = Vec::new();
    for rec in reader(path)?.records() {
        let rec = rec.with_context(|| format!("cannot read {}", path.display()))?;
        let line = rec.position().map_or(0, |p| p.line());
        if rec.iter().all(|f| f.is_empty()) {
            continue;
        }
        out.push((line, rec.iter().map(str::to_string).collect()));
    }
    if out.is_empty() {
        bail!(
            "{} is empty: expected a header line and data rows",
            path.display()
        );
    }
    Ok(out)
}

/// Read a sensing matrix CSV (`grating,<cells…>`, values in pm/g).
pub fn read_matrix(path: &Path) -> Result<SensingMatrix> {
    let recs = records(path)?;
    let (hline, header) = &recs[0];
    if !header[0].eq_ignore_ascii_case("grating") {
        bail!(
            "{}:{hline}: the header must start with `grating`, then one column per cell; found `{}`",
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
    Ok(SensingMatrix {
        gratings,
        cells,
        sensitivity_pm_per_g: DMatrix::from_row_slice(m, n, &values),
    })
}

/// Write a sensing matrix in the same format (atomically).
pub fn write_matrix(path: &Path, m: &SensingMatrix) -> Result<()> {
    write_matrix_with_comments(path, m, &[])
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

/// Read shifts (`[time_s,]<gratings…>`, pm), reordering columns to `gratings`.
pub fn read_shifts(path: &Path, gratings: &[String]) -> Result<ShiftStream> {
    let recs = records(path)?;
    let (hline, header) = &recs[0];
    let time_col = header.iter().position(|h| h.eq_ignore_ascii_case("time_s"));
    let mut seen = HashSet::new();
    for (k, h) in header.iter().enumerate() {
        if Some(k) == time_col {
            continue;
        }
        if !seen.insert(h.as_str()) {
            bail!("{}:{hline}: column `{h}` appears twice", path.display());
        }
        if !gratings.iter().any(|g| g == h) {
            bail!(
                "{}:{hline}: column `{h}` is not a grating of the sensing matrix (its gratings: {})",
                path.display(),
                gratings.join(", ")
            );
        }
    }
    let mut cols = Vec::with_capacity(gratings.len());
    for g in gratings {
        match header.iter().position(|h| h == g) {
            Some(k) => cols.push(k),
            None => bail!(
                "{}:{hline}: no column for grating `{g}` of the sensing matrix (header: {})",
                path.display(),
                header.join(",")
            ),
        }
    }
    if recs.len() < 2 {
        bail!("{}: no frames after the header", path.display());
    }
    let mut times = Vec::new();
    let mut frames = Vec::with_capacity(recs.len() - 1);
    for (line, rec) in &recs[1..] {
        if rec.len() != header.len() {
            bail!(
                "{}:{line}: {} fields, expected {} as in the header",
                path.display(),
                rec.len(),
                header.len()
            );
        }
        if let Some(t) = time_col {
            times.push(parse_value(path, *line, "time_s", &rec[t], "a time in s")?);
        }
        let frame = cols
            .iter()
            .zip(gratings)
            .map(|(&k, g)| parse_value(path, *line, g, &rec[k], "a shift in pm"))
            .collect::<Result<Vec<f64>>>()?;
        frames.push(frame);
    }
    Ok(ShiftStream {
        time_s: time_col.map(|_| times),
        frames_pm: frames,
    })
}

/// Write reconstructed loads: `time_s,<cells…>`, g, atomically; without times the
/// first column is `frame`, the 0-based index of the shifts row.
pub fn write_loads(
    path: &Path,
    cells: &[String],
    time_s: Option<&[f64]>,
    loads_g: &[Vec<f64>],
) -> Result<()> {
    crate::output::write_atomic_with(path, |w| {
        let mut c = csv::Writer::from_writer(w);
        let first = if time_s.is_some() { "time_s" } else { "frame" };
        let mut header = vec![first.to_string()];
        header.extend(cells.iter().cloned());
        c.write_record(&header)?;
        for (k, x) in loads_g.iter().enumerate() {
            let mut row = vec![match time_s {
                Some(t) => format!("{}", t[k]),
                None => k.to_string(),
            }];
            row.extend(x.iter().map(|v| format!("{v:.3}")));
            c.write_record(&row)?;
        }
        c.flush()?;
        Ok(())
    })
}
