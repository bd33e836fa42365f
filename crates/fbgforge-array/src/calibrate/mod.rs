//! The array's own calibration: the measured sensing matrix A (pm/g) of a cast sheet,
//! the paper's metrological table (Table 2) of every staircase, additivity, the faults
//! that make a matrix unusable, and the measured matrix against the design's
//! prediction (docs/array.md §13 is the protocol a lab follows).
//!
//! Input besides the wavelength log: a schedule CSV, one line per load resting on a
//! cell ([`schedule`]):
//!
//! ```text
//! # times in s from the first row of the wavelength log
//! start_s,end_s,cell,load_g
//! 10,30,A,200
//! 40,60,B,200
//! ```
//!
//! The steps are found in the data ([`steps`]: every grating together) and matched to
//! the schedule's order ([`matching`]: its clock a hint); each state is read
//! ([`levels`]) against the interpolated unloaded baseline; single-cell states give
//! the matrix and its per-entry scatter ([`matrix`]); staircases give Table 2
//! ([`metrology`]); simultaneous loads give additivity ([`additivity`]); the faults
//! come from the schedule against the data, the baselines ([`drift`]) and the matrix
//! against the prediction ([`faults`]); [`compare`] judges every grating.
//!
//! The use case `fbgforge calibrate-array` and the Python binding call is [`run`]:
//! the files read, [`analysis::analyse`] on them, the matrix written only when no
//! fault makes it unusable, optionally the sheet's unknowns fitted to it, each result
//! handed to a [`CalibrationSink`] (the printers are `fbgforge_report::calibrate`'s).

pub mod additivity;
pub mod analysis;
pub mod compare;
pub mod drift;
pub mod faults;
pub mod levels;
pub mod matching;
pub mod matrix;
pub mod metrology;
pub mod schedule;
pub mod steps;

pub use analysis::{analyse, AnalysisInputs, RunData};
pub use schedule::{parse_schedule, read_schedule, Loading};

use crate::logs::assign::{self, GratingWindow};
use crate::logs::{self, LogWarnings, ReadOptions};
use crate::profile::{cell_label, ArrayLayout};
use crate::sheet::fit::{fit_sheet, FitEntry, SheetFit};
use crate::spec::Design;
use crate::{kernel, SensingMatrix};
use additivity::AdditivityTest;
use anyhow::{bail, Context, Result};
use compare::Comparison;
use metrology::Metrology;
use nalgebra::DMatrix;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The interrogator resolution assumed when none is given, pm (the paper's I-MON
/// 512E: "smaller than 0.5 pm"; Table 2's 1.35 g = 0.5 pm / 0.371 pm/g).
pub const DEFAULT_RESOLUTION_PM: f64 = 0.5;

/// What kind of fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// Two columns point the same way.
    CollinearCells,
    /// The schedule does not describe the data (or its clock is off).
    ScheduleMisaligned,
    /// A baseline moved beyond the resolution.
    Drift,
    /// Two gratings lie in each other's places.
    SwappedGratings,
    /// An entry below zero beyond noise and the model's band.
    NegativeEntry,
    /// A cell the schedule lists was not loaded.
    UnloadedCell,
}

impl FaultKind {
    /// The kind as the JSON writes it.
    pub fn name(self) -> &'static str {
        match self {
            FaultKind::CollinearCells => "collinear_cells",
            FaultKind::ScheduleMisaligned => "schedule_misaligned",
            FaultKind::Drift => "drift",
            FaultKind::SwappedGratings => "swapped_gratings",
            FaultKind::NegativeEntry => "negative_entry",
            FaultKind::UnloadedCell => "unloaded_cell",
        }
    }
}

/// What a fault means for the matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Severity {
    /// The matrix must not be used: it is not written where asked, the command exits 3.
    Unusable,
    /// Found and worked around (a schedule clock the data's steps replaced).
    Warning,
}

/// A fault found at calibration time.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Fault {
    /// What kind.
    pub kind: FaultKind,
    /// What it means for the matrix.
    pub severity: Severity,
    /// The gratings it concerns.
    pub gratings: Vec<String>,
    /// The cells it concerns.
    pub cells: Vec<String>,
    /// What was seen and what it likely means, in words.
    pub reason: String,
    /// The numbers behind it.
    pub evidence: BTreeMap<String, f64>,
}

/// One state of the schedule where the data put it.
#[derive(Debug, Clone, Serialize)]
pub struct StateSpan {
    /// Start by the schedule's clock, s.
    pub schedule_start_s: f64,
    /// First sample in the data, s.
    pub data_start_s: f64,
    /// Last sample in the data, s.
    pub data_end_s: f64,
    /// Settled samples read.
    pub samples_used: usize,
    /// The loads, g, by cell.
    pub loads_g: BTreeMap<String, f64>,
}

/// How the steps were found and matched.
#[derive(Debug, Clone, Serialize)]
pub struct StepSummary {
    /// Load changes the schedule lists.
    pub scheduled_changes: usize,
    /// Load changes found in the data.
    pub detected_changes: usize,
    /// Scheduled changes paired with one in the data.
    pub matched_changes: usize,
    /// Median of data time − schedule time over the pairs, s.
    pub clock_offset_s: f64,
    /// Largest departure of a pair from that median, s.
    pub clock_spread_s: f64,
    /// Samples on each side of the change test.
    pub test_window_samples: usize,
    /// Each grating's noise, pm.
    pub noise_pm: Vec<f64>,
    /// Bumps (changes undone at once) left out, s.
    pub transients_s: Vec<f64>,
    /// Every state.
    pub states: Vec<StateSpan>,
}

/// A calibration run analysed.
#[derive(Debug, Clone, Serialize)]
pub struct Calibration {
    /// Grating names (rows).
    pub gratings: Vec<String>,
    /// Cell labels (columns).
    pub cells: Vec<String>,
    /// The measured matrix, pm/g, one row per grating (null: cell never loaded alone).
    pub matrix_pm_per_g: Vec<Vec<Option<f64>>>,
    /// Standard deviation of each entry, pm/g.
    pub matrix_sd_pm_per_g: Vec<Vec<Option<f64>>>,
    /// No fault makes the matrix unusable.
    pub usable: bool,
    /// Every cell was loaded alone at least once.
    pub complete: bool,
    /// Single-cell readings of each cell.
    pub readings_per_cell: Vec<usize>,
    /// Faults, unusable ones and warnings.
    pub faults: Vec<Fault>,
    /// Table 2 for every grating on every staircase-loaded cell.
    pub metrology: Vec<Metrology>,
    /// Additivity tests.
    pub additivity: Vec<AdditivityTest>,
    /// The measured matrix against the prediction.
    pub comparison: Comparison,
    /// How the steps were found.
    pub steps: StepSummary,
    /// The interrogator resolution used, pm.
    pub resolution_pm: f64,
}

impl Calibration {
    /// The measured matrix (NaN where a cell was never loaded alone).
    pub fn matrix(&self) -> SensingMatrix {
        self.named(&self.matrix_pm_per_g)
    }

    /// The per-entry standard deviations, shaped as the matrix.
    pub fn matrix_sd(&self) -> SensingMatrix {
        self.named(&self.matrix_sd_pm_per_g)
    }

    /// The entries the comparison judged, for the sheet fit.
    pub fn fit_entries(&self) -> Vec<FitEntry> {
        let n = self.cells.len();
        self.comparison
            .entries
            .iter()
            .enumerate()
            .filter(|(_, e)| e.judged)
            .filter_map(|(k, e)| {
                Some(FitEntry {
                    grating: k / n,
                    cell: k % n,
                    measured_pm_per_g: e.measured_pm_per_g?,
                    sd_pm_per_g: e.measured_sd_pm_per_g?,
                })
            })
            .collect()
    }

    fn named(&self, rows: &[Vec<Option<f64>>]) -> SensingMatrix {
        SensingMatrix {
            gratings: self.gratings.clone(),
            cells: self.cells.clone(),
            sensitivity_pm_per_g: DMatrix::from_fn(
                self.gratings.len(),
                self.cells.len(),
                |g, c| rows[g][c].unwrap_or(f64::NAN),
            ),
        }
    }
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
    /// The interrogator's resolution, pm ([`DEFAULT_RESOLUTION_PM`] when `None`).
    pub resolution_pm: Option<f64>,
    /// The model's relative band for the comparison
    /// ([`compare::DEFAULT_MODEL_TOLERANCE`] when `None`).
    pub model_tolerance: Option<f64>,
    /// Write the measured matrix here when it is usable and complete (a CSV naming the
    /// log and the schedule in a comment), its scatter beside it (`<out>.sd.csv`, the
    /// form `reconstruct --matrix-sd` reads) and the whole calibration as JSON
    /// (`<out>.calibration.json`); with an unusable fault the matrix goes to
    /// `<out>.faulty.csv` instead and nothing is written at `out`.
    pub out: Option<PathBuf>,
    /// Also fit the sheet's unknowns (modulus, thickness, table interface) to the
    /// measured matrix (`<out>.sheet-fit.json` beside it).
    pub fit_sheet: bool,
}

impl CalibrateRequest {
    /// Check the numbers before anything is read.
    pub fn validate(&self) -> Result<()> {
        if let Some(r) = self.resolution_pm {
            if !(r.is_finite() && r > 0.0 && r <= 100.0) {
                bail!("CalibrateRequest.resolution_pm must be in (0, 100] pm, got {r}");
            }
        }
        if let Some(t) = self.model_tolerance {
            if !(t.is_finite() && t > 0.0 && t <= 5.0) {
                bail!("CalibrateRequest.model_tolerance must be a fraction in (0, 5] (0.4 = ±40 %), got {t}");
            }
        }
        if let Some(w) = self.window_half_width_nm {
            if !(w.is_finite() && w > 0.0) {
                bail!("CalibrateRequest.window_half_width_nm must be positive, got {w}");
            }
        }
        Ok(())
    }
}

/// The files a calibration wrote.
#[derive(Debug, Clone, Default, Serialize)]
pub struct CalibrationFiles {
    /// The matrix (usable and complete only).
    pub matrix: Option<PathBuf>,
    /// Its per-entry standard deviations.
    pub matrix_sd: Option<PathBuf>,
    /// The matrix of a run with unusable faults.
    pub faulty_matrix: Option<PathBuf>,
    /// The whole calibration as JSON.
    pub json: Option<PathBuf>,
    /// Where the matrix would have gone (`out`).
    pub requested: Option<PathBuf>,
}

/// Where a calibration's results go; every method has a no-op default.
pub trait CalibrationSink {
    /// The run analysed, the log's warnings, and the files written.
    fn calibrated(
        &mut self,
        _calibration: &Calibration,
        _warnings: &LogWarnings,
        _files: &CalibrationFiles,
    ) -> Result<()> {
        Ok(())
    }
    /// The sheet's unknowns fitted to the matrix, and the file it was written to.
    fn sheet_fitted(&mut self, _fit: &SheetFit, _path: Option<&Path>) -> Result<()> {
        Ok(())
    }
}

/// No sink: the outcome is only returned.
impl CalibrationSink for () {}

impl<A: CalibrationSink, B: CalibrationSink> CalibrationSink for (A, B) {
    fn calibrated(&mut self, c: &Calibration, w: &LogWarnings, f: &CalibrationFiles) -> Result<()> {
        self.0.calibrated(c, w, f)?;
        self.1.calibrated(c, w, f)
    }
    fn sheet_fitted(&mut self, fit: &SheetFit, path: Option<&Path>) -> Result<()> {
        self.0.sheet_fitted(fit, path)?;
        self.1.sheet_fitted(fit, path)
    }
}

/// A calibration's results: the JSON `calibrate-array --json` prints.
#[derive(Debug, Clone, Serialize)]
pub struct CalibrationOutcome {
    /// The design's name.
    pub design: String,
    /// The analysed run.
    #[serde(flatten)]
    pub calibration: Calibration,
    /// Counted, non-fatal problems of the wavelength log.
    pub warnings: LogWarnings,
    /// The files written.
    pub files: CalibrationFiles,
    /// The sheet's unknowns (with `fit_sheet`).
    pub sheet_fit: Option<SheetFit>,
}

/// The log's shifts per grating, pm from each grating's nominal wavelength.
fn read_run(design: &Design, req: &CalibrateRequest) -> Result<(RunData, LogWarnings)> {
    let a = design.array.as_ref().expect("checked");
    let log = logs::read_peak_log(&req.log, &req.read)?;
    let nominals: Vec<f64> = a.gratings.iter().map(|g| g.bragg_wavelength_nm).collect();
    let hw = req
        .window_half_width_nm
        .unwrap_or_else(|| assign::default_half_width_nm(&nominals));
    let windows: Vec<GratingWindow> = a
        .gratings
        .iter()
        .map(|g| GratingWindow::new(&g.name, g.bragg_wavelength_nm, hw))
        .collect();
    let tracks = assign::assign(&log, &windows);
    for tr in &tracks {
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
    }
    let t0 = log.time_s.first().copied().unwrap_or(0.0);
    let data = RunData {
        time_s: log.time_s.iter().map(|t| t - t0).collect(),
        shifts_pm: tracks.iter().map(|tr| tr.offsets_pm()).collect(),
    };
    Ok((data, log.warnings))
}

/// Write the matrix (or the faulty one), its scatter and the JSON as `req` says.
fn write_files(
    req: &CalibrateRequest,
    cal: &Calibration,
    outcome_json: impl FnOnce(&CalibrationFiles) -> Result<()>,
) -> Result<CalibrationFiles> {
    let Some(out) = &req.out else {
        return Ok(CalibrationFiles::default());
    };
    let mut files = CalibrationFiles {
        requested: Some(out.clone()),
        json: Some(out.with_extension("calibration.json")),
        ..Default::default()
    };
    let from = format!("from {} and {}", req.log.display(), req.schedule.display());
    if cal.usable && cal.complete {
        crate::io::write_matrix_with_comments(
            out,
            &cal.matrix(),
            &[format!("measured sensing matrix, pm/g, {from}")],
        )?;
        let sd = out.with_extension("sd.csv");
        crate::io::write_matrix_with_comments(
            &sd,
            &cal.matrix_sd(),
            &[format!(
                "standard deviation of each entry of {}, pm/g, {from}",
                out.display()
            )],
        )?;
        files.matrix = Some(out.clone());
        files.matrix_sd = Some(sd);
    } else if !cal.usable {
        let faulty = out.with_extension("faulty.csv");
        let mut comments = vec![format!("FAULTY calibration, do not use: {from}")];
        comments.extend(
            cal.faults
                .iter()
                .map(|f| format!("fault {}: {}", f.kind.name(), f.reason)),
        );
        crate::io::write_matrix_with_comments(&faulty, &cal.matrix(), &comments)?;
        files.faulty_matrix = Some(faulty);
    }
    outcome_json(&files)?;
    Ok(files)
}

/// Analyse `design`'s calibration run as `req` says, write what it asks, and hand
/// each result to `sink`.
pub fn run(
    design: &Design,
    req: &CalibrateRequest,
    sink: &mut dyn CalibrationSink,
) -> Result<CalibrationOutcome> {
    req.validate()?;
    let a = design
        .array
        .as_ref()
        .with_context(|| format!("design `{}` has no [array] to calibrate", design.name))?;
    let n_cells = (a.cells_x * a.cells_y) as usize;
    let schedule = read_schedule(&req.schedule, n_cells)?;
    let (data, warnings) = read_run(design, req)?;
    let predicted = kernel::model_matrix(design, None)?;
    let gratings: Vec<String> = a.gratings.iter().map(|g| g.name.clone()).collect();
    let cells: Vec<String> = (0..n_cells).map(cell_label).collect();
    let calibration = analyse(&AnalysisInputs {
        gratings: &gratings,
        cells: &cells,
        data: &data,
        schedule: &schedule,
        predicted: &predicted.matrix.sensitivity_pm_per_g,
        model: &predicted.description,
        resolution_pm: req.resolution_pm.unwrap_or(DEFAULT_RESOLUTION_PM),
        tolerance: req
            .model_tolerance
            .unwrap_or(compare::DEFAULT_MODEL_TOLERANCE),
    })?;
    let sheet_fit = if req.fit_sheet {
        Some(
            fit_sheet(design, &calibration.fit_entries()).with_context(|| {
                let of = req.design_file.as_ref().map_or_else(
                    || format!("design `{}`", design.name),
                    |p| p.display().to_string(),
                );
                format!("{of}: fitting the sheet's unknowns")
            })?,
        )
    } else {
        None
    };
    let mut outcome = CalibrationOutcome {
        design: design.name.clone(),
        calibration,
        warnings,
        files: CalibrationFiles::default(),
        sheet_fit,
    };
    let files = write_files(req, &outcome.calibration, |files| {
        if let Some(path) = &files.json {
            let mut o = outcome.clone();
            o.files = files.clone();
            crate::output::write_json(path, &o)?;
        }
        Ok(())
    })?;
    outcome.files = files;
    sink.calibrated(&outcome.calibration, &outcome.warnings, &outcome.files)?;
    if let Some(fit) = &outcome.sheet_fit {
        let path = req.out.as_ref().map(|o| o.with_extension("sheet-fit.json"));
        if let Some(p) = &path {
            crate::output::write_json(p, fit)?;
        }
        sink.sheet_fitted(fit, path.as_deref())?;
    }
    Ok(outcome)
}
