//! Array calibration: the measured sensing matrix A (pm/g) of a flat array, from a
//! wavelength log in which a known load sits on each cell in turn.
//!
//! Input besides the log: a schedule CSV with one line per loading (fields may be
//! quoted, as a spreadsheet writes them),
//!
//! ```text
//! # times in s from the first row of the wavelength log
//! start_s,end_s,cell,load_g
//! 10,30,A,200
//! 40,60,B,200
//! ```
//!
//! Each loading's shift is the mean over the last three quarters of its interval (the
//! first quarter is left for the silicone to settle) minus the mean of the unloaded
//! stretches just before and after it (so slow drift cancels). With several loadings
//! of one cell, the sensitivity is the least-squares slope through the origin,
//! Σ shift·load / Σ load². Output: `grating,A,B,…` with one row per grating in pm/g,
//! the format `fbgforge reconstruct` reads.
//!
//! The use case `fbgforge calibrate-array` and the Python binding call is [`run`]: the
//! matrix measured and written, optionally the sheet model's modulus fitted to it, each
//! result handed to a [`CalibrationSink`] (the terminal table is
//! `fbgforge_report::calibrate`'s).

use crate::logs;
use crate::logs::assign::{self, GratingWindow};
use crate::logs::{csv_table, num, LogWarnings, PeakLog, ReadOptions};
use crate::profile::{cell_label, ArrayLayout};
use crate::sheet::fit::{fit_modulus, ModulusFit};
use crate::spec::Design;
use crate::{kernel, SensingMatrix};
use anyhow::{bail, Context, Result};
use nalgebra::DMatrix;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// One loading in the schedule.
#[derive(Debug, Clone, PartialEq)]
pub struct Loading {
    /// Start, s from the log's first row.
    pub start_s: f64,
    /// End, s.
    pub end_s: f64,
    /// Cell index (A = 0).
    pub cell: usize,
    /// Load, g.
    pub load_g: f64,
}

/// Read a schedule CSV, checking cell labels against the design.
pub fn read_schedule(path: &Path, n_cells: usize) -> Result<Vec<Loading>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the schedule {}", path.display()))?;
    parse_schedule(&text, path, n_cells)
}

/// Parse a schedule from text (a CSV: quoted fields, `#` comments and blank lines
/// allowed).
pub fn parse_schedule(text: &str, path: &Path, n_cells: usize) -> Result<Vec<Loading>> {
    let labels: Vec<String> = (0..n_cells).map(cell_label).collect();
    let mut out = Vec::new();
    let records = csv_table::records(text, b',', path)?;
    let mut records = records.iter();
    if let Some(header) = records.next() {
        let f = &header.fields;
        if f.len() != 4
            || !f[0].eq_ignore_ascii_case("start_s")
            || !f[1].eq_ignore_ascii_case("end_s")
            || !f[2].eq_ignore_ascii_case("cell")
            || !f[3].eq_ignore_ascii_case("load_g")
        {
            bail!(
                "{}:{}: expected the header `start_s,end_s,cell,load_g`",
                path.display(),
                header.line
            );
        }
    }
    for rec in records {
        let f = &rec.fields;
        let at = || format!("{}:{}", path.display(), rec.line);
        if f.len() != 4 {
            bail!(
                "{}: expected 4 fields `start_s,end_s,cell,load_g`, got {}",
                at(),
                f.len()
            );
        }
        let num = |s: &str, what: &str| -> Result<f64> {
            num::parse_f64(s.as_bytes(), false)
                .filter(|v| v.is_finite())
                .with_context(|| format!("{}: {what} `{s}` is not a number", at()))
        };
        let (a, b, g) = (
            num(&f[0], "start_s")?,
            num(&f[1], "end_s")?,
            num(&f[3], "load_g")?,
        );
        if b <= a {
            bail!("{}: end_s {b} is not after start_s {a}", at());
        }
        if g <= 0.0 {
            bail!("{}: load_g must be positive, got {g}", at());
        }
        let cell = labels
            .iter()
            .position(|c| c.eq_ignore_ascii_case(&f[2]))
            .with_context(|| {
                format!(
                    "{}: unknown cell `{}`; the design has cells {}",
                    at(),
                    f[2],
                    labels.join(", ")
                )
            })?;
        out.push(Loading {
            start_s: a,
            end_s: b,
            cell,
            load_g: g,
        });
    }
    if out.is_empty() {
        bail!("{}: the schedule lists no loadings", path.display());
    }
    out.sort_by(|x, y| x.start_s.total_cmp(&y.start_s));
    for w in out.windows(2) {
        if w[1].start_s < w[0].end_s {
            bail!(
                "{}: loadings overlap ({}–{} s and {}–{} s)",
                path.display(),
                w[0].start_s,
                w[0].end_s,
                w[1].start_s,
                w[1].end_s
            );
        }
    }
    Ok(out)
}

/// Mean of the finite values with a ≤ t < b (half-open, so a loading's first
/// sample never counts in the rest before it).
fn mean_in(t: &[f64], v: &[f64], a: f64, b: f64) -> Option<f64> {
    let i0 = t.partition_point(|&x| x < a);
    let i1 = t.partition_point(|&x| x < b);
    let (mut s, mut n) = (0.0, 0usize);
    for &x in &v[i0..i1.max(i0)] {
        if x.is_finite() {
            s += x;
            n += 1;
        }
    }
    (n > 0).then(|| s / n as f64)
}

/// Build the matrix from a log and a schedule.
pub fn calibrate(
    design: &Design,
    log: &PeakLog,
    schedule: &[Loading],
    half_width_nm: Option<f64>,
) -> Result<SensingMatrix> {
    let Some(a) = &design.array else {
        bail!("design `{}` has no [array] to calibrate", design.name)
    };
    let layout = ArrayLayout::from_array(a);
    let n_cells = layout.cell_centers_mm.len();
    let nominals: Vec<f64> = a.gratings.iter().map(|g| g.bragg_wavelength_nm).collect();
    let hw = half_width_nm.unwrap_or_else(|| assign::default_half_width_nm(&nominals));
    let windows: Vec<GratingWindow> = a
        .gratings
        .iter()
        .map(|g| GratingWindow::new(&g.name, g.bragg_wavelength_nm, hw))
        .collect();
    let tracks = assign::assign(log, &windows);
    let t: Vec<f64> = log.time_s.iter().map(|x| x - log.time_s[0]).collect();
    let end = *t.last().unwrap_or(&0.0);
    for (cell, label) in (0..n_cells).map(|c| (c, cell_label(c))) {
        if !schedule.iter().any(|l| l.cell == cell) {
            bail!("the schedule never loads cell {label}; every cell needs at least one loading");
        }
    }
    if let Some(l) = schedule.iter().find(|l| l.end_s > end + 1e-9) {
        bail!(
            "a loading ends at {} s, after the log's last row at {end:.3} s",
            l.end_s
        );
    }
    let mut m = vec![vec![0.0; n_cells]; tracks.len()];
    for (gi, tr) in tracks.iter().enumerate() {
        if tr.rows_present < log.rows() / 10 {
            bail!(
                "{}: grating `{}` ({} ± {hw:.3} nm) has a peak in only {} of {} rows",
                log.source.display(),
                tr.window.name,
                tr.window.nominal_nm,
                tr.rows_present,
                log.rows()
            );
        }
        let s: Vec<f64> = tr
            .wavelength_nm
            .iter()
            .map(|l| (l - tr.window.nominal_nm) * 1e3)
            .collect();
        let mut num_ = vec![0.0; n_cells];
        let mut den = vec![0.0; n_cells];
        for (k, l) in schedule.iter().enumerate() {
            let prev_end = if k == 0 { 0.0 } else { schedule[k - 1].end_s };
            let next_start = schedule.get(k + 1).map_or(end, |n| n.start_s);
            let loaded = mean_in(&t, &s, l.start_s + 0.25 * (l.end_s - l.start_s), l.end_s)
                .with_context(|| {
                    format!(
                        "grating `{}` has no peak while cell {} is loaded ({}–{} s)",
                        tr.window.name,
                        cell_label(l.cell),
                        l.start_s,
                        l.end_s
                    )
                })?;
            let before = mean_in(&t, &s, prev_end + 0.25 * (l.start_s - prev_end), l.start_s);
            let after = mean_in(&t, &s, l.end_s + 0.25 * (next_start - l.end_s), next_start);
            let base = match (before, after) {
                (Some(x), Some(y)) => (x + y) / 2.0,
                (Some(x), None) | (None, Some(x)) => x,
                (None, None) => bail!(
                    "no unloaded samples around the loading of cell {} at {} s",
                    cell_label(l.cell),
                    l.start_s
                ),
            };
            num_[l.cell] += (loaded - base) * l.load_g;
            den[l.cell] += l.load_g * l.load_g;
        }
        for c in 0..n_cells {
            m[gi][c] = num_[c] / den[c];
        }
    }
    Ok(SensingMatrix {
        gratings: a.gratings.iter().map(|g| g.name.clone()).collect(),
        cells: (0..n_cells).map(cell_label).collect(),
        sensitivity_pm_per_g: DMatrix::from_fn(m.len(), n_cells, |g, c| m[g][c]),
    })
}

/// The bare power law s(d) = c·d^(−n) fitted to the paper's Table 1
/// ([`kernel::fit_power_law`]; reference §2: c ≈ 44.7 pm·mm²/g, n ≈ 2.05), with d the
/// distance in mm from the load to the grating. The fit covers 14.6–39.5 mm; nearer
/// loads are clamped to d = 10 mm, where the kernel gives ≈ 0.4 pm/g, close to the
/// 0.371 pm/g of a single encapsulated grating loaded directly (Table 2). Used for
/// synthetic calibration logs.
pub fn power_law_matrix(design: &Design) -> Result<SensingMatrix> {
    let Some(a) = &design.array else {
        bail!("design `{}` has no [array]", design.name)
    };
    let layout = ArrayLayout::from_array(a);
    let law = kernel::fit_power_law(&kernel::TABLE1)?.kernel;
    let sensitivity_pm_per_g = DMatrix::from_fn(
        layout.grating_positions_mm.len(),
        layout.cell_centers_mm.len(),
        |g, c| {
            let ((gx, gy), (cx, cy)) = (layout.grating_positions_mm[g], layout.cell_centers_mm[c]);
            law.sensitivity_pm_per_g((gx - cx).hypot(gy - cy).max(10.0))
        },
    );
    Ok(SensingMatrix {
        gratings: a.gratings.iter().map(|g| g.name.clone()).collect(),
        cells: (0..layout.cell_centers_mm.len()).map(cell_label).collect(),
        sensitivity_pm_per_g,
    })
}

/// A sensing matrix measured from a calibration run, with what reading its log found.
#[derive(Debug, Clone, Serialize)]
pub struct ArrayCalibration {
    /// The measured matrix, pm/g.
    pub matrix: SensingMatrix,
    /// Counted, non-fatal problems of the wavelength log.
    pub warnings: LogWarnings,
}

/// Measure the sensing matrix of `design`'s array from a wavelength log of a run
/// that loaded the cells as `schedule` says; `window_nm` is the half-width of each
/// grating's wavelength window (the verifier's rule when `None`).
pub fn calibrate_array(
    design: &Design,
    log: &Path,
    schedule: &Path,
    read: &ReadOptions,
    window_nm: Option<f64>,
) -> Result<ArrayCalibration> {
    let n_cells = design
        .array
        .as_ref()
        .map(|x| (x.cells_x * x.cells_y) as usize)
        .with_context(|| format!("design `{}` has no [array] to calibrate", design.name))?;
    let sched = read_schedule(schedule, n_cells)?;
    let log = logs::read_peak_log(log, read)?;
    let matrix = calibrate(design, &log, &sched, window_nm)?;
    Ok(ArrayCalibration {
        matrix,
        warnings: log.warnings,
    })
}

/// What to calibrate and how: the run's log and schedule, and what to write.
#[derive(Debug, Clone, Default)]
pub struct CalibrateRequest {
    /// Where the design was read from, for messages (its name when `None`).
    pub design_file: Option<PathBuf>,
    /// Wavelength log of the calibration run.
    pub log: PathBuf,
    /// Schedule CSV: `start_s,end_s,cell,load_g`, times in s from the log's first row.
    pub schedule: PathBuf,
    /// Format and date order of the log (detected when `None`).
    pub read: ReadOptions,
    /// Half-width of each grating's wavelength window, nm (the verifier's rule when
    /// `None`).
    pub window_half_width_nm: Option<f64>,
    /// Write the measured matrix here (a CSV naming the log and the schedule in a
    /// comment); nothing is written when `None`.
    pub out: Option<PathBuf>,
    /// Also fit the sheet model's modulus to the measured matrix, the misfit of every
    /// entry written beside `out` (`<out>.modulus-fit.json`).
    pub fit_modulus: bool,
}

/// Where a calibration's results go; every method has a no-op default.
pub trait CalibrationSink {
    /// The measured matrix with the log's warnings, and the file it was written to.
    fn measured(&mut self, _calibration: &ArrayCalibration, _out: Option<&Path>) -> Result<()> {
        Ok(())
    }
    /// The sheet model's modulus fitted to the matrix, and the file it was written to.
    fn modulus_fitted(&mut self, _fit: &ModulusFit, _path: &Path) -> Result<()> {
        Ok(())
    }
}

/// No sink: the outcome is only returned.
impl CalibrationSink for () {}

/// A calibration's results.
#[derive(Debug, Clone, Serialize)]
pub struct CalibrationOutcome {
    /// The measured matrix and the log's warnings.
    pub calibration: ArrayCalibration,
    /// The fitted modulus (with `fit_modulus`).
    pub modulus_fit: Option<ModulusFit>,
}

/// Measure `design`'s sensing matrix as `req` says, write it (and the modulus fit),
/// and hand each result to `sink`.
pub fn run(
    design: &Design,
    req: &CalibrateRequest,
    sink: &mut dyn CalibrationSink,
) -> Result<CalibrationOutcome> {
    if req.fit_modulus && req.out.is_none() {
        bail!("CalibrateRequest.fit_modulus writes its fit beside CalibrateRequest.out: give both");
    }
    let cal = calibrate_array(
        design,
        &req.log,
        &req.schedule,
        &req.read,
        req.window_half_width_nm,
    )?;
    if let Some(out) = &req.out {
        crate::io::write_matrix_with_comments(
            out,
            &cal.matrix,
            &[format!(
                "measured sensing matrix, pm/g, from {} and {}",
                req.log.display(),
                req.schedule.display()
            )],
        )?;
    }
    sink.measured(&cal, req.out.as_deref())?;
    let mut modulus_fit = None;
    if let (true, Some(out)) = (req.fit_modulus, &req.out) {
        let f = fit_modulus(design, &cal.matrix).with_context(|| {
            let of = req.design_file.as_ref().map_or_else(
                || format!("design `{}`", design.name),
                |p| p.display().to_string(),
            );
            format!("{of}: fitting the sheet model's modulus")
        })?;
        let path = out.with_extension("modulus-fit.json");
        crate::output::write_json(&path, &f)?;
        sink.modulus_fitted(&f, &path)?;
        modulus_fit = Some(f);
    }
    Ok(CalibrationOutcome {
        calibration: cal,
        modulus_fit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quoted_schedule_reads_as_a_plain_one() {
        let p = Path::new("sched.csv");
        let plain = parse_schedule("start_s,end_s,cell,load_g\n0,10,A,200\n", p, 8).unwrap();
        let quoted = parse_schedule(
            "\"start_s\",\"end_s\",\"cell\",\"load_g\"\r\n\"0\",\"10\",\"A\",\"200\"\r\n",
            p,
            8,
        )
        .unwrap();
        assert_eq!(quoted, plain);
        // Errors keep the file, the line and the field, quoted or not.
        let e = parse_schedule(
            "# loads\n\"start_s\",\"end_s\",\"cell\",\"load_g\"\n\"0\",\"1,5\",\"A\",\"200\"\n",
            p,
            8,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("sched.csv:3") && e.contains("end_s `1,5` is not a number"),
            "{e}"
        );
        let e = parse_schedule("\"start_s\",\"end\"\n", p, 8)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("sched.csv:1") && e.contains("start_s,end_s,cell,load_g"),
            "{e}"
        );
    }
}
